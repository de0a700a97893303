//! Reading plans and machines from JSON text or files. Parsing reports serde_json's line/column and
//! the arc / control point / layer / field; a parsed document is then validated in full.

use std::path::Path;

use serde::de::DeserializeOwned;

use crate::error::{At, PlanError, PlanIssue};
use crate::machine::validate_machine;
use crate::model::{ArcPlan, Machine, MACHINE_FORMAT, PLAN_FORMAT};
use crate::validate::validate_plan;

/// Parses and validates a plan; `source_name` (usually the file name) appears in every message.
pub fn parse_plan(text: &str, source_name: &str) -> Result<ArcPlan, PlanError> {
    let plan: ArcPlan = parse_json(text, source_name, PLAN_FORMAT)?;
    invalid_if_any(source_name, validate_plan(&plan, source_name))?;
    Ok(plan)
}

/// Reads, parses and validates a plan file.
pub fn load_plan(path: impl AsRef<Path>) -> Result<ArcPlan, PlanError> {
    let (text, name) = read(path.as_ref())?;
    parse_plan(&text, &name)
}

/// Parses and validates a machine model.
pub fn parse_machine(text: &str, source_name: &str) -> Result<Machine, PlanError> {
    let machine: Machine = parse_json(text, source_name, MACHINE_FORMAT)?;
    invalid_if_any(source_name, validate_machine(&machine, source_name))?;
    Ok(machine)
}

/// Reads, parses and validates a machine file.
pub fn load_machine(path: impl AsRef<Path>) -> Result<Machine, PlanError> {
    let (text, name) = read(path.as_ref())?;
    parse_machine(&text, &name)
}

pub(crate) fn invalid_if_any(source_name: &str, issues: Vec<PlanIssue>) -> Result<(), PlanError> {
    if issues.is_empty() {
        Ok(())
    } else {
        Err(PlanError::Invalid {
            source_name: source_name.to_string(),
            issues,
        })
    }
}

fn read(path: &Path) -> Result<(String, String), PlanError> {
    let name = path.display().to_string();
    match std::fs::read_to_string(path) {
        Ok(text) => Ok((text, name)),
        Err(source) => Err(PlanError::Io { path: name, source }),
    }
}

fn parse_json<T: DeserializeOwned>(
    text: &str,
    source_name: &str,
    format: &str,
) -> Result<T, PlanError> {
    // A byte-order mark (some Windows editors write one) is not JSON; skip it.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut de = serde_json::Deserializer::from_str(text);
    let parsed: Result<T, _> = serde_path_to_error::deserialize(&mut de);
    match parsed {
        Ok(value) => match de.end() {
            Ok(()) => Ok(value),
            Err(e) => Err(PlanError::from_serde(source_name, None, &e)),
        },
        // A file of another format (or version) fails on some field deep inside; say what matters.
        Err(e) => Err(wrong_format(text, source_name, format)
            .unwrap_or_else(|| PlanError::from_serde(source_name, Some(e.path()), e.inner()))),
    }
}

/// When the text is a JSON object whose `format` is missing or not `format`, the error to report.
fn wrong_format(text: &str, source_name: &str, format: &str) -> Option<PlanError> {
    let value: serde_json::Value = serde_json::from_str(text).ok()?;
    let found = match value.as_object()?.get("format") {
        None => "no `format` field".to_string(),
        Some(serde_json::Value::String(s)) if s == format => return None,
        Some(other) => format!("{other}"),
    };
    let issue = PlanIssue::new(
        source_name,
        At::top(),
        "format",
        format!("expected \"{format}\", got {found}; this file is not in the {format} format"),
    );
    Some(PlanError::Invalid {
        source_name: source_name.to_string(),
        issues: vec![issue],
    })
}
