//! `arcsim simulate`: one plan on one machine with one speed schedule — total time, where it
//! goes, the tightest margins and the costliest transitions; JSON, CSV and Rerun outputs.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use arcsim_sequencer::{
    certify, machine_limits, simulate_observed, spot_timeline, ArcEnds, Certificate, Delivery,
    GantryState, Limiter, Margins, Motion, Schedule, SpotRow, CERTIFY_ROUNDS,
};

use crate::input::{load_machine_hashed, load_plan_hashed};
use crate::table::{csv_table, Column};
use crate::CliError;

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ScheduleArg {
    /// Bidirectional scan (fast, near-optimal).
    Scan,
    /// Least total time found (dynamic programming over refined speed grids; never worse than
    /// scan, not certified).
    Optimal,
    /// The plan's required speeds, checked; violations reported and minimally corrected.
    Prescribed,
    /// Gantry at rest for every layer (baseline).
    StepAndShoot,
}

/// Parses `--motion`: any motion model the sequencer has (`Motion::ALL`), so a new controller
/// needs no new option code.
pub fn parse_motion(text: &str) -> Result<Motion, String> {
    text.parse::<Motion>().map_err(|e| e.to_string())
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ArcEndsArg {
    /// The first and last layers of each arc are irradiated at rest.
    Rest,
    /// The gantry may move at the first and last beam (run-up counted, final braking not).
    Free,
}

impl From<ArcEndsArg> for ArcEnds {
    fn from(a: ArcEndsArg) -> Self {
        match a {
            ArcEndsArg::Rest => ArcEnds::Rest,
            ArcEndsArg::Free => ArcEnds::Free,
        }
    }
}

impl From<ScheduleArg> for Schedule {
    fn from(s: ScheduleArg) -> Self {
        match s {
            ScheduleArg::Scan => Schedule::Scan,
            ScheduleArg::Optimal => Schedule::Optimal,
            ScheduleArg::Prescribed => Schedule::Prescribed,
            ScheduleArg::StepAndShoot => Schedule::StepAndShoot,
        }
    }
}

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Plan file: arcsim JSON or DICOM RT Ion Plan.
    plan: PathBuf,
    /// Machine model (JSON); default: the built-in ATOM article gantry (scenarios/machine-atom.json).
    #[arg(long)]
    machine: Option<PathBuf>,
    /// How layer speeds are chosen (with free motion: the constant-speed start and baseline);
    /// default: the machine's controller's (optimal when the machine names none).
    #[arg(long, value_enum)]
    schedule: Option<ScheduleArg>,
    /// Motion model, overriding the machine's controller: `constant` (one speed per layer,
    /// ATOM's model), `free` (speed may change during beam-on) or `one-speed` (one speed per
    /// arc, the AAPM 2026 one-speed workflow). Default: the machine's controller (constant speed
    /// per layer, assumed, when the machine names none; constant when a servo period applies).
    #[arg(long, value_parser = parse_motion, value_name = "MOTION")]
    motion: Option<Motion>,
    /// Arc ends at rest (default) or free (free motion only).
    #[arg(long, value_enum, default_value_t = ArcEndsArg::Rest)]
    arc_ends: ArcEndsArg,
    /// Servo period (s): every transition lasts a whole number of periods (overrides the
    /// machine's `servo_period_s`).
    #[arg(long, value_name = "TS", allow_hyphen_values = true)]
    period: Option<f64>,
    /// Prove how close the delivery is to the fastest one: print (and write with --json) a lower
    /// bound and the gap to it. Constant motion: of every constant-speed schedule (tight; takes
    /// seconds on a 180-layer plan). Free motion: of every free motion (loose: 0.5-22 % below
    /// on the bundled plans and the ATOM cases, docs/model.md).
    #[arg(long)]
    certify: bool,
    /// Write the full result (summary, per-layer and per-transition rows, margins) as JSON.
    #[arg(long, value_name = "OUT")]
    json: Option<PathBuf>,
    /// Write every spot delivery as CSV: arc, control point, layer, spot, painting, x and y (mm),
    /// MU, start and end time (s), gantry angle at start and end (deg). With --json, the JSON
    /// result also lists them (`spots`).
    #[arg(long, value_name = "SPOTS.csv")]
    spots: Option<PathBuf>,
    /// Write the delivery as a machine would log it (`arcsim-log/1` CSV: time, gantry angle,
    /// beam on, energy, spot, MU since the previous row), a virtual log.
    #[arg(long, value_name = "LOG.csv")]
    log: Option<PathBuf>,
    /// Time between the virtual log's samples (s).
    #[arg(
        long,
        value_name = "S",
        default_value_t = 0.01,
        allow_hyphen_values = true
    )]
    log_period: f64,
    /// Standard deviation of Gaussian noise added to the virtual log's angles (deg): encoder
    /// noise, or gantry errors for dose-reconstruction studies.
    #[arg(
        long,
        value_name = "SD",
        default_value_t = 0.0,
        allow_hyphen_values = true
    )]
    angle_noise_deg: f64,
    /// Seed of the virtual log's angle noise and of the Monte Carlo draws.
    #[arg(long, value_name = "N", default_value_t = 0)]
    seed: u64,
    /// Simulate N more deliveries with the machine's timing spreads (`spread`, measured by
    /// `arcsim calibrate`) drawn per switch and per layer; print (and write with --json) the
    /// 5th, 50th and 95th percentiles of the total.
    #[arg(long, value_name = "N")]
    monte_carlo: Option<usize>,
    /// Write the sampled timeline as CSV.
    #[arg(long, value_name = "TIMELINE")]
    csv: Option<PathBuf>,
    /// Sampling step for --csv and --rrd (s).
    #[arg(long, default_value_t = 0.01, allow_hyphen_values = true)]
    dt: f64,
    /// Write the timeline for the Rerun viewer (.rrd).
    #[arg(long, value_name = "OUT.rrd")]
    rrd: Option<PathBuf>,
    /// Open a Rerun viewer (the `rerun` binary must be installed) and stream the timeline to it.
    #[arg(long)]
    spawn: bool,
    /// Stream the timeline to a running Rerun viewer, e.g. rerun+http://127.0.0.1:9876/proxy.
    #[arg(long, value_name = "URL")]
    connect: Option<String>,
    /// Refuse values far outside their field's plausible range (likely unit slips such as ELST
    /// in ms or limits in rad/s) instead of warning about them.
    #[arg(long)]
    strict: bool,
}

