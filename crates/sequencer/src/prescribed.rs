//! Prescribed speeds: the plan's required speeds, checked, and lowered where they cannot be
//! delivered.

use arcsim_plan::ResolvedArc;
use arcsim_planner::{Limits, MoveAnalysis, Reversal};

use crate::problem::ArcProblem;
use crate::scan::{scan, scan_converged};
use crate::{SpeedBound, Violation};

/// The prescribed speeds, lowered by the scan where they cannot be delivered, and every point
/// where they could not.
pub(crate) fn prescribed_speeds(
    arc: &ResolvedArc,
    p: &ArcProblem,
    limits: &Limits,
    first_layer: usize,
    period: Option<f64>,
) -> (Vec<f64>, Vec<SpeedBound>, Vec<Violation>) {
    let (caps, caps_bound, mut found) = prescribed_caps(arc, p, limits, first_layer);
    let (mut v, mut b) = scan(p, limits, &caps, &caps_bound, true, None);
    if period.is_some() {
        (v, b) = scan_converged(p, limits, &v, &b, true, period)
            .unwrap_or_else(|| scan(p, limits, &caps, &caps_bound, true, period));
    }
    for viol in &mut found {
        viol.corrected_deg_per_s = v[viol.layer - first_layer];
    }
    (v, b, found)
}

/// Per-layer caps from the plan's required speeds, and every point where they cannot be
/// delivered (above V, window overflow, ends not at rest, transitions that do not fit).
fn prescribed_caps(
    arc: &ResolvedArc,
    p: &ArcProblem,
    lim: &Limits,
    offset: usize,
) -> (Vec<f64>, Vec<SpeedBound>, Vec<Violation>) {
    let n = p.len();
    let mut caps = p.speed_cap.clone();
    let mut bounds = p.cap_bound.clone();
    let mut found = Vec::new();
    let req: Vec<Option<f64>> = arc
        .layers
        .iter()
        .map(|l| l.required_speed_deg_per_s)
        .collect();
    let mut flag = |k: usize, v: f64, reason: String| {
        found.push(Violation {
            layer: offset + k,
            arc: arc.arc_index,
            control_point: arc.layers[k].control_point,
            prescribed_deg_per_s: v,
            corrected_deg_per_s: v,
            reason,
        })
    };
    for k in 0..n {
        let Some(v) = req[k] else { continue };
        if let Some(why) = layer_violation(p, k, v, lim) {
            flag(k, v, why);
        }
        if k > 0 && k + 1 < n && v < caps[k] {
            caps[k] = v;
            bounds[k] = crate::SpeedBound::Prescribed;
        }
    }
    // Transitions between two prescribed (and otherwise valid) speeds.
    for k in 0..n.saturating_sub(1) {
        let (Some(a), Some(b)) = (req[k], req[k + 1]) else {
            continue;
        };
        let (a, b) = (
            if k == 0 { 0.0 } else { a.min(p.speed_cap[k]) },
            if k + 2 == n {
                0.0
            } else {
                b.min(p.speed_cap[k + 1])
            },
        );
        if let Some(why) = transition_violation(p, k, (a, b), lim) {
            flag(k, req[k].unwrap_or(a), why);
        }
    }
    found.sort_by_key(|v| v.layer);
    (caps, bounds, found)
}

/// Why layer `k` cannot be delivered at the prescribed speed `v` (an end of the arc not at
/// rest, above V, or sweeping more than its window); `None` when it can.
fn layer_violation(p: &ArcProblem, k: usize, v: f64, lim: &Limits) -> Option<String> {
    let n = p.len();
    if (k == 0 || k + 1 == n) && v > 0.0 {
        Some("the first and last layers of an arc are delivered at rest".into())
    } else if v > lim.max_vel * (1.0 + 1e-12) {
        Some(format!(
            "above the gantry speed limit V = {} deg/s",
            lim.max_vel
        ))
    } else if v * p.irradiation_s[k] > p.window[k] * (1.0 + 1e-12) {
        Some(format!(
            "sweeps {:.4} deg in {:.4} s, more than the {:.4} deg window",
            v * p.irradiation_s[k],
            p.irradiation_s[k],
            p.window[k]
        ))
    } else {
        None
    }
}

/// Why transition `k` has no move at the speeds `(a, b)` (it does not fit its gap or cannot
/// last its ELST); `None` when it has one.
fn transition_violation(
    p: &ArcProblem,
    k: usize,
    (a, b): (f64, f64),
    lim: &Limits,
) -> Option<String> {
    if p.cost(k, a, b, lim).is_some() {
        return None;
    }
    let mv = p.transition_move(k, a, b);
    Some(match MoveAnalysis::new(&mv, lim, Reversal::Forbid) {
        Err(e) => format!(
            "transition to the next layer does not fit its {:.4} deg gap: {e}",
            mv.distance
        ),
        Ok(_) => format!(
            "transition to the next layer cannot last its {:.3} s energy switch",
            p.elst[k + 1]
        ),
    })
}
