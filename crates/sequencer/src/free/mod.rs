//! Free motion: the gantry may change speed while a layer is irradiated.
//!
//! ATOM's model (and arcsim's `constant` motion) irradiates each layer at one constant speed,
//! its sweep centred on the layer's angle, with zero acceleration at every beam-on and beam-off.
//! The machine is bound by less: layer `k` is irradiated for `t_k` seconds while the gantry is
//! anywhere inside the window `[θ_k - w_k/2, θ_k + w_k/2]`; at least the ELST passes between one
//! beam-off and the next beam-on; and the whole delivery is one jerk-, acceleration- and
//! speed-limited motion that never reverses inside an arc. Every constant-speed timeline is a
//! free one, so free motion is never slower.
//!
//! The solver (per arc) is a direct transcription solved by sequential linear programming:
//! 1. Two *seeds*: the constant-speed schedule and the anchored moves (layers between the long
//!    switches flown along one fastest move, [`solve`]); each is refined (steps 2–4, side by
//!    side) and the shortest delivery kept.
//! 2. The seed is cut into stages (run-up, beams, switches, braking) of constant-jerk pieces
//!    with free durations ([`transcribe`]); the states at the joins, the jerks and the durations
//!    are the variables, the limits, windows, irradiation times and ELSTs the constraints, the
//!    total duration the objective.
//! 3. Each step solves that problem linearised inside a trust region, as one banded linear
//!    programme ([`lp`], an interior-point method whose Newton steps cost O(pieces)), and a
//!    corrector; a step is kept when the exact delivery built from it is shorter ([`refine`]).
//! 4. The exact delivery: every beam and switch re-flown as a time-optimal full-state move
//!    between the transcript's states (rsruckig, [`mover`]), or on the transcript's own pieces
//!    where no such move exists to rounding; every move re-integrated and checked.
//! 5. Smoothing ([`smooth`](mod@smooth)): the total time is the only objective, so where beams and ELSTs
//!    set the clock the result may chatter (−J, +J, −J within a tenth of a second); stretches
//!    between beam edges are re-flown as single Ruckig moves of the same duration between the
//!    same states, where every beam stays in its window, choosing those that leave the fewest
//!    short jerk reversals; a move that still reverses is flown again with its neighbours as the
//!    least-jerk move through their beam edges ([`least_jerk`], a small linear programme at fixed
//!    edge times). Times are unchanged (the transitions keep the solver's labels); a smoothed
//!    timeline that fails verification is replaced by the unsmoothed one.
//!
//! The result is a local optimum of the transcribed problem. An independent optimiser (direct
//! multiple shooting with IPOPT, `tests/oracle/` of the repository) gets within 0.05 % of it on
//! the ATOM article cases and the bundled prostate and two-arc plans, and finds shorter
//! deliveries on the bundled lung (0.12 %) and 722-layer head-neck (0.29 %), where many steps'
//! exact builds fail; the tests also check it against an exhaustive search on small arcs and
//! against the problem's own laws (never slower than constant speed; a higher limit never costs
//! more than solver noise on the ATOM cases).
//!
//! [`bound`] proves a lower bound of every free motion (the certificate of `--certify`): rigorous
//! but loose, as it drops the jerk limit.

mod assemble;
mod bound;
mod deliver;
mod least_jerk;
mod lp;
mod mover;
mod refine;
mod smooth;
mod solve;
mod transcribe;

use assemble::{assemble, from_constant};
pub(crate) use bound::plan_lower_bound;
pub(crate) use deliver::simulate_free;
use smooth::smooth;
use solve::{solve_arc, End, Start};

/// How arc `ai` starts and ends: both at rest, or with free ends a run-up before its first beam
/// and braking after its last unless it is the plan's `last` arc.
pub(crate) fn arc_ends(ends: crate::ArcEnds, last: bool) -> (Start, End) {
    match ends {
        crate::ArcEnds::Rest => (Start::Rest, End::Rest),
        crate::ArcEnds::Free if last => (Start::RunUp, End::Free),
        crate::ArcEnds::Free => (Start::RunUp, End::Brake),
    }
}
