//! `arcsim compare`: a delivery log beside the simulation of its plan — totals, breakdowns,
//! differences by class, the worst layers, which motion model fits, and the gantry's observed
//! limits; JSON and Rerun outputs.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use arcsim_log::kinematics::{ObservedKinematics, Plateau};
use arcsim_log::{ColumnMap, Comparison, DeliveryLog};
use arcsim_sequencer::{machine_limits, simulate_resolved, Delivery, Motion, Options, Schedule};

use crate::input::{input_name, load_machine, load_plan_with_bytes, machine_name};
use crate::simulate::{parse_motion, ScheduleArg};
use crate::CliError;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Plan file: arcsim JSON or DICOM RT Ion Plan.
    plan: PathBuf,
    /// Delivery log: `arcsim-log/1` CSV, another CSV with --columns, or a DICOM RT Ion Beams
    /// Treatment Record.
    log: PathBuf,
    /// Machine model (JSON); default: the built-in ATOM article gantry.
    #[arg(long)]
    machine: Option<PathBuf>,
    /// Motion model of the simulation (default: the machine's controller); every other model is
    /// simulated too, to say which fits the log better.
    #[arg(long, value_parser = parse_motion, value_name = "MOTION")]
    motion: Option<Motion>,
    /// Speed schedule of the simulations (default: the machine's controller's).
    #[arg(long, value_enum)]
    schedule: Option<ScheduleArg>,
    /// The log's column names, e.g. `t_s=TIME,gantry_angle_deg=GantryAngle,beam_on=BeamOn`.
    #[arg(long, value_name = "MAP")]
    columns: Option<String>,
    /// Write the comparison (totals, classes, every layer logged and simulated) as JSON.
    #[arg(long, value_name = "OUT")]
    json: Option<PathBuf>,
    /// Write the logged and simulated gantry angle and speed on one timeline (.rrd).
    #[arg(long, value_name = "OUT.rrd")]
    rrd: Option<PathBuf>,
}

/// Reads the log of a plan whose file's bytes are `plan_bytes`: a DICOM RT Ion Beams Treatment
/// Record (by content; refused when it references another plan than a DICOM plan's), else a CSV
/// log with an optional `--columns` mapping.
pub fn read(
    path: &Path,
    columns: Option<&str>,
    plan_bytes: &[u8],
) -> Result<DeliveryLog, CliError> {
    let map = match columns {
        Some(text) => {
            ColumnMap::parse(text, "--columns").map_err(|e| CliError::usage(e.to_string()))?
        }
        None => ColumnMap::default(),
    };
    let plan_uid = arcsim_dicom::sop_instance_uid_of(plan_bytes);
    arcsim_dicom::read_delivery_log(path, &map, plan_uid.as_deref())
        .map_err(|e| CliError::failed(e.to_string()))
}

/// The options of `--motion` / `--schedule` on `machine` (the defaults of `simulate`: the
/// machine's controller), and the controller they amount to.
pub fn options(
    motion: Option<Motion>,
    schedule: Option<ScheduleArg>,
    plan: &arcsim_plan::ArcPlan,
    machine: &arcsim_plan::Machine,
) -> (Options, arcsim_app::ControllerUsed) {
    let request = arcsim_app::SimulateRequest {
        schedule: schedule.map(Schedule::from),
        motion,
        ..arcsim_app::SimulateRequest::machine_default()
    };
    let (opts, _, used) = request.resolve(plan, machine);
    (opts, used)
}

