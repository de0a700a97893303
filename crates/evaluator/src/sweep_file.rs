//! The sweep file format `arcsim-sweep/1` (JSON): its serde types and parsing with located errors.
//! Field-by-field documentation: `scenarios/README.md`, section "Sweeps".

use std::fmt;

use arcsim_sequencer::{ArcEnds, Motion, Schedule};
use serde::de::value::{MapAccessDeserializer, SeqAccessDeserializer};
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use serde::{Deserialize, Serialize};

use crate::EvalError;

/// Value of the `format` field of every sweep file.
pub const SWEEP_FORMAT: &str = "arcsim-sweep/1";

/// A sweep file as written.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepFile {
    /// Must equal [`SWEEP_FORMAT`].
    pub format: String,
    /// The sweep's name, carried into its outputs.
    pub name: String,
    /// Free text describing the sweep.
    #[serde(default)]
    pub description: Option<String>,
    /// Plan files (paths or globs relative to the sweep file) and ATOM article cases.
    pub plans: Vec<PlanSource>,
    /// The base machine (path relative to the sweep file); every axis varies one of its values.
    pub machine: String,
    /// The axes swept for every schedule (an absent axis stays at the base machine's value).
    #[serde(default)]
    pub axes: Axes,
    /// The schedules to run: a name, or `{"schedule": NAME, "axes": {..}}` whose axes replace the
    /// top-level ones (e.g. `optimal` on a coarser grid).
    pub schedules: Vec<ScheduleEntry>,
    /// Build each timeline to report kinematic margins (slower); default false.
    #[serde(default)]
    pub margins: bool,
    /// Give every constant-speed row the certificate: a proven lower bound of every
    /// constant-speed schedule and the gap to it (seconds per row); default false.
    #[serde(default)]
    pub certify: bool,
    /// The time the summary's "cheapest change" must reach; default `{"saving_percent": 10}`.
    #[serde(default)]
    pub target: Option<Target>,
    /// Re-sequencing as a what-if beside the gantry's axes: `[false, true]` runs every plan as
    /// given and re-sequenced (`true` or `[true]`: re-sequenced only); default as given only.
    #[serde(default)]
    pub resequence: Option<Resequence>,
}

/// The sweep file's `resequence`: one value or a list of them.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum Resequence {
    /// `true` or `false`.
    One(bool),
    /// `[false, true]` and the like.
    Values(Vec<bool>),
}

impl Resequence {
    /// (as given, re-sequenced): which of the two a plan is run as.
    pub fn runs(&self) -> (bool, bool) {
        match self {
            Resequence::One(b) => (!b, *b),
            Resequence::Values(v) => (v.contains(&false), v.contains(&true)),
        }
    }
}

/// Where a plan comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum PlanSource {
    /// A plan file, or a glob matching several (relative to the sweep file).
    Path(String),
    /// A case of the ATOM article reference file: `{"atom_case": "prostate", "reference": PATH}`.
    AtomCase {
        /// The case name (e.g. `prostate`).
        atom_case: String,
        /// The reference file (relative to the sweep file).
        reference: String,
    },
    /// One plan file under a name of the sweep's choosing: `{"path": PATH, "name": NAME}`
    /// (e.g. a bundled ATOM plan keeping the `atom:CASE` label of its reference-file entry).
    Named {
        /// The plan file (relative to the sweep file).
        path: String,
        /// The label its rows carry.
        name: String,
    },
}

