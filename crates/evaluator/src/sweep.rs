//! A loaded sweep: its plans and base machine read, its axes expanded into one grid per schedule.
//!
//! Combinations are numbered plan-major: for each plan (in file order, glob matches sorted), for
//! each schedule entry, every grid point, with the jerk varying fastest, then acceleration, speed,
//! downward ELST, upward ELST and window (slowest).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::RunMode;
use arcsim_plan::{ArcPlan, ElstModel, Machine};
use serde::Serialize;

use crate::sweep_file::{parse_sweep_file, Axes, AxisSpec, PlanSource, SweepFile, Target};
use crate::EvalError;

/// One plan of the sweep.
#[derive(Debug, Clone)]
pub struct SweepPlan {
    /// How rows name it: the path relative to the sweep file, or `atom:CASE`.
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
}

/// The values of every axis for one schedule entry.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    pub jerk: Vec<f64>,
    pub accel: Vec<f64>,
    pub speed: Vec<f64>,
    pub elst_up: Vec<Option<f64>>,
    pub elst_down: Vec<Option<f64>>,
    pub window: Vec<Option<f64>>,
}

/// One schedule entry: a schedule and its grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
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
    pub runs: Vec<Run>,
    /// Build timelines so rows carry kinematic margins.
    pub margins: bool,
    pub target: Target,
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
}

impl Axis {
    pub const ALL: [Axis; 6] = [
        Axis::Jerk,
        Axis::Accel,
        Axis::Speed,
        Axis::ElstUp,
        Axis::ElstDown,
        Axis::Window,
    ];

    /// The field name in sweep files and output columns.
    pub fn field(self) -> &'static str {
        match self {
            Axis::Jerk => "jerk_deg_per_s3",
            Axis::Accel => "accel_deg_per_s2",
            Axis::Speed => "speed_deg_per_s",
            Axis::ElstUp => "elst_up_s",
            Axis::ElstDown => "elst_down_s",
            Axis::Window => "window_deg",
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
        }
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
        }
        self
    }
}

impl Grid {
    /// Number of grid points (at least 1 once loaded).
    pub fn len(&self) -> usize {
        self.jerk.len()
            * self.accel.len()
            * self.speed.len()
            * self.elst_up.len()
            * self.elst_down.len()
            * self.window.len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The setting at grid index `i` (jerk fastest, window slowest).
    pub fn setting(&self, i: usize) -> Setting {
        let (j, i) = (i % self.jerk.len(), i / self.jerk.len());
        let (a, i) = (i % self.accel.len(), i / self.accel.len());
        let (v, i) = (i % self.speed.len(), i / self.speed.len());
        let (d, i) = (i % self.elst_down.len(), i / self.elst_down.len());
        let (u, w) = (i % self.elst_up.len(), i / self.elst_up.len());
        Setting {
            jerk_deg_per_s3: self.jerk[j],
            accel_deg_per_s2: self.accel[a],
            speed_deg_per_s: self.speed[v],
            elst_up_s: self.elst_up[u],
            elst_down_s: self.elst_down[d],
            window_deg: self.window[w],
        }
    }

    /// The values of one axis (`None`: the base value).
    pub fn values(&self, axis: Axis) -> Vec<Option<f64>> {
        match axis {
            Axis::Jerk => self.jerk.iter().map(|&x| Some(x)).collect(),
            Axis::Accel => self.accel.iter().map(|&x| Some(x)).collect(),
            Axis::Speed => self.speed.iter().map(|&x| Some(x)).collect(),
            Axis::ElstUp => self.elst_up.clone(),
            Axis::ElstDown => self.elst_down.clone(),
            Axis::Window => self.window.clone(),
        }
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
        let plans = load_plans(&spec, base_dir, file, load_plan)?;
        Ok(Sweep {
            name: spec.name,
            description: spec.description,
            source: file.to_string(),
            plans,
            machine,
            runs,
            margins: spec.margins,
            target: spec.target.unwrap_or_default(),
        })
    }

    /// The base machine's setting (its J, A, V; ELST and window as they are).
    pub fn base_setting(&self) -> Setting {
        let g = &self.machine.gantry;
        Setting {
            jerk_deg_per_s3: g.max_jerk_deg_per_s3,
            accel_deg_per_s2: g.max_accel_deg_per_s2,
            speed_deg_per_s: g.max_speed_deg_per_s,
            elst_up_s: None,
            elst_down_s: None,
            window_deg: None,
        }
    }

    /// The base machine's value of an axis (ELST up: `None` for a polynomial model).
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
            other => self.base_setting().get(other),
        }
    }

    /// Number of combinations per plan (the sum of the schedule entries' grid sizes).
    pub fn combinations_per_plan(&self) -> usize {
        self.runs.iter().map(|r| r.grid.len()).sum()
    }

    /// Total number of combinations.
    pub fn combinations(&self) -> usize {
        self.plans.len() * self.combinations_per_plan()
    }
}

