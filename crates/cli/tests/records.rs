//! DICOM RT Ion Beams Treatment Records end to end: `simulate --record` writes what the oncology
//! information system would store of a delivery on a machine hidden from the fit; `calibrate`
//! recovers that machine from the records of three plans, its gantry's A and J by the model from
//! the switches' durations (a record holds no angle trace; V, which no switch reaches, not
//! determined), and the fitted machine predicts a held-out plan's record; a
//! record of another plan is refused by its reference; a clock in whole seconds is named as the
//! likely cause of what it cannot resolve, and every value it calls fitted keeps the truth inside
//! its interval.

use std::path::{Path, PathBuf};

use arcsim_test_support::temp_dir;
use serde_json::Value;

use crate::util::{arcsim, path_str, text};

/// The ATOM machine with other timings and another gantry (A 0.5 -> 0.4, J 0.5 -> 0.7): what
/// the records are made on and the fit must find.
const HIDDEN: [(&str, f64); 6] = [
    ("/elst/up_s", 4.2),
    ("/elst/down_s", 0.7),
    ("/beam/s_per_mu", 0.0056),
    ("/beam/spot_switch_time_s", 0.0025),
    ("/gantry/max_accel_deg_per_s2", 0.4),
    ("/gantry/max_jerk_deg_per_s3", 0.7),
];

fn hidden_machine(dir: &Path) -> PathBuf {
    let mut m = crate::util::repo_json("scenarios/machine-atom.json");
    m["name"] = "hidden".into();
    for (field, value) in HIDDEN {
        *m.pointer_mut(field).expect("field") = value.into();
    }
    let path = dir.join("hidden.json");
    std::fs::write(&path, m.to_string()).expect("machine written");
    path
}

/// The record of `plan` delivered on `machine`, times with `digits` fraction digits.
fn record(dir: &Path, plan: &str, machine: &Path, digits: &str, start: &str) -> PathBuf {
    let stem = Path::new(plan).file_stem().expect("stem").to_string_lossy();
    let path = dir.join(format!("{stem}-{digits}.dcm"));
    let out = arcsim(&[
        "simulate",
        plan,
        "--machine",
        path_str(machine),
        "--record",
        path_str(&path),
        "--record-time-digits",
        digits,
        "--record-start",
        start,
    ]);
    assert!(out.status.success(), "{:?}", text(&out));
    path
}

fn calibrate(dir: &Path, digits: &str) -> (Value, String, PathBuf) {
    let machine = hidden_machine(dir);
    let mut args: Vec<String> = vec![
        "calibrate".into(),
        "--machine".into(),
        "scenarios/machine-atom.json".into(),
    ];
    // One record crosses midnight (and the new year).
    for (plan, start) in [
        ("plans/prostate.json", "20261231235800"),
        ("plans/lung.json", "20260102080000"),
        ("plans/two-arc.json", "20260103080000"),
    ] {
        args.push(plan.into());
        args.push(path_str(&record(dir, plan, &machine, digits, start)).into());
    }
    let (fitted, json) = (
        dir.join(format!("fitted-{digits}.json")),
        dir.join(format!("cal-{digits}.json")),
    );
    args.extend([
        "-o".into(),
        path_str(&fitted).into(),
        "--json".into(),
        path_str(&json).into(),
    ]);
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = arcsim(&refs);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("report")).expect("json");
    (report, format!("{stdout}\n{stderr}"), fitted)
}

fn value<'a>(report: &'a Value, field: &str) -> &'a Value {
    report["values"]
        .as_array()
        .expect("values")
        .iter()
        .find(|v| v["field"] == field)
        .unwrap_or_else(|| panic!("{field}"))
}

fn truth(field: &str) -> f64 {
    let key = format!("/{}", field.replace('.', "/"));
    HIDDEN
        .iter()
        .find(|(f, _)| *f == key)
        .map(|(_, v)| *v)
        .expect("hidden")
}