/// `x` with `decimals` decimals, right-aligned in `width` characters; a zero is never signed
/// ("-0.00" is written "0.00").
fn fixed(x: f64, decimals: usize, width: usize) -> String {
    let text = arcsim_plan::without_zero_sign(format!("{x:.decimals$}"));
    format!("{text:>width$}")
}

fn min_sec(t: f64) -> String {
    let m = (t / 60.0).floor();
    format!("{}:{:04.1}", m as u64, t - 60.0 * m)
}

fn limiter_name(l: Limiter) -> &'static str {
    match l {
        Limiter::Elst => "ELST",
        Limiter::Speed => "V",
        Limiter::Accel => "A",
        Limiter::Jerk => "J",
        Limiter::None => "-",
    }
}

/// The readable summary printed on standard output.
pub fn summary(d: &Delivery, plan: &str, machine: &str) -> String {
    let mut s = String::new();
    heading(&mut s, d, plan, machine);
    time_breakdown(&mut s, d);
    motion_notes(&mut s, d);
    if let Some(m) = d.margins {
        tightest_margins(&mut s, &m);
    }
    where_lost(&mut s, d);
    speed_violations(&mut s, d);
    s
}

/// The plan, machine, schedule and motion, and the counts of layers and transitions.
fn heading(s: &mut String, d: &Delivery, plan: &str, machine: &str) {
    let _ = writeln!(
        s,
        "plan {plan} on {machine}, schedule {}, motion {}{}",
        d.schedule.name(),
        d.motion.name(),
        if d.motion.speed_changes_during_beam() {
            format!(" (arc ends {})", d.arc_ends.name())
        } else {
            String::new()
        }
    );
    let _ = writeln!(
        s,
        "{}, {}",
        crate::count(d.layers.len(), "layer"),
        crate::count(d.transitions.len(), "transition")
    );
}

