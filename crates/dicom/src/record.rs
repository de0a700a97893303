//! DICOM RT Ion Beams Treatment Records (SOP class 1.2.840.10008.5.1.4.1.1.481.9): what the
//! oncology information system stores of every delivered fraction, read as the beam-on intervals
//! of its layers.
//!
//! # Reading rules
//! - Each item of TreatmentSessionIonBeamSequence (3008,0021) is a beam as delivered; a beam
//!   delivered in two parts (interrupted, then resumed) is two items, each read on its own.
//! - Each item of its IonControlPointDeliverySequence (3008,0041) gives a time
//!   (TreatmentControlPointDate (3008,0024) and TreatmentControlPointTime (3008,0025)), the
//!   beam's cumulative DeliveredMeterset (3008,0044), GantryAngle (300A,011E) and
//!   NominalBeamEnergy (300A,0114). The angle and the energy are inherited from earlier items of
//!   the beam when absent, and a date from the item before it; a time never is.
//! - The beam is on between two consecutive items where the delivered meterset grows: one
//!   interval, the meterset's growth its MU. Delivery systems write a layer as a pair of items
//!   (its start and its end); a layer interrupted inside is two intervals.
//! - Items must come in delivery order: a time earlier than its predecessor's, or a delivered
//!   meterset that shrinks, is refused with the item's index. An item that repeats its
//!   predecessor exactly (same ReferencedControlPointIndex, time and meterset) is dropped and
//!   counted.
//! - Two beams may not be on at once. Times count from the record's earliest control point;
//!   dates make a delivery across midnight continuous, and all of a record's times share one
//!   zone (TimezoneOffsetFromUTC (0008,0201) when given), so no zone is needed.
//! - Times come at the resolution the system wrote them (whole seconds to microseconds):
//!   [`TreatmentRecord::time_resolution_s`] is the coarsest one seen, which bounds every edge's
//!   error.

use std::path::Path;

use arcsim_log::BeamInterval;
use dicom_dictionary_std::uids;
use dicom_object::InMemDicomObject;

use crate::error::{DicomImportError, Location};
use crate::read::access::{float_at, int_at, invalid, items, missing, required, text};
use crate::read::attr::{
    DELIVERED_METERSET, GANTRY_ANGLE, ION_CONTROL_POINT_DELIVERY_SEQUENCE, NOMINAL_BEAM_ENERGY,
    REFERENCED_BEAM_NUMBER, REFERENCED_CONTROL_POINT_INDEX, REFERENCED_RT_PLAN_SEQUENCE,
    REFERENCED_SOP_INSTANCE_UID, SOP_CLASS_UID, SOP_INSTANCE_UID, TREATMENT_CONTROL_POINT_DATE,
    TREATMENT_CONTROL_POINT_TIME, TREATMENT_SESSION_ION_BEAM_SEQUENCE,
    TREATMENT_TERMINATION_STATUS,
};
use crate::read::file::{parse_bytes, sop_class_name, sop_class_of};

mod time;
mod write;

pub use write::{treatment_record_bytes, RecordStart};

use time::{parse_date, parse_time};

