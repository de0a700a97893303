//! The least-jerk move: between two states in a given time, through given windows at given
//! times, the motion whose acceleration varies least (minimum ∫|jerk| dt).
//!
//! Smoothing's last resort where the solver's states at the beam edges wiggle: a single Ruckig
//! move cannot pass through several windows, and moves between the solver's own states keep
//! their wiggle. With the edge times fixed, every constraint is linear in the knots' states and
//! the pieces' jerks, so this is one small linear programme ([`Lp`]). Its pieces are taken from a
//! grid and from the current motion's own jerk switches (so that the current motion is one of its
//! solutions, up to the margins below); the interior point's answer, accurate to about 1e-9, is
//! then closed exactly onto the target by the least change of its jerks, and integrated and
//! checked like any other move.

use arcsim_planner::{Limits, Segment};

use super::lp::Lp;
use super::mover::{FullMove, FullState, Mover};

/// The longest piece (s): the grid on which the jerk may change, besides the current motion's
/// own switches.
const PIECE_S: f64 = 0.05;

/// How far inside the limits and windows the programme keeps (relative): the interior point's
/// answer and its exact closure move the motion by about 1e-9.
const MARGIN: f64 = 1e-8;

/// The most knots of one programme: a stretch longer than that (a switch of hours) is left as
/// it is, the work per stretch bounded.
const MAX_KNOTS: usize = 2000;

/// Jerks below this fraction of the limit are the interior point's trace of none.
const TRACE: f64 = 1e-6;

/// A window the move must be inside at a time: `(t_s, lo_deg, hi_deg)`, `t_s` from its start.
pub(crate) type Mark = (f64, f64, f64);

/// The least-jerk move `from → to` lasting the current motion's duration (`current`, which
/// starts in `from`), inside every window of `marks` and every limit, never going backwards;
/// `None` where the programme does not solve or its answer cannot be closed within the limits.
pub(crate) fn least_jerk_move(
    mover: &Mover,
    lim: &Limits,
    from: FullState,
    to: FullState,
    current: &[Segment],
    marks: &[Mark],
) -> Option<FullMove> {
    let duration: f64 = current.iter().map(|s| s.duration).sum();
    if duration.is_nan() || duration <= 0.0 || to.pos < from.pos {
        return None;
    }
    let knots = knot_times(current, marks, duration);
    if knots.len() > MAX_KNOTS {
        return None;
    }
    // Each knot's position bounds: between the ends (the motion never goes backwards), and
    // inside the window of a mark at that knot.
    let scale = 1.0 + from.pos.abs().max(to.pos.abs());
    let mut x_bounds: Vec<(f64, f64)> = vec![(from.pos, to.pos); knots.len()];
    for &(tm, lo, hi) in marks {
        let q = knots.partition_point(|&k| k < tm - 1e-9);
        if q + 1 >= knots.len() || (knots[q] - tm).abs() > 1e-9 {
            // A mark at the end is the target's own position, checked by the caller.
            continue;
        }
        let b = &mut x_bounds[q];
        b.0 = b.0.max(lo + MARGIN * scale);
        b.1 = b.1.min(hi - MARGIN * scale);
        if b.0 > b.1 {
            return None;
        }
    }
    let shrink = 1.0 - MARGIN;
    let j_max = lim.max_jerk * shrink;
    let mut lp = Lp::default();
    let fixed = |lp: &mut Lp, s: &FullState| -> [usize; 3] {
        [
            lp.var(s.pos, s.pos, 0.0),
            lp.var(s.vel, s.vel, 0.0),
            lp.var(s.acc, s.acc, 0.0),
        ]
    };
    let mut knot = fixed(&mut lp, &from);
    let mut jerks: Vec<(f64, usize, usize)> = Vec::with_capacity(knots.len());
    let mut t0 = 0.0;
    for (q, &t1) in knots.iter().enumerate() {
        let h = t1 - t0;
        t0 = t1;
        let next = if q + 1 == knots.len() {
            fixed(&mut lp, &to)
        } else {
            let (lo, hi) = x_bounds[q];
            [
                lp.var(lo, hi, 0.0),
                lp.var(0.0, lim.max_vel * shrink, 0.0),
                lp.var(-lim.max_decel * shrink, lim.max_accel * shrink, 0.0),
            ]
        };
        let up = lp.var(0.0, j_max, h);
        let down = lp.var(0.0, j_max, h);
        jerks.push((h, up, down));
        let [x0, v0, a0] = knot;
        let [x1, v1, a1] = next;
        let (h2, h3) = (0.5 * h * h, h * h * h / 6.0);
        lp.row(
            &[
                (x1, 1.0),
                (x0, -1.0),
                (v0, -h),
                (a0, -h2),
                (up, -h3),
                (down, h3),
            ],
            0.0,
        );
        lp.row(
            &[(v1, 1.0), (v0, -1.0), (a0, -h), (up, -h2), (down, h2)],
            0.0,
        );
        lp.row(&[(a1, 1.0), (a0, -1.0), (up, -h), (down, h)], 0.0);
        knot = next;
    }
    let z = lp.solve()?;
    let pieces: Vec<Segment> = jerks
        .iter()
        .map(|&(h, up, down)| {
            let j = (z[up] - z[down]).clamp(-j_max, j_max);
            Segment {
                duration: h,
                jerk: if j.abs() < TRACE * lim.max_jerk {
                    0.0
                } else {
                    j
                },
            }
        })
        .collect();
    closed(mover, from, to, &pieces, lim.max_jerk)
}