/// The total delivery time and its parts, each with its share of the total.
fn time_breakdown(s: &mut String, d: &Delivery) {
    let b = d.breakdown;
    let pct = |x: f64| {
        if d.total_s > 0.0 {
            100.0 * x / d.total_s
        } else {
            0.0
        }
    };
    let _ = writeln!(
        s,
        "total delivery time  {:9.2} s  ({})",
        d.total_s,
        min_sec(d.total_s)
    );
    let _ = writeln!(
        s,
        "  beam on            {} s  {} %",
        fixed(b.beam_on_s, 2, 9),
        fixed(pct(b.beam_on_s), 1, 5)
    );
    if b.scanning_s + b.burst_switching_s + b.spill_waiting_s > 0.0 {
        let _ = writeln!(
            s,
            "    spot irradiation {} s  {} %",
            fixed(b.spot_irradiation_s, 2, 9),
            fixed(pct(b.spot_irradiation_s), 1, 5)
        );
        let _ = writeln!(
            s,
            "    between spots    {} s  {} %  (scanning, settling, layer overhead)",
            fixed(b.scanning_s, 2, 9),
            fixed(pct(b.scanning_s), 1, 5)
        );
    }
    if b.burst_switching_s > 0.0 {
        let _ = writeln!(
            s,
            "    burst switching  {} s  {} %  (pauses between a layer's bursts)",
            fixed(b.burst_switching_s, 2, 9),
            fixed(pct(b.burst_switching_s), 1, 5)
        );
    }
    if b.spill_waiting_s > 0.0 {
        let _ = writeln!(
            s,
            "    spill waiting    {} s  {} %  (beam off, waiting for the next spill)",
            fixed(b.spill_waiting_s, 2, 9),
            fixed(pct(b.spill_waiting_s), 1, 5)
        );
    }
    let _ = writeln!(
        s,
        "  energy switching   {} s  {} %",
        fixed(b.energy_switching_s, 2, 9),
        fixed(pct(b.energy_switching_s), 1, 5)
    );
    let _ = writeln!(
        s,
        "  lost (gantry)      {} s  {} %",
        fixed(b.lost_s, 2, 9),
        fixed(pct(b.lost_s), 1, 5)
    );
}

/// After the heading's first line: the controller the number comes from and where that came
/// from, and how to see each other model as a what-if (the constant-speed total comes with every
/// other model, as its seed or baseline; the others are asked for, as free motion costs seconds).
pub fn insert_controller_lines(text: &mut String, used: &arcsim_app::ControllerUsed, d: &Delivery) {
    let mut lines = format!("{}\n", used.line());
    for m in Motion::ALL {
        let shown = m == d.motion || (m == Motion::Constant && d.constant_speed_total_s.is_some());
        if !shown {
            lines.push_str(&format!(
                "what-if: {} with --motion {}\n",
                m.describe(),
                m.name()
            ));
        }
    }
    let at = text.find('\n').map_or(text.len(), |i| i + 1);
    text.insert_str(at, &lines);
}

/// The servo period, what the model saves or costs against constant speed per layer, and what
/// limits the transitions.
fn motion_notes(s: &mut String, d: &Delivery) {
    if let Some(ts) = d.servo_period_s {
        let _ = writeln!(
            s,
            "transitions last whole numbers of a {:.3} ms servo period (limits kept)",
            1e3 * ts
        );
    }
    if let Some(c) = d.constant_speed_total_s {
        let saved = c - d.total_s;
        let (verb, by) = if saved >= 0.0 {
            ("saves", saved)
        } else {
            ("costs", -saved)
        };
        let _ = writeln!(
            s,
            "{} {verb} {} s ({} %) against constant speed per layer ({c:.2} s)",
            d.motion.short(),
            fixed(by, 2, 0),
            fixed(if c > 0.0 { 100.0 * by / c } else { 0.0 }, 1, 0)
        );
    }
    let c = d.limiter_counts;
    let _ = writeln!(
        s,
        "transitions limited by: ELST {}, V {}, A {}, J {}, none {}",
        c.elst, c.speed, c.accel, c.jerk, c.none
    );
}

/// How close the delivery comes to each limit, and where.
fn tightest_margins(s: &mut String, m: &Margins) {
    let _ = writeln!(s, "tightest margins:");
    let _ = writeln!(
        s,
        "  speed        {:6.1} % of V     at t = {:8.2} s (layer {})",
        100.0 * m.speed_use.value,
        m.speed_use.t_s,
        m.speed_use.layer
    );
    let _ = writeln!(
        s,
        "  acceleration {:6.1} % of A/D   at t = {:8.2} s (layer {})",
        100.0 * m.accel_use.value,
        m.accel_use.t_s,
        m.accel_use.layer
    );
    let _ = writeln!(
        s,
        "  jerk         {:6.1} % of J     at t = {:8.2} s (layer {})",
        100.0 * m.jerk_use.value,
        m.jerk_use.t_s,
        m.jerk_use.layer
    );
    let _ = writeln!(
        s,
        "  window slack {:8.4} deg      at t = {:8.2} s (layer {})",
        m.window_slack_deg.value, m.window_slack_deg.t_s, m.window_slack_deg.layer
    );
    if m.elst_slack_s.value.is_finite() {
        let _ = writeln!(
            s,
            "  ELST slack   {:8.4} s        at t = {:8.2} s (layer {})",
            m.elst_slack_s.value.max(0.0),
            m.elst_slack_s.t_s,
            m.elst_slack_s.layer
        );
    }
}

