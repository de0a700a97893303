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
    // A table without the `combinations` column (an earlier arcsim's): refused, naming the file,
    // the column and the header expected.
    let old = file(&[1], "\n").replacen("index,combinations,", "index,", 1);
    let e = merge_csv(&[a.clone(), ("old.csv".into(), old)], None)
        .expect_err("an earlier header")
        .to_string();
    assert_eq!(
        e,
        format!(
            "old.csv: line 1: no column combinations (a table of an earlier arcsim? run its \
             sweep again); expected the arcsim sweep CSV header: {CSV_HEADER}"
        )
    );
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
        format!("e: empty file; expected the arcsim sweep CSV header: {CSV_HEADER}")
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
        Header::parse(rd.headers().expect("header")).map(|h| h.len)
    };
    let expected = format!("expected the arcsim sweep CSV header: {CSV_HEADER}");
    assert_eq!(parse(CSV_HEADER), Ok(COLUMNS.len()));
    // In another order: each column found by its name.
    let mut names: Vec<&str> = CSV_HEADER.split(',').collect();
    names.reverse();
    let reversed = names.join(",");
    let mut rd = reader(&reversed);
    let header = Header::parse(rd.headers().expect("header")).expect("reversed");
    let record = csv::StringRecord::from(names.clone());
    let in_order: Vec<&str> = header.in_order(&record).collect();
    assert_eq!(in_order.join(","), CSV_HEADER);
    let twice = CSV_HEADER.replacen("plan,", "plan,plan,", 1);
    assert_eq!(
        parse(&twice),
        Err(format!("line 1: column plan appears twice; {expected}"))
    );
    // A column missing (a table of an earlier arcsim): the first missing column is named.
    let half = CSV_HEADER.replacen("scanning_s,", "", 1);
    assert_eq!(
        parse(&half),
        Err(format!(
            "line 1: no column scanning_s (a table of an earlier arcsim? run its sweep again); \
             {expected}"
        ))
    );
    assert_eq!(
        parse(&format!("{CSV_HEADER},extra")),
        Err(format!("line 1: unknown column \"extra\"; {expected}"))
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
