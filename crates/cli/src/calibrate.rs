//! `arcsim calibrate`: a machine fitted to delivery logs — ELST, beam timing and gantry limits
//! with 95 % intervals, what the logs cannot determine, the residual per log before and after.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use arcsim_log::{CalibrationReport, ElstFit, LoggedRun};

use crate::input::{input_name, load_machine, load_plan_with_bytes};
use crate::simulate::{parse_motion, ScheduleArg};
use crate::CliError;

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ElstArg {
    /// One time up, one down, one at the same energy.
    Constant,
    /// The upward time a line in the energy step (up_coeffs_s = [c0, c1]).
    Poly,
}

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The machine to start from: what the logs do not determine is kept from it.
    #[arg(long)]
    machine: PathBuf,
    /// Pairs of a plan and its delivery log (CSV, or a DICOM RT Ion Beams Treatment Record):
    /// PLAN LOG [PLAN LOG ...].
    #[arg(required = true, num_args = 2.., value_names = ["PLAN", "LOG"])]
    inputs: Vec<PathBuf>,
    /// Where to write the fitted machine (JSON).
    #[arg(short = 'o', long = "output", value_name = "FITTED.json")]
    output: PathBuf,
    /// Write the report (every value with its interval, the residuals) as JSON.
    #[arg(long, value_name = "REPORT")]
    json: Option<PathBuf>,
    /// How the ELST is fitted.
    #[arg(long, value_enum, default_value_t = ElstArg::Constant)]
    elst: ElstArg,
    /// The logs' column names, e.g. `t_s=TIME,gantry_angle_deg=GantryAngle,beam_on=BeamOn`.
    #[arg(long, value_name = "MAP")]
    columns: Option<String>,
    /// Force the motion model instead of learning it from the logs (`constant` or `free`; a
    /// calibration under `one-speed` is not built and is refused with the reason).
    #[arg(long, value_parser = parse_motion, value_name = "MOTION")]
    motion: Option<arcsim_sequencer::Motion>,
    /// Speed schedule of the simulations (default: the base machine's controller's).
    #[arg(long, value_enum)]
    schedule: Option<ScheduleArg>,
    /// Refuse (exit 1, nothing written) when the fit leaves a warning: a residual above the
    /// noise, or a controller the logs do not determine.
    #[arg(long)]
    strict: bool,
}

/// Checks that `inputs` are pairs of a plan and its `what` (a log), and that the outputs clobber
/// none of them (nor the machine) before any work.
pub fn check_pairs(
    inputs: &[PathBuf],
    machine: &Path,
    (output, json): (&Path, Option<&Path>),
    what: &str,
) -> Result<(), CliError> {
    if !inputs.len().is_multiple_of(2) {
        return Err(CliError::usage(format!(
            "expected pairs of a plan and its {what}, got {} paths (the last, {}, has no {what})",
            inputs.len(),
            inputs[inputs.len() - 1].display()
        )));
    }
    let mut all: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    all.push(machine);
    crate::output::check_outputs(&all, &[("--output", Some(output)), ("--json", json)])
}

