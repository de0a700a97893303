//! The log's MU column against the plan: a log whose layers carry other MU than the plan's is
//! of another plan (or in another unit), even when its energies and angles match, and timing
//! fits from it would blame the plan (a plan with its layers' MU reversed gave a negative s/MU).

use arcsim_plan::{ArcPlan, ResolvedArc};

use crate::matching::{LoggedLayer, MatchError};
use crate::DeliveryLog;

/// The median logged/plan MU ratio may differ from 1 by this much (a dose monitor's calibration
/// drifts by a few percent; a unit slip or another plan by far more).
pub const MU_RATIO_TOLERANCE: f64 = 0.05;

/// A layer's logged MU may differ from its plan's (after the median ratio) by this much.
pub const LAYER_MU_TOLERANCE: f64 = 0.2;

/// `(arc, control point, layer)` of each layer of `arcs`, in delivery order.
pub(crate) fn delivery_order(arcs: &[ResolvedArc]) -> Vec<(usize, usize, usize)> {
    arcs.iter()
        .flat_map(|a| {
            a.layers
                .iter()
                .map(move |l| (a.arc_index, l.control_point, l.layer))
        })
        .collect()
}

/// Checks the log's `mu` column (when it has one) against the plan's layers matched in
/// `logged`: the MU delivered from a layer's beam-on to the next layer's, per layer. Errors name
/// the first layer that differs.
pub fn check_mu(
    log: &DeliveryLog,
    plan: &ArcPlan,
    arcs: &[ResolvedArc],
    logged: &[LoggedLayer],
) -> Result<(), MatchError> {
    if !log.has_mu {
        return Ok(());
    }
    let delivery_order = delivery_order(arcs);
    let fail = |message: String| MatchError {
        file: log.source.clone(),
        message,
    };
    let plan_mu = |&(arc, cp, layer): &(usize, usize, usize)| -> Option<f64> {
        let l = plan
            .arcs
            .get(arc)?
            .control_points
            .get(cp)?
            .layers
            .get(layer)?;
        l.spots.as_ref().map(arcsim_plan::layer_mu)
    };
    let s = &log.samples;
    let mut rows = Vec::new();
    let mut i = 0;
    for (k, l) in logged.iter().enumerate() {
        let until = logged.get(k + 1).map_or(f64::INFINITY, |n| n.start_s);
        while i < s.len() && s[i].t_s < l.start_s {
            i += 1;
        }
        let mut mu = 0.0;
        while i < s.len() && s[i].t_s < until {
            mu += s[i].mu.unwrap_or(0.0);
            i += 1;
        }
        if let Some(p) = delivery_order
            .get(l.index)
            .and_then(plan_mu)
            .filter(|p| *p > 0.0)
        {
            rows.push((l.index, mu, p));
        }
    }
    if rows.is_empty() {
        return Ok(());
    }
    let mut ratios: Vec<f64> = rows.iter().map(|r| r.1 / r.2).collect();
    ratios.sort_by(f64::total_cmp);
    let median = ratios[ratios.len() / 2];
    if !((1.0 - MU_RATIO_TOLERANCE)..=(1.0 + MU_RATIO_TOLERANCE)).contains(&median) {
        return Err(fail(format!(
            "the mu column gives {median:.4} times the plan's MU (median over {} layers; expected 1 within {} %): MU in another unit (charge?), or a log of another plan",
            rows.len(),
            100.0 * MU_RATIO_TOLERANCE
        )));
    }
    let off: Vec<&(usize, f64, f64)> = rows
        .iter()
        .filter(|r| (r.1 / (median * r.2) - 1.0).abs() > LAYER_MU_TOLERANCE)
        .collect();
    if off.len() * 10 > rows.len() {
        let (index, mu, p) = *off[0];
        let (arc, cp, layer) = delivery_order[index];
        return Err(fail(format!(
            "the mu column differs from the plan's MU in {} of {} layers by more than {} %; the first: layer {index} (arc {arc}, control point {cp}, layer {layer}) logged {mu:.4} MU, the plan {p:.4} MU: a log of another plan?",
            off.len(),
            rows.len(),
            100.0 * LAYER_MU_TOLERANCE
        )));
    }
    Ok(())
}