/// The swept axes; each is absent (the base machine's value), one number, a list of numbers,
/// `{"values": [..]}` or `{"from": .., "to": .., "steps": .., "scale": "linear" | "log"}`.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Axes {
    /// Gantry jerk limit J (deg/s³).
    #[serde(default)]
    pub jerk_deg_per_s3: Option<AxisSpec>,
    /// Gantry acceleration limit A (deg/s²); an explicit deceleration limit scales with it.
    #[serde(default)]
    pub accel_deg_per_s2: Option<AxisSpec>,
    /// Gantry speed limit V (deg/s).
    #[serde(default)]
    pub speed_deg_per_s: Option<AxisSpec>,
    /// Upward energy-layer switching time (s); needs a `constant` ELST model.
    #[serde(default)]
    pub elst_up_s: Option<AxisSpec>,
    /// Downward energy-layer switching time (s).
    #[serde(default)]
    pub elst_down_s: Option<AxisSpec>,
    /// Tolerance window of every control point (deg), replacing the plan's and the machine's.
    #[serde(default)]
    pub window_deg: Option<AxisSpec>,
    /// Scanning speed of the beam model (mm/s, both axes); needs a `scanning` beam model.
    #[serde(default)]
    pub scan_speed_mm_per_s: Option<AxisSpec>,
    /// Dose-rate scale (dimensionless, > 0): every time per MU of the beam model divided by it
    /// (2: twice the dose rate).
    #[serde(default)]
    pub dose_rate_scale: Option<AxisSpec>,
    /// Pause between two bursts of a layer (s, ≥ 0); needs a `scanning` beam model.
    #[serde(default)]
    pub burst_switching_time_s: Option<AxisSpec>,
    /// Charge of one spill (MU, > 0); needs a beam model with spills.
    #[serde(default)]
    pub spill_charge_mu: Option<AxisSpec>,
    /// Time to the next spill (s, ≥ 0); needs a beam model with spills.
    #[serde(default)]
    pub spill_refill_time_s: Option<AxisSpec>,
    /// Most layers one spill serves (whole numbers ≥ 1; 1: no multi-energy extraction); needs a
    /// beam model with multi-energy extraction.
    #[serde(default)]
    pub spill_max_layers: Option<AxisSpec>,
}

/// How a range's values are spaced.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Scale {
    /// Equal spacing.
    #[default]
    Linear,
    /// Geometric spacing (equal ratios), for limits spanning orders of magnitude.
    Log,
}

/// One axis as written.
#[derive(Debug, Clone, PartialEq)]
pub enum AxisSpec {
    /// These values, in this order.
    Values(Vec<f64>),
    /// `steps` values from `from` to `to`, both ends included, spaced by `scale`.
    Range {
        /// First value, in the axis's unit.
        from: f64,
        /// Last value, in the axis's unit.
        to: f64,
        /// Number of values.
        steps: usize,
        /// Spacing of the values.
        scale: Scale,
    },
}

/// One entry of `schedules`.
#[derive(Debug, Clone, PartialEq)]
pub struct ScheduleEntry {
    /// The speed schedule of each layer.
    pub schedule: Schedule,
    /// Constant speed per layer or free motion; `None`: the base machine's controller's.
    pub motion: Option<Motion>,
    /// Arc ends at rest (default) or free (free motion only).
    pub arc_ends: ArcEnds,
    /// Axes replacing the top-level ones for this schedule (per axis).
    pub axes: Option<Axes>,
}

/// The target of the summary's cheapest change: `{"saving_percent": P}` or `{"total_s": T}` (one
/// field, checked when the file is parsed: T finite and > 0, 0 <= P < 100).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Target {
    /// An absolute total delivery time (s).
    TotalS(f64),
    /// A saving of this many percent of the base machine's total.
    SavingPercent(f64),
}

impl Default for Target {
    fn default() -> Self {
        Target::SavingPercent(10.0)
    }
}

impl Target {
    /// The total time to reach given the base machine's total.
    pub fn total_s(self, base_total_s: f64) -> f64 {
        match self {
            Target::TotalS(t) => t,
            Target::SavingPercent(p) => base_total_s * (1.0 - p / 100.0),
        }
    }
}

impl AxisSpec {
    /// Number of values (`steps` for a range), without computing them.
    pub fn len(&self) -> usize {
        match *self {
            AxisSpec::Values(ref v) => v.len(),
            AxisSpec::Range { steps, .. } => steps,
        }
    }

