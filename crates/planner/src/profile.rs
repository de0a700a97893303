//! A planned move as constant-jerk segments: sampled at any time, its extrema, and its own
//! integration check.

use crate::{Limits, PlannerError};

/// Most segments any planner profile has (cruise, brake, dwell, accelerate, cruise).
pub(crate) const MAX_SEGMENTS: usize = 10;

/// One piece of constant jerk.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Segment {
    /// Duration (s), > 0 in a built profile.
    pub duration: f64,
    /// Jerk (units/s³), constant over the segment.
    pub jerk: f64,
}

/// Kinematic state at one instant.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct State {
    /// Position from the move's start (units).
    pub position: f64,
    /// Signed speed (units/s).
    pub velocity: f64,
    /// Signed acceleration (units/s²).
    pub acceleration: f64,
    /// Signed jerk (units/s³) of the segment the instant falls in.
    pub jerk: f64,
}

/// Extreme values over a whole profile (exact: from the segments' polynomials, not sampling).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Extrema {
    /// Lowest position (units).
    pub min_position: f64,
    /// Highest position (units).
    pub max_position: f64,
    /// Lowest signed speed (units/s).
    pub min_velocity: f64,
    /// Highest signed speed (units/s).
    pub max_velocity: f64,
    /// Lowest signed acceleration (units/s²).
    pub min_acceleration: f64,
    /// Highest signed acceleration (units/s²).
    pub max_acceleration: f64,
    /// Largest |jerk| (units/s³).
    pub max_abs_jerk: f64,
}

/// The seven phases of a distance-constrained move (paper section 2.2): speed change
/// `v_start → v_peak` (periods t1, t2, t1 of eq. 3), cruise t3 at `v_peak`, speed change
/// `v_peak → v_end` (t4, t5, t4). Speeds are along the direction of travel (`direction` = ±1
/// maps them to coordinates), so the servo discretisation can re-solve the move.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct SevenPhases {
    /// Direction of travel: +1 or -1.
    pub direction: f64,
    /// Start speed along travel (units/s).
    pub v_start: f64,
    /// Extreme speed along travel: a peak, or a valley (negative when the axis reverses).
    pub v_peak: f64,
    /// End speed along travel (units/s).
    pub v_end: f64,
    /// Each jerk period of the first speed change (s), eq. 3.
    pub t1: f64,
    /// Constant-acceleration period of the first speed change (s), eq. 3.
    pub t2: f64,
    /// Cruise at `v_peak` (s).
    pub t3: f64,
    /// Each jerk period of the second speed change (s), eq. 3.
    pub t4: f64,
    /// Constant-acceleration period of the second speed change (s), eq. 3.
    pub t5: f64,
}

impl SevenPhases {
    /// Total duration 2·t1 + t2 + t3 + 2·t4 + t5 (eq. 4 for each speed change plus the cruise).
    pub fn duration(&self) -> f64 {
        2.0 * self.t1 + self.t2 + self.t3 + 2.0 * self.t4 + self.t5
    }
}

/// A planned move: start state and constant-jerk segments, with the state at every segment
/// boundary precomputed (so `state_at` is a short scan and a cubic). Every profile
/// [`crate::plan`] returns has been re-integrated and checked against its target and the limits.
#[derive(Clone, Debug, PartialEq)]
pub struct Profile {
    len: usize,
    segments: [Segment; MAX_SEGMENTS],
    /// Time, position, velocity, acceleration at the start of each segment; index `len` is the end.
    t: [f64; MAX_SEGMENTS + 1],
    p: [f64; MAX_SEGMENTS + 1],
    v: [f64; MAX_SEGMENTS + 1],
    a: [f64; MAX_SEGMENTS + 1],
    seven_phases: Option<SevenPhases>,
    /// Time the servo grid added against the continuous profile (s), when put on one.
    servo_added_time: Option<f64>,
}

#[inline]
fn advance(p: f64, v: f64, a: f64, j: f64, t: f64) -> (f64, f64, f64) {
    (
        p + t * (v + t * (a / 2.0 + t * j / 6.0)),
        v + t * (a + t * j / 2.0),
        a + t * j,
    )
}

/// Absolute position error (deg) every verification accepts, whatever the move's scale.
const MIN_POSITION_SCALE_DEG: f64 = 1e-12;

impl Profile {
    /// Builds a profile from a start state and segments; zero-length segments are dropped.
    /// Panics only if more than [`MAX_SEGMENTS`] non-empty segments are given (a planner bug:
    /// no planner profile has more).
    pub(crate) fn new(
        position: f64,
        velocity: f64,
        acceleration: f64,
        segments: &[Segment],
    ) -> Self {
        let mut prof = Profile {
            len: 0,
            segments: [Segment::default(); MAX_SEGMENTS],
            t: [0.0; MAX_SEGMENTS + 1],
            p: [0.0; MAX_SEGMENTS + 1],
            v: [0.0; MAX_SEGMENTS + 1],
            a: [0.0; MAX_SEGMENTS + 1],
            seven_phases: None,
            servo_added_time: None,
        };
        prof.p[0] = position;
        prof.v[0] = velocity;
        prof.a[0] = acceleration;
        for s in segments.iter().filter(|s| s.duration > 0.0) {
            let k = prof.len;
            assert!(
                k < MAX_SEGMENTS,
                "planner built more than {MAX_SEGMENTS} segments"
            );
            prof.segments[k] = *s;
            let (p, v, a) = advance(prof.p[k], prof.v[k], prof.a[k], s.jerk, s.duration);
            prof.t[k + 1] = prof.t[k] + s.duration;
            prof.p[k + 1] = p;
            prof.v[k + 1] = v;
            prof.a[k + 1] = a;
            prof.len += 1;
        }
        prof
    }