/// A delivery log that cannot be read, or a record of another plan.
#[derive(Debug, thiserror::Error)]
pub enum ReadLogError {
    /// A CSV log that cannot be read.
    #[error(transparent)]
    Csv(#[from] arcsim_log::LogError),
    /// A treatment record that cannot be read.
    #[error("{file}: {source}")]
    Record {
        /// The record as named to the reader.
        file: String,
        /// What is wrong in it.
        source: DicomImportError,
    },
    /// A record whose reference names another plan.
    #[error("{file}: the record's ReferencedRTPlanSequence (300C,0002) names plan {recorded}, not {plan} (SOPInstanceUID of the plan given); expected a record of this plan")]
    OtherPlan {
        /// The record as named to the reader.
        file: String,
        /// The plan the record references.
        recorded: String,
        /// The plan given.
        plan: String,
    },
    /// A record without any beam-on interval.
    #[error("{file}: no control point pair delivers any meterset (DeliveredMeterset (3008,0044) never grows); expected a record of a delivered fraction")]
    NothingDelivered {
        /// The record as named to the reader.
        file: String,
    },
}

/// Reads the delivery log at `path`: a folder as an IBA-style log ([`arcsim_log::iba`]), a DICOM file (a regular file within the log size limit,
/// recognised by its content) as an RT Ion Beams Treatment Record, else a CSV log through `map`
/// (a FIFO is read as a CSV). A record whose ReferencedRTPlanSequence names another plan than
/// `plan_uid` (the SOPInstanceUID of the plan it is compared with, when that is a DICOM file) is
/// refused.
pub fn read_delivery_log(
    path: &Path,
    map: &arcsim_log::ColumnMap,
    plan_uid: Option<&str>,
) -> Result<arcsim_log::DeliveryLog, ReadLogError> {
    // A folder is an IBA-style log (beam folders of map_record files).
    if arcsim_log::iba::is_iba_folder(path) {
        return Ok(arcsim_log::iba::read_iba_log(path)?.to_delivery_log()?);
    }
    // Only a regular file is looked into: a FIFO's first bytes would be consumed by the look.
    // One above the size limit is left to the CSV reader, which refuses it by its size.
    let small_file =
        std::fs::metadata(path).is_ok_and(|m| m.is_file() && m.len() <= arcsim_log::MAX_LOG_BYTES);
    if !(small_file && crate::read::is_dicom_file(path)) {
        return Ok(arcsim_log::read_log(path, map)?);
    }
    let file = path.display().to_string();
    let record = read_treatment_record(path).map_err(|source| ReadLogError::Record {
        file: file.clone(),
        source,
    })?;
    if let (Some(recorded), Some(plan)) = (&record.referenced_plan_uid, plan_uid) {
        if recorded != plan {
            return Err(ReadLogError::OtherPlan {
                file,
                recorded: recorded.clone(),
                plan: plan.to_string(),
            });
        }
    }
    record
        .to_log(&file)
        .ok_or(ReadLogError::NothingDelivered { file })
}

impl TreatmentRecord {
    /// Every beam's intervals in time order, as a delivery log of intervals
    /// ([`arcsim_log::DeliveryLog::from_intervals`]); `None` without any.
    pub fn to_log(&self, source: &str) -> Option<arcsim_log::DeliveryLog> {
        let mut all: Vec<BeamInterval> = self
            .beams
            .iter()
            .flat_map(|b| &b.intervals)
            .map(|i| i.interval)
            .collect();
        all.sort_by(|a, b| a.start_s.total_cmp(&b.start_s));
        arcsim_log::DeliveryLog::from_intervals(source, &all, self.time_resolution_s)
    }
}

/// SOP class UID of RT Ion Beams Treatment Record Storage.
pub const RT_ION_BEAMS_TREATMENT_RECORD_STORAGE: &str = uids::RT_ION_BEAMS_TREATMENT_RECORD_STORAGE;

/// A treatment record read: the beam-on intervals of every beam delivered.
#[derive(Debug, Clone, PartialEq)]
pub struct TreatmentRecord {
    /// SOPInstanceUID (0008,0018) of the record.
    pub sop_instance_uid: Option<String>,
    /// The plan delivered: ReferencedSOPInstanceUID (0008,1155) of the first item of
    /// ReferencedRTPlanSequence (300C,0002).
    pub referenced_plan_uid: Option<String>,
    /// The beams in file order.
    pub beams: Vec<RecordedBeam>,
    /// The coarsest resolution of the record's times, s (1 for whole seconds).
    pub time_resolution_s: f64,
    /// Control points dropped as exact repeats of their predecessor.
    pub repeats_dropped: usize,
}

/// One item of TreatmentSessionIonBeamSequence.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedBeam {
    /// Its ReferencedBeamNumber (300C,0006), when given.
    pub beam_number: Option<i64>,
    /// TreatmentTerminationStatus (3008,002A), e.g. NORMAL, OPERATOR, MACHINE.
    pub termination: Option<String>,
    /// The beam-on intervals in time order.
    pub intervals: Vec<BeamOnInterval>,
}

/// The beam on between two consecutive control points of a recorded beam: the interval (times
/// in s from the record's earliest control point, angles in degrees as recorded, 0 to 360) and
/// where it starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamOnInterval {
    /// Index (in IonControlPointDeliverySequence) of the control point it starts at.
    pub control_point: usize,
    /// Beam on and off, angles, energy and the meterset delivered in it (the growth of
    /// DeliveredMeterset).
    pub interval: BeamInterval,
}

/// Reads the treatment record at `path`.
pub fn read_treatment_record(path: impl AsRef<Path>) -> Result<TreatmentRecord, DicomImportError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| DicomImportError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    treatment_record_from_bytes(&bytes)
}

/// Reads a treatment record held in memory (preamble, "DICM", meta group, data set).
pub fn treatment_record_from_bytes(bytes: &[u8]) -> Result<TreatmentRecord, DicomImportError> {
    let obj = parse_bytes(bytes)?;
    match sop_class_of(&obj)
        .as_deref()
        .map(|u| u.trim_end_matches(['\0', ' ']))
    {
        Some(RT_ION_BEAMS_TREATMENT_RECORD_STORAGE) => {}
        Some(other) => {
            return Err(DicomImportError::NotIonRecord {
                sop_class_uid: other.to_string(),
                name: sop_class_name(other),
            });
        }
        None => {
            return Err(missing(
                SOP_CLASS_UID,
                Location::Dataset,
                Some("cannot tell whether this is an RT Ion Beams Treatment Record"),
            ))
        }
    }
    record_from_dataset(&obj)
}