    /// Whether the axis has no value.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Value `i` (< [`AxisSpec::len`]), computed on demand: for a range of `steps` values,
    /// `from + f·(to − from)` (linear) or `from·(to/from)^f` (log) with `f = i/(steps − 1)`, and
    /// exactly `to` for the last one (a one-step range is `from`).
    ///
    /// # Panics
    /// If `i` is out of range.
    pub fn value(&self, i: usize) -> f64 {
        match *self {
            AxisSpec::Values(ref v) => v[i],
            AxisSpec::Range {
                from,
                to,
                steps,
                scale,
            } => {
                assert!(i < steps, "axis value {i} of {steps}");
                if steps == 1 {
                    from
                } else if i + 1 == steps {
                    to
                } else {
                    let f = i as f64 / (steps - 1) as f64;
                    match scale {
                        Scale::Linear => from + f * (to - from),
                        Scale::Log => from * (to / from).powf(f),
                    }
                }
            }
        }
    }

    /// The values of the axis, in the order written (ranges from `from` to `to`).
    ///
    /// Materialises the whole axis: prefer [`AxisSpec::len`] and [`AxisSpec::value`] for a range
    /// that may be long.
    pub fn values(&self) -> Vec<f64> {
        (0..self.len()).map(|i| self.value(i)).collect()
    }
}

/// Parses a sweep file's text; `file` names it in every error.
///
/// A UTF-8 byte-order mark at the start of the text is ignored. Besides the JSON shape, the
/// `format` and the `target` values are checked here; the axes are checked when the sweep is
/// built ([`crate::Sweep::from_text`]), against the base machine.
pub fn parse_sweep_file(text: &str, file: &str) -> Result<SweepFile, EvalError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut de = serde_json::Deserializer::from_str(text);
    let parsed: Result<SweepFile, _> = serde_path_to_error::deserialize(&mut de);
    let sweep = match parsed {
        Ok(s) => {
            de.end().map_err(|e| json_error(file, "", &e))?;
            s
        }
        Err(e) => {
            if let Some(err) = wrong_format(text, file) {
                return Err(err);
            }
            return Err(json_error(file, &e.path().to_string(), e.inner()));
        }
    };
    if sweep.format != SWEEP_FORMAT {
        return Err(EvalError::sweep(
            file,
            "format",
            format!("expected \"{SWEEP_FORMAT}\", got \"{}\"", sweep.format),
        ));
    }
    match sweep.target {
        Some(Target::TotalS(t)) if !(t.is_finite() && t > 0.0) => {
            return Err(EvalError::sweep(
                file,
                "target.total_s",
                format!("expected a total time finite and > 0 s, got {t}"),
            ));
        }
        Some(Target::SavingPercent(p)) if !(p.is_finite() && (0.0..100.0).contains(&p)) => {
            return Err(EvalError::sweep(
                file,
                "target.saving_percent",
                format!("expected a saving >= 0 and < 100 (percent of the base machine's total), got {p}"),
            ));
        }
        _ => {}
    }
    Ok(sweep)
}

/// A JSON error located as `FILE: FIELD: message (line L, column C)`: the position left out when
/// serde_json does not know it, the field cut before the first part of the path that
/// serde_path_to_error could not name (it writes `?` there, as in a syntax error inside an object).
fn json_error(file: &str, path: &str, e: &serde_json::Error) -> EvalError {
    let msg = e.to_string();
    let msg = msg.rfind(" at line ").map_or(msg.as_str(), |i| &msg[..i]);
    let known: Vec<&str> = path
        .split('.')
        .take_while(|part| !part.is_empty() && !part.starts_with('?'))
        .collect();
    let field = known.join(".");
    let kind = match e.classify() {
        serde_json::error::Category::Syntax | serde_json::error::Category::Eof => {
            "malformed JSON: "
        }
        _ => "",
    };
    let position = if e.line() > 0 {
        format!(" (line {}, column {})", e.line(), e.column())
    } else {
        String::new()
    };
    EvalError::sweep(file, field, format!("{kind}{msg}{position}"))
}

fn wrong_format(text: &str, file: &str) -> Option<EvalError> {
    let value: serde_json::Value = serde_json::from_str(text).ok()?;
    let found = match value.as_object()?.get("format") {
        None => "no `format` field".to_string(),
        Some(serde_json::Value::String(s)) if s == SWEEP_FORMAT => return None,
        Some(other) => other.to_string(),
    };
    Some(EvalError::sweep(
        file,
        "format",
        format!("expected \"{SWEEP_FORMAT}\", got {found}; this is not a sweep file"),
    ))
}

