//! Single moves (`arcsim profile`): one profile with its phases and vectorised sampling, or
//! millions at once from numpy arrays, in parallel with the GIL released.

use arcsim_app::{MoveError, MoveRequest, SolvedMove};
use arcsim_planner::{Move, Reversal};
use numpy::IntoPyArray;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyAny, PyDict, PyList};
use rayon::prelude::*;

use crate::inputs::{check_each, check_positive, floats, is_scalar, number, opt_number, positive};
use crate::ProfileError;

fn reversal(name: &str) -> PyResult<Reversal> {
    match name {
        "forbid" => Ok(Reversal::Forbid),
        "allow" => Ok(Reversal::Allow),
        other => Err(PyValueError::new_err(format!(
            "reverse: expected \"forbid\" or \"allow\", got {other:?}"
        ))),
    }
}

/// A minimum-time (or exact-duration) jerk-limited move.
#[pyclass(frozen, module = "arcsim")]
pub struct Profile {
    solved: SolvedMove,
}

#[pymethods]
impl Profile {
    /// Duration (s).
    #[getter]
    fn duration_s(&self) -> f64 {
        self.solved.profile.duration()
    }

    /// Time the servo grid added against the continuous profile (s), or None without a period.
    #[getter]
    fn servo_added_time_s(&self) -> Option<f64> {
        self.solved.added_time_s
    }

    /// Highest speed magnitude reached (deg/s).
    #[getter]
    fn peak_speed_deg_per_s(&self) -> f64 {
        let e = self.solved.profile.extrema();
        e.max_velocity.max(-e.min_velocity)
    }

    /// The constant-jerk phases: numpy arrays `start_s`, `duration_s`, `jerk_deg_per_s3`.
    #[getter]
    fn phases<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let segs = self.solved.profile.segments();
        let mut start = Vec::with_capacity(segs.len());
        let mut t = 0.0;
        for s in segs {
            start.push(t);
            t += s.duration;
        }
        let d = PyDict::new(py);
        d.set_item("start_s", start.into_pyarray(py))?;
        let dur: Vec<f64> = segs.iter().map(|s| s.duration).collect();
        d.set_item("duration_s", dur.into_pyarray(py))?;
        let jerk: Vec<f64> = segs.iter().map(|s| s.jerk).collect();
        d.set_item("jerk_deg_per_s3", jerk.into_pyarray(py))?;
        Ok(d)
    }

    /// The state at times `t` (s; a number or numpy array, clamped to the move): numpy arrays
    /// `position_deg`, `speed_deg_per_s`, `accel_deg_per_s2`, `jerk_deg_per_s3`.
    fn sample<'py>(&self, py: Python<'py>, t: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyDict>> {
        let times: Vec<f64> = broadcast("t", t, None)?;
        if times.iter().any(|x| !x.is_finite()) {
            return Err(PyValueError::new_err("t: expected finite times"));
        }
        let p = &self.solved.profile;
        let states: Vec<_> = py.detach(|| times.iter().map(|&x| p.state_at(x)).collect());
        let d = PyDict::new(py);
        let col =
            |f: fn(&arcsim_planner::State) -> f64| -> Vec<f64> { states.iter().map(f).collect() };
        d.set_item("position_deg", col(|s| s.position).into_pyarray(py))?;
        d.set_item("speed_deg_per_s", col(|s| s.velocity).into_pyarray(py))?;
        d.set_item("accel_deg_per_s2", col(|s| s.acceleration).into_pyarray(py))?;
        d.set_item("jerk_deg_per_s3", col(|s| s.jerk).into_pyarray(py))?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!(
            "Profile({:.9} s, {} phases)",
            self.duration_s(),
            self.solved.profile.segments().len()
        )
    }
}

