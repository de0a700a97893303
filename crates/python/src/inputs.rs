//! Plans and machines: read from files as the CLI reads them, or built in memory.

use std::path::PathBuf;

use arcsim_app::{sha256_hex, Source, DEFAULT_MACHINE_JSON, DEFAULT_MACHINE_SOURCE};
use arcsim_plan::{ArcPlan, ControlPoint, EnergyLayer, RotationDirection};
use numpy::PyReadonlyArray1;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyAny, PyBool, PyInt, PyString};

use crate::PlanError;

fn plan_err(e: impl std::fmt::Display) -> PyErr {
    PlanError::new_err(e.to_string())
}

/// A validated arc plan, with the file it came from (name and SHA-256 of its bytes).
#[pyclass(frozen, module = "arcsim")]
pub struct Plan {
    pub plan: ArcPlan,
    pub source: Source,
}

/// Whether `x` is a Python or numpy boolean (both convert to 1.0 or 0.0 silently).
fn is_bool(x: &Bound<'_, PyAny>) -> bool {
    x.is_instance_of::<PyBool>()
        || x.get_type()
            .name()
            .is_ok_and(|n| n == "bool" || n == "bool_")
}

fn type_name(x: &Bound<'_, PyAny>) -> String {
    x.get_type()
        .name()
        .map_or_else(|_| "?".to_string(), |n| n.to_string())
}

/// A number as Python writes it (`nan`, `inf`, `-inf`, `0.5`).
pub(crate) fn show(v: f64) -> String {
    if v.is_nan() {
        "nan".to_string()
    } else if v.is_infinite() {
        if v > 0.0 { "inf" } else { "-inf" }.to_string()
    } else {
        v.to_string()
    }
}

/// A number argument: a Python or numpy int or float (not a bool), finite. TypeError for
/// anything else, ValueError for NaN or ±inf; both name the argument (`name`, with its index for
/// an array element).
pub(crate) fn number(name: &str, x: &Bound<'_, PyAny>) -> PyResult<f64> {
    if is_bool(x) {
        return Err(PyTypeError::new_err(format!(
            "{name}: expected a number, got a bool ({})",
            x.repr().map_or_else(|_| "?".to_string(), |r| r.to_string())
        )));
    }
    let v = x.extract::<f64>().map_err(|_| {
        if x.is_instance_of::<PyInt>() {
            PyValueError::new_err(format!(
                "{name}: expected a finite number, got an integer too large for a float"
            ))
        } else {
            PyTypeError::new_err(format!("{name}: expected a number, got {}", type_name(x)))
        }
    })?;
    if !v.is_finite() {
        return Err(PyValueError::new_err(format!(
            "{name}: expected a finite number, got {}",
            show(v)
        )));
    }
    Ok(v)
}

/// An optional number argument ([`number`]); None stays None.
pub(crate) fn opt_number(name: &str, x: Option<&Bound<'_, PyAny>>) -> PyResult<Option<f64>> {
    x.map(|x| number(name, x)).transpose()
}

/// A number argument that must be > 0.
pub(crate) fn positive(name: &str, x: &Bound<'_, PyAny>) -> PyResult<f64> {
    let v = number(name, x)?;
    check_positive(name, v)?;
    Ok(v)
}

/// ValueError naming `name` unless `v > 0`.
pub(crate) fn check_positive(name: &str, v: f64) -> PyResult<()> {
    if v > 0.0 {
        Ok(())
    } else {
        Err(PyValueError::new_err(format!(
            "{name}: expected a number > 0, got {v}"
        )))
    }
}

/// ValueError naming `name[k]` unless every value passes `ok` (`what` says what is expected).
pub(crate) fn check_each(
    name: &str,
    v: &[f64],
    what: &str,
    ok: impl Fn(f64) -> bool,
) -> PyResult<()> {
    match v.iter().position(|&x| !ok(x)) {
        Some(k) => Err(PyValueError::new_err(format!(
            "{name}[{k}]: expected {what}, got {}",
            show(v[k])
        ))),
        None => Ok(()),
    }
}

/// Whether `x` is a single value (a number, a bool, a 0-d array) rather than a sequence.
pub(crate) fn is_scalar(x: &Bound<'_, PyAny>) -> bool {
    x.try_iter().is_err() && !x.is_instance_of::<PyString>()
}

