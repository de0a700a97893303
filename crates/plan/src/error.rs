//! Errors and located problems. Every message names the file, then the arc, control point and layer
//! (indices from 0, as in the JSON arrays) where relevant, then the field, then what was expected.

use std::fmt;

/// One problem found in a plan or machine, located precisely enough to fix it without searching.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlanIssue {
    /// File name (or other source name) the plan or machine came from.
    pub source: String,
    /// Index of the arc (from 0), when the issue is inside one.
    pub arc: Option<usize>,
    /// Index of the control point within its arc (from 0), when the issue is inside one.
    pub control_point: Option<usize>,
    /// Index of the layer within its control point (from 0), when the issue is inside one.
    pub layer: Option<usize>,
    /// Field path inside the located element, e.g. `energy_mev`, `spots.mu[3]`, `gantry.max_speed_deg_per_s`.
    pub field: String,
    /// What is wrong and what was expected.
    pub message: String,
}

impl PlanIssue {
    pub(crate) fn new(
        source: &str,
        at: At,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        PlanIssue {
            source: source.to_string(),
            arc: at.arc,
            control_point: at.control_point,
            layer: at.layer,
            field: field.into(),
            message: message.into(),
        }
    }

    /// "arc 0, control point 3, layer 1, field `energy_mev`" without the source.
    pub fn location(&self) -> String {
        describe_location(self.arc, self.control_point, self.layer, &self.field)
    }
}

fn describe_location(
    arc: Option<usize>,
    cp: Option<usize>,
    layer: Option<usize>,
    field: &str,
) -> String {
    let mut parts = Vec::new();
    if let Some(a) = arc {
        parts.push(format!("arc {a}"));
    }
    if let Some(c) = cp {
        parts.push(format!("control point {c}"));
    }
    if let Some(l) = layer {
        parts.push(format!("layer {l}"));
    }
    if !field.is_empty() {
        parts.push(format!("field `{field}`"));
    }
    if parts.is_empty() {
        "top level".to_string()
    } else {
        parts.join(", ")
    }
}

impl fmt::Display for PlanIssue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}: {}", self.source, self.location(), self.message)
    }
}

/// Where in a plan an issue is; a small helper so validation code reads naturally.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct At {
    /// Index of the arc (from 0), when the issue is inside one.
    pub arc: Option<usize>,
    /// Index of the control point within its arc (from 0), when the issue is inside one.
    pub control_point: Option<usize>,
    /// Index of the layer within its control point (from 0), when the issue is inside one.
    pub layer: Option<usize>,
}

impl At {
    pub fn top() -> Self {
        At::default()
    }
    pub fn arc(a: usize) -> Self {
        At {
            arc: Some(a),
            ..At::default()
        }
    }
    pub fn cp(a: usize, c: usize) -> Self {
        At {
            arc: Some(a),
            control_point: Some(c),
            layer: None,
        }
    }
    pub fn layer(a: usize, c: usize, l: usize) -> Self {
        At {
            arc: Some(a),
            control_point: Some(c),
            layer: Some(l),
        }
    }
}

/// Why a plan or machine could not be loaded or resolved.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// The file could not be read.
    #[error("{path}: cannot read file: {source}")]
    Io {
        /// The file's path.
        path: String,
        /// Why it could not be read.
        #[source]
        source: std::io::Error,
    },
    /// The text is not valid JSON, or does not have the fields and types of the format.
    #[error("{source_name}:{line}:{column}: {location}: {message}")]
    Json {
        /// The file name (or other source name) of the text.
        source_name: String,
        /// 1-based line and column reported by serde_json (0 when unknown).
        line: usize,
        /// See `line`.
        column: usize,
        /// Arc / control point / layer / field where the error was found, as far as known.
        location: String,
        /// serde_json's message.
        message: String,
    },
    /// The plan or machine parsed but breaks one or more rules; all of them are listed.
    #[error("{source_name}: {} problem{}:\n{}", issues.len(), if issues.len() == 1 { "" } else { "s" }, join_issues(issues))]
    Invalid {
        /// The file name (or other source name) of the plan or machine.
        source_name: String,
        /// Every problem found.
        issues: Vec<PlanIssue>,
    },
}

/// Problems of one kind that are listed once, with their count and first few places.
const GROUP_FROM: usize = 3;
/// Places named for a group.
const GROUP_PLACES: usize = 3;

/// What makes two problems "the same": the field without its indices and the message without
/// its numbers (`spots.mu[3]` and `spots.mu[7]`, "got 150000" and "got 160000").
fn kind_of(issue: &PlanIssue) -> (String, String) {
    let strip = |s: &str| -> String {
        let mut out = String::with_capacity(s.len());
        let mut in_number = false;
        for c in s.chars() {
            let numeric = c.is_ascii_digit() || (in_number && matches!(c, '.' | 'e' | '-' | '+'));
            if numeric {
                if !in_number {
                    out.push('#');
                }
            } else {
                out.push(c);
            }
            in_number = numeric;
        }
        out
    };
    (strip(&issue.field), strip(&issue.message))
}

