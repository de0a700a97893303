//! arcsim-plan: the native arc-plan format (`arcsim-plan/1`) and machine models (`arcsim-machine/1`).
//!
//! Load a plan and a machine, get every problem located by file, arc, control point, layer and field,
//! then [`resolve`] them into the per-layer timings the sequencer consumes. Also: a seeded generator
//! of example plans ([`generate()`]) and the ATOM article cases as plans ([`atom_case_plan`]).
//! The format is documented field by field in `docs/plan-format.md`.

mod atom;
mod error;
pub mod generate;
mod load;
mod machine;
pub mod model;
mod resolve;
mod validate;

pub use atom::{atom_case_plan, ATOM_PLACEHOLDER_MIN_ENERGY_MEV};
pub use error::{PlanError, PlanIssue};
pub use generate::{generate, to_json, PlanKind};
pub use load::{load_machine, load_plan, parse_machine, parse_plan};
pub use machine::validate_machine;
pub use model::*;
pub use resolve::{layer_irradiation_time_s, resolve, spots_irradiation_time_s};
pub use validate::{validate_plan, ENERGY_RANGE_MEV};
