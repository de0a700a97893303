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
const MAX_STEPS: usize = 60;
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
        let s = self;
        let p = s.p;
        let n = p.len();
        let lim = s.lim;
        let (on_s, off_s) = tr.anchors(n);
        let (lo, hi): (Vec<f64>, Vec<f64>) = (0..n).map(|k| p.window_edges(k)).unzip();
        let clean = |x: FullState, k: usize| FullState {
            pos: x.pos.clamp(lo[k], hi[k]),
            vel: x.vel.clamp(0.0, lim.max_vel),
            acc: x.acc.clamp(-lim.max_decel, lim.max_accel),
        };
        let (start, end) = (s.start, s.end);
        let rest_at = |k: usize| beam_at_rest(k, n, start, end);
        let mut moves = Vec::with_capacity(2 * n + 1);
        let mut beam_on = vec![0.0; n];
        let (mut cur, run_up) = if start == Start::RunUp {
            let r = s.mover.run_up(clean(on_s[0], 0))?;
            (r.end(), Some(r))
        } else {
            (FullState::rest(clean(on_s[0], 0).pos), None)
        };
        let mut t = 0.0;
        let tol = 1e-10 * (1.0 + p.travel_deg.last().copied().unwrap_or(0.0));
        for k in 0..n {
            if k > 0 {
                let to = if rest_at(k) {
                    FullState::rest(clean(on_s[k], k).pos)
                } else {
                    clean(on_s[k], k)
                };
                let ruckig = s.mover.solve(cur, to, p.elst[k]);
                // Into a beam at rest: braking to rest wherever the gantry stops does, if that is
                // inside the window (the exact stop the transcript aims at can be a hair out of
                // reach after the linearisation).
                let ruckig = ruckig.or_else(|| {
                    if !rest_at(k) {
                        return None;
                    }
                    brake_into_window(s.mover, cur, lo[k], hi[k], p.elst[k])
                });
                let mv = match ruckig {
                    Some(mv) => mv,
                    // Ruckig finds no move where the transcript's sits on a limit (exactly one
                    // move fits): fly the transcript's own pieces, at least the ELST long.
                    None => pieces_from(cur, tr.switch_segments(k), Some(p.elst[k]), &lim)?,
                };
                let c = s.mover.end_within_limits(&mv)?;
                t += mv.duration();
                cur = c;
                moves.push(mv);
            }
            beam_on[k] = t;
            if cur.pos < lo[k] - tol {
                return None;
            }
            let t_k = p.irradiation_s[k];
            if rest_at(k) && (cur.vel.abs() > 1e-12 || cur.acc.abs() > 1e-12) {
                return None;
            }
            let mv = if rest_at(k) {
                FullMove::dwell(cur.pos, t_k)
            } else {
                let to = clean(off_s[k], k);
                let ruckig = s.mover.solve(cur, to, t_k);
                match ruckig {
                    Some(mv) if mv.duration() <= t_k * (1.0 + 1e-12) => mv,
                    _ => pieces_from(cur, scaled_to(tr.beam_segments(k), t_k), None, &lim)?,
                }
            };
            // Exactly the irradiation time (Ruckig's duration may be off by rounding), so that
            // beam edges and move joins coincide.
            let mut mv = mv;
            trim_to(&mut mv, t_k);
            let c = s.mover.end_within_limits(&mv)?;
            if c.pos > hi[k] + tol {
                return None;
            }
            cur = c;
            t += t_k;
            moves.push(mv);
        }
        if end == End::Brake {
            let mv = brake_after_last_beam(s.mover, cur, tr, &lim)?;
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

/// Braking to rest from `cur`, if the gantry stops inside `[lo, hi]`; padded with a dwell to
/// last at least `elst`.
fn brake_into_window(
    mover: &mut Mover,
    cur: FullState,
    lo: f64,
    hi: f64,
    elst: f64,
) -> Option<FullMove> {
    let mut mv = mover.brake(cur)?;
    let stop = mv.end().pos;
    if stop < lo || stop > hi {
        return None;
    }
    let d = mv.duration();
    if d < elst {
        mv.segments.push(Segment {
            duration: elst - d,
            jerk: 0.0,
        });
    }
    Some(mv)
}

/// Shortens the last segment of `mv` by what it lasts beyond `t_k` (when that segment is longer).
fn trim_to(mv: &mut FullMove, t_k: f64) {
    let excess = mv.duration() - t_k;
    if let Some(last) = mv.segments.last_mut() {
        if last.duration > excess {
            last.duration -= excess;
        }
    }
}

/// The braking after the last beam from `cur` (the transcript's own pieces where Ruckig finds
/// none); `None` unless it ends at rest within the limits.
fn brake_after_last_beam(
    mover: &mut Mover,
    cur: FullState,
    tr: &Transcript,
    lim: &Limits,
) -> Option<FullMove> {
    let mv = match mover.brake(cur) {
        Some(mv) => mv,
        None => pieces_from(cur, tr.brake_segments(), None, lim)?,
    };
    let stop = mover.end_within_limits(&mv)?;
    if stop.vel.abs() > 1e-9 * lim.max_vel || stop.acc.abs() > 1e-9 * lim.max_accel {
        return None;
    }
    Some(mv)
}
