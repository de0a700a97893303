//! The free-motion solver of one arc: anchors at the long energy switches, the fastest move
//! between them, and a pattern search over the anchor states.

use arcsim_planner::Limits;

use super::mover::{FullMove, FullState, Mover};
use crate::scan::ArcProblem;

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

/// Search budget in passes over all anchors (deterministic: the same result on any machine).
const MAX_PASSES: usize = 60;

struct Solver<'a> {
    p: &'a ArcProblem,
    lim: Limits,
    start: Start,
    end: End,
    mover: Mover,
}

impl Solver<'_> {
    fn lo(&self, k: usize) -> f64 {
        self.p.travel_deg[k] - 0.5 * self.p.window[k]
    }
    fn hi(&self, k: usize) -> f64 {
        self.p.travel_deg[k] + 0.5 * self.p.window[k]
    }
    /// Range of an anchor's position: its layer's window, or (for the rest state after the last
    /// beam of a braking end) up to a braking distance beyond it.
    fn pos_range(&self, k: usize, braking_anchor: bool) -> (f64, f64) {
        if braking_anchor {
            let l = &self.lim;
            let reach = l.max_vel * (l.max_vel / l.max_decel + l.max_decel / l.max_jerk);
            (self.lo(k), self.hi(k) + reach)
        } else {
            (self.lo(k), self.hi(k))
        }
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

    fn stretch_time(&mut self, st: LayerSpan, on: FullState, off: FullState) -> Option<Timed> {
        self.solve_stretch(st, on, off).map(|(_, t)| t)
    }

    /// The switch between two stretches: from the last beam-off state to the next beam-on state,
    /// lasting the ELST less what the previous stretch already spent after its last beam.
    fn cut_time(&mut self, from: FullState, to: FullState, elst: f64, tail: f64) -> Option<f64> {
        self.mover
            .solve(from, to, (elst - tail).max(0.0))
            .map(|m| m.duration())
    }

    fn run_up_time(&mut self, on: FullState) -> Option<f64> {
        self.mover.run_up(on).map(|m| m.duration())
    }
}

/// Anchor states and the costs they give.
#[derive(Clone)]
struct State {
    stretches: Vec<LayerSpan>,
    on: Vec<FullState>,
    off: Vec<FullState>,
    timed: Vec<Timed>,
    cuts: Vec<f64>,
    run_up: f64,
}

impl State {
    /// Total time: run-up, stretches, switches; with a free end the last stretch counts to its
    /// last beam-off.
    fn total(&self, end: End) -> f64 {
        let n = self.timed.len();
        let mut t = self.run_up + self.cuts.iter().sum::<f64>();
        for (i, tm) in self.timed.iter().enumerate() {
            t += if i + 1 == n && end == End::Free {
                tm.last_off
            } else {
                tm.duration
            };
        }
        t
    }
}

