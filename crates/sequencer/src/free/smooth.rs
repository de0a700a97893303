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
//! re-fly is a shortest path over the beam edges whose cost is the reversals left.

use arcsim_planner::{Limits, Segment};

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
    let push = |out: &mut Vec<FullMove>, segments: Vec<Segment>| {
        let start = out.last().map_or(fa.moves[0].start, delivered_end);
        out.push(FullMove { start, segments });
    };
    if edges[0] > 0.0 {
        push(&mut out, track.slice(0.0, edges[0]));
    }
    for (i, k, reflown) in plan {
        let from = out.last().map_or(states[i], delivered_end);
        let mv = reflown
            .then(|| exact(&mut mover, from, states[k], edges[k] - edges[i]))
            .flatten()
            .filter(|mv| in_windows(mv, edges[i], edges[k]));
        match mv {
            Some(mv) => push(&mut out, mv.segments),
            None => push(&mut out, track.slice(edges[i], edges[k])),
        }
    }
    let end = track.end();
    if end > last_off {
        push(&mut out, track.slice(last_off, end));
    }
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

/// Where `mv` ends as the timeline delivers it: each segment without jerk that starts a
/// rounding away from rest starts at rest ([`FullState::settled`]), as the assembly does.
fn delivered_end(mv: &FullMove) -> FullState {
    mv.segments.iter().fold(mv.start, |s, seg| {
        s.settled(seg.jerk).after(seg.duration, seg.jerk)
    })
}

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
    Some(mv)
}

/// Jerk runs (consecutive segments of one sign, zero-jerk segments shorter than 1e-9 s skipped)
/// shorter than [`SHORT_REVERSAL_S`] between runs of the other sign.
fn reversals(segments: &[Segment]) -> usize {
    let mut runs: Vec<(i8, f64)> = Vec::new();
    for s in segments {
        let sign = if s.jerk > 0.0 {
            1
        } else if s.jerk < 0.0 {
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
