//! The CLI's CSV tables, each defined by one column list and read or written with the `csv`
//! crate: `profile --batch` reads what a spreadsheet saves (byte-order mark, CRLF line ends,
//! quoted fields, columns in any order) and names the line and column of a bad value;
//! `simulate --spots` and `--csv` write tables that read back by column name.

use std::path::Path;

use arcsim_test_support::temp_dir;
use serde_json::Value;

use crate::util::{arcsim, path_str, text};

/// The moves of the batch tests: infeasible, ok, a bad number, ok with reversal allowed.
const MOVES: &str = "distance,v_start,v_end,jerk,accel,vel,min_duration,reverse
2,1.5,1.5,0.5,0.5,5,5,
1.6,0.3,0.3,0.5,0.5,5,5,
abc,0,0,1,1,1,,
0,0,0.4,2000,20,1.2,,allow
";

/// Runs `profile --batch` on `input` (written to `name`) and returns the output table.
fn batch(dir: &Path, name: &str, input: &[u8]) -> String {
    let path = dir.join(name);
    std::fs::write(&path, input).expect("write");
    let out = dir.join(format!("{name}.out.csv"));
    let o = arcsim(&[
        "profile",
        "--batch",
        path_str(&path),
        "--out",
        path_str(&out),
    ]);
    assert!(o.status.success(), "{name}: {}", text(&o).1);
    std::fs::read_to_string(&out).expect("output")
}

/// The records of a CSV table (header first).
fn records(table: &str) -> Vec<Vec<String>> {
    csv::ReaderBuilder::new()
        .has_headers(false)
        .from_reader(table.as_bytes())
        .records()
        .map(|r| r.expect("a CSV record").iter().map(String::from).collect())
        .collect()
}

/// `table`'s lines as fields, each quoted, columns reversed, CRLF ends, after a byte-order mark.
fn spreadsheet(table: &str) -> Vec<u8> {
    let mut out = "\u{feff}".to_string();
    for line in table.lines() {
        let mut fields: Vec<String> = line.split(',').map(|f| format!("\"{f}\"")).collect();
        fields.reverse();
        out += &fields.join(",");
        out += "\r\n";
    }
    out.into_bytes()
}

#[test]
fn a_batch_reads_a_spreadsheet_file_like_a_plain_one() {
    let dir = temp_dir().join("csv-batch");
    std::fs::create_dir_all(&dir).expect("dir");
    let plain = batch(&dir, "plain.csv", MOVES.as_bytes());
    let rows = records(&plain);
    assert_eq!(
        rows[0],
        ["line", "status", "duration_s", "peak_speed", "message"]
    );
    let status: Vec<(&str, &str)> = rows[1..]
        .iter()
        .map(|r| (r[0].as_str(), r[1].as_str()))
        .collect();
    assert_eq!(
        status,
        [
            ("2", "infeasible"),
            ("3", "ok"),
            ("4", "error"),
            ("5", "ok")
        ]
    );
    assert_eq!(rows[2][2], "5");
    assert_eq!(rows[3][4], "field distance: 'abc' is not a finite number");
    assert!(rows[1][4].contains("feasible durations"), "{}", rows[1][4]);
    // Quoted, reordered, CRLF, BOM: the same results, line for line.
    let sheet = spreadsheet(MOVES);
    assert!(sheet.starts_with("\u{feff}\"reverse\",\"min_duration\",\"vel\"".as_bytes()));
    assert_eq!(batch(&dir, "sheet.csv", &sheet), plain);
    // A quoted field may hold the separator: here a bad one, named with its line and column.
    let quoted = MOVES.replace("abc,0,0,1,1,1,,", "1,0,0,\"1,5\",1,1,,");
    let rows = records(&batch(&dir, "quoted.csv", quoted.as_bytes()));
    assert_eq!(rows[3][..2], ["4", "error"]);
    assert_eq!(rows[3][4], "field jerk: '1,5' is not a finite number");
}

