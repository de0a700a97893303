//! `arcsim import PLAN.dcm [-o plan.json]`: convert a DICOM RT Ion Plan into the native plan format.

use std::path::PathBuf;

use arcsim_plan::{ArcPlan, RotationDirection};

use crate::{output, CliError};

#[derive(clap::Args)]
pub struct Args {
    /// DICOM RT Ion Plan file (recognised by its content, whatever the extension).
    input: PathBuf,
    /// Where to write the plan (arcsim-plan/1 JSON); standard output when omitted.
    #[arg(short, long)]
    output: Option<PathBuf>,
}

/// Converts the plan, writes the JSON and prints a summary (to standard error when the JSON goes to
/// standard output).
pub fn run(args: Args) -> Result<(), CliError> {
    output::check_outputs(&[&args.input], &[("--output", args.output.as_deref())])?;
    let bytes = crate::input::read_input(&args.input)?;
    let plan = crate::input::dicom_plan(&args.input, &bytes)?;
    let json = arcsim_plan::to_json(&plan);
    let summary = summary(&plan);
    match &args.output {
        Some(path) => {
            output::write_file(path, json.as_bytes())?;
            output::println(&format!(
                "{} -> {}",
                crate::input::input_name(&args.input),
                path.display()
            ));
            output::println(&summary);
        }
        None => {
            output::print(&json);
            eprintln!("{summary}");
        }
    }
    Ok(())
}

/// "plan NAME: 2 arcs, ..." then one line per arc: direction, angle range, control points, layers,
/// spots, MU.
fn summary(plan: &ArcPlan) -> String {
    let n = plan.arcs.len();
    let mut out = format!("plan \"{}\": {}", plan.name, crate::count(n, "arc"));
    for (i, arc) in plan.arcs.iter().enumerate() {
        let cps = &arc.control_points;
        let layers: Vec<_> = cps.iter().flat_map(|cp| &cp.layers).collect();
        let spots: u64 = layers
            .iter()
            .filter_map(|l| l.spots.as_ref())
            .map(|s| u64::from(s.count))
            .sum();
        let mu: f64 = layers
            .iter()
            .filter_map(|l| l.spots.as_ref())
            .map(|s| s.total_mu.unwrap_or_else(|| s.mu.iter().flatten().sum()))
            .sum();
        let dir = match arc.direction {
            RotationDirection::Cw => "CW",
            RotationDirection::Cc => "CC",
        };
        let (first, last) = match (cps.first(), cps.last()) {
            (Some(f), Some(l)) => (f.angle_deg, l.angle_deg),
            _ => (f64::NAN, f64::NAN),
        };
        out.push_str(&format!(
            "\n  arc {i}: {dir} {first} -> {last} deg, {}, {}, {}, {mu:.3} MU",
            crate::count(cps.len(), "control point"),
            crate::count(layers.len(), "layer"),
            crate::count(spots as usize, "spot")
        ));
    }
    out
}