/// The prescribed speeds that cannot be delivered, and the speeds used instead.
fn speed_violations(s: &mut String, d: &Delivery) {
    if !d.violations.is_empty() {
        let _ = writeln!(
            s,
            "{} prescribed speeds cannot be delivered (corrected speeds used above):",
            d.violations.len()
        );
        for v in &d.violations {
            let _ = writeln!(
                s,
                "  arc {}, control point {} (layer {}): {:.4} deg/s → {:.4} deg/s: {}",
                v.arc,
                v.control_point,
                v.layer,
                v.prescribed_deg_per_s,
                v.corrected_deg_per_s,
                v.reason
            );
        }
    }
}

/// Angle ranges as "10–30, 44–52 deg" (gantry angles, in [0, 360)), at most four, then
/// "+N more".
fn ranges_text(r: &[[f64; 2]]) -> String {
    let mut parts: Vec<String> = r
        .iter()
        .take(4)
        .map(|&[a, b]| {
            let (a, b) = (crate::gantry_deg(a), crate::gantry_deg(b));
            if (b - a).abs() < 1e-9 {
                format!("{a:.1}")
            } else {
                format!("{a:.1}–{b:.1}")
            }
        })
        .collect();
    if r.len() > 4 {
        parts.push(format!("+{} more", r.len() - 4));
    }
    parts.join(", ")
}

/// "Where the time is lost": lost time by cause and place, then the costliest transitions,
/// located by arc, control point and angle.
fn where_lost(s: &mut String, d: &Delivery) {
    let lt = &d.lost_time;
    if lt.count == 0 {
        let _ = writeln!(s, "no time lost: every transition lasts just its ELST");
        return;
    }
    let _ = writeln!(
        s,
        "where the time is lost: {:.2} s in {} of {} transitions (time beyond the ELST)",
        lt.total_s,
        lt.count,
        d.transitions.len()
    );
    let _ = writeln!(
        s,
        "  limit  switch      layers apart         count  lost (s)  each (s)  angles (deg)"
    );
    for g in lt.groups.iter().take(8) {
        let _ = writeln!(
            s,
            "  {:<5}  {:<10}  {:<19} {:>6}  {:8.2}  {:8.2}  {}",
            limiter_name(g.limited_by),
            g.switch.name(),
            g.gap.name(),
            g.count,
            g.lost_s,
            g.mean_lost_s,
            ranges_text(&g.angle_ranges_deg)
        );
    }
    if lt.groups.len() > 8 {
        let rest: f64 = lt.groups[8..].iter().map(|g| g.lost_s).sum();
        let _ = writeln!(s, "  … {} more causes, {rest:.2} s", lt.groups.len() - 8);
    }
    let _ = writeln!(s, "{} most costly transitions:", lt.costliest.len());
    let _ = writeln!(
        s,
        "  arc  control point   angle (deg)        start (s)  duration (s)  ELST (s)  lost (s)  switch  limit"
    );
    for c in &lt.costliest {
        let tr = &d.transitions[c.transition];
        let arc = if c.from_arc == c.to_arc {
            format!("{}", c.from_arc)
        } else {
            format!("{}→{}", c.from_arc, c.to_arc)
        };
        let _ = writeln!(
            s,
            "  {:<3}  {:>5} → {:<5}  {:7.2} → {:<7.2}  {:9.2}  {:12.3}  {:8.2}  {:8.3}  {:<6}  {}",
            arc,
            c.from_control_point,
            c.to_control_point,
            crate::gantry_deg(c.from_angle_deg),
            crate::gantry_deg(c.to_angle_deg),
            tr.t_start_s,
            c.duration_s,
            c.elst_s,
            c.lost_s,
            c.switch.name(),
            limiter_name(c.limited_by)
        );
    }
}

/// The spot table: one row per spot delivery, columns named with their units (the burst and
/// spill indices last, so tables of machines without them keep their column positions).
const SPOT_COLUMNS: [Column<SpotRow>; 15] = [
    Column {
        name: "layer_index",
        get: |r| r.layer_index.to_string(),
    },
    Column {
        name: "arc",
        get: |r| r.arc.to_string(),
    },
    Column {
        name: "control_point",
        get: |r| r.control_point.to_string(),
    },
    Column {
        name: "layer",
        get: |r| r.layer.to_string(),
    },
    Column {
        name: "spot",
        get: |r| r.spot.to_string(),
    },
    Column {
        name: "painting",
        get: |r| r.painting.to_string(),
    },
    Column {
        name: "x_mm",
        get: |r| optional(r.x_mm),
    },
    Column {
        name: "y_mm",
        get: |r| optional(r.y_mm),
    },
    Column {
        name: "mu",
        get: |r| r.mu.to_string(),
    },
    Column {
        name: "t_start_s",
        get: |r| r.t_start_s.to_string(),
    },
    Column {
        name: "t_end_s",
        get: |r| r.t_end_s.to_string(),
    },
    Column {
        name: "angle_start_deg",
        get: |r| r.angle_start_deg.to_string(),
    },
    Column {
        name: "angle_end_deg",
        get: |r| r.angle_end_deg.to_string(),
    },
    Column {
        name: "burst",
        get: |r| r.burst.map(|b| b.to_string()).unwrap_or_default(),
    },
    Column {
        name: "spill",
        get: |r| r.spill.map(|b| b.to_string()).unwrap_or_default(),
    },
];

