//! The `garmatnet` command line: one file per subcommand.

/// `println!` for the commands' results, which reports a closed standard output as
/// [`StdoutClosed`] instead of panicking (`garmatnet materials | head -3`); `main` then
/// ends quietly. Other write errors are returned as they are. Defined before the `mod`
/// lines below, so every subcommand's module can use it.
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::cli::write_stdout(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `eprintln!` for warnings and notes that must not end the command: written to standard
/// error, and dropped if it is closed (where `eprintln!` panics).
macro_rules! warnln {
    ($($arg:tt)*) => {
        $crate::cli::write_stderr(format_args!("{}\n", format_args!($($arg)*)))
    };
}

pub mod bench;
pub mod body;
pub mod calibrate;
pub mod dataset;
pub mod drape;
pub mod ensemble;
pub mod eval;
pub mod materials;
pub mod poses;
pub mod simulate;
pub mod stress;
pub mod template;
pub mod train;

/// The reader of standard output went away (a pipe closed early, as `head` does): not a
/// failure of the command, so `main` exits successfully and prints nothing more.
#[derive(Debug)]
pub struct StdoutClosed;

impl std::fmt::Display for StdoutClosed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("standard output was closed")
    }
}

impl std::error::Error for StdoutClosed {}

/// Writes `text` to standard output; [`outln!`]'s body.
///
/// # Errors
/// [`StdoutClosed`] when the reader has gone, any other write error as it is.
pub fn write_stdout(text: std::fmt::Arguments<'_>) -> anyhow::Result<()> {
    use std::io::Write as _;
    match std::io::stdout().lock().write_fmt(text) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Err(StdoutClosed.into()),
        Err(e) => Err(anyhow::Error::new(e).context("writing to standard output")),
    }
}

/// Writes `text` to standard error, ignoring a failed write (a closed stderr); [`warnln!`]'s
/// body.
pub fn write_stderr(text: std::fmt::Arguments<'_>) {
    use std::io::Write as _;
    let _ = std::io::stderr().lock().write_fmt(text);
}

/// Reads a settings file (`train --config`, `simulate --solver`): JSON for `T`, whose
/// missing keys take their defaults. A key `T` does not know is refused with its path, so
/// a misspelt setting (`"max_iteratons"`) is not silently left at its default.
///
/// # Errors
/// The file cannot be read, is not valid JSON for `T`, or has keys `T` does not know.
pub fn read_settings_file<T: serde::de::DeserializeOwned>(
    path: &std::path::Path,
) -> anyhow::Result<T> {
    use anyhow::Context as _;
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut unknown = Vec::new();
    let value: T =
        serde_ignored::deserialize(&mut serde_json::Deserializer::from_str(&text), |key| {
            unknown.push(key.to_string())
        })
        .with_context(|| format!("parsing {}", path.display()))?;
    if !unknown.is_empty() {
        anyhow::bail!(
            "{}: unknown setting{} {}; check the spelling against the defaults \
             (book/src/cli.md)",
            path.display(),
            if unknown.len() == 1 { "" } else { "s" },
            unknown.join(", ")
        );
    }
    Ok(value)
}

/// Writes `view` to each of `outs` and says what was written: one animation file, with
/// `what` (e.g. the fabric and frames) and its frame rate, or a run of numbered files.
///
/// # Errors
/// The first write that fails, naming its path.
pub fn write_sequence_outputs(
    view: &garmatnet::core::DrapeSequence<'_>,
    outs: &[std::path::PathBuf],
    what: &str,
) -> anyhow::Result<()> {
    use anyhow::Context as _;
    for out in outs {
        let written = view
            .write(out)
            .with_context(|| format!("writing {}", out.display()))?;
        match written.as_slice() {
            [one] if one == out => outln!(
                "wrote {} ({what} at {} frames a second)",
                out.display(),
                view.fps
            )?,
            _ => outln!(
                "wrote {} files ({what}), {} … {}",
                written.len(),
                written[0].display(),
                written[written.len() - 1].display()
            )?,
        }
    }
    Ok(())
}
