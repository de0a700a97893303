//! A loaded sweep: its plans and base machine read, its axes checked into one grid per schedule.
//!
//! Combinations are numbered plan-major: for each plan (in file order, glob matches sorted), for
//! each schedule entry, every grid point, with the jerk varying fastest, then acceleration, speed,
//! downward ELST, upward ELST, window, scanning speed and dose-rate scale (slowest).
//!
//! Nothing here is proportional to the number of combinations: a grid keeps its axes as written
//! (a range is its ends and step count), and [`Grid::setting`] decodes a grid index by mixed radix,
//! computing each axis value on demand. A sweep of more than [`MAX_COMBINATIONS`] combinations is
//! refused when it is loaded.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::RunMode;
use arcsim_plan::{ArcPlan, BeamModel, ElstModel, Machine};
use serde::Serialize;

use crate::sweep_file::{parse_sweep_file, Axes, AxisSpec, PlanSource, Scale, SweepFile, Target};
use crate::EvalError;

/// The most combinations (plans × grid points of every schedule entry) a sweep may have; also the
/// most values one axis may have. A sweep over it is refused when it is loaded, with its size:
/// its rows are kept in memory for the summary, and at thousands of evaluations per second it
/// would run for days.
pub const MAX_COMBINATIONS: usize = 100_000_000;

/// One plan of the sweep.
#[derive(Debug, Clone)]
pub struct SweepPlan {
    /// How rows name it: the path relative to the sweep file, `atom:CASE`, or the entry's `name`.
    pub label: String,
    pub plan: ArcPlan,
}

/// The machine values of one combination. `None` keeps the base machine's (or plan's) value.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Setting {
    pub jerk_deg_per_s3: f64,
    pub accel_deg_per_s2: f64,
    pub speed_deg_per_s: f64,
    pub elst_up_s: Option<f64>,
    pub elst_down_s: Option<f64>,
    pub window_deg: Option<f64>,
    /// Scanning speed of a `scanning` beam model (mm/s, both axes).
    pub scan_speed_mm_per_s: Option<f64>,
    /// Dose-rate scale: every time per MU of the beam model divided by it (2: twice the dose rate).
    pub dose_rate_scale: Option<f64>,
}

/// The base machine's values of the limits a [`Setting`] may leave unset (`None`): what a
/// combination that does not sweep them runs with, and what the CSV's limit columns hold for them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Defaults {
    /// Upward ELST (s); `None` for a polynomial ELST model (no single value; the axis cannot be
    /// swept then).
    pub elst_up_s: Option<f64>,
    /// Downward ELST (s).
    pub elst_down_s: f64,
    /// The machine's default window (deg). Control points with a window of their own keep it
    /// unless the window is swept.
    pub window_deg: f64,
    /// The scanning speed (mm/s) of a `scanning` beam model with one speed for both axes; `None`
    /// for a `per_mu` model (no scanning speed) or separate x and y speeds (no single value).
    pub scan_speed_mm_per_s: Option<f64>,
    /// The dose-rate scale of the base machine: 1.
    pub dose_rate_scale: f64,
}

/// The values of every axis for one schedule entry, kept as written: a range is computed value
/// by value when needed ([`AxisSpec::value`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// J (an absent axis is the base machine's value, one value).
    pub jerk: AxisSpec,
    /// A (as `jerk`).
    pub accel: AxisSpec,
    /// V (as `jerk`).
    pub speed: AxisSpec,
    /// Upward ELST; `None`: the base machine's (one grid point).
    pub elst_up: Option<AxisSpec>,
    /// Downward ELST; `None`: the base machine's (one grid point).
    pub elst_down: Option<AxisSpec>,
    /// Window; `None`: the plan's and machine's (one grid point).
    pub window: Option<AxisSpec>,
    /// Scanning speed; `None`: the base machine's beam model (one grid point).
    pub scan_speed: Option<AxisSpec>,
    /// Dose-rate scale; `None`: the base machine's beam model (one grid point).
    pub dose_rate_scale: Option<AxisSpec>,
}

/// One schedule entry of a sweep: how it moves (schedule, motion, arc ends) and the grid of
/// settings it is evaluated at.
#[derive(Debug, Clone, PartialEq)]
pub struct ScheduleGrid {
    pub schedule: RunMode,
    pub grid: Grid,
}

/// A sweep ready to evaluate.
#[derive(Debug, Clone)]
pub struct Sweep {
    pub name: String,
    pub description: Option<String>,
    /// The sweep file as named on the command line.
    pub source: String,
    pub plans: Vec<SweepPlan>,
    pub machine: Machine,
    /// The schedule entries, in the sweep file's order (a plan's combinations follow it).
    pub schedule_grids: Vec<ScheduleGrid>,
    /// Build timelines so rows carry kinematic margins.
    pub margins: bool,
    /// Certify every constant-speed row (lower bound and gap).
    pub certify: bool,
    pub target: Target,
    /// Every file the sweep file names and that was read (the machine, the plans, ATOM reference
    /// files), as joined to the sweep file's directory: a command must not write over them.
    pub inputs: Vec<PathBuf>,
}

