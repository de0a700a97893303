//! RT Ion Beams Treatment Records read as beam-on intervals. Records here are built attribute
//! by attribute in the test (independently of the crate's writer), except where the writer's
//! own round trip is what is tested; every fault named by issue 46 (midnight, resolution,
//! missing or unsorted times, repeats, an interrupted and resumed beam, another plan) is
//! handled or refused with the control point's index.

use arcsim_dicom::{
    read_delivery_log, treatment_record_bytes, treatment_record_from_bytes, BeamOnInterval,
    DicomImportError, ReadLogError, RecordStart, RecordedBeam, TreatmentRecord,
};
use arcsim_log::{beam_segments, BeamInterval, ColumnMap};
use arcsim_test_support::dicom::file_bytes;
use dicom_core::value::DataSetSequence;
use dicom_core::{DataElement, PrimitiveValue, Tag, VR};
use dicom_dictionary_std::{tags, uids};
use dicom_object::InMemDicomObject;

/// One control point of a hand-built record: each attribute optional.
#[derive(Clone, Default)]
struct Cp {
    date: Option<&'static str>,
    time: Option<&'static str>,
    meterset: Option<f64>,
    angle: Option<f64>,
    energy: Option<f64>,
    index: Option<i64>,
}

fn cp(date: &'static str, time: &'static str, meterset: f64, angle: f64, energy: f64) -> Cp {
    Cp {
        date: Some(date),
        time: Some(time),
        meterset: Some(meterset),
        angle: Some(angle),
        energy: Some(energy),
        index: None,
    }
}

fn put(obj: &mut InMemDicomObject, tag: Tag, vr: VR, value: String) {
    obj.put(DataElement::new(tag, vr, PrimitiveValue::from(value)));
}

/// A record of `beams` (ReferencedBeamNumber, termination, control points) with SOP class
/// `class`, referencing `plan` when given.
fn record(class: &str, plan: Option<&str>, beams: &[(i64, &str, Vec<Cp>)]) -> Vec<u8> {
    let mut ds = InMemDicomObject::new_empty();
    put(&mut ds, tags::SOP_CLASS_UID, VR::UI, class.into());
    put(&mut ds, tags::SOP_INSTANCE_UID, VR::UI, "2.25.1".into());
    if let Some(p) = plan {
        let mut item = InMemDicomObject::new_empty();
        put(
            &mut item,
            tags::REFERENCED_SOP_INSTANCE_UID,
            VR::UI,
            p.into(),
        );
        ds.put(DataElement::new(
            tags::REFERENCED_RT_PLAN_SEQUENCE,
            VR::SQ,
            DataSetSequence::from(vec![item]),
        ));
    }
    let mut session = Vec::new();
    for (number, status, cps) in beams {
        let mut item = InMemDicomObject::new_empty();
        put(
            &mut item,
            tags::REFERENCED_BEAM_NUMBER,
            VR::IS,
            number.to_string(),
        );
        put(
            &mut item,
            tags::TREATMENT_TERMINATION_STATUS,
            VR::CS,
            (*status).into(),
        );
        let mut out = Vec::new();
        for c in cps {
            let mut o = InMemDicomObject::new_empty();
            if let Some(i) = c.index {
                put(
                    &mut o,
                    tags::REFERENCED_CONTROL_POINT_INDEX,
                    VR::IS,
                    i.to_string(),
                );
            }
            if let Some(d) = c.date {
                put(&mut o, tags::TREATMENT_CONTROL_POINT_DATE, VR::DA, d.into());
            }
            if let Some(t) = c.time {
                put(&mut o, tags::TREATMENT_CONTROL_POINT_TIME, VR::TM, t.into());
            }
            if let Some(m) = c.meterset {
                put(&mut o, tags::DELIVERED_METERSET, VR::DS, m.to_string());
            }
            if let Some(a) = c.angle {
                put(&mut o, tags::GANTRY_ANGLE, VR::DS, a.to_string());
            }
            if let Some(e) = c.energy {
                put(&mut o, tags::NOMINAL_BEAM_ENERGY, VR::DS, e.to_string());
            }
            out.push(o);
        }
        item.put(DataElement::new(
            tags::ION_CONTROL_POINT_DELIVERY_SEQUENCE,
            VR::SQ,
            DataSetSequence::from(out),
        ));
        session.push(item);
    }
    ds.put(DataElement::new(
        tags::TREATMENT_SESSION_ION_BEAM_SEQUENCE,
        VR::SQ,
        DataSetSequence::from(session),
    ));
    file_bytes(ds)
}

