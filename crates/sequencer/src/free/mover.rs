//! Full-state moves: between two kinematic states (position, speed, acceleration) in the least
//! time that lasts at least a given duration, jerk-, acceleration- and speed-limited.
//!
//! The planner crate solves moves that start and end with zero acceleration; free motion needs
//! any acceleration at a layer boundary, which is Ruckig's problem. Each move is solved with
//! rsruckig, converted to our own constant-jerk segments and re-integrated: a move whose segments
//! do not reach the target state (to 1e-9), or break a limit, is treated as infeasible.

use arcsim_planner::{Limits, Segment};
use rsruckig::prelude::*;

/// A kinematic state along the arc's direction of travel (deg, deg/s, deg/s²).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct FullState {
    pub pos: f64,
    pub vel: f64,
    pub acc: f64,
}

impl FullState {
    pub fn rest(pos: f64) -> Self {
        FullState {
            pos,
            vel: 0.0,
            acc: 0.0,
        }
    }

    /// This state as a segment of jerk `j` starts from: at rest when it holds (no jerk) a
    /// rounding's speed and acceleration away from rest. A stop ends 1e-15 to 1e-11 from it,
    /// which a hold of hours (a long switch) would integrate into micro- to milli-degrees of
    /// drift and a speed below zero.
    pub fn settled(&self, j: f64) -> FullState {
        // A planned crawl (a move stretched over hours creeps at 1e-11 deg/s) has no
        // acceleration at all; a stop's residue has some.
        let residue = self.acc != 0.0 && self.acc.abs() < AT_REST;
        if j == 0.0 && residue && self.vel.abs() < AT_REST {
            FullState::rest(self.pos)
        } else {
            *self
        }
    }

    /// The state `t` seconds into a constant-jerk piece with jerk `j`.
    #[inline]
    pub fn after(&self, t: f64, j: f64) -> FullState {
        FullState {
            pos: self.pos + t * (self.vel + t * (0.5 * self.acc + t * j / 6.0)),
            vel: self.vel + t * (self.acc + 0.5 * t * j),
            acc: self.acc + t * j,
        }
    }
}

/// A speed (deg/s) and an acceleration (deg/s²) below this at the start of a segment without jerk
/// are a stop's rounding: the gantry is at rest. Far below the verification's tolerance of a jump
/// (1e-9 of a limit).
const AT_REST: f64 = 1e-10;

/// A solved move: its start state and constant-jerk segments.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct FullMove {
    pub start: FullState,
    pub segments: Vec<Segment>,
}

impl FullMove {
    /// A move of `duration` at rest at `pos`.
    pub fn dwell(pos: f64, duration: f64) -> Self {
        FullMove {
            start: FullState::rest(pos),
            segments: vec![Segment {
                duration,
                jerk: 0.0,
            }],
        }
    }

    pub fn duration(&self) -> f64 {
        self.segments.iter().map(|s| s.duration).sum()
    }

    pub fn end(&self) -> FullState {
        self.segments
            .iter()
            .fold(self.start, |s, seg| s.after(seg.duration, seg.jerk))
    }

    /// Where the move ends as the timeline delivers it: each segment without jerk that starts a
    /// rounding away from rest starts at rest ([`FullState::settled`]), as the assembly does.
    pub fn delivered_end(&self) -> FullState {
        self.segments.iter().fold(self.start, |s, seg| {
            s.settled(seg.jerk).after(seg.duration, seg.jerk)
        })
    }

    /// Whether the delivery, which takes a state a rounding away from rest before a piece
    /// without jerk as rest ([`FullState::settled`]), finds no jump above 1e-13 inside this move
    /// or at its end (where the next move may hold still): the timeline's joins must be
    /// continuous to 1e-12, and a Ruckig move stretched over a hold can leave 1e-12 deg/s.
    pub fn settles_smoothly(&self) -> bool {
        let jump = |s: FullState| {
            let r = s.settled(0.0);
            (r.vel - s.vel).abs().max((r.acc - s.acc).abs()) <= 1e-13
        };
        let mut s = self.start;
        for seg in &self.segments {
            if seg.jerk == 0.0 && !jump(s) {
                return false;
            }
            s = s.settled(seg.jerk).after(seg.duration, seg.jerk);
        }
        jump(s)
    }

