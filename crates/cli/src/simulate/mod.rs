//! `arcsim simulate`: one plan on one machine with one speed schedule — total time, where it
//! goes, the tightest margins and the costliest transitions; JSON, CSV and Rerun outputs.
//! Here: the arguments, their checks and the run; [`summary`](mod@summary): the text printed;
//! [`outputs`]: the files written.

use std::path::{Path, PathBuf};

use arcsim_sequencer::{
    certify, machine_limits, simulate_observed, spot_timeline, ArcEnds, Certificate, Delivery,
    Motion, Schedule, CERTIFY_ROUNDS,
};

use crate::input::{load_machine_hashed, load_plan_with_bytes, sha256_hex};
use crate::CliError;

mod outputs;
mod summary;

use outputs::{log_options, write_csv, write_json, write_log, write_spots_csv, Extras};
use summary::{certificate_lines, monte_carlo_lines};
pub use summary::{insert_controller_lines, summary};

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

fn parse_iba_layout(text: &str) -> Result<arcsim_log::iba::IbaLayout, String> {
    text.parse()
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
    /// Write the delivery as the oncology information system would record it: a DICOM RT Ion
    /// Beams Treatment Record, each layer a pair of control points (beam on, beam off) with its
    /// time, gantry angle, energy and cumulative delivered MU; one beam per arc.
    #[arg(long, value_name = "RECORD.dcm")]
    record: Option<PathBuf>,
    /// Write the delivery as an IBA-style log: a folder with one beam folder per arc, each
    /// holding a `map_record` (a row per 0.25 ms) and `map_specif` file per layer, `beam_config`,
    /// `beam` and the arc irradiation `events` (docs/records.md#iba-logs).
    #[arg(long, value_name = "DIR")]
    iba_log: Option<PathBuf>,
    /// The recorder's layout of `--iba-log`: `rows` (a `map_record` row per 0.25 ms with
    /// `SUBMAP_NUMBER` and `TIME`), `elements` (`map_record` elements with `SPOT_ID` and a
    /// microsecond `FPGA_COUNT`) or `bursts` (a synchrocyclotron's `burst_record`, an element
    /// per 1 ms pulse).
    #[arg(long, value_name = "LAYOUT", default_value = "rows", value_parser = parse_iba_layout)]
    iba_layout: arcsim_log::iba::IbaLayout,
    /// When the record's (and the IBA-style log's) first layer starts: YYYYMMDDHHMMSS.
    #[arg(long, value_name = "WHEN", default_value = "20260101080000")]
    record_start: String,
    /// Fraction digits of the record's times (0: whole seconds, 6: microseconds).
    #[arg(long, value_name = "N", default_value_t = 3)]
    record_time_digits: u32,
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
            ("--record", args.record.as_deref()),
            ("--iba-log", args.iba_log.as_deref()),
        ],
    )?;
    if let Some(dir) = &args.iba_log {
        if dir.exists() && std::fs::read_dir(dir).map_or(true, |mut d| d.next().is_some()) {
            return Err(CliError::usage(format!(
                "--iba-log {}: exists and is not an empty folder; expected a new folder",
                dir.display()
            )));
        }
    }
    if args.record.is_some() || args.iba_log.is_some() {
        arcsim_dicom::RecordStart::parse(&args.record_start)
            .map_err(|e| CliError::usage(format!("--record-start {e}")))?;
        if args.record_time_digits > 6 {
            return Err(CliError::usage(format!(
                "--record-time-digits {}: expected 0 to 6 (a DICOM time holds at most microseconds)",
                args.record_time_digits
            )));
        }
    }
    Ok(())
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

pub fn run(args: Args) -> Result<(), CliError> {
    check_args(&args)?;
    let (plan, plan_bytes) = load_plan_with_bytes(&args.plan)?;
    let plan_sha256 = sha256_hex(&plan_bytes);
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
    let spots = spot_rows(&args, &plan, &machine, &delivery)?;

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
    if let (Some(dir), Some(spots)) = (&args.iba_log, &spots) {
        outputs::write_iba_log(dir, &delivery, spots, &args)?;
    }
    if let Some(path) = &args.record {
        outputs::write_record(path, &delivery, (&plan, &machine, &plan_bytes), &args)?;
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

/// The spot timeline for --spots, --log and --iba-log, and for the beam's-eye view of the Rerun
/// outputs; `None` when no output needs it.
fn spot_rows(
    args: &Args,
    plan: &arcsim_plan::ArcPlan,
    machine: &arcsim_plan::Machine,
    delivery: &Delivery,
) -> Result<Option<Vec<arcsim_sequencer::SpotRow>>, CliError> {
    let viewer = args.rrd.is_some() || args.spawn || args.connect.is_some();
    if !(args.spots.is_some() || args.log.is_some() || args.iba_log.is_some() || viewer) {
        return Ok(None);
    }
    spot_timeline(plan, machine, delivery)
        .map(Some)
        .map_err(|e| {
            CliError::failed(format!(
                "spot timeline: {}: {e}",
                crate::input::input_name(&args.plan)
            ))
        })
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
