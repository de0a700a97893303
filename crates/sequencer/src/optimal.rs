//! The `optimal` schedule: the least total delivery time found over the layer speeds of an arc,
//! by dynamic programming over a speed grid per layer, refined around the best path.
//!
//! The arc's time is Σ irradiation + Σ transition(v_k, v_k+1), a chain, so dynamic programming
//! over a grid is exact for that grid; refining around the best path makes it a local search,
//! not a certified optimum (the transition cost jumps where an ELST stops fitting without a stop,
//! so the chain has many local optima). Every layer's speed is provably at most its
//! [`speed_bound`]. Two searches run and the shorter is kept: one with grids over [0, bound],
//! one with finer grids over [0, upper_k], the scan without ELST, where the optimum most often is
//! (not a bound: a slower neighbour widens a gap, so a layer can be faster). First grids contain
//! the scan's speeds and rest, so the result is never worse than the seed scan or step-and-shoot;
//! each refinement shrinks the spacing six-fold around the best path.

use arcsim_planner::{Limits, LinearGap};

use crate::scan::{moving_time, ArcProblem};

/// Points per layer in each refinement's grid.
const GRID: usize = 13;
/// Speed pairs per DP in the first grid: short arcs get finer first grids for the same work
/// (at least [`GRID`] points per layer, at most [`MAX_FIRST_GRID`]).
const FIRST_GRID_PAIRS: usize = 180 * GRID * GRID;
/// Most points per layer in the first grid.
const MAX_FIRST_GRID: usize = 257;
/// Refinements around the best path.
const REFINEMENTS: usize = 3;

/// Best path through per-layer speed grids; `None` if no path is feasible.
fn best_path(p: &ArcProblem, lim: &Limits, grids: &[Vec<f64>]) -> Option<(f64, Vec<f64>)> {
    let n = grids.len();
    let mut best: Vec<f64> = vec![0.0; grids[0].len()];
    let mut back: Vec<Vec<usize>> = Vec::with_capacity(n);
    back.push(vec![0; grids[0].len()]);
    for k in 0..n - 1 {
        let (from, to) = (&grids[k], &grids[k + 1]);
        let gap = p.gap(k);
        // Monotone-branch bounds (exact): a pair fits iff it is within them.
        let max_end: Vec<f64> = from
            .iter()
            .map(|&vs| {
                gap.max_end_speed(vs, lim)
                    .ok()
                    .flatten()
                    .unwrap_or(f64::NEG_INFINITY)
            })
            .collect();
        let max_start: Vec<f64> = to
            .iter()
            .map(|&ve| {
                gap.max_start_speed(ve, lim)
                    .ok()
                    .flatten()
                    .unwrap_or(f64::NEG_INFINITY)
            })
            .collect();
        let mut next = vec![f64::INFINITY; to.len()];
        let mut arg = vec![usize::MAX; to.len()];
        let elst = p.elst[k + 1];
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
                // Every transition also lasts at least its speed change (eq. 3) and its gap at
                // top speed: skip pairs that cannot improve.
                let quick = lim
                    .speed_change_duration(vs, ve)
                    .max(gap.at(vs, ve) / lim.max_vel);
                if best[j] + quick >= next[i] {
                    continue;
                }
                let fits = if ve >= vs {
                    ve <= max_end[j]
                } else {
                    vs <= max_start[i]
                };
                if !fits {
                    continue;
                }
                if let Some(c) = p.cost(k, vs, ve, lim) {
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

/// Minimum-time speeds of an arc. `upper`: the scan without ELST (where the optimum most often
/// sits); `seed`: a feasible schedule (the scan) that the result never does worse than. Returns
/// the speeds and their moving time (Σ transition durations, s).
///
/// Two searches, the shorter kept: grids spanning each layer's provable speed bound, and finer
/// grids spanning [0, upper] (the scan's ELST-free speeds are not a bound: a slower neighbour
/// widens a gap, so a layer can be faster than they allow).
pub(crate) fn optimal(
    p: &ArcProblem,
    lim: &Limits,
    upper: &[f64],
    seed: &[f64],
) -> (Vec<f64>, f64) {
    let n = p.len();
    if n <= 2 {
        return (seed.to_vec(), moving_time(p, lim, seed));
    }
    let hi: Vec<f64> = (0..n).map(|k| speed_bound(p, lim, k)).collect();
    let narrow: Vec<f64> = upper.iter().zip(&hi).map(|(u, h)| u.min(*h)).collect();
    [
        search(p, lim, &hi, &hi, upper, seed, first_grid_points(n)),
        search(p, lim, &narrow, &hi, upper, seed, GRID),
    ]
    .into_iter()
    .flatten()
    .min_by(|a, b| a.0.total_cmp(&b.0))
    .map_or_else(
        || (seed.to_vec(), moving_time(p, lim, seed)),
        |(total, path)| (path, total),
    )
}

/// Points per layer of the wide search's first grid on an arc of `n` layers.
fn first_grid_points(n: usize) -> usize {
    (((FIRST_GRID_PAIRS / n) as f64).sqrt() as usize).clamp(GRID, MAX_FIRST_GRID)
}

/// One grid search: first grids uniform over [0, span_k] with rest, the seed and `upper`,
/// then refinements around the best path; every speed within [0, hi_k]. Returns the moving
/// time and the speeds; `None` if no path is feasible.
fn search(
    p: &ArcProblem,
    lim: &Limits,
    span: &[f64],
    hi: &[f64],
    upper: &[f64],
    seed: &[f64],
    first: usize,
) -> Option<(f64, Vec<f64>)> {
    let n = p.len();
    let mut grids: Vec<Vec<f64>> = (0..n)
        .map(|k| {
            let extra = [0.0, seed[k].min(hi[k]), upper[k].min(hi[k])];
            grid_around(0.5 * span[k], 0.5 * span[k], hi[k], &extra, first)
        })
        .collect();
    let (mut total, mut path) = best_path(p, lim, &grids)?;
    let mut half: Vec<f64> = span.iter().map(|w| w / (first - 1) as f64).collect();
    for _ in 0..REFINEMENTS {
        for k in 0..n {
            grids[k] = grid_around(path[k], half[k], hi[k], &[path[k]], GRID);
        }
        if let Some(better) = best_path(p, lim, &grids) {
            (total, path) = better;
        }
        for h in half.iter_mut() {
            *h *= 2.0 / (GRID - 1) as f64;
        }
    }
    Some((total, path))
}
