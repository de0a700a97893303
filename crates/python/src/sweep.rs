//! `sweep`: a sweep file (or the same as a dict) evaluated in parallel with the GIL released;
//! Ctrl-C stops it after the rows in progress and raises `SweepInterrupted` with those rows.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use arcsim_evaluator::{Evaluator, Results, Row, Summary, Sweep, RESULTS_FORMAT};
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyAny, PyBool, PyDict, PyFloat, PyList, PyModule, PyTuple};

use crate::convert::{columns, data_frame, serde_to_py};
use crate::{SweepError, SweepInterrupted};

/// The columns a sweep's rows start with (the rest follow in name order).
const ROW_COLUMNS_FIRST: &[&str] = &[
    "index",
    "plan",
    "schedule",
    "status",
    "jerk_deg_per_s3",
    "accel_deg_per_s2",
    "speed_deg_per_s",
    "elst_up_s",
    "elst_down_s",
    "window_deg",
    "scan_speed_mm_per_s",
    "dose_rate_scale",
    "burst_switching_time_s",
    "spill_charge_mu",
    "spill_refill_time_s",
    "spill_max_layers",
    "total_s",
    "speedup",
    "breakdown.beam_on_s",
    "breakdown.spot_irradiation_s",
    "breakdown.scanning_s",
    "breakdown.burst_switching_s",
    "breakdown.spill_waiting_s",
    "breakdown.energy_switching_s",
    "breakdown.lost_s",
];

/// A sweep's rows and summary.
#[pyclass(frozen, module = "arcsim")]
pub struct SweepResult {
    name: String,
    combinations: usize,
    rows: Vec<Row>,
    summary: Option<Summary>,
}

#[pymethods]
impl SweepResult {
    /// The sweep's name.
    #[getter]
    fn name(&self) -> &str {
        &self.name
    }

    /// Combinations in the whole sweep.
    #[getter]
    fn combinations(&self) -> usize {
        self.combinations
    }

    /// Whether every combination was evaluated (False after Ctrl-C).
    #[getter]
    fn complete(&self) -> bool {
        self.rows.len() == self.combinations
    }

    /// The rows as columns (dict of numpy arrays / lists): `index`, `plan`, `schedule`, `status`,
    /// `message`, the setting's limits, `total_s`, `speedup`, `lower_bound_s` and `gap_s` (with
    /// `"certify": true`), `breakdown.*`, `limiter_counts.*`
    /// (margins as `margins.*` when the sweep asks for them). Limits the setting keeps from the
    /// base machine are NaN.
    #[getter]
    fn rows<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let values: Vec<serde_json::Value> = self
            .rows
            .iter()
            .map(serde_json::to_value)
            .collect::<Result<_, _>>()
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        columns(py, &values, &["setting.", "outcome."], ROW_COLUMNS_FIRST)
    }

    /// The rows as a pandas DataFrame (needs pandas).
    fn to_pandas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        data_frame(py, self.rows(py)?)
    }

    /// The summary (per plan and schedule: base total, fastest setting, sensitivities, cheapest
    /// change reaching the target) as a dict; None after Ctrl-C.
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        serde_to_py(py, &self.summary)
    }

    /// The summary tables as `arcsim sweep` prints them; None after Ctrl-C.
    fn summary_table(&self) -> Option<String> {
        self.summary.as_ref().map(Summary::to_table)
    }

    /// Rows and summary as `arcsim sweep --json` writes them.
    fn to_json(&self) -> PyResult<String> {
        let results = Results {
            format: RESULTS_FORMAT,
            sweep: self.name.clone(),
            combinations: self.combinations,
            shard: None,
            complete: self.complete(),
            rows: &self.rows,
            summary: self.summary.as_ref(),
        };
        serde_json::to_string_pretty(&results).map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }

    fn __repr__(&self) -> String {
        format!(
            "SweepResult({:?}: {} of {} combinations)",
            self.name,
            self.rows.len(),
            self.combinations
        )
    }
}

fn plan_loader(p: &Path) -> Result<arcsim_plan::ArcPlan, String> {
    arcsim_app::read_plan_file(p)
        .map(|(plan, _)| plan)
        .map_err(|e| e.to_string())
}

/// SweepError naming the key path (`axes.jerk_deg_per_s3.from`, `plans[1]`) of the first NaN
/// or ±inf in a sweep dict: JSON has no such numbers.
fn finite_numbers(key: &str, x: &Bound<'_, PyAny>) -> PyResult<()> {
    let join = |k: &str| {
        if key.is_empty() {
            k.to_string()
        } else {
            format!("{key}.{k}")
        }
    };
    if let Ok(d) = x.cast::<PyDict>() {
        for (k, v) in d.iter() {
            let k = k.str().map_or_else(|_| "?".to_string(), |k| k.to_string());
            finite_numbers(&join(&k), &v)?;
        }
    } else if x.is_instance_of::<PyList>() || x.is_instance_of::<PyTuple>() {
        for (i, v) in x.try_iter()?.enumerate() {
            finite_numbers(&format!("{key}[{i}]"), &v?)?;
        }
    } else if x.is_instance_of::<PyFloat>() {
        let v: f64 = x.extract()?;
        if !v.is_finite() {
            return Err(SweepError::new_err(format!(
                "sweep dict: {key}: expected a finite number, got {}",
                crate::inputs::show(v)
            )));
        }
    }
    Ok(())
}