/// The axes, in the order of [`Axis::ALL`] (also the order of the summary's columns).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Axis {
    Jerk,
    Accel,
    Speed,
    ElstUp,
    ElstDown,
    Window,
    /// Scanning speed of a `scanning` beam model (mm/s).
    ScanSpeed,
    /// Dose-rate scale of the beam model (dimensionless; 2: twice the dose rate).
    DoseRateScale,
}

impl Axis {
    pub const ALL: [Axis; 8] = [
        Axis::Jerk,
        Axis::Accel,
        Axis::Speed,
        Axis::ElstUp,
        Axis::ElstDown,
        Axis::Window,
        Axis::ScanSpeed,
        Axis::DoseRateScale,
    ];

    /// The gantry's own limits (J, A, V): raising one admits every timeline the lower value
    /// admitted, so it never makes the best delivery longer.
    pub fn is_gantry_limit(self) -> bool {
        matches!(self, Axis::Jerk | Axis::Accel | Axis::Speed)
    }

    /// The field name in sweep files and output columns.
    pub fn field(self) -> &'static str {
        match self {
            Axis::Jerk => "jerk_deg_per_s3",
            Axis::Accel => "accel_deg_per_s2",
            Axis::Speed => "speed_deg_per_s",
            Axis::ElstUp => "elst_up_s",
            Axis::ElstDown => "elst_down_s",
            Axis::Window => "window_deg",
            Axis::ScanSpeed => "scan_speed_mm_per_s",
            Axis::DoseRateScale => "dose_rate_scale",
        }
    }

    /// The unit as figures and plot titles print it ("°/s³"; [`Axis::symbol`] has the plain-text
    /// one of the tables).
    pub fn unit(self) -> &'static str {
        match self {
            Axis::Jerk => "°/s³",
            Axis::Accel => "°/s²",
            Axis::Speed => "°/s",
            Axis::ElstUp | Axis::ElstDown => "s",
            Axis::Window => "°",
            Axis::ScanSpeed => "mm/s",
            Axis::DoseRateScale => "×",
        }
    }

    /// Short symbol and unit for tables ("J", "deg/s^3").
    pub fn symbol(self) -> (&'static str, &'static str) {
        match self {
            Axis::Jerk => ("J", "deg/s^3"),
            Axis::Accel => ("A", "deg/s^2"),
            Axis::Speed => ("V", "deg/s"),
            Axis::ElstUp => ("ELST up", "s"),
            Axis::ElstDown => ("ELST down", "s"),
            Axis::Window => ("window", "deg"),
            Axis::ScanSpeed => ("scan speed", "mm/s"),
            Axis::DoseRateScale => ("dose rate", "×"),
        }
    }
}

impl Setting {
    /// The value of one axis (`None`: as in the base machine or plan).
    pub fn get(&self, axis: Axis) -> Option<f64> {
        match axis {
            Axis::Jerk => Some(self.jerk_deg_per_s3),
            Axis::Accel => Some(self.accel_deg_per_s2),
            Axis::Speed => Some(self.speed_deg_per_s),
            Axis::ElstUp => self.elst_up_s,
            Axis::ElstDown => self.elst_down_s,
            Axis::Window => self.window_deg,
            Axis::ScanSpeed => self.scan_speed_mm_per_s,
            Axis::DoseRateScale => self.dose_rate_scale,
        }
    }

    /// The value of one axis, the base machine's (`defaults`) where the setting keeps it (`None`
    /// only for the upward ELST of a polynomial ELST model).
    pub fn get_or(&self, axis: Axis, defaults: &Defaults) -> Option<f64> {
        self.get(axis).or(match axis {
            Axis::ElstUp => defaults.elst_up_s,
            Axis::ElstDown => Some(defaults.elst_down_s),
            Axis::Window => Some(defaults.window_deg),
            Axis::ScanSpeed => defaults.scan_speed_mm_per_s,
            Axis::DoseRateScale => Some(defaults.dose_rate_scale),
            Axis::Jerk | Axis::Accel | Axis::Speed => None,
        })
    }

    /// A copy with one axis set.
    pub fn with(mut self, axis: Axis, value: f64) -> Setting {
        match axis {
            Axis::Jerk => self.jerk_deg_per_s3 = value,
            Axis::Accel => self.accel_deg_per_s2 = value,
            Axis::Speed => self.speed_deg_per_s = value,
            Axis::ElstUp => self.elst_up_s = Some(value),
            Axis::ElstDown => self.elst_down_s = Some(value),
            Axis::Window => self.window_deg = Some(value),
            Axis::ScanSpeed => self.scan_speed_mm_per_s = Some(value),
            Axis::DoseRateScale => self.dose_rate_scale = Some(value),
        }
        self
    }
}

impl Grid {
    fn axis(&self, axis: Axis) -> Option<&AxisSpec> {
        match axis {
            Axis::Jerk => Some(&self.jerk),
            Axis::Accel => Some(&self.accel),
            Axis::Speed => Some(&self.speed),
            Axis::ElstUp => self.elst_up.as_ref(),
            Axis::ElstDown => self.elst_down.as_ref(),
            Axis::Window => self.window.as_ref(),
            Axis::ScanSpeed => self.scan_speed.as_ref(),
            Axis::DoseRateScale => self.dose_rate_scale.as_ref(),
        }
    }

