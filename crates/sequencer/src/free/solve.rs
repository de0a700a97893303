//! One arc's free motion: the seed (layers between the long energy switches flown along one
//! fastest move, every beam as early as its window and the ELST allow), then its refinement.

use arcsim_planner::Limits;

use super::mover::{FullMove, FullState, Mover};
use super::refine::{refine, MAX_STEPS};
use crate::problem::ArcProblem;

/// How an arc's motion starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Start {
    /// The first layer is irradiated at rest.
    Rest,
    /// A run-up from rest (counted) reaches the first beam-on at any speed.
    RunUp,
}

/// How an arc's motion ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum End {
    /// The last layer is irradiated at rest.
    Rest,
    /// The last beam ends at any speed; the gantry then brakes to rest (counted: another arc
    /// follows).
    Brake,
    /// The last beam ends at any speed and nothing after it counts (the plan's last arc).
    Free,
}

/// Whether layer `k` of `n` is irradiated at rest: the arc's first layer with a rest start, its
/// last with a rest end.
pub(super) fn beam_at_rest(k: usize, n: usize, start: Start, end: End) -> bool {
    (k == 0 && start == Start::Rest) || (k + 1 == n && end == End::Rest)
}

/// Layers `first..=last` delivered along one move.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct LayerSpan {
    first: usize,
    last: usize,
    /// At rest for the whole beam (the arc's first or last layer with `rest` ends).
    at_rest: bool,
}

/// A stretch evaluated: its move's duration and the end of its last beam (both from the
/// stretch's first beam-on).
#[derive(Clone, Copy, Debug)]
struct Timed {
    duration: f64,
    last_off: f64,
}

/// The solved arc, in travel coordinates (deg along the direction of travel from the arc's
/// first layer) and seconds.
#[derive(Clone, Debug)]
pub(crate) struct FreeArc {
    /// The run-up from rest before the first beam (`free` ends); its start is where the gantry
    /// waits at rest.
    pub run_up: Option<FullMove>,
    /// Consecutive moves from the first beam-on to the last beam-off.
    pub moves: Vec<FullMove>,
    /// Beam-on time of every layer, from the first beam-on (s).
    pub beam_on: Vec<f64>,
    /// From the start of the run-up (or the first beam-on) to the last beam-off (s).
    pub total: f64,
}

struct Solver<'a> {
    p: &'a ArcProblem,
    start: Start,
    end: End,
    mover: Mover,
}

impl Solver<'_> {
    fn lo(&self, k: usize) -> f64 {
        self.p.window_edges(k).0
    }
    fn hi(&self, k: usize) -> f64 {
        self.p.window_edges(k).1
    }
    fn edge_tol(&self) -> f64 {
        1e-12 * (1.0 + self.p.travel_deg.last().copied().unwrap_or(0.0))
    }

    /// Beams of `st` scheduled as early as possible along `mv`: the first at 0, each next one
    /// when the gantry is in its window and the switch has had its ELST; every beam must end
    /// before the gantry leaves its window and before the move ends. The end of the last beam.
    fn schedule(
        &self,
        st: LayerSpan,
        mv: &FullMove,
        beam_on: Option<&mut Vec<f64>>,
    ) -> Option<f64> {
        let p = self.p;
        let tol = self.edge_tol();
        let end = mv.duration();
        let exit = |k: usize| mv.time_at_position(self.hi(k) + tol).min(end);
        let mut out = Vec::new();
        if p.irradiation_s[st.first] > exit(st.first) + 1e-12 {
            return None;
        }
        out.push(0.0);
        let mut off = p.irradiation_s[st.first];
        for k in st.first + 1..=st.last {
            let on = mv.time_at_position(self.lo(k) - tol).max(off + p.elst[k]);
            if on + p.irradiation_s[k] > exit(k) + 1e-12 * (1.0 + end) {
                return None;
            }
            out.push(on);
            off = on + p.irradiation_s[k];
        }
        if let Some(b) = beam_on {
            *b = out;
        }
        Some(off)
    }

    /// The fastest move of a stretch from `on` (first beam-on) to `off` whose beams fit, and
    /// its timing. Lengthened past the minimum time when the fastest one outruns a beam.
    fn solve_stretch(
        &mut self,
        st: LayerSpan,
        on: FullState,
        off: FullState,
    ) -> Option<(FullMove, Timed)> {
        let p = self.p;
        if st.at_rest {
            let mv = FullMove::dwell(on.pos, p.irradiation_s[st.first]);
            return Some((
                mv,
                Timed {
                    duration: p.irradiation_s[st.first],
                    last_off: p.irradiation_s[st.first],
                },
            ));
        }
        if off.pos < on.pos {
            return None;
        }
        let chain: f64 = (st.first..=st.last)
            .map(|k| p.irradiation_s[k])
            .sum::<f64>()
            + (st.first + 1..=st.last).map(|k| p.elst[k]).sum::<f64>();
        let mv = self.mover.solve(on, off, chain)?;
        let t_opt = mv.duration();
        if let Some(last_off) = self.schedule(st, &mv, None) {
            return Some((
                mv,
                Timed {
                    duration: t_opt,
                    last_off,
                },
            ));
        }
        // Lengthen: geometric steps, then bisection back to the shortest that worked.
        let try_len = |s: &mut Self, t: f64| -> Option<(FullMove, f64)> {
            let mv = s.mover.solve(on, off, t)?;
            let lo = s.schedule(st, &mv, None)?;
            Some((mv, lo))
        };
        let mut bad = t_opt;
        let mut good = None;
        let mut step = 1e-3 * t_opt.max(1e-3);
        for _ in 0..14 {
            let t = t_opt + step;
            if let Some(r) = try_len(self, t) {
                good = Some((t, r));
                break;
            }
            bad = t;
            step *= 2.0;
        }
        let (mut t_good, mut best) = good?;
        for _ in 0..12 {
            let mid = 0.5 * (bad + t_good);
            match try_len(self, mid) {
                Some(r) => {
                    t_good = mid;
                    best = r;
                }
                None => bad = mid,
            }
        }
        let (mv, last_off) = best;
        let duration = mv.duration();
        Some((mv, Timed { duration, last_off }))
    }
}

