//! Smoothing: the same free-motion arc flown with fewer jerk reversals.
//!
//! The solver's objective is the total time only, so wherever the gantry is not what limits a
//! stretch (its beams and ELSTs set the clock) any feasible jerk sequence is as good as another,
//! and the transcript's is often a saw-tooth (−J, +J, −J within a tenth of a second). The
//! jerk limit is there to spare the gantry: such stretches are re-flown as one Ruckig move
//! between the same two states in the same time, which has at most seven phases. Every beam-on
//! and beam-off keeps its time and every layer's sweep stays inside its window, so the total,
//! the rows and the ELSTs are untouched; a stretch is re-flown only where that move exists,
//! keeps every limit and holds every beam it spans inside its window. Which stretches to
//! re-fly is a shortest path over the beam edges whose cost is the reversals left. Where the
//! solver's own states at the edges wiggle, moves between them keep the wiggle: a move that
//! still reverses is then flown again with its neighbours as the least-jerk move through their
//! edges ([`least_jerk_move`]), kept where it leaves fewer reversals.

use arcsim_planner::{Limits, Segment};

use super::least_jerk::{least_jerk_move, Mark};
use super::mover::{FullMove, FullState, Mover, Track};
use super::solve::FreeArc;
use crate::problem::ArcProblem;

/// The most beam edges one re-flown stretch spans (bounds the work per stretch).
const MAX_SPAN: usize = 32;

/// Jerk runs shorter than this (s) between runs of the other sign are what smoothing removes.
const SHORT_REVERSAL_S: f64 = 0.1;

/// `fa` with stretches between beam edges re-flown as single moves, chosen to leave the fewest
/// jerk reversals ([`fewest_reversals`]); beam times, the run-up and the motion after the last
/// beam-off are kept, and so is the whole arc if a rounding moved a beam out of its window.
pub(crate) fn smooth(p: &ArcProblem, lim: &Limits, fa: &FreeArc) -> FreeArc {
    let n = p.len();
    if n < 2 || fa.beam_on.len() != n || fa.moves.is_empty() {
        return fa.clone();
    }
    let track = Track::new(&fa.moves);
    // Beam edges, in time order, from the first beam-on to the last beam-off.
    let mut edges: Vec<f64> = Vec::with_capacity(2 * n);
    for k in 0..n {
        edges.push(fa.beam_on[k]);
        edges.push(fa.beam_on[k] + p.irradiation_s[k]);
    }
    edges.dedup_by(|b, a| *b <= *a);
    let last_off = *edges.last().unwrap_or(&0.0);
    let states: Vec<FullState> = edges.iter().map(|&t| track.state_at(t)).collect();
    let tol = 1e-12 * (1.0 + p.travel_deg.last().copied().unwrap_or(0.0));
    // Every beam inside [t0, t1] (by its beam-on) swept inside its window; the motion never
    // goes backwards, so its ends are what to check.
    let in_windows = |mv: &FullMove, t0: f64, t1: f64| -> bool {
        let first = fa.beam_on.partition_point(|&on| on < t0);
        (first..n).take_while(|&k| fa.beam_on[k] < t1).all(|k| {
            let (on, off) = (fa.beam_on[k], fa.beam_on[k] + p.irradiation_s[k]);
            let (lo, hi) = p.window_edges(k);
            [on, off.min(t1)].iter().all(|&t| {
                let x = mv.state_at(t - t0).pos;
                x >= lo - tol && x <= hi + tol
            })
        })
    };
    let plan = fewest_reversals(&track, &edges, &states, lim, &in_windows);
    // Each move starts exactly where the one before ends (the timeline's joins are continuous);
    // a re-flown stretch reaches its end state to Ruckig's precision, and what follows starts
    // from there (the stretch is solved again from that start, and kept as it was if it no
    // longer fits).
    let mut mover = Mover::new(lim, false);
    let mut out: Vec<FullMove> = Vec::with_capacity(plan.len() + 2);
    // The beam edges each move of `out` runs between (none for the run-up and the tail).
    let mut spans: Vec<Option<(usize, usize)>> = Vec::with_capacity(plan.len() + 2);
    let push = |out: &mut Vec<FullMove>, segments: Vec<Segment>| {
        let start = out
            .last()
            .map_or(fa.moves[0].start, FullMove::delivered_end);
        out.push(FullMove { start, segments });
    };
    if edges[0] > 0.0 {
        push(&mut out, track.slice(0.0, edges[0]));
        spans.push(None);
    }
    for (i, k, reflown) in plan {
        let from = out.last().map_or(states[i], FullMove::delivered_end);
        let mv = reflown
            .then(|| exact(&mut mover, from, states[k], edges[k] - edges[i]))
            .flatten()
            .filter(|mv| in_windows(mv, edges[i], edges[k]));
        match mv {
            Some(mv) => push(&mut out, mv.segments),
            None => push(&mut out, track.slice(edges[i], edges[k])),
        }
        spans.push(Some((i, k)));
    }
    let end = track.end();
    if end > last_off {
        push(&mut out, track.slice(last_off, end));
        spans.push(None);
    }
    // The beams' windows at the edges, for the least-jerk moves.
    let mut marks: Vec<(f64, f64)> = vec![(f64::NEG_INFINITY, f64::INFINITY); edges.len()];
    for k in 0..n {
        let (lo, hi) = p.window_edges(k);
        for t in [fa.beam_on[k], fa.beam_on[k] + p.irradiation_s[k]] {
            let i = edges.partition_point(|&e| e < t);
            if i < edges.len() && edges[i] == t {
                marks[i] = (marks[i].0.max(lo), marks[i].1.min(hi));
            }
        }
    }
    let polish = Polish {
        edges: &edges,
        marks: &marks,
        lim,
        in_windows: &in_windows,
    };
    polish.run(&mut out, &mut spans);
    // The stretches kept as they were now start a rounding away from where they did: every
    // beam is checked again on the whole new motion, and the arc kept as solved if one left its
    // window.
    let smoothed = Track::new(&out);
    let whole = FullMove {
        start: fa.moves[0].start,
        segments: smoothed.slice(0.0, smoothed.end()),
    };
    if !in_windows(&whole, 0.0, f64::INFINITY) {
        return fa.clone();
    }
    FreeArc {
        run_up: fa.run_up.clone(),
        moves: out,
        beam_on: fa.beam_on.clone(),
        total: fa.total,
    }
}

