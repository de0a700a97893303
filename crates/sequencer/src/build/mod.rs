//! Entry points: resolve, schedule, then build, measure and verify one delivery.

mod assemble;
mod prescribed;
mod schedule;

use arcsim_plan::{ArcPlan, Machine, ResolvedArc};
use arcsim_planner::Limits;

use crate::free;
use crate::problem::ArcProblem;
use crate::timeline::Timeline;
use crate::verify::{margins, verify_timeline};
use crate::{
    ArcEnds, Breakdown, Delivery, Infeasibility, Motion, Options, Schedule, SequenceError,
    SpeedBound,
};

use assemble::{assemble, limiter_counts};
use schedule::{choose_speeds, ChosenSpeeds};

pub(crate) use schedule::arc_time_on_grid;

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
    let arcs = arcsim_plan::resolve(plan, machine)?;
    let limits = machine_limits(machine)?;
    let opts = Options {
        servo_period_s: opts.servo_period_s.or(machine.servo_period_s),
        ..opts.clone()
    };
    simulate_resolved(&arcs, &limits, &opts)
}

fn check_period(opts: &Options) -> Result<(), SequenceError> {
    match opts.servo_period_s {
        Some(ts) if !(ts.is_finite() && ts > 0.0) => Err(SequenceError::Input(format!(
            "servo period {ts} s: expected a finite number > 0"
        ))),
        _ => Ok(()),
    }
}

/// Simulates already-resolved arcs (sweeps resolve once and vary the limits).
pub fn simulate_resolved(
    arcs: &[ResolvedArc],
    limits: &Limits,
    opts: &Options,
) -> Result<Delivery, SequenceError> {
    limits.validate().map_err(SequenceError::Limits)?;
    check_period(opts)?;
    check_motion(opts)?;
    let problems: Vec<ArcProblem> = arcs.iter().map(|a| ArcProblem::new(a, limits)).collect();
    let chosen = choose_speeds(arcs, &problems, limits, opts);
    // Free motion needs only the constant-speed total (its baseline), not its timeline.
    let constant_opts = Options {
        build_timeline: opts.build_timeline && opts.motion == Motion::Constant,
        ..opts.clone()
    };
    let constant = assemble(arcs, &problems, &chosen, limits, &constant_opts)?;
    match opts.motion {
        Motion::Constant => Ok(constant),
        Motion::Free => simulate_free(arcs, &problems, &chosen.speeds, limits, opts, constant),
    }
}

/// Checks the motion options against the rest of the options.
fn check_motion(opts: &Options) -> Result<(), SequenceError> {
    match (opts.motion, opts.arc_ends) {
        (Motion::Constant, ArcEnds::Free) => Err(SequenceError::Input(
            "free arc ends need free motion (--motion free): a constant-speed arc starts and ends at rest".into(),
        )),
        (Motion::Free, _) if opts.servo_period_s.is_some() => Err(SequenceError::Input(
            "free motion is continuous-time only (its solver switches jerk at any instant; a version whose jerk holds over whole servo periods is not built): drop the servo period (--period or the machine's servo_period_s), or use --motion constant, which supports one".into(),
        )),
        (Motion::Free, _) if matches!(opts.schedule, Schedule::StepAndShoot | Schedule::Prescribed) => {
            Err(SequenceError::Input(format!(
                "free motion chooses its own speeds: use it with the optimal or scan schedule, not {}",
                opts.schedule.name()
            )))
        }
        _ => Ok(()),
    }
}

/// Free motion: each arc solved from its constant-speed schedule (kept where nothing faster is
/// found), assembled and verified by integration.
fn simulate_free(
    arcs: &[ResolvedArc],
    problems: &[ArcProblem],
    speeds: &[Vec<f64>],
    limits: &Limits,
    opts: &Options,
    constant: Delivery,
) -> Result<Delivery, SequenceError> {
    let mut solved = Vec::with_capacity(arcs.len());
    let mut constant_arcs = Vec::with_capacity(arcs.len());
    for (ai, ((arc, p), v)) in arcs.iter().zip(problems).zip(speeds).enumerate() {
        let base = free::from_constant(p, limits, v).ok_or(SequenceError::Infeasible {
            arc: arc.arc_index,
            layer: 0,
            reason: Infeasibility::FreeMotionRebuild,
        })?;
        let (start, end) = match opts.arc_ends {
            ArcEnds::Rest => (free::Start::Rest, free::End::Rest),
            ArcEnds::Free if ai + 1 == arcs.len() => (free::Start::RunUp, free::End::Free),
            ArcEnds::Free => (free::Start::RunUp, free::End::Brake),
        };
        let best = match free::solve_arc(p, limits, start, end, v) {
            Some(f) if f.total < base.total => f,
            _ => base.clone(),
        };
        solved.push(best);
        constant_arcs.push(base);
    }
    let mut a = free::assemble(arcs, problems, &solved, limits)?;
    if a.total > constant.total_s {
        // Between arcs the braking and run-up of free ends can cost more than they save.
        a = free::assemble(arcs, problems, &constant_arcs, limits)?;
    }
    let energy_switching_s: f64 = a.transitions.iter().map(|tr| tr.elst_s).sum();
    let lost_s: f64 = a.transitions.iter().map(|tr| tr.lost_s).sum::<f64>() + a.lead_s;
    let counts = limiter_counts(&a.transitions);
    let tl = Timeline {
        pieces: std::mem::take(&mut a.pieces),
    };
    verify_timeline(&tl, problems, &a.layers, &a.transitions, limits, true)?;
    let margins = opts
        .build_timeline
        .then(|| margins(&tl, &a.layers, &a.transitions, limits));
    Ok(Delivery {
        schedule: opts.schedule,
        motion: Motion::Free,
        arc_ends: opts.arc_ends,
        constant_speed_total_s: Some(constant.total_s),
        total_s: a.total,
        breakdown: Breakdown::of(arcs, energy_switching_s, lost_s),
        limits: (*limits).into(),
        servo_period_s: None,
        lost_time: crate::LostTime::of(&a.layers, &a.transitions),
        layers: a.layers,
        transitions: a.transitions,
        limiter_counts: counts,
        margins,
        violations: constant.violations,
        timeline: opts.build_timeline.then_some(tl),
    })
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
        return Err(SequenceError::Input(format!(
            "{} speeds given for {total} layers",
            speeds_deg_per_s.len()
        )));
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
    };
    let opts = Options {
        schedule: Schedule::Prescribed,
        ..opts.clone()
    };
    assemble(arcs, &problems, &chosen, limits, &opts)
}
