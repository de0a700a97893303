//! The constant-speed delivery: each layer irradiated at one speed, centred in its window, and
//! the jerk-limited moves between layers, built, timed and verified.

use arcsim_plan::ResolvedArc;
use arcsim_planner::{Limits, Move, MoveAnalysis, Profile, Reversal};

use crate::problem::ArcProblem;
use crate::raise::{label_by_raise, move_duration, timed};
use crate::schedule::ChosenSpeeds;
use crate::servo::grid_duration;
use crate::timeline::{Piece, PieceKind, Timeline};
use crate::verify::{margins, verify_timeline};
use crate::{
    ArcEnds, Breakdown, Delivery, Infeasibility, LayerRow, Limiter, LimiterCounts, Motion, Options,
    SequenceError, SpeedBound, TransitionRow, Violation,
};

pub(crate) fn limiter_counts(transitions: &[TransitionRow]) -> LimiterCounts {
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

/// Solves one forward move of `mv` lasting at least `elst` and at least `hold` (a cruise's
/// duration; 0 for none).
fn solve_move(
    mv: Move,
    elst: f64,
    hold: f64,
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
    let timed = timed(&analysis);
    let min_time = timed.min_time;
    let duration = timed
        .at_least(elst.max(hold))
        .ok_or_else(|| infeasible(Infeasibility::CannotLastElst { elst_s: elst }))?;
    // A held move (a cruise) is labelled by its controller, which knows what set the hold.
    let limiter = if hold > 0.0 {
        Limiter::None
    } else if duration > 0.0 {
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
pub(crate) fn assemble(
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
        let hold = |k: usize| chosen.min_move_s.get(ai).map_or(0.0, |h| h[k]);
        for k in 0..p.len() {
            let transition_in = match (k, prev_end) {
                (0, None) => (0.0, Limiter::None),
                (0, Some((angle, from))) => a.turn_between_arcs(arc, p, angle, from)?,
                _ => a.move_within_arc(arc, p, k, v, hold(k))?,
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
    /// The least duration beyond the ELST (a cruise's), 0 for none (s).
    hold_s: f64,
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
        let s = solve_move(spec.mv, spec.elst_s, spec.hold_s, self.lim, &at)?;
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
            hold_s: 0.0,
            from_layer,
            arc_change: true,
            start_angle_deg: from_angle,
            dir: if delta < 0.0 { -1.0 } else { 1.0 },
            at_arc: arc.arc_index,
            at_layer: 0,
        })
    }

    /// The move from layer `k − 1` to layer `k` of an arc, between their beam-on sweeps, lasting
    /// at least `hold_s` (a cruise) as well as the ELST.
    fn move_within_arc(
        &mut self,
        arc: &ResolvedArc,
        p: &ArcProblem,
        k: usize,
        v: &[f64],
        hold_s: f64,
    ) -> Result<(f64, Limiter), SequenceError> {
        self.transition(TransitionSpec {
            mv: p.transition_move(k - 1, v[k - 1], v[k]),
            elst_s: p.elst[k],
            hold_s,
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
            verify_timeline(&tl, problems, &layers, &transitions, lim, false)?;
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
