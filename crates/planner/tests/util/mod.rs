//! Shared test helpers: a seeded generator of moves and limits, the rsruckig oracle, and a
//! brute-force integrator independent of the planner's own boundary states.

use arcsim_planner::{plan, Limits, Move, MoveOptions, PlannerError, Profile, Reversal};
use rsruckig::prelude::*;

/// The minimum-time profile: [`plan`] with no minimum duration and no servo period.
pub fn min_time(mv: &Move, lim: &Limits, reversal: Reversal) -> Result<Profile, PlannerError> {
    let options = MoveOptions {
        reversal,
        ..MoveOptions::default()
    };
    plan(mv, lim, &options)
}

/// xorshift64*: tiny, seeded, reproducible.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    pub fn log_uniform(&mut self, lo_exp: f64, hi_exp: f64) -> f64 {
        10f64.powf(self.uniform(lo_exp, hi_exp))
    }
    pub fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }
}

/// Limits spanning gantry scale (J = 0.1 deg/s³) to CNC scale (J = 1e4), sometimes asymmetric.
pub fn random_limits(rng: &mut Rng) -> Limits {
    let j = rng.log_uniform(-1.0, 4.0);
    let a = rng.log_uniform(-1.0, 1.7);
    let v = rng.log_uniform(-1.0, 1.3);
    let d = if rng.chance(0.3) {
        a * rng.log_uniform(-0.5, 0.5)
    } else {
        a
    };
    Limits::with_decel(j, a, d, v).expect("valid limits")
}

/// A move at the scale of the limits: edge cases (zero distance, equal speeds, speeds at V, tiny
/// and huge gaps) mixed with uniform ones. `forward_only` keeps speeds >= 0 along d >= 0.
pub fn random_move(rng: &mut Rng, lim: &Limits, forward_only: bool) -> Move {
    let v = lim.max_vel;
    let speed = |rng: &mut Rng| {
        let r = rng.unit();
        if r < 0.12 {
            0.0
        } else if r < 0.22 {
            if forward_only || rng.chance(0.5) {
                v
            } else {
                -v
            }
        } else if forward_only {
            rng.uniform(0.0, v)
        } else {
            rng.uniform(-v, v)
        }
    };
    let vs = speed(rng);
    let ve = if rng.chance(0.1) { vs } else { speed(rng) };
    let scale = v * v / lim.max_accel + v * lim.max_accel / lim.max_jerk;
    let r = rng.unit();
    let mut d = if r < 0.05 {
        0.0
    } else if r < 0.1 {
        scale * 1e-9
    } else {
        scale * rng.log_uniform(-4.0, 2.0)
    };
    if !forward_only && rng.chance(0.5) {
        d = -d;
    }
    Move {
        distance: d,
        v_start: vs,
        v_end: ve,
    }
}

/// Ruckig's minimum duration for the same move with zero boundary accelerations.
/// Limits are mapped so that `max_accel` acts along the direction of travel.
pub fn ruckig_duration(
    mv: &Move,
    lim: &Limits,
    otg: &mut Ruckig<1, ThrowErrorHandler>,
) -> Option<f64> {
    let forward = mv.direction() > 0.0;
    let (a_max, a_min) = if forward {
        (lim.max_accel, -lim.max_decel)
    } else {
        (lim.max_decel, -lim.max_accel)
    };
    let mut input = InputParameter::new(None);
    input.current_position[0] = 0.0;
    input.current_velocity[0] = mv.v_start;
    input.current_acceleration[0] = 0.0;
    input.target_position[0] = mv.distance;
    input.target_velocity[0] = mv.v_end;
    input.target_acceleration[0] = 0.0;
    input.max_velocity[0] = lim.max_vel;
    input.max_acceleration[0] = a_max;
    input.min_acceleration = Some(daov_stack![a_min]);
    input.max_jerk[0] = lim.max_jerk;
    let mut traj = Trajectory::new(None);
    otg.calculate(&input, &mut traj).ok()?;
    Some(traj.get_duration())
}

pub fn new_ruckig() -> Ruckig<1, ThrowErrorHandler> {
    Ruckig::<1, ThrowErrorHandler>::new(None, 0.001)
}

/// End position, speed and acceleration by integrating the *sampled* profile: Simpson's rule
/// on `steps` sub-intervals of every segment, applied to `state_at`'s jerk, acceleration and
/// speed. Simpson is exact for the cubic pieces, so this is independent of the profile's stored
/// boundary states yet needs no loose tolerance.
pub fn brute_force_end(p: &Profile, steps: usize) -> (f64, f64, f64) {
    let s0 = p.start_state();
    let (mut pos, mut vel, mut acc) = (s0.position, s0.velocity, s0.acceleration);
    let mut t0 = 0.0;
    let steps = steps.max(1);
    for seg in p.segments() {
        let h = seg.duration / steps as f64;
        for i in 0..steps {
            let a = t0 + i as f64 * h;
            // Keep the end samples inside the segment: a sample an ulp into the next one would see
            // its jerk, times a long step.
            let (ta, tb) = (a.next_up().next_up(), (a + h).next_down().next_down());
            let (l, m, r) = (p.state_at(ta), p.state_at(a + 0.5 * h), p.state_at(tb));
            pos += h / 6.0 * (l.velocity + 4.0 * m.velocity + r.velocity);
            vel += h / 6.0 * (l.acceleration + 4.0 * m.acceleration + r.acceleration);
            // Jerk jumps at segment ends (p, v, a are continuous): take it at the midpoint.
            acc += h * m.jerk;
        }
        t0 += seg.duration;
    }
    (pos, vel, acc)
}

/// Relative scale of a move for end-state tolerances.
pub fn move_scale(mv: &Move, lim: &Limits, duration: f64) -> f64 {
    mv.distance.abs().max(lim.max_vel * duration).max(1e-300)
}

/// The acceleration extremes of a profile against the limits in the planner's convention: A
/// along the direction of travel, D against it. `Err` says which is exceeded.
pub fn check_accel(
    e: &arcsim_planner::Extrema,
    mv: &Move,
    lim: &Limits,
    rel: f64,
) -> Result<(), String> {
    let forward = mv.direction() > 0.0;
    let (along, against) = if forward {
        (e.max_acceleration, -e.min_acceleration)
    } else {
        (-e.min_acceleration, e.max_acceleration)
    };
    if along <= lim.max_accel * (1.0 + rel) && against <= lim.max_decel * (1.0 + rel) {
        Ok(())
    } else {
        Err(format!(
            "acceleration {along} along travel (A {}), {against} against (D {})",
            lim.max_accel, lim.max_decel
        ))
    }
}