pub fn run(args: Args) -> Result<(), CliError> {
    let mut inputs: Vec<&Path> = vec![args.plan.as_path(), args.log.as_path()];
    inputs.extend(args.machine.as_deref());
    crate::output::check_outputs(
        &inputs,
        &[
            ("--json", args.json.as_deref()),
            ("--rrd", args.rrd.as_deref()),
        ],
    )?;
    let (plan, plan_bytes) = load_plan_with_bytes(&args.plan)?;
    let machine = load_machine(args.machine.as_deref())?;
    let log = read(&args.log, args.columns.as_deref(), &plan_bytes)?;
    let arcs = arcsim_plan::resolve(&plan, &machine).map_err(crate::input::plan_error)?;
    let limits = machine_limits(&machine).map_err(|e| CliError::failed(e.to_string()))?;
    let (opts, controller) = options(args.motion, args.schedule, &plan, &machine);
    let opts = Options {
        servo_period_s: machine.servo_period_s,
        ..opts
    };
    let fail = |e: arcsim_sequencer::SequenceError| {
        CliError::failed(format!("{}: {e}", input_name(&args.plan)))
    };
    // Match first: a log of another plan is refused before any simulation.
    let logged =
        arcsim_log::match_layers(&log, &arcs).map_err(|e| CliError::failed(e.to_string()))?;
    arcsim_log::check_mu(&log, &plan, &arcs, &logged)
        .map_err(|e| CliError::failed(e.to_string()))?;
    let others: Vec<Options> = Motion::ALL
        .into_iter()
        .filter(|&m| m != opts.motion)
        .map(|motion| Options {
            motion,
            servo_period_s: None,
            ..opts.clone()
        })
        .collect();
    let (main, alts) = rayon::join(
        || simulate_resolved(&arcs, &limits, &opts),
        || {
            use rayon::prelude::*;
            others
                .par_iter()
                .map(|o| simulate_resolved(&arcs, &limits, o))
                .collect::<Vec<_>>()
        },
    );
    let main = main.map_err(fail)?;
    // Another model may not apply (free motion on a servo period): then it is left out.
    let alts: Vec<Delivery> = alts.into_iter().filter_map(Result::ok).collect();
    let others: Vec<&Delivery> = alts.iter().collect();
    let c = arcsim_log::compare(&arcs, &main, &others, &log)
        .map_err(|e| CliError::failed(e.to_string()))?;
    let mut text = summary(&c, &plan.name, &machine_name(args.machine.as_deref()));
    let at = text.find('\n').map_or(text.len(), |i| i + 1);
    text.insert_str(at, &format!("{}\n", controller.line()));
    crate::output::print(&text);
    if let Some(path) = &args.json {
        let mut doc = serde_json::to_value(&c).map_err(|e| CliError::failed(e.to_string()))?;
        if let Some(o) = doc.as_object_mut() {
            o.insert("format".into(), "arcsim-compare/1".into());
            o.insert("plan".into(), plan.name.clone().into());
            o.insert("plan_file".into(), input_name(&args.plan).into());
            o.insert("machine".into(), machine.name.clone().into());
            let used =
                serde_json::to_value(&controller).map_err(|e| CliError::failed(e.to_string()))?;
            o.insert("controller".into(), used);
        }
        let text =
            serde_json::to_string_pretty(&doc).map_err(|e| CliError::failed(e.to_string()))?;
        crate::output::write_file(path, text.as_bytes())?;
    }
    if let Some(path) = &args.rrd {
        write_rrd(path, &plan.name, &log, &c, &main)?;
    }
    Ok(())
}

fn write_rrd(
    path: &Path,
    title: &str,
    log: &DeliveryLog,
    c: &Comparison,
    sim: &Delivery,
) -> Result<(), CliError> {
    let shift = c.log_shift_s;
    let t: Vec<f64> = log.samples.iter().map(|s| s.t_s + shift).collect();
    let angle: Vec<f64> = log.samples.iter().map(|s| s.gantry_angle_deg).collect();
    let tr = arcsim_log::kinematics::trace(log);
    let speed_t: Vec<f64> = tr.t_s.iter().map(|t| t + shift).collect();
    let speed: Vec<f64> = tr.values.iter().map(|v| v[0]).collect();
    let samples = sim
        .timeline
        .as_ref()
        .map(|tl| tl.samples(0.01))
        .unwrap_or_default();
    let st: Vec<f64> = samples.iter().map(|s| s.0).collect();
    let sa: Vec<f64> = samples.iter().map(|s| s.1.angle_deg).collect();
    let sv: Vec<f64> = samples.iter().map(|s| s.1.speed_deg_per_s).collect();
    let series = [
        arcsim_viewer::AngleSeries {
            name: "logged",
            t_s: &t,
            angle_deg: &angle,
            speed_t_s: &speed_t,
            speed_deg_per_s: &speed,
        },
        arcsim_viewer::AngleSeries {
            name: "simulated",
            t_s: &st,
            angle_deg: &sa,
            speed_t_s: &st,
            speed_deg_per_s: &sv,
        },
    ];
    crate::output::write_via_path(path, |tmp| {
        arcsim_viewer::save_comparison(tmp, title, &series)
            .map_err(|e| CliError::failed(format!("--rrd {}: {e}", path.display())))
    })
}

