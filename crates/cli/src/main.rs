//! `arcsim`: how long does this proton-arc plan take on this gantry, where is the time lost, and what
//! would other limits (J, A, V) buy? Each subcommand lives in a module of its own.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod error;
mod generate;
mod import;
mod input;
mod output;
mod profile;
mod simulate;
mod sweep;
mod validate;
mod viewer;

pub use error::CliError;

#[derive(Parser)]
#[command(
    name = "arcsim",
    version,
    about = "Simulate proton-arc delivery on a jerk-limited gantry"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Plan one minimum-time jerk-limited move (or a batch of moves from a CSV file).
    Profile(profile::Args),
    /// Simulate a plan's delivery: total time, where it goes, margins; JSON/CSV/Rerun outputs.
    Simulate(simulate::Args),
    /// Check a plan: print every problem at once (exit 1), or a short summary (exit 0).
    Validate(validate::Args),
    /// Write a deterministic synthetic example plan (prostate, head-neck, two-arc, lung).
    GeneratePlan(generate::Args),
    /// Convert a DICOM RT Ion Plan into an arcsim plan (JSON) and summarise it.
    Import(import::Args),
    /// Evaluate plans x machine variants x schedules from a sweep file, in parallel.
    Sweep(sweep::Args),
    /// Join the CSV outputs of `sweep --shard K/N` into the single-run table.
    SweepMerge(sweep::MergeArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Profile(args) => profile::run(args),
        Command::Simulate(args) => simulate::run(args),
        Command::Validate(args) => validate::run(args),
        Command::GeneratePlan(args) => generate::run(args),
        Command::Import(args) => import::run(args),
        Command::Sweep(args) => sweep::run(args),
        Command::SweepMerge(args) => sweep::merge(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {}", output::printable(&err.to_string()));
            ExitCode::from(err.exit_code())
        }
    }
}
