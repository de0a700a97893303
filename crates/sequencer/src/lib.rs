//! # arcsim-sequencer
//!
//! Turns a resolved arc plan into one gantry timeline: each energy layer is irradiated at a
//! constant speed inside its window, centred on its angle; between layers the planner's
//! jerk-limited move covers the remaining gap and lasts at least the energy-layer switching time
//! (ELST). Arcs start and end at rest; a change of arc (rotation direction) is a stop.
//!
//! Choosing the layer speeds is the velocity-scheduling problem ([`Schedule`]): prescribed by the
//! plan, a bidirectional scan that also avoids stops at ELSTs, the shortest found by dynamic
//! programming over refined speed grids (a local search, never worse than the scan), or
//! step-and-shoot.
//! [`certify`] proves a lower bound of every constant-speed schedule (a branch-and-bound over
//! boxes of layer speeds), so a delivery's distance from the best is known.
//! Every timeline is verified by integrating its segments before it is returned.

mod bound;
mod build;
mod error;
mod free;
mod lost;
mod optimal;
mod problem;
mod raise;
mod scan;
mod servo;
mod spots;
mod timeline;
mod types;
mod verify;

pub use error::{Infeasibility, SequenceError};
pub use lost::{GapClass, LostGroup, LostTime, LostTransition, SwitchKind};
pub use raise::{limiter_by_raise, move_duration, raised_limits, LIMIT_RAISE_FACTOR};
pub use spots::{spot_timeline, SpotRow};
pub use timeline::{GantryState, Piece, PieceKind, Timeline};
pub use types::*;

pub use bound::{certify, Certificate, CERTIFY_ROUNDS};
pub use build::{machine_limits, simulate, simulate_resolved, simulate_with_speeds};
