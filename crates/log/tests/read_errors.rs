//! Bad logs get clear, located errors: unsorted or repeated times, NaN, a missing required column
//! (named), bad flags and fields, an empty log, a file too large (refused with its size before
//! it is read); other CSVs read through a column mapping.

use arcsim_log::{parse_log, read_log, ColumnMap, LogError, MAX_LOG_BYTES};
use arcsim_test_support::temp_file;

const GOOD: &str = "t_s,gantry_angle_deg,beam_on,energy_mev,spot,mu
0.00,10.0,0,,,
0.01,10.1,1,150.2,0,0.5
0.02,10.2,1,150.2,1,0.25
0.03,10.3,0,,,0
";

fn read(text: &str) -> Result<arcsim_log::DeliveryLog, LogError> {
    parse_log(text.as_bytes(), "log.csv", &ColumnMap::default())
}

fn error(text: &str) -> String {
    read(text).expect_err("a bad log").to_string()
}

#[test]
fn a_good_log_reads_with_its_optional_columns() {
    let log = read(GOOD).expect("reads");
    assert_eq!(log.samples.len(), 4);
    assert!(log.has_energy && log.has_spot && log.has_mu);
    assert_eq!(log.samples[1].energy_mev, Some(150.2));
    assert_eq!(log.samples[2].spot, Some(1));
    assert_eq!(log.samples[0].mu, None);
    assert!((log.duration_s() - 0.03).abs() < 1e-12);
    // Only the required columns, in another order, with a byte-order mark and CRLF lines.
    let minimal = "\u{feff}beam_on,t_s,gantry_angle_deg,extra\r\n0,1,5,x\r\n1,2,6,y\r\n";
    let log = read(minimal).expect("reads");
    assert!(!log.has_energy && !log.has_spot && !log.has_mu);
    assert_eq!(log.samples[1].t_s, 2.0);
    assert!(log.samples[1].beam_on && log.samples[1].energy_mev.is_none());
}

#[test]
fn times_must_increase_strictly() {
    let repeated = GOOD.replace("0.02,10.2", "0.01,10.2");
    assert_eq!(
        error(&repeated),
        "log.csv: line 4: column t_s: time 0.01 s repeats the previous row's; expected strictly increasing times"
    );
    let unsorted = GOOD.replace("0.03,10.3", "0.015,10.3");
    assert_eq!(
        error(&unsorted),
        "log.csv: line 5: column t_s: time 0.015 s is before the previous row's 0.02 s; expected rows in time order"
    );
}

#[test]
fn every_field_is_checked_where_it_is() {
    let cases = [
        (GOOD.replace("10.2,1", "NaN,1"), "line 4: column gantry_angle_deg: expected a finite number (gantry angle in degrees), found \"NaN\""),
        (GOOD.replace("0.02,", "inf,"), "line 4: column t_s: expected a finite number"),
        (GOOD.replace("10.1,1", "10.1,2"), "line 3: column beam_on: expected 1 or true (beam on), 0 or false (off), found \"2\""),
        (GOOD.replace("150.2,0", "-3,0"), "line 3: column energy_mev: -3 MeV"),
        (GOOD.replace("150.2,1,", "150.2,1.5,"), "line 4: column spot: expected a spot index"),
        (GOOD.replace(",0.25", ",-0.25"), "line 4: column mu: -0.25 MU"),
        (GOOD.replace("0.03,10.3,0,,,0", "0.03,10.3,0,,"), "line 5: 5 fields; expected 6 (as the header)"),
    ];
    for (text, want) in cases {
        let e = error(&text);
        assert!(
            e.starts_with(&format!("log.csv: {want}")),
            "{e}\nwanted {want}"
        );
    }
}

/// `true` and `false` are what the error says they are: the same log as 1 and 0.
#[test]
fn beam_on_reads_true_and_false_as_its_error_says() {
    let words = GOOD
        .replace("10.1,1", "10.1,true")
        .replace("10.3,0", "10.3,false");
    assert_ne!(words, GOOD);
    let (a, b) = (read(&words).expect("words"), read(GOOD).expect("digits"));
    assert_eq!(a.samples, b.samples);
}

#[test]
fn missing_columns_and_empty_logs_are_named() {
    let e = error("t_s,beam_on\n0,1\n");
    assert_eq!(
        e,
        "log.csv: line 1: no column gantry_angle_deg: gantry angle in degrees (required); the header has t_s, beam_on"
    );
    let e = error("t_s,t_s,gantry_angle_deg,beam_on\n");
    assert!(e.contains("column t_s: appears twice"), "{e}");
    let e = error("");
    assert!(
        e.starts_with("log.csv: empty file; expected a header line"),
        "{e}"
    );
    let e = error("t_s,gantry_angle_deg,beam_on\n");
    assert!(e.starts_with("log.csv: no samples"), "{e}");
}

#[test]
fn another_csv_reads_through_a_column_mapping() {
    let vendor = "TIME,GantryAngle,Beam,Energy\n0,1,0,\n0.5,2,1,120\n";
    let map = ColumnMap::parse(
        "t_s=TIME, gantry_angle_deg=GantryAngle,beam_on=Beam,energy_mev=Energy",
        "--columns",
    )
    .expect("mapping");
    let log = parse_log(vendor.as_bytes(), "vendor.csv", &map).expect("reads");
    assert_eq!(log.samples[1].energy_mev, Some(120.0));
    assert!(log.has_energy && !log.has_spot);
    // Without the mapping the names are missing; a mapped name missing says what it maps.
    let e = parse_log(vendor.as_bytes(), "vendor.csv", &ColumnMap::default())
        .expect_err("unmapped")
        .to_string();
    assert!(e.contains("no column t_s"), "{e}");
    let map = ColumnMap::parse("t_s=Time", "--columns").expect("mapping");
    let e = parse_log(vendor.as_bytes(), "vendor.csv", &map)
        .expect_err("wrong name")
        .to_string();
    assert!(e.contains("no column Time (mapped from t_s)"), "{e}");
    for (bad, want) in [
        ("t_s", "expected FIELD=COLUMN"),
        ("time=T", "unknown field \"time\""),
        ("t_s=", "names no column"),
        ("t_s=A,t_s=B", "mapped twice"),
        // One source for two fields: refused, where it read the column twice.
        (
            "t_s=A,mu=A",
            "t_s and mu would both read column \"A\"; expected one column per field",
        ),
        ("mu=t_s", "t_s and mu would both read column \"t_s\""),
    ] {
        let e = ColumnMap::parse(bad, "--columns")
            .expect_err(bad)
            .to_string();
        assert!(e.starts_with("--columns: ") && e.contains(want), "{e}");
    }
}

/// A file above the limit is refused with its size, without being read (a sparse file: nothing
/// is written to disk).
#[test]
fn a_huge_log_is_refused_with_its_size() {
    let path = temp_file("huge.csv", GOOD.as_bytes());
    let file = std::fs::OpenOptions::new()
        .write(true)
        .open(&path)
        .expect("open");
    file.set_len(1 << 30).expect("a sparse 1 GiB file");
    let e = read_log(&path, &ColumnMap::default())
        .expect_err("too large")
        .to_string();
    assert!(
        e.contains("1073741824 bytes (1.00 GiB)") && e.contains(&MAX_LOG_BYTES.to_string()),
        "{e}"
    );
    let e = read_log(&path.with_file_name("absent.csv"), &ColumnMap::default())
        .expect_err("absent")
        .to_string();
    assert!(e.contains("absent.csv: cannot read the log"), "{e}");
}