pub fn run(args: Args) -> Result<(), CliError> {
    check_pairs(
        &args.inputs,
        &args.machine,
        (&args.output, args.json.as_deref()),
        "log",
    )?;
    let base = load_machine(Some(&args.machine))?;
    let runs = args
        .inputs
        .chunks(2)
        .map(|pair| {
            let (plan, plan_bytes) = load_plan_with_bytes(&pair[0])?;
            Ok(LoggedRun {
                plan_name: input_name(&pair[0]),
                plan,
                log: crate::compare::read(&pair[1], args.columns.as_deref(), &plan_bytes)?,
            })
        })
        .collect::<Result<Vec<_>, CliError>>()?;
    let fit = match args.elst {
        ElstArg::Constant => ElstFit::Constant,
        ElstArg::Poly => ElstFit::Polynomial,
    };
    let (opts, _) = crate::compare::options(None, args.schedule, &runs[0].plan, &base);
    let cal = arcsim_log::calibrate_controller(&base, &runs, fit, &opts, args.motion)
        .map_err(|e| CliError::failed(e.to_string()))?;
    if args.strict {
        let mut doubts = cal.report.warnings.clone();
        if let Some(e) = cal
            .report
            .controller
            .as_ref()
            .filter(|e| e.decision == "not determined")
        {
            doubts.push(format!(
                "the controller is not determined by the logs ({})",
                e.rms_beam_on_start_s
                    .iter()
                    .map(|(k, v)| format!("{k} {v:.3} s"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        if !doubts.is_empty() {
            return Err(CliError::failed(format!(
                "--strict: the fit leaves {} warning(s), nothing written:\n  {}",
                doubts.len(),
                doubts.join("\n  ")
            )));
        }
    }
    let machine_json =
        serde_json::to_string_pretty(&cal.machine).map_err(|e| CliError::failed(e.to_string()))?;
    // The fitted machine must read back as a machine file.
    arcsim_app::machine_from_text(&args.output.display().to_string(), &machine_json)
        .map_err(|e| CliError::failed(format!("the fitted machine is not valid: {e}")))?;
    let report = match &args.json {
        Some(_) => Some(report_json(&cal.report)?),
        None => None,
    };
    let mut text = summary(&cal.report, &input_name(&args.machine));
    if let Some(c) = &cal.machine.controller {
        text.insert_str(
            text.find('\n').map_or(text.len(), |i| i + 1),
            &format!(
                "controller: {}, {} schedule ({}): {}\n",
                c.motion.describe(),
                c.schedule.name(),
                c.evidence.as_ref().map_or("", |e| e.decision.as_str()),
                c.source
            ),
        );
    }
    crate::output::print(&text);
    write_fitted(
        &args.output,
        &machine_json,
        args.json.as_deref().zip(report),
    )
}

fn report_json(report: &CalibrationReport) -> Result<String, CliError> {
    tagged_json(report, "arcsim-calibration/1")
}

/// `value` as pretty JSON with its `format` tag.
pub fn tagged_json(value: &impl serde::Serialize, format: &str) -> Result<String, CliError> {
    let mut doc = serde_json::to_value(value).map_err(|e| CliError::failed(e.to_string()))?;
    if let Some(o) = doc.as_object_mut() {
        o.insert("format".into(), format.into());
    }
    serde_json::to_string_pretty(&doc).map_err(|e| CliError::failed(e.to_string()))
}

/// Writes the fitted machine to `output` and, where asked, the report.
pub fn write_fitted(
    output: &Path,
    machine_json: &str,
    report: Option<(&Path, String)>,
) -> Result<(), CliError> {
    crate::output::write_file(output, format!("{machine_json}\n").as_bytes())?;
    if let Some((path, text)) = report {
        crate::output::write_file(path, text.as_bytes())?;
    }
    Ok(())
}

/// The readable report printed on standard output.
pub fn summary(r: &CalibrationReport, base: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "calibrated from {} on {} log(s): {}",
        base,
        r.logs.len(),
        r.logs.join(", ")
    );
    s.push_str(&values_table(&r.values));
    s.push_str(&report_tail(r));
    s
}

/// Every value considered, a row each (base, fitted, interval, observations, what was done),
/// then how each was found.
pub fn values_table(values: &[arcsim_log::FittedValue]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "  field                              base        fitted     95 % interval            n  "
    );
    for v in values {
        let interval = v
            .interval
            .map_or_else(|| "-".to_string(), |[a, b]| format!("{a:.6} – {b:.6}"));
        let base = v.base.map_or_else(|| "-".to_string(), |b| format!("{b}"));
        let _ = writeln!(
            s,
            "  {:<32} {:>9}  {:>12.6}  {:<24} {:>4}  {}",
            v.field,
            base,
            v.value,
            interval,
            v.observations,
            match (v.determined, v.base) {
                (true, _) => "fitted",
                (false, Some(b)) if b < v.value => "raised",
                (false, Some(b)) if b > v.value => "lowered",
                _ => "kept",
            }
        );
    }
    let _ = writeln!(s, "how each value was found:");
    for v in values {
        let _ = writeln!(s, "  {}: {}", v.field, v.note);
    }
    s
}

/// The rest of the calibration report: spreads, residuals, warnings.
fn report_tail(r: &CalibrationReport) -> String {
    let mut s = String::new();
    let sp = &r.spread;
    let _ = writeln!(
        s,
        "spreads (sd): ELST up {:.4} s, down {:.4} s, same {:.4} s; beam-on time {:.2} %",
        sp.elst_up_sd_s,
        sp.elst_down_sd_s,
        sp.elst_same_sd_s,
        100.0 * sp.beam_time_sd_fraction
    );
    let _ = writeln!(s, "residuals (simulated - logged total):");
    for x in &r.residuals {
        let _ = writeln!(
            s,
            "  {}: logged {:.2} s; base {:.2} s ({:+.2} %); fitted {:.2} s ({:+.2} %)",
            x.log,
            x.logged_total_s,
            x.base_total_s,
            x.base_error_pct,
            x.fitted_total_s,
            x.fitted_error_pct
        );
    }
    if r.glitches_rejected > 0 {
        let _ = writeln!(
            s,
            "log cleaning: {} glitched angle sample(s) rejected and interpolated",
            r.glitches_rejected
        );
    }
    for w in &r.warnings {
        let _ = writeln!(s, "warning: {w}");
    }
    s
}
