//! The bidirectional scan and the `scan` schedule built on it.
//!
//! The scan puts every speed as high as its neighbours allow. Where that leaves a long ELST that
//! the move can only last by stopping and dwelling (the ELST falls in the gap between the
//! durations a move can last without stopping and those with a stop), slightly lower speeds
//! last it without the stop and cost less: [`avoid_stops`] tries them. [`rebalance`] then
//! revisits the transitions that the ELST made the scan slow down for: a lower end speed lets the
//! braking before them stay faster. Last, a local search ([`polish`]) moves single speeds and
//! pairs of neighbours in opposite directions where that shortens the arc: the scan only lowers,
//! and on closely spaced layers whose transitions barely exceed their ELSTs the shorter schedule
//! raises one speed and lowers its neighbour.

use crate::polish::polish;
use crate::problem::{moving_time, ArcProblem};
use crate::rebalance::rebalance;
use crate::servo::grid_duration_in;
use crate::stops::avoid_stops;
use arcsim_planner::{Limits, LinearGap, MoveAnalysis, Reversal};

use crate::SpeedBound;

/// Bidirectional scan: start from `caps`, then lower speeds that cannot be reached (forward
/// pass) or left (backward pass) within their gaps, with the planner's exact bounds; with
/// `with_elst`, also lower both speeds of a transition that cannot last its ELST (by a common
/// factor, bisected). Repeats until nothing changes; the result is feasible.
pub(crate) fn scan(
    p: &ArcProblem,
    lim: &Limits,
    caps: &[f64],
    bounds: &[SpeedBound],
    with_elst: bool,
    period: Option<f64>,
) -> (Vec<f64>, Vec<SpeedBound>) {
    scan_converged(p, lim, caps, bounds, with_elst, period).unwrap_or_else(|| {
        // Not settled after MAX_ROUNDS (never seen in continuous time): rest is always feasible.
        (vec![0.0; p.len()], vec![SpeedBound::StepAndShoot; p.len()])
    })
}

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

/// The highest start speed of transition `k` that still reaches `ve` within its gap (the
/// braking pass's bound); `ve` itself when the planner finds none.
pub(crate) fn highest_start(p: &ArcProblem, k: usize, ve: f64, lim: &Limits) -> f64 {
    p.gap(k)
        .max_start_speed(ve, lim)
        .ok()
        .flatten()
        .unwrap_or(ve)
}

/// The highest end speed of transition `k` reachable from `vs` within its gap (the speed-up
/// pass's bound); `vs` itself when the planner finds none.
pub(crate) fn highest_end(p: &ArcProblem, k: usize, vs: f64, lim: &Limits) -> f64 {
    p.gap(k).max_end_speed(vs, lim).ok().flatten().unwrap_or(vs)
}

/// Rounds of passes after which [`scan_converged`] gives up.
const MAX_ROUNDS: usize = 200;

/// [`scan`], or `None` when the speeds have not settled after [`MAX_ROUNDS`] rounds (on a servo
/// period, speeds on a reachability bound can keep failing the grid one neighbour after another).
pub(crate) fn scan_converged(
    p: &ArcProblem,
    lim: &Limits,
    caps: &[f64],
    bounds: &[SpeedBound],
    with_elst: bool,
    period: Option<f64>,
) -> Option<(Vec<f64>, Vec<SpeedBound>)> {
    let n = p.len();
    let mut s = Speeds {
        v: caps.to_vec(),
        bound: bounds.to_vec(),
    };
    if n < 2 {
        return Some((s.v, s.bound));
    }
    // Speeds only ever come down; each check is skipped while the pair it last passed with is
    // unchanged (most transitions settle in the first round).
    let mut braked_ok: Vec<Option<(f64, f64)>> = vec![None; n - 1];
    let mut sped_ok: Vec<Option<(f64, f64)>> = vec![None; n - 1];
    let mut move_ok: Vec<Option<(f64, f64)>> = vec![None; n - 1];
    for round in 0..MAX_ROUNDS {
        let mut changed = s.braking_pass(p, lim, &mut braked_ok);
        changed |= s.speed_up_pass(p, lim, &mut sped_ok);
        let (v, bound) = (&mut s.v, &mut s.bound);
        for k in 0..n - 1 {
            if move_ok[k] == Some((v[k], v[k + 1])) {
                continue;
            }
            // A move that does not fit its gap is the passes' job (next round); here only the
            // transitions whose move fits but cannot last the ELST, or that the passes could not
            // settle after many rounds.
            let check = transition_check(p, k, v[k], v[k + 1], lim, with_elst, period);
            if check == Check::DoesNotFit && round < 100 {
                changed = true;
                continue;
            }
            if check != Check::Ok {
                let lo = feasible_factor(p, k, (v[k], v[k + 1]), lim, with_elst, period);
                let why = if check == Check::OffServoGrid {
                    SpeedBound::Servo
                } else if with_elst {
                    SpeedBound::Elst
                } else {
                    SpeedBound::Gap
                };
                for i in [k, k + 1] {
                    if v[i] > 0.0 {
                        v[i] *= lo;
                        bound[i] = why;
                    }
                }
                changed = true;
            }
            move_ok[k] = Some((v[k], v[k + 1]));
        }
        if !changed {
            break;
        }
        if round == MAX_ROUNDS - 1 {
            return None;
        }
    }
    Some((s.v, s.bound))
}

/// The speeds of a scan in progress and what bounds each.
struct Speeds {
    v: Vec<f64>,
    bound: Vec<SpeedBound>,
}