const RECORD: &str = uids::RT_ION_BEAMS_TREATMENT_RECORD_STORAGE;

fn read(bytes: &[u8]) -> Result<TreatmentRecord, DicomImportError> {
    treatment_record_from_bytes(bytes)
}

fn intervals(r: &TreatmentRecord) -> Vec<BeamInterval> {
    r.beams
        .iter()
        .flat_map(|b| b.intervals.iter().map(|i| i.interval))
        .collect()
}

/// Two layers as delivery systems write them: a pair of control points each.
fn two_layers() -> Vec<Cp> {
    vec![
        cp("20261206", "101500.000", 0.0, 10.0, 150.0),
        cp("20261206", "101501.250", 12.5, 11.0, 150.0),
        cp("20261206", "101502.000", 12.5, 11.5, 140.0),
        cp("20261206", "101503.500", 20.0, 12.5, 140.0),
    ]
}

#[test]
fn pairs_of_control_points_are_layers_with_their_times_mu_and_angles() {
    let r = read(&record(
        RECORD,
        Some("1.2.3"),
        &[(1, "NORMAL", two_layers())],
    ))
    .expect("record");
    assert_eq!(r.referenced_plan_uid.as_deref(), Some("1.2.3"));
    assert_eq!(r.time_resolution_s, 1e-3);
    let iv = intervals(&r);
    assert_eq!(iv.len(), 2);
    let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
    assert!(
        close(iv[0].start_s, 0.0) && close(iv[0].end_s, 1.25),
        "{iv:?}"
    );
    assert!(
        close(iv[1].start_s, 2.0) && close(iv[1].end_s, 3.5),
        "{iv:?}"
    );
    assert!(close(iv[0].mu, 12.5) && close(iv[1].mu, 7.5));
    assert_eq!((iv[1].angle_start_deg, iv[1].angle_end_deg), (11.5, 12.5));
    assert_eq!((iv[0].energy_mev, iv[1].energy_mev), (150.0, 140.0));
    let starts: Vec<usize> = r.beams[0]
        .intervals
        .iter()
        .map(|i| i.control_point)
        .collect();
    assert_eq!(starts, vec![0, 2]);
}

#[test]
fn a_delivery_across_midnight_stays_continuous() {
    let cps = vec![
        cp("20261231", "235959.5", 0.0, 359.0, 150.0),
        cp("20270101", "000000.75", 3.0, 0.5, 150.0),
    ];
    let r = read(&record(RECORD, None, &[(1, "NORMAL", cps)])).expect("record");
    let iv = intervals(&r);
    assert!((iv[0].end_s - iv[0].start_s - 1.25).abs() < 1e-9, "{iv:?}");
    // The log unwraps the angle through 0°.
    let log = r.to_log("r").expect("log");
    let on: Vec<f64> = log
        .samples
        .iter()
        .filter(|s| s.beam_on)
        .map(|s| s.gantry_angle_deg)
        .collect();
    assert_eq!(on, vec![359.0, 360.5]);
    assert_eq!(log.wraps_unwrapped, 1);
}