/// The SOPInstanceUID of a DICOM file held in memory (a plan as it was read, to check a record's
/// reference), or `None` for anything else (a JSON plan).
pub fn sop_instance_uid_of(bytes: &[u8]) -> Option<String> {
    if !crate::read::has_dicom_magic(bytes) {
        return None;
    }
    let obj = parse_bytes(bytes).ok()?;
    text(&obj, SOP_INSTANCE_UID)
}

/// One control point as read, its inherited values filled in.
#[derive(Clone, Copy)]
struct Point {
    index: usize,
    reference: Option<i64>,
    days: i64,
    time_s: f64,
    delivered: f64,
    angle_deg: f64,
    energy_mev: Option<f64>,
}

fn record_from_dataset(ds: &InMemDicomObject) -> Result<TreatmentRecord, DicomImportError> {
    let referenced_plan_uid = items(ds, REFERENCED_RT_PLAN_SEQUENCE)
        .and_then(|i| i.first())
        .and_then(|i| text(i, REFERENCED_SOP_INSTANCE_UID));
    let beam_items = required(
        items(ds, TREATMENT_SESSION_ION_BEAM_SEQUENCE),
        TREATMENT_SESSION_ION_BEAM_SEQUENCE,
        Location::Dataset,
    )?;
    let mut resolution = 0.0f64;
    let mut repeats = 0;
    let mut read = Vec::with_capacity(beam_items.len());
    for (b, item) in beam_items.iter().enumerate() {
        let at = Location::SessionBeam {
            beam: b,
            number: None,
        };
        let number = int_at(item, REFERENCED_BEAM_NUMBER, at)?;
        let at = Location::SessionBeam { beam: b, number };
        let points = read_points(item, b, number, &mut resolution, &mut repeats)?;
        read.push((number, text(item, TREATMENT_TERMINATION_STATUS), points, at));
    }
    // Times from the earliest control point, whole days apart counted exactly.
    let origin = read
        .iter()
        .flat_map(|(_, _, p, _)| p.iter())
        .map(|p| (p.days, p.time_s))
        .min_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let Some((day0, t0)) = origin else {
        return Err(missing(
            ION_CONTROL_POINT_DELIVERY_SEQUENCE,
            Location::Dataset,
            Some("no beam has a delivered control point"),
        ));
    };
    let clock = |p: &Point| (p.days - day0) as f64 * 86_400.0 + (p.time_s - t0);
    let mut beams = Vec::with_capacity(read.len());
    for (number, termination, points, at) in read {
        let mut intervals = Vec::new();
        for w in points.windows(2) {
            let mu = w[1].delivered - w[0].delivered;
            if mu <= 0.0 {
                continue;
            }
            let energy_mev = required(w[0].energy_mev, NOMINAL_BEAM_ENERGY, cp_at(at, w[0].index))?;
            intervals.push(BeamOnInterval {
                control_point: w[0].index,
                interval: BeamInterval {
                    start_s: clock(&w[0]),
                    end_s: clock(&w[1]),
                    angle_start_deg: w[0].angle_deg,
                    angle_end_deg: w[1].angle_deg,
                    energy_mev,
                    mu,
                },
            });
        }
        beams.push(RecordedBeam {
            beam_number: number,
            termination,
            intervals,
        });
    }
    check_no_overlap(&beams)?;
    Ok(TreatmentRecord {
        sop_instance_uid: text(ds, SOP_INSTANCE_UID),
        referenced_plan_uid,
        beams,
        time_resolution_s: resolution,
        repeats_dropped: repeats,
    })
}

fn cp_at(beam_at: Location, control_point: usize) -> Location {
    match beam_at {
        Location::SessionBeam { beam, number } => Location::DeliveredControlPoint {
            beam,
            number,
            control_point,
        },
        other => other,
    }
}