/// Loads a sweep from a path, or from a dict in the sweep-file format (paths in it relative to
/// the current directory).
fn load(spec: &Bound<'_, PyAny>) -> PyResult<Sweep> {
    let py = spec.py();
    let sweep = if let Ok(path) = spec.extract::<PathBuf>() {
        Sweep::load_with(&path, &plan_loader)
    } else if spec.is_instance_of::<PyDict>() {
        finite_numbers("", spec)?;
        let text: String = py
            .import("json")?
            .call_method1("dumps", (spec,))?
            .extract()?;
        let here = std::env::current_dir().map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Sweep::from_text(&text, "sweep dict", &here, &plan_loader)
    } else {
        return Err(PyValueError::new_err(
            "expected a sweep file path or a dict in the sweep-file format",
        ));
    };
    sweep.map_err(|e| SweepError::new_err(e.to_string()))
}

/// The `threads` argument: an int (not a bool) from 1 to 256.
fn thread_count(x: &Bound<'_, PyAny>) -> PyResult<usize> {
    if x.is_instance_of::<PyBool>() {
        return Err(PyTypeError::new_err(
            "threads: expected an integer, got a bool",
        ));
    }
    let n = x.extract::<i64>().map_err(|_| {
        PyTypeError::new_err(format!(
            "threads: expected an integer, got {}",
            x.get_type()
                .name()
                .map_or_else(|_| "?".to_string(), |n| n.to_string())
        ))
    })?;
    usize::try_from(n)
        .ok()
        .filter(|n| (1..=256).contains(n))
        .ok_or_else(|| PyValueError::new_err(format!("threads: expected 1 to 256, got {n}")))
}

/// The Python-level SIGINT handler when a sweep starts, put back when the sweep returns, raises
/// or unwinds: Ctrl-C keeps working in the interpreter after the sweep whatever ran in between.
struct SigintHandler<'py> {
    signal: Bound<'py, PyModule>,
    handler: Bound<'py, PyAny>,
}

impl<'py> SigintHandler<'py> {
    fn save(py: Python<'py>) -> PyResult<Self> {
        let signal = py.import("signal")?;
        let handler = signal.call_method1("getsignal", (signal.getattr("SIGINT")?,))?;
        Ok(SigintHandler { signal, handler })
    }

    fn restore(&self) -> PyResult<()> {
        let sigint = self.signal.getattr("SIGINT")?;
        let now = self.signal.call_method1("getsignal", (&sigint,))?;
        if !now.is(&self.handler) && !self.handler.is_none() {
            self.signal
                .call_method1("signal", (sigint, &self.handler))?;
        }
        Ok(())
    }
}

impl Drop for SigintHandler<'_> {
    fn drop(&mut self) {
        if let Err(e) = self.restore() {
            // Drop cannot raise: Python reports the failure as unraisable.
            e.write_unraisable(self.signal.py(), None);
        }
    }
}

/// Evaluates a sweep (a path to an arcsim-sweep/1 file, or the same as a dict) on `threads`
/// worker threads (default: one per core), with a progress bar on a terminal when `progress`.
/// The GIL is released while it runs. Ctrl-C stops after the rows in progress and raises
/// SweepInterrupted (a KeyboardInterrupt) whose `result` holds the finished rows.
#[pyfunction]
#[pyo3(signature = (sweep, threads=None, progress=true))]
pub fn sweep(
    py: Python<'_>,
    sweep: &Bound<'_, PyAny>,
    threads: Option<&Bound<'_, PyAny>>,
    progress: bool,
) -> PyResult<SweepResult> {
    let threads = threads.map(thread_count).transpose()?;
    let spec = load(sweep)?;
    let _sigint = SigintHandler::save(py)?;
    let n_threads = threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .min(spec.combinations().max(1));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(n_threads)
        .build()
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start worker threads: {e}")))?;
    let name = spec.name.clone();
    let ev = py
        .detach(|| pool.install(|| Evaluator::new(spec)))
        .map_err(|e| SweepError::new_err(e.to_string()))?;
    let combinations = ev.len();
    let bar = if progress {
        indicatif::ProgressBar::new(combinations as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    let cancel = AtomicBool::new(false);
    let mut rows: Vec<Row> = Vec::new();
    let mut interrupt: Option<PyErr> = None;
    let outcome = py.detach(|| {
        std::thread::scope(|s| {
            let worker = s.spawn(|| {
                pool.install(|| {
                    ev.run(&(0..combinations), &cancel, |chunk| {
                        rows.extend_from_slice(chunk);
                        bar.inc(chunk.len() as u64);
                        Ok(())
                    })
                })
            });
            // Signals reach Python only on the thread that called: look for them while the
            // workers run.
            while !worker.is_finished() {
                std::thread::sleep(Duration::from_millis(50));
                if interrupt.is_none() {
                    if let Err(e) = Python::attach(|py| py.check_signals()) {
                        interrupt = Some(e);
                        cancel.store(true, Ordering::SeqCst);
                    }
                }
            }
            worker.join()
        })
    });
    bar.finish_and_clear();
    match outcome {
        Ok(Ok(_)) => {}
        Ok(Err(e)) => return Err(SweepError::new_err(e.to_string())),
        Err(_) => {
            return Err(PyRuntimeError::new_err(
                "the sweep panicked (a bug in arcsim)",
            ))
        }
    }
    if let Some(e) = interrupt {
        let result = SweepResult {
            name,
            combinations,
            rows,
            summary: None,
        };
        if e.is_instance_of::<pyo3::exceptions::PyKeyboardInterrupt>(py) {
            let err = SweepInterrupted::new_err(format!(
                "sweep interrupted after {} of {combinations} combinations; .result holds them",
                result.rows.len()
            ));
            err.value(py).setattr("result", Py::new(py, result)?)?;
            return Err(err);
        }
        return Err(e);
    }
    let summary = py.detach(|| pool.install(|| ev.summarize(&rows)));
    Ok(SweepResult {
        name,
        combinations,
        rows,
        summary: Some(summary),
    })
}
