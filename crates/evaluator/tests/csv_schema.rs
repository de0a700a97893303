//! The sweep table's one schema: written, read back and merged through the same column list, so
//! a table reads back equal whatever a spreadsheet did to it (quoted fields, a byte-order mark,
//! CRLF line ends, columns in another order), an earlier arcsim's table is refused, and bad input
//! is an error that names the file, the line and the column.

use crate::util::{csv, from_text};
use arcsim_evaluator::{merge_csv, Evaluator, Row, Shard, Status, CSV_HEADER};

/// Prostate on the ATOM machine, two jerks, two schedules: four rows.
const SWEEP: &str = r#"{
  "format": "arcsim-sweep/1", "name": "t",
  "plans": ["../plans/prostate.json"],
  "machine": "machine-atom.json",
  "axes": {"jerk_deg_per_s3": [0.5, 1]},
  "schedules": ["scan", "prescribed"]
}"#;

fn evaluator() -> Evaluator {
    Evaluator::new(from_text(SWEEP).expect("sweep")).expect("prepare")
}

/// The rows of `ev`, the last one an error whose message needs quoting (a comma, quotes and a
/// line break).
fn rows(ev: &Evaluator) -> Vec<Row> {
    let mut rows = ev.run_collect(&(0..ev.len()).collect::<Vec<_>>());
    assert_eq!(rows.len(), 4);
    let last = rows.last_mut().expect("a row");
    last.status = Status::Error;
    last.outcome = None;
    last.message = "bad \"limit\", see\nthe log".into();
    rows
}

/// What a table keeps of a row: everything but the margins (not read back), and the message
/// on one line.
fn kept(r: &Row) -> String {
    let mut r = r.clone();
    if let Some(o) = r.outcome.as_mut() {
        o.margins = None;
    }
    r.message = r.message.replace('\n', " ");
    format!("{r:?}")
}

fn assert_same_rows(back: &[Row], rows: &[Row]) {
    assert_eq!(back.len(), rows.len());
    for (a, b) in back.iter().zip(rows) {
        assert_eq!(kept(a), kept(b));
    }
}

/// The fields of a table written by `csv` (its only quoted field is the last row's message).
fn fields(table: &str) -> Vec<Vec<String>> {
    let mut rd = csv::ReaderBuilder::new()
        .has_headers(false)
        .from_reader(table.as_bytes());
    rd.records()
        .map(|r| r.expect("record").iter().map(String::from).collect())
        .collect()
}

/// Joins `fields` into a table: every field quoted when `quote_all`, lines ended by `end`.
fn join(fields: &[Vec<String>], quote_all: bool, end: &str) -> String {
    let mut out = String::new();
    for line in fields {
        let cells: Vec<String> = line
            .iter()
            .map(|f| {
                if quote_all || f.contains([',', '"']) {
                    format!("\"{}\"", f.replace('"', "\"\""))
                } else {
                    f.clone()
                }
            })
            .collect();
        out += &cells.join(",");
        out += end;
    }
    out
}

/// `table` with its columns in another order (reversed).
fn reversed(table: &str) -> String {
    let mut f = fields(table);
    for line in &mut f {
        line.reverse();
    }
    join(&f, false, "\n")
}

/// `table` without the columns `names`.
fn without(table: &str, names: &[&str]) -> String {
    let f = fields(table);
    let keep: Vec<bool> = f[0].iter().map(|h| !names.contains(&h.as_str())).collect();
    let f: Vec<Vec<String>> = f
        .iter()
        .map(|line| {
            line.iter()
                .zip(&keep)
                .filter(|(_, k)| **k)
                .map(|(c, _)| c.clone())
                .collect()
        })
        .collect();
    join(&f, false, "\n")
}

fn error(ev: &Evaluator, table: &str) -> String {
    ev.rows_from_csv("t.csv", table)
        .expect_err("an error")
        .to_string()
}

#[test]
fn a_table_reads_back_equal_and_writes_the_same_bytes() {
    let ev = evaluator();
    let rows = rows(&ev);
    let table = csv(&rows);
    assert!(table.starts_with(&format!("{CSV_HEADER}\n")));
    // The message is quoted, on one line.
    assert!(
        table.ends_with(",\"bad \"\"limit\"\", see the log\"\n"),
        "{table}"
    );
    assert_eq!(table.lines().count(), 5);
    let back = ev.rows_from_csv("t.csv", &table).expect("read back");
    assert_same_rows(&back, &rows);
    assert_eq!(back[3].message, "bad \"limit\", see the log");
    assert_eq!(csv(&back), table);
}

#[test]
fn bom_crlf_and_quoted_fields_read_and_merge() {
    let ev = evaluator();
    let rows = rows(&ev);
    let table = csv(&rows);
    let spreadsheet = format!("\u{feff}{}", join(&fields(&table), true, "\r\n"));
    let size = ev.len();
    assert!(spreadsheet.contains(&format!(
        "\"0\",\"{size}\",\"../plans/prostate.json\",\"scan\","
    )));
    let back = ev
        .rows_from_csv("excel.csv", &spreadsheet)
        .expect("a spreadsheet's table reads");
    assert_same_rows(&back, &rows);
    // Merged, it is the table a run writes.
    let merged = merge_csv(&[("excel.csv".into(), spreadsheet)], Some(4)).expect("merge");
    assert_eq!(merged, table);
}

