//! The `garmatnet` command line: one file per subcommand.

pub mod bench;
pub mod body;
pub mod dataset;
pub mod drape;
pub mod ensemble;
pub mod eval;
pub mod materials;
pub mod simulate;
pub mod stress;
pub mod template;
pub mod train;

/// Writes `view` to each of `outs` and says what was written: one animation file, with
/// `what` (e.g. the fabric and frames) and its frame rate, or a run of numbered files.
///
/// # Errors
/// The first write that fails, naming its path.
pub fn write_sequence_outputs(
    view: &garmatnet::train::DrapeSequence<'_>,
    outs: &[std::path::PathBuf],
    what: &str,
) -> anyhow::Result<()> {
    use anyhow::Context as _;
    for out in outs {
        let written = view
            .write(out)
            .with_context(|| format!("writing {}", out.display()))?;
        match written.as_slice() {
            [one] if one == out => println!(
                "wrote {} ({what} at {} frames a second)",
                out.display(),
                view.fps
            ),
            _ => println!(
                "wrote {} files ({what}), {} … {}",
                written.len(),
                written[0].display(),
                written[written.len() - 1].display()
            ),
        }
    }
    Ok(())
}