    /// Number of values of one axis (1 for an absent ELST, window or beam axis).
    pub fn axis_len(&self, axis: Axis) -> usize {
        self.axis(axis).map_or(1, AxisSpec::len)
    }

    /// Value `i` (< [`Grid::axis_len`]) of one axis (`None`: the base value).
    pub fn value(&self, axis: Axis, i: usize) -> Option<f64> {
        match self.axis(axis) {
            Some(a) => Some(a.value(i)),
            None => {
                assert!(i == 0, "value {i} of an absent axis");
                None
            }
        }
    }

    /// Number of grid points, `None` when it overflows `usize` (a loaded sweep has at most
    /// [`MAX_COMBINATIONS`]).
    pub fn checked_len(&self) -> Option<usize> {
        Axis::ALL
            .into_iter()
            .try_fold(1usize, |n, a| n.checked_mul(self.axis_len(a)))
    }

    /// Number of grid points (at least 1 once loaded; saturates at `usize::MAX`).
    pub fn len(&self) -> usize {
        self.checked_len().unwrap_or(usize::MAX)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The setting at grid index `i` (< [`Grid::len`]; jerk fastest, dose-rate scale slowest): `i`
    /// read as a mixed-radix number whose digits index the axes, each value computed on demand.
    pub fn setting(&self, i: usize) -> Setting {
        let mut rest = i;
        let mut digit = |axis: Axis| {
            let n = self.axis_len(axis);
            let d = rest % n;
            rest /= n;
            d
        };
        // The digits from the fastest: J, A, V, ELST down, ELST up, window, scanning speed,
        // dose-rate scale.
        let j = digit(Axis::Jerk);
        let a = digit(Axis::Accel);
        let v = digit(Axis::Speed);
        let d = digit(Axis::ElstDown);
        let u = digit(Axis::ElstUp);
        let w = digit(Axis::Window);
        let sc = digit(Axis::ScanSpeed);
        let r = digit(Axis::DoseRateScale);
        assert!(rest == 0, "grid index {i} of {}", self.len());
        Setting {
            jerk_deg_per_s3: self.jerk.value(j),
            accel_deg_per_s2: self.accel.value(a),
            speed_deg_per_s: self.speed.value(v),
            elst_up_s: self.value(Axis::ElstUp, u),
            elst_down_s: self.value(Axis::ElstDown, d),
            window_deg: self.value(Axis::Window, w),
            scan_speed_mm_per_s: self.value(Axis::ScanSpeed, sc),
            dose_rate_scale: self.value(Axis::DoseRateScale, r),
        }
    }

    /// The values of one axis (`None`: the base value). Materialises the axis: prefer
    /// [`Grid::axis_len`] and [`Grid::value`].
    pub fn values(&self, axis: Axis) -> Vec<Option<f64>> {
        (0..self.axis_len(axis))
            .map(|i| self.value(axis, i))
            .collect()
    }
}

impl Sweep {
    /// Reads a sweep file and everything it names (paths relative to the file), loading plan files
    /// with [`arcsim_plan::load_plan`].
    pub fn load(path: &Path) -> Result<Sweep, EvalError> {
        Sweep::load_with(path, &|p: &Path| {
            arcsim_plan::load_plan(p).map_err(|e| e.to_string())
        })
    }

