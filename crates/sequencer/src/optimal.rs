//! The `optimal` schedule: the least total delivery time found over the layer speeds of an arc,
//! by dynamic programming over a speed grid per layer, refined around the best path.
//!
//! The arc's time is Σ irradiation + Σ transition(v_k, v_k+1), a chain, so dynamic programming
//! over a grid is exact for that grid; refining around the best path makes it a local search,
//! not a certified optimum (the transition cost jumps where an ELST stops fitting without a stop,
//! so the chain has many local optima). Every layer's speed is provably at most its
//! [`speed_bound`]. Two searches run and the shorter is kept: one with grids over [0, s_k]
//! ([`jerk_spans`]: the window cap and what jerk alone lets the gantry reach from rest and
//! brake from), one with finer grids over [0, upper_k], the scan without ELST, where
//! the optimum most often is (not a bound: a slower neighbour widens a gap, so a layer can be
//! faster). First grids contain the seed scan's speeds and rest, so the result is never worse
//! than the seed or step-and-shoot; each refinement shrinks the spacing six-fold around the best
//! path, and runs once more at the same spacing when the path improved and ended on a grid's
//! edge (the optimum may lie beyond). A fourth, finer refinement follows while the third still
//! gained 1e-6 of the moving time: three can stop some 1e-5 °/s short of the local optimum, and
//! free motion, which starts from these speeds, can land a second apart on such a difference
//! (a 4-layer arc of `free_optimality.rs`: 11.16 s against 12.22 s).
//!
//! # Why raising a limit does not lengthen it
//!
//! Raising J, A, D or V admits every move the lower limits admitted, so each transition's cost
//! (its shortest feasible duration of at least the ELST) can only fall, and dynamic programming
//! over the *same* grids can only find a shorter path. What could break that is the search's
//! inputs, not its costs: grids spanning each layer's bound min(V, w_k/t_k, reach) would spread
//! the same points over a wider range at a higher V, and seeds from scans that start at
//! min(V, w_k/t_k) would move with V, ending in another basin. So, in continuous time:
//!
//! - the first grids are the lattice `i · s_k / (m − 1)` of a span `s_k` that holds no limit but
//!   J ([`jerk_spans`]: the window cap w_k / t_k, and the speed a jerk triangle reaches from
//!   rest over the travel before the layer and brakes from over the travel after it), cut at
//!   the layer's provable bound: A, D and V enter only as that cut, so a higher limit keeps
//!   every point a lower one had (and may add the cut point);
//! - the seed ([`speed_free_scan`], also the `scan` schedule's start) and the finer search's span
//!   are scans of the arc without V ([`without_speed_limit`]: V raised to the highest window
//!   cap); the seed is then scanned again at the true V, which changes nothing where V cuts none
//!   of its speeds.
//!
//! So for every V that cuts no speed of the V-free seed and no move of the search, the whole
//! computation is the same, whatever V is; for A and D the first grids are the same points.
//! Where V does cut, and along J, A and D (which enter the scans' passes and ELST lowering and
//! the costs the refinements follow), the seed and the refinements are still local heuristics
//! that depend on the limits: there monotonicity is what the one-axis sweeps of
//! `tests/optimal_monotone.rs` check (J, A, D, V, ten values each, ATOM machine, ATOM cases and
//! bundled plans: no step above 1e-6 relative), not a theorem. Probes at other bases still find
//! small steps: at J 0.287, A 0.698 along A up to +0.010 s (10 of 280 settings), where a lower A
//! sends the scan's ELST lowering into another basin; at the ATOM machine with other sweep
//! values, along D on lung, +0.0004 s (3 of 280).
//!
//! Most speed pairs of a grid cannot improve their target: the closed-form test
//! [`may_last_within`] (eq. 3–4, no root solve) skips every pair whose minimum time already
//! exceeds what would improve it, so only a few pairs per target get the exact planner solve.
//!
//! The two searches are independent and run side by side (`rayon::join`; the polished scan
//! candidate of the caller too): one plan's `optimal` uses both cores, while a sweep, whose rows
//! already keep every core busy, runs them in turn at no cost.
//!
//! On a servo period the same search runs on the grid-timed problem: each pair costs the whole
//! number of periods its move can last ([`ArcProblem::cost_on`]); the test above still applies,
//! as a period only lengthens a transition. There the grids keep their earlier spans (each
//! layer's bound, and the caller's `upper`): the grid-timed search is repeated from several
//! starts and is not swept for monotonicity. Those repeated passes also show where the
//! continuous search stops short: on plans/lung.json a 1 µs period gives 158.215 s against
//! 158.232 s continuous, with no transition shorter than its continuous duration (its speeds
//! replayed in continuous time give 158.215 s too), so the grid-timing rule holds and the
//! continuous result is the one that is not optimal. Repeating the continuous search from its
//! own result would close that but costs one search per pass and moves lung along A by 2e-6
//! relative, so it is not done.

