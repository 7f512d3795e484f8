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
    /// An input that needs at least one element has none. Give it one.
    #[error("{what} needs at least one {item}")]
    Empty {
        /// The input, e.g. ``"mesh `shirt`"``.
        what: String,
        /// What it needs one of, e.g. `"frame"`.
        item: &'static str,
    },
    /// A name is not one of its kind's options. Use one of those listed.
    #[error("unknown {kind} `{name}`; use {options}")]
    UnknownName {
        /// The kind of name, e.g. `"resolution"`.
        kind: &'static str,
        /// The name that was given.
        name: String,
        /// The names accepted, e.g. `"coarse, default or paper"`.
        options: &'static str,
    },
    /// The skeleton is not in the T-pose the T-shirt pattern is cut for. Give the skeleton's
    /// rest (T-pose) joints, in metres, with the left arm along +x.
    #[error(
        "the T-shirt needs a T-pose skeleton with the left arm along +x and shoulders 0.1-1 m \
         apart; got shoulders {shoulder_span:.3} m apart"
    )]
    NotATPose {
        /// The distance between the shoulder joints (metres).
        shoulder_span: f64,
    },
    /// The skeleton's proportions leave no room for the T-shirt's neck and sleeves. Use a
    /// skeleton of adult human proportions, in metres.
    #[error(
        "the skeleton's proportions leave no room for the T-shirt's neck and sleeves; use a \
         skeleton of adult human proportions, in metres"
    )]
    NoRoomForGarment,
    /// A garment vertex lies inside or too near the body: the body is larger than its
    /// skeleton suggests. Use capsules that fit the skeleton, or a larger skeleton.
    #[error(
        "T-shirt vertex {vertex} at ({:.3}, {:.3}, {:.3}) m is {distance_mm:.1} mm from the \
         body (at least {needed_mm:.0} mm needed): the body is larger than its skeleton \
         suggests",
        position[0], position[1], position[2]
    )]
    GarmentInsideBody {
        /// The template vertex.
        vertex: usize,
        /// Where it lies (metres).
        position: [f64; 3],
        /// Its distance from the body surface (mm; negative inside).
        distance_mm: f64,
        /// The clearance a vertex needs (mm).
        needed_mm: f64,
    },
    /// Fitting the garment to the body would move a vertex further than allowed: the body
    /// is larger than its skeleton suggests. Use capsules that fit the skeleton.
    #[error(
        "T-shirt vertex {vertex} at ({:.3}, {:.3}, {:.3}) m is {distance_mm:.1} mm from the \
         body and would move {push_mm:.0} mm to clear it (at most {max_push_mm:.0} mm \
         allowed): the body is larger than its skeleton suggests",
        position[0], position[1], position[2]
    )]
    GarmentTooTight {
        /// The template vertex.
        vertex: usize,
        /// Where it lies (metres).
        position: [f64; 3],
        /// Its distance from the body surface (mm; negative inside).
        distance_mm: f64,
        /// How far it would move to clear the body (mm).
        push_mm: f64,
        /// The farthest a vertex may move ([`crate::MAX_FIT_PUSH`], mm).
        max_push_mm: f64,
    },
    /// A limb root joint is listed twice. List each joint once.
    #[error("limb root joint {joint} is listed twice; list each joint once")]
    DuplicateLimbRoot {
        /// The repeated joint index.
        joint: usize,
    },
    /// The body is too large to mesh: its capsules are probably not in metres. Give the
    /// capsules in metres.
    #[error(
        "the body spans {extent:?} metres, too large to mesh at {spacing} m; check that the \
         capsules are in metres"
    )]
    BodyTooLarge {
        /// The body's bounding-box size (metres).
        extent: [f64; 3],
        /// The mesh spacing (metres).
        spacing: f64,
    },
    /// A meshing box is empty or not finite. Give finite corners with min < max on every
    /// axis.
    #[error(
        "surface-nets box min {min:?} .. max {max:?} must be finite with min < max on every axis"
    )]
    InvalidBox {
        /// The lower corner.
        min: [f64; 3],
        /// The upper corner.
        max: [f64; 3],
    },
    /// A render's size or supersampling is out of range. Use a positive width and height and
    /// a supersampling of 1 to 8.
    #[error(
        "render size {width}x{height} with supersampling {supersample}: width and height must \
         be > 0 and supersampling 1..=8"
    )]
    RenderSize {
        /// Image width (pixels).
        width: u32,
        /// Image height (pixels).
        height: u32,
        /// Samples per pixel along each axis.
        supersample: u32,
    },
    /// An animation's frame rate is not a positive number. Give frames a second, e.g. 30.
    #[error("the frame rate must be a positive number of frames a second, got {fps}")]
    InvalidFrameRate {
        /// The frame rate given.
        fps: f64,
    },
    /// At this frame rate, glTF's 32-bit key times cannot keep every frame finite and apart.
    /// Use a frame rate such as 24, 30 or 60.
    #[error(
        "at {fps} frames a second, the key times of {frames} frames do not stay finite and \
         apart in glTF's 32-bit floats: use a frame rate such as 24, 30 or 60"
    )]
    KeyTimes {
        /// The frame rate given.
        fps: f64,
        /// The number of frames.
        frames: usize,
    },
    /// A glTF binary would be past what the format can index or hold (4 GiB). Write fewer
    /// frames or vertices per file.
    #[error(
        "{what} is past what one glTF binary can hold: write fewer frames or vertices per file"
    )]
    GlbTooLarge {
        /// What is too large, e.g. `"an animation of 70000 frames"`.
        what: String,
    },
    /// The glTF document could not be serialised. This is a bug in garmatnet: please report
    /// it with the command that failed.
    #[error("could not serialise the glTF document: {source}")]
    GlbJson {
        /// serde_json's reason.
        #[source]
        source: serde_json::Error,
    },
    /// A vertex's skinning weights are not 1 to 4 (joint, weight) pairs with joints in the
    /// skeleton, weights ≥ 0 and a sum of one. Normalise the weights.
    #[error(
        "the skinning weights of vertex {vertex} of mesh `{mesh}` must be 1 to 4 (joint < 24, \
         weight ≥ 0) pairs summing to one, got {weights:?}"
    )]
    InvalidSkinWeights {
        /// The mesh's name.
        mesh: String,
        /// The vertex.
        vertex: usize,
        /// Its (joint, weight) pairs as given.
        weights: Vec<(usize, f64)>,
    },
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