#[test]
fn whole_second_times_say_their_resolution() {
    let cps = vec![
        cp("20261206", "101500", 0.0, 10.0, 150.0),
        cp("20261206", "101502", 5.0, 11.0, 150.0),
    ];
    let r = read(&record(RECORD, None, &[(1, "NORMAL", cps)])).expect("record");
    assert_eq!(r.time_resolution_s, 1.0);
    assert_eq!(r.to_log("r").expect("log").typical_period_s(), 1.0);
}

fn err(bytes: &[u8]) -> String {
    read(bytes).expect_err("refused").to_string()
}

#[test]
fn a_missing_time_is_refused_with_its_control_point() {
    let mut cps = two_layers();
    cps[3].time = None;
    let e = err(&record(RECORD, None, &[(1, "NORMAL", cps)]));
    assert!(e.contains("TreatmentControlPointTime"), "{e}");
    assert!(e.contains("IonControlPointDeliverySequence[3]"), "{e}");
    assert!(e.contains("ReferencedBeamNumber 1"), "{e}");
}

#[test]
fn a_missing_date_is_inherited_but_the_first_is_required() {
    let mut cps = two_layers();
    cps[2].date = None;
    let r = read(&record(RECORD, None, &[(1, "NORMAL", cps.clone())])).expect("inherited");
    assert_eq!(intervals(&r).len(), 2);
    cps[0].date = None;
    let e = err(&record(RECORD, None, &[(1, "NORMAL", cps)]));
    assert!(
        e.contains("TreatmentControlPointDate") && e.contains("[0]"),
        "{e}"
    );
}

#[test]
fn unsorted_control_points_are_refused_naming_both() {
    let mut cps = two_layers();
    cps.swap(1, 2);
    let e = err(&record(RECORD, None, &[(1, "NORMAL", cps)]));
    assert!(e.contains("IonControlPointDeliverySequence[2]"), "{e}");
    assert!(
        e.contains("before the previous control point's (IonControlPointDeliverySequence[1])"),
        "{e}"
    );
}

#[test]
fn an_exact_repeat_is_dropped_and_counted() {
    let mut cps = two_layers();
    for (i, c) in cps.iter_mut().enumerate() {
        c.index = Some(i as i64);
    }
    cps.insert(2, cps[1].clone());
    let r = read(&record(RECORD, None, &[(1, "NORMAL", cps)])).expect("record");
    assert_eq!(r.repeats_dropped, 1);
    assert_eq!(intervals(&r).len(), 2);
}

#[test]
fn a_shrinking_meterset_is_refused() {
    let mut cps = two_layers();
    cps[3].meterset = Some(10.0);
    let e = err(&record(RECORD, None, &[(1, "NORMAL", cps)]));
    assert!(
        e.contains("DeliveredMeterset") && e.contains("never decreases"),
        "{e}"
    );
}

#[test]
fn angles_and_energies_are_inherited_and_an_energy_is_required() {
    let mut cps = two_layers();
    cps[1].angle = None;
    cps[1].energy = None;
    let r = read(&record(RECORD, None, &[(1, "NORMAL", cps.clone())])).expect("record");
    assert_eq!(intervals(&r)[0].angle_end_deg, 10.0);
    for c in &mut cps {
        c.energy = None;
    }
    let e = err(&record(RECORD, None, &[(1, "NORMAL", cps)]));
    assert!(e.contains("NominalBeamEnergy") && e.contains("[0]"), "{e}");
}

