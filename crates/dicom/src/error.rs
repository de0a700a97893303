//! What can go wrong while importing an RT Ion Plan, and where in the file it went wrong.

use std::fmt;
use std::path::PathBuf;

use dicom_core::Tag;

/// Where in the DICOM data set a problem was found. Sequence indices count from 0, in file order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// The top level of the data set.
    Dataset,
    /// An item of IonBeamSequence (300A,03A2).
    Beam {
        /// Index of the beam in IonBeamSequence.
        beam: usize,
        /// Its BeamNumber (300A,00C0), when present.
        number: Option<i64>,
    },
    /// An item of IonControlPointSequence (300A,03A8) inside an ion beam.
    ControlPoint {
        /// Index of the beam in IonBeamSequence.
        beam: usize,
        /// Its BeamNumber (300A,00C0), when present.
        number: Option<i64>,
        /// Index of the control point in the beam's IonControlPointSequence.
        control_point: usize,
    },
    /// An item of TreatmentSessionIonBeamSequence (3008,0021) of a treatment record.
    SessionBeam {
        /// Index of the item.
        beam: usize,
        /// Its ReferencedBeamNumber (300C,0006), when present.
        number: Option<i64>,
    },
    /// An item of IonControlPointDeliverySequence (3008,0041) inside a recorded beam.
    DeliveredControlPoint {
        /// Index of the beam in TreatmentSessionIonBeamSequence.
        beam: usize,
        /// Its ReferencedBeamNumber (300C,0006), when present.
        number: Option<i64>,
        /// Index of the item in the beam's IonControlPointDeliverySequence.
        control_point: usize,
    },
    /// An item of FractionGroupSequence (300A,0070).
    FractionGroup {
        /// Index of the fraction group.
        group: usize,
    },
    /// An item of ReferencedBeamSequence (300C,0004) inside a fraction group.
    ReferencedBeam {
        /// Index of the fraction group.
        group: usize,
        /// Index of the item in its ReferencedBeamSequence.
        item: usize,
    },
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let beam_number =
            |n: &Option<i64>| n.map(|n| format!(" (BeamNumber {n})")).unwrap_or_default();
        match self {
            Location::Dataset => f.write_str("the top-level data set"),
            Location::Beam { beam, number } => {
                write!(f, "IonBeamSequence[{beam}]{}", beam_number(number))
            }
            Location::ControlPoint {
                beam,
                number,
                control_point,
            } => write!(
                f,
                "IonBeamSequence[{beam}]{} > IonControlPointSequence[{control_point}]",
                beam_number(number)
            ),
            Location::SessionBeam { beam, number } => {
                let n = number.map(|n| format!(" (ReferencedBeamNumber {n})"));
                write!(
                    f,
                    "TreatmentSessionIonBeamSequence[{beam}]{}",
                    n.unwrap_or_default()
                )
            }
            Location::DeliveredControlPoint {
                beam,
                number,
                control_point,
            } => {
                let n = number.map(|n| format!(" (ReferencedBeamNumber {n})"));
                write!(
                    f,
                    "TreatmentSessionIonBeamSequence[{beam}]{} > IonControlPointDeliverySequence[{control_point}]",
                    n.unwrap_or_default()
                )
            }
            Location::FractionGroup { group } => write!(f, "FractionGroupSequence[{group}]"),
            Location::ReferencedBeam { group, item } => {
                write!(
                    f,
                    "FractionGroupSequence[{group}] > ReferencedBeamSequence[{item}]"
                )
            }
        }
    }
}