/// The minimum-time move over `distance` (deg) from `v_start` to `v_end` (deg/s) within the
/// limits `jerk`, `accel`, `vel` (and `decel`, default `accel`), as `arcsim profile` computes it:
/// with `min_duration` (s; 0: no minimum) it lasts the shortest duration of at least that long
/// (that value itself when the move can last it), with `period_s` every phase is on the servo grid,
/// `reverse` "forbid" (default) or "allow" a move against the travel. Raises ProfileError when
/// there is no such move.
#[pyfunction]
#[pyo3(signature = (distance, v_start, v_end, jerk, accel, vel, decel=None, min_duration=None, period_s=None, reverse="forbid"))]
// Each Python keyword argument of the signature above is one Rust parameter: pyo3 needs them all.
#[allow(clippy::too_many_arguments)]
pub fn profile(
    distance: &Bound<'_, PyAny>,
    v_start: &Bound<'_, PyAny>,
    v_end: &Bound<'_, PyAny>,
    jerk: &Bound<'_, PyAny>,
    accel: &Bound<'_, PyAny>,
    vel: &Bound<'_, PyAny>,
    decel: Option<&Bound<'_, PyAny>>,
    min_duration: Option<&Bound<'_, PyAny>>,
    period_s: Option<&Bound<'_, PyAny>>,
    reverse: &str,
) -> PyResult<Profile> {
    let distance = number("distance", distance)?;
    let v_start = number("v_start", v_start)?;
    let v_end = number("v_end", v_end)?;
    let jerk = positive("jerk", jerk)?;
    let accel = positive("accel", accel)?;
    let vel = positive("vel", vel)?;
    let decel = opt_number("decel", decel)?;
    if let Some(d) = decel {
        check_positive("decel", d)?;
    }
    let min_duration = opt_number("min_duration", min_duration)?;
    if let Some(t) = min_duration.filter(|&t| t < 0.0) {
        return Err(PyValueError::new_err(format!(
            "min_duration: expected a number >= 0, got {t}"
        )));
    }
    let period_s = opt_number("period_s", period_s)?;
    if let Some(ts) = period_s {
        check_positive("period_s", ts)?;
    }
    let request = MoveRequest {
        mv: Move {
            distance,
            v_start,
            v_end,
        },
        jerk_deg_per_s3: jerk,
        accel_deg_per_s2: accel,
        decel_deg_per_s2: decel,
        speed_deg_per_s: vel,
        min_duration_s: min_duration,
        period_s,
        reverse: reversal(reverse)?,
    };
    solve(&request)
        .map(|solved| Profile { solved })
        .map_err(ProfileError::new_err)
}

/// [`MoveRequest::solve`], a panic (a bug) turned into an error message too.
fn solve(request: &MoveRequest) -> Result<SolvedMove, String> {
    std::panic::catch_unwind(|| request.solve())
        .map_err(|_| "the planner panicked (a bug in arcsim)".to_string())?
        .map_err(|e: MoveError| e.to_string())
}

/// A numpy array or a number, broadcast to `n`.
fn broadcast(name: &str, x: &Bound<'_, PyAny>, n: Option<usize>) -> PyResult<Vec<f64>> {
    if is_scalar(x) {
        return Ok(vec![number(name, x)?; n.unwrap_or(1)]);
    }
    let v = floats(name, x)?;
    match n {
        Some(n) if v.len() != n => Err(PyValueError::new_err(format!(
            "{name}: {} values, expected {n} (the length of the other arrays) or one number",
            v.len()
        ))),
        _ => Ok(v),
    }
}