/// The last pass: a move that still reverses its jerk is flown again, with its neighbours, as
/// the least-jerk move through their beam edges ([`least_jerk_move`]), where that leaves fewer
/// short reversals.
struct Polish<'a> {
    edges: &'a [f64],
    /// Each edge's window (lowest and highest position a beam there allows).
    marks: &'a [(f64, f64)],
    lim: &'a Limits,
    in_windows: &'a dyn Fn(&FullMove, f64, f64) -> bool,
}

/// How many moves on each side of a reversing one the least-jerk stretches take, in the order
/// tried.
const POLISH_RADII: [usize; 3] = [1, 2, 4];

impl Polish<'_> {
    fn run(&self, out: &mut Vec<FullMove>, spans: &mut Vec<Option<(usize, usize)>>) {
        let mover = Mover::new(self.lim, false);
        let mut q = 0;
        while q < out.len() {
            if spans[q].is_none() || around(out, q, q, None) == 0 {
                q += 1;
                continue;
            }
            let mut next = q + 1;
            for r in POLISH_RADII {
                let mut lo = q;
                while lo > 0 && q - lo < r && spans[lo - 1].is_some() {
                    lo -= 1;
                }
                let mut hi = q;
                while hi + 1 < out.len() && hi - q < r && spans[hi + 1].is_some() {
                    hi += 1;
                }
                let (Some((i0, _)), Some((_, i1))) = (spans[lo], spans[hi]) else {
                    continue;
                };
                let Some(mv) = self.least_jerk(&mover, out, lo, hi, i0, i1) else {
                    continue;
                };
                if around(out, lo, hi, Some(&mv)) >= around(out, lo, hi, None) {
                    continue;
                }
                // What follows starts where the new move ends, move by move; a rounding there
                // must not turn a hold that was smooth into one the delivery settles with a jump.
                let mut trial: Vec<FullMove> = out[..lo].to_vec();
                trial.push(mv);
                for m in &out[hi + 1..] {
                    let start = trial.last().map_or(m.start, FullMove::delivered_end);
                    trial.push(FullMove {
                        start,
                        segments: m.segments.clone(),
                    });
                }
                let smooth_after = out[hi + 1..]
                    .iter()
                    .zip(&trial[lo + 1..])
                    .all(|(old, new)| !old.settles_smoothly() || new.settles_smoothly());
                if trial[lo].settles_smoothly() && smooth_after {
                    *out = trial;
                    spans.splice(lo..=hi, [Some((i0, i1))]);
                    next = lo + 1;
                    break;
                }
            }
            q = next;
        }
    }

    /// The least-jerk move replacing `out[lo..=hi]` (edges `i0` to `i1`), in the windows.
    fn least_jerk(
        &self,
        mover: &Mover,
        out: &[FullMove],
        lo: usize,
        hi: usize,
        i0: usize,
        i1: usize,
    ) -> Option<FullMove> {
        let current: Vec<Segment> = out[lo..=hi]
            .iter()
            .flat_map(|m| m.segments.iter().copied())
            .collect();
        let t0 = self.edges[i0];
        let marks: Vec<Mark> = (i0 + 1..i1)
            .map(|i| (self.edges[i] - t0, self.marks[i].0, self.marks[i].1))
            .collect();
        let from = out[lo].start;
        let to = out[hi].delivered_end();
        let mv = least_jerk_move(mover, self.lim, from, to, &current, &marks)?;
        (self.in_windows)(&mv, t0, self.edges[i1]).then_some(mv)
    }
}