#[test]
fn columns_are_found_by_name() {
    let ev = evaluator();
    let rows = rows(&ev);
    let table = csv(&rows);
    let other_order = reversed(&table);
    assert!(
        other_order.starts_with("message,elst_slack_s,"),
        "{other_order}"
    );
    let back = ev
        .rows_from_csv("reordered.csv", &other_order)
        .expect("columns in another order read");
    assert_same_rows(&back, &rows);
    // Shards with their columns in another order merge into the run's table.
    let shards: Vec<(String, String)> = (1..=2)
        .map(|k| {
            let part = ev.run_collect(&Shard::new(k, 2).expect("shard").indices(4));
            (format!("shard-{k}.csv"), reversed(&csv(&part)))
        })
        .collect();
    let single = csv(&ev.run_collect(&[0, 1, 2, 3]));
    assert_eq!(merge_csv(&shards, Some(4)).expect("merge"), single);
}

#[test]
fn a_missing_column_is_named() {
    let ev = evaluator();
    let table = csv(&rows(&ev));
    for column in ["total_s", "plan", "limited_jerk", "dose_rate_scale"] {
        let e = error(&ev, &without(&table, &[column]));
        assert!(
            e.starts_with(&format!("t.csv: line 1: no column {column} (")),
            "{column}: {e}"
        );
        let e = merge_csv(&[("m.csv".into(), without(&table, &[column]))], None)
            .expect_err("no merge")
            .to_string();
        assert!(e.contains(&format!("no column {column}")), "{e}");
    }
    let e = error(&ev, &table.replacen("violations", "violation", 1));
    assert!(
        e.starts_with("t.csv: line 1: unknown column \"violation\""),
        "{e}"
    );
}

#[test]
fn a_bad_number_names_line_and_column() {
    let ev = evaluator();
    let table = csv(&rows(&ev));
    // Row 1 (line 3): its total_s damaged.
    let mut f = fields(&table);
    let col = f[0].iter().position(|h| h == "total_s").expect("total_s");
    f[2][col] = "12.x".into();
    let e = error(&ev, &join(&f, false, "\n"));
    assert_eq!(
        e,
        "t.csv: line 3: column total_s: expected a number, found \"12.x\""
    );
    // And a count, in a CRLF table with its columns reversed.
    let mut f = fields(&table);
    let col = f[0]
        .iter()
        .position(|h| h == "limited_elst")
        .expect("limited_elst");
    f[1][col] = "-1".into();
    for line in &mut f {
        line.reverse();
    }
    let e = error(&ev, &join(&f, false, "\r\n"));
    assert_eq!(
        e,
        "t.csv: line 2: column limited_elst: expected a count, found \"-1\""
    );
    // A line with a field too many.
    let e = error(&ev, &table.replacen(",ok,", ",ok,,", 1));
    assert!(
        e.starts_with("t.csv: line 2: 41 fields; expected 40"),
        "{e}"
    );
    // An unknown status.
    let e = error(&ev, &table.replacen(",ok,", ",fine,", 1));
    assert!(
        e.starts_with("t.csv: line 2: column status: expected ok, infeasible, invalid or error"),
        "{e}"
    );
}

/// A table an earlier arcsim wrote (without the certificate, the beam axes, the split of the
/// beam-on time or the spill columns) is refused by the read-back and the merge alike, in any of
/// the forms a spreadsheet leaves it: the error names the file, the first column missing and the
/// header expected.
#[test]
fn a_table_of_an_earlier_header_is_refused_naming_the_file_and_the_header() {
    let ev = evaluator();
    let table = csv(&rows(&ev));
    let expected = format!("expected the arcsim sweep CSV header: {CSV_HEADER}");
    for (missing, dropped) in [
        ("lower_bound_s", &["lower_bound_s", "gap_s"][..]),
        ("gap_s", &["gap_s"][..]),
        (
            "scan_speed_mm_per_s",
            &["scan_speed_mm_per_s", "dose_rate_scale"][..],
        ),
        (
            "spill_charge_mu",
            &["spill_charge_mu", "spill_waiting_s"][..],
        ),
    ] {
        let old = without(&table, dropped);
        for (name, text) in [
            ("old.csv", old.clone()),
            (
                "old-crlf.csv",
                format!("\u{feff}{}", old.replace('\n', "\r\n")),
            ),
            ("old-reordered.csv", reversed(&old)),
        ] {
            let message = format!(
                "{name}: line 1: no column {missing} (a table of an earlier arcsim? run its sweep \
                 again); {expected}"
            );
            let e = ev
                .rows_from_csv(name, &text)
                .expect_err("an earlier header");
            assert_eq!(e.to_string(), message);
            let e = merge_csv(&[(name.into(), text)], Some(4)).expect_err("an earlier header");
            assert_eq!(e.to_string(), message);
        }
    }
}