#[test]
fn an_interrupted_and_resumed_beam_keeps_every_mu() {
    // Layer 2 stops after 4 of its 7.5 MU (operator), the beam is resumed 60 s later.
    let first = vec![
        cp("20261206", "101500.000", 0.0, 10.0, 150.0),
        cp("20261206", "101501.250", 12.5, 11.0, 150.0),
        cp("20261206", "101502.000", 12.5, 11.5, 140.0),
        cp("20261206", "101502.800", 16.5, 12.0, 140.0),
    ];
    let resumed = vec![
        cp("20261206", "101602.800", 0.0, 12.0, 140.0),
        cp("20261206", "101603.500", 3.5, 12.5, 140.0),
    ];
    let r = read(&record(
        RECORD,
        None,
        &[(1, "OPERATOR", first), (1, "NORMAL", resumed)],
    ))
    .expect("record");
    assert_eq!(r.beams[0].termination.as_deref(), Some("OPERATOR"));
    let iv = intervals(&r);
    assert_eq!(iv.len(), 3);
    let mu: f64 = iv.iter().map(|i| i.mu).sum();
    assert!((mu - 20.0).abs() < 1e-9);
    let segs = beam_segments(&r.to_log("r").expect("log"));
    assert_eq!(segs.len(), 3);
    assert!((segs[2].start_s - 62.8).abs() < 1e-3, "{segs:?}");
}

#[test]
fn two_beams_on_at_once_are_refused() {
    let a = two_layers();
    let b = vec![
        cp("20261206", "101501.000", 0.0, 50.0, 150.0),
        cp("20261206", "101502.000", 5.0, 51.0, 150.0),
    ];
    let e = err(&record(RECORD, None, &[(1, "NORMAL", a), (2, "NORMAL", b)]));
    assert!(e.contains("one beam on at a time"), "{e}");
}

#[test]
fn a_plan_is_not_a_record() {
    let e = err(&record(
        uids::RT_ION_PLAN_STORAGE,
        None,
        &[(1, "NORMAL", two_layers())],
    ));
    assert!(
        e.contains("not an RT Ion Beams Treatment Record") && e.contains("RT Ion Plan"),
        "{e}"
    );
}

#[test]
fn the_log_of_a_record_puts_each_edge_within_a_thousandth_of_its_resolution() {
    let r = read(&record(RECORD, None, &[(1, "NORMAL", two_layers())])).expect("record");
    let log = r.to_log("r").expect("log");
    let segs = beam_segments(&log);
    for (s, i) in segs.iter().zip(intervals(&r)) {
        assert!(
            (s.start_s - i.start_s).abs() <= 1e-3 * r.time_resolution_s,
            "{s:?} {i:?}"
        );
        assert!(
            (s.end_s - i.end_s).abs() <= 1e-3 * r.time_resolution_s,
            "{s:?} {i:?}"
        );
        assert!((s.mu.expect("mu") - i.mu).abs() < 1e-9);
        assert!(!s.start_uncertain && !s.end_uncertain);
    }
}

