//! # arcsim (Python)
//!
//! The arcsim engine as a Python extension module (`import arcsim`), built with PyO3 and maturin
//! into an abi3 wheel (CPython ≥ 3.9). It converts between Python and the library crates and adds
//! no logic of its own: plans and machines are read as `arcsim-app` reads them for the CLI,
//! results are the CLI's (`to_json()` is `simulate --json`), and every long computation runs
//! with the GIL released. Errors are Python exceptions carrying the CLI's located messages.

#![warn(missing_docs)]

use pyo3::create_exception;
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::prelude::*;

mod convert;
mod inputs;
mod log;
mod logtools;
mod profile;
mod resequence;
mod simulate;
mod sweep;

create_exception!(
    arcsim,
    PlanError,
    PyValueError,
    "A plan or machine that cannot be read or is invalid (the message says where)."
);
create_exception!(
    arcsim,
    LogError,
    PyValueError,
    "A delivery log that cannot be read (the message gives file, line and column)."
);
create_exception!(
    arcsim,
    SweepError,
    PyValueError,
    "A sweep file (or dict) that cannot be read or is invalid."
);
create_exception!(
    arcsim,
    ProfileError,
    PyValueError,
    "A move with invalid input or no feasible profile."
);
create_exception!(
    arcsim,
    SimulationError,
    PyRuntimeError,
    "The sequencer found no feasible delivery (or failed to verify one)."
);
create_exception!(
    arcsim,
    SweepInterrupted,
    PyKeyboardInterrupt,
    "Ctrl-C during a sweep: `.result` holds the rows finished before it."
);

#[pymodule]
fn arcsim(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add(
        "__doc__",
        "arcsim: proton-arc delivery on a jerk-limited gantry (plans, simulate, profiles, sweeps).",
    )?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("PlanError", py.get_type::<PlanError>())?;
    m.add("SweepError", py.get_type::<SweepError>())?;
    m.add("LogError", py.get_type::<LogError>())?;
    m.add("ProfileError", py.get_type::<ProfileError>())?;
    m.add("SimulationError", py.get_type::<SimulationError>())?;
    m.add("SweepInterrupted", py.get_type::<SweepInterrupted>())?;
    m.add_class::<inputs::Plan>()?;
    m.add_class::<inputs::Machine>()?;
    m.add_function(wrap_pyfunction!(inputs::load_plan, m)?)?;
    m.add_function(wrap_pyfunction!(inputs::load_machine, m)?)?;
    m.add_function(wrap_pyfunction!(log::load_log, m)?)?;
    m.add_class::<logtools::Comparison>()?;
    m.add_function(wrap_pyfunction!(logtools::compare, m)?)?;
    m.add_function(wrap_pyfunction!(logtools::calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(logtools::calibrate_spots, m)?)?;
    m.add_class::<simulate::Delivery>()?;
    m.add_function(wrap_pyfunction!(simulate::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(resequence::resequence, m)?)?;
    m.add_function(wrap_pyfunction!(resequence::write_resequenced_dicom, m)?)?;
    m.add_function(wrap_pyfunction!(simulate::schedule_arrays, m)?)?;
    m.add_class::<profile::Profile>()?;
    m.add_function(wrap_pyfunction!(profile::profile, m)?)?;
    m.add_function(wrap_pyfunction!(profile::profile_batch, m)?)?;
    m.add_class::<sweep::SweepResult>()?;
    m.add_function(wrap_pyfunction!(sweep::sweep, m)?)?;
    Ok(())
}
