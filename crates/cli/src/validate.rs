//! `arcsim validate PLAN [--machine FILE]`: every problem of a plan at once, or a short summary.

use std::path::PathBuf;

use arcsim_plan::resolve;

use crate::input::{load_machine, load_plan, plan_error};
use crate::CliError;

#[derive(clap::Args)]
pub struct Args {
    /// Plan file: arcsim-plan/1 JSON or DICOM RT Ion Plan (recognised by its content or a
    /// .dcm/.dicom extension); `-` reads it from standard input.
    plan: PathBuf,
    /// Machine model (arcsim-machine/1 JSON); the built-in ATOM machine when omitted.
    #[arg(long)]
    machine: Option<PathBuf>,
    /// Refuse values far outside their field's plausible range (likely unit slips) instead of
    /// warning about them.
    #[arg(long)]
    strict: bool,
}

/// Prints all problems (exit 1) or a summary: arcs, control points, layers, beam-on time (exit 0).
pub fn run(args: Args) -> Result<(), CliError> {
    let plan = load_plan(&args.plan)?;
    let machine = load_machine(args.machine.as_deref())?;
    let warnings = crate::input::plausibility(&plan, &args.plan, &machine, args.machine.as_deref());
    crate::input::report_warnings(&warnings, args.strict)?;
    let arcs = resolve(&plan, &machine).map_err(plan_error)?;
    let control_points: usize = plan.arcs.iter().map(|a| a.control_points.len()).sum();
    let layers: Vec<_> = arcs.iter().flat_map(|a| &a.layers).collect();
    let beam_on: f64 = layers.iter().map(|l| l.irradiation_s).sum();
    let switching_s: f64 = layers.iter().map(|l| l.switch_in_s).sum();
    let switching = arcsim_sequencer::Switching::of(
        &arcs,
        None,
        &machine.elst,
        arcsim_sequencer::SMALL_UPWARD_STEP_MEV,
    );
    let upward = switching
        .class(arcsim_sequencer::SwitchKind::Up)
        .map_or(0, |g| g.count);
    crate::output::println(&format!(
        "{}: valid ({})",
        crate::input::input_name(&args.plan),
        plan.name
    ));
    crate::output::println(&format!(
        "  {}, {}, {}, {}",
        crate::count(arcs.len(), "arc"),
        crate::count(control_points, "control point"),
        crate::count(layers.len(), "layer"),
        crate::count(upward, "upward energy switch")
    ));
    crate::output::println(&format!(
        "  on machine \"{}\": beam-on time {beam_on:.1} s, energy switching {switching_s:.1} s",
        machine.name
    ));
    crate::output::print(&crate::switching::lines(&switching));
    Ok(())
}
