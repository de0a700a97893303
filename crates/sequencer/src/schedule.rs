//! Choosing the layer speeds of every arc: the options' schedule, on a servo period if one is set.

use arcsim_plan::ResolvedArc;
use arcsim_planner::Limits;

use crate::optimal::{optimal, speed_free_scan};
use crate::prescribed::prescribed_speeds;
use crate::problem::{arc_time_on_grid, moving_time, moving_time_on, ArcProblem};
use crate::scan::{polished_scan, scan, scan_converged};
use crate::{Options, Schedule, SpeedBound, Violation};

/// Layer speeds chosen for every arc (magnitudes, delivery order), what bounds each, and the
/// prescribed speeds that could not be delivered.
pub(crate) struct ChosenSpeeds {
    pub(crate) speeds: Vec<Vec<f64>>,
    pub(crate) bounds: Vec<Vec<SpeedBound>>,
    pub(crate) violations: Vec<Violation>,
    /// Per arc and layer, the least duration of the move into the layer beyond its ELST (s):
    /// one speed per arc cruises between layers (gap / speed). Empty: the ELST alone.
    pub(crate) min_move_s: Vec<Vec<f64>>,
}

/// Runs the options' schedule on every arc.
pub(crate) fn choose_speeds(
    arcs: &[ResolvedArc],
    problems: &[ArcProblem],
    limits: &Limits,
    opts: &Options,
) -> ChosenSpeeds {
    let mut chosen = ChosenSpeeds {
        speeds: Vec::with_capacity(arcs.len()),
        bounds: Vec::with_capacity(arcs.len()),
        violations: Vec::new(),
        min_move_s: Vec::new(),
    };
    let mut first_layer = 0;
    let period = opts.servo_period_s;
    for (arc, p) in arcs.iter().zip(problems) {
        let (v, b) = match opts.schedule {
            Schedule::StepAndShoot => (vec![0.0; p.len()], vec![SpeedBound::StepAndShoot; p.len()]),
            Schedule::Scan => scan_speeds(p, limits, period),
            Schedule::Optimal => optimal_speeds(p, limits, period),
            Schedule::Prescribed => {
                let (v, b, found) = prescribed_speeds(arc, p, limits, first_layer, period);
                chosen.violations.extend(found);
                (v, b)
            }
        };
        chosen.speeds.push(v);
        chosen.bounds.push(b);
        first_layer += p.len();
    }
    chosen
}

/// The scan's speeds, from the scan of the arc without V ([`speed_free_scan`]: the same start
/// at every V that cuts none of its speeds, so raising V does not move it). On a servo period,
/// the continuous scan's speeds are kept where their
/// transitions fit the grid and lowered only where not, so a period never shortens a transition
/// (a scan from the caps on a fine grid could settle on other, faster speeds); the scan from the
/// caps is the fallback when that repair does not settle.
fn scan_speeds(
    p: &ArcProblem,
    limits: &Limits,
    period: Option<f64>,
) -> (Vec<f64>, Vec<SpeedBound>) {
    let settled = speed_free_scan(p, limits);
    on_period(p, limits, polished_scan(p, limits, settled), period)
}

/// Continuous-time scan speeds `cont` on a servo period: kept where their transitions fit the
/// grid, lowered where not (the scan from the caps if that does not settle).
fn on_period(
    p: &ArcProblem,
    limits: &Limits,
    cont: (Vec<f64>, Vec<SpeedBound>),
    period: Option<f64>,
) -> (Vec<f64>, Vec<SpeedBound>) {
    match period {
        Some(_) => scan_converged(p, limits, &cont.0, &cont.1, true, period)
            .unwrap_or_else(|| scan(p, limits, &p.speed_cap, &p.cap_bound, true, period)),
        None => cont,
    }
}

/// Most passes of the grid-timed search on a servo period.
const GRID_PASSES: usize = 8;

/// The optimal schedule's speeds, each labelled with what bounds it.
fn optimal_speeds(
    p: &ArcProblem,
    limits: &Limits,
    period: Option<f64>,
) -> (Vec<f64>, Vec<SpeedBound>) {
    let (upper, _) = scan(p, limits, &p.speed_cap, &p.cap_bound, false, None);
    // The search's seed: the scan from the caps the arc has without V, the same at every V that
    // cuts none of its speeds (see `optimal`'s module doc: why `optimal` is monotone in V).
    let (seed, seed_bounds) = speed_free_scan(p, limits);
    // The search is local: the `scan` schedule (which avoids stops at ELSTs, from the same seed)
    // can sit in a better basin, and `optimal` is never worse than it. The two are independent
    // and run side by side.
    let ((found, found_time), fast) = rayon::join(
        || optimal(p, limits, &upper, &seed, None),
        || polished_scan(p, limits, (seed.clone(), seed_bounds.clone())),
    );
    let labels = found
        .iter()
        .zip(&seed_bounds)
        .enumerate()
        .map(|(k, (&v, &sb))| {
            if (v - p.speed_cap[k]).abs() <= 1e-12 * (1.0 + v) {
                p.cap_bound[k]
            } else if v == seed[k] {
                sb
            } else {
                SpeedBound::Optimised
            }
        })
        .collect::<Vec<_>>();
    let (best, b) = if moving_time(p, limits, &fast.0) < found_time {
        fast.clone()
    } else {
        (found, labels)
    };
    let Some(ts) = period else {
        return (best, b);
    };
    // The optimum is found in continuous time; the scan then lowers any speeds whose transitions
    // cannot be put on the servo grid. Other candidates can do better, and the shortest is
    // kept: the servo-aware scan from the caps, the search's seed repaired on the grid, and
    // `scan` on the same period, so `optimal` is never worse than `scan`.
    let repaired = scan(p, limits, &best, &b, true, period);
    let direct = scan(p, limits, &p.speed_cap, &p.cap_bound, true, period);
    let seeded = scan_converged(p, limits, &seed, &seed_bounds, true, period);
    // The scan from the caps (not the V-free seed) repaired on the grid: one more start, so a
    // servo-period total is never longer than the one the caps' scan gives.
    let capped = scan(p, limits, &p.speed_cap, &p.cap_bound, true, None);
    let capped = scan_converged(p, limits, &capped.0, &capped.1, true, period);
    let scanned = on_period(p, limits, fast, period);
    let time = |v: &[f64]| arc_time_on_grid(p, v, limits, ts);
    let (start, start_bounds) = [Some(direct), seeded, capped, Some(scanned)]
        .into_iter()
        .flatten()
        .fold(repaired, |a, c| if time(&c.0) < time(&a.0) { c } else { a });
    // The same search with every transition timed on the period, its first grids holding the
    // best of those, repeated from its own result while that improves: a grid-timed cost is
    // flat between ticks, so one pass often stops on a plateau that the next one leaves.
    let start_time = moving_time_on(p, limits, &start, period);
    let (mut on_grid, mut on_grid_time) = (start.clone(), start_time);
    for _ in 0..GRID_PASSES {
        let (v, t) = optimal(p, limits, &upper, &on_grid, period);
        if t >= on_grid_time * (1.0 - 1e-9) {
            break;
        }
        (on_grid, on_grid_time) = (v, t);
    }
    if on_grid_time < start_time {
        let labels = on_grid
            .iter()
            .zip(&start)
            .zip(&start_bounds)
            .map(|((&v, &s), &b)| if v == s { b } else { SpeedBound::Optimised })
            .collect();
        (on_grid, labels)
    } else {
        (start, start_bounds)
    }
}
