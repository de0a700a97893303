//! Reading the inputs every subcommand shares: plans and machine models, with CLI-ready errors.
//! A plan is either native JSON or a DICOM RT Ion Plan, told apart by content ("DICM" after the
//! 128-byte preamble), not by extension.

use std::io::Read;
use std::path::Path;

use arcsim_plan::{ArcPlan, Machine, PlanError};

use crate::CliError;

pub use arcsim_app::{sha256_hex, DEFAULT_MACHINE_JSON, DEFAULT_MACHINE_SOURCE};

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
    load_plan_hashed(path).map(|(plan, _)| plan)
}

/// The file stem a DICOM plan without RTPlanLabel or RTPlanName is named after.
fn stem(path: &Path) -> Option<String> {
    path.file_stem()
        .filter(|_| path.as_os_str() != "-")
        .map(|s| s.to_string_lossy().into_owned())
}

/// The DICOM RT Ion Plan in `bytes` (read from `path`), named after the file's stem when it has
/// neither RTPlanLabel nor RTPlanName. The import's warnings go to standard error.
pub fn dicom_plan(path: &Path, bytes: &[u8]) -> Result<ArcPlan, CliError> {
    arcsim_app::plan_from_bytes_warned(&input_name(path), stem(path).as_deref(), true, bytes)
        .map(print_import_warnings)
        .map_err(|e| CliError::failed(e.to_string()))
}

/// Prints the warnings of a DICOM import to standard error; returns the plan.
fn print_import_warnings((plan, warnings): (ArcPlan, Vec<String>)) -> ArcPlan {
    for w in &warnings {
        eprintln!("warning: {}", crate::output::printable(w));
    }
    plan
}

/// [`load_plan`], with the SHA-256 of the bytes read (to tell edited files apart in results). The
/// warnings of a DICOM import go to standard error.
pub fn load_plan_hashed(path: &Path) -> Result<(ArcPlan, String), CliError> {
    load_plan_with_bytes(path).map(|(plan, bytes)| (plan, sha256_hex(&bytes)))
}

/// [`load_plan`], with the bytes read (a DICOM plan's file, to write a changed plan back).
pub fn load_plan_with_bytes(path: &Path) -> Result<(ArcPlan, Vec<u8>), CliError> {
    let dicom_extension = arcsim_app::has_dicom_extension(path);
    let bytes = read_input(path)?;
    arcsim_app::plan_from_bytes_warned(
        &input_name(path),
        stem(path).as_deref(),
        dicom_extension,
        &bytes,
    )
    .map(|imported| (print_import_warnings(imported), bytes))
    .map_err(|e| CliError::failed(e.to_string()))
}

/// Loads the machine file at `path` (`-`: standard input), or the built-in ATOM machine when
/// `path` is `None`.
pub fn load_machine(path: Option<&Path>) -> Result<Machine, CliError> {
    load_machine_hashed(path).map(|(m, _)| m)
}

/// [`load_machine`], with the SHA-256 of its text.
pub fn load_machine_hashed(path: Option<&Path>) -> Result<(Machine, String), CliError> {
    let (text, name) = match path {
        Some(p) => (read_text(p)?, input_name(p)),
        None => (
            DEFAULT_MACHINE_JSON.to_string(),
            DEFAULT_MACHINE_SOURCE.to_string(),
        ),
    };
    let digest = sha256_hex(text.as_bytes());
    arcsim_app::machine_from_text(&name, &text)
        .map(|m| (m, digest))
        .map_err(|e| CliError::failed(e.to_string()))
}

/// Name of a machine input in messages and results.
pub fn machine_name(path: Option<&Path>) -> String {
    path.map_or_else(|| DEFAULT_MACHINE_SOURCE.to_string(), input_name)
}

/// The plausibility warnings of a plan and a machine (see [`report_warnings`]).
pub fn plausibility(
    plan: &ArcPlan,
    plan_path: &Path,
    machine: &Machine,
    machine_path: Option<&Path>,
) -> Vec<arcsim_plan::Warning> {
    arcsim_app::plausibility(
        plan,
        &input_name(plan_path),
        machine,
        &machine_name(machine_path),
    )
}

/// Prints warnings to standard error; with `strict`, turns them into an error (exit 1).
pub fn report_warnings(warnings: &[arcsim_plan::Warning], strict: bool) -> Result<(), CliError> {
    if strict {
        arcsim_app::refuse_implausible(warnings, "--strict")
            .map_err(|e| CliError::failed(e.to_string()))?;
    }
    for w in warnings {
        eprintln!("warning: {}", crate::output::printable(&w.to_string()));
    }
    Ok(())
}

/// Bad input data: exit code 1 with the located message.
pub fn plan_error(err: PlanError) -> CliError {
    CliError::failed(err.to_string())
}