    /// As [`Sweep::load`], with a plan loader of the caller's (e.g. one that also reads DICOM).
    pub fn load_with(
        path: &Path,
        load_plan: &dyn Fn(&Path) -> Result<ArcPlan, String>,
    ) -> Result<Sweep, EvalError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| EvalError::sweep(&file, "", format!("cannot read: {e}")))?;
        let base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Sweep::from_text(&text, &file, &base_dir, load_plan)
    }

    /// Builds a sweep from a sweep file's text; `base_dir` resolves its relative paths.
    pub fn from_text(
        text: &str,
        file: &str,
        base_dir: &Path,
        load_plan: &dyn Fn(&Path) -> Result<ArcPlan, String>,
    ) -> Result<Sweep, EvalError> {
        let spec = parse_sweep_file(text, file)?;
        let machine_path = base_dir.join(&spec.machine);
        let machine = arcsim_plan::load_machine(&machine_path).map_err(|e| EvalError::Input {
            file: file.to_string(),
            field: "machine".into(),
            message: e.to_string(),
        })?;
        let runs = expand_runs(&spec, &machine, file)?;
        let mut inputs = vec![machine_path];
        let plans = load_plans(&spec, base_dir, file, load_plan, &mut inputs)?;
        check_combinations(file, Some(plans.len()), runs.iter().map(|r| &r.grid))?;
        Ok(Sweep {
            name: spec.name,
            description: spec.description,
            source: file.to_string(),
            plans,
            machine,
            schedule_grids: runs,
            margins: spec.margins,
            certify: spec.certify,
            target: spec.target.unwrap_or_default(),
            inputs,
        })
    }

    /// The base machine's setting (its J, A, V; ELST, window and beam model as they are).
    pub fn base_setting(&self) -> Setting {
        let g = &self.machine.gantry;
        Setting {
            jerk_deg_per_s3: g.max_jerk_deg_per_s3,
            accel_deg_per_s2: g.max_accel_deg_per_s2,
            speed_deg_per_s: g.max_speed_deg_per_s,
            elst_up_s: None,
            elst_down_s: None,
            window_deg: None,
            scan_speed_mm_per_s: None,
            dose_rate_scale: None,
        }
    }

    /// The base machine's value of an axis (ELST up: `None` for a polynomial model; scanning
    /// speed: `None` for a `per_mu` beam model or separate x and y speeds; dose-rate scale: 1).
    pub fn base_value(&self, axis: Axis) -> Option<f64> {
        match axis {
            Axis::ElstUp => match self.machine.elst {
                ElstModel::Constant { up_s, .. } => Some(up_s),
                ElstModel::Polynomial { .. } => None,
            },
            Axis::ElstDown => match self.machine.elst {
                ElstModel::Constant { down_s, .. } | ElstModel::Polynomial { down_s, .. } => {
                    Some(down_s)
                }
            },
            Axis::Window => Some(self.machine.default_window_deg),
            Axis::ScanSpeed => single_scan_speed(&self.machine.beam),
            Axis::DoseRateScale => Some(1.0),
            other => self.base_setting().get(other),
        }
    }

    /// The base machine's ELST and default window ([`Defaults`]).
    pub fn defaults(&self) -> Defaults {
        Defaults {
            elst_up_s: self.base_value(Axis::ElstUp),
            elst_down_s: match self.machine.elst {
                ElstModel::Constant { down_s, .. } | ElstModel::Polynomial { down_s, .. } => down_s,
            },
            window_deg: self.machine.default_window_deg,
            scan_speed_mm_per_s: single_scan_speed(&self.machine.beam),
            dose_rate_scale: 1.0,
        }
    }

    /// Number of combinations per plan (the sum of the schedule entries' grid sizes; saturates at
    /// `usize::MAX`, a loaded sweep has at most [`MAX_COMBINATIONS`]).
    pub fn combinations_per_plan(&self) -> usize {
        self.schedule_grids
            .iter()
            .fold(0usize, |n, r| n.saturating_add(r.grid.len()))
    }

    /// Total number of combinations (saturates as [`Sweep::combinations_per_plan`]).
    pub fn combinations(&self) -> usize {
        self.plans
            .len()
            .saturating_mul(self.combinations_per_plan())
    }
}

/// The one scanning speed of a beam model: `None` for `per_mu` (no scanning speed) and for
/// different x and y speeds.
fn single_scan_speed(beam: &BeamModel) -> Option<f64> {
    match beam {
        BeamModel::PerMu(_) => None,
        BeamModel::Scanning(b) => match b.speeds_mm_per_s() {
            (x, y) if x == y && x.is_finite() => Some(x),
            _ => None,
        },
    }
}

/// Refuses a sweep whose combinations (`plans` × the grids' points; per plan when `plans` is not
/// known yet) overflow `usize` or exceed [`MAX_COMBINATIONS`], naming the count.
pub(crate) fn check_combinations<'a>(
    file: &str,
    plans: Option<usize>,
    grids: impl IntoIterator<Item = &'a Grid>,
) -> Result<(), EvalError> {
    let per_plan = grids
        .into_iter()
        .try_fold(0usize, |n, g| n.checked_add(g.checked_len()?));
    let total = per_plan.and_then(|n| n.checked_mul(plans.unwrap_or(1)));
    if total.is_some_and(|n| n <= MAX_COMBINATIONS) {
        return Ok(());
    }
    let count = |n: Option<usize>| match n {
        Some(n) => n.to_string(),
        None => format!("2^{} or more", usize::BITS),
    };
    let what = match plans {
        None => format!(
            "{} combinations per plan (grid points summed over the schedule entries)",
            count(per_plan)
        ),
        Some(p) => format!(
            "{} combinations ({p} plan{} × {} grid points summed over the schedule entries)",
            count(total),
            if p == 1 { "" } else { "s" },
            count(per_plan)
        ),
    };
    Err(EvalError::sweep(
        file,
        "",
        format!("{what}; expected at most {MAX_COMBINATIONS} (the most combinations a sweep may have): use fewer steps, values, schedules or plans"),
    ))
}

