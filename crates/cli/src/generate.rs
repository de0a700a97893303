//! `arcsim generate-plan --kind KIND --seed N [--spacing DEG] [--layers MIN-MAX]
//! [--energy LOW-HIGH] [--spot-spacing MIN-MAX] [-o FILE]`: a deterministic synthetic example plan.

use std::path::PathBuf;

use arcsim_plan::{generate_shaped, to_json, PlanKind, Shape};

use crate::CliError;

#[derive(clap::Args)]
pub struct Args {
    /// prostate, head-neck, two-arc or lung.
    #[arg(long)]
    kind: PlanKind,
    /// Seed of the generator; the same kind and seed always give the same file.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Degrees between control points (each arc keeps its start and span); the kind's own when
    /// omitted.
    #[arg(long, value_name = "DEG")]
    spacing: Option<f64>,
    /// Layers per control point, MIN-MAX (e.g. 2-4) or one number; the kind's own when omitted.
    #[arg(long, value_name = "MIN-MAX", value_parser = layer_range)]
    layers: Option<(u32, u32)>,
    /// Energy range in MeV, LOW-HIGH (e.g. 70-230); the kind's own when omitted.
    #[arg(long, value_name = "LOW-HIGH", value_parser = energy_range)]
    energy: Option<(f64, f64)>,
    /// Spot spacing in mm, MIN-MAX: each layer's grid spacing falls linearly with its energy,
    /// from MAX at the plan's lowest energy to MIN at its highest (smaller spots at higher
    /// energies); 5 mm for every layer when omitted.
    #[arg(long, value_name = "MIN-MAX", value_parser = spacing_range)]
    spot_spacing: Option<(f64, f64)>,
    /// Output file (then one line says what was written); standard output when omitted.
    #[arg(short, long)]
    output: Option<PathBuf>,
}

/// Writes the plan to the output file and says what it wrote ("wrote prostate plan (seed 1):
/// 1 arc, 180 control points, 180 layers -> FILE"), or prints the JSON on standard output.
pub fn run(args: Args) -> Result<(), CliError> {
    let shape = Shape {
        spacing_deg: args.spacing,
        layers_per_cp: args.layers,
        energy_mev: args.energy,
        spot_spacing_mm: args.spot_spacing,
    };
    let plan = generate_shaped(args.kind, args.seed, &shape)
        .map_err(|e| CliError::Usage(format!("generate-plan {e}")))?;
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

/// `MIN-MAX` or `N` as two integers.
fn layer_range(text: &str) -> Result<(u32, u32), String> {
    let parse = |t: &str| {
        t.trim()
            .parse::<u32>()
            .map_err(|_| format!("\"{text}\" is not MIN-MAX layers per control point (e.g. 2-4)"))
    };
    match text.split_once('-') {
        Some((lo, hi)) => Ok((parse(lo)?, parse(hi)?)),
        None => parse(text).map(|n| (n, n)),
    }
}

/// `LOW-HIGH` as two energies (MeV).
fn energy_range(text: &str) -> Result<(f64, f64), String> {
    let bad = || format!("\"{text}\" is not LOW-HIGH in MeV (e.g. 70-230)");
    let (lo, hi) = text.split_once('-').ok_or_else(bad)?;
    let parse = |t: &str| t.trim().parse::<f64>().map_err(|_| bad());
    Ok((parse(lo)?, parse(hi)?))
}

/// `MIN-MAX` as two spot spacings (mm).
fn spacing_range(text: &str) -> Result<(f64, f64), String> {
    let bad = || format!("\"{text}\" is not MIN-MAX in mm (e.g. 3-8)");
    let (lo, hi) = text.split_once('-').ok_or_else(bad)?;
    let parse = |t: &str| t.trim().parse::<f64>().map_err(|_| bad());
    Ok((parse(lo)?, parse(hi)?))
}
