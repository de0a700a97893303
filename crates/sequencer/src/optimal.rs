//! The `optimal` schedule: minimum total delivery time over the layer speeds of an arc, by dynamic
//! programming over a speed grid per layer, refined around the best path.
//!
//! The arc's time is Σ irradiation + Σ transition(v_k, v_k+1), a chain, so dynamic programming
//! over a grid is exact for that grid. The first grid spans [0, upper_k] (upper_k: the scan
//! without ELST, an upper bound of every feasible speed) uniformly and contains the scan's speeds
//! and rest, so the optimum is never worse than `scan` or `step-and-shoot`. Each refinement
//! halves the grid spacing around the best path; the reported tolerance is the spacing left.

use arcsim_planner::Limits;

use crate::scan::ArcProblem;

/// Points per layer in each grid.
const GRID: usize = 13;
/// Refinements around the best path.
const REFINEMENTS: usize = 3;
/// Layers within this many of one whose ELST-free bound differs from the scan get a full grid;
/// elsewhere the grid is the two scan solutions (with and without ELST), where the optimum sits
/// when no energy switch constrains the neighbourhood.
const REACH: usize = 6;

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
        for (i, &ve) in to.iter().enumerate() {
            for (j, &vs) in from.iter().enumerate() {
                // Every transition lasts at least its ELST: skip pairs that cannot improve.
                if !best[j].is_finite() || best[j] + elst >= next[i] {
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

fn grid_around(centre: f64, half_width: f64, upper: f64, extra: &[f64]) -> Vec<f64> {
    let mut g: Vec<f64> = (0..GRID)
        .map(|i| centre - half_width + 2.0 * half_width * i as f64 / (GRID - 1) as f64)
        .map(|v| v.clamp(0.0, upper))
        .chain(extra.iter().copied())
        .collect();
    g.sort_by(f64::total_cmp);
    g.dedup();
    g
}

/// Minimum-time speeds of an arc. `upper`: per-layer upper bounds (scan without ELST);
/// `seed`: a feasible schedule (the scan) that the result never does worse than.
/// Returns the speeds and the speed tolerance of the last grid (deg/s).
pub(crate) fn optimal(
    p: &ArcProblem,
    lim: &Limits,
    upper: &[f64],
    seed: &[f64],
) -> (Vec<f64>, f64) {
    let n = p.len();
    if n <= 2 {
        return (seed.to_vec(), 0.0);
    }
    let affected: Vec<bool> = (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(REACH), (k + REACH).min(n - 1));
            (a..=b).any(|i| {
                seed[i] < upper[i] * (1.0 - 1e-9)
                    || p.elst[i] > 0.0
                        && i > 0
                        && p.cost(i - 1, upper[i - 1], upper[i], lim).is_none()
            })
        })
        .collect();
    let full = |k: usize| affected[k] && upper[k] > 0.0;
    let mut grids: Vec<Vec<f64>> = (0..n)
        .map(|k| {
            if upper[k] <= 0.0 {
                vec![0.0]
            } else if full(k) {
                grid_around(0.5 * upper[k], 0.5 * upper[k], upper[k], &[0.0, seed[k]])
            } else {
                let mut g = vec![seed[k], upper[k]];
                g.dedup();
                g
            }
        })
        .collect();
    let Some((_, mut path)) = best_path(p, lim, &grids) else {
        return (seed.to_vec(), f64::INFINITY);
    };
    let mut half: Vec<f64> = upper.iter().map(|u| u / (GRID - 1) as f64).collect();
    for _ in 0..REFINEMENTS {
        for k in 0..n {
            grids[k] = if upper[k] <= 0.0 {
                vec![0.0]
            } else {
                grid_around(path[k], half[k], upper[k], &[path[k]])
            };
        }
        if let Some((_, better)) = best_path(p, lim, &grids) {
            path = better;
        }
        for h in half.iter_mut() {
            *h *= 2.0 / (GRID - 1) as f64;
        }
    }
    let tol = half.iter().copied().fold(0.0, f64::max);
    (path, tol)
}
