//! Reading: bytes -> DICOM object (dicom-object) -> the plain [`IonPlan`] structs that `convert` turns
//! into an arc plan. Every required attribute is checked here, with its location in the file.
//!
//! - [`file`](mod@file): recognising a DICOM file, parsing it (after the nesting pre-scan) and
//!   checking its SOP class;
//! - [`attr`] and [`access`]: the attributes read, and reading one of them from a data set with the
//!   located error when it is missing or malformed;
//! - [`ion_plan`]: the plain structs the reading fills in;
//! - [`plan`]: the plan's beams and their BeamMeterset; [`control_points`]: one beam's control points
//!   and spots.

pub(crate) mod access;
pub(crate) mod attr;
mod control_points;
pub(crate) mod file;
mod ion_plan;
mod plan;

pub use control_points::MAX_PAINTINGS;
pub use file::{
    check_sop_class, has_dicom_magic, is_dicom_file, parse_bytes, sop_class_of, MAX_NESTING,
    RT_ION_PLAN_STORAGE, RT_PLAN_STORAGE,
};
pub(crate) use ion_plan::{BeamKind, IonBeam, IonLayer, IonPlan, Rotation};
pub(crate) use plan::read_ion_plan;
pub use plan::{CUMULATIVE_WEIGHT_TOLERANCE, MAX_SPOTS};

type Result<T, E = crate::error::DicomImportError> = std::result::Result<T, E>;
