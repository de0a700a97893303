//! The recorder's element layout: one row per element (a sample of the chamber, or on a
//! synchrocyclotron one beam pulse) with the spot it belongs to and a free-running microsecond
//! counter, as REGGUI's `load_PBS_logs.m` reads it (its `FPGA_COUNT` branch and its S2C2
//! `burst_record` reader; docs/records.md lists every assumption).
//!
//! - A line holding `START_IRRADIATION` names the column whose value, on the next line, stamps
//!   the layer's first element (`2021-10-20 23:02:04.144 UTC`, `20170423-20:07:38.788` or
//!   `2018-06-11T11:59:54.846+02:00`; zone suffixes are not applied, one zone per log).
//! - The column line starts with `#ELEMENT_ID` (`SPOT_ID`, `FPGA_COUNT`, `PRIM_IC_X_POSITION`,
//!   `PRIM_IC_Y_POSITION`, `PRIM_IC_CHARGE`) or holds `SUBMAP_NUMBER` with `DEKIMO_ELEMENT_ID`,
//!   `SPOT_ID`, `FPGA_COUNT`, `X_POSITION(mm)`, `Y_POSITION(mm)`, `DOSE_PRIM(C)`.
//! - Rows whose element and spot numbers are positive count; a spot is a run of rows of one
//!   spot number. The counter wraps at 2²³ µs.

use super::read::{CsvRow, RawSpot};
use super::time::{parse_element_stamp, Stamp};
use crate::LogError;

/// The counter's period: it counts microseconds in 23 bits.
const COUNTER_WRAP_US: f64 = super::COUNTER_WRAP_US as f64;

/// Whether `text` is a record in the element layout: its column line (the first naming
/// `SUBMAP_NUMBER` or `FPGA_COUNT`) includes `FPGA_COUNT`. Only the header is read.
pub(super) fn is_element_layout(text: &str) -> bool {
    text.lines()
        .find(|l| l.contains("SUBMAP_NUMBER") || l.contains("FPGA_COUNT"))
        .is_some_and(|l| l.contains("FPGA_COUNT"))
}

/// The columns of the two header variants.
struct Columns {
    /// How many columns the header names.
    width: usize,
    element: usize,
    spot: usize,
    counter: usize,
    x: usize,
    y: usize,
    charge: usize,
}

fn columns(name: &str, line: u64, header: &str) -> Result<Columns, LogError> {
    let head: Vec<&str> = header.split(',').map(str::trim).collect();
    let names: [&str; 6] = if head.first() == Some(&"#ELEMENT_ID") {
        [
            "#ELEMENT_ID",
            "SPOT_ID",
            "FPGA_COUNT",
            "PRIM_IC_X_POSITION",
            "PRIM_IC_Y_POSITION",
            "PRIM_IC_CHARGE",
        ]
    } else {
        [
            "DEKIMO_ELEMENT_ID",
            "SPOT_ID",
            "FPGA_COUNT",
            "X_POSITION(mm)",
            "Y_POSITION(mm)",
            "DOSE_PRIM(C)",
        ]
    };
    let mut at = [0; 6];
    for (slot, want) in at.iter_mut().zip(names) {
        *slot = head.iter().position(|h| *h == want).ok_or_else(|| {
            LogError::at(
                name,
                line,
                None,
                format!("no column `{want}`; expected {}", names.join(", ")),
            )
        })?;
    }
    Ok(Columns {
        width: head.len(),
        element: at[0],
        spot: at[1],
        counter: at[2],
        x: at[3],
        y: at[4],
        charge: at[5],
    })
}

/// One counted row: its spot, its counter reading unwrapped (µs), physics X and Y on the
/// chamber (mm), its charge (C) and line.
struct Element {
    spot: i64,
    count_us: f64,
    pos: [f64; 2],
    charge_c: f64,
    line: u64,
}

