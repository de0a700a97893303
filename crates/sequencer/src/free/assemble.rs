//! Free-motion arcs into one delivery: pieces split at every beam-on and beam-off, layer and
//! transition rows, stop-and-turn moves between arcs.

use arcsim_plan::ResolvedArc;
use arcsim_planner::{Limits, Segment};

use super::mover::{FullMove, FullState, Mover, Track};
use super::solve::FreeArc;
use crate::problem::ArcProblem;
use crate::raise::label_by_raise;
use crate::timeline::{Piece, PieceKind};
use crate::{Infeasibility, LayerRow, Limiter, SequenceError, SpeedBound, TransitionRow};

/// The constant-speed schedule `speeds` of one arc as a free-motion arc (so arcs where the
/// search finds nothing better keep it).
pub(crate) fn from_constant(p: &ArcProblem, lim: &Limits, speeds: &[f64]) -> Option<FreeArc> {
    let n = p.len();
    let mut moves = Vec::with_capacity(2 * n);
    let mut beam_on = Vec::with_capacity(n);
    let mut t = 0.0;
    for k in 0..n {
        let on = FullState {
            pos: p.travel_deg[k] - 0.5 * speeds[k] * p.irradiation_s[k],
            vel: speeds[k],
            acc: 0.0,
        };
        beam_on.push(t);
        moves.push(FullMove {
            start: on,
            segments: vec![Segment {
                duration: p.irradiation_s[k],
                jerk: 0.0,
            }],
        });
        t += p.irradiation_s[k];
        if k + 1 < n {
            let d = p.cost(k, speeds[k], speeds[k + 1], lim)?;
            let prof = arcsim_planner::plan(
                &p.transition_move(k, speeds[k], speeds[k + 1]),
                lim,
                &arcsim_planner::MoveOptions {
                    min_duration_s: d,
                    ..Default::default()
                },
            )
            .ok()?;
            moves.push(FullMove {
                start: FullState {
                    pos: p.travel_deg[k] + 0.5 * speeds[k] * p.irradiation_s[k],
                    vel: speeds[k],
                    acc: 0.0,
                },
                segments: prof.segments().to_vec(),
            });
            t += d;
        }
    }
    Some(FreeArc {
        run_up: None,
        moves,
        beam_on,
        total: t,
    })
}

/// Signed absolute state of travel state `s` on an arc (angle of its first layer, direction).
fn absolute(s: FullState, angle0: f64, dir: f64) -> FullState {
    FullState {
        pos: angle0 + dir * s.pos,
        vel: dir * s.vel,
        acc: dir * s.acc,
    }
}

/// Arcs solved with free motion as rows and a timeline starting at `t = 0`.
pub(crate) struct Assembled {
    pub layers: Vec<LayerRow>,
    pub transitions: Vec<TransitionRow>,
    pub pieces: Vec<Piece>,
    pub total: f64,
    /// Run-up before the first arc's first beam (s); the rest of the lost time is in rows.
    pub lead_s: f64,
}

/// Assembles arcs solved with free motion into rows and a timeline starting at `t = 0`. The
/// transitions' labels (what limits them) come from `labelled`'s states at the beam edges where
/// given: smoothing flies the same times through other states, which says nothing of what
/// set those times.
pub(crate) fn assemble(
    arcs: &[ResolvedArc],
    problems: &[ArcProblem],
    solved: &[FreeArc],
    labelled: Option<&[FreeArc]>,
    lim: &Limits,
) -> Result<Assembled, SequenceError> {
    let mut a = Assembly {
        lim,
        out: Assembled {
            layers: Vec::new(),
            transitions: Vec::new(),
            pieces: Vec::new(),
            total: 0.0,
            lead_s: 0.0,
        },
        turn: Mover::new(lim, true),
        t: 0.0,
        prev: None,
    };
    for (ai, ((arc, p), fa)) in arcs.iter().zip(problems).zip(solved).enumerate() {
        let label_fa = labelled.and_then(|l| l.get(ai)).unwrap_or(fa);
        a.arc(ai, arc, p, fa, label_fa)?;
    }
    a.out.total = a.t;
    Ok(a.out)
}

