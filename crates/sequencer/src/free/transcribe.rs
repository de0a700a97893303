//! A direct transcription of one arc's free motion, improved by sequential linear programming.
//!
//! The motion is cut into *stages* (the run-up, every beam, every switch, the braking) and every
//! stage into pieces of constant jerk whose durations are free. The variables are the state at
//! each join (angle, speed, acceleration), each piece's jerk and its duration. The constraints:
//! the limits at every join, |jerk| ≤ J, every beam's pieces last its irradiation time and every
//! switch's pieces at least its ELST, and each beam starts past its window's low edge and ends
//! before its high edge (the angle never decreases, so the whole beam is then inside). The
//! objective is the total duration.
//!
//! Exact integration across a piece is linear in the state and the jerk and a polynomial in the
//! duration, so a step solves the problem linearised at the current pieces (the changes of all
//! variables; the durations inside a trust region) as one linear programme. The driver
//! ([`super::refine`]) keeps a step only when the exact delivery built from its beam-on and
//! beam-off states is shorter. The speed is bounded at the joins; inside a piece where braking
//! turns into speeding up (or the reverse) it passes a low (high) point between them, kept at
//! or above 0 (at or below V) by a linearised cut where it comes near: 2·u·v ≥ a²
//! (2·|u|·(V − v) ≥ a²). Without the upper cut, beams planned at full speed with the
//! acceleration still positive overshoot V, the exact build rejects every such step, and the
//! refinement stalls (the bundled two-arc plan at 252.93 s instead of 251.81 s). The exact build
//! (time-optimal moves between the states) is what is verified and returned.

use arcsim_planner::{Limits, Segment};

use super::lp::Lp;
use super::mover::{FullMove, FullState};
use super::solve::{beam_at_rest, End, FreeArc, Start};
use crate::problem::ArcProblem;

/// What a stage of the arc's motion is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum StageKind {
    /// From rest to the first beam-on (`free` ends).
    RunUp,
    /// Layer `k` irradiated.
    Beam(usize),
    /// The energy switch into layer `k` (beam off).
    Switch(usize),
    /// From the last beam-off to rest (another arc follows).
    Brake,
}

#[derive(Clone, Copy, Debug)]
struct Stage {
    kind: StageKind,
    /// Index of its first piece.
    first: usize,
    /// Number of pieces.
    count: usize,
}

/// Pieces per stage kind (a stage keeps more where its seed has more segments). The exact build
/// re-flies every switch, run-up and braking as a time-optimal move between the transcript's
/// states, so their pieces only have to tell which states a stage can join: a few suffice.
const BEAM_PIECES: usize = 2;
const MOVE_PIECES: usize = 5;

/// How far inside its window each beam starts and ends in the linear programme (deg), so that
/// the exact build, which integrates the pieces from where the gantry really is, stays inside.
const GATE_MARGIN_DEG: f64 = 5e-5;

/// How far inside each limit the linear programme keeps (relative).
const LIMIT_MARGIN: f64 = 1e-9;

/// The transcribed arc: stages of constant-jerk pieces.
#[derive(Clone, Debug)]
pub(crate) struct Transcript {
    stages: Vec<Stage>,
    /// State at the start of each piece, then the final state (pieces + 1 entries).
    state: Vec<FullState>,
    jerk: Vec<f64>,
    dur: Vec<f64>,
}

/// One constant-jerk piece of a trajectory, with its start time and state.
#[derive(Clone, Copy)]
struct Timed {
    t0: f64,
    start: FullState,
    jerk: f64,
    dur: f64,
}

/// The state at time `t` and the pieces of `[a, b]` of a trajectory laid out as `pieces`.
fn cut(pieces: &[Timed], a: f64, b: f64) -> (FullState, Vec<(f64, f64)>) {
    let at = |t: f64| -> FullState {
        let i = pieces.partition_point(|q| q.t0 <= t).saturating_sub(1);
        match pieces.get(i) {
            Some(q) => q.start.after((t - q.t0).clamp(0.0, q.dur), q.jerk),
            None => FullState::default(),
        }
    };
    let mut out = Vec::new();
    for q in pieces {
        let lo = q.t0.max(a);
        let hi = (q.t0 + q.dur).min(b);
        if hi > lo {
            out.push((q.jerk, hi - lo));
        }
    }
    (at(a), out)
}

