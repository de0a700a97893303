//! `compare` and `calibrate`: delivery logs against simulations, and a machine fitted to logs,
//! as `arcsim compare` and `arcsim calibrate` compute them (the GIL released).

use std::path::PathBuf;

use arcsim_app::{sha256_hex, SimulateRequest, Source};
use arcsim_sequencer::{machine_limits, simulate_resolved, ArcEnds, Options};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyAny, PyDict, PyTuple};

use crate::convert::{columns, data_frame, serde_to_py};
use crate::inputs::{Machine, Plan};
use crate::{LogError, SimulationError};

/// A delivery log: a CSV through the `columns` mapping, or a DICOM RT Ion Beams Treatment
/// Record (recognised by its content).
pub(crate) fn read(
    path: &std::path::Path,
    columns: Option<&str>,
) -> PyResult<arcsim_log::DeliveryLog> {
    let map = arcsim_log::ColumnMap::parse(columns.unwrap_or(""), "columns")
        .map_err(|e| LogError::new_err(e.to_string()))?;
    arcsim_dicom::read_delivery_log(path, &map, None).map_err(|e| LogError::new_err(e.to_string()))
}

fn options(
    schedule: Option<&str>,
    motion: Option<&str>,
    plan: &Plan,
    machine: &Machine,
) -> PyResult<Options> {
    let request = SimulateRequest {
        schedule: crate::simulate::schedule_opt(schedule)?,
        motion: crate::simulate::motion_of(motion)?,
        arc_ends: ArcEnds::Rest,
        period_s: None,
    };
    Ok(request.options(&plan.plan, &machine.machine).0)
}

/// A delivery log set beside the simulation of its plan (`arcsim compare`).
#[pyclass(frozen, module = "arcsim")]
pub struct Comparison {
    comparison: arcsim_log::Comparison,
}

#[pymethods]
impl Comparison {
    /// Logged minus simulated total (s).
    #[getter]
    fn difference_s(&self) -> f64 {
        self.comparison.difference_s
    }

    /// Everything but the per-layer rows (dict): the logged and simulated splits, the classes,
    /// the worst layers, the motion fits, the observed gantry limits.
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut v = serde_json::to_value(&self.comparison)
            .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
        if let Some(o) = v.as_object_mut() {
            o.remove("layers");
        }
        crate::convert::to_py(py, &v)
    }

    /// One row per layer, logged and simulated, as a dict of numpy arrays.
    #[getter]
    fn layers<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let rows: Vec<serde_json::Value> = self
            .comparison
            .layers
            .iter()
            .map(|r| serde_json::to_value(r).unwrap_or_default())
            .collect();
        columns(py, &rows, &[], &["index"])
    }

    /// The per-layer rows as a pandas DataFrame (needs pandas).
    fn to_pandas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        data_frame(py, self.layers(py)?)
    }

    /// The comparison as `arcsim compare --json` writes it (without the plan's file name).
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string_pretty(&self.comparison)
            .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))
    }

    fn __repr__(&self) -> String {
        format!(
            "Comparison(log={:?}, logged {:.2} s, simulated {:.2} s, better motion {})",
            self.comparison.log,
            self.comparison.logged.total_s,
            self.comparison.simulated.total_s,
            self.comparison.better_motion
        )
    }
}

/// Compares the delivery log at `log` (an `arcsim-log/1` CSV, or another CSV through
/// `columns`) with `plan` simulated on `machine` (default the built-in ATOM machine), as
/// `arcsim compare` does. Raises LogError for a log that cannot be read or does not fit the plan.
#[pyfunction]
#[pyo3(signature = (plan, log, machine=None, motion=None, schedule=None, columns=None))]
pub fn compare(
    py: Python<'_>,
    plan: &Bound<'_, Plan>,
    log: PathBuf,
    machine: Option<&Bound<'_, Machine>>,
    motion: Option<&str>,
    schedule: Option<&str>,
    columns: Option<&str>,
) -> PyResult<Comparison> {
    let plan = plan.get();
    let builtin;
    let machine = match machine {
        Some(m) => m.get(),
        None => {
            builtin = Machine::builtin();
            &builtin
        }
    };
    let opts = options(schedule, motion, plan, machine)?;
    let log = read(&log, columns)?;
    let comparison = py.detach(|| -> Result<_, PyErr> {
        let arcs = arcsim_plan::resolve(&plan.plan, &machine.machine)
            .map_err(|e| crate::PlanError::new_err(e.to_string()))?;
        let logged =
            arcsim_log::match_layers(&log, &arcs).map_err(|e| LogError::new_err(e.to_string()))?;
        arcsim_log::check_mu(&log, &plan.plan, &arcs, &logged)
            .map_err(|e| LogError::new_err(e.to_string()))?;
        let limits = machine_limits(&machine.machine)
            .map_err(|e| SimulationError::new_err(e.to_string()))?;
        let opts = Options {
            servo_period_s: machine.machine.servo_period_s,
            ..opts
        };
        let main = simulate_resolved(&arcs, &limits, &opts)
            .map_err(|e| SimulationError::new_err(e.to_string()))?;
        let alts: Vec<arcsim_sequencer::Delivery> = arcsim_sequencer::Motion::ALL
            .into_iter()
            .filter(|&m| m != opts.motion)
            .filter_map(|motion| {
                let other = Options {
                    motion,
                    servo_period_s: None,
                    ..opts.clone()
                };
                simulate_resolved(&arcs, &limits, &other).ok()
            })
            .collect();
        let others: Vec<&arcsim_sequencer::Delivery> = alts.iter().collect();
        arcsim_log::compare(&arcs, &main, &others, &log)
            .map_err(|e| LogError::new_err(e.to_string()))
    })?;
    Ok(Comparison { comparison })
}

