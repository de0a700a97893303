//! `simulate`: one plan on one machine, with the GIL released; the result as attributes, columns,
//! a sampled timeline, a Rerun recording and the CLI's JSON document.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

use arcsim_app::{Provenance, ResultDocument, SimulateRequest, Source};
use arcsim_plan::Warning;
use arcsim_sequencer::{
    certify, machine_limits, ArcEnds, Motion, Schedule, SequenceError, CERTIFY_ROUNDS,
};
use numpy::IntoPyArray;
use pyo3::exceptions::{PyRuntimeError, PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyAny, PyDict};

use crate::convert::{columns, data_frame, serde_to_py};
use crate::inputs::{check_each, check_positive, floats, opt_number, positive, Machine, Plan};
use crate::{PlanError, SimulationError};

/// A schedule by its name, as the CLI and the files take it (the sequencer's `FromStr`).
pub(crate) fn schedule_of(name: &str) -> PyResult<Schedule> {
    name.parse::<Schedule>()
        .map_err(|e| PyValueError::new_err(format!("schedule: {e}")))
}

pub(crate) fn motion_of(name: Option<&str>) -> PyResult<Option<Motion>> {
    name.map(|n| {
        n.parse::<Motion>()
            .map_err(|e| PyValueError::new_err(format!("motion: {e}")))
    })
    .transpose()
}

/// A schedule name, or `None` for the machine controller's.
pub(crate) fn schedule_opt(name: Option<&str>) -> PyResult<Option<Schedule>> {
    name.map(schedule_of).transpose()
}

/// Arc ends by their name (the sequencer's `FromStr`).
fn arc_ends_of(name: &str) -> PyResult<ArcEnds> {
    name.parse::<ArcEnds>()
        .map_err(|e| PyValueError::new_err(format!("arc_ends: {e}")))
}

/// A simulated delivery: what `arcsim simulate` computes.
#[pyclass(frozen, module = "arcsim")]
pub struct Delivery {
    delivery: arcsim_sequencer::Delivery,
    plan: arcsim_plan::ArcPlan,
    plan_source: Source,
    machine: arcsim_plan::Machine,
    machine_source: Source,
    warnings: Vec<Warning>,
    notes: Vec<String>,
    strict: bool,
    controller: arcsim_app::ControllerUsed,
}

impl Delivery {
    /// The per-spot timeline, computed with the GIL released.
    fn spot_rows(&self, py: Python<'_>) -> PyResult<Vec<arcsim_sequencer::SpotRow>> {
        py.detach(|| arcsim_sequencer::spot_timeline(&self.plan, &self.machine, &self.delivery))
            .map_err(|e| SimulationError::new_err(e.to_string()))
    }
}

#[pymethods]
impl Delivery {
    /// Total delivery time (s).
    #[getter]
    fn total_s(&self) -> f64 {
        self.delivery.total_s
    }

