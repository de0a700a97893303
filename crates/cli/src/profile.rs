//! `arcsim profile`: one minimum-time jerk-limited move, or a batch of moves from a CSV file.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use arcsim_planner::{Limits, Move, PlannerError, Profile, Reversal};
use serde::Serialize;

use crate::CliError;

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ReverseArg {
    /// The axis may first move backwards (time-optimal, as Ruckig).
    Allow,
    /// Speed stays along the direction of travel (a gantry inside an arc).
    Forbid,
}

impl From<ReverseArg> for Reversal {
    fn from(r: ReverseArg) -> Self {
        match r {
            ReverseArg::Allow => Reversal::Allow,
            ReverseArg::Forbid => Reversal::Forbid,
        }
    }
}

#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("mode").required(true).args(["batch", "distance"])))]
pub struct Args {
    /// Distance to cover (deg; negative moves the other way).
    #[arg(long, allow_hyphen_values = true, requires_all = ["v_start", "v_end", "jerk", "accel", "vel"])]
    distance: Option<f64>,
    /// Speed at the start (deg/s).
    #[arg(long, allow_hyphen_values = true)]
    v_start: Option<f64>,
    /// Speed at the end (deg/s).
    #[arg(long, allow_hyphen_values = true)]
    v_end: Option<f64>,
    /// Maximum jerk J (deg/s³).
    #[arg(long, allow_hyphen_values = true)]
    jerk: Option<f64>,
    /// Maximum acceleration A (deg/s²).
    #[arg(long, allow_hyphen_values = true)]
    accel: Option<f64>,
    /// Maximum deceleration (deg/s²); defaults to --accel.
    #[arg(long, allow_hyphen_values = true)]
    decel: Option<f64>,
    /// Maximum speed V (deg/s).
    #[arg(long, allow_hyphen_values = true)]
    vel: Option<f64>,
    /// The move must last at least this long (s), e.g. an energy-layer switching time.
    #[arg(long, allow_hyphen_values = true)]
    min_duration: Option<f64>,
    /// Servo period (s): every phase becomes a whole number of periods.
    #[arg(long, allow_hyphen_values = true)]
    period: Option<f64>,
    /// Whether the axis may move backwards when the end speed is out of reach.
    #[arg(long, value_enum, default_value_t = ReverseArg::Forbid)]
    reverse: ReverseArg,
    /// Print the result as JSON.
    #[arg(long)]
    json: bool,
    /// Write samples of the profile to this CSV file.
    #[arg(long, requires = "dt")]
    csv: Option<PathBuf>,
    /// Sampling step for --csv (s).
    #[arg(long, allow_hyphen_values = true)]
    dt: Option<f64>,
    /// Solve every move of a CSV file (header: distance,v_start,v_end,jerk,accel,vel and
    /// optionally decel,min_duration,period,reverse).
    #[arg(long, conflicts_with_all = ["distance", "json", "csv"])]
    batch: Option<PathBuf>,
    /// Output CSV for --batch (default: standard output).
    #[arg(long, requires = "batch")]
    out: Option<PathBuf>,
}

/// One move as the user specified it.
#[derive(Clone, Debug)]
struct MoveSpec {
    mv: Move,
    jerk: f64,
    accel: f64,
    decel: Option<f64>,
    vel: f64,
    min_duration: Option<f64>,
    period: Option<f64>,
    reverse: Reversal,
}

struct Solved {
    profile: Profile,
    limits: Limits,
    added_time_s: Option<f64>,
}

enum Outcome {
    Ok(Box<Solved>),
    /// No profile under the chosen policy; the message says what is reachable.
    Infeasible(String),
    /// Bad input values.
    Error(String),
}

fn classify(err: PlannerError) -> Outcome {
    match err {
        PlannerError::Unreachable { .. }
        | PlannerError::DurationInfeasible { .. }
        | PlannerError::PeriodTooCoarse { .. } => Outcome::Infeasible(err.to_string()),
        _ => Outcome::Error(err.to_string()),
    }
}

fn solve(spec: &MoveSpec) -> Outcome {
    let request = arcsim_app::MoveRequest {
        mv: spec.mv,
        jerk_deg_per_s3: spec.jerk,
        accel_deg_per_s2: spec.accel,
        decel_deg_per_s2: spec.decel,
        speed_deg_per_s: spec.vel,
        min_duration_s: spec.min_duration,
        period_s: spec.period,
        reverse: spec.reverse,
    };
    match request.solve() {
        Ok(s) => Outcome::Ok(Box::new(Solved {
            profile: s.profile,
            limits: s.limits,
            added_time_s: s.added_time_s,
        })),
        Err(arcsim_app::MoveError::Planner(e)) => classify(e),
        Err(e) => Outcome::Error(e.to_string()),
    }
}

#[derive(Serialize)]
struct PhaseOut {
    start_s: f64,
    duration_s: f64,
    jerk_deg_per_s3: f64,
    speed_at_start_deg_per_s: f64,
    accel_at_start_deg_per_s2: f64,
}

