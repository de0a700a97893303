//! Unit tests of the table's schema, writer, merge and reader.

use super::read::reader;
use super::schema::*;
use super::write::{one_line, write_records};
use super::*;
use crate::sweep::Axis;

/// A table of rows `rows` of a sweep of 5 (index, combinations, plan and schedule filled, the
/// status `error`, the other fields empty).
fn file(rows: &[usize], end: &str) -> String {
    let mut s = format!("{CSV_HEADER}{end}");
    let status = column_index("status");
    for r in rows {
        let mut fields = vec![String::new(); COLUMNS.len()];
        fields[..4].clone_from_slice(&[r.to_string(), "5".into(), "p".into(), "scan".into()]);
        fields[status] = "error".into();
        s.push_str(&format!("{}{end}", fields.join(",")));
    }
    s
}

#[test]
fn the_headers_are_the_column_list() {
    let names: Vec<&str> = COLUMNS.iter().map(|c| c.name).collect();
    assert_eq!(CSV_HEADER, names.join(","));
    let old: Vec<&str> = Layout::V1.columns().map(|c| c.name).collect();
    assert_eq!(CSV_HEADER_V1, old.join(","));
    let v2: Vec<&str> = Layout::V2.columns().map(|c| c.name).collect();
    assert_eq!(CSV_HEADER_V2, v2.join(","));
    let v3: Vec<&str> = Layout::V3.columns().map(|c| c.name).collect();
    assert_eq!(CSV_HEADER_V3, v3.join(","));
    let v4: Vec<&str> = Layout::V4.columns().map(|c| c.name).collect();
    assert_eq!(CSV_HEADER_V4, v4.join(","));
    let v5: Vec<&str> = Layout::V5.columns().map(|c| c.name).collect();
    assert_eq!(CSV_HEADER_V5, v5.join(","));
    assert_eq!(v5.len(), COLUMNS.len() - 5);
    assert_eq!(v4.len(), COLUMNS.len() - 6);
    assert_eq!(v3.len(), COLUMNS.len() - 7);
    assert_eq!(v2.len(), COLUMNS.len() - 9);
    assert_eq!(old.len(), COLUMNS.len() - 13);
    // One limit column per axis, named as the axis.
    let limits: Vec<Axis> = COLUMNS
        .iter()
        .filter_map(|c| match c.field {
            Field::Limit(a) => {
                assert_eq!(c.name, a.field());
                Some(a)
            }
            _ => None,
        })
        .collect();
    assert_eq!(limits, Axis::ALL);
}

