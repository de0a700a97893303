//! The events file of an IBA-style beam folder: each layer's arc irradiation, its start and end
//! with target and actual angles.

use std::path::Path;

use super::read::read_text;
use super::settings::number;
use super::time::parse_stamp;
use super::{ArcIrradiation, IbaBeam};
use crate::LogError;

/// How far outside its events file's arc irradiation a layer's spots may lie, s.
const EVENT_SLACK_S: f64 = 1.0;

/// The events file's `START_ARC_ANGLE_IRRADIATION` / `END_ARC_ANGLE_IRRADIATION` pairs.
pub(super) fn read_events(
    p: &Path,
    origin: &mut Option<i64>,
) -> Result<Vec<ArcIrradiation>, LogError> {
    let (name, text) = (p.display().to_string(), read_text(p)?);
    let mut arcs = Vec::new();
    let mut open: Option<(f64, f64, f64, u64)> = None;
    for (i, l) in text.lines().enumerate() {
        let line = i as u64 + 1;
        if !l.contains("recordEvent") {
            continue;
        }
        let (start, end) = (
            l.contains("START_ARC_ANGLE_IRRADIATION"),
            l.contains("END_ARC_ANGLE_IRRADIATION"),
        );
        if !(start || end) {
            continue;
        }
        let stamp_text = l.split([',', ';']).next().unwrap_or("");
        let t = parse_stamp(stamp_text)
            .map_err(|m| LogError::at(&name, line, None, m))?
            .since(origin);
        let angle = |key: &str| -> Result<f64, LogError> {
            let at = l.find(key).ok_or_else(|| {
                LogError::at(
                    &name,
                    line,
                    None,
                    format!("no `{key}`; expected Target=… Actual=… angles"),
                )
            })?;
            let v: String = l[at + key.len()..]
                .chars()
                .take_while(|c| !c.is_whitespace() && *c != ',' && *c != ';')
                .collect();
            number(&v, &name, line, key.trim_end_matches('='))
        };
        let (target, actual) = (angle("Target=")?, angle("Actual=")?);
        match (start, open) {
            (true, None) => open = Some((t, target, actual, line)),
            (true, Some(o)) => return Err(LogError::at(&name, line, None, format!("a second START_ARC_ANGLE_IRRADIATION before the one of line {} ended; expected START and END in turn", o.3))),
            (false, None) => return Err(LogError::at(&name, line, None, "END_ARC_ANGLE_IRRADIATION without a START before it")),
            (false, Some((t0, target0, actual0, line0))) => {
                if t < t0 {
                    return Err(LogError::at(&name, line, None, "ends before its start; expected events in time order"));
                }
                arcs.push(ArcIrradiation { start_s: t0, end_s: t, actual_start_deg: actual0, actual_end_deg: actual, target_start_deg: target0, target_end_deg: target, line: line0 });
                open = None;
            }
        }
    }
    if let Some(o) = open {
        return Err(LogError::at(
            &name,
            o.3,
            None,
            "START_ARC_ANGLE_IRRADIATION never ends (no END after it)",
        ));
    }
    Ok(arcs)
}

/// An arc's events pair with its layers in order, each layer's spots within its irradiation.
pub(super) fn check_events(
    beam: &IbaBeam,
    events: Option<&Path>,
    origin: Option<i64>,
) -> Result<(), LogError> {
    let Some(p) = events else { return Ok(()) };
    let name = p.display().to_string();
    if beam.arcs.is_empty() {
        return Ok(());
    }
    if beam.arcs.len() != beam.layers.len() {
        return Err(LogError::file(
            &name,
            format!(
                "{} arc irradiations for {} layers with spots in {}; expected one per layer",
                beam.arcs.len(),
                beam.layers.len(),
                beam.folder
            ),
        ));
    }
    for (a, l) in beam.arcs.iter().zip(&beam.layers) {
        let (first, last) = (l.spots[0].t_start_s, l.spots[l.spots.len() - 1].t_end_s);
        if first < a.start_s - EVENT_SLACK_S || last > a.end_s + EVENT_SLACK_S {
            return Err(LogError::at(&name, a.line, None, {
                let at = |t: f64| super::time::format_stamp(origin.unwrap_or(0) as f64 + t);
                format!("layer {}'s spots ({} to {}) lie outside this arc irradiation; expected each layer within its START/END", l.number, at(first), at(last))
            }));
        }
    }
    Ok(())
}