/// A number, or an empty field.
fn optional(x: Option<f64>) -> String {
    x.map(|v| v.to_string()).unwrap_or_default()
}

/// What `--log-period`, `--angle-noise-deg` and `--seed` ask of the virtual log.
fn log_options(args: &Args) -> arcsim_log::VirtualLogOptions {
    arcsim_log::VirtualLogOptions {
        period_s: args.log_period,
        angle_noise_deg: args.angle_noise_deg,
        seed: args.seed,
    }
}

/// The virtual log of `--log`.
fn write_log(
    path: &Path,
    delivery: &Delivery,
    spots: &[SpotRow],
    args: &Args,
) -> Result<(), CliError> {
    let samples = arcsim_log::virtual_log(delivery, spots, &log_options(args))
        .map_err(|e| CliError::usage(format!("--log: {e}")))?;
    crate::output::write_file(path, arcsim_log::to_csv(&samples).as_bytes())
}

fn write_spots_csv(path: &Path, spots: &[SpotRow]) -> Result<(), CliError> {
    crate::output::write_file(path, &csv_table(&SPOT_COLUMNS, spots))
}

/// One sample of the timeline: time, gantry state, and the layer being irradiated (its index
/// and energy).
struct Sample {
    t: f64,
    state: GantryState,
    beam: Option<(usize, f64)>,
}

/// The columns of the timeline CSV.
const SAMPLE_COLUMNS: [Column<Sample>; 7] = [
    Column {
        name: "t_s",
        get: |s| format!("{:.6}", s.t),
    },
    Column {
        name: "angle_deg",
        get: |s| s.state.angle_deg.to_string(),
    },
    Column {
        name: "speed_deg_per_s",
        get: |s| s.state.speed_deg_per_s.to_string(),
    },
    Column {
        name: "accel_deg_per_s2",
        get: |s| s.state.accel_deg_per_s2.to_string(),
    },
    Column {
        name: "jerk_deg_per_s3",
        get: |s| s.state.jerk_deg_per_s3.to_string(),
    },
    Column {
        name: "beam_layer",
        get: |s| s.beam.map(|(l, _)| l.to_string()).unwrap_or_default(),
    },
    Column {
        name: "energy_mev",
        get: |s| optional(s.beam.map(|(_, e)| e)),
    },
];

fn write_csv(path: &Path, d: &Delivery, dt: f64) -> Result<(), CliError> {
    let tl = d
        .timeline
        .as_ref()
        .ok_or_else(|| CliError::failed("no timeline was built"))?;
    let samples = tl.samples(dt).into_iter().map(|(t, state)| Sample {
        t,
        state,
        beam: tl
            .beam_layer_at(t)
            .map(|l| (l, d.layers.get(l).map_or(f64::NAN, |x| x.energy_mev))),
    });
    crate::output::write_file(path, &csv_table(&SAMPLE_COLUMNS, samples))
}

/// The certificate of a delivery (`--certify`).
fn certificate(
    plan: &arcsim_plan::ArcPlan,
    machine: &arcsim_plan::Machine,
    delivery: &Delivery,
    path: &Path,
) -> Result<Certificate, CliError> {
    let failed = |e: String| CliError::failed(format!("{}: {e}", crate::input::input_name(path)));
    let arcs = arcsim_plan::resolve(plan, machine).map_err(|e| failed(e.to_string()))?;
    let limits = machine_limits(machine).map_err(|e| failed(e.to_string()))?;
    certify(&arcs, &limits, delivery, CERTIFY_ROUNDS).map_err(|e| failed(e.to_string()))
}

/// The certificate's lines of the summary.
fn certificate_lines(c: &Certificate, total_s: f64, motion: Motion) -> String {
    let pct = if total_s > 0.0 {
        100.0 * c.gap_s / total_s
    } else {
        0.0
    };
    // One speed per arc is a constant-speed delivery (its cruises held): the constant-speed
    // bound holds for it too.
    let what = if motion.speed_changes_during_beam() {
        "no free motion is faster; a loose bound"
    } else {
        "no constant-speed schedule is faster"
    };
    format!(
        "lower bound          {:9.2} s  ({what})\n\
         gap                  {:9.3} s  {:6.3} %\n",
        c.lower_bound_s, c.gap_s, pct
    )
}