// ---- serde for the entries that take several shapes ----

/// The object form of a plan entry: an ATOM case (`atom_case`, `reference`) or a named plan
/// file (`path`, `name`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PlanObject {
    atom_case: Option<String>,
    reference: Option<String>,
    path: Option<String>,
    name: Option<String>,
}

impl<'de> Deserialize<'de> for PlanSource {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = PlanSource;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(
                    "a plan path or glob, {\"path\": PATH, \"name\": NAME} or {\"atom_case\": NAME, \"reference\": PATH}",
                )
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<PlanSource, E> {
                Ok(PlanSource::Path(s.to_string()))
            }
            fn visit_map<M: MapAccess<'de>>(self, map: M) -> Result<PlanSource, M::Error> {
                let o = PlanObject::deserialize(MapAccessDeserializer::new(map))?;
                match o {
                    PlanObject {
                        atom_case: Some(atom_case),
                        reference: Some(reference),
                        path: None,
                        name: None,
                    } => Ok(PlanSource::AtomCase {
                        atom_case,
                        reference,
                    }),
                    PlanObject {
                        atom_case: None,
                        reference: None,
                        path: Some(path),
                        name: Some(name),
                    } => Ok(PlanSource::Named { path, name }),
                    _ => Err(de::Error::custom(
                        "expected {\"path\": PATH, \"name\": NAME} or {\"atom_case\": NAME, \"reference\": PATH}, with both fields and nothing else",
                    )),
                }
            }
        }
        d.deserialize_any(V)
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AxisObject {
    #[serde(default)]
    values: Option<Vec<f64>>,
    #[serde(default)]
    from: Option<f64>,
    #[serde(default)]
    to: Option<f64>,
    #[serde(default)]
    steps: Option<usize>,
    #[serde(default)]
    scale: Option<Scale>,
}

impl<'de> Deserialize<'de> for AxisSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = AxisSpec;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number, a list of numbers, {\"values\": [..]} or {\"from\": .., \"to\": .., \"steps\": ..}")
            }
            fn visit_f64<E: de::Error>(self, x: f64) -> Result<AxisSpec, E> {
                Ok(AxisSpec::Values(vec![x]))
            }
            fn visit_u64<E: de::Error>(self, x: u64) -> Result<AxisSpec, E> {
                Ok(AxisSpec::Values(vec![x as f64]))
            }
            fn visit_i64<E: de::Error>(self, x: i64) -> Result<AxisSpec, E> {
                Ok(AxisSpec::Values(vec![x as f64]))
            }
            fn visit_seq<S: SeqAccess<'de>>(self, seq: S) -> Result<AxisSpec, S::Error> {
                Vec::<f64>::deserialize(SeqAccessDeserializer::new(seq)).map(AxisSpec::Values)
            }
            fn visit_map<M: MapAccess<'de>>(self, map: M) -> Result<AxisSpec, M::Error> {
                let o = AxisObject::deserialize(MapAccessDeserializer::new(map))?;
                match o {
                    AxisObject { values: Some(v), from: None, to: None, steps: None, scale: None } => Ok(AxisSpec::Values(v)),
                    AxisObject { values: None, from: Some(from), to: Some(to), steps: Some(steps), scale } => {
                        Ok(AxisSpec::Range { from, to, steps, scale: scale.unwrap_or_default() })
                    }
                    AxisObject { values: Some(_), .. } => {
                        Err(de::Error::custom("expected either \"values\" or \"from\"/\"to\"/\"steps\", not both"))
                    }
                    _ => Err(de::Error::custom(
                        "expected {\"values\": [..]} or all three of \"from\", \"to\" and \"steps\" (\"scale\" optional)",
                    )),
                }
            }
        }
        d.deserialize_any(V)
    }
}

/// `target` as written: exactly one of the two fields, checked after parsing it (an externally
/// tagged enum would answer "both fields" with a bare syntax error).
#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "{\"total_s\": SECONDS} or {\"saving_percent\": PERCENT}"
)]
struct TargetObject {
    #[serde(default)]
    total_s: Option<f64>,
    #[serde(default)]
    saving_percent: Option<f64>,
}