/// A small seeded generator (no dependency needed for a few hundred draws).
fn lcg(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

#[test]
fn the_writer_round_trips_random_deliveries_to_its_resolution() {
    let mut s = 7u64;
    for digits in [0u32, 3, 6] {
        let res = 10f64.powi(-(digits as i32));
        let mut t = 0.0;
        let mut angle = 350.0;
        let beams: Vec<RecordedBeam> = (1..=2)
            .map(|b| RecordedBeam {
                beam_number: Some(b),
                termination: Some("NORMAL".into()),
                intervals: (0..40)
                    .map(|k| {
                        t += 0.3 + 3.0 * lcg(&mut s);
                        let start = t;
                        t += 0.2 + 2.0 * lcg(&mut s);
                        let a0 = angle;
                        angle += 2.0 * lcg(&mut s);
                        BeamOnInterval {
                            control_point: k,
                            interval: BeamInterval {
                                start_s: start,
                                end_s: t,
                                angle_start_deg: a0,
                                angle_end_deg: angle,
                                energy_mev: 70.0 + 160.0 * lcg(&mut s),
                                mu: 1.0 + 50.0 * lcg(&mut s),
                            },
                        }
                    })
                    .collect(),
            })
            .collect();
        let start = RecordStart::parse("20261231235900").expect("start");
        let (bytes, uid) =
            treatment_record_bytes(&beams, start, digits, Some("1.2.3")).expect("written");
        let back = read(&bytes).expect("read back");
        assert_eq!(back.sop_instance_uid.as_deref(), Some(uid.as_str()));
        assert_eq!(back.time_resolution_s, res);
        let (want, got): (Vec<_>, Vec<_>) = (
            beams
                .iter()
                .flat_map(|b| b.intervals.iter().map(|i| i.interval))
                .collect::<Vec<_>>(),
            intervals(&back),
        );
        assert_eq!(want.len(), got.len(), "digits {digits}");
        let t0 = want[0].start_s;
        for (w, g) in want.iter().zip(&got) {
            // Each time is rounded to the resolution: an edge off by at most half of it from
            // the truth, counted from the first (rounded too).
            assert!(
                (g.start_s - (w.start_s - t0)).abs() <= res + 1e-9,
                "{digits}: {w:?} {g:?}"
            );
            assert!(
                (g.end_s - (w.end_s - t0)).abs() <= res + 1e-9,
                "{digits}: {w:?} {g:?}"
            );
            assert!((g.mu - w.mu).abs() <= 2e-6, "{w:?} {g:?}");
            assert!((g.energy_mev - w.energy_mev).abs() <= 1e-6);
            assert!((g.angle_start_deg - w.angle_start_deg.rem_euclid(360.0)).abs() <= 1e-6);
        }
    }
}

#[test]
fn a_record_of_another_plan_is_refused_and_a_csv_is_read_as_one() {
    let dir = std::env::temp_dir().join(format!("arcsim-records-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let path = dir.join("r.dcm");
    std::fs::write(
        &path,
        record(RECORD, Some("1.2.3"), &[(1, "NORMAL", two_layers())]),
    )
    .expect("written");
    let map = ColumnMap::default();
    match read_delivery_log(&path, &map, Some("9.9.9")) {
        Err(ReadLogError::OtherPlan { recorded, plan, .. }) => {
            assert_eq!((recorded.as_str(), plan.as_str()), ("1.2.3", "9.9.9"));
        }
        other => panic!("{other:?}"),
    }
    let log = read_delivery_log(&path, &map, Some("1.2.3")).expect("its plan");
    assert_eq!(log.edge_resolution_s, Some(1e-3));
    let csv = dir.join("l.csv");
    std::fs::write(
        &csv,
        "t_s,gantry_angle_deg,beam_on\n0,10,0\n0.1,10.1,1\n0.2,10.2,0\n",
    )
    .expect("csv");
    let log = read_delivery_log(&csv, &map, Some("1.2.3")).expect("csv");
    assert_eq!((log.samples.len(), log.edge_resolution_s), (3, None));
    std::fs::remove_dir_all(&dir).ok();
}

/// A log streamed through a FIFO is read whole as a CSV: the look for a DICOM file must not
/// consume its first bytes.
#[test]
fn a_csv_log_through_a_fifo_is_read_whole() {
    let dir = std::env::temp_dir().join(format!("arcsim-records-fifo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let fifo = dir.join("log.fifo");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    assert!(
        made.is_ok_and(|s| s.success()),
        "mkfifo is needed for this test"
    );
    let text = "t_s,gantry_angle_deg,beam_on\n0,10,0\n0.1,10.1,1\n0.2,10.2,0\n";
    let writer = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::write(&fifo, text))
    };
    // Read on a thread with a deadline: a reader that consumed the head waits forever.
    let (tx, rx) = std::sync::mpsc::channel();
    {
        let fifo = fifo.clone();
        std::thread::spawn(move || {
            let read = read_delivery_log(&fifo, &ColumnMap::default(), None);
            tx.send(read.map(|l| l.samples.len()).map_err(|e| e.to_string()))
        });
    }
    let read = rx.recv_timeout(std::time::Duration::from_secs(20));
    assert_eq!(
        read,
        Ok(Ok(3)),
        "the FIFO's log was not read whole within 20 s"
    );
    writer.join().expect("writer").expect("written");
    std::fs::remove_dir_all(&dir).ok();
}