/// Anchor states: each stretch's first beam-on and last beam-off.
struct State {
    stretches: Vec<LayerSpan>,
    on: Vec<FullState>,
    off: Vec<FullState>,
}

/// Solves one arc's free motion: the anchored moves built from the constant-speed schedule
/// `speeds`, then both seeds (the anchored moves and the constant-speed timeline) refined
/// ([`refine`]), side by side; the shortest of the anchored moves and the two refinements. `None` when neither gives a feasible delivery (the constant-speed timeline
/// is then the answer; the caller also keeps it when it is shorter).
pub(crate) fn solve_arc(
    p: &ArcProblem,
    lim: &Limits,
    start: Start,
    end: End,
    speeds: &[f64],
    report: &(dyn Fn(usize, usize) + Sync),
) -> Option<FreeArc> {
    let n = p.len();
    if n < 2 {
        return None;
    }
    let mut s = Solver {
        p,
        start,
        end,
        mover: Mover::new(lim, false),
    };
    let cut_after = initial_cuts(p, lim, start, end, speeds);
    let stretches = fitting_stretches(&mut s, cut_after, speeds);
    let state = anchor_states(p, lim, end, stretches, speeds);
    let anchored = finish(&mut s, &state);
    // The transcription refined from each seed, the anchored moves and the constant-speed
    // schedule: where long switches at shared control points make the problem rugged (the
    // bundled lung plan), the two lead to different local optima, 1.3 % apart.
    // The two refinements are independent: side by side when a core is free.
    let base = super::from_constant(p, lim, speeds);
    // Both refinements' steps count towards the arc's progress.
    let done = std::sync::atomic::AtomicUsize::new(0);
    let steps = 2 * MAX_STEPS;
    report(0, steps);
    let step_done = || {
        let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        report(d.min(steps), steps);
    };
    let refined_from = |seed: Option<&FreeArc>| {
        seed.and_then(|seed| {
            refine(
                p,
                lim,
                start,
                end,
                &mut Mover::new(lim, false),
                seed,
                &step_done,
            )
        })
    };
    let (from_anchored, from_constant) = rayon::join(
        || refined_from(anchored.as_ref()),
        || refined_from(base.as_ref()),
    );
    [anchored, from_anchored, from_constant]
        .into_iter()
        .flatten()
        .min_by(|a, b| a.total.total_cmp(&b.total))
}

/// Layer `k`'s beam-on state at constant speed `speeds[k]`, its sweep centred on its angle.
fn constant_on(p: &ArcProblem, speeds: &[f64], k: usize) -> FullState {
    FullState {
        pos: p.travel_deg[k] - 0.5 * speeds[k] * p.irradiation_s[k],
        vel: speeds[k],
        acc: 0.0,
    }
}

/// Layer `k`'s beam-off state at constant speed `speeds[k]`.
fn constant_off(p: &ArcProblem, speeds: &[f64], k: usize) -> FullState {
    FullState {
        pos: p.travel_deg[k] + 0.5 * speeds[k] * p.irradiation_s[k],
        vel: speeds[k],
        acc: 0.0,
    }
}

/// Where the arc is cut into stretches: its ends at rest, and the switches that are long against
/// the moves between layers (the gantry must slow down for them, so a single fast move cannot
/// span them).
fn initial_cuts(p: &ArcProblem, lim: &Limits, start: Start, end: End, speeds: &[f64]) -> Vec<bool> {
    let n = p.len();
    let mut durations: Vec<f64> = (0..n - 1)
        .filter_map(|k| p.cost(k, speeds[k], speeds[k + 1], lim))
        .collect();
    durations.sort_by(f64::total_cmp);
    let typical = durations.get(durations.len() / 2).copied().unwrap_or(0.0);
    let mut cut_after: Vec<bool> = (0..n - 1)
        .map(|k| p.elst[k + 1] > 0.0 && p.elst[k + 1] >= 2.0 * typical)
        .collect();
    if start == Start::Rest {
        cut_after[0] = true;
    }
    if end == End::Rest {
        cut_after[n - 2] = true;
    }
    cut_after
}

