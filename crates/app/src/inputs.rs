//! Plan and machine inputs: recognised by content, parsed and validated, with located errors.

use arcsim_dicom::DicomImportError;
use arcsim_plan::{ArcPlan, Machine, PlanError};

/// The ATOM machine, built in so that every command works without a machine file.
pub const DEFAULT_MACHINE_JSON: &str = include_str!("../../../scenarios/machine-atom.json");
/// Name the built-in machine goes by in messages and results.
pub const DEFAULT_MACHINE_SOURCE: &str = "built-in scenarios/machine-atom.json";

/// Why an input could not be used. Every message starts with the input's name.
#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// A plan or machine that does not parse or validate (the message lists every problem).
    #[error("{0}")]
    Plan(#[from] PlanError),
    /// A DICOM file that is not a usable RT Ion Plan.
    #[error("{name}: {source}")]
    Dicom {
        /// The input's name in messages (a path).
        name: String,
        /// Why it is not a usable RT Ion Plan.
        source: DicomImportError,
    },
    /// Neither DICOM nor UTF-8 text.
    #[error("{name}: neither a DICOM file nor UTF-8 text (invalid byte at offset {offset}); expected an arcsim-plan/1 JSON file or a DICOM RT Ion Plan")]
    NotAPlanFile {
        /// The input's name in messages (a path).
        name: String,
        /// Byte offset of the first invalid UTF-8 byte.
        offset: usize,
    },
    /// A file that cannot be read.
    #[error("{name}: cannot read: {message}")]
    Read {
        /// The input's name in messages (a path).
        name: String,
        /// Why it cannot be read.
        message: String,
    },
    /// An option out of its range (e.g. a servo period).
    #[error("{0}")]
    Option(String),
}

/// SHA-256 of some bytes, as lowercase hex (results name the exact inputs they came from).
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::{Digest, Sha256};
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The plan in `bytes`, read from the input called `name` in messages. A DICOM RT Ion Plan
/// (recognised by content, or by `dicom_extension` so a broken one gets a DICOM message) is
/// imported and named after `stem` when it has neither RTPlanLabel nor RTPlanName; anything else
/// must be an `arcsim-plan/1` JSON document. Also returns the warnings of a DICOM import, each starting
/// with `name` (a JSON plan has none).
pub fn plan_from_bytes_warned(
    name: &str,
    stem: Option<&str>,
    dicom_extension: bool,
    bytes: &[u8],
) -> Result<(ArcPlan, Vec<String>), AppError> {
    if dicom_extension || arcsim_dicom::has_dicom_magic(bytes) {
        return arcsim_dicom::import_rt_ion_plan_from_bytes(
            bytes,
            stem.unwrap_or(arcsim_dicom::DEFAULT_PLAN_NAME),
        )
        .map(|imported| {
            let warnings = imported
                .warnings
                .iter()
                .map(|w| format!("{name}: {w}"))
                .collect();
            (imported.plan, warnings)
        })
        .map_err(|source| AppError::Dicom {
            name: name.to_owned(),
            source,
        });
    }
    let text = std::str::from_utf8(bytes).map_err(|e| AppError::NotAPlanFile {
        name: name.to_owned(),
        offset: e.valid_up_to(),
    })?;
    Ok((arcsim_plan::parse_plan(text, name)?, Vec::new()))
}

/// Reads the plan file at `path` (named by its path in messages) with [`plan_from_bytes_warned`];
/// returns it with the SHA-256 of its bytes.
pub fn read_plan_file(path: &std::path::Path) -> Result<(ArcPlan, String), AppError> {
    read_plan_file_warned(path).map(|(plan, sha256, _)| (plan, sha256))
}

/// [`read_plan_file`], with the warnings of a DICOM import ([`plan_from_bytes_warned`]).
pub fn read_plan_file_warned(
    path: &std::path::Path,
) -> Result<(ArcPlan, String, Vec<String>), AppError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| AppError::Read {
        name: name.clone(),
        message: e.to_string(),
    })?;
    let dicom_extension = has_dicom_extension(path);
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned());
    let (plan, warnings) = plan_from_bytes_warned(&name, stem.as_deref(), dicom_extension, &bytes)?;
    Ok((plan, sha256_hex(&bytes), warnings))
}

/// Whether `path` ends in `.dcm` or `.dicom` (any case): such a file is read, and written, as
/// DICOM.
pub fn has_dicom_extension(path: &std::path::Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("dcm") || e.eq_ignore_ascii_case("dicom"))
}

/// The machine model in `text`, from the input called `name` in messages.
pub fn machine_from_text(name: &str, text: &str) -> Result<Machine, AppError> {
    Ok(arcsim_plan::parse_machine(text, name)?)
}

/// The built-in ATOM machine ([`DEFAULT_MACHINE_JSON`]).
pub fn builtin_machine() -> Machine {
    // Compiled in and checked by this crate's tests: it always parses.
    match arcsim_plan::parse_machine(DEFAULT_MACHINE_JSON, DEFAULT_MACHINE_SOURCE) {
        Ok(m) => m,
        Err(e) => unreachable!("the built-in machine is valid: {e}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_machine_is_the_atom_machine() {
        let m = builtin_machine();
        assert_eq!(m.gantry.max_jerk_deg_per_s3, 0.5);
        assert_eq!(sha256_hex(b"abc").len(), 64);
    }

    #[test]
    fn plans_are_told_apart_by_content() {
        let err = plan_from_bytes_warned("x.json", None, false, &[0xff, 0xfe]).unwrap_err();
        assert!(
            err.to_string().starts_with("x.json: neither a DICOM file"),
            "{err}"
        );
        let err = plan_from_bytes_warned("x.dcm", None, true, b"{}").unwrap_err();
        assert!(matches!(err, AppError::Dicom { .. }), "{err}");
        let err = plan_from_bytes_warned("x.json", None, false, b"{}").unwrap_err();
        assert!(matches!(err, AppError::Plan(_)), "{err}");
    }
}