    pub(crate) fn with_seven_phases(mut self, phases: SevenPhases) -> Self {
        self.seven_phases = Some(phases);
        self
    }

    pub(crate) fn with_servo_added_time(mut self, added: f64) -> Self {
        self.servo_added_time = Some(added);
        self
    }

    /// The seven-phase structure, when the profile has one (minimum-time and peak/valley moves;
    /// not the direct speed change with cruises at both end speeds that some durations need).
    pub fn seven_phases(&self) -> Option<&SevenPhases> {
        self.seven_phases.as_ref()
    }

    /// With a servo period ([`crate::MoveOptions::servo_period_s`]): the time the whole-period
    /// phases added against the continuous profile (s, >= 0); `None` without one.
    pub fn servo_added_time(&self) -> Option<f64> {
        self.servo_added_time
    }

    /// The non-empty constant-jerk segments in order.
    pub fn segments(&self) -> &[Segment] {
        &self.segments[..self.len]
    }

    /// Total duration (s).
    pub fn duration(&self) -> f64 {
        self.t[self.len]
    }

    /// State at the start.
    pub fn start_state(&self) -> State {
        State {
            position: self.p[0],
            velocity: self.v[0],
            acceleration: self.a[0],
            jerk: 0.0,
        }
    }

    /// State at the end (from the precomputed boundaries).
    pub fn end_state(&self) -> State {
        let k = self.len;
        State {
            position: self.p[k],
            velocity: self.v[k],
            acceleration: self.a[k],
            jerk: 0.0,
        }
    }

    /// State at time `t` (s from the start). Before the start and after the end the axis is
    /// taken to move on at its boundary speed with zero acceleration.
    #[inline]
    pub fn state_at(&self, t: f64) -> State {
        if t < 0.0 {
            return State {
                position: self.p[0] + self.v[0] * t,
                velocity: self.v[0],
                acceleration: 0.0,
                jerk: 0.0,
            };
        }
        let n = self.len;
        if t >= self.t[n] {
            let dt = t - self.t[n];
            return State {
                position: self.p[n] + self.v[n] * dt,
                velocity: self.v[n],
                acceleration: 0.0,
                jerk: 0.0,
            };
        }
        let mut k = 0;
        while k + 1 < n && t >= self.t[k + 1] {
            k += 1;
        }
        let j = self.segments[k].jerk;
        let (p, v, a) = advance(self.p[k], self.v[k], self.a[k], j, t - self.t[k]);
        State {
            position: p,
            velocity: v,
            acceleration: a,
            jerk: j,
        }
    }

    /// Samples every `dt` seconds from 0, always including the end instant.
    pub fn samples(&self, dt: f64) -> Vec<(f64, State)> {
        let total = self.duration();
        let mut out = Vec::new();
        if !(dt.is_finite() && dt > 0.0) {
            return out;
        }
        let n = (total / dt).floor() as usize;
        for i in 0..=n {
            let t = i as f64 * dt;
            out.push((t, self.state_at(t)));
        }
        if out.last().is_none_or(|(t, _)| *t < total) {
            out.push((total, self.state_at(total)));
        }
        out
    }

    /// Exact extrema of position, speed and acceleration, and the largest |jerk|.
    pub fn extrema(&self) -> Extrema {
        let mut e = Extrema {
            min_position: self.p[0],
            max_position: self.p[0],
            min_velocity: self.v[0],
            max_velocity: self.v[0],
            min_acceleration: self.a[0],
            max_acceleration: self.a[0],
            max_abs_jerk: 0.0,
        };
        let mut take = |p: f64, v: f64, a: f64| {
            e.min_position = e.min_position.min(p);
            e.max_position = e.max_position.max(p);
            e.min_velocity = e.min_velocity.min(v);
            e.max_velocity = e.max_velocity.max(v);
            e.min_acceleration = e.min_acceleration.min(a);
            e.max_acceleration = e.max_acceleration.max(a);
        };
        let mut max_jerk: f64 = 0.0;
        for k in 0..self.len {
            let s = self.segments[k];
            max_jerk = max_jerk.max(s.jerk.abs());
            let (p0, v0, a0) = (self.p[k], self.v[k], self.a[k]);
            take(self.p[k + 1], self.v[k + 1], self.a[k + 1]);
            // Speed extremum where a(t) = a0 + j t = 0.
            if s.jerk != 0.0 {
                let tv = -a0 / s.jerk;
                if tv > 0.0 && tv < s.duration {
                    let (p, v, a) = advance(p0, v0, a0, s.jerk, tv);
                    take(p, v, a);
                }
            }
            // Position extrema where v(t) = v0 + a0 t + j t²/2 = 0.
            for tp in quadratic_roots(s.jerk / 2.0, a0, v0) {
                if tp > 0.0 && tp < s.duration {
                    let (p, v, a) = advance(p0, v0, a0, s.jerk, tp);
                    take(p, v, a);
                }
            }
        }
        e.max_abs_jerk = max_jerk;
        e
    }