use arcsim_planner::{two_change, Limits, LinearGap};

use crate::problem::{moving_time_on, ArcProblem};
use crate::scan::scan;
use crate::servo::ticks;
use crate::SpeedBound;

/// Points per layer in each refinement's grid.
const GRID: usize = 13;
/// Speed pairs per DP in the first grid: short arcs get finer first grids for the same work
/// (at least [`GRID`] points per layer, at most [`MAX_FIRST_GRID`]).
const FIRST_GRID_PAIRS: usize = 180 * GRID * GRID;
/// Most points per layer in the first grid.
const MAX_FIRST_GRID: usize = 257;
/// Refinements around the best path.
const REFINEMENTS: usize = 3;
/// Finer refinements after those, each only while the one before still gained more than
/// [`EXTRA_REFINEMENT_GAIN`] of the moving time.
const EXTRA_REFINEMENTS: usize = 1;
/// Relative gain of a refinement below which no finer one follows.
const EXTRA_REFINEMENT_GAIN: f64 = 1e-6;

/// Best path through per-layer speed grids; `None` if no path is feasible.
fn best_path(
    p: &ArcProblem,
    lim: &Limits,
    grids: &[Vec<f64>],
    period: Option<f64>,
) -> Option<(f64, Vec<f64>)> {
    let n = grids.len();
    let mut best: Vec<f64> = vec![0.0; grids[0].len()];
    let mut back: Vec<Vec<usize>> = Vec::with_capacity(n);
    back.push(vec![0; grids[0].len()]);
    for k in 0..n - 1 {
        let (from, to) = (&grids[k], &grids[k + 1]);
        let gap = p.gap(k);
        let mut next = vec![f64::INFINITY; to.len()];
        let mut arg = vec![usize::MAX; to.len()];
        let elst = match period {
            Some(ts) => ticks(p.elst[k + 1], ts),
            None => p.elst[k + 1],
        };
        // Predecessors in order of their best time: once one plus the ELST cannot improve a
        // target, none after it can.
        let mut order: Vec<usize> = (0..from.len()).filter(|&j| best[j].is_finite()).collect();
        order.sort_by(|&a, &b| best[a].total_cmp(&best[b]));
        for (i, &ve) in to.iter().enumerate() {
            for &j in &order {
                let vs = from[j];
                if best[j] + elst >= next[i] {
                    break;
                }
                // Skip pairs with no forward move or none short enough to improve the target.
                if !may_last_within(gap.at(vs, ve), vs, ve, next[i] - best[j], lim) {
                    continue;
                }
                if let Some(c) = p.cost_on(k, vs, ve, lim, period) {
                    let total = best[j] + c;
                    if total < next[i] {
                        next[i] = total;
                        arg[i] = j;
                    }
                }
            }
        }
        best = next;
        back.push(arg);
    }
    let (mut i, &total) = best.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1))?;
    if !total.is_finite() {
        return None;
    }
    let mut path = vec![0.0; n];
    for k in (0..n).rev() {
        path[k] = grids[k][i];
        if k > 0 {
            i = back[k][i];
        }
    }
    Some((total, path))
}

