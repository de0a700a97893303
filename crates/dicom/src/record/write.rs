//! A treatment record written from beam-on intervals: what a delivery system would store of a
//! simulated delivery (`arcsim simulate --record`), so that the whole record loop (compare,
//! calibrate) can be tried and tested without patient data.
//!
//! Each interval becomes a pair of control points (its start and its end, the cumulative
//! DeliveredMeterset before and after it), as delivery systems write a layer; times are written
//! with `time_digits` fraction digits (rounded), dates roll over at midnight.

use dicom_core::value::DataSetSequence;
use dicom_core::{DataElement, VR};
use dicom_dictionary_std::{tags, uids};
use dicom_object::meta::FileMetaTableBuilder;
use dicom_object::InMemDicomObject;

use super::{RecordedBeam, RT_ION_BEAMS_TREATMENT_RECORD_STORAGE};

/// When a written record's first control point was delivered: a date (days since 1970-01-01)
/// and a time of day (s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordStart {
    /// Days since 1970-01-01.
    pub days: i64,
    /// Seconds since midnight.
    pub seconds: f64,
}

impl RecordStart {
    /// Parses `YYYYMMDDHHMMSS` (an optional fraction after the seconds).
    pub fn parse(text: &str) -> Result<RecordStart, String> {
        let (date, time) = (text.get(..8), text.get(8..));
        let (Some(date), Some(time)) = (date, time) else {
            return Err(format!(
                "\"{text}\": expected YYYYMMDDHHMMSS (e.g. 20260101080000)"
            ));
        };
        let days = super::time::parse_date(date)?;
        let t = super::time::parse_time(time)?;
        Ok(RecordStart {
            days,
            seconds: t.seconds,
        })
    }
}

/// The civil date of `days` since 1970-01-01.
fn civil_from_days(days: i64) -> (i64, i64, i64) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    (if m <= 2 { y + 1 } else { y }, m, d)
}

/// DA and TM texts of `t` seconds after `start`, the time with `digits` fraction digits.
fn date_time(start: RecordStart, t: f64, digits: u32) -> (String, String) {
    let scale = 10f64.powi(digits as i32);
    let ticks = ((start.seconds + t) * scale).round();
    let per_day = 86_400.0 * scale;
    let day = (ticks / per_day).floor();
    let in_day = ticks - day * per_day;
    let (y, m, d) = civil_from_days(start.days + day as i64);
    let whole = (in_day / scale).floor();
    let frac = in_day - whole * scale;
    let (h, mi, s) = (
        whole as i64 / 3600,
        (whole as i64 % 3600) / 60,
        whole as i64 % 60,
    );
    let time = if digits == 0 {
        format!("{h:02}{mi:02}{s:02}")
    } else {
        format!(
            "{h:02}{mi:02}{s:02}.{:0width$}",
            frac as i64,
            width = digits as usize
        )
    };
    (format!("{y:04}{m:02}{d:02}"), time)
}

fn text(tag: dicom_core::Tag, vr: VR, value: impl Into<String>) -> DataElement<InMemDicomObject> {
    DataElement::new(tag, vr, dicom_core::PrimitiveValue::from(value.into()))
}

