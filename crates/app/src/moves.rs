//! One planner move with `arcsim profile`'s options: minimum time, or a minimum duration, then
//! optionally every phase on a servo period.

use arcsim_plan::fmt_num;
use arcsim_planner::{plan, Limits, Move, MoveOptions, PlannerError, Profile, Reversal};

/// A move and its options, as `arcsim profile` takes them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MoveRequest {
    /// The move (deg, deg/s).
    pub mv: Move,
    /// Maximum jerk (deg/s³).
    pub jerk_deg_per_s3: f64,
    /// Maximum acceleration (deg/s²).
    pub accel_deg_per_s2: f64,
    /// Maximum deceleration (deg/s²); `None`: equal to the acceleration.
    pub decel_deg_per_s2: Option<f64>,
    /// Maximum speed (deg/s).
    pub speed_deg_per_s: f64,
    /// Last at least this long (s); `None` or 0: the minimum time. The move lasts exactly this
    /// long when it can, else the shortest feasible duration above it (with [`Reversal::Allow`]
    /// backing up if need be); it is infeasible only when it cannot last this long or longer.
    pub min_duration_s: Option<f64>,
    /// Put every phase on this servo period (s).
    pub period_s: Option<f64>,
    /// Whether the speed may go against the direction of travel.
    pub reverse: Reversal,
}

/// A solved move.
#[derive(Clone, Debug)]
pub struct SolvedMove {
    /// The verified profile.
    pub profile: Profile,
    /// The limits it was planned with.
    pub limits: Limits,
    /// Time the servo grid added against the continuous profile (s), with a period.
    pub added_time_s: Option<f64>,
}

/// Why a move has no profile.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MoveError {
    /// The planner's answer: invalid input, or no profile (unreachable, infeasible duration, …).
    #[error("{0}")]
    Planner(#[from] PlannerError),
    /// A finite number outside the range the planner is checked over ([`MoveRequest::RANGES`]).
    #[error("{name} {value} {unit} is outside the range a move is solved in ({lo} to {hi} {unit}){hint}", value = fmt_num(*.value), lo = fmt_num(.range.0), hi = fmt_num(.range.1))]
    OutOfRange {
        /// The input's name, as `arcsim profile` takes it (`jerk`, `distance`, …).
        name: &'static str,
        /// The value given.
        value: f64,
        /// Its unit.
        unit: &'static str,
        /// The range it must lie in (inclusive; for a signed input, of its magnitude).
        range: (f64, f64),
        /// Why, where the range is not the whole story.
        hint: &'static str,
    },
}

/// How an input of a move is checked against its range.
struct Range {
    name: &'static str,
    unit: &'static str,
    lo: f64,
    hi: f64,
    /// Whether the range is of the magnitude (a signed input: a distance, a speed).
    magnitude: bool,
}

impl MoveRequest {
    /// The ranges every move is solved in, as (name, unit, low, high): the limits, the distance
    /// and boundary speeds (magnitudes), the minimum duration and the servo period. Far wider
    /// than any gantry (J, A, V of real gantries lie in 0.01–100); outside them rounding, not
    /// the move, decides the answer (a jerk of 1e-300 °/s³ overflows the profile's durations),
    /// so they are refused rather than answered wrongly. A seeded random test solves a million
    /// moves across the whole box, its ends included, and finds every one verified or infeasible.
    pub const RANGES: [(&'static str, &'static str, f64, f64); 8] = [
        ("jerk", "deg/s³", 1e-3, 1e4),
        ("accel", "deg/s²", 1e-3, 1e4),
        ("decel", "deg/s²", 1e-3, 1e4),
        ("vel", "deg/s", 1e-3, 1e4),
        ("distance", "deg", 0.0, 1e5),
        ("v-start/v-end", "deg/s", 0.0, 1e4),
        ("min-duration", "s", 0.0, 1e13),
        ("period", "s", 1e-5, 10.0),
    ];