/// The spots of the element-layout record `name` (its text `text`), times in seconds after
/// `origin`, each element lasting `default_period_s` where the file does not show its period (a
/// spot of one element on every spot); also the period used and the resolution of the
/// `START_IRRADIATION` stamp (which places the whole layer in time).
pub(super) fn read_element_spots(
    name: &str,
    text: &str,
    origin: &mut Option<i64>,
    default_period_s: f64,
) -> Result<(Vec<RawSpot>, f64, f64), LogError> {
    let lines: Vec<&str> = text.lines().collect();
    let mut start: Option<Stamp> = None;
    let mut header = None;
    let mut i = 0;
    while i < lines.len() {
        let l = lines[i];
        if l.contains("START_IRRADIATION") && start.is_none() {
            let col = l
                .split(',')
                .map(str::trim)
                .position(|h| h == "START_IRRADIATION")
                .unwrap_or(0);
            let value = lines
                .get(i + 1)
                .and_then(|v| v.split(',').nth(col))
                .unwrap_or("")
                .trim();
            let stamp = parse_element_stamp(value)
                .map_err(|m| LogError::at(name, i as u64 + 2, Some("START_IRRADIATION"), m))?;
            start = Some(stamp);
            i += 2;
            continue;
        }
        if l.contains("FPGA_COUNT") {
            header = Some((i as u64 + 1, columns(name, i as u64 + 1, l)?));
            break;
        }
        i += 1;
    }
    let Some((header_line, cols)) = header else {
        return Err(LogError::file(name, "no column line with FPGA_COUNT"));
    };
    let Some(start) = start else {
        return Err(LogError::file(name, "no START_IRRADIATION line before the columns; expected the stamp of the layer's first element"));
    };
    let elements = read_elements(name, &lines[header_line as usize..], header_line, &cols)?;
    let period_s = element_period_s(&elements).unwrap_or(default_period_s);
    let Some(first) = elements.first() else {
        return Ok((Vec::new(), period_s, start.resolution_s));
    };
    // The stamp reads the first element's time down to its resolution: placed mid-way.
    let t0 = start.since(origin) + 0.5 * start.resolution_s;
    let at = |e: &Element| t0 + (e.count_us - first.count_us) * 1e-6;
    let mut spots = Vec::new();
    let mut k = 0;
    while k < elements.len() {
        let j = k + elements[k..]
            .iter()
            .take_while(|e| e.spot == elements[k].spot)
            .count();
        let run = &elements[k..j];
        let last = &run[run.len() - 1];
        spots.push(RawSpot {
            t_start_s: at(&run[0]),
            t_end_s: at(last) + period_s,
            pos: last.pos,
            charge_c: run.iter().map(|e| e.charge_c.abs()).sum(),
            line: run[0].line,
        });
        k = j;
    }
    Ok((spots, period_s, start.resolution_s))
}

/// The rows after the column line (`first_line` its 1-based number) that belong to a spot, the
/// counter unwrapped; rows end at the first blank line.
fn read_elements(
    name: &str,
    rows: &[&str],
    first_line: u64,
    cols: &Columns,
) -> Result<Vec<Element>, LogError> {
    let mut out: Vec<Element> = Vec::new();
    let (mut wraps, mut last_raw) = (0.0, None::<f64>);
    for (i, l) in rows.iter().enumerate() {
        let line = first_line + i as u64 + 1;
        if l.trim().is_empty() {
            break;
        }
        let row = CsvRow {
            fields: l.split(',').map(str::trim).collect(),
            width: cols.width,
            name,
            line,
        };
        let raw = row.number(cols.counter, "FPGA_COUNT")?;
        if !(0.0..COUNTER_WRAP_US).contains(&raw) {
            return Err(LogError::at(
                name,
                line,
                Some("FPGA_COUNT"),
                format!("{raw}; expected a counter reading from 0 to 2^23 µs"),
            ));
        }
        if last_raw.is_some_and(|p| raw < p) {
            wraps += COUNTER_WRAP_US;
        }
        last_raw = Some(raw);
        let (element, spot) = (
            row.number(cols.element, "element id")?,
            row.number(cols.spot, "SPOT_ID")?,
        );
        if element <= 0.0 || spot <= 0.0 {
            continue;
        }
        out.push(Element {
            spot: spot as i64,
            count_us: raw + wraps,
            pos: [
                row.number(cols.x, "X position")?,
                row.number(cols.y, "Y position")?,
            ],
            charge_c: row.number(cols.charge, "charge")?,
            line,
        });
    }
    Ok(out)
}

