//! Entry points: resolve, choose the layer speeds, then build, measure and verify one delivery.

use arcsim_plan::{ArcPlan, Machine, ResolvedArc};
use arcsim_planner::Limits;

use crate::constant::assemble;
use crate::free::simulate_free;
use crate::one_speed::simulate_one_speed;
use crate::problem::ArcProblem;
use crate::progress::Observer;
use crate::schedule::{choose_speeds, ChosenSpeeds};
use crate::{
    ArcEnds, Delivery, Infeasibility, InputError, Motion, Options, Schedule, SequenceError,
    SpeedBound,
};

/// The planner limits of a machine model.
pub fn machine_limits(machine: &Machine) -> Result<Limits, SequenceError> {
    let g = &machine.gantry;
    Limits::with_decel(
        g.max_jerk_deg_per_s3,
        g.max_accel_deg_per_s2,
        g.max_decel_deg_per_s2.unwrap_or(g.max_accel_deg_per_s2),
        g.max_speed_deg_per_s,
    )
    .map_err(SequenceError::Limits)
}

/// Simulates the delivery of `plan` on `machine` (on the machine's servo period, if it has one
/// and `opts` sets none).
pub fn simulate(
    plan: &ArcPlan,
    machine: &Machine,
    opts: &Options,
) -> Result<Delivery, SequenceError> {
    simulate_observed(plan, machine, opts, &crate::progress::ignore)
}

/// [`simulate`], reporting its progress to `observe` as it goes.
pub fn simulate_observed(
    plan: &ArcPlan,
    machine: &Machine,
    opts: &Options,
    observe: Observer,
) -> Result<Delivery, SequenceError> {
    let arcs = arcsim_plan::resolve(plan, machine)?;
    let limits = machine_limits(machine)?;
    let opts = Options {
        servo_period_s: opts.servo_period_s.or(machine.servo_period_s),
        ..opts.clone()
    };
    simulate_resolved_observed(&arcs, &limits, &opts, observe)
}

fn check_period(opts: &Options) -> Result<(), SequenceError> {
    match opts.servo_period_s {
        Some(ts) if !(ts.is_finite() && ts > 0.0) => {
            Err(InputError::ServoPeriod { period_s: ts }.into())
        }
        _ => Ok(()),
    }
}

/// Simulates already-resolved arcs (sweeps resolve once and vary the limits).
pub fn simulate_resolved(
    arcs: &[ResolvedArc],
    limits: &Limits,
    opts: &Options,
) -> Result<Delivery, SequenceError> {
    simulate_resolved_observed(arcs, limits, opts, &crate::progress::ignore)
}

/// [`simulate_resolved`], reporting its progress to `observe` as it goes.
pub fn simulate_resolved_observed(
    arcs: &[ResolvedArc],
    limits: &Limits,
    opts: &Options,
    observe: Observer,
) -> Result<Delivery, SequenceError> {
    limits.validate().map_err(SequenceError::Limits)?;
    check_period(opts)?;
    check_motion(opts)?;
    let problems: Vec<ArcProblem> = arcs.iter().map(|a| ArcProblem::new(a, limits)).collect();
    let chosen = choose_speeds(arcs, &problems, limits, opts);
    // Other models need only the constant-speed total (their baseline), not its timeline.
    let constant_opts = Options {
        build_timeline: opts.build_timeline && opts.motion == Motion::Constant,
        ..opts.clone()
    };
    let constant = assemble(arcs, &problems, &chosen, limits, &constant_opts)?;
    // The one place a motion model is dispatched: each has its own solver file.
    match opts.motion {
        Motion::Constant => Ok(constant),
        Motion::Free => simulate_free(
            arcs,
            &problems,
            &chosen.speeds,
            limits,
            opts,
            constant,
            observe,
        ),
        Motion::OneSpeed => simulate_one_speed(arcs, &problems, limits, opts, constant),
    }
}

/// Checks the motion options against the rest of the options.
fn check_motion(opts: &Options) -> Result<(), SequenceError> {
    let motion = opts.motion;
    if opts.arc_ends == ArcEnds::Free && !motion.speed_changes_during_beam() {
        return Err(InputError::FreeEndsNeedFreeMotion { motion }.into());
    }
    if let (Some(why), Some(_)) = (motion.continuous_time_only(), opts.servo_period_s) {
        return Err(InputError::ContinuousTimeOnly { motion, why }.into());
    }
    if !motion.accepts_schedule(opts.schedule) {
        return Err(InputError::MotionSchedule {
            motion,
            schedule: opts.schedule,
        }
        .into());
    }
    Ok(())
}

/// Builds the timeline for given layer speeds (one per layer, delivery order; magnitudes),
/// e.g. ATOM's chosen speeds. Infeasible speeds are an error naming the layer.
pub fn simulate_with_speeds(
    arcs: &[ResolvedArc],
    limits: &Limits,
    speeds_deg_per_s: &[f64],
    opts: &Options,
) -> Result<Delivery, SequenceError> {
    limits.validate().map_err(SequenceError::Limits)?;
    check_period(opts)?;
    let total: usize = arcs.iter().map(|a| a.layers.len()).sum();
    if speeds_deg_per_s.len() != total {
        return Err(InputError::SpeedCount {
            given: speeds_deg_per_s.len(),
            layers: total,
        }
        .into());
    }
    let problems: Vec<ArcProblem> = arcs.iter().map(|a| ArcProblem::new(a, limits)).collect();
    let mut speeds = Vec::new();
    let mut bounds = Vec::new();
    let mut at = 0;
    for (a, p) in arcs.iter().zip(&problems) {
        let v = speeds_deg_per_s[at..at + p.len()].to_vec();
        for (k, &s) in v.iter().enumerate() {
            let cap = if k == 0 || k + 1 == p.len() {
                0.0
            } else {
                p.speed_cap[k]
            };
            if !(s.is_finite() && s >= 0.0 && s <= cap * (1.0 + 1e-9) + 1e-12) {
                return Err(SequenceError::Infeasible {
                    arc: a.arc_index,
                    layer: k,
                    reason: Infeasibility::SpeedOutOfRange {
                        speed_deg_per_s: s,
                        cap_deg_per_s: cap,
                    },
                });
            }
        }
        speeds.push(
            v.iter()
                .enumerate()
                .map(|(k, &s)| s.min(p.speed_cap[k]))
                .collect::<Vec<_>>(),
        );
        bounds.push(vec![SpeedBound::Prescribed; p.len()]);
        at += p.len();
    }
    let chosen = ChosenSpeeds {
        speeds,
        bounds,
        violations: Vec::new(),
        min_move_s: Vec::new(),
    };
    let opts = Options {
        schedule: Schedule::Prescribed,
        ..opts.clone()
    };
    assemble(arcs, &problems, &chosen, limits, &opts)
}