fn expand_runs(
    spec: &SweepFile,
    machine: &Machine,
    file: &str,
) -> Result<Vec<ScheduleGrid>, EvalError> {
    if spec.schedules.is_empty() {
        return Err(EvalError::sweep(
            file,
            "schedules",
            "expected at least one schedule; an empty sweep has nothing to run",
        ));
    }
    let g = &machine.gantry;
    // Ranges whose values are checked distinct once the size of the sweep is known to be sane
    // (that check walks the range).
    let mut ranges: Vec<(String, AxisSpec)> = Vec::new();
    let runs = spec
        .schedules
        .iter()
        .enumerate()
        .map(|(i, entry)| {
            let own = entry.axes.as_ref();
            let pick = |f: fn(&Axes) -> &Option<AxisSpec>| -> (Option<&AxisSpec>, String) {
                match own.and_then(|a| f(a).as_ref()) {
                    Some(a) => (Some(a), format!("schedules[{i}].axes")),
                    None => (f(&spec.axes).as_ref(), "axes".to_string()),
                }
            };
            let mut checked = |f: fn(&Axes) -> &Option<AxisSpec>, axis: Axis| -> Result<Option<AxisSpec>, EvalError> {
                let (a, at) = pick(f);
                let field = format!("{at}.{}", axis.field());
                let Some(a) = a else { return Ok(None) };
                if axis == Axis::ElstUp && matches!(machine.elst, ElstModel::Polynomial { .. }) {
                    return Err(EvalError::sweep(
                        file,
                        field,
                        format!("machine \"{}\" has a polynomial ELST model; expected a constant one to sweep the upward switching time", machine.name),
                    ));
                }
                if axis == Axis::ScanSpeed && matches!(machine.beam, BeamModel::PerMu(_)) {
                    return Err(EvalError::sweep(
                        file,
                        field,
                        format!("machine \"{}\": its beam model has no scanning speed (kind per_mu); expected a beam model of kind scanning to sweep the scanning speed", machine.name),
                    ));
                }
                let zero_ok = matches!(axis, Axis::ElstUp | Axis::ElstDown);
                check_axis(a, &field, file, zero_ok)?;
                if axis == Axis::DoseRateScale {
                    check_dose_rate_scales(a, &field, file)?;
                }
                check_machine_values(a, axis, &field, file, machine)?;
                if matches!(a, AxisSpec::Range { .. }) && !ranges.iter().any(|(f, _)| *f == field) {
                    ranges.push((field, a.clone()));
                }
                Ok(Some(a.clone()))
            };
            let jerk = checked(|a| &a.jerk_deg_per_s3, Axis::Jerk)?;
            let accel = checked(|a| &a.accel_deg_per_s2, Axis::Accel)?;
            let speed = checked(|a| &a.speed_deg_per_s, Axis::Speed)?;
            let elst_up = checked(|a| &a.elst_up_s, Axis::ElstUp)?;
            let elst_down = checked(|a| &a.elst_down_s, Axis::ElstDown)?;
            let window = checked(|a| &a.window_deg, Axis::Window)?;
            let scan_speed = checked(|a| &a.scan_speed_mm_per_s, Axis::ScanSpeed)?;
            let dose_rate_scale = checked(|a| &a.dose_rate_scale, Axis::DoseRateScale)?;
            let limit = |a: Option<AxisSpec>, base: f64| a.unwrap_or(AxisSpec::Values(vec![base]));
            let grid = Grid {
                jerk: limit(jerk, g.max_jerk_deg_per_s3),
                accel: limit(accel, g.max_accel_deg_per_s2),
                speed: limit(speed, g.max_speed_deg_per_s),
                elst_up,
                elst_down,
                window,
                scan_speed,
                dose_rate_scale,
            };
            Ok(ScheduleGrid {
                schedule: RunMode {
                    schedule: entry.schedule,
                    motion: entry.motion,
                    arc_ends: entry.arc_ends,
                },
                grid,
            })
        })
        .collect::<Result<Vec<ScheduleGrid>, EvalError>>()?;
    // At least one plan: refuse an absurd grid before walking its ranges or loading any plan.
    check_combinations(file, None, runs.iter().map(|r| &r.grid))?;
    for (field, range) in &ranges {
        check_range_distinct(range, field, file)?;
    }
    Ok(runs)
}

/// Checks one axis without walking a range: at least one value and at most
/// [`MAX_COMBINATIONS`], each finite and > 0 (>= 0 when `zero_ok`), no value of a list twice; a
/// range's ends likewise (> 0 on a log scale), and one step only when `from` equals `to`.
/// Whether a range's values are distinct is [`check_range_distinct`]'s.
fn check_axis(spec: &AxisSpec, field: &str, file: &str, zero_ok: bool) -> Result<(), EvalError> {
    let bad = |sub: &str, msg: String| EvalError::sweep(file, format!("{field}{sub}"), msg);
    let lower = if zero_ok {
        "finite and >= 0"
    } else {
        "finite and > 0"
    };
    let ok = |x: f64| x.is_finite() && (x > 0.0 || (zero_ok && x == 0.0));
    match *spec {
        AxisSpec::Values(ref v) if v.is_empty() => Err(bad(
            "",
            "expected at least one value; an axis with no values makes an empty sweep".into(),
        )),
        AxisSpec::Values(ref v) => {
            if v.len() > MAX_COMBINATIONS {
                return Err(bad(
                    "",
                    format!("{} values; expected at most {MAX_COMBINATIONS}", v.len()),
                ));
            }
            if let Some((i, x)) = v.iter().enumerate().find(|(_, &x)| !ok(x)) {
                return Err(bad(
                    &format!("[{i}]"),
                    format!("expected a value {lower}, got {x}"),
                ));
            }
            let mut seen = HashMap::new();
            for (i, x) in v.iter().enumerate() {
                if let Some(j) = seen.insert(x.to_bits(), i) {
                    return Err(bad("", twice(*x, j, i)));
                }
            }
            Ok(())
        }
        AxisSpec::Range { steps: 0, .. } => Err(bad(
            ".steps",
            "expected at least 1 step; an axis with no values makes an empty sweep".into(),
        )),
        AxisSpec::Range { steps, .. } if steps > MAX_COMBINATIONS => Err(bad(
            ".steps",
            format!("{steps} steps; expected at most {MAX_COMBINATIONS} (the most combinations a sweep may have)"),
        )),
        AxisSpec::Range {
            from,
            to,
            steps,
            scale,
        } => {
            for (name, x) in [("from", from), ("to", to)] {
                let positive = x.is_finite() && x > 0.0;
                if !ok(x) || (scale == Scale::Log && !positive) {
                    let need = if scale == Scale::Log {
                        "finite and > 0 (log scale)"
                    } else {
                        lower
                    };
                    return Err(bad(
                        &format!(".{name}"),
                        format!("expected a value {need}, got {x}"),
                    ));
                }
            }
            if steps == 1 && from != to {
                return Err(bad(
                    ".steps",
                    format!("1 step gives only `from` ({from}), not `to` ({to}); expected at least 2 steps, or `to` equal to `from`"),
                ));
            }
            Ok(())
        }
    }
}