/// Knot times: the current motion's switches, the marks and a grid, 1 ns apart at least; the
/// last is `duration`.
fn knot_times(current: &[Segment], marks: &[Mark], duration: f64) -> Vec<f64> {
    let mut cuts: Vec<f64> = Vec::with_capacity(current.len() + marks.len() + 64);
    let mut t = 0.0;
    for seg in current {
        t += seg.duration;
        cuts.push(t);
    }
    cuts.extend(marks.iter().map(|m| m.0));
    let n_grid = (duration / PIECE_S).ceil().clamp(1.0, MAX_KNOTS as f64) as usize;
    cuts.extend((1..n_grid).map(|g| duration * g as f64 / n_grid as f64));
    cuts.sort_by(f64::total_cmp);
    let mut knots: Vec<f64> = Vec::with_capacity(cuts.len() + 1);
    for &c in &cuts {
        if c > knots.last().copied().unwrap_or(0.0) + 1e-9 && c < duration - 1e-9 {
            knots.push(c);
        }
    }
    knots.push(duration);
    knots
}

/// `pieces` flown from `from`, their jerks changed as little as needed to end exactly in `to`
/// (the end state is linear in the jerks: a weighted least-norm change, 3×3). Only pieces with
/// jerk change, each in proportion to its jerk and its room to the limit, so that no piece
/// changes sign; all pieces with room where those cannot close the miss. `None` where the
/// closed move breaks a limit.
fn closed(
    mover: &Mover,
    from: FullState,
    to: FullState,
    pieces: &[Segment],
    j_max: f64,
) -> Option<FullMove> {
    let end = pieces
        .iter()
        .fold(from, |s, seg| s.after(seg.duration, seg.jerk));
    let miss = [to.pos - end.pos, to.vel - end.vel, to.acc - end.acc];
    // Each piece's effect on the end state per unit of jerk, with the time left after it.
    let mut left: f64 = pieces.iter().map(|s| s.duration).sum();
    let mut cols: Vec<[f64; 3]> = Vec::with_capacity(pieces.len());
    for seg in pieces {
        let h = seg.duration;
        left -= h;
        let r = left.max(0.0);
        cols.push([
            h * h * h / 6.0 + 0.5 * h * h * r + 0.5 * h * r * r,
            0.5 * h * h + h * r,
            h,
        ]);
    }
    let room = |seg: &Segment| (j_max - seg.jerk.abs()).max(0.0);
    // First only the pieces with jerk (no sign changes); then all, those with jerk first.
    let weight_sets: [Vec<f64>; 2] = [
        pieces
            .iter()
            .map(|s| room(s) * s.jerk.abs() / j_max)
            .collect(),
        pieces
            .iter()
            .map(|s| room(s) * (s.jerk.abs() / j_max + 1e-3))
            .collect(),
    ];
    weight_sets.iter().find_map(|weights| {
        let g = gram(&cols, weights);
        let mut segments = pieces.to_vec();
        let mut miss = miss;
        // Twice more on what rounding left (a stop must end at rest to 1e-15, not 1e-12).
        for _ in 0..3 {
            let y = solve3(g, miss)?;
            for (seg, (c, w)) in segments.iter_mut().zip(cols.iter().zip(weights)) {
                seg.jerk += w * (c[0] * y[0] + c[1] * y[1] + c[2] * y[2]);
            }
            let e = segments
                .iter()
                .fold(from, |s, seg| s.after(seg.duration, seg.jerk));
            miss = [to.pos - e.pos, to.vel - e.vel, to.acc - e.acc];
        }
        if segments
            .iter()
            .any(|s| s.jerk.is_nan() || s.jerk.abs() > j_max)
        {
            return None;
        }
        let mv = FullMove {
            start: from,
            segments,
        };
        let e = mover.end_within_limits(&mv)?;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-13 * (1.0 + b.abs());
        (close(e.pos, to.pos)
            && close(e.vel, to.vel)
            && close(e.acc, to.acc)
            && mv.settles_smoothly())
        .then_some(mv)
    })
}

