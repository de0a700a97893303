//! Delivery logs: `load_log` reads an `arcsim-log/1` file (or another CSV through a column
//! mapping, or a DICOM RT Ion Beams Treatment Record) as `arcsim compare` will.

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::simulate::records;

/// Reads a delivery log: columns `t_s`, `gantry_angle_deg`, `beam_on` (bool), `energy_mev`,
/// `spot`, `mu` (NaN where empty or where the log has no such column). `columns` maps another
/// CSV's names, as `--columns`: "t_s=TIME,gantry_angle_deg=GantryAngle,beam_on=Beam". Raises
/// LogError with the file, line and column of the first problem. A DICOM RT Ion Beams Treatment
/// Record is read as the beam-on intervals of its control points (two beam-on rows per interval).
#[pyfunction]
#[pyo3(signature = (path, columns=None))]
pub fn load_log<'py>(
    py: Python<'py>,
    path: PathBuf,
    columns: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    let log = py.detach(|| crate::logtools::read(&path, columns))?;
    records(py, &log.samples)
}
