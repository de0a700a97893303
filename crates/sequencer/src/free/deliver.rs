//! A free-motion delivery: every arc solved from its constant-speed schedule, assembled and
//! verified by integration.

use arcsim_plan::ResolvedArc;
use arcsim_planner::Limits;

use super as free;
use crate::problem::ArcProblem;
use crate::progress::{Observer, Progress};
use crate::timeline::Timeline;
use crate::verify::{margins, verify_timeline};
use crate::{Breakdown, Delivery, Infeasibility, Motion, Options, SequenceError};

/// Free motion: each arc solved from its constant-speed schedule (kept where nothing faster is
/// found), assembled and verified by integration.
pub(crate) fn simulate_free(
    arcs: &[ResolvedArc],
    problems: &[ArcProblem],
    speeds: &[Vec<f64>],
    limits: &Limits,
    opts: &Options,
    constant: Delivery,
    observe: Observer,
) -> Result<Delivery, SequenceError> {
    let mut solved = Vec::with_capacity(arcs.len());
    let mut constant_arcs = Vec::with_capacity(arcs.len());
    for (ai, ((arc, p), v)) in arcs.iter().zip(problems).zip(speeds).enumerate() {
        let base = free::from_constant(p, limits, v).ok_or(SequenceError::Infeasible {
            arc: arc.arc_index,
            layer: 0,
            reason: Infeasibility::FreeMotionRebuild,
        })?;
        let (start, end) = free::arc_ends(opts.arc_ends, ai + 1 == arcs.len());
        let report = |step: usize, steps: usize| {
            observe(Progress::FreeMotion {
                arc: ai,
                arcs: arcs.len(),
                layers: p.len(),
                step,
                steps,
            })
        };
        let best = match free::solve_arc(p, limits, start, end, v, &report) {
            Some(f) if f.total < base.total => f,
            _ => base.clone(),
        };
        solved.push(best);
        constant_arcs.push(base);
    }
    // Smoothed where that passes verification; as solved where it does not.
    let smoothed: Vec<_> = solved
        .iter()
        .zip(problems)
        .map(|(fa, p)| free::smooth(p, limits, fa))
        .collect();
    let (a, tl) = match built(arcs, problems, &smoothed, Some(&solved), limits) {
        Ok(b) => b,
        Err(_) => built(arcs, problems, &solved, None, limits)?,
    };
    let (a, tl) = if a.total > constant.total_s {
        // Between arcs the braking and run-up of free ends can cost more than they save.
        built(arcs, problems, &constant_arcs, None, limits)?
    } else {
        (a, tl)
    };
    let energy_switching_s: f64 = a.transitions.iter().map(|tr| tr.elst_s).sum();
    let lost_s: f64 = a.transitions.iter().map(|tr| tr.lost_s).sum::<f64>() + a.lead_s;
    let counts = crate::constant::limiter_counts(&a.transitions);
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

/// Free-motion arcs assembled into rows and a timeline, verified by integration; the
/// transitions labelled from `labelled` where given ([`free::assemble()`]).
fn built(
    arcs: &[ResolvedArc],
    problems: &[ArcProblem],
    solved: &[super::solve::FreeArc],
    labelled: Option<&[super::solve::FreeArc]>,
    limits: &Limits,
) -> Result<(super::assemble::Assembled, Timeline), SequenceError> {
    let mut a = free::assemble(arcs, problems, solved, labelled, limits)?;
    let tl = Timeline {
        pieces: std::mem::take(&mut a.pieces),
    };
    verify_timeline(&tl, problems, &a.layers, &a.transitions, limits, true)?;
    Ok((a, tl))
}