/// Whether a forward move over `d` from `vs` to `ve` exists and may last at most `budget`
/// seconds; false only when there is none or its minimum time exceeds the budget. Closed forms
/// of eq. 3–4, no root solve:
/// - a forward move exists iff `d` holds the direct change `vs → ve` or stopping and starting
///   again (as [`LinearGap::fits`]);
/// - every forward move lasts at least the direct change and `d / V`;
/// - when the direct change fits in `d` (`d >= D(m)`, `m = max(vs, ve)`), the minimum-time move
///   rises to the highest top speed `c` the distance allows and comes back (step 1): with
///   `S(c)`, `D(c)` the duration and distance of `vs → c → ve`, both rising in `c`, it lasts
///   `S(c_d)` where `D(c_d) = d`, or cruises at V (`S(V) + (d - D(V)) / V`). The search for
///   `c_d` (regula falsi, bisecting every third step) stops as soon as its bracket decides the
///   comparison with the budget.
fn may_last_within(d: f64, vs: f64, ve: f64, budget: f64, lim: &Limits) -> bool {
    let budget = budget * (1.0 + 1e-9);
    let d = d.max(0.0);
    let sd = |c: f64| two_change(vs, c, ve, lim);
    let v = lim.max_vel;
    let m = vs.max(ve);
    let (s_m, d_m) = sd(m);
    if s_m > budget || d > v * budget {
        return false;
    }
    if d < d_m {
        // Only a valley move can fit: it must hold the stop-and-go distance at least.
        return d >= sd(0.0).1;
    }
    if m >= v {
        // A cruise at V: no cheap bound beyond the above.
        return true;
    }
    let (s_v, d_v) = sd(v);
    if d_v <= d {
        return s_v + (d - d_v) / v <= budget;
    }
    // D(c_d) = d with c_d in (lo, hi); T_min = S(c_d) is in [S(lo), S(hi)]. Regula falsi
    // (Illinois) on D keeps the bracket and decides most pairs in a few steps; undecided after
    // the steps (T_min within rounding of the budget), the pair is kept.
    if s_v <= budget {
        return true;
    }
    let (mut lo, mut hi) = (m, v);
    let (mut f_lo, mut f_hi) = (d_m - d, d_v - d);
    let mut side = 0i8;
    for step in 0..60 {
        // Every third step bisects, so the bracket shrinks even when one end stalls.
        let falsi = lo - f_lo * (hi - lo) / (f_hi - f_lo);
        let mid = if step % 3 != 2 && falsi > lo && falsi < hi {
            falsi
        } else {
            0.5 * (lo + hi)
        };
        if !(mid > lo && mid < hi) {
            break;
        }
        let (s, dd) = sd(mid);
        if dd <= d {
            if s > budget {
                return false;
            }
            (lo, f_lo) = (mid, dd - d);
            if side == -1 {
                f_hi *= 0.5;
            }
            side = -1;
        } else {
            if s <= budget {
                return true;
            }
            (hi, f_hi) = (mid, dd - d);
            if side == 1 {
                f_lo *= 0.5;
            }
            side = 1;
        }
    }
    true
}

fn grid_around(centre: f64, half_width: f64, upper: f64, extra: &[f64], points: usize) -> Vec<f64> {
    let mut g: Vec<f64> = (0..points)
        .map(|i| centre - half_width + 2.0 * half_width * i as f64 / (points - 1) as f64)
        .map(|v| v.clamp(0.0, upper))
        .chain(extra.iter().copied())
        .collect();
    g.sort_by(f64::total_cmp);
    g.dedup();
    g
}