    /// Re-derives the end state by integrating the segments one after another from the start
    /// state, independently of the stored boundary states, and checks both agree, that the end
    /// state is the target and that no limit is exceeded. `tol` is relative to the move's scale.
    pub(crate) fn verify(
        &self,
        target_position: f64,
        target_velocity: f64,
        limits: &Limits,
        forbid_reversal: bool,
        tol: f64,
    ) -> Result<(), PlannerError> {
        let (mut p, mut v, mut a) = (self.p[0], self.v[0], self.a[0]);
        for s in self.segments() {
            if !(s.duration.is_finite() && s.duration > 0.0 && s.jerk.is_finite()) {
                return Err(PlannerError::Verification(format!("bad segment {s:?}")));
            }
            (p, v, a) = advance(p, v, a, s.jerk, s.duration);
        }
        // Scales of the move itself (not of the limits), so tiny moves are held to tiny errors.
        let e = self.extrema();
        let vel_scale = e
            .max_velocity
            .max(-e.min_velocity)
            .max(target_velocity.abs())
            .max(f64::MIN_POSITIVE);
        let pos_scale = (target_position - self.p[0])
            .abs()
            .max(vel_scale * self.duration())
            .max(f64::MIN_POSITIVE);
        let acc_scale = limits.max_accel.max(limits.max_decel);
        let bad = |what: &str, got: f64, want: f64, scale: f64| -> Result<(), PlannerError> {
            if (got - want).abs() <= tol * scale && got.is_finite() {
                Ok(())
            } else {
                Err(PlannerError::Verification(format!(
                    "{what}: got {got}, expected {want}"
                )))
            }
        };
        // Positions also get an absolute floor far below any encoder's resolution: a move of
        // 1e-14 deg cannot be placed on a servo grid to a relative 1e-9.
        let pos_scale = pos_scale.max(MIN_POSITION_SCALE_DEG / tol.max(f64::MIN_POSITIVE));
        bad("end position", p, target_position, pos_scale)?;
        bad("end velocity", v, target_velocity, vel_scale)?;
        bad("end acceleration", a, 0.0, acc_scale)?;
        bad("stored end position", self.p[self.len], p, pos_scale)?;
        let lim_tol = 1e-9;
        // The planner knows the direction of a seven-phase move; otherwise derive it (the two
        // agree except for zero-length moves, where re-timing may leave a sub-ulp residue).
        let dir = match self.seven_phases {
            Some(s) => s.direction,
            None => travel_direction(target_position - self.p[0], self.v[0], target_velocity),
        };
        let (a_fwd, a_back) = if dir > 0.0 {
            (e.max_acceleration, -e.min_acceleration)
        } else {
            (-e.min_acceleration, e.max_acceleration)
        };
        let checks = [
            ("|jerk|", e.max_abs_jerk, limits.max_jerk),
            ("acceleration along travel", a_fwd, limits.max_accel),
            ("deceleration", a_back, limits.max_decel),
            ("speed", e.max_velocity.max(-e.min_velocity), limits.max_vel),
        ];
        for (what, got, limit) in checks {
            if got > limit * (1.0 + lim_tol) {
                return Err(PlannerError::Verification(format!(
                    "{what} {got} exceeds limit {limit}"
                )));
            }
        }
        if forbid_reversal {
            let min_along = if dir > 0.0 {
                e.min_velocity
            } else {
                -e.max_velocity
            };
            if min_along < -lim_tol * vel_scale {
                return Err(PlannerError::Verification(format!(
                    "speed {min_along} against the direction of travel"
                )));
            }
        }
        Ok(())
    }
}

/// Direction of travel of a move (±1): the sign of the distance, or for a zero distance the
/// direction the boundary speeds point to. `max_accel` acts along it.
pub(crate) fn travel_direction(distance: f64, v_start: f64, v_end: f64) -> f64 {
    if distance < 0.0 || (distance == 0.0 && v_start + v_end < 0.0) {
        -1.0
    } else {
        1.0
    }
}

/// Real roots of a x² + b x + c = 0 (a may be 0).
fn quadratic_roots(a: f64, b: f64, c: f64) -> impl Iterator<Item = f64> {
    let mut out = [f64::NAN; 2];
    if a == 0.0 {
        if b != 0.0 {
            out[0] = -c / b;
        }
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc >= 0.0 {
            let q = -0.5 * (b + b.signum() * disc.sqrt());
            if q != 0.0 {
                out[0] = q / a;
                out[1] = c / q;
            } else {
                out[0] = 0.0;
            }
        }
    }
    out.into_iter().filter(|x| x.is_finite())
}
