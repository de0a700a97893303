//! What the user reads: no output shows a negative zero, the warnings of a DICOM import reach
//! standard error, DICOM and sweep-file errors name the file and a usable place in it, and a
//! deflated DICOM file imports.

use std::path::Path;

use arcsim_test_support::dicom::{self, BeamSpec, Layer, PlanSpec};
use arcsim_test_support::{temp_dir, temp_file};

use crate::util::{arcsim, path_str, repo, stderr, stdout};

/// The numbers in `text` written as a negative zero ("-0", "-0.0", "-0.00"), with their line.
fn negative_zeros(text: &str) -> Vec<String> {
    text.lines()
        .flat_map(|line| {
            line.split(|c: char| {
                c.is_whitespace()
                    || matches!(c, ',' | ':' | '[' | ']' | '{' | '}' | '"' | '(' | ')')
            })
            .filter(|token| {
                token.starts_with("-0")
                    && arcsim_plan::without_zero_sign(token.to_string()) != *token
            })
            .map(move |token| format!("{token} in: {line}"))
        })
        .collect()
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// One layer (no transition: empty sums) and a CC arc of two layers (at rest: speed -0).
const ONE_LAYER: &str = r#"{"format": "arcsim-plan/1", "name": "one", "arcs": [{"direction": "CW",
  "control_points": [{"angle_deg": 0, "layers": [{"energy_mev": 100, "irradiation_time_s": 1.0}]}]}]}"#;
const CC_ARC: &str = r#"{"format": "arcsim-plan/1", "name": "cc", "arcs": [{"direction": "CC",
  "control_points": [{"angle_deg": 20, "layers": [{"energy_mev": 100, "irradiation_time_s": 1.0}]},
                     {"angle_deg": 10, "layers": [{"energy_mev": 100, "irradiation_time_s": 1.0}]}]}]}"#;

#[test]
fn the_negative_zero_test_finds_negative_zeros() {
    assert_eq!(negative_zeros("a,-0,1").len(), 1);
    assert_eq!(negative_zeros("x: -0.00 s  -0.0 %").len(), 2);
    assert!(negative_zeros("-0.5, -10, 0, plan-0, 1e-0").is_empty());
}

