//! Sequential linear programming on the transcription ([`Transcript`]) of one arc, and the exact
//! delivery built from its result.
//!
//! Each step solves the transcription linearised at the current pieces inside a trust region,
//! then a *corrector* (the same, linearised at the step, in a region ten times smaller) closes
//! most of what the linearisation missed. The step is kept only when the exact delivery built
//! from it ([`realize`]) is shorter than the best so far; the trust region then grows by half,
//! else it halves. The result is a local optimum of the transcribed problem, within the
//! trust-region tolerance.

use arcsim_planner::{Limits, Segment};

use super::mover::{FullMove, FullState, Mover};
use super::solve::{beam_at_rest, End, FreeArc, Start};
use super::transcribe::Transcript;
use crate::problem::ArcProblem;

/// Most steps one refinement takes (each solves two linear programmes).
pub(super) const MAX_STEPS: usize = 60;
/// First trust radius (a fraction of each piece's duration).
const FIRST_RADIUS: f64 = 0.0625;
/// The corrector's trust radius against the step's.
const CORRECTOR_RADIUS: f64 = 0.1;
/// Refinement stops once a step would gain less than this fraction of the total.
const STOP_GAIN: f64 = 1e-5;

/// The shortest exact delivery found by sequential linear programming from `seed` (`None` if
/// neither the seed's transcription nor any step could be built exactly).
pub(super) fn refine(
    p: &ArcProblem,
    lim: &Limits,
    start: Start,
    end: End,
    mover: &mut Mover,
    seed: &FreeArc,
    step_done: &(dyn Fn() + Sync),
) -> Option<FreeArc> {
    let mut fl = Flight {
        p,
        lim: *lim,
        start,
        end,
        mover,
    };
    let mut tr = Transcript::from_arc(p, start, end, seed);
    let mut best = fl.realize(&tr);
    let mut best_total = best.as_ref().map_or(f64::INFINITY, |b| b.total);
    let mut radius = FIRST_RADIUS;
    for _ in 0..MAX_STEPS {
        step_done();
        let next = tr.step(p, lim, start, end, radius).and_then(|next| {
            let mut c = next.step(p, lim, start, end, CORRECTOR_RADIUS * radius)?;
            c.normalise(p);
            Some(c)
        });
        let Some(next) = next else {
            radius *= 0.5;
            if radius < 1e-4 {
                break;
            }
            continue;
        };
        let predicted = tr.duration() - next.duration();
        match fl.realize(&next) {
            Some(fa) if fa.total < best_total - 1e-10 * (1.0 + best_total) => {
                best_total = fa.total;
                best = Some(fa);
                tr = next;
                radius = (1.5 * radius).min(1.0);
            }
            _ => radius *= 0.5,
        }
        if radius < 1e-4 || (best.is_some() && predicted.abs() < STOP_GAIN * best_total) {
            break;
        }
    }
    best
}

/// What building an exact delivery needs.
struct Flight<'a> {
    p: &'a ArcProblem,
    lim: Limits,
    start: Start,
    end: End,
    mover: &'a mut Mover,
}