impl Transcript {
    /// The transcription of a solved arc (`fa`), each stage cut from its trajectory and its
    /// longest pieces split until the stage has its number of pieces.
    pub fn from_arc(p: &ArcProblem, start: Start, end: End, fa: &FreeArc) -> Transcript {
        let n = p.len();
        let mut pieces = Vec::new();
        let lead = fa.run_up.as_ref().map_or(0.0, FullMove::duration);
        let mut t = -lead;
        for mv in fa.run_up.iter().chain(&fa.moves) {
            let mut s = mv.start;
            for seg in &mv.segments {
                pieces.push(Timed {
                    t0: t,
                    start: s,
                    jerk: seg.jerk,
                    dur: seg.duration,
                });
                s = s.after(seg.duration, seg.jerk);
                t += seg.duration;
            }
        }
        let t_end = t;
        let mut bounds: Vec<(StageKind, f64, f64)> = Vec::with_capacity(2 * n + 1);
        if start == Start::RunUp {
            bounds.push((StageKind::RunUp, -lead, 0.0));
        }
        for k in 0..n {
            let on = fa.beam_on[k];
            if k > 0 {
                bounds.push((
                    StageKind::Switch(k),
                    fa.beam_on[k - 1] + p.irradiation_s[k - 1],
                    on,
                ));
            }
            bounds.push((StageKind::Beam(k), on, on + p.irradiation_s[k]));
        }
        let last_off = fa.beam_on[n - 1] + p.irradiation_s[n - 1];
        if end == End::Brake {
            bounds.push((StageKind::Brake, last_off, t_end.max(last_off)));
        }
        let mut tr = Transcript {
            stages: Vec::with_capacity(bounds.len()),
            state: Vec::new(),
            jerk: Vec::new(),
            dur: Vec::new(),
        };
        let mut last = FullState::default();
        for (kind, a, b) in bounds {
            let (s0, mut segs) = cut(&pieces, a, b);
            let at_rest = matches!(kind, StageKind::Beam(k) if beam_at_rest(k, n, start, end));
            let want = match kind {
                _ if at_rest => 1,
                StageKind::Beam(_) => BEAM_PIECES,
                _ => MOVE_PIECES,
            };
            if at_rest {
                segs = vec![(0.0, b - a)];
            }
            if segs.is_empty() {
                segs.push((0.0, 0.0));
            }
            while segs.len() < want {
                let (i, _) = segs
                    .iter()
                    .enumerate()
                    .max_by(|x, y| x.1 .1.total_cmp(&y.1 .1))
                    .unwrap_or((0, &(0.0, 0.0)));
                let (j, d) = segs[i];
                segs[i] = (j, 0.5 * d);
                segs.insert(i + 1, (j, 0.5 * d));
            }
            tr.stages.push(Stage {
                kind,
                first: tr.jerk.len(),
                count: segs.len(),
            });
            let mut s = if at_rest { FullState::rest(s0.pos) } else { s0 };
            for (j, d) in segs {
                tr.state.push(s);
                tr.jerk.push(j);
                tr.dur.push(d);
                s = s.after(d, j);
            }
            last = s;
        }
        tr.state.push(last);
        tr
    }

    /// Beam-on and beam-off state of every layer.
    pub fn anchors(&self, n: usize) -> (Vec<FullState>, Vec<FullState>) {
        let mut on = vec![FullState::default(); n];
        let mut off = vec![FullState::default(); n];
        for st in &self.stages {
            if let StageKind::Beam(k) = st.kind {
                on[k] = self.state[st.first];
                off[k] = self.state[st.first + st.count];
            }
        }
        (on, off)
    }

    /// The pieces of layer `k`'s beam.
    pub fn beam_segments(&self, k: usize) -> Vec<Segment> {
        self.segments_of(StageKind::Beam(k))
    }

    /// The pieces of the switch into layer `k`.
    pub fn switch_segments(&self, k: usize) -> Vec<Segment> {
        self.segments_of(StageKind::Switch(k))
    }

    /// The pieces of the braking after the last beam (empty without one).
    pub fn brake_segments(&self) -> Vec<Segment> {
        self.segments_of(StageKind::Brake)
    }

    fn segments_of(&self, kind: StageKind) -> Vec<Segment> {
        self.stages
            .iter()
            .find(|st| st.kind == kind)
            .map(|st| {
                (st.first..st.first + st.count)
                    .map(|q| Segment {
                        duration: self.dur[q],
                        jerk: self.jerk[q],
                    })
                    .collect()
            })
            .unwrap_or_default()
    }

