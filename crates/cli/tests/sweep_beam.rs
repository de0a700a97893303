//! `arcsim sweep` over the beam axes, as a user runs it: a dose-rate scale on the ATOM machine
//! (`per_mu` beam) shortens the beam-on time, the CSV and JSON carry the axes and the split of the
//! beam-on time, a scanning-speed axis on that machine is refused with the reason, and a shard
//! table of an earlier arcsim (without the new columns) is refused by `sweep-merge`.

use std::path::Path;

use arcsim_test_support::temp_dir;

use crate::util::{arcsim, path_str, sweep_file, text};
use serde_json::Value;

/// The CSV as (header, rows), split at commas (no quoted fields in these tables).
fn table(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).expect("csv");
    let mut lines = text.lines();
    let split = |l: &str| -> Vec<String> {
        assert!(!l.contains('"'), "{l}");
        l.split(',').map(str::to_string).collect()
    };
    let header = split(lines.next().expect("header"));
    (header, lines.map(split).collect())
}

fn col(header: &[String], name: &str) -> usize {
    header.iter().position(|h| h == name).expect(name)
}

#[test]
fn dose_rate_axis_runs_and_its_columns_are_written() {
    let dir = temp_dir();
    let sweep = sweep_file(
        &dir,
        "dose",
        "plans/prostate.json",
        serde_json::json!({"dose_rate_scale": [1, 2]}),
    );
    let (csv, json) = (dir.join("out.csv"), dir.join("out.json"));
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
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(stdout.contains("dose rate (base 1)"), "{stdout}");
    assert!(stdout.contains("dose rate [×]"), "{stdout}");

    let (header, rows) = table(&csv);
    assert_eq!(rows.len(), 2);
    let num = |r: &[String], name: &str| -> f64 { r[col(&header, name)].parse().expect(name) };
    assert_eq!(rows[0][col(&header, "dose_rate_scale")], "1");
    assert_eq!(rows[1][col(&header, "dose_rate_scale")], "2");
    assert_eq!(rows[0][col(&header, "scan_speed_mm_per_s")], "");
    let (spot, scan) = (
        num(&rows[0], "spot_irradiation_s"),
        num(&rows[0], "scanning_s"),
    );
    assert!(spot > 0.0 && scan > 0.0);
    let beam = |r: &[String]| num(r, "beam_on_s");
    assert!((beam(&rows[0]) - (spot + scan)).abs() < 1e-9 * beam(&rows[0]));
    // Twice the dose rate: the spots' irradiation halves, the spot switching stays.
    assert!((num(&rows[1], "spot_irradiation_s") - spot / 2.0).abs() < 1e-9 * spot);
    assert_eq!(num(&rows[1], "scanning_s"), scan);
    assert!(beam(&rows[1]) < beam(&rows[0]));
    assert!(num(&rows[1], "total_s") <= num(&rows[0], "total_s"));

    let v: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("valid json");
    let r1 = &v["rows"][1];
    assert_eq!(r1["setting"]["dose_rate_scale"], 2.0);
    assert!(r1["setting"]["scan_speed_mm_per_s"].is_null());
    assert!(r1["outcome"]["breakdown"]["scanning_s"].is_number());
    let sens = v["summary"]["entries"][0]["sensitivity"]
        .as_array()
        .expect("sensitivity");
    assert!(
        sens.iter()
            .any(|s| s["axis"] == "dose_rate_scale" && s["base_value"] == 1.0),
        "{sens:?}"
    );
}

#[test]
fn scan_speed_axis_on_a_per_mu_machine_is_refused() {
    let dir = temp_dir();
    let sweep = sweep_file(
        &dir,
        "scan",
        "plans/prostate.json",
        serde_json::json!({"scan_speed_mm_per_s": [5000, 10000]}),
    );
    let o = arcsim(&["sweep", path_str(&sweep)]);
    let (_, stderr) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("axes.scan_speed_mm_per_s: machine \"atom\": its beam model has no scanning speed (kind per_mu)"),
        "{stderr}"
    );
}

/// A shard table written by an earlier arcsim (without the beam columns) is refused by
/// `sweep-merge`, naming the file, the column missing and the header expected; nothing is written.
#[test]
fn an_older_shard_table_is_refused() {
    let dir = temp_dir();
    let sweep = sweep_file(
        &dir,
        "jerk",
        "plans/prostate.json",
        serde_json::json!({"jerk_deg_per_s3": [0.5, 1]}),
    );
    let mut shards = Vec::new();
    for k in 1..=2 {
        let path = dir.join(format!("shard-{k}.csv"));
        let o = arcsim(&[
            "sweep",
            path_str(&sweep),
            "--shard",
            &format!("{k}/2"),
            "--out",
            path_str(&path),
        ]);
        assert!(o.status.success(), "{}", text(&o).1);
        shards.push(path);
    }
    // Shard 2 as an earlier arcsim wrote it: without the dose-rate axis's column.
    let (header, rows) = table(&shards[1]);
    let keep: Vec<bool> = header.iter().map(|h| h != "dose_rate_scale").collect();
    let old: String = std::iter::once(&header)
        .chain(&rows)
        .map(|r| {
            let f: Vec<&str> = r
                .iter()
                .zip(&keep)
                .filter(|(_, k)| **k)
                .map(|(f, _)| f.as_str())
                .collect();
            f.join(",") + "\n"
        })
        .collect();
    std::fs::write(&shards[1], old).expect("write old shard");
    let merged = dir.join("merged.csv");
    let o = arcsim(&[
        "sweep-merge",
        path_str(&shards[0]),
        path_str(&shards[1]),
        "--out",
        path_str(&merged),
        "--sweep",
        path_str(&sweep),
    ]);
    let (_, stderr) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "{}: line 1: no column dose_rate_scale (a table of an earlier arcsim? run its sweep \
             again); expected the arcsim sweep CSV header: index,combinations,plan,",
            shards[1].display()
        )),
        "{stderr}"
    );
    assert!(!merged.exists(), "nothing is written");
}