/// Highest speed layer `k` can have in any feasible schedule: its cap, the speed reachable from
/// rest at the arc's first layer over the whole travel to it, and the speed from which the gantry
/// can still brake to rest by the last layer. A speed change split over several transitions, with
/// zero acceleration between them and constant-speed sweeps in between, covers at least the
/// distance of the direct change (eq. 4), so these hold whatever the other layers' speeds are.
pub(crate) fn speed_bound(p: &ArcProblem, lim: &Limits, k: usize) -> f64 {
    let n = p.len();
    let cap = p.speed_cap[k];
    if cap <= 0.0 {
        return 0.0;
    }
    let reach = |d: f64, forward: bool| {
        let gap = LinearGap::plain(d.max(0.0));
        let r = if forward {
            gap.max_end_speed(0.0, lim)
        } else {
            gap.max_start_speed(0.0, lim)
        };
        r.ok().flatten().unwrap_or(cap)
    };
    cap.min(reach(p.travel_deg[k] - p.travel_deg[0], true))
        .min(reach(p.travel_deg[n - 1] - p.travel_deg[k], false))
}

/// Minimum-time speeds of an arc. `upper`: on a servo period, the scan without ELST (where the
/// optimum most often sits; in continuous time the search scans the arc without V instead, see
/// the module doc); `seed`: a feasible schedule (the scan) that the result never does worse than;
/// `period`: time every transition in whole servo periods. Returns the speeds and their moving
/// time (Σ transition durations, s).
///
/// Two searches, the shorter kept: grids spanning [`jerk_spans`] (on a period: each layer's
/// provable speed bound), and finer grids spanning [0, upper] (the scan's ELST-free speeds are
/// not a bound: a slower neighbour widens a gap, so a layer can be faster than they allow).
/// Every grid is cut at the layer's provable bound.
pub(crate) fn optimal(
    p: &ArcProblem,
    lim: &Limits,
    upper: &[f64],
    seed: &[f64],
    period: Option<f64>,
) -> (Vec<f64>, f64) {
    let n = p.len();
    if n <= 2 {
        return (seed.to_vec(), moving_time_on(p, lim, seed, period));
    }
    let hi: Vec<f64> = (0..n).map(|k| speed_bound(p, lim, k)).collect();
    // Spans: in continuous time without A, D and V (jerk_spans) and without V (the ELST-free
    // scan of the arc without V), so that a higher limit searches the same lattice.
    let (span, upper): (Vec<f64>, Vec<f64>) = match period {
        Some(_) => (hi.clone(), upper.to_vec()),
        None => {
            let (free_p, free_lim) = without_speed_limit(p, lim);
            let (free_upper, _) = scan(
                &free_p,
                &free_lim,
                &free_p.speed_cap,
                &free_p.cap_bound,
                false,
                None,
            );
            (jerk_spans(&free_p, lim.max_jerk), free_upper)
        }
    };
    let narrow: Vec<f64> = upper.iter().zip(&span).map(|(u, s)| u.min(*s)).collect();
    let upper = &upper[..];
    // The two searches are independent: on a second core they run side by side.
    let (wide, close) = rayon::join(
        || {
            search(
                p,
                lim,
                &span,
                &hi,
                [upper, seed],
                first_grid_points(n),
                period,
            )
        },
        || search(p, lim, &narrow, &hi, [upper, seed], GRID, period),
    );
    [wide, close]
        .into_iter()
        .flatten()
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map_or_else(
            || (seed.to_vec(), moving_time_on(p, lim, seed, period)),
            |(total, path)| (path, total),
        )
}

/// Each layer's window cap, lowered to the highest speed any jerk-limited motion (whatever A, D
/// and V) can reach from rest at the arc's first layer and still brake from to rest by its last:
/// with no acceleration limit the fastest change from rest to `u` is a jerk triangle covering
/// `u^(3/2) / J^(1/2)`, so over `d` no speed above `(J·d²)^(1/3)` is reachable. A and D only
/// lower that, so these spans hold no limit but J: grids spanned on them are the same lattice
/// at every A, D and V (each cut at the layer's true bound).
fn jerk_spans(free_p: &ArcProblem, jerk: f64) -> Vec<f64> {
    let n = free_p.len();
    let s = &free_p.travel_deg;
    let reach = |d: f64| (jerk * d.max(0.0) * d.max(0.0)).cbrt();
    (0..n)
        .map(|k| {
            free_p.speed_cap[k]
                .min(reach(s[k] - s[0]))
                .min(reach(s[n - 1] - s[k]))
        })
        .collect()
}