    /// State `t` seconds into the move (clamped).
    pub fn state_at(&self, t: f64) -> FullState {
        let mut s = self.start;
        let mut left = t.max(0.0);
        for seg in &self.segments {
            if left <= seg.duration {
                return s.after(left, seg.jerk);
            }
            s = s.after(seg.duration, seg.jerk);
            left -= seg.duration;
        }
        s
    }

    /// First time the position reaches `x` (the move never goes backwards); `+∞` if it never
    /// does, 0 if it starts there or beyond.
    pub fn time_at_position(&self, x: f64) -> f64 {
        if self.start.pos >= x {
            return 0.0;
        }
        let mut s = self.start;
        let mut t0 = 0.0;
        for seg in &self.segments {
            let e = s.after(seg.duration, seg.jerk);
            if e.pos >= x {
                return t0 + crossing(s, seg.jerk, seg.duration, x);
            }
            s = e;
            t0 += seg.duration;
        }
        f64::INFINITY
    }
}

/// The first time in `[0, d]` at which a piece starting at `s` with jerk `j` reaches position
/// `x` (`s.pos < x <= end position`; position is non-decreasing): Newton's method kept inside a
/// shrinking bracket, returning the bracket's upper end (the gantry is at or past `x` there).
fn crossing(s: FullState, j: f64, d: f64, x: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, d);
    let mut t = 0.5 * d;
    for _ in 0..100 {
        let st = s.after(t, j);
        if st.pos >= x {
            hi = t;
        } else {
            lo = t;
        }
        let next = if st.vel > 0.0 {
            t - (st.pos - x) / st.vel
        } else {
            f64::NAN
        };
        let next = if next > lo && next < hi {
            next
        } else {
            0.5 * (lo + hi)
        };
        if (st.pos - x).abs() <= 4.0 * f64::EPSILON * (1.0 + x.abs())
            || (next - t).abs() <= 1e-14 * (1.0 + d)
            || hi - lo <= 4.0 * f64::EPSILON * d
        {
            t = next;
            break;
        }
        t = next;
    }
    // The gantry must be at or past `x` at the returned time: step up from a root found just
    // below it (by rounding) rather than falling back to the bracket's far end.
    let mut step = 4.0 * f64::EPSILON * (1.0 + t);
    for _ in 0..60 {
        if s.after(t, j).pos >= x || t >= hi {
            break;
        }
        t = (t + step).min(hi);
        step *= 2.0;
    }
    t.min(hi)
}

/// `mv` lasting at least `min_duration`: as it is, or held at rest at its end (Ruckig answers a
/// move from rest to the same place at rest with no move at all, whatever the minimum duration:
/// two arcs that meet at one angle). `None` when it is too short and does not end at rest.
fn held_for(mut mv: FullMove, to: FullState, min_duration: f64) -> Option<FullMove> {
    let short = min_duration - mv.duration();
    if short <= 1e-12 * (1.0 + min_duration) {
        return Some(mv);
    }
    if to.vel != 0.0 || to.acc != 0.0 {
        return None;
    }
    mv.segments.push(Segment {
        duration: short,
        jerk: 0.0,
    });
    Some(mv)
}

/// Relative tolerance of a move's own check.
const TOL: f64 = 1e-9;