/// A failed import. Every variant names what was expected; tag problems name the attribute keyword,
/// its (gggg,eeee) number and the sequence item it belongs to.
#[derive(Debug, thiserror::Error)]
pub enum DicomImportError {
    /// The file cannot be read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why it cannot be read.
        source: std::io::Error,
    },

    /// The file is not a DICOM file.
    #[error("not a DICOM file: {reason}")]
    NotDicom {
        /// Why it is not a DICOM file.
        reason: String,
    },

    /// The DICOM file is truncated or corrupt.
    #[error("truncated or corrupt DICOM file: {reason}")]
    Unreadable {
        /// What the reader reported.
        reason: String,
    },

    #[error(
        "unsupported transfer syntax {uid}{}: arcsim reads DICOM data sets that are uncompressed \
         (Implicit VR Little Endian, Explicit VR Little or Big Endian) or deflated (Deflated \
         Explicit VR Little Endian, 1.2.840.10008.1.2.1.99); export the plan in one of these",
        name.map(|n| format!(" ({n})")).unwrap_or_else(|| " (not a known transfer syntax)".into())
    )]
    /// The data set is in a transfer syntax arcsim does not read (e.g. compressed).
    UnsupportedTransferSyntax {
        /// The transfer syntax UID.
        uid: String,
        /// The transfer syntax's name, when it is a known one.
        name: Option<&'static str>,
    },

    #[error(
        "refused DICOM file: sequences nested deeper than {limit} levels (level {} is {}{tag}); \
         an RT Ion Plan needs fewer than 10",
        limit + 1,
        keyword.map(|k| format!("{k} ")).unwrap_or_default()
    )]
    /// Sequences nested deeper than [`MAX_NESTING`](crate::MAX_NESTING): refused before parsing so it cannot overflow the stack.
    TooDeeplyNested {
        /// [`MAX_NESTING`](crate::MAX_NESTING).
        limit: usize,
        /// The sequence that goes one level too deep.
        tag: Tag,
        /// The keyword of that sequence, when it is a known attribute.
        keyword: Option<&'static str>,
    },

    #[error(
        "not an RT Ion Plan: SOP class {sop_class_uid}{}; expected RT Ion Plan Storage ({})",
        name.as_ref().map(|n| format!(" ({n})")).unwrap_or_default(),
        crate::read::RT_ION_PLAN_STORAGE
    )]
    /// The SOP class is not RT Ion Plan Storage.
    NotIonPlan {
        /// The file's SOP class UID.
        sop_class_uid: String,
        /// The SOP class's name, when it is a known one.
        name: Option<String>,
    },

    #[error(
        "not an RT Ion Beams Treatment Record: SOP class {sop_class_uid}{}; expected RT Ion Beams \
         Treatment Record Storage ({})",
        name.as_ref().map(|n| format!(" ({n})")).unwrap_or_default(),
        crate::record::RT_ION_BEAMS_TREATMENT_RECORD_STORAGE
    )]
    /// The SOP class is not RT Ion Beams Treatment Record Storage.
    NotIonRecord {
        /// The file's SOP class UID.
        sop_class_uid: String,
        /// The SOP class's name, when it is a known one.
        name: Option<String>,
    },

    #[error(
        "this is a photon plan: SOP class {sop_class_uid} (RT Plan Storage); arcsim imports proton/ion plans, \
         RT Ion Plan Storage ({})",
        crate::read::RT_ION_PLAN_STORAGE
    )]
    /// A photon RT Plan, not an ion plan.
    PhotonPlan {
        /// The file's SOP class UID (RT Plan Storage).
        sop_class_uid: String,
    },

    /// A required attribute is absent.
    #[error("missing {keyword} {tag} in {at}{}", note.map(|n| format!(" ({n})")).unwrap_or_default())]
    MissingTag {
        /// The attribute's keyword (e.g. `BeamNumber`).
        keyword: &'static str,
        /// The attribute's tag.
        tag: Tag,
        /// Where it is missing.
        at: Location,
        /// Why it is needed, when that helps.
        note: Option<&'static str>,
    },

    /// An attribute's value cannot be used.
    #[error("invalid {keyword} {tag} in {at}: {problem}")]
    InvalidValue {
        /// The attribute's keyword (e.g. `BeamNumber`).
        keyword: &'static str,
        /// The attribute's tag.
        tag: Tag,
        /// The sequence item it belongs to.
        at: Location,
        /// What is wrong with the value and what was expected.
        problem: String,
    },

    #[error(
        "inconsistent spots in {at}: ScanSpotMetersetWeights (300A,0396) has {weights} values but \
         NumberOfScanSpotPositions (300A,0392) is {spots}; expected one weight per spot"
    )]
    /// A control point has not one meterset weight per spot.
    SpotCountMismatch {
        /// The control point.
        at: Location,
        /// Number of ScanSpotMetersetWeights values.
        weights: usize,
        /// NumberOfScanSpotPositions.
        spots: usize,
    },

    /// Attributes that contradict each other.
    #[error("inconsistent {keyword} {tag} in {at}: {problem}")]
    Inconsistent {
        /// The attribute's keyword (e.g. `BeamNumber`).
        keyword: &'static str,
        /// The attribute's tag.
        tag: Tag,
        /// The sequence item it belongs to.
        at: Location,
        /// What contradicts what.
        problem: String,
    },

    #[error(
        "no BeamMeterset (300A,0086) for {at}: no FractionGroupSequence (300A,0070) > ReferencedBeamSequence \
         (300C,0004) item has ReferencedBeamNumber (300C,0006) {number}"
    )]
    /// A beam that no fraction group gives a BeamMeterset.
    NoBeamMeterset {
        /// The beam.
        at: Location,
        /// Its BeamNumber.
        number: i64,
    },

    #[error(
        "two beams have BeamNumber (300A,00C0) {number}: IonBeamSequence[{first}] and \
         IonBeamSequence[{second}]; expected a different number for each beam, since \
         ReferencedBeamNumber (300C,0006) in the fraction group refers to a beam by its number"
    )]
    /// Two beams share a BeamNumber.
    DuplicateBeamNumber {
        /// The shared BeamNumber.
        number: i64,
        /// Index of the first beam with that number.
        first: usize,
        /// Index of the beam that repeats it.
        second: usize,
    },

    #[error(
        "too many spots: the plan has {spots} spots after repainting (NumberOfScanSpotPositions \
         (300A,0392) x NumberOfPaintings (300A,039A), summed over all energy layers); at most {limit} \
         are imported"
    )]
    /// More spots than [`MAX_SPOTS`](crate::MAX_SPOTS): refused to bound the work of timing the plan.
    TooManySpots {
        /// Spots after repainting, over all imported beams.
        spots: u64,
        /// [`MAX_SPOTS`](crate::MAX_SPOTS).
        limit: u64,
    },

    /// No ion beam can be imported.
    #[error("the plan has no ion beam to import: {reason}")]
    NoIonBeams {
        /// Why no beam is importable.
        reason: String,
    },

    #[error(
        "{keyword} {tag} in {at} is {number}, but no item of IonBeamSequence (300A,03A2) has \
         BeamNumber {number} (the beams are {}); expected the number of a beam of this plan",
        beams.iter().map(ToString::to_string).collect::<Vec<_>>().join(", ")
    )]
    /// A reference to a BeamNumber no beam has.
    UnknownBeamReference {
        /// The attribute's keyword (e.g. `BeamNumber`).
        keyword: &'static str,
        /// The attribute's tag.
        tag: Tag,
        /// The sequence item it belongs to.
        at: Location,
        /// The referenced BeamNumber.
        number: i64,
        /// The BeamNumbers of the plan's beams, in file order.
        beams: Vec<i64>,
    },

    #[error(
        "the imported plan breaks the arcsim plan rules (arcs, control points and layers counted \
         as imported, from 0): {}",
        issues.join("; ")
    )]
    /// The converted plan fails arcsim's plan validation.
    InvalidPlan {
        /// Every rule broken, one message each.
        issues: Vec<String>,
    },
}