/// Accepted dose-rate scales (from a thousandth to a thousand times the base machine's dose rate).
pub const DOSE_RATE_SCALE_RANGE: (f64, f64) = (1e-3, 1e3);

/// Checks a dose-rate scale axis's values (a list's each, a range's ends) against
/// [`DOSE_RATE_SCALE_RANGE`]; the scaled beam model is then checked as a machine's
/// ([`check_machine_values`]).
fn check_dose_rate_scales(spec: &AxisSpec, field: &str, file: &str) -> Result<(), EvalError> {
    let (lo, hi) = DOSE_RATE_SCALE_RANGE;
    let values: Vec<(String, f64)> = match spec {
        AxisSpec::Values(v) => v
            .iter()
            .enumerate()
            .map(|(i, &x)| (format!("{field}[{i}]"), x))
            .collect(),
        AxisSpec::Range { from, to, .. } => vec![
            (format!("{field}.from"), *from),
            (format!("{field}.to"), *to),
        ],
    };
    match values.into_iter().find(|(_, x)| !(lo..=hi).contains(x)) {
        Some((at, x)) => Err(EvalError::sweep(
            file,
            at,
            format!("expected a dose-rate scale from {lo} to {hi} (a factor on the base machine's dose rate), got {x}"),
        )),
        None => Ok(()),
    }
}

fn twice(x: f64, j: usize, i: usize) -> String {
    format!("value {x} appears twice (positions {j} and {i}); expected distinct values")
}

/// Checks that a range's values are distinct without storing them: consecutive values must move
/// strictly from `from` towards `to` (a range finer than the floating-point resolution does not).
fn check_range_distinct(spec: &AxisSpec, field: &str, file: &str) -> Result<(), EvalError> {
    let AxisSpec::Range { from, to, .. } = *spec else {
        return Ok(());
    };
    let n = spec.len();
    let mut prev = spec.value(0);
    for i in 1..n {
        let x = spec.value(i);
        if x == prev {
            return Err(EvalError::sweep(file, field, twice(x, i - 1, i)));
        }
        if (x > prev) != (to > from) {
            return Err(EvalError::sweep(
                file,
                format!("{field}.steps"),
                format!("{n} steps from {from} to {to} are finer than floating-point resolution (value {i}, {x}, does not move on from value {}, {prev}); expected fewer steps", i - 1),
            ));
        }
        prev = x;
    }
    Ok(())
}

/// Checks an axis's extreme values as the base machine's own would be: the machine with the
/// value set must pass [`arcsim_plan::validate_machine`] (so a sweep accepts the gantry limits,
/// switching times and windows a machine file accepts, and no value far beyond physical sense).
/// The extremes decide, as every accepted set of values is an interval. A also sets the
/// deceleration limit D = D_base · (A / A_base) (D_base: the machine's explicit deceleration
/// limit, else its A), which must stay finite, > 0 and accepted.
fn check_machine_values(
    spec: &AxisSpec,
    axis: Axis,
    field: &str,
    file: &str,
    machine: &Machine,
) -> Result<(), EvalError> {
    let extremes: [(String, f64); 2] = match spec {
        AxisSpec::Values(v) => {
            let pick = |better: fn(f64, f64) -> bool| {
                let (i, x) = v
                    .iter()
                    .copied()
                    .enumerate()
                    .reduce(|a, b| if better(b.1, a.1) { b } else { a })
                    .unwrap_or((0, f64::NAN));
                (format!("{field}[{i}]"), x)
            };
            [pick(|a, b| a < b), pick(|a, b| a > b)]
        }
        AxisSpec::Range { from, to, .. } => [
            (format!("{field}.from"), *from),
            (format!("{field}.to"), *to),
        ],
    };
    let g = &machine.gantry;
    for (at, x) in extremes {
        let mut m = machine.clone();
        let mut note = String::new();
        match axis {
            Axis::Jerk => m.gantry.max_jerk_deg_per_s3 = x,
            Axis::Speed => m.gantry.max_speed_deg_per_s = x,
            Axis::Accel => {
                m.gantry.max_accel_deg_per_s2 = x;
                let d = g.max_decel_deg_per_s2.unwrap_or(g.max_accel_deg_per_s2);
                let decel = d * (x / g.max_accel_deg_per_s2);
                if g.max_decel_deg_per_s2.is_some() || !(decel.is_finite() && decel > 0.0) {
                    m.gantry.max_decel_deg_per_s2 = Some(decel);
                    note = format!(
                        "A = {x} deg/s^2 scales the deceleration limit ({d} deg/s^2 at A = {} deg/s^2) to {decel} deg/s^2: ",
                        g.max_accel_deg_per_s2
                    );
                }
            }
            Axis::ElstUp | Axis::ElstDown => match &mut m.elst {
                ElstModel::Constant { up_s, down_s, .. } => {
                    *if axis == Axis::ElstUp { up_s } else { down_s } = x;
                }
                ElstModel::Polynomial { down_s, .. } => *down_s = x,
            },
            Axis::Window => m.default_window_deg = x,
            Axis::ScanSpeed => {
                // A `per_mu` model is refused before (it has no scanning speed).
                if let Some(b) = m.beam.with_scan_speed(x) {
                    m.beam = b;
                }
            }
            Axis::DoseRateScale => m.beam = m.beam.with_dose_rate_scale(x),
        }
        if let Some(issue) = arcsim_plan::validate_machine(&m, &machine.name).first() {
            return Err(EvalError::sweep(
                file,
                at,
                format!(
                    "{note}{} (the values a machine's `{}` accepts)",
                    issue.message, issue.field
                ),
            ));
        }
    }
    Ok(())
}