#[test]
fn calibrate_recovers_a_hidden_machine_from_treatment_records() {
    let _heavy = crate::util::one_heavy_test_at_a_time();
    let dir = temp_dir().join("records-ms");
    std::fs::create_dir_all(&dir).expect("dir");
    let (report, out, fitted) = calibrate(&dir, "3");
    assert_eq!(report["controller"]["decision"], "chosen", "{out}");
    // A and J by the model, from the switches' durations (the record holds no angle trace).
    for field in [
        "elst.up_s",
        "elst.down_s",
        "beam.s_per_mu",
        "beam.spot_switch_time_s",
        "gantry.max_accel_deg_per_s2",
        "gantry.max_jerk_deg_per_s3",
    ] {
        let v = value(&report, field);
        let got = v["value"].as_f64().expect("value");
        let rel = (got / truth(field) - 1.0).abs();
        assert!(
            v["determined"] == true && rel < 0.01,
            "{field}: {got} ({rel:.2e})\n{out}"
        );
    }
    // No switch of these plans reaches V: not determined, the base's 5 kept.
    let v = value(&report, "gantry.max_speed_deg_per_s");
    assert_eq!(v["determined"], false, "{v}");
    assert_eq!(v["value"], 5.0, "{v}");
    let note = v["note"].as_str().expect("note");
    assert!(note.contains("do not bind it"), "{note}");
    // D moves with A: the ATOM machine keeps one limit.
    let d = value(&report, "gantry.max_decel_deg_per_s2");
    assert_eq!(
        d["value"],
        value(&report, "gantry.max_accel_deg_per_s2")["value"]
    );
    let fitted_machine: Value =
        serde_json::from_str(&std::fs::read_to_string(&fitted).expect("fitted")).expect("json");
    assert!(fitted_machine["gantry"]["max_decel_deg_per_s2"].is_null());
    // A held-out plan's record, compared with the fitted machine and no flags.
    let held_out = record(
        &dir,
        "plans/head-neck.json",
        &hidden_machine(&dir),
        "3",
        "20260104080000",
    );
    let json = dir.join("compare.json");
    let out = arcsim(&[
        "compare",
        "plans/head-neck.json",
        path_str(&held_out),
        "--machine",
        path_str(&fitted),
        "--json",
        path_str(&json),
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}{stderr}");
    assert!(
        stdout.contains("gantry observed: nothing (a log of beam-on intervals, times to 0.001 s"),
        "{stdout}"
    );
    let c: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("json");
    let pct = c["difference_pct"].as_f64().expect("pct");
    assert!(
        pct.abs() < 1.0,
        "held-out head-neck off by {pct} %\n{stdout}"
    );
    assert_eq!(c["edge_resolution_s"], 0.001);
}

#[test]
fn whole_second_records_name_their_clock_and_every_fitted_interval_holds_the_truth() {
    let _heavy = crate::util::one_heavy_test_at_a_time();
    let dir = temp_dir().join("records-s");
    std::fs::create_dir_all(&dir).expect("dir");
    let (report, out, _) = calibrate(&dir, "0");
    for field in [
        "elst.up_s",
        "elst.down_s",
        "beam.s_per_mu",
        "beam.spot_switch_time_s",
        "gantry.max_accel_deg_per_s2",
        "gantry.max_jerk_deg_per_s3",
    ] {
        let v = value(&report, field);
        if v["determined"] == true {
            let iv = v["interval"].as_array().expect("an interval");
            let (lo, hi) = (iv[0].as_f64().expect("lo"), iv[1].as_f64().expect("hi"));
            let t = truth(field);
            assert!(lo <= t && t <= hi, "{field}: {t} outside {lo}–{hi}\n{out}");
        }
    }
    assert!(
        out.contains("a clock too coarse for the switches it times (this log's times are to 1 s)"),
        "{out}"
    );
    // A switch's duration read to a second cannot time the gantry's moves: nothing fitted (at
    // whole seconds such a fit gave V 3.7 and J 2.1 where the truth is 5 and 0.7).
    for field in [
        "gantry.max_speed_deg_per_s",
        "gantry.max_accel_deg_per_s2",
        "gantry.max_jerk_deg_per_s3",
    ] {
        let v = value(&report, field);
        assert_eq!(v["determined"], false, "{field}: {v}");
        let note = v["note"].as_str().expect("note");
        assert!(
            note.contains("nor by the model: the log's clock (times to 1 s)"),
            "{note}"
        );
    }
}

#[test]
fn a_record_of_another_dicom_plan_is_refused_by_its_reference() {
    let dir = temp_dir().join("records-ref");
    std::fs::create_dir_all(&dir).expect("dir");
    let rec = dir.join("multi.dcm");
    let out = arcsim(&[
        "simulate",
        "plans/dicom/multi.dcm",
        "--record",
        path_str(&rec),
    ]);
    assert!(out.status.success(), "{:?}", text(&out));
    let out = arcsim(&["compare", "plans/dicom/multi.dcm", path_str(&rec)]);
    assert!(out.status.success(), "{:?}", text(&out));
    // The plan written back by `resequence` is another plan: a new SOPInstanceUID.
    let other = dir.join("other.dcm");
    let out = arcsim(&[
        "resequence",
        "plans/dicom/multi.dcm",
        "-o",
        path_str(&other),
    ]);
    assert!(out.status.success(), "{:?}", text(&out));
    let out = arcsim(&["compare", path_str(&other), path_str(&rec)]);
    let (_, stderr) = text(&out);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("ReferencedRTPlanSequence (300C,0002) names plan 2.25.1234567890123456789")
            && stderr.contains("expected a record of this plan"),
        "{stderr}"
    );
}