/// An array argument as a Vec: a 1-D numpy array or any sequence of numbers, each finite (not a
/// bool); errors name the argument and the index of the first bad element.
pub(crate) fn floats(name: &str, x: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    let values = if let Ok(a) = x.extract::<PyReadonlyArray1<'_, f64>>() {
        a.as_array().to_vec()
    } else {
        if let Ok(kind) = x
            .getattr("dtype")
            .and_then(|d| d.getattr("kind"))
            .and_then(|k| k.extract::<String>())
        {
            if kind == "b" {
                return Err(PyTypeError::new_err(format!(
                    "{name}: expected numbers, got an array of bools"
                )));
            }
        }
        let iter = match x.try_iter() {
            Ok(it) if !x.is_instance_of::<PyString>() => it,
            _ => {
                return Err(PyTypeError::new_err(format!(
                    "{name}: expected a 1-D array or sequence of numbers, got {}",
                    type_name(x)
                )))
            }
        };
        let mut v = Vec::new();
        for (k, item) in iter.enumerate() {
            v.push(number(&format!("{name}[{k}]"), &item?)?);
        }
        v
    };
    check_each(name, &values, "a finite number", f64::is_finite)?;
    Ok(values)
}

/// One value for every layer, or one per layer.
fn per_layer(name: &str, x: &Bound<'_, PyAny>, n: usize) -> PyResult<Vec<f64>> {
    if is_scalar(x) {
        return Ok(vec![number(name, x)?; n]);
    }
    let v = floats(name, x)?;
    if v.len() != n {
        return Err(PyValueError::new_err(format!(
            "{name}: expected one value or {n} (one per layer), got {}",
            v.len()
        )));
    }
    Ok(v)
}

#[pymethods]
impl Plan {
    /// A one-arc plan from arrays, one entry per energy layer in delivery order: consecutive
    /// layers at the same angle share a control point. `window_deg`: one value or one per layer
    /// (`None`: the machine's default); `switching_times_s`: one per transition (layer k → k+1),
    /// overriding the machine's ELST; `direction`: "CW" (angle increases) or "CC".
    #[staticmethod]
    #[pyo3(signature = (angles_deg, irradiation_times_s, energies_mev, window_deg=None, switching_times_s=None, direction="CW", name="plan from arrays"))]
    pub(crate) fn from_arrays(
        angles_deg: &Bound<'_, PyAny>,
        irradiation_times_s: &Bound<'_, PyAny>,
        energies_mev: &Bound<'_, PyAny>,
        window_deg: Option<&Bound<'_, PyAny>>,
        switching_times_s: Option<&Bound<'_, PyAny>>,
        direction: &str,
        name: &str,
    ) -> PyResult<Plan> {
        let angles = floats("angles_deg", angles_deg)?;
        let n = angles.len();
        if n == 0 {
            return Err(PyValueError::new_err(
                "angles_deg: expected at least one layer",
            ));
        }
        let times = per_layer("irradiation_times_s", irradiation_times_s, n)?;
        let energies = per_layer("energies_mev", energies_mev, n)?;
        let windows = window_deg
            .map(|w| per_layer("window_deg", w, n))
            .transpose()?;
        let switching = switching_times_s
            .map(|s| floats("switching_times_s", s))
            .transpose()?;
        check_each("irradiation_times_s", &times, "a time > 0 s", |t| t > 0.0)?;
        check_each("energies_mev", &energies, "an energy > 0 MeV", |e| e > 0.0)?;
        if let Some(w) = &windows {
            check_each("window_deg", w, "a window > 0 deg", |w| w > 0.0)?;
        }
        if let Some(s) = &switching {
            check_each("switching_times_s", s, "a time >= 0 s", |t| t >= 0.0)?;
        }
        if let Some(s) = &switching {
            if s.len() + 1 != n {
                return Err(PyValueError::new_err(format!(
                    "switching_times_s: expected one per transition ({}), got {}",
                    n - 1,
                    s.len()
                )));
            }
        }
        let direction = match direction {
            "CW" | "cw" => RotationDirection::Cw,
            "CC" | "cc" | "CCW" | "ccw" => RotationDirection::Cc,
            other => {
                return Err(PyValueError::new_err(format!(
                    "direction: expected \"CW\" or \"CC\", got {other:?}"
                )))
            }
        };
        let mut cps: Vec<ControlPoint> = Vec::new();
        for k in 0..n {
            let layer = EnergyLayer {
                energy_mev: energies[k],
                spots: None,
                irradiation_time_s: Some(times[k]),
                switching_time_s: match (&switching, k) {
                    (Some(s), k) if k > 0 => Some(s[k - 1]),
                    _ => None,
                },
                window_share: None,
            };
            match cps.last_mut() {
                Some(cp) if cp.angle_deg == angles[k] => cp.layers.push(layer),
                _ => cps.push(ControlPoint {
                    angle_deg: angles[k],
                    required_speed_deg_per_s: None,
                    window_deg: windows.as_ref().map(|w| w[k]),
                    layers: vec![layer],
                }),
            }
        }
        let plan = ArcPlan {
            format: arcsim_plan::PLAN_FORMAT.to_string(),
            name: name.to_string(),
            description: None,
            arcs: vec![arcsim_plan::Arc {
                direction,
                control_points: cps,
            }],
        };
        // Through the plan format's own reader, so every check (and message) is the files'.
        let json = arcsim_plan::to_json(&plan);
        let plan = arcsim_plan::parse_plan(&json, "Plan.from_arrays").map_err(plan_err)?;
        Ok(Plan {
            plan,
            source: Source {
                file: "Plan.from_arrays".into(),
                sha256: sha256_hex(json.as_bytes()),
            },
        })
    }