    /// Where the time goes: {"beam_on_s", "spot_irradiation_s", "scanning_s",
    /// "burst_switching_s", "spill_waiting_s", "energy_switching_s", "lost_s"} (s). Beam-on is
    /// spot irradiation plus the time between spots (scanning, settling, layer overhead), burst
    /// switching and waits for a spill; lost_s is what the gantry adds beyond beam-on and energy
    /// switching.
    #[getter]
    fn breakdown<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        serde_to_py(py, &self.delivery.breakdown)
    }

    /// How many layer speeds and transitions each limit set (dict).
    #[getter]
    fn limiter_counts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        serde_to_py(py, &self.delivery.limiter_counts)
    }

    /// The tightest speed, acceleration and jerk against their limits, and where (dict, or None
    /// without a timeline).
    #[getter]
    fn margins<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        serde_to_py(py, &self.delivery.margins)
    }

    /// Percentiles of the total over `draws` deliveries with the machine's timing spreads
    /// (`spread`, per switch and per layer) and its fitted values' `uncertainty` (one draw per
    /// delivery) drawn, both measured by `calibrate`, as `simulate --monte-carlo` gives them:
    /// dict `p5_s`, `p50_s`, `p95_s`, `mean_s`, `sd_s`, `totals_s`, and with both sources
    /// `spreads_only_sd_s`, `parameters_only_sd_s` and `dominant`. Raises SimulationError when
    /// the machine has neither. The GIL is released.
    #[pyo3(signature = (draws, seed=0))]
    fn monte_carlo<'py>(
        &self,
        py: Python<'py>,
        draws: usize,
        seed: u64,
    ) -> PyResult<Bound<'py, PyAny>> {
        if self.machine.spread.is_none() && !self.machine.uncertainty.is_some_and(|u| u.any()) {
            return Err(SimulationError::new_err(format!(
                "monte_carlo: the machine {} has no timing spreads (`spread`) and no fitted values' `uncertainty`; calibrate() measures them in delivery logs",
                self.machine_source.file
            )));
        }
        if draws == 0 || draws > arcsim_evaluator::MAX_DRAWS {
            return Err(PyValueError::new_err(format!(
                "draws: expected 1 to {}, got {draws}",
                arcsim_evaluator::MAX_DRAWS
            )));
        }
        let d = &self.delivery;
        let opts = arcsim_sequencer::Options {
            schedule: d.schedule,
            build_timeline: false,
            servo_period_s: d.servo_period_s,
            motion: d.motion,
            arc_ends: d.arc_ends,
        };
        let mc = py
            .detach(|| {
                arcsim_evaluator::machine_monte_carlo(&self.plan, &self.machine, &opts, draws, seed)
                    .map_err(|e| e.to_string())
            })
            .map_err(SimulationError::new_err)?;
        serde_to_py(py, &mc)
    }

    /// The certificate of this delivery, as `simulate --certify` gives it (dict `lower_bound_s`,
    /// `gap_s`): constant motion, a proven lower bound of every constant-speed schedule of the
    /// plan on this machine (and servo period), seconds on a 180-layer plan with the GIL
    /// released; free motion, a proven but loose lower bound of every free motion (5-20 % below
    /// it on the bundled and ATOM plans).
    fn certify<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let certificate = py
            .detach(|| {
                let arcs =
                    arcsim_plan::resolve(&self.plan, &self.machine).map_err(|e| e.to_string())?;
                let limits = machine_limits(&self.machine).map_err(|e| e.to_string())?;
                certify(&arcs, &limits, &self.delivery, CERTIFY_ROUNDS).map_err(|e| e.to_string())
            })
            .map_err(PyRuntimeError::new_err)?;
        serde_to_py(py, &certificate)
    }

    /// Lost time by cause and place, and the costliest transitions (dict).
    #[getter]
    fn lost_time<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        serde_to_py(py, &self.delivery.lost_time)
    }

    /// The energy switches by class and band of energy step (count, ELST, time taken and lost),
    /// and the upward steps below 1 MeV with their control points and cost (dict; as `arcsim
    /// simulate` prints them and writes them under `switching` in its JSON).
    #[getter]
    fn switching<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let switching = arcsim_app::switching_of(&self.plan, &self.machine, &self.delivery);
        serde_to_py(py, &switching)
    }

    /// Schedule, motion and arc ends used, e.g. ("optimal", "free", "rest").
    #[getter]
    fn options(&self) -> (&'static str, &'static str, &'static str) {
        (
            self.delivery.schedule.name(),
            self.delivery.motion.name(),
            self.delivery.arc_ends.name(),
        )
    }

    /// Plausibility warnings of the inputs (also issued as Python warnings).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.warnings.iter().map(ToString::to_string).collect()
    }

    /// Notes on how the options applied.
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    /// One entry per energy layer in delivery order, as columns (dict of numpy arrays / lists).
    #[getter]
    fn layers<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        records(py, &self.delivery.layers)
    }

    /// One entry per transition (beam-off move), as columns.
    #[getter]
    fn transitions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        records(py, &self.delivery.transitions)
    }

    /// One entry per spot delivery (one painting of one spot, or its part in one spill) in
    /// delivery order, as columns: `layer_index`, `arc`, `control_point`, `layer`, `spot`,
    /// `painting`, `burst`, `spill` (None without bursts / spills), `x_mm`, `y_mm` (NaN
    /// without positions), `mu`, `t_start_s`, `t_end_s`, `angle_start_deg`, `angle_end_deg`
    /// (the gantry angle at the spot's start and end); as `simulate --spots` writes them.
    #[getter]
    fn spots<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        records(py, &self.spot_rows(py)?)
    }

    /// `layers` (default), `transitions` or `spots` as a pandas DataFrame (needs pandas).
    #[pyo3(signature = (table="layers"))]
    fn to_pandas<'py>(&self, py: Python<'py>, table: &str) -> PyResult<Bound<'py, PyAny>> {
        let cols = match table {
            "layers" => self.layers(py)?,
            "transitions" => self.transitions(py)?,
            "spots" => self.spots(py)?,
            other => {
                return Err(PyValueError::new_err(format!(
                    "table: expected \"layers\", \"transitions\" or \"spots\", got {other:?}"
                )))
            }
        };
        data_frame(py, cols)
    }

    /// The gantry sampled every `dt` s (default 0.01 s; and at the end): numpy arrays `t_s`, `angle_deg`,
    /// `speed_deg_per_s`, `accel_deg_per_s2`, `jerk_deg_per_s3`, `energy_mev` (NaN while the
    /// beam is off), `beam_on` (bool), `layer` (delivery-order index, -1 while the beam is off).
    #[pyo3(signature = (dt=None))]
    fn timeline<'py>(
        &self,
        py: Python<'py>,
        dt: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let dt = dt.map_or(Ok(0.01), |dt| positive("dt", dt))?;
        let tl = self
            .delivery
            .timeline
            .as_ref()
            .ok_or_else(|| PyRuntimeError::new_err("no timeline was built"))?;
        if !(dt.is_finite() && dt > 0.0) || tl.duration_s() / dt > 5e7 {
            return Err(PyValueError::new_err(format!(
                "dt {dt}: expected a finite number > 0 giving at most 5e7 samples"
            )));
        }
        let samples = py.detach(|| tl.samples(dt));
        let layer: Vec<Option<usize>> = samples.iter().map(|(t, _)| tl.beam_layer_at(*t)).collect();
        let d = PyDict::new(py);
        let col = |f: fn(&arcsim_sequencer::GantryState) -> f64| -> Vec<f64> {
            samples.iter().map(|(_, s)| f(s)).collect()
        };
        d.set_item(
            "t_s",
            samples
                .iter()
                .map(|s| s.0)
                .collect::<Vec<_>>()
                .into_pyarray(py),
        )?;
        d.set_item("angle_deg", col(|s| s.angle_deg).into_pyarray(py))?;
        d.set_item(
            "speed_deg_per_s",
            col(|s| s.speed_deg_per_s).into_pyarray(py),
        )?;
        d.set_item(
            "accel_deg_per_s2",
            col(|s| s.accel_deg_per_s2).into_pyarray(py),
        )?;
        d.set_item(
            "jerk_deg_per_s3",
            col(|s| s.jerk_deg_per_s3).into_pyarray(py),
        )?;
        let energy: Vec<f64> = layer
            .iter()
            .map(|l| l.map_or(f64::NAN, |l| self.delivery.layers[l].energy_mev))
            .collect();
        d.set_item("energy_mev", energy.into_pyarray(py))?;
        let on: Vec<bool> = layer.iter().map(Option::is_some).collect();
        d.set_item("beam_on", on.into_pyarray(py))?;
        let index: Vec<i64> = layer.iter().map(|l| l.map_or(-1, |l| l as i64)).collect();
        d.set_item("layer", index.into_pyarray(py))?;
        Ok(d)
    }

    /// The delivery as a machine would log it, a virtual log (as `simulate --log`): columns
    /// `t_s`, `gantry_angle_deg`, `beam_on`, `energy_mev`, `spot`, `mu` (NaN where the log has
    /// nothing), a sample every `period` s from 0 and at the end; `angle_noise_deg` adds
    /// Gaussian noise seeded by `seed` to the angles. With `path`, also writes the
    /// `arcsim-log/1` CSV there.
    #[pyo3(signature = (path=None, period=0.01, angle_noise_deg=0.0, seed=0))]
    fn to_log<'py>(
        &self,
        py: Python<'py>,
        path: Option<PathBuf>,
        period: f64,
        angle_noise_deg: f64,
        seed: u64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let spots = self.spot_rows(py)?;
        let opts = arcsim_log::VirtualLogOptions {
            period_s: period,
            angle_noise_deg,
            seed,
        };
        let samples = py
            .detach(|| arcsim_log::virtual_log(&self.delivery, &spots, &opts))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        if let Some(p) = path {
            std::fs::write(&p, arcsim_log::to_csv(&samples)).map_err(|e| {
                pyo3::exceptions::PyOSError::new_err(format!("{}: {e}", p.display()))
            })?;
        }
        records(py, &samples)
    }

    /// Writes the delivery for the Rerun viewer (.rrd), sampled every `dt` s (default 0.02 s),
    /// as `simulate --rrd` does.
    #[pyo3(signature = (path, dt=None))]
    fn save_rrd(
        &self,
        py: Python<'_>,
        path: PathBuf,
        dt: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let dt = dt.map_or(Ok(0.02), |dt| positive("dt", dt))?;
        let opts = arcsim_viewer::ViewerOptions { sample_dt_s: dt };
        let spots = self.spot_rows(py)?;
        py.detach(|| {
            arcsim_viewer::save_delivery(&path, &self.plan.name, &self.delivery, &spots, &opts)
        })
        .map_err(|e| PyRuntimeError::new_err(format!("{}: {e}", path.display())))
    }

    /// The result document, equal to what `arcsim simulate --json` writes for the same inputs.
    fn to_json(&self) -> PyResult<String> {
        let from = Provenance {
            plan_source: self.plan_source.clone(),
            machine: &self.machine,
            machine_source: self.machine_source.clone(),
            warnings: &self.warnings,
            notes: &self.notes,
            strict: self.strict,
            controller: &self.controller,
        };
        ResultDocument::new(&self.plan, &from, &self.delivery)
            .to_json()
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }

    fn __repr__(&self) -> String {
        let (s, m, _) = self.options();
        format!(
            "Delivery({:?}: {:.3} s, {s}, {m} motion, {} layers)",
            self.plan.name,
            self.delivery.total_s,
            self.delivery.layers.len()
        )
    }
}

