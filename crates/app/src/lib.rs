#![warn(missing_docs)]
//! # arcsim-app
//!
//! What the `arcsim` command does around the engine, as a library, so that every front end (the
//! CLI, the Python package) reads the same files the same way and writes the same result:
//!
//! - [`plan_from_bytes_warned`]: a plan file is native JSON or a DICOM RT Ion Plan, told apart by content
//!   ("DICM" after the 128-byte preamble) or a `.dcm`/`.dicom` extension, not by trust in the name;
//! - [`machine_from_text`] and [`builtin_machine`]: machine models, the ATOM machine built in;
//! - [`SimulateRequest::resolve`]: `simulate`'s defaults (the machine's controller, else the
//!   documented assumption; constant speed where a servo period applies or the schedule is
//!   `prescribed`/`step-and-shoot`), the notes they give rise to and the [`ControllerUsed`];
//! - [`check_period`]: a servo period's range and plausibility;
//! - [`ResultDocument`]: the `arcsim-result/1` JSON document of a simulation;
//! - [`MoveRequest`]: one planner move with `arcsim profile`'s options;
//! - [`resequence_report`]: the `arcsim-resequence/1` report of a re-sequencing;
//! - [`output_file`]: an output file replaced whole, through a temporary file beside it.

mod document;
mod inputs;
mod moves;
pub mod output_file;
mod request;

pub use document::{
    resequence_report, switching_of, OptionsOut, Provenance, ResultDocument, Source,
    RESEQUENCE_FORMAT, RESULT_FORMAT,
};
pub use inputs::{
    builtin_machine, has_dicom_extension, machine_from_text, plan_from_bytes_warned,
    read_plan_file, read_plan_file_warned, sha256_hex, AppError, DEFAULT_MACHINE_JSON,
    DEFAULT_MACHINE_SOURCE,
};
pub use moves::{MoveError, MoveRequest, SolvedMove};
pub use request::{
    check_period, plausibility, refuse_implausible, ControllerUsed, SimulateRequest,
};
