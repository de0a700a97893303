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
    /// Output file (then one line says what was written); standard output when omitted.
    #[arg(short, long)]
    output: Option<PathBuf>,
}

/// Writes the plan to the output file and says what it wrote ("wrote prostate plan (seed 1):
/// 1 arc, 180 control points, 180 layers -> FILE"), or prints the JSON on standard output.
pub fn run(args: Args) -> Result<(), CliError> {
    let plan = generate(args.kind, args.seed);
    let json = to_json(&plan);
    match args.output {
        Some(path) => {
            crate::output::check_outputs(&[], &[("--output", Some(&path))])?;
            crate::output::write_file(&path, json.as_bytes())?;
            let control_points = plan.arcs.iter().map(|a| a.control_points.len()).sum();
            let layers = plan
                .arcs
                .iter()
                .flat_map(|a| &a.control_points)
                .map(|cp| cp.layers.len())
                .sum();
            crate::output::println(&format!(
                "wrote {} plan (seed {}): {}, {}, {} -> {}",
                args.kind.name(),
                args.seed,
                crate::count(plan.arcs.len(), "arc"),
                crate::count(control_points, "control point"),
                crate::count(layers, "layer"),
                path.display()
            ));
            Ok(())
        }
        None => {
            crate::output::print(&json);
            Ok(())
        }
    }
}
