#![warn(missing_docs)]
//! DICOM RT Ion Plan import into arcsim arc plans (`arcsim-plan/1`), the write-back of a
//! re-sequenced plan, and DICOM RT Ion Beams Treatment Records read as delivery logs.
//!
//! [`read_rt_ion_plan`] reads an RT Ion Plan file (SOP class 1.2.840.10008.5.1.4.1.1.481.8) with
//! dicom-object and converts it into an [`ArcPlan`]; [`is_dicom_file`] recognises a DICOM file by its
//! content (128-byte preamble + "DICM"), whatever its extension. Failures are [`DicomImportError`]s
//! that name the attribute keyword, its (gggg,eeee) tag and the beam / control-point index;
//! [`import_rt_ion_plan_from_bytes`] also returns the [`ImportWarning`]s (a GantryAngle of 360,
//! fraction groups left out), which the other functions drop. Uncompressed and deflated
//! (1.2.840.10008.1.2.1.99) data sets are read.
//!
//! # Conversion rules
//!
//! - **Layers.** Each control point whose ScanSpotMetersetWeights (300A,0396) sum above 0 is one
//!   energy layer (usually the first of a pair; its successor carries zero weights and is skipped).
//!   NumberOfScanSpotPositions (300A,0392) must equal the number of weights. GantryAngle (300A,011E),
//!   GantryRotationDirection (300A,011F), NominalBeamEnergy (300A,0114) and NumberOfPaintings
//!   (300A,039A) are inherited from earlier control points of the same beam when absent.
//!   GantryAngle must be in [0, 360) (360 is read as 0 with a warning), and each step between
//!   control points must go the way GantryRotationDirection says (CW: increasing).
//! - **Fraction groups.** Only the beams of the first item of FractionGroupSequence (300A,0070) are
//!   imported; beams only other groups reference are left out with a warning. Every
//!   ReferencedBeamNumber must be the BeamNumber of a beam.
//! - **MU.** Spot MU = weight x BeamMeterset / FinalCumulativeMetersetWeight, BeamMeterset (300A,0086)
//!   taken from the first FractionGroupSequence > ReferencedBeamSequence item whose
//!   ReferencedBeamNumber is the beam's number; rounded to [`MU_RESOLUTION`] (1e-9 MU) so the JSON
//!   written from the plan reads back to exactly the same numbers. One native spot per DICOM spot.
//!   FinalCumulativeMetersetWeight must equal the sum of the beam's weights within
//!   [`CUMULATIVE_WEIGHT_TOLERANCE`] (relative).
//! - **Positions.** ScanSpotPositionMap (300A,0394), x, y in mm per spot, becomes `spots.positions_mm`
//!   in the file's spot order, rounded to [`POSITION_RESOLUTION_MM`] (1e-6 mm). It must hold 2 finite
//!   values per spot, within 10,000 mm ([`arcsim_plan::MAX_SPOT_POSITION_MM`]). A layer whose control
//!   point has no map gets no positions (the `per_mu` beam model does not need them).
//! - **Paintings.** The weights are the total over all paintings (as DICOM defines them), so the MU of
//!   a spot is its total and NumberOfPaintings N becomes `spots.paintings` (absent when 1): the beam
//!   model delivers MU / N per spot in each of N passes over the spot list, which is not repeated in
//!   the plan. NumberOfPaintings must be 1 to [`MAX_PAINTINGS`] (1000: delivery systems repaint a
//!   layer a few to a few dozen times), a layer may hold at most 1,000,000 spots
//!   ([`arcsim_plan::MAX_SPOTS_PER_LAYER`]) and the whole plan at most [`MAX_SPOTS`] (5,000,000) spot
//!   deliveries (spot count x paintings, summed over the layers).
//! - **Single values.** BeamNumber, GantryAngle, NominalBeamEnergy, BeamMeterset and the other
//!   attributes that hold one number are refused when they hold several (`10\20`), rather than read
//!   as their first value. Every BeamNumber must be different (the fraction group refers to beams by
//!   number).
//! - **Control points.** Consecutive layers at the same gantry angle form one native control point
//!   (several layers); a new angle starts a new one.
//! - **Arcs.** Beams are taken in BeamNumber order; setup beams and beams without spots are left out
//!   (and listed in the plan description). A DYNAMIC beam is one arc, whose direction follows the
//!   declared rotation of each step (the shortest way where it says NONE); it is split into sub-arcs
//!   where the rotation reverses. A STATIC beam is delivered at rest (`window_deg: 0`).
//!   Consecutive STATIC beams are grouped into one arc while the angle
//!   keeps progressing in one direction, each step taken the shorter way round (a step of exactly
//!   180 degrees counts as CW); a static beam at the same angle as the previous one adds layers to its
//!   control point, and a reversal or a DYNAMIC beam starts a new arc. Without BeamType a beam that
//!   stays at one angle counts as STATIC.
//! - **Angles** are unwrapped along each arc (350 -> 370 for CW across 0) and an arc that would go
//!   below 0 is shifted up by 360. An arc that never moves is CW unless its control points say CC.
//!
//! The result is checked with [`arcsim_plan::validate_plan`]; see `docs/dicom-import.md`.
//!
//! [`write_resequenced`] writes a plan whose layers were reordered inside their control points
//! (`arcsim resequence`) back as an RT Ion Plan: the original file with the layers' control points
//! in the new order, a new SOPInstanceUID referencing the original, unapproved.
//!
//! [`read_treatment_record`] reads an RT Ion Beams Treatment Record (SOP class
//! 1.2.840.10008.5.1.4.1.1.481.9) as the beam-on intervals of its control points, and
//! [`read_delivery_log`] reads either a record or a CSV log as an `arcsim_log::DeliveryLog`;
//! [`treatment_record_bytes`] writes one (`arcsim simulate --record`). The rules are in the
//! `record` module and `docs/records.md`.
//!
//! A file whose sequences nest deeper than [`MAX_NESTING`] (64) levels is refused before it is parsed
//! (dicom-object parses nested sequences recursively: thousands of levels would overflow the stack).