#[test]
fn batch_errors_name_the_line_and_the_column() {
    let dir = temp_dir().join("csv-batch-errors");
    std::fs::create_dir_all(&dir).expect("dir");
    // Blank lines keep the line numbers of the file; CRLF too.
    let input = "vel,accel,jerk,v_end,v_start,distance\r\n\r\n5,0.5,0.5,0,0,10\r\n5,0.5,-x,0,0,10\r\n5,0.5,0.5,0,0\r\n5,0.5,0.5,0,0,\r\n";
    let rows = records(&batch(&dir, "errors.csv", input.as_bytes()));
    let got: Vec<[&str; 3]> = rows[1..]
        .iter()
        .map(|r| [r[0].as_str(), r[1].as_str(), r[4].as_str()])
        .collect();
    assert_eq!(
        got,
        [
            ["3", "ok", ""],
            ["4", "error", "field jerk: '-x' is not a finite number"],
            ["5", "error", "5 fields; expected 6 (as the header)"],
            ["6", "error", "field distance: missing value"],
        ]
    );
    // A missing, an unknown or a repeated column stops the batch, located at the header.
    for (header, expected) in [
        (
            "distance,v_start,v_end,jerk,accel",
            "line 1: header lacks the column 'vel' (need distance,v_start,v_end,jerk,accel,vel)",
        ),
        (
            "distance,v_start,v_end,jerk,accel,vel,speed",
            "line 1: unknown column 'speed'",
        ),
        (
            "distance,v_start,v_end,jerk,accel,vel,jerk",
            "line 1: column 'jerk' appears twice",
        ),
        ("", "empty file, expected a header line"),
    ] {
        let path = dir.join("bad-header.csv");
        std::fs::write(&path, format!("{header}\n")).expect("write");
        let o = arcsim(&["profile", "--batch", path_str(&path)]);
        let err = text(&o).1;
        assert_eq!(o.status.code(), Some(1), "{header}: {err}");
        assert!(
            err.contains(&format!("{}: {expected}", path.display())),
            "{header}: {err}"
        );
    }
}

/// The spot table reads back by column name, equal to the JSON's spots; the timeline CSV keeps
/// its header and number format.
#[test]
fn simulate_tables_read_back_by_column_name() {
    let dir = temp_dir().join("csv-spots");
    std::fs::create_dir_all(&dir).expect("dir");
    let (spots, json, timeline) = (dir.join("spots.csv"), dir.join("r.json"), dir.join("t.csv"));
    let o = arcsim(&[
        "simulate",
        "plans/prostate.json",
        "--machine",
        "scenarios/machine-opentps-pbs.json",
        "--spots",
        path_str(&spots),
        "--json",
        path_str(&json),
        "--csv",
        path_str(&timeline),
        "--dt",
        "0.5",
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    let result: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("result");
    let expected = result["spots"].as_array().expect("spots in the JSON");
    let table = std::fs::read_to_string(&spots).expect("spots");
    let rows = records(&table);
    assert_eq!(
        rows[0].join(","),
        "layer_index,arc,control_point,layer,spot,painting,x_mm,y_mm,mu,t_start_s,t_end_s,angle_start_deg,angle_end_deg,burst,spill"
    );
    assert_eq!(rows.len() - 1, expected.len());
    assert!(!expected.is_empty());
    for (row, spot) in rows[1..].iter().zip(expected) {
        for (name, field) in rows[0].iter().zip(row) {
            let want = &spot[name.as_str()];
            if want.is_null() {
                assert_eq!(field, "", "{name}");
            } else {
                let got: f64 = field.parse().expect("a number");
                assert_eq!(Some(got), want.as_f64(), "{name}");
            }
        }
    }
    let timeline = std::fs::read_to_string(&timeline).expect("timeline");
    let rows = records(&timeline);
    assert_eq!(
        rows[0].join(","),
        "t_s,angle_deg,speed_deg_per_s,accel_deg_per_s2,jerk_deg_per_s3,beam_layer,energy_mev"
    );
    assert_eq!(rows[1][0], "0.000000");
    assert_eq!(rows[2][0], "0.500000");
    assert!(rows[1..].iter().all(|r| r.len() == 7));
    assert!(rows[1..].iter().any(|r| r[5].is_empty() && r[6].is_empty()));
    assert!(rows[1..]
        .iter()
        .any(|r| !r[5].is_empty() && !r[6].is_empty()));
}