    /// The plan's name.
    #[getter]
    fn name(&self) -> &str {
        &self.plan.name
    }

    /// Where the plan came from: the path as given, or how it was built.
    #[getter]
    fn file(&self) -> &str {
        &self.source.file
    }

    /// SHA-256 of the plan file's bytes (of its JSON when built in memory).
    #[getter]
    fn sha256(&self) -> &str {
        &self.source.sha256
    }

    /// Number of arcs.
    #[getter]
    fn arcs(&self) -> usize {
        self.plan.arcs.len()
    }

    /// Number of energy layers over all arcs.
    #[getter]
    fn layers(&self) -> usize {
        self.plan
            .arcs
            .iter()
            .flat_map(|a| &a.control_points)
            .map(|cp| cp.layers.len())
            .sum()
    }

    /// The plan as arcsim-plan/1 JSON (what `arcsim import` writes).
    fn to_json(&self) -> String {
        arcsim_plan::to_json(&self.plan)
    }

    fn __repr__(&self) -> String {
        format!(
            "Plan({:?}: {} arc(s), {} layer(s), from {})",
            self.plan.name,
            self.arcs(),
            self.layers(),
            self.source.file
        )
    }
}

/// Reads a plan: arcsim-plan/1 JSON or a DICOM RT Ion Plan (recognised by content, as the CLI
/// does). Raises PlanError with the located problems; a DICOM import's warnings (a GantryAngle of
/// 360, fraction groups left out) are Python `UserWarning`s, as the CLI prints them.
#[pyfunction]
pub fn load_plan(py: Python<'_>, path: PathBuf) -> PyResult<Plan> {
    let (plan, sha256, warnings) = arcsim_app::read_plan_file_warned(&path).map_err(plan_err)?;
    if !warnings.is_empty() {
        let module = py.import("warnings")?;
        let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
        for w in &warnings {
            module.call_method1("warn", (w.as_str(), &category, 2))?;
        }
    }
    Ok(Plan {
        plan,
        source: Source {
            file: path.display().to_string(),
            sha256,
        },
    })
}

/// A gantry and beam model (arcsim-machine/1), with the file it came from.
#[pyclass(frozen, module = "arcsim")]
pub struct Machine {
    pub machine: arcsim_plan::Machine,
    pub source: Source,
}

impl Machine {
    pub fn builtin() -> Machine {
        Machine {
            machine: arcsim_app::builtin_machine(),
            source: Source {
                file: DEFAULT_MACHINE_SOURCE.into(),
                sha256: sha256_hex(DEFAULT_MACHINE_JSON.as_bytes()),
            },
        }
    }
}

#[pymethods]
impl Machine {
    /// The ATOM machine built into arcsim (scenarios/machine-atom.json), the default of simulate.
    #[staticmethod]
    fn atom() -> Machine {
        Machine::builtin()
    }