/// The readable comparison printed on standard output.
pub fn summary(c: &Comparison, plan: &str, machine: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "log {} against plan {plan} on {machine} (motion {})",
        c.log, c.motion
    );
    let _ = writeln!(
        s,
        "{} layers matched; {} interrupted ({} interruptions); {} machine pauses inside layers (bursts, spills: beam-on time)",
        c.layers.len(),
        c.interrupted_layers,
        c.interruptions,
        c.machine_pauses
    );
    if c.glitches_rejected > 0 || c.uncertain_edges > 0 {
        let _ = writeln!(
            s,
            "log cleaning: {} glitched angle sample(s) rejected and interpolated; {} beam edge(s) after a sampling gap of more than 5 log periods, put at their sample (those layers' beam-on times are lower bounds)",
            c.glitches_rejected, c.uncertain_edges
        );
    }
    let _ = writeln!(
        s,
        "                       logged (s)  simulated (s)  difference (s)"
    );
    let (l, m) = (&c.logged, &c.simulated);
    for (name, a, b) in [
        ("total", l.total_s, m.total_s),
        ("  beam on", l.beam_on_s, m.beam_on_s),
        (
            "  energy switching",
            l.energy_switching_s,
            m.energy_switching_s,
        ),
        ("  gantry", l.gantry_s, m.gantry_s),
        ("  interruptions", l.interruptions_s, m.interruptions_s),
    ] {
        let _ = writeln!(s, "{name:<20} {a:12.2}  {b:13.2}  {:+14.2}", a - b);
    }
    let _ = writeln!(
        s,
        "difference of the totals: {:+.2} s ({:+.2} %)",
        c.difference_s, c.difference_pct
    );
    let _ = writeln!(s, "differences by class (logged - simulated, s):");
    let _ = writeln!(
        s,
        "  class                       count      mean        sd       min       max"
    );
    for k in &c.classes {
        let _ = writeln!(
            s,
            "  {:<26} {:6}  {:+8.3}  {:8.3}  {:+8.3}  {:+8.3}",
            k.class, k.count, k.mean_s, k.sd_s, k.min_s, k.max_s
        );
    }
    let _ = writeln!(
        s,
        "worst layers (transition in + beam on, logged - simulated):"
    );
    for w in &c.worst {
        let _ = writeln!(
            s,
            "  layer {:4} (arc {}, control point {}, {:.1} deg, {} MeV): {:+.3} s",
            w.index,
            w.arc,
            w.control_point,
            crate::gantry_deg(w.angle_deg),
            w.energy_mev,
            w.difference_s
        );
    }
    for f in &c.motion_fits {
        let _ = writeln!(
            s,
            "motion {:<8} total {:9.2} s, beam-on times off by {:.3} s (rms)",
            f.motion, f.total_s, f.rms_start_s
        );
    }
    let _ = writeln!(s, "the log fits {} motion better", c.better_motion);
    if c.better_motion != c.motion {
        let _ = writeln!(
            s,
            "  the simulation's controller ({} motion) is not the one the log shows: `arcsim calibrate` learns it, or try --motion {}",
            c.motion, c.better_motion
        );
    }
    observed_lines(&mut s, &c.observed, c);
    s
}

fn observed_lines(s: &mut String, o: &ObservedKinematics, c: &Comparison) {
    if let Some(res) = c.edge_resolution_s {
        let _ = writeln!(
            s,
            "gantry observed: nothing (a log of beam-on intervals, times to {res} s: a treatment record or an IBA-style log holds each layer's beam-on and beam-off, not the gantry's motion between them)"
        );
        return;
    }
    let _ = writeln!(
        s,
        "gantry observed (local polynomial fits over {} s; angle noise {:.4} deg):",
        o.window_s, o.angle_noise_deg
    );
    let l = &c.limits;
    let line = |s: &mut String, what: &str, p: &Option<Plateau>, limit: f64, unit: &str| {
        let _ = match p {
            Some(p) => writeln!(
                s,
                "  {what:<13} peak {:.4}, plateau {:.4} for {:.1} s in all ({}) against the limit {limit} {unit}",
                p.peak,
                p.level,
                p.held_s,
                if p.reached { "reached" } else { "not reached" }
            ),
            None => writeln!(s, "  {what:<13} not seen"),
        };
    };
    line(s, "speed", &o.speed, l.max_speed_deg_per_s, "deg/s");
    line(
        s,
        "acceleration",
        &o.accel,
        l.max_accel_deg_per_s2,
        "deg/s^2",
    );
    line(
        s,
        "deceleration",
        &o.decel,
        l.max_decel_deg_per_s2,
        "deg/s^2",
    );
    line(s, "jerk", &o.jerk, l.max_jerk_deg_per_s3, "deg/s^3");
    let _ = match &o.jerk_reversals {
        Some(r) => writeln!(
            s,
            "  jerk from the acceleration's reversals: {:.4} deg/s^3 ({}) against the limit {} deg/s^3",
            r.level,
            if r.reached { "reached" } else { "fewer than 3 reversals" },
            l.max_jerk_deg_per_s3
        ),
        None => writeln!(s, "  jerk from the acceleration's reversals: none (the acceleration limits are not both held)"),
    };
}