/// Many moves at once: every argument a number or a 1-D array (all arrays of one length), solved
/// in parallel with the GIL released. Returns numpy arrays `duration_s` (NaN where there is no
/// profile), `ok` (bool), `peak_speed_deg_per_s` (NaN where not ok) and a list `error` (None
/// where ok, else the message).
#[pyfunction]
#[pyo3(signature = (distance, v_start, v_end, jerk, accel, vel, decel=None, min_duration=None, period_s=None, reverse="forbid"))]
// Each Python keyword argument of the signature above is one Rust parameter: pyo3 needs them all.
#[allow(clippy::too_many_arguments)]
pub fn profile_batch<'py>(
    py: Python<'py>,
    distance: &Bound<'py, PyAny>,
    v_start: &Bound<'py, PyAny>,
    v_end: &Bound<'py, PyAny>,
    jerk: &Bound<'py, PyAny>,
    accel: &Bound<'py, PyAny>,
    vel: &Bound<'py, PyAny>,
    decel: Option<&Bound<'py, PyAny>>,
    min_duration: Option<&Bound<'py, PyAny>>,
    period_s: Option<&Bound<'py, PyAny>>,
    reverse: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let reverse = reversal(reverse)?;
    let period_s = opt_number("period_s", period_s)?;
    if let Some(ts) = period_s {
        check_positive("period_s", ts)?;
    }
    let mut inputs: Vec<(&str, &Bound<'py, PyAny>)> = vec![
        ("distance", distance),
        ("v_start", v_start),
        ("v_end", v_end),
        ("jerk", jerk),
        ("accel", accel),
        ("vel", vel),
    ];
    inputs.extend(decel.map(|d| ("decel", d)));
    inputs.extend(min_duration.map(|d| ("min_duration", d)));
    // The length: that of the first array given.
    let n = inputs
        .iter()
        .find_map(|(_, x)| (!is_scalar(x)).then(|| broadcast("", x, None).ok().map(|v| v.len())))
        .flatten();
    let mut cols = Vec::with_capacity(inputs.len());
    for (name, x) in &inputs {
        cols.push(broadcast(name, x, n)?);
    }
    for ((name, x), col) in inputs.iter().zip(&cols) {
        let (what, ok): (&str, fn(f64) -> bool) = match *name {
            "jerk" | "accel" | "vel" | "decel" => ("a number > 0", |x| x > 0.0),
            "min_duration" => ("a number >= 0", |x| x >= 0.0),
            _ => continue,
        };
        match col.iter().position(|&v| !ok(v)) {
            Some(_) if is_scalar(x) => {
                return Err(PyValueError::new_err(format!(
                    "{name}: expected {what}, got {}",
                    col[0]
                )))
            }
            Some(_) => check_each(name, col, what, ok)?,
            None => {}
        }
    }
    let len = n.unwrap_or(1);
    let get = |name: &str| -> Option<&Vec<f64>> {
        inputs
            .iter()
            .position(|(n, _)| *n == name)
            .map(|i| &cols[i])
    };
    let (d, vs, ve, j, a, v) = (&cols[0], &cols[1], &cols[2], &cols[3], &cols[4], &cols[5]);
    let dec = get("decel");
    let mind = get("min_duration");
    let results: Vec<Result<SolvedMove, String>> = py.detach(|| {
        (0..len)
            .into_par_iter()
            .map(|k| {
                solve(&MoveRequest {
                    mv: Move {
                        distance: d[k],
                        v_start: vs[k],
                        v_end: ve[k],
                    },
                    jerk_deg_per_s3: j[k],
                    accel_deg_per_s2: a[k],
                    decel_deg_per_s2: dec.map(|x| x[k]),
                    speed_deg_per_s: v[k],
                    min_duration_s: mind.map(|x| x[k]),
                    period_s,
                    reverse,
                })
            })
            .collect()
    });
    batch_output(py, &results)
}

/// The dict `profile_batch` returns, from the solved moves in order.
fn batch_output<'py>(
    py: Python<'py>,
    results: &[Result<SolvedMove, String>],
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let duration: Vec<f64> = results
        .iter()
        .map(|r| r.as_ref().map_or(f64::NAN, |s| s.profile.duration()))
        .collect();
    let peak: Vec<f64> = results
        .iter()
        .map(|r| {
            r.as_ref().map_or(f64::NAN, |s| {
                let e = s.profile.extrema();
                e.max_velocity.max(-e.min_velocity)
            })
        })
        .collect();
    let ok: Vec<bool> = results.iter().map(Result::is_ok).collect();
    let errors = PyList::empty(py);
    for r in results {
        match r {
            Ok(_) => errors.append(py.None())?,
            Err(e) => errors.append(e)?,
        }
    }
    out.set_item("duration_s", duration.into_pyarray(py))?;
    out.set_item("ok", ok.into_pyarray(py))?;
    out.set_item("peak_speed_deg_per_s", peak.into_pyarray(py))?;
    out.set_item("error", errors)?;
    Ok(out)
}
