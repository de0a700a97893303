//! Entry points: resolve, schedule, then build, measure and verify one delivery.

use arcsim_plan::{ArcPlan, Machine, ResolvedArc};
use arcsim_planner::{
    exact_duration, min_time_shape, shortest_duration_at_least, Limits, Move, Profile, Reversal,
    TwoStep,
};

use crate::free;
use crate::optimal::optimal;
use crate::scan::{scan, scan_converged, ArcProblem};
use crate::servo::grid_duration;
use crate::timeline::{Piece, PieceKind, Timeline};
use crate::verify::{margins, verify_timeline};
use crate::{
    ArcEnds, Breakdown, Delivery, LayerRow, Limiter, LimiterCounts, Motion, Options, Schedule,
    SequenceError, SpeedBound, TransitionRow, Violation,
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
    let arcs = arcsim_plan::resolve(plan, machine)?;
    let limits = machine_limits(machine)?;
    let opts = Options {
        servo_period_s: opts.servo_period_s.or(machine.servo_period_s),
        ..opts.clone()
    };
    simulate_resolved(&arcs, &limits, &opts)
}

/// Time of one arc at layer speeds `v` with every transition on the servo period (infinite when
/// a transition has no such duration).
fn arc_time_on_grid(p: &ArcProblem, v: &[f64], lim: &Limits, period: f64) -> f64 {
    let moving: Option<f64> = (0..p.len().saturating_sub(1))
        .map(|k| {
            let d = p.cost(k, v[k], v[k + 1], lim)?;
            grid_duration(p.transition_move(k, v[k], v[k + 1]), lim, d, period)
        })
        .sum();
    moving.map_or(f64::INFINITY, |m| m + p.t.iter().sum::<f64>())
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
    let mut speeds = Vec::with_capacity(arcs.len());
    let mut bounds = Vec::with_capacity(arcs.len());
    let mut violations = Vec::new();
    let mut first_layer = 0;
    let period = opts.servo_period_s;
    for (arc, p) in arcs.iter().zip(&problems) {
        let (v, b) = match opts.schedule {
            Schedule::StepAndShoot => (vec![0.0; p.len()], vec![SpeedBound::StepAndShoot; p.len()]),
            // On a servo period, the continuous scan's speeds are kept where their transitions
            // fit the grid and lowered only where not, so a period never shortens a transition
            // (a scan from the caps on a fine grid could settle on other, faster speeds); the
            // scan from the caps is the fallback when that repair does not settle.
            Schedule::Scan => {
                let cont = scan(p, limits, &p.cap, &p.cap_bound, true, None);
                match period {
                    Some(_) => scan_converged(p, limits, &cont.0, &cont.1, true, period)
                        .unwrap_or_else(|| scan(p, limits, &p.cap, &p.cap_bound, true, period)),
                    None => cont,
                }
            }
            Schedule::Optimal => {
                let (upper, _) = scan(p, limits, &p.cap, &p.cap_bound, false, None);
                let (seed, seed_bounds) = scan(p, limits, &p.cap, &p.cap_bound, true, None);
                let (best, _tol) = optimal(p, limits, &upper, &seed);
                let b = best
                    .iter()
                    .zip(&seed_bounds)
                    .enumerate()
                    .map(|(k, (&v, &sb))| {
                        if (v - p.cap[k]).abs() <= 1e-12 * (1.0 + v) {
                            p.cap_bound[k]
                        } else if v == seed[k] {
                            sb
                        } else {
                            SpeedBound::Optimised
                        }
                    })
                    .collect::<Vec<_>>();
                match period {
                    // The optimum is found in continuous time; the scan then lowers any speeds
                    // whose transitions cannot be put on the servo grid. The servo-aware scan
                    // from the caps can still do better: keep whichever is shorter.
                    // `scan` on the same period (the seed, which is the continuous scan,
                    // repaired on the grid; else the scan from the caps, `direct`) is a
                    // candidate too, so `optimal` is never worse.
                    Some(ts) => {
                        let repaired = scan(p, limits, &best, &b, true, period);
                        let direct = scan(p, limits, &p.cap, &p.cap_bound, true, period);
                        let scanned = scan_converged(p, limits, &seed, &seed_bounds, true, period);
                        let time = |v: &[f64]| arc_time_on_grid(p, v, limits, ts);
                        std::iter::once(direct)
                            .chain(scanned)
                            .fold(repaired, |a, c| if time(&c.0) < time(&a.0) { c } else { a })
                    }
                    None => (best, b),
                }
            }
            Schedule::Prescribed => {
                let (caps, caps_bound, mut found) = prescribed_caps(arc, p, limits, first_layer);
                let (mut v, mut b) = scan(p, limits, &caps, &caps_bound, true, None);
                if period.is_some() {
                    (v, b) = scan_converged(p, limits, &v, &b, true, period)
                        .unwrap_or_else(|| scan(p, limits, &caps, &caps_bound, true, period));
                }
                for viol in &mut found {
                    viol.corrected_deg_per_s = v[viol.layer - first_layer];
                }
                violations.extend(found);
                (v, b)
            }
        };
        speeds.push(v);
        bounds.push(b);
        first_layer += p.len();
    }
    // Free motion needs only the constant-speed total (its baseline), not its timeline.
    let constant_opts = Options {
        build_timeline: opts.build_timeline && opts.motion == Motion::Constant,
        ..opts.clone()
    };
    let constant = assemble(
        arcs,
        &problems,
        &speeds,
        &bounds,
        limits,
        &constant_opts,
        violations,
    )?;
    match opts.motion {
        Motion::Constant => Ok(constant),
        Motion::Free => simulate_free(arcs, &problems, &speeds, limits, opts, constant),
    }
}