    /// A copy with other gantry limits (deg/s³, deg/s², deg/s; `decel` only for a machine with a
    /// separate deceleration limit), checked as a machine file's are.
    #[pyo3(signature = (jerk=None, accel=None, speed=None, decel=None))]
    fn with_limits(
        &self,
        jerk: Option<&Bound<'_, PyAny>>,
        accel: Option<&Bound<'_, PyAny>>,
        speed: Option<&Bound<'_, PyAny>>,
        decel: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Machine> {
        let limit =
            |name: &str, field: &str, x: Option<&Bound<'_, PyAny>>| -> PyResult<Option<f64>> {
                let v = opt_number(name, x)?;
                match v {
                    Some(v) if v <= 0.0 => Err(PlanError::new_err(format!(
                        "with_limits: {name} ({field}): expected a number > 0, got {v}"
                    ))),
                    _ => Ok(v),
                }
            };
        let jerk = limit("jerk", "max_jerk_deg_per_s3", jerk)?;
        let accel = limit("accel", "max_accel_deg_per_s2", accel)?;
        let speed = limit("speed", "max_speed_deg_per_s", speed)?;
        let decel = limit("decel", "max_decel_deg_per_s2", decel)?;
        let mut m = self.machine.clone();
        let g = &mut m.gantry;
        if let Some(j) = jerk {
            g.max_jerk_deg_per_s3 = j;
        }
        if let Some(a) = accel {
            g.max_accel_deg_per_s2 = a;
        }
        if let Some(v) = speed {
            g.max_speed_deg_per_s = v;
        }
        if let Some(d) = decel {
            g.max_decel_deg_per_s2 = Some(d);
        }
        let text =
            serde_json::to_string_pretty(&m).map_err(|e| PlanError::new_err(e.to_string()))?;
        let file = format!("{} (with_limits)", self.source.file);
        let machine = arcsim_plan::parse_machine(&text, &file).map_err(plan_err)?;
        Ok(Machine {
            machine,
            source: Source {
                file,
                sha256: sha256_hex(text.as_bytes()),
            },
        })
    }

    /// The machine's name.
    #[getter]
    fn name(&self) -> &str {
        &self.machine.name
    }

    /// The machine file as given, or the built-in one.
    #[getter]
    fn file(&self) -> &str {
        &self.source.file
    }

    /// Jerk limit J (deg/s³).
    #[getter]
    fn jerk(&self) -> f64 {
        self.machine.gantry.max_jerk_deg_per_s3
    }

    /// Acceleration limit A (deg/s²).
    #[getter]
    fn accel(&self) -> f64 {
        self.machine.gantry.max_accel_deg_per_s2
    }

    /// Deceleration limit (deg/s²): A unless the machine sets its own.
    #[getter]
    fn decel(&self) -> f64 {
        let g = &self.machine.gantry;
        g.max_decel_deg_per_s2.unwrap_or(g.max_accel_deg_per_s2)
    }

    /// Speed limit V (deg/s).
    #[getter]
    fn speed(&self) -> f64 {
        self.machine.gantry.max_speed_deg_per_s
    }

    /// Servo period (s), or None for continuous time.
    #[getter]
    fn servo_period_s(&self) -> Option<f64> {
        self.machine.servo_period_s
    }

    /// Window width (deg) of control points that give none.
    #[getter]
    fn default_window_deg(&self) -> f64 {
        self.machine.default_window_deg
    }

    /// The machine as arcsim-machine/1 JSON.
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string_pretty(&self.machine).map_err(|e| PlanError::new_err(e.to_string()))
    }

    fn __repr__(&self) -> String {
        format!(
            "Machine({:?}: J {}, A {}, V {}, from {})",
            self.machine.name,
            self.jerk(),
            self.accel(),
            self.speed(),
            self.source.file
        )
    }
}

/// Reads a machine model (arcsim-machine/1 JSON). Raises PlanError with the located problems.
#[pyfunction]
pub fn load_machine(path: PathBuf) -> PyResult<Machine> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(&path)
        .map_err(|e| PlanError::new_err(format!("{name}: cannot read: {e}")))?;
    let machine = arcsim_app::machine_from_text(&name, &text).map_err(plan_err)?;
    Ok(Machine {
        machine,
        source: Source {
            file: name,
            sha256: sha256_hex(text.as_bytes()),
        },
    })
}