/// Solves full-state moves (one Ruckig instance, reused).
pub(crate) struct Mover {
    otg: Ruckig<1, ThrowErrorHandler>,
    input: InputParameter<1>,
    /// The same limits for run-ups and braking (velocity interface: any end position).
    run_up_input: InputParameter<1>,
    traj: Trajectory<1>,
    lim: Limits,
    /// Speed may be negative (a stop-and-turn between arcs); else it stays in [0, V].
    reversible: bool,
}

impl Mover {
    /// A mover along the direction of travel (speed in [0, V]), or `reversible` for a
    /// stop-and-turn (speed in [-V, V]). `lim` must be valid.
    pub fn new(lim: &Limits, reversible: bool) -> Self {
        let mut input = InputParameter::new(None);
        input.max_velocity[0] = lim.max_vel;
        input.min_velocity = Some(daov_stack![if reversible { -lim.max_vel } else { 0.0 }]);
        input.max_acceleration[0] = lim.max_accel;
        input.min_acceleration = Some(daov_stack![-lim.max_decel]);
        input.max_jerk[0] = lim.max_jerk;
        let mut run_up_input = input.clone();
        run_up_input.control_interface = ControlInterface::Velocity;
        Mover {
            otg: Ruckig::new(None, 0.001),
            input,
            run_up_input,
            traj: Trajectory::new(None),
            lim: *lim,
            reversible,
        }
    }

    /// Duration of the fastest move `from → to` lasting at least `min_duration`; `None` when
    /// there is none (e.g. the target cannot be reached without going backwards).
    pub fn duration(&mut self, from: FullState, to: FullState, min_duration: f64) -> Option<f64> {
        if !self.admissible(from) || !self.admissible(to) || !min_duration.is_finite() {
            return None;
        }
        self.input.current_position[0] = from.pos;
        self.input.current_velocity[0] = from.vel;
        self.input.current_acceleration[0] = from.acc;
        self.input.target_position[0] = to.pos;
        self.input.target_velocity[0] = to.vel;
        self.input.target_acceleration[0] = to.acc;
        self.input.minimum_duration = Some(min_duration.max(0.0));
        match self.otg.calculate(&self.input, &mut self.traj) {
            Ok(_) => {
                let d = self.traj.get_duration();
                d.is_finite().then_some(d)
            }
            Err(_) => None,
        }
    }

    /// The fastest move `from → to` lasting at least `min_duration`, as verified segments.
    pub fn solve(&mut self, from: FullState, to: FullState, min_duration: f64) -> Option<FullMove> {
        let mv = match self.solve_once(from, to, min_duration) {
            Some(mv) => mv,
            // Ruckig may fail to synchronise to a minimum duration that equals the fastest
            // move's own duration (to rounding): that move is then the answer.
            None => self.solve_once(from, to, 0.0)?,
        };
        held_for(mv, to, min_duration)
    }

    fn solve_once(
        &mut self,
        from: FullState,
        to: FullState,
        min_duration: f64,
    ) -> Option<FullMove> {
        self.duration(from, to, min_duration)?;
        let mv = self.segments(from)?;
        self.check(&mv, to).then_some(mv)
    }

    fn admissible(&self, s: FullState) -> bool {
        let l = &self.lim;
        let v_lo = if self.reversible { -l.max_vel } else { 0.0 };
        s.pos.is_finite()
            && s.vel >= v_lo - TOL * l.max_vel
            && s.vel <= l.max_vel * (1.0 + TOL)
            && s.acc >= -l.max_decel * (1.0 + TOL)
            && s.acc <= l.max_accel * (1.0 + TOL)
    }

    /// The last solved trajectory as our own segments (brake pre-phase, then seven phases).
    fn segments(&self, from: FullState) -> Option<FullMove> {
        let prof = self.traj.get_profiles().first()?.first()?;
        let mut segments = Vec::with_capacity(9);
        if prof.brake.duration > 0.0 {
            for i in 0..2 {
                if prof.brake.t[i] > 0.0 {
                    segments.push(Segment {
                        duration: prof.brake.t[i],
                        jerk: prof.brake.j[i],
                    });
                }
            }
        }
        for i in 0..7 {
            if prof.t[i] > 0.0 {
                segments.push(Segment {
                    duration: prof.t[i],
                    jerk: prof.j[i],
                });
            }
        }
        Some(FullMove {
            start: from,
            segments,
        })
    }

