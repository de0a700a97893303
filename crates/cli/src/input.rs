//! Reading the inputs every subcommand shares: plans and machine models, with CLI-ready errors.
//! A plan is either native JSON or a DICOM RT Ion Plan, told apart by content ("DICM" after the
//! 128-byte preamble), not by extension.

use std::path::Path;

use arcsim_plan::{ArcPlan, Machine, PlanError};

use crate::CliError;

/// The ATOM machine, built into the binary so commands work without a `--machine` file.
pub const DEFAULT_MACHINE_JSON: &str = include_str!("../../../scenarios/machine-atom.json");
/// Name the built-in machine goes by in messages.
pub const DEFAULT_MACHINE_SOURCE: &str = "built-in scenarios/machine-atom.json";

/// Loads and validates a plan file; the error lists every problem, one per line. DICOM RT Ion Plans
/// (recognised by content, or by a .dcm/.dicom extension so a broken one gets a DICOM message) are
/// imported with `arcsim-dicom`.
pub fn load_plan(path: &Path) -> Result<ArcPlan, CliError> {
    let dicom_extension = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("dcm") || e.eq_ignore_ascii_case("dicom"));
    if dicom_extension || arcsim_dicom::is_dicom_file(path) {
        return arcsim_dicom::read_rt_ion_plan(path)
            .map_err(|e| crate::import::dicom_error(path, e));
    }
    arcsim_plan::load_plan(path).map_err(plan_error)
}

/// Loads the machine file at `path`, or the built-in ATOM machine when `path` is `None`.
pub fn load_machine(path: Option<&Path>) -> Result<Machine, CliError> {
    match path {
        Some(p) => arcsim_plan::load_machine(p),
        None => arcsim_plan::parse_machine(DEFAULT_MACHINE_JSON, DEFAULT_MACHINE_SOURCE),
    }
    .map_err(plan_error)
}

/// Bad input data: exit code 1 with the located message.
pub fn plan_error(err: PlanError) -> CliError {
    CliError::failed(err.to_string())
}