/// Whether a transition lasting `duration` lasts no longer than its ELST (to rounding): the
/// ELST is then what limits it.
fn lasts_its_elst(duration: f64, elst: f64) -> bool {
    duration <= elst * (1.0 + 1e-9) + 1e-12
}

/// Where the previous arc ends.
#[derive(Clone, Copy)]
struct ArcEnd {
    /// Absolute state where its motion ends.
    state: FullState,
    /// Its last layer (delivery index).
    layer: usize,
    /// The time of its last beam-off (s).
    last_off: f64,
}

/// Free-motion arcs being assembled: the rows and pieces so far, the clock, and where the
/// previous arc ends.
struct Assembly<'l> {
    lim: &'l Limits,
    out: Assembled,
    /// Solves the stop-and-turn moves between arcs.
    turn: Mover,
    /// Time so far (s).
    t: f64,
    prev: Option<ArcEnd>,
}

/// One arc's beam intervals on the delivery's clock.
struct Beams {
    /// When the arc's motion starts after its run-up (s).
    t_arc: f64,
    on: Vec<f64>,
    off: Vec<f64>,
    /// The arc's first layer and first transition (delivery indices).
    first_layer: usize,
    tr0: usize,
}

impl Assembly<'_> {
    /// Appends arc `ai`: the stop-and-turn into it, its run-up, its layer and transition rows,
    /// its pieces and the labels of its transitions (from `label_fa`'s states at the same beam
    /// edges).
    fn arc(
        &mut self,
        ai: usize,
        arc: &ResolvedArc,
        p: &ArcProblem,
        fa: &FreeArc,
        label_fa: &FreeArc,
    ) -> Result<(), SequenceError> {
        let (mut angle0, dir) = (p.angle.first().copied().unwrap_or(0.0), p.dir);
        let first_layer = self.out.layers.len();
        let run_up = fa.run_up.as_ref();
        let lead = run_up.map_or(0.0, |r| r.duration());
        let wait_at = match run_up {
            Some(r) => r.start,
            None => fa.moves.first().map_or(FullState::default(), |m| m.start),
        };
        if let Some(prev) = self.prev {
            let to = FullState::rest(angle0 + dir * wait_at.pos);
            // The turn lands at rest to Ruckig's precision (1e-10 deg): the arc starts where
            // it landed, so the timeline's joins stay continuous.
            angle0 += self.turn_between_arcs(arc, p, prev, to, lead, first_layer)?;
        }
        if let Some(r) = run_up {
            push_move(
                &mut self.out.pieces,
                r,
                self.t,
                angle0,
                dir,
                PieceKind::RunUp { arc: ai },
            );
            if self.prev.is_none() {
                self.out.lead_s = lead;
            }
            self.t += lead;
        }
        let t_arc = self.t;
        let track = Track::new(&fa.moves);
        let n = p.len();
        // Beam intervals (absolute) and transition indices of this arc.
        let on: Vec<f64> = fa.beam_on.iter().map(|b| t_arc + b).collect();
        let off: Vec<f64> = (0..n).map(|k| on[k] + p.irradiation_s[k]).collect();
        let beams = Beams {
            t_arc,
            on,
            off,
            first_layer,
            tr0: self.out.transitions.len(),
        };
        let ends = self.rows(arc, p, &track, &beams);
        self.pieces(&track, &beams, angle0, dir);
        if std::ptr::eq(label_fa, fa) || label_fa.beam_on != fa.beam_on {
            self.label(&ends, &beams);
        } else {
            let solved = Track::new(&label_fa.moves);
            let at = |t: f64| solved.state_at(t - t_arc);
            let solved_ends: Vec<(FullState, FullState)> = (0..n.saturating_sub(1))
                .map(|k| (at(beams.off[k]), at(beams.on[k + 1])))
                .collect();
            self.label(&solved_ends, &beams);
        }
        self.t = t_arc + fa.total - lead;
        // Where the arc's motion ends (at rest after braking, unless it is the plan's last), as
        // delivered: a rounding away from rest is rest, or the stop-and-turn that follows would
        // start from it and hold it with a jump.
        let last = fa
            .moves
            .last()
            .map_or(FullState::default(), |m| m.delivered_end().settled(0.0));
        self.prev = Some(ArcEnd {
            state: absolute(last, angle0, dir),
            layer: first_layer + n - 1,
            last_off: beams.off[n - 1],
        });
        Ok(())
    }

    /// Stop-and-turn from the previous arc's end to `to`, at rest where this arc's run-up (or
    /// first beam) starts; its row counts from the last beam-off: braking (if any), the turn,
    /// the run-up of `lead` seconds. Returns how far from `to` the turn lands (rounding).
    fn turn_between_arcs(
        &mut self,
        arc: &ResolvedArc,
        p: &ArcProblem,
        prev: ArcEnd,
        to: FullState,
        lead: f64,
        first_layer: usize,
    ) -> Result<f64, SequenceError> {
        let ArcEnd {
            state: from,
            layer: from_layer,
            last_off,
        } = prev;
        let elst = p.elst[0];
        let mv =
            self.turn
                .solve(from, to, (elst - lead).max(0.0))
                .ok_or(SequenceError::Infeasible {
                    arc: arc.arc_index,
                    layer: 0,
                    reason: Infeasibility::NoStopAndTurn,
                })?;
        let index = self.out.transitions.len();
        push_move(
            &mut self.out.pieces,
            &mv,
            self.t,
            0.0,
            1.0,
            PieceKind::Move { transition: index },
        );
        let duration = self.t + mv.duration() + lead - last_off;
        let lim = self.lim;
        self.out.transitions.push(TransitionRow {
            index,
            from_layer,
            to_layer: first_layer,
            arc_change: true,
            t_start_s: last_off,
            duration_s: duration,
            min_time_s: duration,
            elst_s: elst,
            gap_deg: (to.pos - from.pos).abs(),
            v_start_deg_per_s: from.vel.abs(),
            v_end_deg_per_s: 0.0,
            limited_by: if lasts_its_elst(duration, elst) {
                Limiter::Elst
            } else {
                let floor = (elst - lead).max(0.0);
                label_by_raise(mv.duration(), elst, lim, |l| {
                    fastest_at_least(l, true, from, to, floor)
                })
            },
            lost_s: (duration - elst).max(0.0),
        });
        self.t += mv.duration();
        // Where the pieces just pushed end ([`push_move`]'s arithmetic).
        let landed = mv
            .segments
            .iter()
            .filter(|seg| seg.duration > 0.0)
            .fold(mv.start, |s, seg| {
                s.settled(seg.jerk).after(seg.duration, seg.jerk)
            });
        let off = landed.pos - to.pos;
        Ok(if off.abs() <= 1e-9 * (1.0 + to.pos.abs()) {
            off
        } else {
            0.0
        })
    }

    /// The arc's layer rows and the rows of the transitions inside it (labelled later); returns
    /// each beam-off move's boundary states (along the arc), for its label.
    fn rows(
        &mut self,
        arc: &ResolvedArc,
        p: &ArcProblem,
        track: &Track,
        beams: &Beams,
    ) -> Vec<(FullState, FullState)> {
        let Beams {
            t_arc,
            ref on,
            ref off,
            first_layer,
            tr0,
        } = *beams;
        let n = p.len();
        let mut ends: Vec<(FullState, FullState)> = Vec::with_capacity(n.saturating_sub(1));
        for k in 0..n {
            let s_on = track.state_at(on[k] - t_arc);
            let s_off = track.state_at(off[k] - t_arc);
            let (t_in, lim_in) = if k == 0 {
                match self.out.transitions.last() {
                    Some(tr) if self.prev.is_some() => (tr.duration_s, tr.limited_by),
                    _ => (0.0, Limiter::None),
                }
            } else {
                (on[k] - off[k - 1], Limiter::None)
            };
            let l = &arc.layers[k];
            let used = s_off.pos - s_on.pos;
            self.out.layers.push(LayerRow {
                index: first_layer + k,
                arc: arc.arc_index,
                control_point: l.control_point,
                layer: l.layer,
                angle_deg: l.angle_deg,
                energy_mev: l.energy_mev,
                irradiation_s: p.irradiation_s[k],
                speed_deg_per_s: if p.irradiation_s[k] > 0.0 {
                    used / p.irradiation_s[k]
                } else {
                    s_on.vel
                },
                speed_on_deg_per_s: s_on.vel,
                speed_off_deg_per_s: s_off.vel,
                speed_bound: SpeedBound::Free,
                window_deg: p.window[k],
                window_used_deg: used,
                t_start_s: on[k],
                t_end_s: off[k],
                transition_in_s: t_in,
                transition_limited_by: lim_in,
            });
            if k + 1 < n {
                let s_next = track.state_at(on[k + 1] - t_arc);
                let duration = on[k + 1] - off[k];
                ends.push((s_off, s_next));
                self.out.transitions.push(TransitionRow {
                    index: tr0 + k,
                    from_layer: first_layer + k,
                    to_layer: first_layer + k + 1,
                    arc_change: false,
                    t_start_s: off[k],
                    duration_s: duration,
                    min_time_s: duration,
                    elst_s: p.elst[k + 1],
                    gap_deg: s_next.pos - s_off.pos,
                    v_start_deg_per_s: s_off.vel,
                    v_end_deg_per_s: s_next.vel,
                    limited_by: Limiter::None,
                    lost_s: (duration - p.elst[k + 1]).max(0.0),
                });
            }
        }
        ends
    }

    /// The arc's pieces (absolute angles), split at every beam edge so each is a beam or a move.
    fn pieces(&mut self, track: &Track, beams: &Beams, angle0: f64, dir: f64) {
        let Beams {
            t_arc,
            ref on,
            ref off,
            first_layer,
            tr0,
        } = *beams;
        let n = on.len();
        let mut edges: Vec<f64> = on.iter().chain(off.iter()).copied().collect();
        edges.sort_by(f64::total_cmp);
        // Motion after the arc's last beam belongs to the stop-and-turn that follows.
        let after_last = tr0 + n - 1;
        let kind_at = |tm: f64| -> PieceKind {
            let k = on.partition_point(|&b| b <= tm).saturating_sub(1);
            if tm >= off[n - 1] {
                PieceKind::Move {
                    transition: after_last,
                }
            } else if tm >= on[k] && tm < off[k] {
                PieceKind::Beam {
                    layer: first_layer + k,
                }
            } else {
                PieceKind::Move {
                    transition: tr0 + k.min(n.saturating_sub(2)),
                }
            }
        };
        for (start, mv) in &track.moves {
            let mut s = absolute(mv.start, angle0, dir);
            let mut tm = t_arc + start;
            for seg in &mv.segments {
                let end = tm + seg.duration;
                // A few units in the last place of the clock: far into a long delivery (a switch
                // of hours) a beam edge and a move's end differ by rounding, and the sliver
                // between them belongs to neither.
                let eps = 8.0 * f64::EPSILON * (1.0 + end.abs());
                // Cut points relative to the segment's start, so that an uncut segment keeps its
                // own duration: the difference of two clock readings far into a delivery is off
                // by their rounding, which a crawl of hours after it turns into a jump.
                let mut cuts: Vec<f64> = edges
                    .iter()
                    .copied()
                    .filter(|&e| e > tm + eps && e < end - eps)
                    .map(|e| e - tm)
                    .collect();
                cuts.push(seg.duration);
                let mut a = 0.0;
                s = s.settled(dir * seg.jerk);
                let first = self.out.pieces.len();
                for c in cuts {
                    let d = c - a;
                    let cut_before = self.out.pieces.len() > first;
                    match self.out.pieces.last_mut() {
                        // A sliver after a cut belongs to the piece before it, of the same
                        // segment: its motion stays in the timeline.
                        Some(last) if d <= eps && cut_before => {
                            last.duration_s += d;
                        }
                        _ if d > 0.0 => self.out.pieces.push(Piece {
                            t_start_s: tm + a,
                            duration_s: d,
                            angle_deg: s.pos,
                            speed_deg_per_s: s.vel,
                            accel_deg_per_s2: s.acc,
                            jerk_deg_per_s3: dir * seg.jerk,
                            kind: kind_at(tm + 0.5 * (a + c)),
                        }),
                        _ => {}
                    }
                    s = s.after(d, dir * seg.jerk);
                    a = c;
                }
                tm = end;
            }
        }
    }

    /// What limits each transition inside the arc: the ELST when it lasts no longer, else the
    /// gantry limit whose raise shortens the fastest move between the same boundary states most.
    fn label(&mut self, ends: &[(FullState, FullState)], beams: &Beams) {
        for (k, &(from, to)) in ends.iter().enumerate() {
            let tr = &mut self.out.transitions[beams.tr0 + k];
            tr.limited_by = limiter_between(from, to, tr.duration_s, tr.elst_s, self.lim);
            self.out.layers[beams.first_layer + k + 1].transition_limited_by = tr.limited_by;
        }
    }
}