    /// Every beam's pieces scaled to last its irradiation time and every switch's to last at
    /// least its ELST (a linear programme meets them only to its tolerance).
    pub fn normalise(&mut self, p: &ArcProblem) {
        for st in &self.stages {
            let span = st.first..st.first + st.count;
            let total: f64 = self.dur[span.clone()].iter().sum();
            let want = match st.kind {
                StageKind::Beam(k) => p.irradiation_s[k],
                StageKind::Switch(k) if total < p.elst[k] => p.elst[k],
                _ => continue,
            };
            if total > 0.0 {
                for d in &mut self.dur[span] {
                    *d *= want / total;
                }
            }
        }
    }

    /// Total duration of all pieces (s).
    pub fn duration(&self) -> f64 {
        self.dur.iter().sum()
    }

    /// One step: the problem linearised at the current pieces, solved with every duration
    /// inside a trust region of `radius` times its piece's duration (or its stage's mean piece
    /// duration, if larger) and every jerk within `2·radius·J` of its value. `None` when the
    /// linear programme has no solution.
    pub fn step(
        &self,
        p: &ArcProblem,
        lim: &Limits,
        start: Start,
        end: End,
        radius: f64,
    ) -> Option<Transcript> {
        // The limits a hair inside, so that the exact integration of the solution keeps them.
        let inner = 1.0 - LIMIT_MARGIN;
        let inner_lim = InnerLimits {
            jm: lim.max_jerk * inner,
            am: lim.max_accel * inner,
            dm: lim.max_decel * inner,
            vm: lim.max_vel * inner,
        };
        let mut lp = Lp::default();
        let kinds = self.node_kinds(p, start, end);
        let clock = self.stage_clocks();
        let vars = Vars {
            nodes: self.node_vars(&mut lp, &kinds, lim, &inner_lim, radius),
            pieces: self.piece_vars(&mut lp, &kinds.rest_piece, inner_lim.jm, radius),
        };
        // Rows, piece by piece along the arc (so the normal matrix is banded).
        for st in &self.stages {
            let last = st.first + st.count - 1;
            for q in st.first..=last {
                self.clock_row(&mut lp, p, st, q, &vars, &clock);
                self.motion_rows(&mut lp, q, &vars);
                if !kinds.rest_piece[q] {
                    self.speed_turn_rows(&mut lp, q, &vars, lim);
                }
            }
        }
        let z = lp.solve()?;
        if z.iter().any(|v| !v.is_finite()) {
            return None;
        }
        Some(self.moved_by(&z, &vars, lim))
    }

    /// What each node must be (at rest, inside a window from below or above) and where each
    /// stage begins.
    fn node_kinds(&self, p: &ArcProblem, start: Start, end: End) -> NodeKinds {
        let n = p.len();
        let np = self.jerk.len();
        let inf = f64::INFINITY;
        let mut k = NodeKinds {
            rest: vec![false; np + 1],
            rest_piece: vec![false; np],
            floor: vec![-inf; np + 1],
            ceil: vec![inf; np + 1],
            first_of_stage: vec![false; np + 1],
        };
        for st in &self.stages {
            let (a, b) = (st.first, st.first + st.count);
            k.first_of_stage[a] = true;
            match st.kind {
                StageKind::Beam(layer) => {
                    let (lo, hi) = p.window_edges(layer);
                    k.floor[a] = lo + GATE_MARGIN_DEG;
                    k.ceil[b] = hi - GATE_MARGIN_DEG;
                    if beam_at_rest(layer, n, start, end) {
                        k.rest[a..=b].iter_mut().for_each(|r| *r = true);
                        k.rest_piece[a..b].iter_mut().for_each(|r| *r = true);
                    }
                }
                StageKind::RunUp => k.rest[a] = true,
                StageKind::Brake => k.rest[b] = true,
                StageKind::Switch(_) => {}
            }
        }
        k
    }

    /// Clock of each node: time since its stage began (0 at a stage's first node).
    fn stage_clocks(&self) -> Vec<f64> {
        let mut clock = vec![0.0; self.jerk.len() + 1];
        for st in &self.stages {
            let span = st.first..st.first + st.count;
            let mut c = 0.0;
            for (slot, d) in clock[span.clone()].iter_mut().zip(&self.dur[span]) {
                *slot = c;
                c += d;
            }
        }
        clock
    }