#[test]
fn bad_record_options_are_refused_before_anything_is_simulated() {
    let dir = temp_dir().join("records-bad");
    std::fs::create_dir_all(&dir).expect("dir");
    let rec = dir.join("r.dcm");
    for (option, value, says) in [
        ("--record-time-digits", "7", "expected 0 to 6"),
        ("--record-start", "2026", "expected YYYYMMDDHHMMSS"),
        ("--record-start", "20260231080000", "does not exist"),
    ] {
        let out = arcsim(&[
            "simulate",
            "plans/lung.json",
            "--record",
            path_str(&rec),
            option,
            value,
        ]);
        let (_, stderr) = text(&out);
        assert_eq!(out.status.code(), Some(2), "{option} {value}: {stderr}");
        assert!(stderr.contains(option) && stderr.contains(says), "{stderr}");
        assert!(!rec.exists());
    }
}

/// A plan read through a FIFO is read once: the record's reference is checked against the bytes
/// read, not by opening the plan again (which would wait forever for another writer).
#[test]
fn a_plan_through_a_fifo_is_read_once_beside_a_record() {
    let dir = temp_dir().join("records-fifo");
    std::fs::create_dir_all(&dir).expect("dir");
    let rec = dir.join("lung.dcm");
    let out = arcsim(&["simulate", "plans/lung.json", "--record", path_str(&rec)]);
    assert!(out.status.success(), "{:?}", text(&out));
    let fifo = dir.join("plan.fifo");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    assert!(
        made.is_ok_and(|s| s.success()),
        "mkfifo is needed for this test"
    );
    let plan = std::fs::read(crate::util::repo().join("plans/lung.json")).expect("plan");
    let writer = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::write(&fifo, plan))
    };
    let mut child = crate::util::bin()
        .args(["compare", path_str(&fifo), path_str(&rec)])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("compare");
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break Some(s);
        }
        if std::time::Instant::now() > deadline {
            child.kill().ok();
            break None;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    assert!(
        status.is_some_and(|s| s.success()),
        "compare with a FIFO plan: {status:?}"
    );
    writer.join().expect("writer").expect("written");
}
