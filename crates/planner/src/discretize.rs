//! Phase durations on a servo period (after the seed repository's idea, without its defect).
//!
//! A servo runs at a fixed period Ts, so each phase must last a whole number of periods. Every
//! phase of the seven-phase profile is rounded *up*; with the durations fixed, the distance is
//! linear in the extreme speed `c` (eq. 4 summed over the phases), so `c` and then each jerk are
//! re-solved exactly. Longer phases need less jerk and acceleration, so the limits hold; rounding
//! *down* (as the seed repository does) would need more and exceed them.

use crate::profile::{Profile, Segment, TwoStep};
use crate::{Limits, PlannerError};

/// A profile on the servo grid and the time it adds to the continuous one.
#[derive(Clone, Debug, PartialEq)]
pub struct Discretized {
    pub profile: Profile,
    /// Added duration (s), >= 0.
    pub added_time: f64,
}

/// Rounds up to a whole number of periods (an exact multiple stays as it is).
fn round_up(t: f64, period: f64) -> f64 {
    if t <= 0.0 {
        return 0.0;
    }
    (t / period - 1e-9).ceil().max(1.0) * period
}

/// Re-times `profile` so every phase is a whole multiple of `period`, keeping its start and end
/// state and every limit in `lim`. Works on seven-phase (peak/valley, cruise) profiles.
pub fn discretize(
    profile: &Profile,
    period: f64,
    lim: &Limits,
) -> Result<Discretized, PlannerError> {
    if !(period.is_finite() && period > 0.0) {
        return Err(PlannerError::InvalidInput {
            name: "period",
            value: period,
            expected: "a finite number > 0",
        });
    }
    lim.validate()?;
    let Some(shape) = profile.two_step().copied() else {
        return Err(PlannerError::PeriodTooCoarse {
            period,
            detail:
                "only single peak/valley profiles can be re-timed; this one has several cruises"
                    .into(),
        });
    };
    let TwoStep {
        direction: dir,
        v_start: vs,
        v_end: ve,
        ..
    } = shape;
    let start = profile.start_state();
    let distance = dir * (profile.end_state().position - start.position);
    let (mut t1, mut t2, t3, mut t4, mut t5) = (
        round_up(shape.t1, period),
        round_up(shape.t2, period),
        round_up(shape.t3, period),
        round_up(shape.t4, period),
        round_up(shape.t5, period),
    );
    let scale = lim.max_vel.max(vs.abs()).max(ve.abs());
    let mut c = shape.v_peak;
    for _ in 0..3 {
        let tau1 = 2.0 * t1 + t2;
        let tau2 = 2.0 * t4 + t5;
        let weight = 0.5 * tau1 + t3 + 0.5 * tau2;
        if weight <= 0.0 {
            if distance.abs() > 1e-12 * scale || (vs - ve).abs() > 1e-12 * scale {
                // A zero-length profile that must still change speed or move: give it a period.
                t1 = period;
                continue;
            }
            return Ok(Discretized {
                profile: profile.clone(),
                added_time: 0.0,
            });
        }
        c = (distance - 0.5 * vs * tau1 - 0.5 * ve * tau2) / weight;
        let mut again = false;
        if t1 == 0.0 && (c - vs).abs() > 1e-12 * scale {
            t1 = period;
            again = true;
        }
        if t4 == 0.0 && (c - ve).abs() > 1e-12 * scale {
            t4 = period;
            again = true;
        }
        if !again {
            break;
        }
    }
    if t1 == 0.0 {
        t2 = 0.0;
    }
    if t4 == 0.0 {
        t5 = 0.0;
    }
    // Jerks that give exactly the speed changes c - vs and ve - c (Δv = j·t1·(t1 + t2)).
    let j1 = if t1 > 0.0 {
        (c - vs) / (t1 * (t1 + t2))
    } else {
        0.0
    };
    let j2 = if t4 > 0.0 {
        (ve - c) / (t4 * (t4 + t5))
    } else {
        0.0
    };
    let tol = 1e-12;
    let acc_bound = |j: f64| {
        if j >= 0.0 {
            lim.max_accel
        } else {
            lim.max_decel
        }
    };
    let checks = [
        ("|jerk| of the first speed change", j1.abs(), lim.max_jerk),
        ("|jerk| of the second speed change", j2.abs(), lim.max_jerk),
        (
            "acceleration of the first speed change",
            (j1 * t1).abs(),
            acc_bound(j1),
        ),
        (
            "acceleration of the second speed change",
            (j2 * t4).abs(),
            acc_bound(j2),
        ),
        ("extreme speed", c.abs(), lim.max_vel),
    ];
    for (what, got, limit) in checks {
        if got > limit * (1.0 + tol) {
            return Err(PlannerError::PeriodTooCoarse {
                period,
                detail: format!("{what} would be {got:.6e}, above the limit {limit:.6e}"),
            });
        }
    }
    if shape.v_peak >= 0.0 && c < -tol * scale && vs >= 0.0 && ve >= 0.0 {
        return Err(PlannerError::PeriodTooCoarse {
            period,
            detail: format!("the re-timed profile would reverse (extreme speed {c:.6e})"),
        });
    }
    let segs = [
        Segment {
            duration: t1,
            jerk: dir * j1,
        },
        Segment {
            duration: t2,
            jerk: 0.0,
        },
        Segment {
            duration: t1,
            jerk: -dir * j1,
        },
        Segment {
            duration: t3,
            jerk: 0.0,
        },
        Segment {
            duration: t4,
            jerk: dir * j2,
        },
        Segment {
            duration: t5,
            jerk: 0.0,
        },
        Segment {
            duration: t4,
            jerk: -dir * j2,
        },
    ];
    let new = Profile::new(start.position, start.velocity, 0.0, &segs).with_two_step(TwoStep {
        direction: dir,
        v_start: vs,
        v_peak: c,
        v_end: ve,
        t1,
        t2,
        t3,
        t4,
        t5,
    });
    let forbid = vs >= 0.0 && ve >= 0.0 && shape.v_peak >= 0.0;
    new.verify(
        profile.end_state().position,
        profile.end_state().velocity,
        lim,
        forbid,
        1e-9,
    )?;
    let added_time = new.duration() - profile.duration();
    Ok(Discretized {
        profile: new,
        added_time,
    })
}