pub(crate) fn records<'py>(
    py: Python<'py>,
    rows: &[impl serde::Serialize],
) -> PyResult<Bound<'py, PyDict>> {
    let values: Vec<serde_json::Value> = rows
        .iter()
        .map(serde_json::to_value)
        .collect::<Result<_, _>>()
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    columns(py, &values, &[], &["index"])
}

/// Runs the sequencer with the GIL released; a panic (a bug) becomes SimulationError.
fn run(
    py: Python<'_>,
    plan: &arcsim_plan::ArcPlan,
    machine: &arcsim_plan::Machine,
    opts: &arcsim_sequencer::Options,
) -> PyResult<arcsim_sequencer::Delivery> {
    let result = py.detach(|| {
        catch_unwind(AssertUnwindSafe(|| {
            arcsim_sequencer::simulate(plan, machine, opts)
        }))
    });
    match result {
        Ok(Ok(d)) => Ok(d),
        Ok(Err(e @ SequenceError::Plan(_))) => Err(PlanError::new_err(e.to_string())),
        Ok(Err(e)) => Err(SimulationError::new_err(e.to_string())),
        Err(_) => Err(SimulationError::new_err(
            "the simulation panicked (a bug in arcsim)",
        )),
    }
}

/// Simulates `plan` on `machine` (default: the built-in ATOM machine) as `arcsim simulate` does:
/// `schedule` "optimal", "scan", "prescribed", "step-and-shoot" or None (the machine
/// controller's); `motion` "constant", "free", "one-speed" or None (the machine's controller, as
/// the CLI);
/// `period_s` a servo period overriding the machine's; `strict` refuses implausible values
/// (likely unit slips) instead of warning. The GIL is released while it runs.
#[pyfunction]
#[pyo3(signature = (plan, machine=None, schedule=None, period_s=None, motion=None, arc_ends="rest", strict=false))]
// Each Python keyword argument of the signature above is one Rust parameter: pyo3 needs them all.
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    py: Python<'_>,
    plan: &Bound<'_, Plan>,
    machine: Option<&Bound<'_, Machine>>,
    schedule: Option<&str>,
    period_s: Option<&Bound<'_, PyAny>>,
    motion: Option<&str>,
    arc_ends: &str,
    strict: bool,
) -> PyResult<Delivery> {
    let period_s = opt_number("period_s", period_s)?;
    let plan = plan.get();
    let builtin;
    let machine = match machine {
        Some(m) => m.get(),
        None => {
            builtin = Machine::builtin();
            &builtin
        }
    };
    let mut warnings = arcsim_app::plausibility(
        &plan.plan,
        &plan.source.file,
        &machine.machine,
        &machine.source.file,
    );
    if let Some(ts) = period_s {
        let w = arcsim_app::check_period(ts, "period_s")
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        warnings.extend(w);
    }
    if strict {
        arcsim_app::refuse_implausible(&warnings, "strict")
            .map_err(|e| PlanError::new_err(e.to_string()))?;
    }
    for w in &warnings {
        PyErr::warn(
            py,
            &py.get_type::<PyUserWarning>(),
            &std::ffi::CString::new(w.to_string()).unwrap_or_default(),
            1,
        )?;
    }
    let request = SimulateRequest {
        schedule: schedule_opt(schedule)?,
        motion: motion_of(motion)?,
        arc_ends: arc_ends_of(arc_ends)?,
        period_s,
    };
    let (opts, notes, controller) = request.resolve(&plan.plan, &machine.machine);
    let delivery = run(py, &plan.plan, &machine.machine, &opts)?;
    Ok(Delivery {
        delivery,
        plan: plan.plan.clone(),
        plan_source: plan.source.clone(),
        machine: machine.machine.clone(),
        machine_source: machine.source.clone(),
        warnings,
        notes,
        strict,
        controller,
    })
}

