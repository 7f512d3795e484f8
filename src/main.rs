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
    /// Predict a drape with a trained model (the shipped one by default) and write it as
    /// OBJ, glTF binary, PLY or PNG; `--compare` also runs the simulator.
    Drape(cli::drape::DrapeArgs),
    /// List the fabric presets and their material parameters; `--model` also names each
    /// one's nearest training fabric.
    Materials(cli::materials::MaterialsArgs),
    /// Write the poses `simulate --poses N` drapes as a JSON pose file (after another
    /// file's or dataset's poses with `--after`).
    Poses(cli::poses::PosesArgs),
    /// Generate a ground-truth dataset with the mass-spring solver (resumable, shardable).
    Simulate(cli::simulate::SimulateArgs),
    /// Dataset tools.
    #[command(subcommand)]
    Dataset(cli::dataset::DatasetCommand),
    /// Train a GarMatNet model (generally-fitting and locally-detailed nets).
    Train(cli::train::TrainArgs),
    /// Train the TailorNet-style baseline (one pose-only model per target material).
    TrainBaseline(cli::train::TrainBaselineArgs),
    /// Calibrate a fabric for a model with one simulated drape (JSON for `drape
    /// --calibration`).
    Calibrate(cli::calibrate::CalibrateArgs),
    /// Measure fabric calibration on a dataset: each fabric calibrated at one pose, its
    /// other poses predicted with and without it.
    EvalCalibration(cli::calibrate::EvalCalibrationArgs),
    /// Average models trained with different seeds into one (an ensemble in one model file).
    Ensemble(cli::ensemble::EnsembleArgs),
    /// Evaluate a model on its held-out split, or without --data on --held-out sets alone,
    /// and write the report.
    Eval(cli::eval::EvalArgs),
    /// Run time against error: the simulator at several budgets, GarMatNet variants and
    /// the baseline on the same held-out samples (bench.json, bench.md, pareto.png).
    Bench(cli::bench::BenchArgs),
    /// Numerical stress: many random valid (pose, material) pairs through a model; fails on
    /// NaN or a vertex a metre from the body.
    Stress(cli::stress::StressArgs),
    /// Reproduce Table 3: one model per weight controller α.
    SweepAlpha(cli::train::SweepAlphaArgs),
}

/// Runs the command; a closed standard output (`garmatnet materials | head -3`) ends it
/// quietly and successfully, as it does Unix tools, and any other error is printed as
/// `Error: …` with its causes and exits 1.
fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    match run(&cli.command) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) if e.is::<cli::StdoutClosed>() => std::process::ExitCode::SUCCESS,
        Err(e) => {
            // Not `eprintln!`, which panics when standard error is closed too.
            cli::write_stderr(format_args!("Error: {e:?}\n"));
            std::process::ExitCode::FAILURE
        }
    }
}

fn run(command: &Command) -> anyhow::Result<()> {
    match command {
        Command::Template(args) => cli::template::run(args),
        Command::Body(args) => cli::body::run(args),
        Command::Drape(args) => cli::drape::run(args),
        Command::Materials(args) => cli::materials::run(args),
        Command::Poses(args) => cli::poses::run(args),
        Command::Simulate(args) => cli::simulate::run(args),
        Command::Dataset(command) => cli::dataset::run(command),
        Command::Train(args) => cli::train::run_train(args),
        Command::TrainBaseline(args) => cli::train::run_train_baseline(args),
        Command::Calibrate(args) => cli::calibrate::run(args),
        Command::EvalCalibration(args) => cli::calibrate::run_eval(args),
        Command::Ensemble(args) => cli::ensemble::run(args),
        Command::Eval(args) => cli::eval::run(args),
        Command::SweepAlpha(args) => cli::train::run_sweep_alpha(args),
        Command::Bench(args) => cli::bench::run(args),
        Command::Stress(args) => cli::stress::run(args),
    }
}
