//! `arcsim resequence PLAN [--machine M] [-o PLAN2]`: the same dose, delivered faster. The layers
//! of each control point are put in the order that delivers the plan fastest on the machine's
//! controller (optionally with arcs turned and reordered); every spot, MU, energy and control
//! point is kept, which a check proves before anything is written.

use std::fmt::Write;
use std::path::PathBuf;

use arcsim_plan::{to_json, ArcPlan, Machine};
use arcsim_resequence::{
    check_same_dose, resequence, ArcFreedom, Outcome, ResequenceOptions, SEARCH_LAYER_BUDGET,
};
use arcsim_sequencer::{Delivery, Motion, Schedule, SwitchKind, Switching, SMALL_UPWARD_STEP_MEV};

use crate::input::{input_name, load_machine, load_plan_with_bytes};
use crate::simulate::{parse_motion, ScheduleArg};
use crate::CliError;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Plan file: arcsim JSON or DICOM RT Ion Plan.
    plan: PathBuf,
    /// Machine model (JSON); default: the built-in ATOM article gantry.
    #[arg(long)]
    machine: Option<PathBuf>,
    /// Schedule of the simulations that judge each order; default: the machine's controller's.
    #[arg(long, value_enum)]
    schedule: Option<ScheduleArg>,
    /// Motion model of those simulations (`constant`, `free`, `one-speed`); default: the
    /// machine's controller.
    #[arg(long, value_parser = parse_motion, value_name = "MOTION")]
    motion: Option<Motion>,
    /// Also try each arc delivered the other way round and the arcs in another order.
    #[arg(long)]
    turn_arcs: bool,
    /// The search's budget, in layers simulated: every order of a small arc when they fit, a
    /// local search by simulation otherwise (0: only the orders found without simulating).
    #[arg(long, value_name = "LAYERS", default_value_t = SEARCH_LAYER_BUDGET)]
    search: usize,
    /// Write the re-sequenced plan: arcsim JSON, or for a DICOM input and a `.dcm` name, a
    /// DICOM RT Ion Plan (the original with its layers reordered, a new SOPInstanceUID referencing
    /// it, unapproved).
    #[arg(short, long, value_name = "PLAN.json|PLAN.dcm")]
    output: Option<PathBuf>,
    /// Write the before/after report (JSON).
    #[arg(long, value_name = "OUT")]
    json: Option<PathBuf>,
}

fn count_and_time(sw: &Switching, k: SwitchKind) -> (usize, f64) {
    sw.class(k)
        .map_or((0, 0.0), |g| (g.count, g.time_s.unwrap_or(g.elst_s)))
}

/// The before/after table.
fn report(out: &Outcome, before: &Switching, after: &Switching) -> String {
    let mut s = String::new();
    let row = |s: &mut String, what: &str, b: String, a: String| {
        let _ = writeln!(s, "  {what:<28} {b:>14}  {a:>14}");
    };
    let _ = writeln!(s, "  {:<28} {:>14}  {:>14}", "", "as given", "re-sequenced");
    row(
        &mut s,
        "total (s)",
        format!("{:.2}", out.before.total_s),
        format!("{:.2}", out.after.total_s),
    );
    for (k, name) in [
        (SwitchKind::Up, "switches up"),
        (SwitchKind::Down, "switches down"),
        (SwitchKind::Same, "same energy"),
    ] {
        let ((nb, tb), (na, ta)) = (count_and_time(before, k), count_and_time(after, k));
        row(
            &mut s,
            &format!("{name} (count, s)"),
            format!("{nb}, {tb:.2}"),
            format!("{na}, {ta:.2}"),
        );
    }
    row(
        &mut s,
        "energy switching (s)",
        format!("{:.2}", out.before.breakdown.energy_switching_s),
        format!("{:.2}", out.after.breakdown.energy_switching_s),
    );
    row(
        &mut s,
        "lost to the gantry (s)",
        format!("{:.2}", out.before.breakdown.lost_s),
        format!("{:.2}", out.after.breakdown.lost_s),
    );
    row(
        &mut s,
        &format!("upward steps < {SMALL_UPWARD_STEP_MEV} MeV (count, s)"),
        format!(
            "{}, {:.2}",
            before.small_upward.len(),
            before.small_upward_cost_s
        ),
        format!(
            "{}, {:.2}",
            after.small_upward.len(),
            after.small_upward_cost_s
        ),
    );
    s
}