#[derive(Serialize)]
struct ProfileOut {
    duration_s: f64,
    peak_speed_deg_per_s: f64,
    extreme_speed_deg_per_s: Option<f64>,
    servo_added_time_s: Option<f64>,
    speed_use: f64,
    accel_use: f64,
    jerk_use: f64,
    phases: Vec<PhaseOut>,
}

fn describe(s: &Solved) -> ProfileOut {
    let e = s.profile.extrema();
    let mut t = 0.0;
    let phases = s
        .profile
        .segments()
        .iter()
        .map(|seg| {
            let st = s.profile.state_at(t);
            let out = PhaseOut {
                start_s: t,
                duration_s: seg.duration,
                jerk_deg_per_s3: seg.jerk,
                speed_at_start_deg_per_s: st.velocity,
                accel_at_start_deg_per_s2: st.acceleration,
            };
            t += seg.duration;
            out
        })
        .collect();
    let peak = e.max_velocity.max(-e.min_velocity);
    ProfileOut {
        duration_s: s.profile.duration(),
        peak_speed_deg_per_s: peak,
        extreme_speed_deg_per_s: s.profile.two_step().map(|ts| ts.direction * ts.v_peak),
        servo_added_time_s: s.added_time_s,
        speed_use: peak / s.limits.max_vel,
        accel_use: e.max_acceleration.max(-e.min_acceleration)
            / s.limits.max_accel.max(s.limits.max_decel),
        jerk_use: e.max_abs_jerk / s.limits.max_jerk,
        phases,
    }
}

fn print_text(out: &ProfileOut) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "phase  start (s)   duration (s)   jerk (deg/s³)   speed at start (deg/s)"
    );
    for (i, p) in out.phases.iter().enumerate() {
        let _ = writeln!(
            s,
            "{:>5}  {:>9.6}   {:>12.9}   {:>13.6}   {:>22.6}",
            i + 1,
            p.start_s,
            p.duration_s,
            p.jerk_deg_per_s3,
            p.speed_at_start_deg_per_s
        );
    }
    let _ = writeln!(s, "total time: {:.9} s", out.duration_s);
    if let Some(added) = out.servo_added_time_s {
        let _ = writeln!(
            s,
            "servo grid: +{added:.9} s against the continuous profile"
        );
    }
    let _ = writeln!(s, "peak speed: {:.6} deg/s", out.peak_speed_deg_per_s);
    if let Some(c) = out.extreme_speed_deg_per_s {
        let _ = writeln!(s, "extreme speed v_m (signed): {c:.6} deg/s");
    }
    let _ = writeln!(
        s,
        "limits used: speed {:.1}%, acceleration {:.1}%, jerk {:.1}%",
        100.0 * out.speed_use,
        100.0 * out.accel_use,
        100.0 * out.jerk_use
    );
    s
}

fn write_samples(path: &Path, profile: &Profile, dt: f64) -> Result<(), CliError> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(CliError::usage(format!(
            "--dt {dt}: expected a finite number > 0"
        )));
    }
    if profile.duration() / dt > 5e7 {
        return Err(CliError::usage(format!(
            "--dt {dt} would write more than 5e7 samples"
        )));
    }
    let mut s = String::from("t_s,angle_deg,speed_deg_per_s,accel_deg_per_s2,jerk_deg_per_s3\n");
    for (t, st) in profile.samples(dt) {
        let _ = writeln!(
            s,
            "{t},{},{},{},{}",
            st.position, st.velocity, st.acceleration, st.jerk
        );
    }
    crate::output::write_file(path, s.as_bytes())
}

pub fn run(args: Args) -> Result<(), CliError> {
    if let Some(batch) = &args.batch {
        return run_batch(batch, args.out.as_deref(), args.reverse.into());
    }
    crate::output::check_outputs(&[], &[("--csv", args.csv.as_deref())])?;
    let need = |v: Option<f64>, name: &str| {
        v.ok_or_else(|| CliError::usage(format!("--{name} is required")))
    };
    let spec = MoveSpec {
        mv: Move {
            distance: need(args.distance, "distance")?,
            v_start: need(args.v_start, "v-start")?,
            v_end: need(args.v_end, "v-end")?,
        },
        jerk: need(args.jerk, "jerk")?,
        accel: need(args.accel, "accel")?,
        decel: args.decel,
        vel: need(args.vel, "vel")?,
        min_duration: args.min_duration,
        period: args.period,
        reverse: args.reverse.into(),
    };
    let solved = match solve(&spec) {
        Outcome::Ok(s) => s,
        Outcome::Infeasible(m) => return Err(CliError::failed(format!("infeasible: {m}"))),
        Outcome::Error(m) => return Err(CliError::usage(m)),
    };
    let out = describe(&solved);
    if args.json {
        let text =
            serde_json::to_string_pretty(&out).map_err(|e| CliError::failed(e.to_string()))?;
        crate::output::println(&text);
    } else {
        crate::output::print(&print_text(&out));
    }
    if let (Some(path), Some(dt)) = (&args.csv, args.dt) {
        write_samples(path, &solved.profile, dt)?;
    }
    Ok(())
}