/// Checks `--dt` and the output paths against the inputs and each other.
fn check_args(args: &Args) -> Result<(), CliError> {
    if !(args.dt.is_finite() && args.dt > 0.0) {
        return Err(CliError::usage(format!(
            "--dt {}: expected a finite number > 0",
            arcsim_plan::fmt_num(args.dt)
        )));
    }
    if !(args.log_period.is_finite() && args.log_period > 0.0) {
        return Err(CliError::usage(format!(
            "--log-period {}: expected a finite number of seconds > 0",
            arcsim_plan::fmt_num(args.log_period)
        )));
    }
    if !(0.0..=arcsim_log::MAX_ANGLE_NOISE_DEG).contains(&args.angle_noise_deg) {
        return Err(CliError::usage(format!(
            "--angle-noise-deg {}: expected a number of degrees from 0 to {}",
            arcsim_plan::fmt_num(args.angle_noise_deg),
            arcsim_log::MAX_ANGLE_NOISE_DEG
        )));
    }
    let inputs: Vec<&Path> = std::iter::once(args.plan.as_path())
        .chain(args.machine.as_deref())
        .collect();
    crate::output::check_outputs(
        &inputs,
        &[
            ("--json", args.json.as_deref()),
            ("--csv", args.csv.as_deref()),
            ("--rrd", args.rrd.as_deref()),
            ("--spots", args.spots.as_deref()),
            ("--log", args.log.as_deref()),
        ],
    )
}

/// Refuses a `--dt` (or `--log-period`) that would sample the timeline more than 5e7 times, when
/// an output samples it.
fn check_sample_count(args: &Args, delivery: &Delivery) -> Result<(), CliError> {
    let sampled = args.csv.is_some() || args.rrd.is_some() || args.spawn || args.connect.is_some();
    if let Some(tl) = delivery.timeline.as_ref().filter(|_| sampled) {
        if tl.duration_s() / args.dt > 5e7 {
            return Err(CliError::usage(format!(
                "--dt {} would write more than 5e7 samples",
                arcsim_plan::fmt_num(args.dt)
            )));
        }
    }
    if let Some(tl) = delivery.timeline.as_ref().filter(|_| args.log.is_some()) {
        // The virtual log's own check, before any output is written.
        match arcsim_log::check_options(tl.duration_s(), &log_options(args)) {
            Ok(_) => {}
            Err(arcsim_log::VirtualLogError::TooManySamples { .. }) => {
                return Err(CliError::usage(format!(
                    "--log-period {} would write more than 5e7 samples",
                    arcsim_plan::fmt_num(args.log_period)
                )))
            }
            Err(e) => return Err(CliError::usage(format!("--log: {e}"))),
        }
    }
    Ok(())
}

/// `--monte-carlo` needs draws and a machine with spreads: refused before anything is simulated.
fn check_monte_carlo(args: &Args, machine: &arcsim_plan::Machine) -> Result<(), CliError> {
    let Some(n) = args.monte_carlo else {
        return Ok(());
    };
    if n == 0 || n > arcsim_evaluator::MAX_DRAWS {
        return Err(CliError::usage(format!(
            "--monte-carlo {n}: expected 1 to {} draws",
            arcsim_evaluator::MAX_DRAWS
        )));
    }
    if machine.spread.is_none() && !machine.uncertainty.is_some_and(|u| u.any()) {
        return Err(CliError::failed(format!(
            "--monte-carlo: the machine {} has no timing spreads (`spread`: elst_up_sd_s, \
             elst_down_sd_s, beam_time_sd_fraction) and no fitted values' `uncertainty`; `arcsim calibrate` measures both in delivery logs",
            crate::input::machine_name(args.machine.as_deref())
        )));
    }
    Ok(())
}

fn monte_carlo(
    plan: &arcsim_plan::ArcPlan,
    machine: &arcsim_plan::Machine,
    opts: &arcsim_sequencer::Options,
    draws: usize,
    seed: u64,
    plan_path: &Path,
) -> Result<arcsim_evaluator::MachineMonteCarlo, CliError> {
    // A bar on a terminal, and once a few seconds have run, how long the rest will take (it
    // started 1e5 draws of 36 h without a word).
    let total = draws * arcsim_evaluator::monte_carlo_passes(machine);
    let bar = crate::sweep::progress_bar(total)?;
    let started = std::time::Instant::now();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let estimated = std::sync::atomic::AtomicBool::new(false);
    let on_draw = || {
        bar.inc(1);
        let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        let elapsed = started.elapsed().as_secs_f64();
        if elapsed >= crate::sweep::ESTIMATE_AFTER_S
            && !estimated.swap(true, std::sync::atomic::Ordering::Relaxed)
        {
            if let Some(line) = crate::sweep::estimate_line(n, total, elapsed, "simulation") {
                bar.suspend(|| eprintln!("--monte-carlo {draws}: {line}"));
            }
        }
    };
    let mc = arcsim_evaluator::machine_monte_carlo_observed(
        plan,
        machine,
        opts,
        (draws, seed),
        &on_draw,
    )
    .map_err(|e| CliError::failed(format!("{}: {e}", crate::input::input_name(plan_path))));
    bar.finish_and_clear();
    mc
}

