//! The scan's passes: every speed as high as its neighbours allow, lowered until each
//! transition is feasible.

use arcsim_planner::{Limits, LinearGap, MoveAnalysis, Reversal};

use super::{highest_end, highest_start};
use crate::problem::ArcProblem;
use crate::servo::grid_duration_in;
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
    let mut v = caps.to_vec();
    let mut bound = bounds.to_vec();
    if n < 2 {
        return Some((v, bound));
    }
    // Speeds only ever come down; each check is skipped while the pair it last passed with is
    // unchanged (most transitions settle in the first round).
    let mut braked_ok: Vec<Option<(f64, f64)>> = vec![None; n - 1];
    let mut sped_ok: Vec<Option<(f64, f64)>> = vec![None; n - 1];
    let mut move_ok: Vec<Option<(f64, f64)>> = vec![None; n - 1];
    for round in 0..MAX_ROUNDS {
        let mut changed = false;
        changed |= braking_pass(p, lim, &mut v, &mut bound, &mut braked_ok);
        changed |= speed_up_pass(p, lim, &mut v, &mut bound, &mut sped_ok);
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
                // Largest common factor that makes the transition feasible (rest always is), to
                // 2^-12 of the range searched. Below the factor at which stopping fits in the
                // gap, a stop and dwell lasts any ELST (and any whole number of servo periods
                // beyond it), so the search starts there, with or without a period: the same
                // search keeps a period from choosing speeds whose transitions are shorter.
                let lo = feasible_scale(p, k, v[k], v[k + 1], lim, with_elst, period);
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
    Some((v, bound))
}

/// Largest factor `s` in [0, 1] such that the gantry can brake from `s·vs` to rest and start
/// again to `s·ve` within the gap of transition `k` (then a dwell at rest makes the transition
/// last as long as any ELST); 0 (rest) if the speeds are out of range.
pub(super) fn stop_fits_scale(p: &ArcProblem, k: usize, vs: f64, ve: f64, lim: &Limits) -> f64 {
    p.gap(k).max_stop_scale(vs, ve, lim).unwrap_or(0.0)
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Check {
    Ok,
    DoesNotFit,
    TooShortForElst,
    /// Feasible in continuous time, but no duration of a whole number of servo periods is.
    OffServoGrid,
}

/// The braking pass, from the last transition back: each speed above the next lowered to the
/// highest start that still reaches it. Returns whether a speed changed.
fn braking_pass(
    p: &ArcProblem,
    lim: &Limits,
    v: &mut [f64],
    bound: &mut [SpeedBound],
    braked_ok: &mut [Option<(f64, f64)>],
) -> bool {
    let mut changed = false;
    for k in (0..v.len() - 1).rev() {
        // Braking branch (v_k >= v_k+1): the highest start speed that still reaches v_k+1.
        if v[k] > v[k + 1] && braked_ok[k] != Some((v[k], v[k + 1])) {
            let b = highest_start(p, k, v[k + 1], lim);
            if v[k] > b {
                v[k] = b;
                bound[k] = SpeedBound::Gap;
                changed = true;
            }
            braked_ok[k] = Some((v[k], v[k + 1]));
        }
    }
    changed
}

/// The speed-up pass, from the first transition on: each speed above the one before lowered to
/// the highest end reachable from it. Returns whether a speed changed.
fn speed_up_pass(
    p: &ArcProblem,
    lim: &Limits,
    v: &mut [f64],
    bound: &mut [SpeedBound],
    sped_ok: &mut [Option<(f64, f64)>],
) -> bool {
    let mut changed = false;
    for k in 1..v.len() {
        // Speed-up branch (v_k > v_k-1): the highest end speed reachable from v_k-1.
        if v[k] > v[k - 1] && sped_ok[k - 1] != Some((v[k - 1], v[k])) {
            let b = highest_end(p, k - 1, v[k - 1], lim);
            if v[k] > b {
                v[k] = b;
                bound[k] = SpeedBound::Gap;
                changed = true;
            }
            sped_ok[k - 1] = Some((v[k - 1], v[k]));
        }
    }
    changed
}

/// The largest common factor of `vs`, `ve` that makes transition `k` feasible (rest always is),
/// bisected to 2^-12 of the range searched.
fn feasible_scale(
    p: &ArcProblem,
    k: usize,
    vs: f64,
    ve: f64,
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

/// Whether transition `k` at `vs`, `ve` is feasible: a forward move fits its gap and (with
/// `with_elst`) some such move lasts at least the ELST, and (with a servo `period`) lasts a
/// whole number of periods. Closed-form tests first; root solves only where they cannot decide.
pub(super) fn transition_check(
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