/// The stretches between the cuts `cut_after` of an arc of `n` layers.
fn stretches_of(cut_after: &[bool], n: usize, start: Start, end: End) -> Vec<LayerSpan> {
    let mut out = Vec::new();
    let mut first = 0;
    for k in 0..n {
        if k + 1 == n || cut_after.get(k).copied().unwrap_or(false) {
            let at_rest = (start == Start::Rest && k == 0) || (end == End::Rest && first == n - 1);
            out.push(LayerSpan {
                first,
                last: k,
                at_rest,
            });
            first = k + 1;
        }
    }
    out
}

/// The stretches of `cut_after`, a stretch whose fastest move outruns a beam at the start
/// split in the middle until every one fits.
fn fitting_stretches(s: &mut Solver, mut cut_after: Vec<bool>, speeds: &[f64]) -> Vec<LayerSpan> {
    let (p, start, end) = (s.p, s.start, s.end);
    let n = p.len();
    let mut stretches = stretches_of(&cut_after, n, start, end);
    for _ in 0..n {
        let mut split = None;
        for st in &stretches {
            if st.at_rest || st.first == st.last {
                continue;
            }
            let (on, off) = (
                constant_on(p, speeds, st.first),
                constant_off(p, speeds, st.last),
            );
            if s.solve_stretch(*st, on, off).is_none() {
                // Cut in the middle of the failing stretch.
                split = Some((st.first + st.last) / 2);
                break;
            }
        }
        match split {
            Some(k) => {
                cut_after[k] = true;
                stretches = stretches_of(&cut_after, n, start, end);
            }
            None => break,
        }
    }
    stretches
}

/// Each stretch's first beam-on and last beam-off state: at rest for a stretch at rest, else at
/// the constant speeds; with `End::Brake`, the last at rest where the gantry has braked.
fn anchor_states(
    p: &ArcProblem,
    lim: &Limits,
    end: End,
    stretches: Vec<LayerSpan>,
    speeds: &[f64],
) -> State {
    let on: Vec<FullState> = stretches
        .iter()
        .map(|st| {
            if st.at_rest {
                FullState::rest(p.travel_deg[st.first])
            } else {
                constant_on(p, speeds, st.first)
            }
        })
        .collect();
    let mut off: Vec<FullState> = stretches
        .iter()
        .map(|st| {
            if st.at_rest {
                FullState::rest(p.travel_deg[st.last])
            } else {
                constant_off(p, speeds, st.last)
            }
        })
        .collect();
    if end == End::Brake {
        // The last stretch ends at rest once the gantry has braked after its last beam.
        if let Some(last) = off.last_mut() {
            let v = last.vel;
            let l = lim;
            let stop = 0.5 * v * (v / l.max_decel + l.max_decel / l.max_jerk);
            *last = FullState::rest(last.pos + stop);
        }
    }
    State { stretches, on, off }
}

/// Builds the moves and beam times of the final anchor states.
fn finish(s: &mut Solver, st: &State) -> Option<FreeArc> {
    let p = s.p;
    let m = st.stretches.len();
    let mut moves = Vec::with_capacity(2 * m);
    let mut beam_on = vec![0.0; p.len()];
    let mut t = 0.0;
    for i in 0..m {
        let stretch = st.stretches[i];
        let (mut mv, timed) = s.solve_stretch(stretch, st.on[i], st.off[i])?;
        let mut times = Vec::new();
        if stretch.at_rest {
            times.push(0.0);
        } else {
            s.schedule(stretch, &mv, Some(&mut times))?;
        }
        for (j, k) in (stretch.first..=stretch.last).enumerate() {
            beam_on[k] = t + times[j];
        }
        if i + 1 == m && s.end == End::Free {
            // Nothing after the last beam-off counts: cut the move there.
            mv = truncate(&mv, timed.last_off);
            moves.push(mv);
            t += timed.last_off;
            break;
        }
        t += mv.duration();
        moves.push(mv);
        if i + 1 < m {
            let tail = timed.duration - timed.last_off;
            let elst = p.elst[st.stretches[i + 1].first];
            let cut = s
                .mover
                .solve(st.off[i], st.on[i + 1], (elst - tail).max(0.0))?;
            t += cut.duration();
            moves.push(cut);
        }
    }
    let run_up = if s.start == Start::RunUp {
        Some(s.mover.run_up(st.on[0])?)
    } else {
        None
    };
    let lead = run_up.as_ref().map_or(0.0, |r| r.duration());
    Some(FreeArc {
        run_up,
        moves,
        beam_on,
        total: lead + t,
    })
}

/// The first `t` seconds of a move.
fn truncate(mv: &FullMove, t: f64) -> FullMove {
    let mut left = t;
    let mut segments = Vec::new();
    for seg in &mv.segments {
        if left <= 0.0 {
            break;
        }
        let d = seg.duration.min(left);
        segments.push(arcsim_planner::Segment {
            duration: d,
            jerk: seg.jerk,
        });
        left -= d;
    }
    FullMove {
        start: mv.start,
        segments,
    }
}
