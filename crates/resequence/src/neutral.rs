//! The proof that a re-sequenced plan delivers the same dose: the same arcs (each in its own
//! order of control points or the reverse), each control point with the same angle, window and
//! speed, and the same multiset of layers — every energy, spot, MU and position — as the
//! original. Only the order of layers inside a control point, an arc's direction and the arcs'
//! order may differ.

use arcsim_plan::{Arc, ArcPlan, ControlPoint};

/// How a candidate plan differs from the original in what it delivers.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DoseChange {
    /// Not the same number of arcs.
    #[error("the plan has {candidate} arcs where the original has {original}")]
    ArcCount {
        /// The original's arcs.
        original: usize,
        /// The candidate's arcs.
        candidate: usize,
    },
    /// An arc of the candidate matches no unused arc of the original.
    #[error("arc {arc}: its control points are not those of any arc of the original, in either order ({why})")]
    Arc {
        /// The candidate's arc.
        arc: usize,
        /// The first difference against the closest original arc.
        why: String,
    },
    /// The plan's name or format changed.
    #[error("the plan's {field} changed")]
    Field {
        /// `name` or `format`.
        field: &'static str,
    },
}

/// A control point's place and its layers as canonical text, the layers sorted: equal exactly
/// when the control point delivers the same layers, whatever their order.
fn key(cp: &ControlPoint) -> (String, Vec<String>) {
    let place = serde_json::json!({
        "angle_deg": cp.angle_deg,
        "window_deg": cp.window_deg,
        "required_speed_deg_per_s": cp.required_speed_deg_per_s,
    })
    .to_string();
    let mut layers: Vec<String> = cp
        .layers
        .iter()
        .map(|l| serde_json::to_string(l).unwrap_or_default())
        .collect();
    layers.sort();
    (place, layers)
}

/// Why arc `b` (candidate) is not arc `a` (original) in either direction; `None` when it is.
fn arc_difference(a: &Arc, b: &Arc) -> Option<String> {
    if a.control_points.len() != b.control_points.len() {
        return Some(format!(
            "{} control points where the original arc has {}",
            b.control_points.len(),
            a.control_points.len()
        ));
    }
    let ka: Vec<_> = a.control_points.iter().map(key).collect();
    let kb: Vec<_> = b.control_points.iter().map(key).collect();
    let same_way = ka == kb && a.direction == b.direction;
    let reversed = ka.iter().rev().eq(kb.iter()) && a.direction != b.direction;
    if same_way || reversed {
        return None;
    }
    // Name the first control point that differs, read the way the direction says.
    let forward = a.direction == b.direction;
    for (i, got) in kb.iter().enumerate() {
        let want = if forward {
            &ka[i]
        } else {
            &ka[ka.len() - 1 - i]
        };
        if got.0 != want.0 {
            return Some(format!(
                "control point {i}: its angle, window or speed differs"
            ));
        }
        if got.1 != want.1 {
            return Some(format!(
                "control point {i} (angle {} deg): its layers are not the original's (energies, spots, MU and positions as a multiset)",
                b.control_points[i].angle_deg
            ));
        }
    }
    Some("its direction differs with the same order of control points".into())
}

/// Proves `candidate` delivers what `original` delivers (see the module docs), or says where it
/// does not.
pub fn check_same_dose(original: &ArcPlan, candidate: &ArcPlan) -> Result<(), DoseChange> {
    if original.name != candidate.name {
        return Err(DoseChange::Field { field: "name" });
    }
    if original.format != candidate.format {
        return Err(DoseChange::Field { field: "format" });
    }
    if original.arcs.len() != candidate.arcs.len() {
        return Err(DoseChange::ArcCount {
            original: original.arcs.len(),
            candidate: candidate.arcs.len(),
        });
    }
    let mut used = vec![false; original.arcs.len()];
    for (i, arc) in candidate.arcs.iter().enumerate() {
        let mut first_why = None;
        let found = original.arcs.iter().enumerate().position(|(j, o)| {
            if used[j] {
                return false;
            }
            match arc_difference(o, arc) {
                None => true,
                Some(why) => {
                    // Against the original arc at the same place, for the message.
                    if j == i {
                        first_why = Some(why);
                    }
                    false
                }
            }
        });
        match found {
            Some(j) => used[j] = true,
            None => {
                return Err(DoseChange::Arc {
                    arc: i,
                    why: first_why.unwrap_or_else(|| "matches no unused arc".into()),
                })
            }
        }
    }
    Ok(())
}
