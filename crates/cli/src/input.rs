//! Reading the inputs every subcommand shares: plans and machine models, with CLI-ready errors.
//! A plan is either native JSON or a DICOM RT Ion Plan, told apart by content ("DICM" after the
//! 128-byte preamble), not by extension.

use std::io::Read;
use std::path::Path;

use arcsim_plan::{ArcPlan, Machine, PlanError};

use crate::CliError;

/// The ATOM machine, built into the binary so commands work without a `--machine` file.
pub const DEFAULT_MACHINE_JSON: &str = include_str!("../../../scenarios/machine-atom.json");
/// Name the built-in machine goes by in messages.
pub const DEFAULT_MACHINE_SOURCE: &str = "built-in scenarios/machine-atom.json";

/// Largest input file read (bytes): far above any real plan (a 1,000-beam DICOM plan is tens of
/// MB), low enough that a wrong file (or an endless stream) is refused before memory runs out.
pub const MAX_INPUT_BYTES: u64 = 512 << 20;

/// Reads a whole input once: a file, or standard input for `-` (so pipes and FIFOs work).
pub fn read_input(path: &Path) -> Result<Vec<u8>, CliError> {
    let shown = path.display();
    let cannot = |e: std::io::Error| CliError::failed(format!("{shown}: cannot read: {e}"));
    let mut bytes = Vec::new();
    if path.as_os_str() == "-" {
        std::io::stdin()
            .lock()
            .take(MAX_INPUT_BYTES + 1)
            .read_to_end(&mut bytes)
            .map_err(cannot)?;
    } else {
        let file = std::fs::File::open(path).map_err(cannot)?;
        if file.metadata().is_ok_and(|m| m.is_dir()) {
            return Err(CliError::failed(format!(
                "{shown}: is a directory; expected a file"
            )));
        }
        file.take(MAX_INPUT_BYTES + 1)
            .read_to_end(&mut bytes)
            .map_err(cannot)?;
    }
    if bytes.len() as u64 > MAX_INPUT_BYTES {
        return Err(CliError::failed(format!(
            "{shown}: larger than {} MiB; not a plan, machine or sweep file",
            MAX_INPUT_BYTES >> 20
        )));
    }
    Ok(bytes)
}

/// An input as UTF-8 text (JSON files).
pub fn read_text(path: &Path) -> Result<String, CliError> {
    let bytes = read_input(path)?;
    String::from_utf8(bytes).map_err(|e| {
        CliError::failed(format!(
            "{}: not UTF-8 text (invalid byte at offset {}); expected a JSON file",
            path.display(),
            e.utf8_error().valid_up_to()
        ))
    })
}

/// Name of an input in messages: the path, or "standard input" for `-`.
pub fn input_name(path: &Path) -> String {
    if path.as_os_str() == "-" {
        "standard input".to_string()
    } else {
        path.display().to_string()
    }
}

/// Loads and validates a plan (a file, or `-` for standard input), read once; the error lists every
/// problem, one per line. DICOM RT Ion Plans (recognised by content, or by a .dcm/.dicom extension
/// so a broken one gets a DICOM message) are imported with `arcsim-dicom`.
pub fn load_plan(path: &Path) -> Result<ArcPlan, CliError> {
    let dicom_extension = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("dcm") || e.eq_ignore_ascii_case("dicom"));
    let bytes = read_input(path)?;
    if dicom_extension || arcsim_dicom::has_dicom_magic(&bytes) {
        let stem = path
            .file_stem()
            .filter(|_| path.as_os_str() != "-")
            .map(|s| s.to_string_lossy().into_owned());
        return arcsim_dicom::read_rt_ion_plan_from_bytes_named(
            &bytes,
            stem.as_deref().unwrap_or(arcsim_dicom::DEFAULT_PLAN_NAME),
        )
        .map_err(|e| crate::import::dicom_error(path, e));
    }
    let name = input_name(path);
    let text = String::from_utf8(bytes).map_err(|e| {
        CliError::failed(format!(
            "{name}: neither a DICOM file nor UTF-8 text (invalid byte at offset {}); expected an arcsim-plan/1 JSON file or a DICOM RT Ion Plan",
            e.utf8_error().valid_up_to()
        ))
    })?;
    arcsim_plan::parse_plan(&text, &name).map_err(plan_error)
}

/// Loads the machine file at `path` (`-`: standard input), or the built-in ATOM machine when
/// `path` is `None`.
pub fn load_machine(path: Option<&Path>) -> Result<Machine, CliError> {
    match path {
        Some(p) => arcsim_plan::parse_machine(&read_text(p)?, &input_name(p)),
        None => arcsim_plan::parse_machine(DEFAULT_MACHINE_JSON, DEFAULT_MACHINE_SOURCE),
    }
    .map_err(plan_error)
}

/// Bad input data: exit code 1 with the located message.
pub fn plan_error(err: PlanError) -> CliError {
    CliError::failed(err.to_string())
}