/// Short jerk reversals of `out[lo..=hi]` (or `replacement` in their place) with the end of the
/// move before and the start of the move after.
fn around(out: &[FullMove], lo: usize, hi: usize, replacement: Option<&FullMove>) -> usize {
    let mut segments: Vec<Segment> = Vec::new();
    if lo > 0 {
        let before = &out[lo - 1].segments;
        segments.extend_from_slice(&before[before.len().saturating_sub(TAIL)..]);
    }
    match replacement {
        Some(mv) => segments.extend_from_slice(&mv.segments),
        None => {
            for m in &out[lo..=hi] {
                segments.extend_from_slice(&m.segments);
            }
        }
    }
    if let Some(after) = out.get(hi + 1) {
        segments.extend_from_slice(&after.segments[..after.segments.len().min(TAIL)]);
    }
    reversals(&segments)
}

/// One step of the smoothed motion: from edge `i` to edge `k`, re-flown or as it was.
type Step = (usize, usize, bool);

/// The stretches between beam edges to re-fly, chosen by a shortest path over the edges: each
/// step is the solved motion from one edge to the next, or one Ruckig move over up to
/// [`MAX_SPAN`] edges that keeps the beams in their windows; a path's cost is its jerk
/// reversals (those at the joins counted on the last segments before them).
fn fewest_reversals(
    track: &Track,
    edges: &[f64],
    states: &[FullState],
    lim: &Limits,
    in_windows: &dyn Fn(&FullMove, f64, f64) -> bool,
) -> Vec<Step> {
    let m = edges.len();
    let mut mover = Mover::new(lim, false);
    // Per edge: the fewest reversals so far, the step into it, the last segments so far.
    let mut best: Vec<Option<(usize, Step, Vec<Segment>)>> = vec![None; m];
    best[0] = Some((0, (0, 0, false), Vec::new()));
    for i in 0..m.saturating_sub(1) {
        let Some((cost, _, tail)) = best[i].clone() else {
            continue;
        };
        let mut relax = |k: usize, segments: Vec<Segment>, reflown: bool| {
            let mut joined = tail.clone();
            joined.extend_from_slice(&segments);
            let added = reversals(&joined).saturating_sub(reversals(&tail));
            let c = cost + added;
            if best[k].as_ref().is_none_or(|b| c < b.0) {
                let keep = joined.len().saturating_sub(TAIL);
                best[k] = Some((c, (i, k, reflown), joined.split_off(keep)));
            }
        };
        relax(i + 1, track.slice(edges[i], edges[i + 1]), false);
        for k in i + 1..m.min(i + 1 + MAX_SPAN) {
            let Some(mv) = exact(&mut mover, states[i], states[k], edges[k] - edges[i]) else {
                continue;
            };
            if in_windows(&mv, edges[i], edges[k]) {
                relax(k, mv.segments, true);
            }
        }
    }
    let mut steps = Vec::new();
    let mut k = m - 1;
    while k > 0 {
        let Some((_, step, _)) = &best[k] else {
            break;
        };
        steps.push(*step);
        k = step.0;
    }
    steps.reverse();
    steps
}

/// Segments kept from the end of a path to count the reversals at its next join.
const TAIL: usize = 16;

/// The move `from → to` lasting exactly `duration` (Ruckig's to 1e-12 of it, then made exact on
/// its last segment), within the limits and never going backwards; `None` where there is none.
fn exact(mover: &mut Mover, from: FullState, to: FullState, duration: f64) -> Option<FullMove> {
    if duration <= 0.0 {
        return None;
    }
    let mut mv = mover.solve(from, to, duration)?;
    let diff = duration - mv.duration();
    if diff.abs() > 1e-12 * (1.0 + duration) {
        return None;
    }
    let last = mv.segments.last_mut()?;
    if last.duration + diff < 0.0 {
        return None;
    }
    last.duration += diff;
    mover.end_within_limits(&mv)?;
    mv.settles_smoothly().then_some(mv)
}

/// Jerk runs (consecutive segments of one sign, |jerk| ≤ 1e-9 counted as none, zero-jerk
/// segments shorter than 1e-9 s skipped)
/// shorter than [`SHORT_REVERSAL_S`] between runs of the other sign.
fn reversals(segments: &[Segment]) -> usize {
    let mut runs: Vec<(i8, f64)> = Vec::new();
    for s in segments {
        let sign = if s.jerk > 1e-9 {
            1
        } else if s.jerk < -1e-9 {
            -1
        } else {
            0
        };
        if sign == 0 && s.duration < 1e-9 {
            continue;
        }
        match runs.last_mut() {
            Some(r) if r.0 == sign => r.1 += s.duration,
            _ => runs.push((sign, s.duration)),
        }
    }
    runs.windows(3)
        .filter(|w| w[1].0 != 0 && w[0].0 == -w[1].0 && w[2].0 == -w[1].0)
        .filter(|w| w[1].1 < SHORT_REVERSAL_S)
        .count()
}