/// The control points of session beam `b`, in delivery order, checked.
fn read_points(
    item: &InMemDicomObject,
    b: usize,
    number: Option<i64>,
    resolution: &mut f64,
    repeats: &mut usize,
) -> Result<Vec<Point>, DicomImportError> {
    let beam_at = Location::SessionBeam { beam: b, number };
    let cps = required(
        items(item, ION_CONTROL_POINT_DELIVERY_SEQUENCE),
        ION_CONTROL_POINT_DELIVERY_SEQUENCE,
        beam_at,
    )?;
    let mut out: Vec<Point> = Vec::with_capacity(cps.len());
    for (c, cp) in cps.iter().enumerate() {
        let at = cp_at(beam_at, c);
        let prev = out.last().copied();
        let days = match text(cp, TREATMENT_CONTROL_POINT_DATE) {
            Some(d) => parse_date(&d).map_err(|e| invalid(TREATMENT_CONTROL_POINT_DATE, at, e))?,
            None => match prev {
                Some(p) => p.days,
                None => return Err(missing(TREATMENT_CONTROL_POINT_DATE, at, None)),
            },
        };
        let time = required(
            text(cp, TREATMENT_CONTROL_POINT_TIME),
            TREATMENT_CONTROL_POINT_TIME,
            at,
        )?;
        let tod = parse_time(&time).map_err(|e| invalid(TREATMENT_CONTROL_POINT_TIME, at, e))?;
        *resolution = resolution.max(tod.resolution_s);
        let delivered = required(
            float_at(cp, DELIVERED_METERSET, at)?,
            DELIVERED_METERSET,
            at,
        )?;
        if !(delivered.is_finite() && delivered >= 0.0) {
            return Err(invalid(
                DELIVERED_METERSET,
                at,
                format!("{delivered}; expected a finite meterset >= 0"),
            ));
        }
        let angle_deg = match (float_at(cp, GANTRY_ANGLE, at)?, prev) {
            (Some(a), _) if a.is_finite() && (0.0..=360.0).contains(&a) => a,
            (Some(a), _) => {
                return Err(invalid(
                    GANTRY_ANGLE,
                    at,
                    format!("{a}; expected degrees from 0 to 360"),
                ))
            }
            (None, Some(p)) => p.angle_deg,
            (None, None) => return Err(missing(GANTRY_ANGLE, at, None)),
        };
        let energy_mev = match float_at(cp, NOMINAL_BEAM_ENERGY, at)? {
            Some(e) if e.is_finite() && e > 0.0 => Some(e),
            Some(e) => {
                return Err(invalid(
                    NOMINAL_BEAM_ENERGY,
                    at,
                    format!("{e}; expected MeV > 0"),
                ))
            }
            None => prev.and_then(|p| p.energy_mev),
        };
        let point = Point {
            index: c,
            reference: int_at(cp, REFERENCED_CONTROL_POINT_INDEX, at)?,
            days,
            time_s: tod.seconds,
            delivered,
            angle_deg,
            energy_mev,
        };
        if let Some(p) = prev {
            let dt = (point.days - p.days) as f64 * 86_400.0 + (point.time_s - p.time_s);
            if p.reference == point.reference && dt == 0.0 && p.delivered == point.delivered {
                *repeats += 1;
                continue;
            }
            if dt < 0.0 {
                return Err(invalid(
                    TREATMENT_CONTROL_POINT_TIME,
                    at,
                    format!(
                        "{time} is {:.6} s before the previous control point's (IonControlPointDeliverySequence[{}]); expected control points in delivery order",
                        -dt, p.index
                    ),
                ));
            }
            if point.delivered < p.delivered {
                return Err(invalid(
                    DELIVERED_METERSET,
                    at,
                    format!(
                        "{} after {} at IonControlPointDeliverySequence[{}]; expected the beam's cumulative meterset, which never decreases",
                        point.delivered, p.delivered, p.index
                    ),
                ));
            }
        }
        out.push(point);
    }
    Ok(out)
}

/// Refuses two beams on at once.
fn check_no_overlap(beams: &[RecordedBeam]) -> Result<(), DicomImportError> {
    let mut all: Vec<(f64, f64, usize, usize, Option<i64>)> = beams
        .iter()
        .enumerate()
        .flat_map(|(b, beam)| {
            beam.intervals.iter().map(move |i| {
                let iv = &i.interval;
                (iv.start_s, iv.end_s, b, i.control_point, beam.beam_number)
            })
        })
        .collect();
    all.sort_by(|a, b| a.0.total_cmp(&b.0));
    for w in all.windows(2) {
        if w[1].0 < w[0].1 && w[1].2 != w[0].2 {
            return Err(invalid(
                TREATMENT_CONTROL_POINT_TIME,
                Location::DeliveredControlPoint {
                    beam: w[1].2,
                    number: w[1].4,
                    control_point: w[1].3,
                },
                format!(
                    "its beam is on from {:.6} s while TreatmentSessionIonBeamSequence[{}]'s is still on (until {:.6} s, from its IonControlPointDeliverySequence[{}]); expected one beam on at a time",
                    w[1].0, w[0].2, w[0].1, w[0].3
                ),
            ));
        }
    }
    Ok(())
}