    /// Re-integrates a move: it must end at `to` and keep every limit (extrema inside each
    /// constant-jerk segment included).
    fn check(&self, mv: &FullMove, to: FullState) -> bool {
        let l = &self.lim;
        let scale_p = 1.0 + mv.start.pos.abs().max(to.pos.abs());
        let Some(s) = self.end_within_limits(mv) else {
            return false;
        };
        (s.pos - to.pos).abs() <= TOL * scale_p
            && (s.vel - to.vel).abs() <= TOL * l.max_vel
            && (s.acc - to.acc).abs() <= TOL * l.max_accel.max(l.max_decel)
    }

    /// The end state of a move that keeps every limit from its start on (extrema inside each
    /// constant-jerk segment included); `None` if it breaks one.
    pub fn end_within_limits(&self, mv: &FullMove) -> Option<FullState> {
        let l = &self.lim;
        let v_lo = if self.reversible { -l.max_vel } else { 0.0 };
        let mut s = mv.start;
        for seg in &mv.segments {
            if !(seg.duration.is_finite() && seg.duration >= 0.0)
                || seg.jerk.abs() > l.max_jerk * (1.0 + TOL)
            {
                return None;
            }
            // Held as the delivery will be ([`FullState::settled`]).
            s = s.settled(seg.jerk);
            let e = s.after(seg.duration, seg.jerk);
            let mut speeds = [s.vel, e.vel, s.vel];
            if seg.jerk != 0.0 {
                let tv = -s.acc / seg.jerk;
                if tv > 0.0 && tv < seg.duration {
                    speeds[2] = s.after(tv, seg.jerk).vel;
                }
            }
            for v in speeds {
                if v < v_lo - TOL * l.max_vel || v > l.max_vel * (1.0 + TOL) {
                    return None;
                }
            }
            for a in [s.acc, e.acc] {
                if a < -l.max_decel * (1.0 + TOL) || a > l.max_accel * (1.0 + TOL) {
                    return None;
                }
            }
            s = e;
        }
        Some(s)
    }

    /// The shortest braking from `from` to rest, wherever it ends, as verified segments.
    pub fn brake(&mut self, from: FullState) -> Option<FullMove> {
        if !self.admissible(from) {
            return None;
        }
        let mv = self.reach_speed(from, 0.0, 0.0)?;
        let end = mv.end();
        self.check(&mv, FullState::rest(end.pos)).then_some(mv)
    }

    /// The shortest run-up from rest to `to`'s speed and acceleration, ending at `to`'s position
    /// (it starts wherever it needs to), as verified segments.
    pub fn run_up(&mut self, to: FullState) -> Option<FullMove> {
        if !self.admissible(to) {
            return None;
        }
        let from_zero = self.reach_speed(FullState::rest(0.0), to.vel, to.acc)?;
        let dist = from_zero.end().pos;
        let mv = FullMove {
            start: FullState::rest(to.pos - dist),
            segments: from_zero.segments,
        };
        self.check(&mv, to).then_some(mv)
    }

    /// The shortest move from `from` to speed `vel` and acceleration `acc`, wherever it ends
    /// (Ruckig's velocity interface), as our segments, not yet checked.
    fn reach_speed(&mut self, from: FullState, vel: f64, acc: f64) -> Option<FullMove> {
        let input = &mut self.run_up_input;
        input.current_position[0] = from.pos;
        input.current_velocity[0] = from.vel;
        input.current_acceleration[0] = from.acc;
        input.target_velocity[0] = vel;
        input.target_acceleration[0] = acc;
        self.otg.calculate(input, &mut self.traj).ok()?;
        self.segments(from)
    }
}