/// The median step of the counter between consecutive elements of one spot, s (`None` when no
/// spot has two).
fn element_period_s(elements: &[Element]) -> Option<f64> {
    let mut steps: Vec<f64> = elements
        .windows(2)
        .filter(|w| w[0].spot == w[1].spot && w[1].count_us > w[0].count_us)
        .map(|w| w[1].count_us - w[0].count_us)
        .collect();
    if steps.is_empty() {
        return None;
    }
    steps.sort_by(f64::total_cmp);
    Some(steps[steps.len() / 2] * 1e-6)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A record of two spots in the `#ELEMENT_ID` variant, the counter wrapping inside the
    /// second spot, an idle row (element 0) between them.
    fn record(header: &str, rows: &[&str]) -> String {
        format!(
            "beamline,test\nSTART_IRRADIATION,NB_ELEMENTS\n2026-01-01T08:00:00.000,5\n{header}\n{}\n\nfooter,1\n",
            rows.join("\n")
        )
    }

    #[test]
    fn spots_are_timed_from_the_stamp_and_the_counter_across_its_wrap() {
        let wrap = 8_388_608;
        let rows = [
            format!("1,x,1,{},1.0,2.0,1e-10", wrap - 1500),
            format!("2,x,1,{},1.5,2.5,1e-10", wrap - 500),
            format!("0,x,0,{},-10000,-10000,0", wrap - 200),
            format!("3,x,2,{},3.0,4.0,2e-10", 500),
            format!("4,x,2,{},3.0,4.0,2e-10", 1500),
        ];
        let refs: Vec<&str> = rows.iter().map(String::as_str).collect();
        let text = record(
            "#ELEMENT_ID,TIME,SPOT_ID,FPGA_COUNT,PRIM_IC_X_POSITION,PRIM_IC_Y_POSITION,PRIM_IC_CHARGE",
            &refs,
        );
        let mut origin = None;
        let (spots, period, stamp) =
            read_element_spots("rec", &text, &mut origin, 1e-3).expect("read");
        assert_eq!((period, stamp), (1e-3, 1e-3));
        assert_eq!(spots.len(), 2);
        // The stamp is to the millisecond: the first element is placed half of it after.
        let t0 = 0.0005;
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        assert!(close(spots[0].t_start_s, t0), "{}", spots[0].t_start_s);
        assert!(close(spots[0].t_end_s, t0 + 0.002));
        assert!(
            close(spots[1].t_start_s, t0 + 0.002),
            "{}",
            spots[1].t_start_s
        );
        assert!(close(spots[1].t_end_s, t0 + 0.004));
        assert_eq!(spots[0].pos, [1.5, 2.5]);
        assert!(close(spots[1].charge_c, 4e-10));
        assert_eq!((spots[0].line, spots[1].line), (5, 8));
    }

    #[test]
    fn the_submap_variant_reads_as_the_element_variant() {
        let text = record(
            "SUBMAP_NUMBER,DEKIMO_ELEMENT_ID,SPOT_ID,TIME,FPGA_COUNT,X_POSITION(mm),Y_POSITION(mm),DOSE_PRIM(C)",
            &[
                "0,1,1,x,1000,1.0,2.0,1e-10",
                "0,2,1,x,1250,1.0,2.0,1e-10",
                "1,3,2,x,4000,5.0,6.0,3e-10",
            ],
        );
        let mut origin = None;
        let (spots, period, stamp) =
            read_element_spots("rec", &text, &mut origin, 1e-3).expect("read");
        assert_eq!((period, stamp), (0.25e-3, 1e-3));
        assert_eq!(spots.len(), 2);
        assert!((spots[1].t_start_s - spots[0].t_start_s - 0.003).abs() < 1e-12);
        // A spot of one element lasts the period the file shows.
        assert!((spots[1].t_end_s - spots[1].t_start_s - 0.25e-3).abs() < 1e-12);
    }

    #[test]
    fn malformed_element_records_are_named_by_line_and_column() {
        let head = "#ELEMENT_ID,TIME,SPOT_ID,FPGA_COUNT,PRIM_IC_X_POSITION,PRIM_IC_Y_POSITION,PRIM_IC_CHARGE";
        let err = |text: &str| {
            read_element_spots("rec.csv", text, &mut None, 1e-3)
                .expect_err("refused")
                .to_string()
        };
        let e = err(&record(head, &["1,x,1,12x4,1,2,1e-10"]));
        assert!(
            e.contains("rec.csv")
                && e.contains("line 5")
                && e.contains("FPGA_COUNT")
                && e.contains("`12x4`; expected a number"),
            "{e}"
        );
        let e = err(&record(head, &["1,x,1,9000000,1,2,1e-10"]));
        assert!(
            e.contains("expected a counter reading from 0 to 2^23"),
            "{e}"
        );
        let e = err(&format!("{head}\n1,x,1,10,1,2,1e-10\n"));
        assert!(e.contains("no START_IRRADIATION line"), "{e}");
        let e = err(&record(
            "#ELEMENT_ID,SPOT_ID,FPGA_COUNT,PRIM_IC_CHARGE",
            &["1,1,10,1e-10"],
        ));
        assert!(
            e.contains("line 4") && e.contains("no column `PRIM_IC_X_POSITION`"),
            "{e}"
        );
        let bad_stamp = record(head, &[]).replace("2026-01-01T08:00:00.000", "01/01/2026 08:00");
        let e = err(&bad_stamp);
        assert!(
            e.contains("line 3") && e.contains("START_IRRADIATION"),
            "{e}"
        );
    }
}
