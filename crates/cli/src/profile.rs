//! `arcsim profile`: one minimum-time jerk-limited move, or a batch of moves from a CSV file.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use arcsim_app::{MoveRequest, SolvedMove};
use arcsim_evaluator::CsvLineNumbers;
use arcsim_planner::{Move, PlannerError, Profile, Reversal, State};
use serde::Serialize;

use crate::table::{csv_table, Column};
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

enum Outcome {
    Ok(Box<SolvedMove>),
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

fn solve(request: &MoveRequest) -> Outcome {
    match request.solve() {
        Ok(s) => Outcome::Ok(Box::new(s)),
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

fn describe(s: &SolvedMove) -> ProfileOut {
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
        extreme_speed_deg_per_s: s.profile.seven_phases().map(|ts| ts.direction * ts.v_peak),
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
            "--dt {}: expected a finite number > 0",
            arcsim_plan::fmt_num(dt)
        )));
    }
    if profile.duration() / dt > 5e7 {
        return Err(CliError::usage(format!(
            "--dt {} would write more than 5e7 samples",
            arcsim_plan::fmt_num(dt)
        )));
    }
    let table = csv_table(&SAMPLE_COLUMNS, profile.samples(dt));
    crate::output::write_file(path, &table)
}

/// The columns of `profile --csv`: one sample of the move.
const SAMPLE_COLUMNS: [Column<(f64, State)>; 5] = [
    Column {
        name: "t_s",
        get: |(t, _)| t.to_string(),
    },
    Column {
        name: "angle_deg",
        get: |(_, s)| s.position.to_string(),
    },
    Column {
        name: "speed_deg_per_s",
        get: |(_, s)| s.velocity.to_string(),
    },
    Column {
        name: "accel_deg_per_s2",
        get: |(_, s)| s.acceleration.to_string(),
    },
    Column {
        name: "jerk_deg_per_s3",
        get: |(_, s)| s.jerk.to_string(),
    },
];

pub fn run(args: Args) -> Result<(), CliError> {
    if let Some(batch) = &args.batch {
        return run_batch(batch, args.out.as_deref(), args.reverse.into());
    }
    crate::output::check_outputs(&[], &[("--csv", args.csv.as_deref())])?;
    let need = |v: Option<f64>, name: &str| {
        v.ok_or_else(|| CliError::usage(format!("--{name} is required")))
    };
    let spec = MoveRequest {
        mv: Move {
            distance: need(args.distance, "distance")?,
            v_start: need(args.v_start, "v-start")?,
            v_end: need(args.v_end, "v-end")?,
        },
        jerk_deg_per_s3: need(args.jerk, "jerk")?,
        accel_deg_per_s2: need(args.accel, "accel")?,
        decel_deg_per_s2: args.decel,
        speed_deg_per_s: need(args.vel, "vel")?,
        min_duration_s: args.min_duration,
        period_s: args.period,
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

/// One column of a batch input: its name, whether every input must have it, and how its field
/// (trimmed, not empty) sets the move. Columns are found by name, in any order.
struct InputColumn {
    name: &'static str,
    required: bool,
    set: fn(&mut MoveRequest, &str) -> Result<(), String>,
}

const INPUT_COLUMNS: [InputColumn; 10] = [
    InputColumn {
        name: "distance",
        required: true,
        set: |m, t| {
            m.mv.distance = finite(t)?;
            Ok(())
        },
    },
    InputColumn {
        name: "v_start",
        required: true,
        set: |m, t| {
            m.mv.v_start = finite(t)?;
            Ok(())
        },
    },
    InputColumn {
        name: "v_end",
        required: true,
        set: |m, t| {
            m.mv.v_end = finite(t)?;
            Ok(())
        },
    },
    InputColumn {
        name: "jerk",
        required: true,
        set: |m, t| {
            m.jerk_deg_per_s3 = finite(t)?;
            Ok(())
        },
    },
    InputColumn {
        name: "accel",
        required: true,
        set: |m, t| {
            m.accel_deg_per_s2 = finite(t)?;
            Ok(())
        },
    },
    InputColumn {
        name: "vel",
        required: true,
        set: |m, t| {
            m.speed_deg_per_s = finite(t)?;
            Ok(())
        },
    },
    InputColumn {
        name: "decel",
        required: false,
        set: |m, t| {
            m.decel_deg_per_s2 = Some(finite(t)?);
            Ok(())
        },
    },
    InputColumn {
        name: "min_duration",
        required: false,
        set: |m, t| {
            m.min_duration_s = Some(finite(t)?);
            Ok(())
        },
    },
    InputColumn {
        name: "period",
        required: false,
        set: |m, t| {
            m.period_s = Some(finite(t)?);
            Ok(())
        },
    },
    InputColumn {
        name: "reverse",
        required: false,
        set: |m, t| {
            m.reverse = if t.eq_ignore_ascii_case("allow") {
                Reversal::Allow
            } else if t.eq_ignore_ascii_case("forbid") {
                Reversal::Forbid
            } else {
                return Err(format!("'{t}' is not allow or forbid"));
            };
            Ok(())
        },
    },
];

/// A finite number, or what was wrong.
fn finite(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("'{text}' is not a finite number")),
    }
}