/// Quotes a CSV field when it needs it.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

const REQUIRED: [&str; 6] = ["distance", "v_start", "v_end", "jerk", "accel", "vel"];
const OPTIONAL: [&str; 4] = ["decel", "min_duration", "period", "reverse"];

/// Parses one data row into a move; the error names the field and the value.
fn parse_row(
    cols: &[usize; 10],
    cells: &[&str],
    default_reverse: Reversal,
) -> Result<MoveSpec, String> {
    let names: Vec<&str> = REQUIRED.iter().chain(OPTIONAL.iter()).copied().collect();
    let cell = |k: usize| -> Option<&str> {
        let i = cols[k];
        if i == usize::MAX {
            return None;
        }
        cells.get(i).map(|c| c.trim()).filter(|c| !c.is_empty())
    };
    let num = |k: usize| -> Result<Option<f64>, String> {
        match cell(k) {
            None => Ok(None),
            Some(text) => match text.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(Some(v)),
                _ => Err(format!(
                    "field {}: '{text}' is not a finite number",
                    names[k]
                )),
            },
        }
    };
    let req = |k: usize| -> Result<f64, String> {
        num(k)?.ok_or_else(|| format!("field {}: missing value", names[k]))
    };
    let reverse = match cell(9) {
        None => default_reverse,
        Some(t) if t.eq_ignore_ascii_case("allow") => Reversal::Allow,
        Some(t) if t.eq_ignore_ascii_case("forbid") => Reversal::Forbid,
        Some(t) => return Err(format!("field reverse: '{t}' is not allow or forbid")),
    };
    Ok(MoveSpec {
        mv: Move {
            distance: req(0)?,
            v_start: req(1)?,
            v_end: req(2)?,
        },
        jerk: req(3)?,
        accel: req(4)?,
        vel: req(5)?,
        decel: num(6)?,
        min_duration: num(7)?,
        period: num(8)?,
        reverse,
    })
}

fn run_batch(input: &Path, out: Option<&Path>, default_reverse: Reversal) -> Result<(), CliError> {
    crate::output::check_outputs(&[input], &[("--out", out)])?;
    let text = crate::input::read_text(input)?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        return Err(CliError::failed(format!(
            "{}: empty file, expected a header line",
            input.display()
        )));
    };
    let heads: Vec<String> = header
        .split(',')
        .map(|h| h.trim().to_ascii_lowercase())
        .collect();
    let mut cols = [usize::MAX; 10];
    for (k, name) in REQUIRED.iter().chain(OPTIONAL.iter()).enumerate() {
        if let Some(i) = heads.iter().position(|h| h == name) {
            cols[k] = i;
        }
    }
    for (k, name) in REQUIRED.iter().enumerate() {
        if cols[k] == usize::MAX {
            return Err(CliError::failed(format!(
                "{}: line 1: header lacks the column '{name}' (need {})",
                input.display(),
                REQUIRED.join(",")
            )));
        }
    }
    if let Some(unknown) = heads
        .iter()
        .find(|h| !REQUIRED.contains(&h.as_str()) && !OPTIONAL.contains(&h.as_str()))
    {
        return Err(CliError::failed(format!(
            "{}: line 1: unknown column '{unknown}'",
            input.display()
        )));
    }
    let mut report = String::from("line,status,duration_s,peak_speed,message\n");
    let (mut ok, mut infeasible, mut errors) = (0, 0, 0);
    for (i, line) in lines {
        let cells: Vec<&str> = line.split(',').collect();
        let (status, duration, peak, message) =
            match parse_row(&cols, &cells, default_reverse).map(|s| solve(&s)) {
                Err(m) | Ok(Outcome::Error(m)) => {
                    errors += 1;
                    ("error", String::new(), String::new(), m)
                }
                Ok(Outcome::Infeasible(m)) => {
                    infeasible += 1;
                    ("infeasible", String::new(), String::new(), m)
                }
                Ok(Outcome::Ok(s)) => {
                    ok += 1;
                    let d = describe(&s);
                    (
                        "ok",
                        format!("{}", d.duration_s),
                        format!("{}", d.peak_speed_deg_per_s),
                        String::new(),
                    )
                }
            };
        let _ = writeln!(
            report,
            "{},{status},{duration},{peak},{}",
            i + 1,
            csv_field(&message)
        );
    }
    match out {
        Some(p) => crate::output::write_file(p, report.as_bytes())?,
        None => crate::output::print(&report),
    }
    eprintln!(
        "{}: {ok} ok, {infeasible} infeasible, {errors} with an error",
        crate::count(ok + infeasible + errors, "row")
    );
    Ok(())
}