impl Flight<'_> {
    /// The exact delivery of a transcript: every beam flown on the transcript's own pieces from
    /// where the gantry is, every switch the fastest move (at least its ELST) to the transcript's
    /// next beam-on state, the run-up and braking the fastest ones. `None` when a move does not
    /// exist or a beam leaves its window or a limit.
    fn realize(&mut self, tr: &Transcript) -> Option<FreeArc> {
        let p = self.p;
        let n = p.len();
        let (on_s, off_s) = tr.anchors(n);
        let (lo, hi): (Vec<f64>, Vec<f64>) = (0..n).map(|k| p.window_edges(k)).unzip();
        let a = Anchors {
            on_s,
            off_s,
            lo,
            hi,
            lim: self.lim,
        };
        let mut moves = Vec::with_capacity(2 * n + 1);
        let mut beam_on = vec![0.0; n];
        let (mut cur, run_up) = if self.start == Start::RunUp {
            let r = self.mover.run_up(a.clean(a.on_s[0], 0))?;
            (r.end(), Some(r))
        } else {
            (FullState::rest(a.clean(a.on_s[0], 0).pos), None)
        };
        let mut t = 0.0;
        let tol = 1e-10 * (1.0 + p.travel_deg.last().copied().unwrap_or(0.0));
        for (k, on) in beam_on.iter_mut().enumerate() {
            if k > 0 {
                let mv = self.switch_into(k, cur, tr, &a)?;
                let c = self.mover.end_within_limits(&mv)?;
                t += mv.duration();
                cur = c;
                moves.push(mv);
            }
            *on = t;
            if cur.pos < a.lo[k] - tol {
                return None;
            }
            let mv = self.beam(k, cur, tr, &a)?;
            let c = self.mover.end_within_limits(&mv)?;
            if c.pos > a.hi[k] + tol {
                return None;
            }
            cur = c;
            t += p.irradiation_s[k];
            moves.push(mv);
        }
        if self.end == End::Brake {
            let mv = self.brake_after(cur, tr)?;
            t += mv.duration();
            moves.push(mv);
        }
        let lead = run_up.as_ref().map_or(0.0, FullMove::duration);
        Some(FreeArc {
            run_up,
            moves,
            beam_on,
            total: lead + t,
        })
    }

    /// Whether layer `k` is irradiated at rest.
    fn rest_at(&self, k: usize) -> bool {
        beam_at_rest(k, self.p.len(), self.start, self.end)
    }

    /// The switch from `cur` into layer `k`: the fastest move lasting its ELST to the
    /// transcript's beam-on state; into a beam at rest, braking to rest where that stops inside
    /// the window; else the transcript's own pieces.
    fn switch_into(
        &mut self,
        k: usize,
        cur: FullState,
        tr: &Transcript,
        a: &Anchors,
    ) -> Option<FullMove> {
        let p = self.p;
        let to = if self.rest_at(k) {
            FullState::rest(a.clean(a.on_s[k], k).pos)
        } else {
            a.clean(a.on_s[k], k)
        };
        let ruckig = self.mover.solve(cur, to, p.elst[k]);
        // Into a beam at rest: braking to rest wherever the gantry stops does, if that is
        // inside the window (the exact stop the transcript aims at can be a hair out of
        // reach after the linearisation).
        let ruckig = ruckig.or_else(|| {
            if !self.rest_at(k) {
                return None;
            }
            let mut mv = self.mover.brake(cur)?;
            let stop = mv.end().pos;
            if stop < a.lo[k] || stop > a.hi[k] {
                return None;
            }
            let d = mv.duration();
            if d < p.elst[k] {
                mv.segments.push(Segment {
                    duration: p.elst[k] - d,
                    jerk: 0.0,
                });
            }
            Some(mv)
        });
        match ruckig {
            Some(mv) => Some(mv),
            // Ruckig finds no move where the transcript's sits on a limit (exactly one
            // move fits): fly the transcript's own pieces, at least the ELST long.
            None => pieces_from(cur, tr.switch_segments(k), Some(p.elst[k]), &self.lim),
        }
    }

    /// Layer `k`'s beam from `cur`, lasting exactly its irradiation time: a dwell at rest, the
    /// fastest move to the transcript's beam-off state, or the transcript's own pieces.
    fn beam(&mut self, k: usize, cur: FullState, tr: &Transcript, a: &Anchors) -> Option<FullMove> {
        let t_k = self.p.irradiation_s[k];
        if self.rest_at(k) && (cur.vel.abs() > 1e-12 || cur.acc.abs() > 1e-12) {
            return None;
        }
        let mv = if self.rest_at(k) {
            FullMove::dwell(cur.pos, t_k)
        } else {
            let to = a.clean(a.off_s[k], k);
            let ruckig = self.mover.solve(cur, to, t_k);
            match ruckig {
                Some(mv) if mv.duration() <= t_k * (1.0 + 1e-12) => mv,
                _ => pieces_from(cur, scaled_to(tr.beam_segments(k), t_k), None, &self.lim)?,
            }
        };
        // Exactly the irradiation time (Ruckig's duration may be off by rounding), so that
        // beam edges and move joins coincide.
        let mut mv = mv;
        let excess = mv.duration() - t_k;
        if let Some(last) = mv.segments.last_mut() {
            if last.duration > excess {
                last.duration -= excess;
            }
        }
        Some(mv)
    }

    /// The braking to rest after the last beam (the fastest, else the transcript's pieces).
    fn brake_after(&mut self, cur: FullState, tr: &Transcript) -> Option<FullMove> {
        let lim = self.lim;
        let mv = match self.mover.brake(cur) {
            Some(mv) => mv,
            None => pieces_from(cur, tr.brake_segments(), None, &lim)?,
        };
        let stop = self.mover.end_within_limits(&mv)?;
        if stop.vel.abs() > 1e-9 * lim.max_vel || stop.acc.abs() > 1e-9 * lim.max_accel {
            return None;
        }
        Some(mv)
    }
}