/// Something the import did that the user should know of, though the plan was imported. Each names
/// the attribute and where in the file it was found.
#[derive(Debug, Clone, PartialEq)]
pub enum ImportWarning {
    /// GantryAngle (300A,011E) 360, outside DICOM's [0, 360), read as 0.
    GantryAngle360 {
        /// The control point.
        at: Location,
    },
    /// The plan has several fraction groups: only the first one's beams were imported.
    OtherFractionGroups {
        /// FractionGroupNumber (300A,0071) of the imported group (its index when absent).
        imported: String,
        /// The other groups: FractionGroupNumber (or index) and the BeamNumbers they reference.
        left_out: Vec<(String, Vec<i64>)>,
    },
}

impl fmt::Display for ImportWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ImportWarning::GantryAngle360 { at } => write!(
                f,
                "GantryAngle (300A,011E) 360 in {at} read as 0 (DICOM angles are in [0, 360))"
            ),
            ImportWarning::OtherFractionGroups { imported, left_out } => {
                let others: Vec<String> = left_out
                    .iter()
                    .map(|(group, beams)| {
                        let beams: Vec<String> = beams.iter().map(ToString::to_string).collect();
                        if beams.is_empty() {
                            format!("fraction group {group} (no beams)")
                        } else {
                            format!("fraction group {group} (beams {})", beams.join(", "))
                        }
                    })
                    .collect();
                write!(
                    f,
                    "FractionGroupSequence (300A,0070) has {} fraction groups: imported only the \
                     first, fraction group {imported}; left out {}",
                    left_out.len() + 1,
                    others.join(", ")
                )
            }
        }
    }
}