fn monte_carlo_lines(m: &arcsim_evaluator::MachineMonteCarlo) -> String {
    let mc = &m.both;
    let sp = &mc.spread;
    let mut s = format!(
        "Monte Carlo, {} draws (seed {}; sd of ELST up {:.4} s, down {:.4} s, same {:.4} s, beam-on {:.2} %{}):\n  \
         total P5 {:.2} s, P50 {:.2} s, P95 {:.2} s (mean {:.2} s, sd {:.2} s)\n",
        mc.draws,
        mc.seed,
        sp.elst_up_sd_s,
        sp.elst_down_sd_s,
        sp.elst_same_sd_s,
        100.0 * sp.beam_time_sd_fraction,
        if m.uncertainty.is_some() {
            "; and the fitted values' uncertainty, one draw per delivery"
        } else {
            ""
        },
        mc.p5_s,
        mc.p50_s,
        mc.p95_s,
        mc.mean_s,
        mc.sd_s
    );
    if let (Some(a), Some(b)) = (m.spreads_only_sd_s, m.parameters_only_sd_s) {
        s.push_str(&format!(
            "  sd from the timing spreads alone {a:.2} s, from the fitted values' uncertainty alone {b:.2} s: the {} dominate\n",
            if m.dominant == "parameters" { "fitted values" } else { "timing spreads" }
        ));
    }
    s
}

/// What `--json` adds to the delivery, when asked for.
struct Extras<'a> {
    spots: Option<&'a [SpotRow]>,
    certificate: Option<&'a Certificate>,
    monte_carlo: Option<&'a arcsim_evaluator::MachineMonteCarlo>,
}

/// The `--json` result document.
fn write_json(
    path: &Path,
    args: &Args,
    (plan, plan_sha256, machine, machine_sha256): (
        &arcsim_plan::ArcPlan,
        &str,
        &arcsim_plan::Machine,
        &str,
    ),
    delivery: &Delivery,
    (warnings, notes, controller): (
        &[arcsim_plan::Warning],
        &[String],
        &arcsim_app::ControllerUsed,
    ),
    extras: &Extras,
) -> Result<(), CliError> {
    let from = arcsim_app::Provenance {
        plan_source: arcsim_app::Source {
            file: crate::input::input_name(&args.plan),
            sha256: plan_sha256.to_string(),
        },
        machine,
        machine_source: arcsim_app::Source {
            file: crate::input::machine_name(args.machine.as_deref()),
            sha256: machine_sha256.to_string(),
        },
        warnings,
        notes,
        strict: args.strict,
        controller,
    };
    let mut doc = arcsim_app::ResultDocument::new(plan, &from, delivery);
    if let Some(spots) = extras.spots {
        doc = doc.with_spots(spots);
    }
    if let Some(c) = extras.certificate {
        doc = doc.with_certificate(c);
    }
    if let Some(mc) = extras.monte_carlo {
        let value = serde_json::to_value(mc).map_err(|e| CliError::failed(e.to_string()))?;
        doc = doc.with_monte_carlo(value);
    }
    let text = doc.to_json().map_err(|e| CliError::failed(e.to_string()))?;
    crate::output::write_file(path, text.as_bytes())
}