impl Speeds {
    /// Backward pass, braking branch (v_k >= v_k+1): each speed lowered to the highest start
    /// that still reaches the next; `ok` holds the pairs already checked. Whether any changed.
    fn braking_pass(
        &mut self,
        p: &ArcProblem,
        lim: &Limits,
        ok: &mut [Option<(f64, f64)>],
    ) -> bool {
        let (v, bound) = (&mut self.v, &mut self.bound);
        let mut changed = false;
        for k in (0..v.len() - 1).rev() {
            if v[k] > v[k + 1] && ok[k] != Some((v[k], v[k + 1])) {
                let b = highest_start(p, k, v[k + 1], lim);
                if v[k] > b {
                    v[k] = b;
                    bound[k] = SpeedBound::Gap;
                    changed = true;
                }
                ok[k] = Some((v[k], v[k + 1]));
            }
        }
        changed
    }

    /// Forward pass, speed-up branch (v_k > v_k-1): each speed lowered to the highest end
    /// reachable from the one before; `ok` holds the pairs already checked. Whether any changed.
    fn speed_up_pass(
        &mut self,
        p: &ArcProblem,
        lim: &Limits,
        ok: &mut [Option<(f64, f64)>],
    ) -> bool {
        let (v, bound) = (&mut self.v, &mut self.bound);
        let mut changed = false;
        for k in 1..v.len() {
            if v[k] > v[k - 1] && ok[k - 1] != Some((v[k - 1], v[k])) {
                let b = highest_end(p, k - 1, v[k - 1], lim);
                if v[k] > b {
                    v[k] = b;
                    bound[k] = SpeedBound::Gap;
                    changed = true;
                }
                ok[k - 1] = Some((v[k - 1], v[k]));
            }
        }
        changed
    }
}

/// Largest common factor of transition `k`'s speeds `(vs, ve)` that makes it feasible (rest
/// always is), to 2^-12 of the range searched. Below the factor at which stopping fits in the
/// gap, a stop and dwell lasts any ELST (and any whole number of servo periods beyond it), so
/// the search starts there, with or without a period: the same search keeps a period from
/// choosing speeds whose transitions are shorter.
fn feasible_factor(
    p: &ArcProblem,
    k: usize,
    (vs, ve): (f64, f64),
    lim: &Limits,
    with_elst: bool,
    period: Option<f64>,
) -> f64 {
    let (mut lo, mut hi) = (
        if with_elst {
            stop_fits_scale(p, k, vs, ve, lim)
        } else {
            0.0
        },
        1.0f64,
    );
    let ok = |s: f64| transition_check(p, k, s * vs, s * ve, lim, with_elst, period) == Check::Ok;
    let resolution = (hi - lo) / 4096.0;
    // Often nothing above the start is feasible: one test settles it.
    if ok(lo + resolution) {
        lo += resolution;
        while hi - lo > resolution {
            let mid = 0.5 * (lo + hi);
            if ok(mid) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
    }
    lo
}

/// Largest factor `s` in [0, 1] such that the gantry can brake from `s·vs` to rest and start
/// again to `s·ve` within the gap of transition `k` (then a dwell at rest makes the transition
/// last as long as any ELST); 0 (rest) if the speeds are out of range.
fn stop_fits_scale(p: &ArcProblem, k: usize, vs: f64, ve: f64, lim: &Limits) -> f64 {
    p.gap(k).max_stop_scale(vs, ve, lim).unwrap_or(0.0)
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Check {
    Ok,
    DoesNotFit,
    TooShortForElst,
    /// Feasible in continuous time, but no duration of a whole number of servo periods is.
    OffServoGrid,
}

/// Whether transition `k` at `vs`, `ve` is feasible: a forward move fits its gap and (with
/// `with_elst`) some such move lasts at least the ELST, and (with a servo `period`) lasts a
/// whole number of periods. Closed-form tests first; root solves only where they cannot decide.
fn transition_check(
    p: &ArcProblem,
    k: usize,
    vs: f64,
    ve: f64,
    lim: &Limits,
    with_elst: bool,
    period: Option<f64>,
) -> Check {
    if !p.gap_open(k, vs, ve) {
        return Check::DoesNotFit;
    }
    let mv = p.transition_move(k, vs, ve);
    // Closed form: the move fits iff its shortest forward distance does.
    if !LinearGap::plain(mv.distance).fits(vs, ve, lim) {
        return Check::DoesNotFit;
    }
    let e = if with_elst { p.elst[k + 1] } else { 0.0 };
    if period.is_none() {
        // Every move lasts at least its speed change and d / V: when that already covers the
        // ELST, nothing need be solved; else only whether some duration lasts it matters.
        let lower = lim
            .speed_change_duration(vs, ve)
            .max(mv.distance / lim.max_vel);
        if e <= lower {
            return Check::Ok;
        }
    }
    let Ok(analysis) = MoveAnalysis::new(&mv, lim, Reversal::Forbid) else {
        return Check::DoesNotFit;
    };
    let Some(ts) = period else {
        return if analysis.can_last_at_least(e) {
            Check::Ok
        } else {
            Check::TooShortForElst
        };
    };
    // One duration analysis answers both: a duration >= the ELST (the set starts at the minimum
    // time), and one on the grid.
    let set = analysis.durations();
    if set.at_least(e).is_none() {
        return Check::TooShortForElst;
    }
    match grid_duration_in(&set, e, ts) {
        Some(_) => Check::Ok,
        None => Check::OffServoGrid,
    }
}