/// Checks the motion options against the rest of the options.
fn check_motion(opts: &Options) -> Result<(), SequenceError> {
    match (opts.motion, opts.arc_ends) {
        (Motion::Constant, ArcEnds::Free) => Err(SequenceError::Input(
            "free arc ends need free motion (--motion free): a constant-speed arc starts and ends at rest".into(),
        )),
        (Motion::Free, _) if opts.servo_period_s.is_some() => Err(SequenceError::Input(
            "free motion is continuous-time only: drop the servo period (--period or the machine's servo_period_s)".into(),
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
        let base = free::from_constant(p, limits, v).ok_or_else(|| SequenceError::Infeasible {
            arc: arc.arc_index,
            layer: 0,
            message: "the constant-speed schedule could not be rebuilt as free motion".into(),
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
    verify_timeline(&tl, arcs, problems, &a.layers, &a.transitions, limits, true)?;
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

fn limiter_counts(transitions: &[TransitionRow]) -> LimiterCounts {
    let mut counts = LimiterCounts::default();
    for tr in transitions {
        match tr.limited_by {
            Limiter::Elst => counts.elst += 1,
            Limiter::Speed => counts.speed += 1,
            Limiter::Accel => counts.accel += 1,
            Limiter::Jerk => counts.jerk += 1,
            Limiter::None => counts.none += 1,
        }
    }
    counts
}

/// Per-layer caps from the plan's required speeds, and every point where they cannot be
/// delivered (above V, window overflow, ends not at rest, transitions that do not fit).
fn prescribed_caps(
    arc: &ResolvedArc,
    p: &ArcProblem,
    lim: &Limits,
    offset: usize,
) -> (Vec<f64>, Vec<SpeedBound>, Vec<Violation>) {
    let n = p.len();
    let mut caps = p.cap.clone();
    let mut bounds = p.cap_bound.clone();
    let mut found = Vec::new();
    let req: Vec<Option<f64>> = arc
        .layers
        .iter()
        .map(|l| l.required_speed_deg_per_s)
        .collect();
    let mut flag = |k: usize, v: f64, reason: String| {
        found.push(Violation {
            layer: offset + k,
            arc: arc.arc_index,
            control_point: arc.layers[k].control_point,
            prescribed_deg_per_s: v,
            corrected_deg_per_s: v,
            reason,
        })
    };
    for k in 0..n {
        let Some(v) = req[k] else { continue };
        if (k == 0 || k + 1 == n) && v > 0.0 {
            flag(
                k,
                v,
                "the first and last layers of an arc are delivered at rest".into(),
            );
        } else if v > lim.max_vel * (1.0 + 1e-12) {
            flag(
                k,
                v,
                format!("above the gantry speed limit V = {} deg/s", lim.max_vel),
            );
        } else if v * p.t[k] > p.window[k] * (1.0 + 1e-12) {
            flag(
                k,
                v,
                format!(
                    "sweeps {:.4} deg in {:.4} s, more than the {:.4} deg window",
                    v * p.t[k],
                    p.t[k],
                    p.window[k]
                ),
            );
        }
        if k > 0 && k + 1 < n && v < caps[k] {
            caps[k] = v;
            bounds[k] = crate::SpeedBound::Prescribed;
        }
    }
    // Transitions between two prescribed (and otherwise valid) speeds.
    for k in 0..n.saturating_sub(1) {
        let (Some(a), Some(b)) = (req[k], req[k + 1]) else {
            continue;
        };
        let (a, b) = (
            if k == 0 { 0.0 } else { a.min(p.cap[k]) },
            if k + 2 == n { 0.0 } else { b.min(p.cap[k + 1]) },
        );
        if p.cost(k, a, b, lim).is_none() {
            let mv = p.transition_move(k, a, b);
            let why = match min_time_shape(mv, lim, Reversal::Forbid) {
                Err(e) => format!(
                    "transition to the next layer does not fit its {:.4} deg gap: {e}",
                    mv.distance
                ),
                Ok(_) => format!(
                    "transition to the next layer cannot last its {:.3} s energy switch",
                    p.elst[k + 1]
                ),
            };
            flag(k, req[k].unwrap_or(a), why);
        }
    }
    found.sort_by_key(|v| v.layer);
    (caps, bounds, found)
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
                p.cap[k]
            };
            if !(s.is_finite() && s >= 0.0 && s <= cap * (1.0 + 1e-9) + 1e-12) {
                return Err(SequenceError::Infeasible {
                    arc: a.arc_index,
                    layer: k,
                    message: format!("speed {s} deg/s is outside [0, {cap}] (window, V, or rest at the arc's ends)"),
                });
            }
        }
        speeds.push(
            v.iter()
                .enumerate()
                .map(|(k, &s)| s.min(p.cap[k]))
                .collect::<Vec<_>>(),
        );
        bounds.push(vec![SpeedBound::Prescribed; p.len()]);
        at += p.len();
    }
    assemble(
        arcs,
        &problems,
        &speeds,
        &bounds,
        limits,
        &Options {
            schedule: Schedule::Prescribed,
            ..opts.clone()
        },
        Vec::new(),
    )
}

/// One solved transition: its profile (when a timeline is built) and its summary.
struct Solved {
    profile: Option<Profile>,
    duration: f64,
    min_time: f64,
    limiter: Limiter,
}

fn limiter_of(shape: &TwoStep, lim: &Limits) -> Limiter {
    if shape.duration() <= 0.0 {
        Limiter::None
    } else if shape.t3 > 0.0 && shape.v_peak.abs() >= lim.max_vel * (1.0 - 1e-9) {
        Limiter::Speed
    } else if shape.t2 > 0.0 || shape.t5 > 0.0 {
        Limiter::Accel
    } else {
        Limiter::Jerk
    }
}

/// Solves one forward move of `mv` lasting at least `elst`.
#[allow(clippy::too_many_arguments)]
fn solve_move(
    mv: Move,
    elst: f64,
    lim: &Limits,
    period: Option<f64>,
    with_profile: bool,
    arc: usize,
    layer: usize,
) -> Result<Solved, SequenceError> {
    let infeasible = |e: arcsim_planner::PlannerError| SequenceError::Infeasible {
        arc,
        layer,
        message: e.to_string(),
    };
    let shape = min_time_shape(mv, lim, Reversal::Forbid).map_err(infeasible)?;
    let min_time = shape.duration();
    let limiter = if elst > min_time {
        Limiter::Elst
    } else {
        limiter_of(&shape, lim)
    };
    let duration = if elst > min_time {
        shortest_duration_at_least(mv, lim, elst)
            .map_err(infeasible)?
            .ok_or_else(|| SequenceError::Infeasible {
                arc,
                layer,
                message: format!("the move cannot last its {elst} s energy switch"),
            })?
    } else {
        min_time
    };
    let duration = match period {
        Some(ts) => {
            grid_duration(mv, lim, duration, ts).ok_or_else(|| SequenceError::Infeasible {
                arc,
                layer,
                message: format!("the move cannot last a whole number of {ts} s servo periods"),
            })?
        }
        None => duration,
    };
    let profile = if with_profile {
        Some(exact_duration(mv, lim, duration).map_err(infeasible)?)
    } else {
        None
    };
    Ok(Solved {
        profile,
        duration,
        min_time,
        limiter,
    })
}

fn push_profile(
    pieces: &mut Vec<Piece>,
    prof: &Profile,
    t0: f64,
    angle0: f64,
    dir: f64,
    transition: usize,
) {
    let mut t = t0;
    let mut time_in = 0.0;
    for seg in prof.segments() {
        let st = prof.state_at(time_in);
        pieces.push(Piece {
            t_start_s: t,
            duration_s: seg.duration,
            angle_deg: angle0 + dir * st.position,
            speed_deg_per_s: dir * st.velocity,
            accel_deg_per_s2: dir * st.acceleration,
            jerk_deg_per_s3: dir * seg.jerk,
            kind: PieceKind::Move { transition },
        });
        t += seg.duration;
        time_in += seg.duration;
    }
}

#[allow(clippy::too_many_arguments)]
fn assemble(
    arcs: &[ResolvedArc],
    problems: &[ArcProblem],
    speeds: &[Vec<f64>],
    bounds: &[Vec<SpeedBound>],
    lim: &Limits,
    opts: &Options,
    violations: Vec<Violation>,
) -> Result<Delivery, SequenceError> {
    let build = opts.build_timeline;
    let period = opts.servo_period_s;
    let mut layers = Vec::new();
    let mut transitions: Vec<TransitionRow> = Vec::new();
    let mut pieces = Vec::new();
    let mut t = 0.0;
    let mut prev_end: Option<(f64, usize)> = None; // angle and layer index at the end of the previous arc
    for (ai, (arc, p)) in arcs.iter().zip(problems).enumerate() {
        let v = &speeds[ai];
        for k in 0..p.len() {
            let idx = layers.len();
            let half = 0.5 * v[k] * p.t[k];
            let (t_in, lim_in) = if k == 0 {
                match prev_end {
                    None => (0.0, Limiter::None),
                    Some((angle, from)) => {
                        // Stop-and-turn between arcs: rest to rest, lasting at least the ELST.
                        let delta = p.angle[0] - angle;
                        let dir = if delta < 0.0 { -1.0 } else { 1.0 };
                        let mv = Move {
                            distance: delta.abs(),
                            v_start: 0.0,
                            v_end: 0.0,
                        };
                        let s = solve_move(mv, p.elst[0], lim, period, build, arc.arc_index, 0)?;
                        if let Some(prof) = &s.profile {
                            push_profile(&mut pieces, prof, t, angle, dir, transitions.len());
                        }
                        transitions.push(TransitionRow {
                            index: transitions.len(),
                            from_layer: from,
                            to_layer: idx,
                            arc_change: true,
                            t_start_s: t,
                            duration_s: s.duration,
                            min_time_s: s.min_time,
                            elst_s: p.elst[0],
                            gap_deg: delta.abs(),
                            v_start_deg_per_s: 0.0,
                            v_end_deg_per_s: 0.0,
                            limited_by: s.limiter,
                            lost_s: (s.duration - p.elst[0]).max(0.0),
                        });
                        t += s.duration;
                        (s.duration, s.limiter)
                    }
                }
            } else {
                let mv = p.transition_move(k - 1, v[k - 1], v[k]);
                let s = solve_move(mv, p.elst[k], lim, period, build, arc.arc_index, k)?;
                if let Some(prof) = &s.profile {
                    let angle0 = p.angle[k - 1] + p.dir * 0.5 * v[k - 1] * p.t[k - 1];
                    push_profile(&mut pieces, prof, t, angle0, p.dir, transitions.len());
                }
                transitions.push(TransitionRow {
                    index: transitions.len(),
                    from_layer: idx - 1,
                    to_layer: idx,
                    arc_change: false,
                    t_start_s: t,
                    duration_s: s.duration,
                    min_time_s: s.min_time,
                    elst_s: p.elst[k],
                    gap_deg: mv.distance,
                    v_start_deg_per_s: v[k - 1],
                    v_end_deg_per_s: v[k],
                    limited_by: s.limiter,
                    lost_s: (s.duration - p.elst[k]).max(0.0),
                });
                t += s.duration;
                (s.duration, s.limiter)
            };
            if build && p.t[k] > 0.0 {
                pieces.push(Piece {
                    t_start_s: t,
                    duration_s: p.t[k],
                    angle_deg: p.angle[k] - p.dir * half,
                    speed_deg_per_s: p.dir * v[k],
                    accel_deg_per_s2: 0.0,
                    jerk_deg_per_s3: 0.0,
                    kind: PieceKind::Beam { layer: idx },
                });
            }
            let l = &arc.layers[k];
            layers.push(LayerRow {
                index: idx,
                arc: arc.arc_index,
                control_point: l.control_point,
                layer: l.layer,
                angle_deg: l.angle_deg,
                energy_mev: l.energy_mev,
                irradiation_s: p.t[k],
                speed_deg_per_s: v[k],
                speed_on_deg_per_s: v[k],
                speed_off_deg_per_s: v[k],
                speed_bound: bounds[ai][k],
                window_deg: p.window[k],
                window_used_deg: v[k] * p.t[k],
                t_start_s: t,
                t_end_s: t + p.t[k],
                transition_in_s: t_in,
                transition_limited_by: lim_in,
            });
            t += p.t[k];
        }
        if let Some(&last) = p.angle.last() {
            prev_end = Some((last, layers.len() - 1));
        }
    }
    let energy_switching_s: f64 = transitions.iter().map(|tr| tr.elst_s).sum();
    let lost_s: f64 = transitions.iter().map(|tr| tr.lost_s).sum();
    let counts = limiter_counts(&transitions);
    let (timeline, margins) = if build {
        let tl = Timeline { pieces };
        verify_timeline(&tl, arcs, problems, &layers, &transitions, lim, false)?;
        let m = margins(&tl, &layers, &transitions, lim);
        (Some(tl), Some(m))
    } else {
        (None, None)
    };
    Ok(Delivery {
        schedule: opts.schedule,
        motion: Motion::Constant,
        arc_ends: ArcEnds::Rest,
        constant_speed_total_s: None,
        total_s: t,
        breakdown: Breakdown::of(arcs, energy_switching_s, lost_s),
        limits: (*lim).into(),
        servo_period_s: period,
        lost_time: crate::LostTime::of(&layers, &transitions),
        layers,
        transitions,
        limiter_counts: counts,
        margins,
        violations,
        timeline,
    })
}
