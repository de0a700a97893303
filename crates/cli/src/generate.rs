//! `arcsim generate-plan --kind KIND --seed N [-o FILE]`: a deterministic synthetic example plan.

use std::path::PathBuf;

use arcsim_plan::{generate, to_json, PlanKind};

use crate::CliError;

#[derive(clap::Args)]
pub struct Args {
    /// prostate, head-neck, two-arc or lung.
    #[arg(long)]
    kind: PlanKind,
    /// Seed of the generator; the same kind and seed always give the same file.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output file; standard output when omitted.
    #[arg(short, long)]
    output: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<(), CliError> {
    let json = to_json(&generate(args.kind, args.seed));
    match args.output {
        Some(path) => {
            crate::output::check_outputs(&[], &[("--output", &path)])?;
            crate::output::write_file(&path, json.as_bytes())
        }
        None => {
            crate::output::print(&json);
            Ok(())
        }
    }
}