pub fn run(args: Args) -> Result<(), CliError> {
    check_args(&args)?;
    let (plan, plan_sha256) = load_plan_hashed(&args.plan)?;
    let (machine, machine_sha256) = load_machine_hashed(args.machine.as_deref())?;
    let mut warnings =
        crate::input::plausibility(&plan, &args.plan, &machine, args.machine.as_deref());
    if let Some(ts) = args.period {
        let warning =
            arcsim_app::check_period(ts, "--period").map_err(|e| CliError::usage(e.to_string()))?;
        warnings.extend(warning);
    }
    crate::input::report_warnings(&warnings, args.strict)?;
    let request = arcsim_app::SimulateRequest {
        schedule: args.schedule.map(Schedule::from),
        motion: args.motion,
        arc_ends: args.arc_ends.into(),
        period_s: args.period,
    };
    let (opts, notes, controller) = request.resolve(&plan, &machine);
    for n in &notes {
        eprintln!("note: {n}");
    }
    check_monte_carlo(&args, &machine)?;
    let watch = Watch::new();
    let delivery = simulate_observed(&plan, &machine, &opts, &|p| watch.report(p));
    watch.finish();
    let delivery = delivery
        .map_err(|e| CliError::failed(format!("{}: {e}", crate::input::input_name(&args.plan))))?;
    check_sample_count(&args, &delivery)?;
    let certificate = match args.certify {
        true => Some(certificate(&plan, &machine, &delivery, &args.plan)?),
        false => None,
    };
    let monte_carlo = (args.monte_carlo)
        .map(|n| monte_carlo(&plan, &machine, &opts, n, args.seed, &args.plan))
        .transpose()?;
    let mut text = summary(&delivery, &plan.name, &machine.name);
    text.push_str(&crate::switching::of_delivery(&plan, &machine, &delivery));
    insert_controller_lines(&mut text, &controller, &delivery);
    if let Some(c) = &certificate {
        text.push_str(&certificate_lines(c, delivery.total_s, delivery.motion));
    }
    if let Some(mc) = &monte_carlo {
        text.push_str(&monte_carlo_lines(mc));
    }
    crate::output::print(&text);
    // The spot timeline for --spots and --log, and for the beam's-eye view of the Rerun outputs.
    let viewer = args.rrd.is_some() || args.spawn || args.connect.is_some();
    let spots = match args.spots.is_some() || args.log.is_some() || viewer {
        true => Some(spot_timeline(&plan, &machine, &delivery).map_err(|e| {
            CliError::failed(format!(
                "spot timeline: {}: {e}",
                crate::input::input_name(&args.plan)
            ))
        })?),
        false => None,
    };

    if let Some(path) = &args.json {
        let outputs = Extras {
            spots: spots.as_deref().filter(|_| args.spots.is_some()),
            certificate: certificate.as_ref(),
            monte_carlo: monte_carlo.as_ref(),
        };
        let inputs = (
            &plan,
            plan_sha256.as_str(),
            &machine,
            machine_sha256.as_str(),
        );
        write_json(
            path,
            &args,
            inputs,
            &delivery,
            (&warnings, &notes, &controller),
            &outputs,
        )?;
    }
    if let Some(path) = &args.csv {
        write_csv(path, &delivery, args.dt)?;
    }
    if let (Some(path), Some(spots)) = (&args.spots, &spots) {
        write_spots_csv(path, spots)?;
    }
    if let (Some(path), Some(spots)) = (&args.log, &spots) {
        write_log(path, &delivery, spots, &args)?;
    }
    crate::viewer::output(
        &delivery,
        spots.as_deref().unwrap_or_default(),
        &plan.name,
        args.dt,
        args.rrd.as_deref(),
        args.spawn,
        args.connect.as_deref(),
    )
}

/// A simulation's progress on a terminal (standard error), shown once it has run a second: a
/// plan of several hundred layers under free motion takes seconds.
struct Watch {
    bar: indicatif::ProgressBar,
    started: std::time::Instant,
    shown: std::sync::atomic::AtomicBool,
    terminal: bool,
}

impl Watch {
    /// How long a simulation runs before its progress is shown.
    const QUIET: std::time::Duration = std::time::Duration::from_secs(1);

    fn new() -> Watch {
        use std::io::IsTerminal;
        let bar = indicatif::ProgressBar::with_draw_target(
            Some(1),
            indicatif::ProgressDrawTarget::hidden(),
        );
        if let Ok(style) = indicatif::ProgressStyle::with_template("{elapsed} [{bar:30}] {msg}") {
            bar.set_style(style);
        }
        Watch {
            bar,
            started: std::time::Instant::now(),
            shown: std::sync::atomic::AtomicBool::new(false),
            terminal: std::io::stderr().is_terminal(),
        }
    }

    fn report(&self, p: arcsim_sequencer::Progress) {
        if !self.terminal || self.started.elapsed() < Self::QUIET {
            return;
        }
        if !self.shown.swap(true, std::sync::atomic::Ordering::Relaxed) {
            self.bar
                .set_draw_target(indicatif::ProgressDrawTarget::stderr());
        }
        let arcsim_sequencer::Progress::FreeMotion { step, steps, .. } = p;
        self.bar.set_length(steps as u64);
        self.bar.set_position(step as u64);
        self.bar.set_message(p.line());
    }

    fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

#[cfg(test)]
mod tests {
    use super::fixed;

    #[test]
    fn summary_numbers_never_show_a_signed_zero() {
        assert_eq!(fixed(-0.0, 2, 9), "     0.00");
        assert_eq!(fixed(-1e-12, 1, 5), "  0.0");
        assert_eq!(fixed(-0.5, 2, 0), "-0.50");
        assert_eq!(fixed(12.345, 2, 9), "    12.35");
    }
}