/// A transcript's beam-on and beam-off states and the windows they are kept in.
struct Anchors {
    on_s: Vec<FullState>,
    off_s: Vec<FullState>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    lim: Limits,
}

impl Anchors {
    /// State `x` at layer `k` clamped into its window and the limits.
    fn clean(&self, x: FullState, k: usize) -> FullState {
        FullState {
            pos: x.pos.clamp(self.lo[k], self.hi[k]),
            vel: x.vel.clamp(0.0, self.lim.max_vel),
            acc: x.acc.clamp(-self.lim.max_decel, self.lim.max_accel),
        }
    }
}

/// `segs` with their durations scaled to sum to `total` (unchanged if they sum to zero).
fn scaled_to(mut segs: Vec<Segment>, total: f64) -> Vec<Segment> {
    let sum: f64 = segs.iter().map(|g| g.duration).sum();
    if sum > 0.0 {
        for g in &mut segs {
            g.duration *= total / sum;
        }
    }
    segs
}

/// A transcript's pieces flown from `from`: each jerk clipped so that the acceleration and the
/// speed at the piece's end stay inside the limits and the speed neither dips below zero nor
/// overshoots V inside it (the linearisation and the joins-only speed bound can leave them a hair outside), the
/// durations scaled up to `at_least` seconds if given. `None` without a piece.
fn pieces_from(
    from: FullState,
    mut segs: Vec<Segment>,
    at_least: Option<f64>,
    lim: &Limits,
) -> Option<FullMove> {
    let sum: f64 = segs.iter().map(|g| g.duration).sum();
    if sum <= 0.0 {
        return None;
    }
    if let Some(min) = at_least.filter(|&m| sum < m) {
        for g in &mut segs {
            g.duration *= min / sum;
        }
    }
    let mut s = from;
    for g in &mut segs {
        let d = g.duration;
        if d > 0.0 {
            let (mut lo, mut hi) = (-lim.max_jerk, lim.max_jerk);
            lo = lo.max((-lim.max_decel - s.acc) / d);
            hi = hi.min((lim.max_accel - s.acc) / d);
            lo = lo.max(2.0 * (-s.vel - s.acc * d) / (d * d));
            hi = hi.min(2.0 * (lim.max_vel - s.vel - s.acc * d) / (d * d));
            if lo <= hi {
                g.jerk = g.jerk.clamp(lo, hi);
            }
            // Braking that turns into speeding up inside the piece must not dip below zero
            // speed on the way: the least jerk whose lowest speed is exactly zero.
            let u = g.jerk;
            let dips = s.acc < 0.0 && u > 0.0 && -s.acc / u < d;
            if dips && s.vel > 0.0 && s.vel - s.acc * s.acc / (2.0 * u) < 0.0 {
                g.jerk = (s.acc * s.acc / (2.0 * s.vel)).min(lim.max_jerk);
            }
            // Likewise speeding up that turns into braking must not overshoot V: the least
            // braking jerk whose highest speed is exactly V.
            let u = g.jerk;
            let room = lim.max_vel - s.vel;
            let peaks = s.acc > 0.0 && u < 0.0 && -s.acc / u < d;
            if peaks && room > 0.0 && s.vel - s.acc * s.acc / (2.0 * u) > lim.max_vel {
                g.jerk = -(s.acc * s.acc / (2.0 * room)).min(lim.max_jerk);
            }
        }
        s = s.after(g.duration, g.jerk);
    }
    Some(FullMove {
        start: from,
        segments: segs,
    })
}
