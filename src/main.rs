//! The `garmatnet` command-line tool: templates, bodies, ground-truth datasets, training,
//! evaluation and prediction from scripts.

mod cli;

use clap::{Parser, Subcommand};

/// garmatnet: learned garment draping for any fabric.
#[derive(Debug, Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Write the T-shirt template mesh (OBJ).
    Template(cli::template::TemplateArgs),
    /// Write the procedural body mesh (OBJ), optionally posed.
    Body(cli::body::BodyArgs),
    /// List the fabric presets and their material parameters.
    Materials,
    /// Generate a ground-truth dataset with the mass-spring solver (resumable, shardable).
    Simulate(cli::simulate::SimulateArgs),
    /// Dataset tools.
    #[command(subcommand)]
    Dataset(cli::dataset::DatasetCommand),
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match &cli.command {
        Command::Template(args) => cli::template::run(args),
        Command::Body(args) => cli::body::run(args),
        Command::Materials => cli::materials::run(),
        Command::Simulate(args) => cli::simulate::run(args),
        Command::Dataset(command) => cli::dataset::run(command),
    }
}