    /// The variables of every node (changes from the current values), node by node.
    fn node_vars(
        &self,
        lp: &mut Lp,
        kinds: &NodeKinds,
        lim: &Limits,
        inner: &InnerLimits,
        radius: f64,
    ) -> Vec<Node> {
        let np = self.jerk.len();
        let inf = f64::INFINITY;
        let mut nodes = Vec::with_capacity(np + 1);
        for q in 0..=np {
            let s = self.state[q];
            let x = lp.var(kinds.floor[q] - s.pos, kinds.ceil[q] - s.pos, 0.0);
            let (v, a) = if kinds.rest[q] {
                (lp.var(-s.vel, -s.vel, 0.0), lp.var(-s.acc, -s.acc, 0.0))
            } else {
                // Speed and acceleration change within the trust region too: their products
                // with a duration's change are what the linearisation misses.
                let (rv, ra) = (
                    radius * lim.max_vel,
                    2.0 * radius * lim.max_accel.max(lim.max_decel),
                );
                (
                    lp.var((-s.vel).max(-rv), (inner.vm - s.vel).min(rv), 0.0),
                    lp.var(
                        (-inner.dm - s.acc).max(-ra),
                        (inner.am - s.acc).min(ra),
                        0.0,
                    ),
                )
            };
            let c = (q < np && !kinds.first_of_stage[q]).then(|| lp.var(-inf, inf, 0.0));
            nodes.push(Node { x, v, a, c });
        }
        nodes
    }

    /// The jerk and duration variables of every piece, inside their trust regions.
    fn piece_vars(&self, lp: &mut Lp, rest_piece: &[bool], jm: f64, radius: f64) -> PieceVars {
        let np = self.jerk.len();
        let mut jerk = Vec::with_capacity(np);
        let mut dur = Vec::with_capacity(np);
        for st in &self.stages {
            let total: f64 = self.dur[st.first..st.first + st.count].iter().sum();
            let mean = total / st.count as f64;
            for (q, &at_rest) in rest_piece.iter().enumerate().skip(st.first).take(st.count) {
                let (u, d) = (self.jerk[q], self.dur[q]);
                let ru = 2.0 * radius * jm;
                jerk.push(if at_rest {
                    lp.var(-u, -u, 0.0)
                } else {
                    lp.var((-jm - u).max(-ru), (jm - u).min(ru), 0.0)
                });
                let rd = radius * d.max(mean).max(1e-3);
                dur.push(lp.var((-d).max(-rd), rd, 1.0));
            }
        }
        PieceVars { jerk, dur }
    }

    /// The clock row of piece `q` of stage `st`: inside a stage, the next node's clock; at its
    /// last piece, the stage's duration (a beam's irradiation time, at least a switch's ELST).
    fn clock_row(
        &self,
        lp: &mut Lp,
        p: &ArcProblem,
        st: &Stage,
        q: usize,
        vars: &Vars,
        clock: &[f64],
    ) {
        let inf = f64::INFINITY;
        let last = st.first + st.count - 1;
        let d = self.dur[q];
        let dur = &vars.pieces.dur;
        let (nq, nn) = (&vars.nodes[q], &vars.nodes[q + 1]);
        let c_here = nq.c.map(|c| (c, 1.0));
        if q < last {
            // The next node's clock.
            let mut t = vec![(dur[q], -1.0)];
            if let Some(c) = nn.c {
                t.push((c, 1.0));
            }
            if let Some((c, _)) = c_here {
                t.push((c, -1.0));
            }
            lp.row(&t, clock[q] + d - clock[q + 1]);
        } else {
            let mut t = vec![(dur[q], 1.0)];
            if let Some(ch) = c_here {
                t.push(ch);
            }
            let elapsed = clock[q] + d;
            match st.kind {
                StageKind::Beam(k) => lp.row(&t, p.irradiation_s[k] - elapsed),
                StageKind::Switch(k) => {
                    let slack = lp.var(0.0, inf, 0.0);
                    t.push((slack, -1.0));
                    lp.row(&t, p.elst[k] - elapsed);
                }
                StageKind::RunUp | StageKind::Brake => {}
            }
        }
    }

    /// Piece `q`'s end state, linearised in its start state, jerk and duration, is the next
    /// node's state: one row each for position, speed and acceleration.
    fn motion_rows(&self, lp: &mut Lp, q: usize, vars: &Vars) {
        let s = self.state[q];
        let (u, d) = (self.jerk[q], self.dur[q]);
        let (nq, nn) = (&vars.nodes[q], &vars.nodes[q + 1]);
        let (jerk, dur) = (&vars.pieces.jerk, &vars.pieces.dur);
        let f = s.after(d, u);
        let next = self.state[q + 1];
        let d2 = d * d;
        lp.row(
            &[
                (nn.x, 1.0),
                (nq.x, -1.0),
                (nq.v, -d),
                (nq.a, -0.5 * d2),
                (jerk[q], -d2 * d / 6.0),
                (dur[q], -(s.vel + s.acc * d + 0.5 * u * d2)),
            ],
            f.pos - next.pos,
        );
        lp.row(
            &[
                (nn.v, 1.0),
                (nq.v, -1.0),
                (nq.a, -d),
                (jerk[q], -0.5 * d2),
                (dur[q], -(s.acc + u * d)),
            ],
            f.vel - next.vel,
        );
        lp.row(
            &[(nn.a, 1.0), (nq.a, -1.0), (jerk[q], -d), (dur[q], -u)],
            f.acc - next.acc,
        );
    }