fn load_plans(
    spec: &SweepFile,
    base_dir: &Path,
    file: &str,
    load_plan: &dyn Fn(&Path) -> Result<ArcPlan, String>,
    inputs: &mut Vec<PathBuf>,
) -> Result<Vec<SweepPlan>, EvalError> {
    if spec.plans.is_empty() {
        return Err(EvalError::sweep(
            file,
            "plans",
            "expected at least one plan; an empty sweep has nothing to run",
        ));
    }
    let mut plans = Vec::new();
    let mut references: HashMap<PathBuf, String> = HashMap::new();
    for (i, source) in spec.plans.iter().enumerate() {
        let field = format!("plans[{i}]");
        match source {
            PlanSource::Path(pattern) => {
                let full = base_dir.join(pattern);
                let full_str = full
                    .to_str()
                    .ok_or_else(|| EvalError::sweep(file, &field, "expected a UTF-8 path"))?;
                let paths = glob::glob(full_str).map_err(|e| {
                    EvalError::sweep(file, &field, format!("bad glob \"{pattern}\": {e}"))
                })?;
                let mut paths: Vec<PathBuf> = paths.collect::<Result<_, _>>().map_err(|e| {
                    EvalError::sweep(file, &field, format!("cannot list \"{pattern}\": {e}"))
                })?;
                paths.sort();
                if paths.is_empty() {
                    return Err(EvalError::sweep(
                        file,
                        &field,
                        format!(
                            "\"{pattern}\" matches no file (relative to {})",
                            dir_name(base_dir)
                        ),
                    ));
                }
                for p in paths {
                    let plan = load_plan(&p).map_err(|message| EvalError::Input {
                        file: file.to_string(),
                        field: field.clone(),
                        message,
                    })?;
                    let label = p
                        .strip_prefix(base_dir)
                        .unwrap_or(&p)
                        .to_string_lossy()
                        .replace('\\', "/");
                    plans.push(SweepPlan { label, plan });
                    inputs.push(p);
                }
            }
            PlanSource::Named { path, name } => {
                if name.trim().is_empty() || plans.iter().any(|p: &SweepPlan| &p.label == name) {
                    return Err(EvalError::sweep(
                        file,
                        format!("{field}.name"),
                        format!(
                            "\"{name}\": expected a name for the plan's rows that no earlier plan has"
                        ),
                    ));
                }
                let full = base_dir.join(path);
                let plan = load_plan(&full).map_err(|message| EvalError::Input {
                    file: file.to_string(),
                    field: format!("{field}.path"),
                    message,
                })?;
                plans.push(SweepPlan {
                    label: name.clone(),
                    plan,
                });
                inputs.push(full);
            }
            PlanSource::AtomCase {
                atom_case,
                reference,
            } => {
                let path = base_dir.join(reference);
                let text = match references.get(&path) {
                    Some(t) => t.clone(),
                    None => {
                        let t = std::fs::read_to_string(&path).map_err(|e| {
                            EvalError::sweep(
                                file,
                                format!("{field}.reference"),
                                format!("cannot read {}: {e}", path.display()),
                            )
                        })?;
                        references.insert(path.clone(), t.clone());
                        inputs.push(path.clone());
                        t
                    }
                };
                // The reference file is named: a wrong one is found without guessing.
                let plan = arcsim_plan::atom_case_plan(&text, atom_case).map_err(|e| {
                    EvalError::sweep(
                        file,
                        format!("{field}.atom_case"),
                        format!("reference {}: {e}", path.display()),
                    )
                })?;
                plans.push(SweepPlan {
                    label: format!("atom:{atom_case}"),
                    plan,
                });
            }
        }
    }
    Ok(plans)
}