/// One line per problem; a kind of problem found in many places is one line (the first), then
/// the count and the first few other places.
fn join_issues(issues: &[PlanIssue]) -> String {
    let kinds: Vec<(String, String)> = issues.iter().map(kind_of).collect();
    let mut lines = Vec::new();
    let mut done = vec![false; issues.len()];
    for i in 0..issues.len() {
        if done[i] {
            continue;
        }
        let same: Vec<usize> = (i..issues.len())
            .filter(|&j| !done[j] && kinds[j] == kinds[i])
            .collect();
        lines.push(format!("  {}", issues[i]));
        if same.len() >= GROUP_FROM {
            for &j in &same {
                done[j] = true;
            }
            let others: Vec<String> = same[1..]
                .iter()
                .take(GROUP_PLACES)
                .map(|&j| issues[j].location())
                .collect();
            let more = if same.len() - 1 > GROUP_PLACES {
                "; …"
            } else {
                ""
            };
            lines.push(format!(
                "    and {} more like it: {}{more}",
                same.len() - 1,
                others.join("; ")
            ));
        } else {
            done[i] = true;
        }
    }
    lines.join("\n")
}

impl PlanError {
    /// The located problems of an [`PlanError::Invalid`]; empty for other errors.
    pub fn issues(&self) -> &[PlanIssue] {
        match self {
            PlanError::Invalid { issues, .. } => issues,
            _ => &[],
        }
    }

    /// Turns a serde error with its path into a located [`PlanError::Json`].
    pub(crate) fn from_serde(
        source_name: &str,
        path: Option<&serde_path_to_error::Path>,
        inner: &serde_json::Error,
    ) -> Self {
        let (arc, cp, layer, field) = path.map(split_path).unwrap_or_default();
        let message = strip_position(&inner.to_string());
        let message = match inner.classify() {
            serde_json::error::Category::Syntax if message.contains("number out of range") => {
                format!("{message}: expected a finite number (this one overflows a double)")
            }
            serde_json::error::Category::Syntax => format!("malformed JSON: {message}"),
            serde_json::error::Category::Eof => {
                format!("malformed JSON (unexpected end of file): {message}")
            }
            serde_json::error::Category::Io => format!("cannot read: {message}"),
            serde_json::error::Category::Data => message,
        };
        PlanError::Json {
            source_name: source_name.to_string(),
            line: inner.line(),
            column: inner.column(),
            location: describe_location(arc, cp, layer, &field),
            message,
        }
    }
}

/// serde_json appends " at line L column C"; we print the position in front instead.
fn strip_position(msg: &str) -> String {
    match msg.rfind(" at line ") {
        Some(pos) => msg[..pos].to_string(),
        None => msg.to_string(),
    }
}

/// Splits a serde path like `arcs[0].control_points[3].layers[1].spots.mu` into indices and field.
fn split_path(
    path: &serde_path_to_error::Path,
) -> (Option<usize>, Option<usize>, Option<usize>, String) {
    use serde_path_to_error::Segment;
    let (mut arc, mut cp, mut layer) = (None, None, None);
    let mut field = String::new();
    let mut pending: Option<&str> = None;
    for seg in path.iter() {
        match seg {
            Segment::Map { key } => {
                if let Some(p) = pending.take() {
                    push_field(&mut field, p);
                }
                match key.as_str() {
                    "arcs" if arc.is_none() => pending = Some("arcs"),
                    "control_points" if arc.is_some() && cp.is_none() => {
                        pending = Some("control_points")
                    }
                    "layers" if cp.is_some() && layer.is_none() => pending = Some("layers"),
                    other => push_field(&mut field, other),
                }
            }
            Segment::Seq { index } => match pending.take() {
                Some("arcs") => arc = Some(*index),
                Some("control_points") => cp = Some(*index),
                Some("layers") => layer = Some(*index),
                Some(other) => {
                    push_field(&mut field, other);
                    field.push_str(&format!("[{index}]"));
                }
                None => field.push_str(&format!("[{index}]")),
            },
            Segment::Enum { variant } => push_field(&mut field, variant),
            Segment::Unknown => {}
        }
    }
    if let Some(p) = pending {
        push_field(&mut field, p);
    }
    (arc, cp, layer, field)
}

fn push_field(field: &mut String, name: &str) {
    if !field.is_empty() {
        field.push('.');
    }
    field.push_str(name);
}

/// A number as messages show it: at most 10 significant digits (no float noise such as
/// 2.0100000000000002), and in exponent form when very large or small (1e308, not 309 digits).
pub fn fmt_num(x: f64) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    let rounded: f64 = format!("{x:.9e}").parse().unwrap_or(x);
    let a = rounded.abs();
    if a != 0.0 && !(1e-4..1e9).contains(&a) {
        format!("{rounded:e}")
    } else {
        format!("{rounded}")
    }
}