    /// Speed bounds inside moving piece `q`, where its acceleration changes sign: the joins
    /// bound the speed only at the piece's ends.
    fn speed_turn_rows(&self, lp: &mut Lp, q: usize, vars: &Vars, lim: &Limits) {
        let inf = f64::INFINITY;
        let s = self.state[q];
        let (u, d) = (self.jerk[q], self.dur[q]);
        let nq = &vars.nodes[q];
        let jerk = &vars.pieces.jerk;
        // Braking that turns into speeding up inside a piece reaches its lowest speed
        // v - a²/(2u) there, between the joins where the speed is bounded: keep it
        // non-negative (2·u·v ≥ a², linearised) where it comes near zero.
        if s.acc < 0.0 && u > 0.0 && -s.acc / u < 1.2 * d {
            let low = s.vel - s.acc * s.acc / (2.0 * u);
            if low < 0.1 * lim.max_vel {
                let slack = lp.var(0.0, inf, 0.0);
                lp.row(
                    &[
                        (jerk[q], 2.0 * s.vel),
                        (nq.v, 2.0 * u),
                        (nq.a, -2.0 * s.acc),
                        (slack, -1.0),
                    ],
                    s.acc * s.acc - 2.0 * u * s.vel,
                );
            }
        }
        // Likewise speeding up that turns into braking peaks at v + a²/(2|u|): keep it
        // at most V (2·|u|·(V - v) ≥ a², linearised) where it comes near V.
        if s.acc > 0.0 && u < 0.0 && -s.acc / u < 1.2 * d {
            let peak = s.vel - s.acc * s.acc / (2.0 * u);
            if peak > 0.9 * lim.max_vel {
                let slack = lp.var(0.0, inf, 0.0);
                let room = lim.max_vel - s.vel;
                lp.row(
                    &[
                        (jerk[q], -2.0 * room),
                        (nq.v, 2.0 * u),
                        (nq.a, -2.0 * s.acc),
                        (slack, -1.0),
                    ],
                    s.acc * s.acc + 2.0 * u * room,
                );
            }
        }
    }

    /// This transcript moved by the linear programme's solution `z` (jerks clamped to J,
    /// durations to non-negative).
    fn moved_by(&self, z: &[f64], vars: &Vars, lim: &Limits) -> Transcript {
        let mut out = self.clone();
        for (q, nd) in vars.nodes.iter().enumerate() {
            let s = &mut out.state[q];
            s.pos += z[nd.x];
            s.vel += z[nd.v];
            s.acc += z[nd.a];
        }
        for q in 0..self.jerk.len() {
            out.jerk[q] = (out.jerk[q] + z[vars.pieces.jerk[q]]).clamp(-lim.max_jerk, lim.max_jerk);
            out.dur[q] = (out.dur[q] + z[vars.pieces.dur[q]]).max(0.0);
        }
        out
    }
}

/// The gantry limits a hair inside, so that the exact integration of a step's solution keeps
/// them.
struct InnerLimits {
    jm: f64,
    am: f64,
    dm: f64,
    vm: f64,
}

/// What each node of a step must be.
struct NodeKinds {
    /// At rest (speed and acceleration fixed at zero).
    rest: Vec<bool>,
    /// Pieces inside a beam at rest (jerk fixed at zero).
    rest_piece: Vec<bool>,
    /// Lowest and highest position (a beam's window edges; infinite elsewhere).
    floor: Vec<f64>,
    ceil: Vec<f64>,
    first_of_stage: Vec<bool>,
}

/// A node's variables (changes from the current values): position, speed, acceleration, and
/// its clock inside its stage (none at a stage's first node).
struct Node {
    x: usize,
    v: usize,
    a: usize,
    c: Option<usize>,
}

/// Every piece's jerk and duration variables.
struct PieceVars {
    jerk: Vec<usize>,
    dur: Vec<usize>,
}

/// The variables of one step.
struct Vars {
    nodes: Vec<Node>,
    pieces: PieceVars,
}