/// ATOM-style entry point: one arc of layers `irradiation_times_s` (s) at `spacing_deg` apart,
/// `switching_times_s` (one per transition, s) between them, each layer's sweep within
/// `max_window_deg`, on a gantry with limits `jerk`, `accel`, `speed` (and `decel`, default
/// `accel`), irradiated at one constant speed per layer (ATOM's model). Returns (total time in
/// s, layer speeds in deg/s as a numpy array).
#[pyfunction]
#[pyo3(signature = (irradiation_times_s, switching_times_s, spacing_deg, max_window_deg, jerk, accel, speed, decel=None, schedule="optimal"))]
// Each Python keyword argument of the signature above is one Rust parameter: pyo3 needs them all.
#[allow(clippy::too_many_arguments)]
pub fn schedule_arrays<'py>(
    py: Python<'py>,
    irradiation_times_s: &Bound<'py, PyAny>,
    switching_times_s: &Bound<'py, PyAny>,
    spacing_deg: &Bound<'py, PyAny>,
    max_window_deg: &Bound<'py, PyAny>,
    jerk: &Bound<'py, PyAny>,
    accel: &Bound<'py, PyAny>,
    speed: &Bound<'py, PyAny>,
    decel: Option<&Bound<'py, PyAny>>,
    schedule: &str,
) -> PyResult<(f64, Bound<'py, numpy::PyArray1<f64>>)> {
    let times = floats("irradiation_times_s", irradiation_times_s)?;
    check_each("irradiation_times_s", &times, "a time > 0 s", |t| t > 0.0)?;
    let spacing_deg = positive("spacing_deg", spacing_deg)?;
    let max_window_deg = positive("max_window_deg", max_window_deg)?;
    let jerk = positive("jerk", jerk)?;
    let accel = positive("accel", accel)?;
    let speed = positive("speed", speed)?;
    let decel = opt_number("decel", decel)?;
    if let Some(d) = decel {
        check_positive("decel", d)?;
    }
    let angles: Vec<f64> = (0..times.len()).map(|k| k as f64 * spacing_deg).collect();
    let plan = Plan::from_arrays_impl(&angles, &times, max_window_deg, switching_times_s)?;
    let base = Machine::builtin();
    let mut m = base.machine.clone();
    m.gantry.max_jerk_deg_per_s3 = jerk;
    m.gantry.max_accel_deg_per_s2 = accel;
    m.gantry.max_speed_deg_per_s = speed;
    m.gantry.max_decel_deg_per_s2 = decel;
    let text = serde_json::to_string(&m).map_err(|e| PlanError::new_err(e.to_string()))?;
    let machine = arcsim_plan::parse_machine(&text, "schedule_arrays limits")
        .map_err(|e| PlanError::new_err(e.to_string()))?;
    let opts = arcsim_sequencer::Options {
        motion: Motion::Constant,
        ..arcsim_sequencer::Options::new(schedule_of(schedule)?)
    };
    let d = run(py, &plan, &machine, &opts)?;
    let speeds: Vec<f64> = d.layers.iter().map(|l| l.speed_deg_per_s).collect();
    Ok((d.total_s, speeds.into_pyarray(py)))
}

impl Plan {
    /// The one-arc plan of [`schedule_arrays`]: one layer per control point, nominal 100 MeV
    /// (no ELST model applies: every switch has its time).
    fn from_arrays_impl(
        angles: &[f64],
        times: &[f64],
        window: f64,
        switching: &Bound<'_, PyAny>,
    ) -> PyResult<arcsim_plan::ArcPlan> {
        let py = switching.py();
        let angles = angles.to_vec().into_pyarray(py);
        let times = times.to_vec().into_pyarray(py);
        let energies = 100.0f64.into_pyobject(py)?;
        let window = window.into_pyobject(py)?;
        let plan = Plan::from_arrays(
            angles.as_any(),
            times.as_any(),
            energies.as_any(),
            Some(window.as_any()),
            Some(switching),
            "CW",
            "schedule_arrays",
        )?;
        Ok(plan.plan)
    }
}
