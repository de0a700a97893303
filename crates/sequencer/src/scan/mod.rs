//! The bidirectional scan and the searches after it.
//!
//! The scan puts every speed as high as its neighbours allow. Where that leaves a long ELST that
//! the move can only last by stopping and dwelling (the ELST falls in the gap between the
//! durations a move can last without stopping and those with a stop), slightly lower speeds
//! last it without the stop and cost less: [`stop_avoiding_scan`] tries them (at low jerk the
//! plain scan lost up to 4.8 % this way on the ATOM cases). It then [`rebalance`]s the
//! transitions that the ELST made it slow down for: a lower end speed lets the braking before
//! them stay faster (up to 0.46 % on the bundled plans and the ATOM cases). Last, a local
//! search ([`polish`]) moves single speeds and pairs of neighbours in opposite directions where
//! that shortens the arc: the scan only lowers, and on closely spaced layers whose transitions
//! barely exceed their ELSTs the shorter schedule raises one speed and lowers its neighbour
//! (bundled head-neck at J 4, A 1, V 2: 1.14 % above `optimal` before it, 0.33 % after).

mod passes;
mod polish;
mod rebalance;
mod stops;
#[cfg(test)]
pub(crate) mod tests;

use arcsim_planner::Limits;

use crate::problem::ArcProblem;
use crate::SpeedBound;
use passes::{transition_check, Check};
use polish::polish;
use rebalance::rebalance;
use stops::avoid_stops;

pub(crate) use passes::{scan, scan_converged};

/// The `scan` schedule in continuous time: `settled` ([`scan`] from the caps with ELSTs), then
/// [`avoid_stops`] and [`rebalance`].
pub(crate) fn stop_avoiding_scan(
    p: &ArcProblem,
    lim: &Limits,
    settled: (Vec<f64>, Vec<SpeedBound>),
) -> (Vec<f64>, Vec<SpeedBound>) {
    let mut v = settled.0.clone();
    let mut changed = avoid_stops(p, lim, &mut v);
    changed.extend(rebalance(p, lim, &mut v));
    if changed.is_empty() {
        return settled;
    }
    let bound: Vec<SpeedBound> = v
        .iter()
        .zip(settled.0.iter().zip(&settled.1))
        .map(|(&new, (&old, &b))| {
            if new < old {
                SpeedBound::Elst
            } else if new > old {
                SpeedBound::Gap
            } else {
                b
            }
        })
        .collect();
    // Each lowering was kept for a gain over the transitions it changed (all feasible), so the
    // speeds as they are shorten the arc: a check of those transitions confirms it, and the scan
    // settles the speeds again only if one fails.
    let feasible = changed.iter().all(|&(first, last)| {
        (first..=last).all(|k| transition_check(p, k, v[k], v[k + 1], lim, true, None) == Check::Ok)
    });
    if feasible {
        return (v, bound);
    }
    match scan_converged(p, lim, &v, &bound, true, None) {
        Some(again) if moving_time(p, lim, &again.0) < moving_time(p, lim, &settled.0) => again,
        _ => settled,
    }
}

/// The `scan` schedule: [`stop_avoiding_scan`], then [`polish`]; a speed the polish moved is
/// labelled [`SpeedBound::Optimised`].
pub(crate) fn polished_scan(
    p: &ArcProblem,
    lim: &Limits,
    settled: (Vec<f64>, Vec<SpeedBound>),
) -> (Vec<f64>, Vec<SpeedBound>) {
    let (mut v, mut bounds) = stop_avoiding_scan(p, lim, settled);
    let before = v.clone();
    if polish(p, lim, &mut v) {
        for (b, (new, old)) in bounds.iter_mut().zip(v.iter().zip(&before)) {
            if new != old {
                *b = SpeedBound::Optimised;
            }
        }
    }
    (v, bounds)
}

/// Σ transition durations of an arc at speeds `v` (infinite if one is infeasible).
pub(crate) fn moving_time(p: &ArcProblem, lim: &Limits, v: &[f64]) -> f64 {
    moving_time_on(p, lim, v, None)
}

/// Σ transition durations of speeds `v`, on `period` when given; infinite if one is infeasible.
pub(crate) fn moving_time_on(p: &ArcProblem, lim: &Limits, v: &[f64], period: Option<f64>) -> f64 {
    (0..p.len().saturating_sub(1))
        .map(|k| {
            p.cost_on(k, v[k], v[k + 1], lim, period)
                .unwrap_or(f64::INFINITY)
        })
        .sum()
}

/// The highest start speed of transition `k` that still reaches `ve` within its gap (the
/// braking pass's bound); `ve` itself when the planner finds none.
pub(super) fn highest_start(p: &ArcProblem, k: usize, ve: f64, lim: &Limits) -> f64 {
    p.gap(k)
        .max_start_speed(ve, lim)
        .ok()
        .flatten()
        .unwrap_or(ve)
}

/// The highest end speed of transition `k` reachable from `vs` within its gap (the speed-up
/// pass's bound); `vs` itself when the planner finds none.
pub(super) fn highest_end(p: &ArcProblem, k: usize, vs: f64, lim: &Limits) -> f64 {
    p.gap(k).max_end_speed(vs, lim).ok().flatten().unwrap_or(vs)
}

/// Lowers the speeds after layer `k + 1` that rise above what the layer before them can reach,
/// as the scan's forward pass would, until one already can; returns the last transition index
/// `last` such that layers up to `last + 1` may have changed.
pub(super) fn lower_speed_up_after(p: &ArcProblem, k: usize, w: &mut [f64], lim: &Limits) -> usize {
    let mut last = k;
    while last + 2 < w.len() && w[last + 2] > w[last + 1] {
        let b = highest_end(p, last + 1, w[last + 1], lim);
        if w[last + 2] <= b {
            break;
        }
        w[last + 2] = b;
        last += 1;
    }
    last
}