fn dir_name(dir: &Path) -> String {
    if dir.as_os_str().is_empty() {
        ".".into()
    } else {
        dir.display().to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The values of a range as the eager expansion computed them (before axes were lazy).
    fn eager(spec: &AxisSpec) -> Vec<f64> {
        match *spec {
            AxisSpec::Values(ref v) => v.clone(),
            AxisSpec::Range { from, steps: 1, .. } => vec![from],
            AxisSpec::Range {
                from,
                to,
                steps,
                scale,
            } => (0..steps)
                .map(|i| {
                    let f = i as f64 / (steps - 1) as f64;
                    if i + 1 == steps {
                        to
                    } else {
                        match scale {
                            Scale::Linear => from + f * (to - from),
                            Scale::Log => from * (to / from).powf(f),
                        }
                    }
                })
                .collect(),
        }
    }

    fn range(from: f64, to: f64, steps: usize, scale: Scale) -> AxisSpec {
        AxisSpec::Range {
            from,
            to,
            steps,
            scale,
        }
    }

    #[test]
    fn lazy_axis_values_are_bit_identical_to_the_eager_ones() {
        for spec in [
            range(0.125, 4.0, 1001, Scale::Log),
            range(0.1, 4.0, 997, Scale::Linear),
            range(8.0, 2.0, 10, Scale::Log),
            range(3.0, 0.0, 7, Scale::Linear),
            range(2.5, 2.5, 1, Scale::Linear),
            AxisSpec::Values(vec![3.0, 1.0, 2.0]),
        ] {
            let want = eager(&spec);
            assert_eq!(spec.len(), want.len());
            let got: Vec<u64> = (0..spec.len()).map(|i| spec.value(i).to_bits()).collect();
            let want: Vec<u64> = want.iter().map(|x| x.to_bits()).collect();
            assert_eq!(got, want, "{spec:?}");
        }
    }

    /// Grid points decode by mixed radix in the eager nesting: dose-rate scale slowest, then
    /// scanning speed, window, ELST up, ELST down, V, A, and J fastest.
    #[test]
    fn grid_settings_decode_like_the_nested_expansion() {
        let grid = Grid {
            jerk: range(0.25, 4.0, 5, Scale::Log),
            accel: AxisSpec::Values(vec![0.5, 0.25]),
            speed: range(6.0, 3.0, 3, Scale::Linear),
            elst_up: None,
            elst_down: Some(range(0.0, 1.0, 2, Scale::Linear)),
            window: Some(AxisSpec::Values(vec![1.0, 0.5])),
            scan_speed: None,
            dose_rate_scale: Some(AxisSpec::Values(vec![1.0, 2.0])),
        };
        let mut nested = Vec::new();
        // No ELST up or scanning speed axis: one point, `None`.
        for &r in &eager(grid.dose_rate_scale.as_ref().expect("dose rate")) {
            for &w in &eager(grid.window.as_ref().expect("window")) {
                for &d in &eager(grid.elst_down.as_ref().expect("down")) {
                    for &v in &eager(&grid.speed) {
                        for &a in &eager(&grid.accel) {
                            for &j in &eager(&grid.jerk) {
                                nested.push(Setting {
                                    jerk_deg_per_s3: j,
                                    accel_deg_per_s2: a,
                                    speed_deg_per_s: v,
                                    elst_up_s: None,
                                    elst_down_s: Some(d),
                                    window_deg: Some(w),
                                    scan_speed_mm_per_s: None,
                                    dose_rate_scale: Some(r),
                                });
                            }
                        }
                    }
                }
            }
        }
        assert_eq!(grid.len(), nested.len());
        assert_eq!(grid.checked_len(), Some(240));
        for (i, s) in nested.iter().enumerate() {
            assert_eq!(grid.setting(i), *s, "grid point {i}");
        }
        assert_eq!(grid.values(Axis::ElstUp), vec![None]);
        assert_eq!(grid.values(Axis::ScanSpeed), vec![None]);
        assert_eq!(grid.value(Axis::DoseRateScale, 1), Some(2.0));
        assert_eq!(grid.axis_len(Axis::Jerk), 5);
        assert_eq!(grid.value(Axis::Speed, 2), Some(3.0));
    }

    #[test]
    fn grid_sizes_overflow_into_a_refusal_not_a_wrap() {
        let huge = range(1.0, 2.0, MAX_COMBINATIONS, Scale::Linear);
        let grid = Grid {
            jerk: huge.clone(),
            accel: huge.clone(),
            speed: huge,
            elst_up: None,
            elst_down: None,
            window: None,
            scan_speed: None,
            dose_rate_scale: None,
        };
        assert_eq!(grid.checked_len(), None);
        assert_eq!(grid.len(), usize::MAX);
        let e = check_combinations("s.json", Some(3), [&grid])
            .expect_err("too many")
            .to_string();
        assert!(
            e.starts_with("s.json: 2^64 or more combinations (3 plans × 2^64 or more grid points"),
            "{e}"
        );
        let small = Grid {
            jerk: range(1.0, 2.0, 10_000, Scale::Linear),
            accel: range(1.0, 2.0, 10_000, Scale::Linear),
            speed: AxisSpec::Values(vec![1.0]),
            elst_up: None,
            elst_down: None,
            window: None,
            scan_speed: None,
            dose_rate_scale: None,
        };
        assert!(check_combinations("s.json", Some(1), [&small]).is_ok());
        let e = check_combinations("s.json", Some(2), [&small])
            .expect_err("too many")
            .to_string();
        assert!(
            e.starts_with("s.json: 200000000 combinations (2 plans × 100000000 grid points"),
            "{e}"
        );
        assert!(e.contains("expected at most 100000000"), "{e}");
    }
}