    /// Checks every input against [`Self::RANGES`] (non-finite values are left to the planner,
    /// which names them).
    pub fn check_ranges(&self) -> Result<(), MoveError> {
        let r = |i: usize, name: &'static str, magnitude: bool| Range {
            name,
            unit: Self::RANGES[i].1,
            lo: Self::RANGES[i].2,
            hi: Self::RANGES[i].3,
            magnitude,
        };
        let mut checks = vec![
            (r(0, "jerk", false), self.jerk_deg_per_s3),
            (r(1, "accel", false), self.accel_deg_per_s2),
            (r(3, "vel", false), self.speed_deg_per_s),
            (r(4, "distance", true), self.mv.distance),
            (r(5, "v-start", true), self.mv.v_start),
            (r(5, "v-end", true), self.mv.v_end),
        ];
        if let Some(d) = self.decel_deg_per_s2 {
            checks.push((r(2, "decel", false), d));
        }
        if let Some(t) = self.min_duration_s {
            checks.push((r(6, "min-duration", false), t));
        }
        if let Some(p) = self.period_s {
            checks.push((r(7, "period", false), p));
        }
        for (range, value) in checks {
            let size = if range.magnitude { value.abs() } else { value };
            // Zero (no distance, no minimum duration), negative limits and non-finite values
            // are the planner's to name; a range refuses only finite numbers beyond it.
            if !size.is_finite() || size <= 0.0 || (range.lo..=range.hi).contains(&size) {
                continue;
            }
            let hint = match (range.magnitude, range.lo > 0.0) {
                (true, true) => ", in magnitude, or 0",
                (true, false) => ", in magnitude",
                (false, _) => "",
            };
            return Err(MoveError::OutOfRange {
                name: range.name,
                value,
                unit: range.unit,
                range: (range.lo, range.hi),
                hint,
            });
        }
        Ok(())
    }

    /// The profile: [`plan`] with the request's options.
    pub fn solve(&self) -> Result<SolvedMove, MoveError> {
        self.check_ranges()?;
        let limits = Limits::with_decel(
            self.jerk_deg_per_s3,
            self.accel_deg_per_s2,
            self.decel_deg_per_s2.unwrap_or(self.accel_deg_per_s2),
            self.speed_deg_per_s,
        )?;
        let min_duration_s = self.min_duration_s.unwrap_or(0.0);
        let options = MoveOptions {
            min_duration_s,
            servo_period_s: self.period_s,
            reversal: self.reverse,
        };
        let profile = plan(&self.mv, &limits, &options)?;
        Ok(SolvedMove {
            added_time_s: profile.servo_added_time(),
            profile,
            limits,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A seeded generator (xorshift64*), so that a failure names its case.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
        }

        /// Log-uniform in `[lo, hi]`, or one of its ends one time in five.
        fn log_in(&mut self, lo: f64, hi: f64) -> f64 {
            match (self.next() * 10.0) as u32 {
                0 => lo,
                1 => hi,
                _ => lo * (hi / lo).powf(self.next()),
            }
        }
    }

    fn range(name: &str) -> (f64, f64) {
        let r = MoveRequest::RANGES
            .iter()
            .find(|r| r.0 == name)
            .expect("range");
        (r.2, r.3)
    }

    /// Across the whole box of [`MoveRequest::RANGES`] (ends included), every move is verified
    /// or refused as infeasible with what is reachable: never the planner's self-check (a bug),
    /// never a non-finite duration.
    #[test]
    fn every_move_inside_the_ranges_is_solved_or_infeasible() {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let (llo, lhi) = range("jerk");
        // The distance has no lower end: log-uniform down to 1e-12 deg (and 0 below).
        let (_, dhi) = range("distance");
        let (plo, phi) = range("period");
        let (_, thi) = range("min-duration");
        let mut solved = 0;
        let mut bugs = 0;
        for case in 0..1_000_000 {
            let vel = rng.log_in(llo, lhi);
            let distance = match case % 7 {
                0 => 0.0,
                _ => rng.log_in(1e-12, dhi) * if rng.next() < 0.3 { -1.0 } else { 1.0 },
            };
            let speed = |rng: &mut Rng| match (rng.next() * 4.0) as u32 {
                0 => 0.0,
                1 => vel,
                _ => vel * rng.next() * if rng.next() < 0.1 { -1.0 } else { 1.0 },
            } * distance.signum();
            let request = MoveRequest {
                mv: Move {
                    distance,
                    v_start: speed(&mut rng),
                    v_end: speed(&mut rng),
                },
                jerk_deg_per_s3: rng.log_in(llo, lhi),
                accel_deg_per_s2: rng.log_in(llo, lhi),
                decel_deg_per_s2: (rng.next() < 0.3).then(|| rng.log_in(llo, lhi)),
                speed_deg_per_s: vel,
                min_duration_s: (rng.next() < 0.2).then(|| rng.log_in(1e-6, thi)),
                period_s: (rng.next() < 0.1).then(|| rng.log_in(plo, phi)),
                reverse: if rng.next() < 0.5 {
                    Reversal::Allow
                } else {
                    Reversal::Forbid
                },
            };
            match request.solve() {
                Ok(s) => {
                    assert!(s.profile.duration().is_finite(), "case {case}: {request:?}");
                    solved += 1;
                }
                Err(MoveError::Planner(PlannerError::Verification(msg))) => {
                    eprintln!("case {case}: {request:?}: {msg}");
                    bugs += 1;
                }
                Err(MoveError::OutOfRange { name, value, .. }) => {
                    panic!("case {case}: {name} {value} refused inside the ranges")
                }
                Err(MoveError::Planner(_)) => {}
            }
        }
        assert_eq!(
            bugs, 0,
            "moves the planner's own check refused (printed above)"
        );
        // Most moves have a profile: the test does not pass by refusing everything.
        assert!(solved > 500_000, "{solved} of 1000000 solved");
    }

    /// Outside the ranges a move is refused, naming the input and the range; inside it is not.
    #[test]
    fn a_move_outside_the_ranges_is_refused_by_name() {
        let base = MoveRequest {
            mv: Move {
                distance: 10.0,
                v_start: 0.0,
                v_end: 0.0,
            },
            jerk_deg_per_s3: 1.0,
            accel_deg_per_s2: 1.0,
            decel_deg_per_s2: None,
            speed_deg_per_s: 5.0,
            min_duration_s: None,
            period_s: None,
            reverse: Reversal::Forbid,
        };
        assert!(base.solve().is_ok());
        let cases: [(&str, MoveRequest); 5] = [
            (
                "jerk",
                MoveRequest {
                    jerk_deg_per_s3: 1e-300,
                    ..base
                },
            ),
            (
                "vel",
                MoveRequest {
                    speed_deg_per_s: 1e300,
                    ..base
                },
            ),
            (
                "jerk",
                MoveRequest {
                    jerk_deg_per_s3: 1e300,
                    ..base
                },
            ),
            (
                "distance",
                MoveRequest {
                    mv: Move {
                        distance: -1e300,
                        ..base.mv
                    },
                    ..base
                },
            ),
            (
                "period",
                MoveRequest {
                    period_s: Some(1e-9),
                    ..base
                },
            ),
        ];
        for (name, request) in cases {
            let err = request.solve().expect_err(name);
            let text = err.to_string();
            assert!(
                matches!(err, MoveError::OutOfRange { name: n, .. } if n == name),
                "{name}: {text}"
            );
            assert!(text.len() < 160, "{text}");
        }
    }
}