fn num(x: f64) -> String {
    // DS holds at most 16 characters.
    let s = format!("{x:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.').to_string();
    if s.len() > 16 {
        format!("{x:.9e}")
    } else {
        s
    }
}

/// The bytes of an RT Ion Beams Treatment Record holding `beams` (their intervals' times from
/// `start`, written with `time_digits` (0 to 6) fraction digits), referencing plan `plan_uid`
/// when given. Returns the bytes and the record's new SOPInstanceUID.
pub fn treatment_record_bytes(
    beams: &[RecordedBeam],
    start: RecordStart,
    time_digits: u32,
    plan_uid: Option<&str>,
) -> Result<(Vec<u8>, String), String> {
    if time_digits > 6 {
        return Err(format!(
            "{time_digits} fraction digits; a DICOM time holds 0 to 6"
        ));
    }
    let uid = crate::write::new_uid();
    let mut ds = InMemDicomObject::new_empty();
    ds.put(text(
        tags::SOP_CLASS_UID,
        VR::UI,
        RT_ION_BEAMS_TREATMENT_RECORD_STORAGE,
    ));
    ds.put(text(tags::SOP_INSTANCE_UID, VR::UI, uid.clone()));
    ds.put(text(tags::MODALITY, VR::CS, "RTRECORD"));
    if let Some(p) = plan_uid {
        let mut item = InMemDicomObject::new_empty();
        item.put(text(
            tags::REFERENCED_SOP_CLASS_UID,
            VR::UI,
            uids::RT_ION_PLAN_STORAGE,
        ));
        item.put(text(tags::REFERENCED_SOP_INSTANCE_UID, VR::UI, p));
        ds.put(DataElement::new(
            tags::REFERENCED_RT_PLAN_SEQUENCE,
            VR::SQ,
            DataSetSequence::from(vec![item]),
        ));
    }
    let mut session = Vec::with_capacity(beams.len());
    for beam in beams {
        let mut item = InMemDicomObject::new_empty();
        if let Some(n) = beam.beam_number {
            item.put(text(tags::REFERENCED_BEAM_NUMBER, VR::IS, n.to_string()));
        }
        item.put(text(
            tags::TREATMENT_TERMINATION_STATUS,
            VR::CS,
            beam.termination.clone().unwrap_or_else(|| "NORMAL".into()),
        ));
        let mut cps = Vec::with_capacity(2 * beam.intervals.len());
        let mut delivered = 0.0;
        for iv in beam.intervals.iter().map(|i| &i.interval) {
            for (t, angle, cumulative) in [
                (iv.start_s, iv.angle_start_deg, delivered),
                (iv.end_s, iv.angle_end_deg, delivered + iv.mu),
            ] {
                let (date, time) = date_time(start, t, time_digits);
                let mut cp = InMemDicomObject::new_empty();
                cp.put(text(
                    tags::REFERENCED_CONTROL_POINT_INDEX,
                    VR::IS,
                    cps.len().to_string(),
                ));
                cp.put(text(tags::TREATMENT_CONTROL_POINT_DATE, VR::DA, date));
                cp.put(text(tags::TREATMENT_CONTROL_POINT_TIME, VR::TM, time));
                cp.put(text(tags::DELIVERED_METERSET, VR::DS, num(cumulative)));
                cp.put(text(
                    tags::GANTRY_ANGLE,
                    VR::DS,
                    num(angle.rem_euclid(360.0)),
                ));
                cp.put(text(tags::NOMINAL_BEAM_ENERGY, VR::DS, num(iv.energy_mev)));
                cps.push(cp);
            }
            delivered += iv.mu;
        }
        item.put(DataElement::new(
            tags::ION_CONTROL_POINT_DELIVERY_SEQUENCE,
            VR::SQ,
            DataSetSequence::from(cps),
        ));
        session.push(item);
    }
    ds.put(DataElement::new(
        tags::TREATMENT_SESSION_ION_BEAM_SEQUENCE,
        VR::SQ,
        DataSetSequence::from(session),
    ));
    let file = ds
        .with_meta(
            FileMetaTableBuilder::new()
                .transfer_syntax(uids::EXPLICIT_VR_LITTLE_ENDIAN)
                .media_storage_sop_class_uid(RT_ION_BEAMS_TREATMENT_RECORD_STORAGE)
                .media_storage_sop_instance_uid(uid.clone()),
        )
        .map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    file.write_all(&mut out).map_err(|e| e.to_string())?;
    Ok((out, uid))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_dates_invert_day_counts() {
        for days in [-1000, 0, 59, 60, 365, 10_957, 20_819, 20_820, 100_000] {
            let (y, m, d) = civil_from_days(days);
            let text = format!("{y:04}{m:02}{d:02}");
            assert_eq!(super::super::time::parse_date(&text), Ok(days), "{text}");
        }
    }

    #[test]
    fn times_roll_over_midnight_and_round_to_their_digits() {
        let start = RecordStart::parse("20261231235959").unwrap();
        assert_eq!(
            date_time(start, 0.5, 0),
            ("20270101".into(), "000000".into())
        );
        assert_eq!(
            date_time(start, 0.25, 3),
            ("20261231".into(), "235959.250".into())
        );
        assert_eq!(
            date_time(start, 3600.0, 6),
            ("20270101".into(), "005959.000000".into())
        );
    }
}