/// Solves one arc's free motion starting from the constant-speed schedule `speeds` (which it
/// never does worse than; `None` when the anchored search finds nothing feasible, in which case
/// the constant-speed timeline is the answer).
pub(crate) fn solve_arc(
    p: &ArcProblem,
    lim: &Limits,
    start: Start,
    end: End,
    speeds: &[f64],
) -> Option<FreeArc> {
    let n = p.len();
    if n < 2 {
        return None;
    }
    let mut s = Solver {
        p,
        lim: *lim,
        start,
        end,
        mover: Mover::new(lim, false),
    };
    let on0 = |k: usize| FullState {
        pos: p.travel_deg[k] - 0.5 * speeds[k] * p.irradiation_s[k],
        vel: speeds[k],
        acc: 0.0,
    };
    let off0 = |k: usize| FullState {
        pos: p.travel_deg[k] + 0.5 * speeds[k] * p.irradiation_s[k],
        vel: speeds[k],
        acc: 0.0,
    };
    // Cuts: the arc's ends at rest, and the switches that are long against the moves between
    // layers (the gantry must slow down for them, so a single fast move cannot span them).
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
    let build = |cut_after: &[bool]| -> Vec<LayerSpan> {
        let mut out = Vec::new();
        let mut first = 0;
        for k in 0..n {
            if k + 1 == n || cut_after.get(k).copied().unwrap_or(false) {
                let at_rest =
                    (start == Start::Rest && k == 0) || (end == End::Rest && first == n - 1);
                out.push(LayerSpan {
                    first,
                    last: k,
                    at_rest,
                });
                first = k + 1;
            }
        }
        out
    };
    // Split stretches whose fastest move outruns a beam at the start, until every one fits.
    let mut stretches = build(&cut_after);
    for _ in 0..n {
        let mut split = None;
        for st in &stretches {
            if st.at_rest || st.first == st.last {
                continue;
            }
            let (on, off) = (on0(st.first), off0(st.last));
            if s.solve_stretch(*st, on, off).is_none() {
                // Cut in the middle of the failing stretch.
                split = Some((st.first + st.last) / 2);
                break;
            }
        }
        match split {
            Some(k) => {
                cut_after[k] = true;
                stretches = build(&cut_after);
            }
            None => break,
        }
    }
    let on: Vec<FullState> = stretches
        .iter()
        .map(|st| {
            if st.at_rest {
                FullState::rest(p.travel_deg[st.first])
            } else {
                on0(st.first)
            }
        })
        .collect();
    let mut off: Vec<FullState> = stretches
        .iter()
        .map(|st| {
            if st.at_rest {
                FullState::rest(p.travel_deg[st.last])
            } else {
                off0(st.last)
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
    let mut timed = Vec::with_capacity(stretches.len());
    for (i, st) in stretches.iter().enumerate() {
        timed.push(s.stretch_time(*st, on[i], off[i])?);
    }
    let mut cuts = Vec::with_capacity(stretches.len());
    for i in 0..stretches.len() - 1 {
        let tail = timed[i].duration - timed[i].last_off;
        cuts.push(s.cut_time(off[i], on[i + 1], p.elst[stretches[i + 1].first], tail)?);
    }
    let run_up = if start == Start::RunUp {
        s.run_up_time(on[0])?
    } else {
        0.0
    };
    let mut state = State {
        stretches,
        on,
        off,
        timed,
        cuts,
        run_up,
    };
    search(&mut s, &mut state);
    finish(&mut s, &state)
}

/// Pattern search over the anchor states: each position, speed and acceleration is moved up
/// and down by its step; a move is kept when the total drops; steps halve when none helps.
fn search(s: &mut Solver, st: &mut State) {
    let p = s.p;
    let lim = s.lim;
    let m = st.stretches.len();
    let w_min = p
        .window
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
        .max(1e-6);
    let mut step = [
        0.25 * w_min,
        0.05 * lim.max_vel,
        0.25 * lim.max_accel.min(lim.max_decel),
    ];
    let floor = [1e-7 * w_min, 1e-7 * lim.max_vel, 1e-7 * lim.max_accel];
    let mut current = st.total(s.end);
    for _ in 0..MAX_PASSES {
        let at_start = current;
        let mut improved = false;
        for i in 0..m {
            let stretch = st.stretches[i];
            let braking = i + 1 == m && s.end == End::Brake;
            for which in [Anchor::On, Anchor::Off] {
                for (var, &size) in step.iter().enumerate() {
                    // A rest anchor has only a position; a braking end's last anchor is at rest.
                    let rest = stretch.at_rest || (braking && which == Anchor::Off);
                    if (rest && var > 0) || (stretch.at_rest && which == Anchor::Off) {
                        continue;
                    }
                    let range = s.pos_range(
                        if which == Anchor::On {
                            stretch.first
                        } else {
                            stretch.last
                        },
                        braking && which == Anchor::Off,
                    );
                    for sign in [1.0, -1.0] {
                        let mut d = sign * size;
                        let mut gained = false;
                        // A move that pays is repeated with doubling steps while it keeps paying.
                        for _ in 0..21 {
                            let Some((on, off)) = nudged(st, i, which, var, d, range, &lim) else {
                                break;
                            };
                            match try_change(s, st, i, on, off) {
                                Some(delta) if delta < -1e-12 * (1.0 + current) => {
                                    current += delta;
                                    gained = true;
                                    d *= 2.0;
                                }
                                _ => break,
                            }
                        }
                        if gained {
                            improved = true;
                            break;
                        }
                    }
                }
            }
        }
        // A pass that gains next to nothing refines the steps instead of repeating itself.
        if !improved || at_start - current < 1e-7 * (1.0 + current) {
            for (a, b) in step.iter_mut().zip(&floor) {
                *a = (*a * 0.5).max(*b);
            }
            if step.iter().zip(&floor).all(|(a, b)| a <= b) {
                break;
            }
        }
    }
}

/// Which anchor of a stretch: the first beam-on or the last beam-off.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Anchor {
    On,
    Off,
}

/// LayerSpan `i`'s anchor states with one coordinate (`var`: position, speed, acceleration) of
/// one anchor moved by `d`; `None` outside the limits or the position `range`. A stretch at rest
/// moves both anchors (one state).
fn nudged(
    st: &State,
    i: usize,
    which: Anchor,
    var: usize,
    d: f64,
    range: (f64, f64),
    lim: &Limits,
) -> Option<(FullState, FullState)> {
    let mut q = match which {
        Anchor::On => st.on[i],
        Anchor::Off => st.off[i],
    };
    match var {
        0 => q.pos += d,
        1 => q.vel += d,
        _ => q.acc += d,
    }
    let inside = q.pos >= range.0
        && q.pos <= range.1
        && q.vel >= 0.0
        && q.vel <= lim.max_vel
        && q.acc <= lim.max_accel
        && q.acc >= -lim.max_decel;
    if !inside {
        return None;
    }
    Some(if st.stretches[i].at_rest {
        (q, q)
    } else {
        match which {
            Anchor::On => (q, st.off[i]),
            Anchor::Off => (st.on[i], q),
        }
    })
}

/// Applies new anchor states to stretch `i` if the total drops; returns the change (s).
fn try_change(
    s: &mut Solver,
    st: &mut State,
    i: usize,
    on: FullState,
    off: FullState,
) -> Option<f64> {
    let p = s.p;
    let m = st.stretches.len();
    let stretch = st.stretches[i];
    let timed = s.stretch_time(stretch, on, off)?;
    let last = i + 1 == m && s.end == End::Free;
    let cost = |t: &Timed| if last { t.last_off } else { t.duration };
    let mut delta = cost(&timed) - cost(&st.timed[i]);
    let before = if i > 0 {
        let tail = st.timed[i - 1].duration - st.timed[i - 1].last_off;
        let c = s.cut_time(st.off[i - 1], on, p.elst[stretch.first], tail)?;
        delta += c - st.cuts[i - 1];
        Some(c)
    } else {
        None
    };
    let after = if i + 1 < m {
        let tail = timed.duration - timed.last_off;
        let c = s.cut_time(off, st.on[i + 1], p.elst[st.stretches[i + 1].first], tail)?;
        delta += c - st.cuts[i];
        Some(c)
    } else {
        None
    };
    let run_up = if i == 0 && s.start == Start::RunUp {
        let r = s.run_up_time(on)?;
        delta += r - st.run_up;
        Some(r)
    } else {
        None
    };
    if delta >= 0.0 {
        return Some(delta);
    }
    st.on[i] = on;
    st.off[i] = off;
    st.timed[i] = timed;
    if let Some(c) = before {
        st.cuts[i - 1] = c;
    }
    if let Some(c) = after {
        st.cuts[i] = c;
    }
    if let Some(r) = run_up {
        st.run_up = r;
    }
    Some(delta)
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