fn expand_runs(spec: &SweepFile, machine: &Machine, file: &str) -> Result<Vec<Run>, EvalError> {
    if spec.schedules.is_empty() {
        return Err(EvalError::sweep(
            file,
            "schedules",
            "expected at least one schedule; an empty sweep has nothing to run",
        ));
    }
    let g = &machine.gantry;
    spec.schedules
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
            let limit = |f: fn(&Axes) -> &Option<AxisSpec>, axis: Axis, base: f64| -> Result<Vec<f64>, EvalError> {
                let (a, at) = pick(f);
                match a {
                    None => Ok(vec![base]),
                    Some(a) => axis_values(a, &format!("{at}.{}", axis.field()), file, false),
                }
            };
            let optional = |f: fn(&Axes) -> &Option<AxisSpec>, axis: Axis| -> Result<Vec<Option<f64>>, EvalError> {
                let (a, at) = pick(f);
                let field = format!("{at}.{}", axis.field());
                match a {
                    None => Ok(vec![None]),
                    Some(a) => {
                        if axis == Axis::ElstUp && matches!(machine.elst, ElstModel::Polynomial { .. }) {
                            return Err(EvalError::sweep(
                                file,
                                field,
                                format!("machine \"{}\" has a polynomial ELST model; expected a constant one to sweep the upward switching time", machine.name),
                            ));
                        }
                        let zero_ok = axis != Axis::Window;
                        Ok(axis_values(a, &field, file, zero_ok)?.into_iter().map(Some).collect())
                    }
                }
            };
            let grid = Grid {
                jerk: limit(|a| &a.jerk_deg_per_s3, Axis::Jerk, g.max_jerk_deg_per_s3)?,
                accel: limit(|a| &a.accel_deg_per_s2, Axis::Accel, g.max_accel_deg_per_s2)?,
                speed: limit(|a| &a.speed_deg_per_s, Axis::Speed, g.max_speed_deg_per_s)?,
                elst_up: optional(|a| &a.elst_up_s, Axis::ElstUp)?,
                elst_down: optional(|a| &a.elst_down_s, Axis::ElstDown)?,
                window: optional(|a| &a.window_deg, Axis::Window)?,
            };
            Ok(Run {
                schedule: RunMode {
                    schedule: entry.schedule,
                    motion: entry.motion,
                    arc_ends: entry.arc_ends,
                },
                grid,
            })
        })
        .collect()
}

/// Expands and checks one axis: at least one value, each finite and > 0 (>= 0 when `zero_ok`),
/// no value twice.
fn axis_values(
    spec: &AxisSpec,
    field: &str,
    file: &str,
    zero_ok: bool,
) -> Result<Vec<f64>, EvalError> {
    let bad = |sub: &str, msg: String| EvalError::sweep(file, format!("{field}{sub}"), msg);
    let lower = if zero_ok {
        "finite and >= 0"
    } else {
        "finite and > 0"
    };
    let ok = |x: f64| x.is_finite() && (x > 0.0 || (zero_ok && x == 0.0));
    match *spec {
        AxisSpec::Values(ref v) if v.is_empty() => {
            return Err(bad(
                "",
                "expected at least one value; an axis with no values makes an empty sweep".into(),
            ))
        }
        AxisSpec::Values(ref v) => {
            if let Some((i, x)) = v.iter().enumerate().find(|(_, &x)| !ok(x)) {
                return Err(bad(
                    &format!("[{i}]"),
                    format!("expected a value {lower}, got {x}"),
                ));
            }
        }
        AxisSpec::Range { steps: 0, .. } => {
            return Err(bad(
                ".steps",
                "expected at least 1 step; an axis with no values makes an empty sweep".into(),
            ))
        }
        AxisSpec::Range {
            from, to, scale, ..
        } => {
            for (name, x) in [("from", from), ("to", to)] {
                let positive = x.is_finite() && x > 0.0;
                if !ok(x) || (scale == crate::sweep_file::Scale::Log && !positive) {
                    let need = if scale == crate::sweep_file::Scale::Log {
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
        }
    }
    let values = spec.values();
    let mut seen = HashMap::new();
    for (i, x) in values.iter().enumerate() {
        if let Some(j) = seen.insert(x.to_bits(), i) {
            return Err(bad(
                "",
                format!(
                    "value {x} appears twice (positions {j} and {i}); expected distinct values"
                ),
            ));
        }
    }
    Ok(values)
}

fn load_plans(
    spec: &SweepFile,
    base_dir: &Path,
    file: &str,
    load_plan: &dyn Fn(&Path) -> Result<ArcPlan, String>,
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
                }
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
                        t
                    }
                };
                let plan = arcsim_plan::atom_case_plan(&text, atom_case).map_err(|e| {
                    EvalError::sweep(file, format!("{field}.atom_case"), e.to_string())
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