impl<'de> Deserialize<'de> for Target {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match TargetObject::deserialize(d)? {
            TargetObject {
                total_s: Some(t),
                saving_percent: None,
            } => Ok(Target::TotalS(t)),
            TargetObject {
                total_s: None,
                saving_percent: Some(p),
            } => Ok(Target::SavingPercent(p)),
            TargetObject {
                total_s: Some(_),
                saving_percent: Some(_),
            } => Err(de::Error::custom(
                "give either `total_s` (a total time in s) or `saving_percent` (a saving in percent of the base machine's total), not both",
            )),
            TargetObject {
                total_s: None,
                saving_percent: None,
            } => Err(de::Error::custom(
                "expected `total_s` (a total time in s) or `saving_percent` (a saving in percent of the base machine's total), e.g. {\"saving_percent\": 10}",
            )),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ScheduleObject {
    schedule: Schedule,
    #[serde(default)]
    motion: Option<Motion>,
    #[serde(default)]
    arc_ends: ArcEnds,
    #[serde(default)]
    axes: Option<Axes>,
}

impl<'de> Deserialize<'de> for ScheduleEntry {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ScheduleEntry;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a schedule name (prescribed, scan, optimal, step-and-shoot) or {\"schedule\": NAME, \"motion\": \"free\", \"arc_ends\": \"free\", \"axes\": {..}}")
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<ScheduleEntry, E> {
                let schedule = s.parse::<Schedule>().map_err(E::custom)?;
                Ok(ScheduleEntry {
                    schedule,
                    motion: None,
                    arc_ends: ArcEnds::Rest,
                    axes: None,
                })
            }
            fn visit_map<M: MapAccess<'de>>(self, map: M) -> Result<ScheduleEntry, M::Error> {
                let o = ScheduleObject::deserialize(MapAccessDeserializer::new(map))?;
                if let (Some(m), ArcEnds::Free) = (o.motion, o.arc_ends) {
                    if !m.speed_changes_during_beam() {
                        return Err(de::Error::custom(format!(
                            "arc_ends \"free\" needs \"motion\": \"free\" (a {} arc starts and ends at rest)",
                            m.adjective()
                        )));
                    }
                }
                Ok(ScheduleEntry {
                    schedule: o.schedule,
                    motion: o.motion,
                    arc_ends: o.arc_ends,
                    axes: o.axes,
                })
            }
        }
        d.deserialize_any(V)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(text: &str) -> String {
        parse_sweep_file(text, "s.json")
            .expect_err("should fail")
            .to_string()
    }