/// The arc and limits with V raised to the highest window cap (w_k / t_k) of the arc's inner
/// layers, or kept where V is higher. No layer is faster than its window cap, so below that
/// speed V only cuts speeds and moves off: a scan of this arc is the same at every lower V.
fn without_speed_limit(p: &ArcProblem, lim: &Limits) -> (ArcProblem, Limits) {
    let n = p.len();
    let window_cap = |k: usize| {
        let t = p.irradiation_s[k];
        if t > 0.0 {
            p.window[k] / t
        } else {
            f64::INFINITY
        }
    };
    let top = (1..n.saturating_sub(1))
        .map(window_cap)
        .filter(|c| c.is_finite())
        .fold(lim.max_vel, f64::max);
    let free_lim = Limits {
        max_vel: top,
        ..*lim
    };
    let mut free_p = p.clone();
    for k in 1..n.saturating_sub(1) {
        let c = window_cap(k);
        if c < top {
            free_p.speed_cap[k] = c;
            free_p.cap_bound[k] = SpeedBound::Window;
        } else {
            free_p.speed_cap[k] = top;
            free_p.cap_bound[k] = SpeedBound::MaxSpeed;
        }
    }
    (free_p, free_lim)
}

/// Whether `path` takes, at some layer, its grid's lowest or highest speed where the grid could
/// reach further (above rest, below the layer's bound `hi`).
fn on_an_edge(grids: &[Vec<f64>], path: &[f64], hi: &[f64]) -> bool {
    grids.iter().zip(path).zip(hi).any(|((g, &v), &h)| {
        let (lo, top) = (g[0], g[g.len() - 1]);
        g.len() > 2 && (v == lo && lo > 0.0 || v == top && top < h)
    })
}

/// Points per layer of the wide search's first grid on an arc of `n` layers.
fn first_grid_points(n: usize) -> usize {
    (((FIRST_GRID_PAIRS / n) as f64).sqrt() as usize).clamp(GRID, MAX_FIRST_GRID)
}

/// One grid search: first grids uniform over [0, span_k] with rest and the speeds of `extra`
/// (`upper` and the seed), then refinements around the best path; every speed within
/// [0, hi_k]. Transitions are timed on `period` when given. Returns the moving time and the
/// speeds; `None` if no path is feasible.
fn search(
    p: &ArcProblem,
    lim: &Limits,
    span: &[f64],
    hi: &[f64],
    [upper, seed]: [&[f64]; 2],
    first: usize,
    period: Option<f64>,
) -> Option<(f64, Vec<f64>)> {
    let n = p.len();
    let grids: Vec<Vec<f64>> = (0..n)
        .map(|k| {
            let extra = [0.0, seed[k].min(hi[k]), upper[k].min(hi[k])];
            grid_around(0.5 * span[k], 0.5 * span[k], hi[k], &extra, first)
        })
        .collect();
    let (total, path) = best_path(p, lim, &grids, period)?;
    let half: Vec<f64> = span.iter().map(|w| w / (first - 1) as f64).collect();
    Some(refine(p, lim, hi, (total, path), half, period))
}