/// Moves laid end to end from `t = 0` (an arc's, from its first beam-on).
pub(crate) struct Track<'a> {
    /// Each move with its start time (s).
    pub moves: Vec<(f64, &'a FullMove)>,
}

impl<'a> Track<'a> {
    pub fn new(moves: &'a [FullMove]) -> Self {
        let mut t = 0.0;
        let moves = moves
            .iter()
            .map(|m| {
                let start = t;
                t += m.duration();
                (start, m)
            })
            .collect();
        Track { moves }
    }

    /// When the last move ends (s).
    pub fn end(&self) -> f64 {
        self.moves.last().map_or(0.0, |(s, m)| s + m.duration())
    }

    /// The state `t` seconds in (in the move that covers `t`).
    pub fn state_at(&self, t: f64) -> FullState {
        let i = self
            .moves
            .partition_point(|(s, _)| *s <= t)
            .saturating_sub(1);
        let (s, m) = self.moves[i];
        m.state_at(t - s)
    }

    /// The segments from `t0` to `t1` (cut at both ends). Starts one move before the one that
    /// covers `t0` (a move's summed segments may end a rounding past the next one's start) and
    /// stops at the first move starting at or after `t1`, so a stretch costs its own moves.
    pub fn slice(&self, t0: f64, t1: f64) -> Vec<Segment> {
        let first = self
            .moves
            .partition_point(|(s, _)| *s <= t0)
            .saturating_sub(2);
        let mut segments = Vec::new();
        for (s, m) in &self.moves[first..] {
            if *s >= t1 {
                break;
            }
            let mut t = *s;
            for seg in &m.segments {
                let (a, b) = (t.max(t0), (t + seg.duration).min(t1));
                if b > a {
                    segments.push(Segment {
                        duration: b - a,
                        jerk: seg.jerk,
                    });
                }
                t += seg.duration;
            }
        }
        segments
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Moves between random admissible states end where asked, keep every limit and never go
    /// backwards (checked by sampling, independently of the segment check).
    #[test]
    fn moves_reach_their_targets_within_limits() {
        let lim = Limits::with_decel(0.5, 0.5, 0.4, 5.0).expect("limits");
        let mut m = Mover::new(&lim, false);
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut solved = 0;
        for _ in 0..2000 {
            let from = FullState {
                pos: 0.0,
                vel: 3.0 * next(),
                acc: -0.4 + 0.9 * next(),
            };
            let to = FullState {
                pos: 0.5 + 6.0 * next(),
                vel: 3.0 * next(),
                acc: -0.4 + 0.9 * next(),
            };
            let min = 4.0 * next();
            let Some(mv) = m.solve(from, to, min) else {
                continue;
            };
            solved += 1;
            let d = mv.duration();
            assert!(d >= min * (1.0 - 1e-12));
            let n = 400;
            let mut prev = from.pos;
            for i in 0..=n {
                let s = mv.state_at(d * i as f64 / n as f64);
                assert!(s.vel >= -1e-9 && s.vel <= lim.max_vel + 1e-9, "{s:?}");
                assert!(s.acc >= -lim.max_decel - 1e-9 && s.acc <= lim.max_accel + 1e-9);
                assert!(s.pos >= prev - 1e-12);
                prev = s.pos;
            }
            let e = mv.end();
            assert!((e.pos - to.pos).abs() < 1e-8 && (e.vel - to.vel).abs() < 1e-8);
            // Crossing times agree with the sampled state.
            let x = 0.5 * (from.pos + to.pos);
            let tx = mv.time_at_position(x);
            assert!(
                (mv.state_at(tx).pos - x).abs() < 1e-9,
                "x {x} tx {tx} pos {} mv {mv:?}",
                mv.state_at(tx).pos
            );
        }
        assert!(solved > 500, "only {solved} solved");
    }
}