#[test]
fn merge_sorts_and_checks() {
    let a = ("a".to_string(), file(&[0, 2, 4], "\n"));
    let b = ("b".to_string(), file(&[1, 3], "\n"));
    let merged = merge_csv(&[b.clone(), a.clone()], Some(5)).expect("merge");
    assert_eq!(merged, file(&[0, 1, 2, 3, 4], "\n"));
    // CRLF and a byte-order mark: the merged table is the one a run writes.
    let c = (
        "c".to_string(),
        format!("\u{feff}{}", file(&[1, 3], "\r\n")),
    );
    assert_eq!(merge_csv(&[a.clone(), c], Some(5)).expect("merge"), merged);
    assert!(merge_csv(&[a.clone(), b.clone()], Some(6)).is_err());
    assert!(merge_csv(std::slice::from_ref(&a), None)
        .expect_err("gap")
        .to_string()
        .contains("row 1 of 5 is missing"));
    // The last row missing: found from the rows' own count, without the sweep file.
    let short = ("s".to_string(), file(&[0, 2], "\n"));
    let e = merge_csv(&[short, b.clone()], None).expect_err("last row");
    assert!(e.to_string().contains("row 4 of 5 is missing"), "{e}");
    // Tables of sweeps of different sizes.
    let other = (
        "o".to_string(),
        file(&[1, 3], "\n").replace(",5,p,", ",6,p,"),
    );
    let e = merge_csv(&[a.clone(), other], None).expect_err("sizes");
    assert!(e.to_string().contains("a sweep of 6 combinations"), "{e}");
    // A table without the column (an earlier header's) still merges on its indices.
    let v3 = |rows: &[usize]| {
        let mut s = format!("{CSV_HEADER_V3}\n");
        let names: Vec<&str> = CSV_HEADER_V3.split(',').collect();
        let status = names.iter().position(|c| *c == "status").expect("status");
        for r in rows {
            let mut fields = vec![String::new(); names.len()];
            fields[..3].clone_from_slice(&[r.to_string(), "p".into(), "scan".into()]);
            fields[status] = "error".into();
            s.push_str(&format!("{}\n", fields.join(",")));
        }
        s
    };
    let old = merge_csv(&[("x".into(), v3(&[1])), ("y".into(), v3(&[0]))], None);
    assert_eq!(old.expect("older tables"), v3(&[0, 1]));
    assert!(merge_csv(&[a.clone(), a.clone()], None)
        .expect_err("dup")
        .to_string()
        .contains("also appears"));
    assert!(merge_csv(&[("c".into(), "x\n".into())], None)
        .expect_err("header")
        .to_string()
        .contains("header"));
    assert_eq!(
        merge_csv(&[("e".into(), String::new())], None)
            .expect_err("empty")
            .to_string(),
        "e: empty file; expected the arcsim sweep CSV header"
    );
    let e = merge_csv(
        &[(
            "d".into(),
            file(&[0], "\n").replacen("0,5,p", "zero,5,p", 1),
        )],
        None,
    )
    .expect_err("index")
    .to_string();
    assert_eq!(
        e,
        "d: line 2: column index: expected a row index (a count), found \"zero\""
    );
    let cut = file(&[0, 1], "\n");
    let e = merge_csv(&[("k".into(), cut[..cut.len() - 1].to_string())], None)
        .expect_err("cut")
        .to_string();
    assert!(e.contains("the last line is incomplete"), "{e}");
}

#[test]
fn a_header_names_each_column_once() {
    let parse = |h: &str| {
        let mut rd = reader(h);
        Header::parse(rd.headers().expect("header")).map(|h| h.layout)
    };
    assert_eq!(parse(CSV_HEADER), Ok(Layout::Current));
    assert_eq!(parse(CSV_HEADER_V1), Ok(Layout::V1));
    assert_eq!(parse(CSV_HEADER_V2), Ok(Layout::V2));
    assert_eq!(
        parse(&CSV_HEADER_V2.replacen("speedup,", "speedup,gap_s,", 1)),
        Err("line 1: no column lower_bound_s; expected the arcsim sweep CSV header".into())
    );
    let twice = CSV_HEADER.replacen("plan,", "plan,plan,", 1);
    assert_eq!(
        parse(&twice),
        Err("line 1: column plan appears twice; expected the arcsim sweep CSV header".into())
    );
    // Half new, half old: the first missing column of the current header.
    let half = CSV_HEADER.replacen("scanning_s,", "", 1);
    assert_eq!(
        parse(&half),
        Err("line 1: no column scanning_s; expected the arcsim sweep CSV header".into())
    );
}

#[test]
fn text_fields_stay_on_one_line() {
    assert_eq!(one_line("a,b \"c\"\nd\r\n"), "a,b \"c\" d  ");
    let mut out = Vec::new();
    write_records(&mut out, [["a,b \"c\" d", "plain", ""]]).expect("write");
    assert_eq!(out, b"\"a,b \"\"c\"\" d\",plain,\n");
}

#[test]
fn records_are_numbered_by_line() {
    for end in ["\n", "\r\n"] {
        let text = format!("\u{feff}a,b{end}1,2{end}{end}3,\"x{end}y\"{end}4,5{end}");
        let mut rd = reader(&text);
        let mut lines = CsvLineNumbers::new(&text);
        let numbers: Vec<usize> = rd
            .records()
            .map(|r| lines.at(r.expect("record").position().expect("position").byte()))
            .collect();
        assert_eq!(numbers, [2, 4, 6], "{end:?}");
    }
}