/// Fits a machine to delivery logs, starting from `machine`, as `arcsim calibrate` does.
/// `runs` is a list of `(plan, log_path)` pairs; `elst` is "constant" or "poly". Returns
/// `(fitted Machine, report dict)`: every value with its 95 % interval, what the logs do not
/// determine, the spreads, the residual per log before and after.
#[pyfunction]
#[pyo3(signature = (machine, runs, elst="constant", motion=None, schedule=None, columns=None))]
pub fn calibrate<'py>(
    py: Python<'py>,
    machine: &Bound<'py, Machine>,
    runs: Vec<(Bound<'py, Plan>, PathBuf)>,
    elst: &str,
    motion: Option<&str>,
    schedule: Option<&str>,
    columns: Option<&str>,
) -> PyResult<Bound<'py, PyTuple>> {
    let base = machine.get();
    let fit = match elst {
        "constant" => arcsim_log::ElstFit::Constant,
        "poly" => arcsim_log::ElstFit::Polynomial,
        other => {
            return Err(PyValueError::new_err(format!(
                "elst: expected \"constant\" or \"poly\", got {other:?}"
            )))
        }
    };
    let Some((first, _)) = runs.first() else {
        return Err(PyValueError::new_err(
            "runs: expected at least one (plan, log) pair",
        ));
    };
    let opts = options(schedule, None, first.get(), base)?;
    let forced = crate::simulate::motion_of(motion)?;
    let logged = runs
        .iter()
        .map(|(plan, path)| {
            let plan = plan.get();
            Ok(arcsim_log::LoggedRun {
                plan_name: plan.source.file.clone(),
                plan: plan.plan.clone(),
                log: read(path, columns)?,
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    let cal = py
        .detach(|| arcsim_log::calibrate_controller(&base.machine, &logged, fit, &opts, forced))
        .map_err(|e| match e {
            arcsim_log::CalibrateError::Match(m) => LogError::new_err(m.to_string()),
            other => SimulationError::new_err(other.to_string()),
        })?;
    let report = serde_to_py(py, &cal.report)?;
    let fitted = fitted_machine(base, cal.machine, "calibrated")?;
    PyTuple::new(py, [Bound::new(py, fitted)?.into_any(), report])
}

/// The fitted machine as Python receives it: its source the base's file, labelled, and the
/// hash of its JSON.
fn fitted_machine(base: &Machine, machine: arcsim_plan::Machine, label: &str) -> PyResult<Machine> {
    let text = serde_json::to_string_pretty(&machine)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
    Ok(Machine {
        machine,
        source: Source {
            file: format!("{} ({label})", base.source.file),
            sha256: sha256_hex(text.as_bytes()),
        },
    })
}

/// Fits a `scanning` beam's spot timing to per-spot logs, starting from `machine`, as
/// `arcsim calibrate-spots` does. `runs` is a list of `(plan, path)` pairs, each path a per-spot CSV log or an IBA-style log folder. Returns
/// `(fitted Machine, report dict)`.
#[pyfunction]
pub fn calibrate_spots<'py>(
    py: Python<'py>,
    machine: &Bound<'py, Machine>,
    runs: Vec<(Bound<'py, Plan>, PathBuf)>,
) -> PyResult<Bound<'py, PyTuple>> {
    let base = machine.get();
    let spot_runs = runs
        .iter()
        .map(|(plan, path)| {
            let plan = plan.get();
            Ok(arcsim_log::SpotRun {
                plan_name: plan.source.file.clone(),
                plan: plan.plan.clone(),
                log: arcsim_log::read_spots(path, &plan.plan)
                    .map_err(|e| LogError::new_err(e.to_string()))?,
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    let cal = py
        .detach(|| arcsim_log::calibrate_spots(&base.machine, &spot_runs))
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let report = serde_to_py(py, &cal)?;
    let fitted = fitted_machine(base, cal.machine, "spot-calibrated")?;
    PyTuple::new(py, [Bound::new(py, fitted)?.into_any(), report])
}
