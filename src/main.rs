//! The `garmatnet` command-line tool.

fn main() -> anyhow::Result<()> {
    Ok(())
}