#[test]
fn simulate_writes_no_negative_zero() {
    let dir = temp_dir();
    for (name, plan) in [("one.json", ONE_LAYER), ("cc.json", CC_ARC)] {
        let plan_path = dir.join(name);
        std::fs::write(&plan_path, plan).expect("plan");
        let json = dir.join(format!("{name}.result.json"));
        let csv = dir.join(format!("{name}.timeline.csv"));
        let o = arcsim(&[
            "simulate",
            path_str(&plan_path),
            "--json",
            path_str(&json),
            "--csv",
            path_str(&csv),
        ]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let summary = stdout(&o);
        assert!(summary.contains("energy switching"), "{summary}");
        for (what, text) in [
            ("summary", summary),
            ("JSON breakdown", read(&json)),
            ("timeline CSV", read(&csv)),
        ] {
            let found = negative_zeros(&text);
            assert!(found.is_empty(), "{name}, {what}: {found:?}");
        }
    }
}

#[test]
fn profile_samples_write_no_negative_zero() {
    let dir = temp_dir();
    for distance in ["-10", "10"] {
        let csv = dir.join(format!("profile{distance}.csv"));
        let o = arcsim(&[
            "profile",
            "--distance",
            distance,
            "--v-start",
            "0",
            "--v-end",
            "0",
            "--jerk",
            "1",
            "--accel",
            "1",
            "--vel",
            "5",
            "--csv",
            path_str(&csv),
            "--dt",
            "0.25",
            "--json",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        for (what, text) in [("JSON", stdout(&o)), ("CSV", read(&csv))] {
            let found = negative_zeros(&text);
            assert!(found.is_empty(), "distance {distance}, {what}: {found:?}");
        }
    }
}

#[test]
fn sweep_table_and_summary_write_no_negative_zero() {
    let dir = temp_dir();
    let plan = dir.join("one.json");
    std::fs::write(&plan, ONE_LAYER).expect("plan");
    let sweep = dir.join("zero.json");
    let text = serde_json::json!({
        "format": "arcsim-sweep/1",
        "name": "zero",
        "plans": [path_str(&plan)],
        "machine": path_str(&repo().join("scenarios/machine-atom.json")),
        "axes": {"jerk_deg_per_s3": [0.5, 1]},
        "schedules": ["scan"]
    });
    std::fs::write(&sweep, text.to_string()).expect("sweep");
    let csv = dir.join("zero.csv");
    let json = dir.join("zero.result.json");
    let o = arcsim(&[
        "sweep",
        path_str(&sweep),
        "--out",
        path_str(&csv),
        "--json",
        path_str(&json),
        "--threads",
        "1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let table = read(&csv);
    assert_eq!(table.lines().count(), 3, "{table}");
    for (what, text) in [
        ("summary", stdout(&o)),
        ("CSV", table),
        ("JSON", read(&json)),
    ] {
        let found = negative_zeros(&text);
        assert!(found.is_empty(), "{what}: {found:?}");
    }
}

/// Static beams, one layer each, at `angles`.
fn static_beams(label: &str, angles: &[f64], energy: f64) -> PlanSpec {
    let beams = angles
        .iter()
        .enumerate()
        .map(|(i, &angle)| {
            let layer = Layer {
                angle,
                energy,
                weights: dicom::weights_of(i),
            };
            BeamSpec::from_layers(i as i64 + 1, "STATIC", "NONE", 50.0, &[layer])
        })
        .collect();
    PlanSpec::ion(label, beams)
}

#[test]
fn import_writes_no_negative_zero_angle() {
    let dcm = temp_file(
        "negzero.dcm",
        &static_beams("NEGZERO", &[-0.0, 10.0], 120.0).to_bytes(),
    );
    let o = arcsim(&["import", path_str(&dcm)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (json, summary) = (stdout(&o), stderr(&o));
    assert!(summary.contains("CW 0 -> 10 deg"), "{summary}");
    for (what, text) in [("JSON", json), ("summary", summary)] {
        let found = negative_zeros(&text);
        assert!(found.is_empty(), "{what}: {found:?}");
    }
}

#[test]
fn dicom_import_warnings_reach_standard_error() {
    let dcm = temp_file(
        "angle360.dcm",
        &static_beams("A360", &[350.0, 360.0], 120.0).to_bytes(),
    );
    let warning = format!(
        "warning: {}: GantryAngle (300A,011E) 360 in IonBeamSequence[1] (BeamNumber 2) > \
         IonControlPointSequence[0] read as 0 (DICOM angles are in [0, 360))",
        dcm.display()
    );
    let out = temp_dir().join("plan.json");
    for args in [
        vec!["import", path_str(&dcm), "-o", path_str(&out)],
        vec!["simulate", path_str(&dcm)],
        vec!["validate", path_str(&dcm)],
    ] {
        let o = arcsim(&args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        assert!(
            stderr(&o).lines().any(|l| l == warning),
            "{args:?}: no {warning:?} in:\n{}",
            stderr(&o)
        );
    }
}

#[test]
fn dicom_errors_name_the_file_and_the_place_not_the_plan() {
    let dcm = temp_file("hot.dcm", &static_beams("HOT", &[10.0], 9999.0).to_bytes());
    let o = arcsim(&["validate", path_str(&dcm)]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.starts_with(&format!(
            "error: {}: the imported plan breaks the arcsim plan rules (arcs, control points and \
             layers counted as imported, from 0): arc 0, control point 0, layer 0, field \
             `energy_mev`: expected an energy in",
            dcm.display()
        )),
        "{e}"
    );
    assert!(!e.contains("HOT"), "{e}");

    let mut spec = static_beams("BACK", &[10.0, 20.0], 120.0);
    spec.beams[1].final_weight = Some(1000.0);
    let dcm = temp_file("mu.dcm", &spec.to_bytes());
    let o = arcsim(&["import", path_str(&dcm)]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.starts_with(&format!(
            "error: {}: inconsistent FinalCumulativeMetersetWeight (300A,010E) in \
             IonBeamSequence[1] (BeamNumber 2): 1000, but the ScanSpotMetersetWeights",
            dcm.display()
        )),
        "{e}"
    );
}

#[test]
fn a_deflated_dicom_file_imports_like_the_plain_one() {
    let spec = dicom::two_arc_plan();
    let plain = temp_file("plain.dcm", &spec.to_bytes());
    let deflated = temp_file(
        "deflated.dcm",
        &dicom::file_bytes_ts(
            spec.dataset(),
            // Deflated Explicit VR Little Endian.
            "1.2.840.10008.1.2.1.99",
        ),
    );
    let a = arcsim(&["import", path_str(&plain)]);
    let b = arcsim(&["import", path_str(&deflated)]);
    assert!(a.status.success(), "{}", stderr(&a));
    assert!(b.status.success(), "{}", stderr(&b));
    assert_eq!(stdout(&a), stdout(&b));
}

#[test]
fn a_malformed_sweep_file_is_located_by_line_and_column() {
    let sweep = temp_file("bad.json", b"{\n  \"format\": \"arcsim-sweep/1\",\n  ,\n}");
    let o = arcsim(&["sweep", path_str(&sweep)]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert_eq!(
        e.trim_end(),
        format!(
            "error: {}: malformed JSON: key must be a string (line 3, column 3)",
            sweep.display()
        )
    );
}
