//! Entry points: resolve, schedule, then build, measure and verify one delivery.

use arcsim_plan::{ArcPlan, Machine, ResolvedArc};
use arcsim_planner::{Limits, Move, MoveAnalysis, Profile, Reversal};

use crate::free;
use crate::optimal::{optimal, speed_free_scan};
use crate::problem::ArcProblem;
use crate::raise::{label_by_raise, move_duration};
use crate::scan::{moving_time, moving_time_on, polished_scan, scan, scan_converged};
use crate::servo::grid_duration;
use crate::timeline::{Piece, PieceKind, Timeline};
use crate::verify::{margins, verify_timeline};
use crate::{
    ArcEnds, Breakdown, Delivery, Infeasibility, LayerRow, Limiter, LimiterCounts, Motion, Options,
    Schedule, SequenceError, SpeedBound, TransitionRow, Violation,
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
pub(crate) fn arc_time_on_grid(p: &ArcProblem, v: &[f64], lim: &Limits, period: f64) -> f64 {
    moving_time_on(p, lim, v, Some(period)) + p.irradiation_s.iter().sum::<f64>()
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

/// Layer speeds chosen for every arc (magnitudes, delivery order), what bounds each, and the
/// prescribed speeds that could not be delivered.
struct ChosenSpeeds {
    speeds: Vec<Vec<f64>>,
    bounds: Vec<Vec<SpeedBound>>,
    violations: Vec<Violation>,
}

/// Runs the options' schedule on every arc.
fn choose_speeds(
    arcs: &[ResolvedArc],
    problems: &[ArcProblem],
    limits: &Limits,
    opts: &Options,
) -> ChosenSpeeds {
    let mut chosen = ChosenSpeeds {
        speeds: Vec::with_capacity(arcs.len()),
        bounds: Vec::with_capacity(arcs.len()),
        violations: Vec::new(),
    };
    let mut first_layer = 0;
    let period = opts.servo_period_s;
    for (arc, p) in arcs.iter().zip(problems) {
        let (v, b) = match opts.schedule {
            Schedule::StepAndShoot => (vec![0.0; p.len()], vec![SpeedBound::StepAndShoot; p.len()]),
            Schedule::Scan => scan_speeds(p, limits, period),
            Schedule::Optimal => optimal_speeds(p, limits, period),
            Schedule::Prescribed => {
                let (v, b, found) = prescribed_speeds(arc, p, limits, first_layer, period);
                chosen.violations.extend(found);
                (v, b)
            }
        };
        chosen.speeds.push(v);
        chosen.bounds.push(b);
        first_layer += p.len();
    }
    chosen
}

/// The scan's speeds, from the scan of the arc without V ([`speed_free_scan`]: the same start
/// at every V that cuts none of its speeds, so raising V does not move it). On a servo period, the continuous scan's speeds are kept where their
/// transitions fit the grid and lowered only where not, so a period never shortens a transition
/// (a scan from the caps on a fine grid could settle on other, faster speeds); the scan from the
/// caps is the fallback when that repair does not settle.
fn scan_speeds(
    p: &ArcProblem,
    limits: &Limits,
    period: Option<f64>,
) -> (Vec<f64>, Vec<SpeedBound>) {
    let settled = speed_free_scan(p, limits);
    on_period(p, limits, polished_scan(p, limits, settled), period)
}

/// Continuous-time scan speeds `cont` on a servo period: kept where their transitions fit the
/// grid, lowered where not (the scan from the caps if that does not settle).
fn on_period(
    p: &ArcProblem,
    limits: &Limits,
    cont: (Vec<f64>, Vec<SpeedBound>),
    period: Option<f64>,
) -> (Vec<f64>, Vec<SpeedBound>) {
    match period {
        Some(_) => scan_converged(p, limits, &cont.0, &cont.1, true, period)
            .unwrap_or_else(|| scan(p, limits, &p.speed_cap, &p.cap_bound, true, period)),
        None => cont,
    }
}

/// Most passes of the grid-timed search on a servo period.
const GRID_PASSES: usize = 8;

/// The optimal schedule's speeds, each labelled with what bounds it.
fn optimal_speeds(
    p: &ArcProblem,
    limits: &Limits,
    period: Option<f64>,
) -> (Vec<f64>, Vec<SpeedBound>) {
    let (upper, _) = scan(p, limits, &p.speed_cap, &p.cap_bound, false, None);
    // The search's seed: the scan from the caps the arc has without V, the same at every V that
    // cuts none of its speeds (see `optimal`'s module doc: why `optimal` is monotone in V).
    let (seed, seed_bounds) = speed_free_scan(p, limits);
    // The search is local: the `scan` schedule (which avoids stops at ELSTs, from the same seed)
    // can sit in a better basin, and `optimal` is never worse than it. The two are independent
    // and run side by side.
    let ((found, found_time), fast) = rayon::join(
        || optimal(p, limits, &upper, &seed, None),
        || polished_scan(p, limits, (seed.clone(), seed_bounds.clone())),
    );
    let labels = found
        .iter()
        .zip(&seed_bounds)
        .enumerate()
        .map(|(k, (&v, &sb))| {
            if (v - p.speed_cap[k]).abs() <= 1e-12 * (1.0 + v) {
                p.cap_bound[k]
            } else if v == seed[k] {
                sb
            } else {
                SpeedBound::Optimised
            }
        })
        .collect::<Vec<_>>();
    let (best, b) = if moving_time(p, limits, &fast.0) < found_time {
        fast.clone()
    } else {
        (found, labels)
    };
    let Some(ts) = period else {
        return (best, b);
    };
    // The optimum is found in continuous time; the scan then lowers any speeds whose transitions
    // cannot be put on the servo grid. Other candidates can do better, and the shortest is
    // kept: the servo-aware scan from the caps, the search's seed repaired on the grid, and
    // `scan` on the same period, so `optimal` is never worse than `scan`.
    let repaired = scan(p, limits, &best, &b, true, period);
    let direct = scan(p, limits, &p.speed_cap, &p.cap_bound, true, period);
    let seeded = scan_converged(p, limits, &seed, &seed_bounds, true, period);
    // The scan from the caps (the seed before the V-free one) repaired on the grid: one more
    // start, so the V-free seed never makes a servo-period total longer than it was.
    let capped = scan(p, limits, &p.speed_cap, &p.cap_bound, true, None);
    let capped = scan_converged(p, limits, &capped.0, &capped.1, true, period);
    let scanned = on_period(p, limits, fast, period);
    let time = |v: &[f64]| arc_time_on_grid(p, v, limits, ts);
    let (start, start_bounds) = [Some(direct), seeded, capped, Some(scanned)]
        .into_iter()
        .flatten()
        .fold(repaired, |a, c| if time(&c.0) < time(&a.0) { c } else { a });
    // The same search with every transition timed on the period, its first grids holding the
    // best of those, repeated from its own result while that improves: a grid-timed cost is
    // flat between ticks, so one pass often stops on a plateau that the next one leaves.
    let start_time = moving_time_on(p, limits, &start, period);
    let (mut on_grid, mut on_grid_time) = (start.clone(), start_time);
    for _ in 0..GRID_PASSES {
        let (v, t) = optimal(p, limits, &upper, &on_grid, period);
        if t >= on_grid_time * (1.0 - 1e-9) {
            break;
        }
        (on_grid, on_grid_time) = (v, t);
    }
    if on_grid_time < start_time {
        let labels = on_grid
            .iter()
            .zip(&start)
            .zip(&start_bounds)
            .map(|((&v, &s), &b)| if v == s { b } else { SpeedBound::Optimised })
            .collect();
        (on_grid, labels)
    } else {
        (start, start_bounds)
    }
}

/// The prescribed speeds, lowered by the scan where they cannot be delivered, and every point
/// where they could not.
fn prescribed_speeds(
    arc: &ResolvedArc,
    p: &ArcProblem,
    limits: &Limits,
    first_layer: usize,
    period: Option<f64>,
) -> (Vec<f64>, Vec<SpeedBound>, Vec<Violation>) {
    let (caps, caps_bound, mut found) = prescribed_caps(arc, p, limits, first_layer);
    let (mut v, mut b) = scan(p, limits, &caps, &caps_bound, true, None);
    if period.is_some() {
        (v, b) = scan_converged(p, limits, &v, &b, true, period)
            .unwrap_or_else(|| scan(p, limits, &caps, &caps_bound, true, period));
    }
    for viol in &mut found {
        viol.corrected_deg_per_s = v[viol.layer - first_layer];
    }
    (v, b, found)
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
    let mut caps = p.speed_cap.clone();
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
        } else if v * p.irradiation_s[k] > p.window[k] * (1.0 + 1e-12) {
            flag(
                k,
                v,
                format!(
                    "sweeps {:.4} deg in {:.4} s, more than the {:.4} deg window",
                    v * p.irradiation_s[k],
                    p.irradiation_s[k],
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
            if k == 0 { 0.0 } else { a.min(p.speed_cap[k]) },
            if k + 2 == n {
                0.0
            } else {
                b.min(p.speed_cap[k + 1])
            },
        );
        if p.cost(k, a, b, lim).is_none() {
            let mv = p.transition_move(k, a, b);
            let why = match MoveAnalysis::new(&mv, lim, Reversal::Forbid) {
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

/// One solved transition: its profile (when a timeline is built) and its summary.
struct Solved {
    profile: Option<Profile>,
    duration: f64,
    min_time: f64,
    limiter: Limiter,
}

/// Where a move sits (for errors) and what to build of it.
struct MoveContext {
    /// The servo period every transition is put on, if any (s).
    period: Option<f64>,
    /// Whether to build the profile (a timeline is wanted) or only time it.
    with_profile: bool,
    /// The arc's index, for errors.
    arc: usize,
    /// The layer the move leads into (index within the arc), for errors.
    layer: usize,
}

/// Solves one forward move of `mv` lasting at least `elst`.
fn solve_move(
    mv: Move,
    elst: f64,
    lim: &Limits,
    at: &MoveContext,
) -> Result<Solved, SequenceError> {
    let infeasible = |reason: Infeasibility| SequenceError::Infeasible {
        arc: at.arc,
        layer: at.layer,
        reason,
    };
    let planner = |e: arcsim_planner::PlannerError| infeasible(e.into());
    let analysis = MoveAnalysis::new(&mv, lim, Reversal::Forbid).map_err(planner)?;
    let shape = analysis.min_time_phases();
    let min_time = shape.duration();
    let duration = if elst > min_time {
        analysis
            .shortest_duration_at_least(elst)
            .ok_or_else(|| infeasible(Infeasibility::CannotLastElst { elst_s: elst }))?
    } else {
        min_time
    };
    let limiter = if duration > 0.0 {
        label_by_raise(duration, elst, lim, |l| move_duration(&mv, elst, l))
    } else {
        Limiter::None
    };
    let duration = match at.period {
        Some(ts) => grid_duration(mv, lim, duration, ts)
            .ok_or_else(|| infeasible(Infeasibility::NotOnServoGrid { period_s: ts }))?,
        None => duration,
    };
    let profile = if at.with_profile {
        Some(analysis.profile(duration).map_err(planner)?)
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

/// Builds, times and verifies the constant-speed delivery at the chosen speeds.
fn assemble(
    arcs: &[ResolvedArc],
    problems: &[ArcProblem],
    chosen: &ChosenSpeeds,
    lim: &Limits,
    opts: &Options,
) -> Result<Delivery, SequenceError> {
    let mut a = Assembly {
        lim,
        period: opts.servo_period_s,
        build: opts.build_timeline,
        layers: Vec::new(),
        transitions: Vec::new(),
        pieces: Vec::new(),
        t: 0.0,
    };
    // Angle and delivery index of the last layer of the previous arc.
    let mut prev_end: Option<(f64, usize)> = None;
    for (ai, (arc, p)) in arcs.iter().zip(problems).enumerate() {
        let v = &chosen.speeds[ai];
        for k in 0..p.len() {
            let transition_in = match (k, prev_end) {
                (0, None) => (0.0, Limiter::None),
                (0, Some((angle, from))) => a.turn_between_arcs(arc, p, angle, from)?,
                _ => a.move_within_arc(arc, p, k, v)?,
            };
            a.beam_on(arc, p, k, v[k], chosen.bounds[ai][k], transition_in);
        }
        if let Some(&last) = p.angle.last() {
            prev_end = Some((last, a.layers.len() - 1));
        }
    }
    a.finish(arcs, problems, opts, chosen.violations.clone())
}

/// A constant-speed delivery being assembled: its rows, timeline pieces and clock.
struct Assembly<'a> {
    lim: &'a Limits,
    period: Option<f64>,
    build: bool,
    layers: Vec<LayerRow>,
    transitions: Vec<TransitionRow>,
    pieces: Vec<Piece>,
    /// Time so far (s).
    t: f64,
}

/// One transition to solve and record.
struct TransitionSpec {
    /// The move along its direction of travel.
    mv: Move,
    elst_s: f64,
    from_layer: usize,
    arc_change: bool,
    /// Where the move starts (deg) and its direction (+1 or −1).
    start_angle_deg: f64,
    dir: f64,
    /// Where it sits, for errors: the arc and the layer it leads into.
    at_arc: usize,
    at_layer: usize,
}

impl Assembly<'_> {
    /// Solves a transition, appends its row (and profile) and advances the clock; returns its
    /// duration and what limits it.
    fn transition(&mut self, spec: TransitionSpec) -> Result<(f64, Limiter), SequenceError> {
        let at = MoveContext {
            period: self.period,
            with_profile: self.build,
            arc: spec.at_arc,
            layer: spec.at_layer,
        };
        let s = solve_move(spec.mv, spec.elst_s, self.lim, &at)?;
        let index = self.transitions.len();
        if let Some(prof) = &s.profile {
            push_profile(
                &mut self.pieces,
                prof,
                self.t,
                spec.start_angle_deg,
                spec.dir,
                index,
            );
        }
        self.transitions.push(TransitionRow {
            index,
            from_layer: spec.from_layer,
            to_layer: self.layers.len(),
            arc_change: spec.arc_change,
            t_start_s: self.t,
            duration_s: s.duration,
            min_time_s: s.min_time,
            elst_s: spec.elst_s,
            gap_deg: spec.mv.distance,
            v_start_deg_per_s: spec.mv.v_start,
            v_end_deg_per_s: spec.mv.v_end,
            limited_by: s.limiter,
            lost_s: (s.duration - spec.elst_s).max(0.0),
        });
        self.t += s.duration;
        Ok((s.duration, s.limiter))
    }

    /// Stop-and-turn between arcs: rest to rest, lasting at least the ELST.
    fn turn_between_arcs(
        &mut self,
        arc: &ResolvedArc,
        p: &ArcProblem,
        from_angle: f64,
        from_layer: usize,
    ) -> Result<(f64, Limiter), SequenceError> {
        let delta = p.angle[0] - from_angle;
        self.transition(TransitionSpec {
            mv: Move {
                distance: delta.abs(),
                v_start: 0.0,
                v_end: 0.0,
            },
            elst_s: p.elst[0],
            from_layer,
            arc_change: true,
            start_angle_deg: from_angle,
            dir: if delta < 0.0 { -1.0 } else { 1.0 },
            at_arc: arc.arc_index,
            at_layer: 0,
        })
    }

    /// The move from layer `k − 1` to layer `k` of an arc, between their beam-on sweeps.
    fn move_within_arc(
        &mut self,
        arc: &ResolvedArc,
        p: &ArcProblem,
        k: usize,
        v: &[f64],
    ) -> Result<(f64, Limiter), SequenceError> {
        self.transition(TransitionSpec {
            mv: p.transition_move(k - 1, v[k - 1], v[k]),
            elst_s: p.elst[k],
            from_layer: self.layers.len() - 1,
            arc_change: false,
            start_angle_deg: p.angle[k - 1] + p.dir * 0.5 * v[k - 1] * p.irradiation_s[k - 1],
            dir: p.dir,
            at_arc: arc.arc_index,
            at_layer: k,
        })
    }

    /// Layer `k` irradiated at constant speed `speed`, centred on its angle.
    fn beam_on(
        &mut self,
        arc: &ResolvedArc,
        p: &ArcProblem,
        k: usize,
        speed: f64,
        bound: SpeedBound,
        (transition_in_s, limited_by): (f64, Limiter),
    ) {
        let index = self.layers.len();
        let irradiation_s = p.irradiation_s[k];
        if self.build && irradiation_s > 0.0 {
            self.pieces.push(Piece {
                t_start_s: self.t,
                duration_s: irradiation_s,
                angle_deg: p.angle[k] - p.dir * 0.5 * speed * irradiation_s,
                speed_deg_per_s: p.dir * speed,
                accel_deg_per_s2: 0.0,
                jerk_deg_per_s3: 0.0,
                kind: PieceKind::Beam { layer: index },
            });
        }
        let l = &arc.layers[k];
        self.layers.push(LayerRow {
            index,
            arc: arc.arc_index,
            control_point: l.control_point,
            layer: l.layer,
            angle_deg: l.angle_deg,
            energy_mev: l.energy_mev,
            irradiation_s,
            speed_deg_per_s: speed,
            speed_on_deg_per_s: speed,
            speed_off_deg_per_s: speed,
            speed_bound: bound,
            window_deg: p.window[k],
            window_used_deg: speed * irradiation_s,
            t_start_s: self.t,
            t_end_s: self.t + irradiation_s,
            transition_in_s,
            transition_limited_by: limited_by,
        });
        self.t += irradiation_s;
    }

    /// The delivery: totals and breakdown, and the timeline verified by integration when built.
    fn finish(
        self,
        arcs: &[ResolvedArc],
        problems: &[ArcProblem],
        opts: &Options,
        violations: Vec<Violation>,
    ) -> Result<Delivery, SequenceError> {
        let Assembly {
            lim,
            period,
            build,
            layers,
            transitions,
            pieces,
            t,
        } = self;
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
}