/// Refinements of `start` (its moving time and speeds): grids of [`GRID`] points, `half` wide
/// on each side of the best path (within [0, hi_k]), shrinking six-fold [`REFINEMENTS`] times.
fn refine(
    p: &ArcProblem,
    lim: &Limits,
    hi: &[f64],
    (mut total, mut path): (f64, Vec<f64>),
    mut half: Vec<f64>,
    period: Option<f64>,
) -> (f64, Vec<f64>) {
    let n = p.len();
    let mut grids: Vec<Vec<f64>> = vec![Vec::new(); n];
    let mut level_gain = f64::INFINITY;
    for level in 0..REFINEMENTS + EXTRA_REFINEMENTS {
        if level >= REFINEMENTS && level_gain <= EXTRA_REFINEMENT_GAIN * total {
            break;
        }
        let before = total;
        // Once more at the same spacing when the best path improved and ended on its grid's
        // edge somewhere: the optimum may lie beyond it.
        for _ in 0..2 {
            for k in 0..n {
                grids[k] = grid_around(path[k], half[k], hi[k], &[path[k]], GRID);
            }
            let Some(better) = best_path(p, lim, &grids, period) else {
                break;
            };
            let again = better.0 < total * (1.0 - 1e-12) && on_an_edge(&grids, &better.1, hi);
            (total, path) = better;
            if !again {
                break;
            }
        }
        level_gain = before - total;
        for h in half.iter_mut() {
            *h *= 2.0 / (GRID - 1) as f64;
        }
    }
    (total, path)
}

/// The scan with ELST ([`scan`]) from the caps the arc has without V ([`without_speed_limit`]),
/// lowered to V, then scanned again on the true limits: where V cuts no speed of the first scan
/// (and no move between them), the result is the same at every such V.
pub(crate) fn speed_free_scan(p: &ArcProblem, lim: &Limits) -> (Vec<f64>, Vec<SpeedBound>) {
    let (free_p, free_lim) = without_speed_limit(p, lim);
    let (v, b) = scan(
        &free_p,
        &free_lim,
        &free_p.speed_cap,
        &free_p.cap_bound,
        true,
        None,
    );
    let mut caps = p.speed_cap.clone();
    let mut bounds = p.cap_bound.clone();
    for k in 0..caps.len() {
        if v[k] < caps[k] {
            caps[k] = v[k];
            bounds[k] = b[k];
        }
    }
    scan(p, lim, &caps, &bounds, true, None)
}

#[cfg(test)]
mod tests {
    use super::*;
    use arcsim_planner::{Move, MoveAnalysis, Reversal};
    use arcsim_test_support::Rng;

    /// The closed-form test against the planner's exact minimum time on random moves: it never
    /// rejects a move that fits the budget, and it decides every move whose direct speed change
    /// fits the gap (the peak family) to within rounding.
    #[test]
    fn may_last_within_agrees_with_the_planner() {
        let mut rng = Rng::new(0x0005_eed0_f0b7);
        let (mut decided, mut rejected) = (0, 0);
        for _ in 0..20_000 {
            let lim = Limits::with_decel(
                rng.range(0.05, 5.0),
                rng.range(0.05, 3.0),
                rng.range(0.05, 3.0),
                rng.range(0.5, 8.0),
            )
            .expect("limits");
            let vs = if rng.below(8) == 0 {
                0.0
            } else {
                rng.range(0.0, lim.max_vel)
            };
            let ve = if rng.below(8) == 0 {
                vs
            } else {
                rng.range(0.0, lim.max_vel)
            };
            let d = rng.range(0.0, 1.0) * rng.range(0.0, 20.0);
            let mv = Move {
                distance: d,
                v_start: vs,
                v_end: ve,
            };
            let direct = lim.speed_change_distance(vs, ve);
            match MoveAnalysis::new(&mv, &lim, Reversal::Forbid) {
                Err(_) => {
                    assert!(
                        !may_last_within(d, vs, ve, f64::INFINITY, &lim),
                        "no forward move, yet accepted: {mv:?} {lim:?}"
                    );
                    rejected += 1;
                }
                Ok(a) => {
                    let t = a.min_time();
                    assert!(
                        may_last_within(d, vs, ve, t * (1.0 + 1e-12), &lim),
                        "rejected at its own minimum time {t}: {mv:?} {lim:?}"
                    );
                    if d >= direct {
                        assert!(
                            !may_last_within(d, vs, ve, t * (1.0 - 1e-6), &lim),
                            "peak-family move accepted below its minimum time {t}: {mv:?} {lim:?}"
                        );
                        decided += 1;
                    }
                }
            }
        }
        assert!(
            decided > 5_000 && rejected > 500,
            "{decided} decided, {rejected} rejected"
        );
    }
}
