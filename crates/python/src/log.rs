//! Delivery logs: `load_log` reads an `arcsim-log/1` file (or another CSV through a column
//! mapping) as `arcsim compare` will.

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::simulate::records;
use crate::LogError;

/// Reads a delivery log: columns `t_s`, `gantry_angle_deg`, `beam_on` (bool), `energy_mev`,
/// `spot`, `mu` (NaN where empty or where the log has no such column). `columns` maps another
/// CSV's names, as `--columns`: "t_s=TIME,gantry_angle_deg=GantryAngle,beam_on=Beam". Raises
/// LogError with the file, line and column of the first problem.
#[pyfunction]
#[pyo3(signature = (path, columns=None))]
pub fn load_log<'py>(
    py: Python<'py>,
    path: PathBuf,
    columns: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    let map = arcsim_log::ColumnMap::parse(columns.unwrap_or(""), "columns")
        .map_err(|e| LogError::new_err(e.to_string()))?;
    let log = py
        .detach(|| arcsim_log::read_log(&path, &map))
        .map_err(|e| LogError::new_err(e.to_string()))?;
    records(py, &log.samples)
}