/// The positions of [`INPUT_COLUMNS`] in a batch input's header (`None`: not in the input).
fn input_header(
    names: &csv::StringRecord,
    file: &str,
) -> Result<[Option<usize>; INPUT_COLUMNS.len()], CliError> {
    let heads: Vec<String> = names
        .iter()
        .map(|h| h.trim().to_ascii_lowercase())
        .collect();
    if heads.iter().all(String::is_empty) {
        return Err(CliError::failed(format!(
            "{file}: empty file, expected a header line"
        )));
    }
    let mut at = [None; INPUT_COLUMNS.len()];
    for (i, h) in heads.iter().enumerate() {
        let Some(k) = INPUT_COLUMNS.iter().position(|c| c.name == h) else {
            return Err(CliError::failed(format!(
                "{file}: line 1: unknown column '{h}'"
            )));
        };
        if at[k].replace(i).is_some() {
            return Err(CliError::failed(format!(
                "{file}: line 1: column '{h}' appears twice"
            )));
        }
    }
    if let Some(c) = INPUT_COLUMNS
        .iter()
        .zip(&at)
        .find_map(|(c, i)| (c.required && i.is_none()).then_some(c))
    {
        let required: Vec<&str> = INPUT_COLUMNS
            .iter()
            .filter(|c| c.required)
            .map(|c| c.name)
            .collect();
        return Err(CliError::failed(format!(
            "{file}: line 1: header lacks the column '{}' (need {})",
            c.name,
            required.join(",")
        )));
    }
    Ok(at)
}

/// Parses one data row into a move; the error names the column and the value.
fn parse_row(
    at: &[Option<usize>; INPUT_COLUMNS.len()],
    record: &csv::StringRecord,
    columns: usize,
    default_reverse: Reversal,
) -> Result<MoveRequest, String> {
    if record.len() != columns {
        return Err(format!(
            "{} fields; expected {columns} (as the header)",
            record.len()
        ));
    }
    let mut spec = MoveRequest {
        mv: Move {
            distance: f64::NAN,
            v_start: f64::NAN,
            v_end: f64::NAN,
        },
        jerk_deg_per_s3: f64::NAN,
        accel_deg_per_s2: f64::NAN,
        decel_deg_per_s2: None,
        speed_deg_per_s: f64::NAN,
        min_duration_s: None,
        period_s: None,
        reverse: default_reverse,
    };
    for (c, i) in INPUT_COLUMNS.iter().zip(at) {
        match i.and_then(|i| record.get(i)).map(str::trim) {
            Some(t) if !t.is_empty() => {
                (c.set)(&mut spec, t).map_err(|e| format!("field {}: {e}", c.name))?
            }
            _ if c.required => return Err(format!("field {}: missing value", c.name)),
            _ => {}
        }
    }
    Ok(spec)
}

/// One line of the `--batch` output.
struct BatchLine {
    /// The line of the move in the input file.
    line: usize,
    status: &'static str,
    duration_s: Option<f64>,
    peak_speed: Option<f64>,
    message: String,
}

/// The columns of the `--batch` output.
const BATCH_COLUMNS: [Column<BatchLine>; 5] = [
    Column {
        name: "line",
        get: |r| r.line.to_string(),
    },
    Column {
        name: "status",
        get: |r| r.status.to_string(),
    },
    Column {
        name: "duration_s",
        get: |r| r.duration_s.map(|v| v.to_string()).unwrap_or_default(),
    },
    Column {
        name: "peak_speed",
        get: |r| r.peak_speed.map(|v| v.to_string()).unwrap_or_default(),
    },
    Column {
        name: "message",
        get: |r| r.message.clone(),
    },
];

/// The result of the move of input line `line`.
fn batch_line(line: usize, parsed: Result<MoveRequest, String>) -> BatchLine {
    let (status, duration_s, peak_speed, message) = match parsed.map(|s| solve(&s)) {
        Err(m) | Ok(Outcome::Error(m)) => ("error", None, None, m),
        Ok(Outcome::Infeasible(m)) => ("infeasible", None, None, m),
        Ok(Outcome::Ok(s)) => {
            let d = describe(&s);
            (
                "ok",
                Some(d.duration_s),
                Some(d.peak_speed_deg_per_s),
                String::new(),
            )
        }
    };
    BatchLine {
        line,
        status,
        duration_s,
        peak_speed,
        message,
    }
}

fn run_batch(input: &Path, out: Option<&Path>, default_reverse: Reversal) -> Result<(), CliError> {
    crate::output::check_outputs(&[input], &[("--out", out)])?;
    let text = crate::input::read_text(input)?;
    let file = input.display().to_string();
    // Quoted fields, a byte-order mark and CRLF line ends read; a line of another length is a
    // row error, not the end of the batch.
    let mut reader = csv::ReaderBuilder::new()
        .flexible(true)
        .from_reader(text.as_bytes());
    let header = reader
        .headers()
        .map_err(|e| CliError::failed(format!("{file}: {e}")))?;
    let at = input_header(header, &file)?;
    let columns = header.len();
    let mut lines = CsvLineNumbers::new(&text);
    let mut results = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|e| CliError::failed(format!("{file}: {e}")))?;
        if record.iter().all(|f| f.trim().is_empty()) {
            continue;
        }
        let line = lines.at(record.position().map_or(0, |p| p.byte()));
        results.push(batch_line(
            line,
            parse_row(&at, &record, columns, default_reverse),
        ));
    }
    let count = |status: &str| results.iter().filter(|r| r.status == status).count();
    let (ok, infeasible, errors) = (count("ok"), count("infeasible"), count("error"));
    let report = csv_table(&BATCH_COLUMNS, results);
    match out {
        Some(p) => crate::output::write_file(p, &report)?,
        None => crate::output::print(&String::from_utf8_lossy(&report)),
    }
    eprintln!(
        "{}: {ok} ok, {infeasible} infeasible, {errors} with an error",
        crate::count(ok + infeasible + errors, "row")
    );
    Ok(())
}
