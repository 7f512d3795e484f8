//! `garmatnet dataset check`: validate a dataset directory and print its statistics.

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Subcommand;

/// Dataset tools.
#[derive(Debug, Subcommand)]
pub enum DatasetCommand {
    /// Validate a dataset (every array's shape and finiteness) and print its statistics.
    Check {
        /// The dataset directory.
        dir: PathBuf,
    },
}

/// Runs the command.
pub fn run(command: &DatasetCommand) -> Result<()> {
    match command {
        DatasetCommand::Check { dir } => {
            let report = garmatnet::sim::check(dir)?;
            println!("{report}");
            if !report.is_ok() {
                bail!("{} has problems (listed above)", dir.display());
            }
            Ok(())
        }
    }
}