pub fn run(args: Args) -> Result<(), CliError> {
    let dicom_out = args
        .output
        .as_deref()
        .filter(|p| arcsim_app::has_dicom_extension(p));
    if let (Some(out), true) = (dicom_out, args.turn_arcs) {
        return Err(CliError::usage(format!(
            "--output {} with --turn-arcs: a DICOM plan is written back only with layers reordered inside their control points (a beam's direction and the beams' order stay); drop --turn-arcs or write arcsim JSON",
            out.display()
        )));
    }
    let inputs: Vec<&std::path::Path> = std::iter::once(args.plan.as_path())
        .chain(args.machine.as_deref())
        .collect();
    crate::output::check_outputs(
        &inputs,
        &[
            ("--output", args.output.as_deref()),
            ("--json", args.json.as_deref()),
        ],
    )?;
    let (plan, plan_bytes) = load_plan_with_bytes(&args.plan)?;
    if let (Some(out), false) = (dicom_out, arcsim_dicom::has_dicom_magic(&plan_bytes)) {
        return Err(CliError::usage(format!(
            "--output {}: a DICOM plan is written back from a DICOM input; {} is arcsim JSON (write the re-sequenced plan as .json)",
            out.display(),
            input_name(&args.plan)
        )));
    }
    let machine = load_machine(args.machine.as_deref())?;
    let request = arcsim_app::SimulateRequest {
        schedule: args.schedule.map(Schedule::from),
        motion: args.motion,
        arc_ends: arcsim_sequencer::ArcEnds::Rest,
        period_s: None,
    };
    let (simulation, notes, controller) = request.resolve(&plan, &machine);
    for n in &notes {
        eprintln!("note: {n}");
    }
    let opts = ResequenceOptions {
        simulation,
        arcs: if args.turn_arcs {
            ArcFreedom::Turn
        } else {
            ArcFreedom::Keep
        },
        search_layer_budget: args.search,
        exhaustive: true,
    };
    let out = resequence(&plan, &machine, &opts)
        .map_err(|e| CliError::failed(format!("{}: {e}", input_name(&args.plan))))?;
    // The proof, again, on exactly what is written.
    check_same_dose(&plan, &out.plan).map_err(|e| {
        CliError::failed(format!(
            "{}: the re-sequenced plan would change the dose (a bug; nothing written): {e}",
            input_name(&args.plan)
        ))
    })?;
    let text = summary(&args, &plan, &machine, &controller, &out)?;
    crate::output::print(&text);
    if let Some(path) = &args.output {
        write_plan(path, dicom_out.is_some(), &plan_bytes, &out)?;
    }
    if let Some(path) = &args.json {
        write_report(path, &plan, &machine, &controller, &out)?;
    }
    Ok(())
}

/// What `resequence` prints: the plan, the controller, the before/after table and the verdict.
fn summary(
    args: &Args,
    plan: &ArcPlan,
    machine: &Machine,
    controller: &arcsim_app::ControllerUsed,
    out: &Outcome,
) -> Result<String, CliError> {
    let switching = |p: &ArcPlan, d: &Delivery| {
        arcsim_app::switching_of(p, machine, d).ok_or_else(|| {
            CliError::failed(format!(
                "{}: the plan does not resolve on the machine (a bug)",
                input_name(&args.plan)
            ))
        })
    };
    let (before, after) = (
        switching(plan, &out.before)?,
        switching(&out.plan, &out.after)?,
    );

    let mut text = format!(
        "plan {} on {}, {} simulated\n{}\n",
        plan.name,
        machine.name,
        crate::count(out.candidates.len(), "candidate order"),
        controller.line()
    );
    text.push_str(&report(out, &before, &after));
    match out.chosen {
        Some(_) => {
            let saved = out.before.total_s - out.after.total_s;
            let _ = writeln!(
                text,
                "re-sequenced: {:.2} s faster ({:.1} %), {} moved inside their control points; same spots, MU, energies and control points (checked)",
                saved,
                100.0 * saved / out.before.total_s,
                crate::count(out.moved_layers, "layer")
            );
        }
        None => {
            let _ = writeln!(
                text,
                "the plan as given is the fastest order found: nothing re-sequenced"
            );
        }
    }
    Ok(text)
}

/// `--output`: the re-sequenced plan as arcsim JSON, or written back into the DICOM RT Ion Plan
/// it came from (`original`).
fn write_plan(
    path: &std::path::Path,
    dicom: bool,
    original: &[u8],
    out: &Outcome,
) -> Result<(), CliError> {
    if !dicom {
        crate::output::write_file(path, to_json(&out.plan).as_bytes())?;
        crate::output::println(&format!("wrote {}", path.display()));
        return Ok(());
    }
    let written = arcsim_dicom::write_resequenced(original, &out.plan)
        .map_err(|e| CliError::failed(format!("{}: {e}", path.display())))?;
    crate::output::write_file(path, &written.bytes)?;
    crate::output::println(&format!(
        "wrote {} (DICOM RT Ion Plan, SOPInstanceUID {}, referencing {}; unapproved, for review)",
        path.display(),
        written.sop_instance_uid,
        written
            .original_sop_instance_uid
            .as_deref()
            .unwrap_or("no SOPInstanceUID")
    ));
    Ok(())
}

/// `--json`: the before/after report (`arcsim-resequence/1`, docs/results.md).
fn write_report(
    path: &std::path::Path,
    plan: &ArcPlan,
    machine: &Machine,
    controller: &arcsim_app::ControllerUsed,
    out: &Outcome,
) -> Result<(), CliError> {
    let doc = arcsim_app::resequence_report(plan, machine, controller, out);
    let text =
        serde_json::to_string_pretty(&doc).map_err(|e| CliError::failed(format!("--json: {e}")))?;
    crate::output::write_file(path, text.as_bytes())
}