/// Appends the pieces of `mv`, started at `t0`, on an arc starting at `angle0` in direction `dir`.
fn push_move(
    pieces: &mut Vec<Piece>,
    mv: &FullMove,
    t0: f64,
    angle0: f64,
    dir: f64,
    kind: PieceKind,
) {
    let mut s = absolute(mv.start, angle0, dir);
    let mut t = t0;
    for seg in &mv.segments {
        if seg.duration <= 0.0 {
            continue;
        }
        s = s.settled(dir * seg.jerk);
        pieces.push(Piece {
            t_start_s: t,
            duration_s: seg.duration,
            angle_deg: s.pos,
            speed_deg_per_s: s.vel,
            accel_deg_per_s2: s.acc,
            jerk_deg_per_s3: dir * seg.jerk,
            kind,
        });
        s = s.after(seg.duration, dir * seg.jerk);
        t += seg.duration;
    }
}

/// The label of a beam-off move of free motion lasting `duration` between the boundary states
/// `from` and `to`: the ELST when it lasts no longer, else the gantry limit whose raise by
/// [`crate::LIMIT_RAISE_FACTOR`] shortens the fastest move between the same states (lasting at
/// least the ELST) most; none for a move that does not take time.
fn limiter_between(
    from: FullState,
    to: FullState,
    duration: f64,
    elst: f64,
    lim: &Limits,
) -> Limiter {
    if duration <= 0.0 {
        Limiter::None
    } else if lasts_its_elst(duration, elst) {
        Limiter::Elst
    } else {
        match fastest_at_least(lim, false, from, to, elst) {
            Some(base) => label_by_raise(base, elst, lim, |l| {
                fastest_at_least(l, false, from, to, elst)
            }),
            None => Limiter::None,
        }
    }
}

/// Duration of the fastest move `from → to` under `lim` lasting at least `floor`. Ruckig may fail
/// to synchronise to a floor equal to the fastest move's own duration (to rounding); the fastest
/// move without the floor, if it lasts the floor, is then the answer.
fn fastest_at_least(
    lim: &Limits,
    reversible: bool,
    from: FullState,
    to: FullState,
    floor: f64,
) -> Option<f64> {
    let mut mover = Mover::new(lim, reversible);
    mover.duration(from, to, floor).or_else(|| {
        mover
            .duration(from, to, 0.0)
            .filter(|&d| d >= floor - 1e-12 * (1.0 + floor))
    })
}
