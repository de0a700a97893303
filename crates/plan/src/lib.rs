//! arcsim-plan: the native arc-plan format (`arcsim-plan/1`) and machine models (`arcsim-machine/1`).
//!
//! Load a plan and a machine, get every problem located by file, arc, control point, layer and field,
//! then [`resolve`] them into the per-layer timings the sequencer consumes. Also: a seeded generator
//! of example plans ([`generate()`]) and the ATOM article cases as plans ([`atom_case_plan`]).
//! The format is documented field by field in `docs/plan-format.md`.

#![warn(missing_docs)]

mod atom;
mod beam;
mod controller;
mod error;
pub mod generate;
mod load;
mod machine;
mod model;
mod plausible;
mod resolve;
pub mod spill;
mod spread;
mod validate;
mod windows;
mod zero;

pub use atom::{atom_case_plan, ATOM_PLACEHOLDER_MIN_ENERGY_MEV};
pub use beam::{
    layer_beam_time, layer_mu, time_spots, BeamModel, LayerBeamTime, PerMuBeam, ScanDistance,
    ScanningBeam, SpotEvent, SpotTimingError, MAX_SPOT_DELIVERIES,
};
pub use controller::{
    Controller, ControllerEvidence, Motion, Schedule, UnknownName, ASSUMED_CONTROLLER_SOURCE,
    CONTROLLER_DECISION_RATIO,
};
pub use error::{fmt_num, PlanError, PlanIssue};
pub use generate::{generate, generate_shaped, to_json, PlanKind, Shape, ShapeError};
pub use load::{load_machine, load_plan, parse_machine, parse_plan};
pub use machine::{
    validate_machine, ACCEL_RANGE_DEG_PER_S2, JERK_RANGE_DEG_PER_S3, MAX_BEAM_TIME_S,
    MAX_ELST_COEFFS, MAX_SWITCH_TIME_S, SERVO_PERIOD_RANGE_S, SPEED_RANGE_DEG_PER_S,
};
pub use model::{
    Arc, ArcPlan, ControlPoint, ElstModel, EnergyLayer, GantryLimitsSpec, Machine, ResolvedArc,
    ResolvedLayer, RotationDirection, Spots, MACHINE_FORMAT, PLAN_FORMAT,
    SAME_ENERGY_TOLERANCE_MEV,
};
pub use plausible::{machine_warnings, plan_warnings, Warning};
pub use resolve::resolve;
pub use spill::{BeamSequence, ContinueSpillIf, LayerBeam, SpillModel, SpotAcrossSpills};
pub use spread::{FitUncertainty, TimingSpread};
pub use validate::{
    validate_plan, ENERGY_RANGE_MEV, MAX_ANGLE_DEG, MAX_LAYER_TIME_S, MAX_PAINTINGS,
    MAX_SPEED_DEG_PER_S, MAX_SPOTS_PER_LAYER, MAX_SPOT_MU, MAX_SPOT_POSITION_MM, MAX_WINDOW_SHARE,
};
pub use windows::{layer_windows, LayerWindow};
pub use zero::{unsigned_zero, without_zero_sign};