/// Σ w·c·cᵀ over the pieces.
fn gram(cols: &[[f64; 3]], weights: &[f64]) -> [[f64; 3]; 3] {
    let mut g = [[0.0f64; 3]; 3];
    for (c, w) in cols.iter().zip(weights) {
        for (a, row) in g.iter_mut().enumerate() {
            for (b, cell) in row.iter_mut().enumerate() {
                *cell += w * c[a] * c[b];
            }
        }
    }
    g
}

/// The solution of `g·y = b` (Gaussian elimination with partial pivoting); `None` when `g` is
/// singular to rounding.
fn solve3(mut g: [[f64; 3]; 3], mut b: [f64; 3]) -> Option<[f64; 3]> {
    let size = g.iter().flatten().fold(0.0f64, |a, &v| a.max(v.abs()));
    if size.is_nan() || size <= 0.0 {
        return None;
    }
    for c in 0..3 {
        let p = (c..3).max_by(|&i, &j| g[i][c].abs().total_cmp(&g[j][c].abs()))?;
        if g[p][c].abs() <= 1e-14 * size {
            return None;
        }
        g.swap(c, p);
        b.swap(c, p);
        let (top, below) = g.split_at_mut(c + 1);
        let pivot = &top[c];
        for (r, row) in below.iter_mut().enumerate() {
            let f = row[c] / pivot[c];
            for (x, p) in row[c..].iter_mut().zip(&pivot[c..]) {
                *x -= f * p;
            }
            b[c + 1 + r] -= f * b[c];
        }
    }
    let mut y = [0.0; 3];
    for c in (0..3).rev() {
        let s: f64 = (c + 1..3).map(|k| g[c][k] * y[k]).sum();
        y[c] = (b[c] - s) / g[c][c];
    }
    y.iter().all(|v| v.is_finite()).then_some(y)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stretch whose current motion saw-tooths (−J, +J, −J, +J around a cruise) between two
    /// cruising states through two windows: the least-jerk move is the cruise itself (no jerk
    /// left), ends exactly in the target and stays in the windows.
    #[test]
    fn a_saw_tooth_between_cruising_states_becomes_a_cruise() {
        let lim = Limits::new(1.0, 0.5, 6.0).expect("limits");
        let mover = Mover::new(&lim, false);
        let from = FullState {
            pos: 10.0,
            vel: 3.0,
            acc: 0.0,
        };
        let tooth = |j: f64| Segment {
            duration: 0.05,
            jerk: j,
        };
        let current = vec![
            tooth(-1.0),
            tooth(1.0),
            tooth(1.0),
            tooth(-1.0),
            Segment {
                duration: 0.8,
                jerk: 0.0,
            },
            tooth(1.0),
            tooth(-1.0),
            tooth(-1.0),
            tooth(1.0),
        ];
        let d: f64 = current.iter().map(|s| s.duration).sum();
        let to = current
            .iter()
            .fold(from, |s, seg| s.after(seg.duration, seg.jerk));
        assert!((to.vel - 3.0).abs() < 1e-12 && to.acc.abs() < 1e-12);
        let marks = [(0.3, 10.5, 11.5), (0.9, 12.0, 13.0)];
        let mv = least_jerk_move(&mover, &lim, from, to, &current, &marks).expect("a move");
        let e = mv.end();
        assert!((e.pos - to.pos).abs() < 1e-12 * to.pos && (e.vel - to.vel).abs() < 1e-12);
        assert!((mv.duration() - d).abs() < 1e-12);
        let jerk: f64 = mv.segments.iter().map(|s| s.duration * s.jerk.abs()).sum();
        assert!(jerk < 1e-6, "∫|j| = {jerk}: {mv:?}");
        for &(t, lo, hi) in &marks {
            let x = mv.state_at(t).pos;
            assert!(x >= lo && x <= hi, "{x} outside [{lo}, {hi}] at {t} s");
        }
    }
}