mod convert;
mod error;
mod read;
mod record;
mod write;

use std::path::Path;

use arcsim_plan::ArcPlan;
use dicom_object::InMemDicomObject;

pub use convert::{MU_RESOLUTION, POSITION_RESOLUTION_MM, SAME_ANGLE_TOLERANCE_DEG};
pub use error::{DicomImportError, ImportWarning, Location};
pub use read::{
    has_dicom_magic, is_dicom_file, CUMULATIVE_WEIGHT_TOLERANCE, MAX_NESTING, MAX_PAINTINGS,
    MAX_SPOTS, RT_ION_PLAN_STORAGE, RT_PLAN_STORAGE,
};
pub use record::{
    read_delivery_log, read_treatment_record, sop_instance_uid_of, treatment_record_bytes,
    treatment_record_from_bytes, BeamOnInterval, ReadLogError, RecordStart, RecordedBeam,
    TreatmentRecord, RT_ION_BEAMS_TREATMENT_RECORD_STORAGE,
};
pub use write::{write_resequenced, ResequencedDicom, WriteError, RELATIONSHIP_TO_ORIGINAL};

/// Name given to a plan whose file has neither RTPlanLabel nor RTPlanName (and no file name).
pub const DEFAULT_PLAN_NAME: &str = "dicom-rt-ion-plan";

/// An imported plan with the warnings of its import (see [`ImportWarning`]).
#[derive(Debug, Clone)]
pub struct Imported {
    /// The imported arc plan.
    pub plan: ArcPlan,
    /// What the import did that the user should know of.
    pub warnings: Vec<ImportWarning>,
}

/// Reads the RT Ion Plan file at `path` and converts it into an arc plan. The plan is named after
/// RTPlanLabel, else RTPlanName, else the file stem. The warnings of the import are dropped: use
/// [`import_rt_ion_plan_from_bytes`] to get them.
pub fn read_rt_ion_plan(path: impl AsRef<Path>) -> Result<ArcPlan, DicomImportError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| DicomImportError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned());
    import(&bytes, stem.as_deref().unwrap_or(DEFAULT_PLAN_NAME)).map(|i| i.plan)
}

/// Converts a complete RT Ion Plan file held in memory (preamble, "DICM", meta group, data set).
/// The warnings of the import are dropped.
pub fn read_rt_ion_plan_from_bytes(bytes: &[u8]) -> Result<ArcPlan, DicomImportError> {
    import(bytes, DEFAULT_PLAN_NAME).map(|i| i.plan)
}

/// As [`read_rt_ion_plan_from_bytes`], with the warnings of the import, naming the plan
/// `fallback_name` (usually the file stem) when the file has neither RTPlanLabel nor RTPlanName;
/// for callers that read the file themselves.
pub fn import_rt_ion_plan_from_bytes(
    bytes: &[u8],
    fallback_name: &str,
) -> Result<Imported, DicomImportError> {
    import(bytes, fallback_name)
}

/// Converts an RT Ion Plan data set (no file meta group); its SOPClassUID (0008,0016) must be present.
pub fn rt_ion_plan_from_dataset(ds: &InMemDicomObject) -> Result<ArcPlan, DicomImportError> {
    read::check_sop_class(
        ds.get(dicom_dictionary_std::tags::SOP_CLASS_UID)
            .and_then(|e| e.to_str().ok())
            .as_deref(),
    )?;
    convert_dataset(ds, DEFAULT_PLAN_NAME).map(|i| i.plan)
}

fn import(bytes: &[u8], fallback_name: &str) -> Result<Imported, DicomImportError> {
    let obj = read::parse_bytes(bytes)?;
    read::check_sop_class(read::sop_class_of(&obj).as_deref())?;
    convert_dataset(&obj, fallback_name)
}

fn convert_dataset(
    ds: &InMemDicomObject,
    fallback_name: &str,
) -> Result<Imported, DicomImportError> {
    let mut warnings = Vec::new();
    let ion_plan = read::read_ion_plan(ds, &mut warnings)?;
    let plan = convert::to_arc_plan(&ion_plan, fallback_name);
    // The caller names the file; an issue is located in the imported plan (arc, control point, layer).
    let issues = arcsim_plan::validate_plan(&plan, "");
    if issues.is_empty() {
        Ok(Imported { plan, warnings })
    } else {
        Err(DicomImportError::InvalidPlan {
            issues: issues
                .iter()
                .map(|i| format!("{}: {}", i.location(), i.message))
                .collect(),
        })
    }
}
