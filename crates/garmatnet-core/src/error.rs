//! The crate-wide error type: every variant says what went wrong and what to fix.

use std::path::PathBuf;

/// Everything that can go wrong in `garmatnet-core`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read or written. Check that the path exists and is writable.
    #[error("cannot access `{path}`: {source}")]
    Io {
        /// The file or directory involved.
        path: PathBuf,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// A file's content is malformed. The message names the line or element to fix.
    #[error("malformed file `{path}`{}: {message}", line.map(|l| format!(" at line {l}")).unwrap_or_default())]
    Parse {
        /// The file that failed to parse.
        path: PathBuf,
        /// The 1-based line, when the format is line-oriented and the line is known.
        line: Option<usize>,
        /// What is wrong there.
        message: String,
    },
    /// An input has the wrong number of elements.
    #[error("{what} has {got} values, expected {expected}")]
    WrongLength {
        /// The input, e.g. `"pose vector"`.
        what: String,
        /// The accepted length(s), e.g. `"72"` or `"72 or 156"`.
        expected: String,
        /// The length that was given.
        got: usize,
    },
    /// An input contains NaN or infinity.
    #[error(
        "{what} contains a non-finite value (NaN or infinity) at index {index}; every value must be a finite number"
    )]
    NonFinite {
        /// The input, e.g. `"pose vector"`.
        what: String,
        /// The index of the first non-finite value.
        index: usize,
    },
    /// A value lies outside its documented range.
    #[error(
        "{what} = {} is outside the allowed range [{}, {}]{hint}",
        compact(*value),
        compact(*min),
        compact(*max)
    )]
    OutOfRange {
        /// The quantity, with its unit, e.g. `"shear stiffness (N/m)"`.
        what: String,
        /// The offending value.
        value: f64,
        /// The smallest allowed value.
        min: f64,
        /// The largest allowed value.
        max: f64,
        /// Extra advice (may be empty), starting with `"; "`.
        hint: String,
    },
    /// A material name is not in the preset library.
    #[error("unknown material `{name}`; closest presets: {}", suggestions.join(", "))]
    UnknownMaterial {
        /// The name that was asked for.
        name: String,
        /// The closest preset names, best first.
        suggestions: Vec<String>,
    },
    /// A mesh is unusable (bad face indices, degenerate, too small). The message says why.
    #[error("invalid mesh: {0}")]
    InvalidMesh(String),
    /// Two things that must agree do not (e.g. vertex counts of a garment and its template).
    #[error("{what}: expected {expected}, got {got}")]
    Mismatch {
        /// What disagrees.
        what: String,
        /// What was expected.
        expected: String,
        /// What was found.
        got: String,
    },
    /// A number was expected and something else was written. Write a decimal number there.
    #[error("{what} is `{text}`, not a number{hint}")]
    NotANumber {
        /// Where the number belongs, e.g. `"ω component 3"`.
        what: String,
        /// What was written instead.
        text: String,
        /// Extra advice (may be empty), starting with `"; "`.
        hint: String,
    },
    /// An output file's extension names no format garmatnet writes. End the file name in
    /// `.obj`, `.glb`, `.ply` or `.png`.
    #[error(
        "cannot tell the output format of `{}`: end the file name in .obj, .glb, .ply or .png",
        path.display()
    )]
    UnknownOutputFormat {
        /// The path whose extension is missing or unknown.
        path: PathBuf,
    },
    /// An argument is invalid in a way the other variants do not cover; the message says how.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
}

/// Shorthand for results in `garmatnet-core`.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// An [`Error::Io`] for `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}

/// Checks that every value of `values` is finite, naming `what` in the error.
///
/// # Errors
/// [`Error::NonFinite`] with the index of the first NaN or infinity.
pub fn ensure_finite(what: &str, values: impl IntoIterator<Item = f64>) -> Result<()> {
    match values.into_iter().position(|v| !v.is_finite()) {
        Some(index) => Err(Error::NonFinite {
            what: what.to_owned(),
            index,
        }),
        None => Ok(()),
    }
}

/// A number as a message shows it: plainly, or in scientific notation when it is tiny or
/// huge (`1e-300`, not three hundred digits).
fn compact(x: f64) -> String {
    if x != 0.0 && x.is_finite() && !(1e-4..1e9).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn out_of_range_values_read_compactly() {
        let err = Error::OutOfRange {
            what: "step (radians)".into(),
            value: 1e-300,
            min: 1e-4,
            max: 0.5,
            hint: String::new(),
        };
        assert_eq!(
            err.to_string(),
            "step (radians) = 1e-300 is outside the allowed range [0.0001, 0.5]"
        );
        assert_eq!(compact(250.0), "250");
        assert_eq!(compact(0.0), "0");
        assert_eq!(compact(2e12), "2e12");
    }
}
