//! # arcsim-sequencer
//!
//! Turns resolved arcs (energy layers with angles, windows, irradiation times and ELSTs) and the
//! gantry's limits into one verified delivery: its total time, per-layer and per-transition rows,
//! where the time is lost, and the gantry timeline.
//!
//! Three motions ([`Motion`]), each a controller with its own solver file: *constant* irradiates
//! each layer at one speed, its sweep centred in its window, with the planner's jerk-limited
//! moves between layers (ATOM's model; a servo period puts every move on whole periods); *free*
//! lets the gantry change speed while the beam is on, anywhere inside the window (a solver
//! seeded by the constant-speed schedule, never slower); *one-speed* holds one speed through the
//! whole arc (`one_speed.rs`, the AAPM 2026 one-speed workflow). The layer speeds come from a [`Schedule`]: prescribed by the plan, a bidirectional
//! scan, the shortest found by a search over refined speed grids, or step-and-shoot.
//! [`certify`] bounds every constant-speed schedule from below. Every timeline is verified by
//! integrating its pieces before it is returned.
//!
//! Entry points: [`simulate`] (plan and machine), [`simulate_resolved`] (resolved arcs and
//! limits, for sweeps), [`simulate_with_speeds`] (given speeds); the `_observed` forms report
//! their [`Progress`] to a callback. [`Options::default`] is
//! constant motion with the `scan` schedule; the CLI and the Python package take the machine's
//! controller (see `arcsim-app`'s `SimulateRequest`).

#![warn(missing_docs)]

mod bound;
mod constant;
mod error;
mod free;
mod lost;
mod one_speed;
mod optimal;
mod polish;
mod prescribed;
mod problem;
mod progress;
mod raise;
mod rebalance;
mod scan;
mod schedule;
mod servo;
mod simulate;
mod spots;
mod stops;
mod switching;
mod timeline;
mod types;
mod verify;

pub use error::{Infeasibility, InputError, SequenceError, UnknownName, VerificationError};
pub use lost::{GapClass, LostGroup, LostTime, LostTransition, SwitchKind};
pub use progress::{Observer, Progress};
pub use raise::{move_duration, raised_limits, LIMIT_RAISE_FACTOR};
pub use spots::{spot_timeline, SpotRow};
pub use switching::{
    SmallUpwardStep, SwitchGroup, Switching, SMALL_UPWARD_STEP_MEV, STEP_BANDS_MEV,
};
pub use timeline::{GantryState, Piece, PieceKind, Timeline};
pub use types::{
    ArcEnds, Breakdown, Delivery, LayerRow, Limiter, LimiterCounts, LimitsOut, Margin, Margins,
    Motion, Options, Schedule, SpeedBound, TransitionRow, Violation,
};

pub use bound::{certify, Certificate, CERTIFY_ROUNDS};
pub use simulate::{
    machine_limits, simulate, simulate_observed, simulate_resolved, simulate_resolved_observed,
    simulate_with_speeds,
};