    const OK: &str = r#"{"format": "arcsim-sweep/1", "name": "t", "plans": ["a.json", {"atom_case": "liver", "reference": "r.json"}],
        "machine": "m.json", "axes": {"jerk_deg_per_s3": [0.5, 1], "accel_deg_per_s2": {"from": 0.25, "to": 1, "steps": 3},
        "speed_deg_per_s": 5, "window_deg": {"values": [1]}},
        "schedules": ["scan", {"schedule": "optimal", "axes": {"jerk_deg_per_s3": {"from": 0.1, "to": 10, "steps": 3, "scale": "log"}}}]}"#;

    #[test]
    fn malformed_json_is_located_by_line_and_column_not_by_an_unknown_path() {
        // A syntax error inside an object: serde_path_to_error's path is "?".
        assert_eq!(
            err("{,"),
            "s.json: malformed JSON: key must be a string (line 1, column 2)"
        );
        assert_eq!(
            err("{\"format\": \"arcsim-sweep/1\" \"x\"}"),
            "s.json: malformed JSON: expected `,` or `}` (line 1, column 29)"
        );
        // A known path is kept after the position.
        assert_eq!(
            err("{\"format\": \"arcsim-sweep/1\",\n \"plans\": [1]}"),
            "s.json: plans[0]: invalid type: integer `1`, expected a plan path or glob, \
             {\"path\": PATH, \"name\": NAME} or {\"atom_case\": NAME, \"reference\": PATH} \
             (line 2, column 12)"
        );
        assert_eq!(
            err("{\"axes\": {,"),
            "s.json: axes: malformed JSON: key must be a string (line 1, column 11)"
        );
    }

    #[test]
    fn parses_every_shape() {
        let s = parse_sweep_file(OK, "s.json").expect("valid");
        assert_eq!(
            s.plans[1],
            PlanSource::AtomCase {
                atom_case: "liver".into(),
                reference: "r.json".into()
            }
        );
        assert_eq!(
            s.axes.accel_deg_per_s2.as_ref().map(AxisSpec::values),
            Some(vec![0.25, 0.625, 1.0])
        );
        assert_eq!(
            s.axes.speed_deg_per_s.as_ref().map(AxisSpec::values),
            Some(vec![5.0])
        );
        let j = s.schedules[1]
            .axes
            .as_ref()
            .and_then(|a| a.jerk_deg_per_s3.as_ref())
            .map(AxisSpec::values)
            .expect("axis");
        assert!((j[1] - 1.0).abs() < 1e-12 && j[2] == 10.0);
        assert_eq!(s.schedules[1].schedule, Schedule::Optimal);
        assert_eq!(s.target, None);
    }

    #[test]
    fn a_named_plan_needs_a_path_and_a_name_and_nothing_else() {
        let named = OK.replace(
            r#"{"atom_case": "liver", "reference": "r.json"}"#,
            r#"{"path": "p.json", "name": "atom:liver"}"#,
        );
        let s = parse_sweep_file(&named, "s.json").expect("valid");
        assert_eq!(
            s.plans[1],
            PlanSource::Named {
                path: "p.json".into(),
                name: "atom:liver".into()
            }
        );
        for bad in [
            r#"{"path": "p.json"}"#,
            r#"{"name": "x"}"#,
            r#"{"path": "p.json", "name": "x", "reference": "r.json"}"#,
            r#"{"atom_case": "liver"}"#,
        ] {
            let e = err(&OK.replace(r#"{"atom_case": "liver", "reference": "r.json"}"#, bad));
            assert!(
                e.starts_with("s.json: plans[1]: expected {\"path\": PATH, \"name\": NAME} or"),
                "{bad}: {e}"
            );
        }
        let e = err(&OK.replace(
            r#"{"atom_case": "liver", "reference": "r.json"}"#,
            r#"{"path": "p.json", "name": "x", "colour": 1}"#,
        ));
        assert!(e.contains("colour"), "{e}");
    }

    #[test]
    fn errors_are_located() {
        let e = err(&OK.replace("\"steps\": 3}", "\"steps\": \"3\"}"));
        assert!(
            e.starts_with("s.json: axes.accel_deg_per_s2.steps: invalid type"),
            "{e}"
        );
        let e = err(&OK.replace("\"speed_deg_per_s\"", "\"speed\""));
        assert!(
            e.starts_with("s.json: axes.speed: unknown field `speed`"),
            "{e}"
        );
        let e = err(&OK.replace("\"optimal\"", "\"fastest\""));
        assert!(
            e.contains("schedules[1].schedule: unknown variant `fastest`"),
            "{e}"
        );
        let e = err(&OK.replace("\"scan\",", "\"scann\","));
        assert!(e.contains("schedules[0]: unknown schedule 'scann'"), "{e}");
        let e = err(&OK.replace("\"atom_case\"", "\"atomcase\""));
        assert!(e.contains("plans[1].atomcase: unknown field"), "{e}");
        let e = err(&OK.replace("arcsim-sweep/1", "arcsim-plan/1"));
        assert!(
            e.starts_with("s.json: format: expected \"arcsim-sweep/1\""),
            "{e}"
        );
        let e = err(&OK.replace("{\"values\": [1]}", "{\"values\": [1], \"from\": 1}"));
        assert!(e.contains("axes.window_deg: expected either"), "{e}");
        let e = err("{\"format\": \"arcsim-sweep/1\",");
        assert!(e.contains("malformed JSON"), "{e}");
    }
}
