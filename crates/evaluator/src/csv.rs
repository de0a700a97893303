//! The results table as CSV (one header line, then one line per combination in index order) and
//! the merge of shard outputs. Numbers are written in Rust's shortest round-trip form, so equal
//! results give equal bytes; there are no timing fields.
//!
//! The limit columns (`jerk_deg_per_s3` to `dose_rate_scale`) follow one rule: each holds the
//! value the combination uses, the swept one or else the base machine's ([`crate::Defaults`]).
//! Two columns hold the machine's value where the plan can override it: `elst_up_s` and
//! `elst_down_s` (layers with their own switching time keep it) and `window_deg` when the window
//! is not swept (it is then the machine's `default_window_deg`, used by the control points without
//! a window of their own; a swept window replaces every control point's). `dose_rate_scale` is 1
//! when not swept (the machine's own dose rate). A column is empty only where the machine has no
//! single value: `elst_up_s` for a polynomial ELST model, `scan_speed_mm_per_s` for a `per_mu`
//! beam model (no scanning speed) or a `scanning` one with separate x and y speeds.
//!
//! Tables of an older arcsim ([`CSV_HEADER_V2`]: without the certificate's `lower_bound_s` and
//! `gap_s`; [`CSV_HEADER_V1`]: also without the two beam axes and the split of the beam-on time)
//! still merge (with tables of the same header) and read back.
//!
//! Every column is defined once, in `COLUMNS`: its name and how a row writes it and reads back
//! into one. The writer, the reader and the merge all go through that list and the `csv` crate,
//! so a table read back may have its columns in any order (found by their header name), quoted
//! fields, a UTF-8 byte-order mark and CRLF line ends.

use std::io::Write;

use arcsim_sequencer::{Breakdown, LimiterCounts, Margins};
use csv::StringRecord;

use crate::run::{Evaluator, Outcome, Row, Status};
use crate::sweep::Axis;
use crate::EvalError;

/// How one column of the sweep table is written from a row and read back into one.
#[derive(Clone, Copy)]
enum Field {
    /// The combination's index: read first, it names the combination the rest is checked against.
    Index,
    /// The sweep's number of combinations: a shard's table says how many rows the whole sweep
    /// has, so a merge finds a missing last row without the sweep file.
    Combinations,
    /// Text naming the combination (plan label, schedule entry): written from the row, and on
    /// reading it must be what the sweep's combination of that index writes.
    Name(fn(&Row) -> String),
    /// The value of a limit used (see the module documentation): written from the setting and the
    /// base machine; on reading it must be the sweep's combination's. A table without the column
    /// (an older arcsim's) holds only combinations that leave the axis to the base machine.
    Limit(Axis),
    Status,
    /// A number of an `ok` row's outcome; a table without the column (an older arcsim's) reads
    /// it as unknown (NaN).
    Number(fn(&Outcome) -> f64, fn(&mut Outcome) -> &mut f64),
    /// A number of an `ok` row's outcome that may be absent (empty).
    Optional(
        fn(&Outcome) -> Option<f64>,
        fn(&mut Outcome) -> &mut Option<f64>,
    ),
    /// A count of an `ok` row's outcome.
    Count(fn(&Outcome) -> usize, fn(&mut Outcome) -> &mut usize),
    /// A margin, written when the row has margins; not read back (summaries do not use them).
    Margin(fn(&Margins) -> f64),
    Message,
}

/// One column of the sweep table.
#[derive(Clone, Copy)]
struct Column {
    name: &'static str,
    field: Field,
}

/// Defines [`CSV_HEADER`] and [`COLUMNS`] from one list of `name => field`.
macro_rules! sweep_columns {
    ($first:literal => $first_field:expr, $($name:literal => $field:expr),+ $(,)?) => {
        /// The CSV header line (without the newline): the names of the table's columns.
        pub const CSV_HEADER: &str = concat!($first $(, ",", $name)+);

        /// The columns of the sweep table, in the order written.
        const COLUMNS: &[Column] = &[
            Column { name: $first, field: $first_field },
            $(Column { name: $name, field: $field },)+
        ];
    };
}

/// A [`Field::Number`], [`Field::Optional`] or [`Field::Count`] of the outcome field `$path`.
macro_rules! outcome {
    ($kind:ident, $($path:ident).+) => {
        Field::$kind(|o| o.$($path).+, |o| &mut o.$($path).+)
    };
}

sweep_columns! {
    "index" => Field::Index,
    "combinations" => Field::Combinations,
    "plan" => Field::Name(|r| r.plan.clone()),
    "schedule" => Field::Name(|r| r.schedule.name()),
    "jerk_deg_per_s3" => Field::Limit(Axis::Jerk),
    "accel_deg_per_s2" => Field::Limit(Axis::Accel),
    "speed_deg_per_s" => Field::Limit(Axis::Speed),
    "elst_up_s" => Field::Limit(Axis::ElstUp),
    "elst_down_s" => Field::Limit(Axis::ElstDown),
    "window_deg" => Field::Limit(Axis::Window),
    "scan_speed_mm_per_s" => Field::Limit(Axis::ScanSpeed),
    "dose_rate_scale" => Field::Limit(Axis::DoseRateScale),
    "status" => Field::Status,
    "total_s" => outcome!(Number, total_s),
    "beam_on_s" => outcome!(Number, breakdown.beam_on_s),
    "spot_irradiation_s" => outcome!(Number, breakdown.spot_irradiation_s),
    "scanning_s" => outcome!(Number, breakdown.scanning_s),
    "energy_switching_s" => outcome!(Number, breakdown.energy_switching_s),
    "lost_s" => outcome!(Number, breakdown.lost_s),
    "speedup" => outcome!(Optional, speedup),
    "lower_bound_s" => outcome!(Optional, lower_bound_s),
    "gap_s" => outcome!(Optional, gap_s),
    "limited_elst" => outcome!(Count, limiter_counts.elst),
    "limited_speed" => outcome!(Count, limiter_counts.speed),
    "limited_accel" => outcome!(Count, limiter_counts.accel),
    "limited_jerk" => outcome!(Count, limiter_counts.jerk),
    "limited_none" => outcome!(Count, limiter_counts.none),
    "violations" => outcome!(Count, violations),
    "speed_use" => Field::Margin(|m| m.speed_use.value),
    "accel_use" => Field::Margin(|m| m.accel_use.value),
    "jerk_use" => Field::Margin(|m| m.jerk_use.value),
    "window_slack_deg" => Field::Margin(|m| m.window_slack_deg.value),
    "elst_slack_s" => Field::Margin(|m| m.elst_slack_s.value),
    "message" => Field::Message,
}

/// The header of the tables of arcsim before the `combinations` column: [`CSV_HEADER`] without
/// it. Such tables merge (the sweep's size then comes from `--sweep`, or from the indices) and
/// read back.
pub const CSV_HEADER_V3: &str = "index,plan,schedule,jerk_deg_per_s3,accel_deg_per_s2,speed_deg_per_s,elst_up_s,elst_down_s,window_deg,\
scan_speed_mm_per_s,dose_rate_scale,status,total_s,beam_on_s,spot_irradiation_s,scanning_s,energy_switching_s,lost_s,speedup,\
lower_bound_s,gap_s,limited_elst,limited_speed,limited_accel,limited_jerk,limited_none,violations,speed_use,accel_use,jerk_use,\
window_slack_deg,elst_slack_s,message";

/// The header of the tables of arcsim before the certificate: [`CSV_HEADER`] without the
/// `lower_bound_s` and `gap_s` columns. Such tables merge and read back (no certificate).
pub const CSV_HEADER_V2: &str = "index,plan,schedule,jerk_deg_per_s3,accel_deg_per_s2,speed_deg_per_s,elst_up_s,elst_down_s,window_deg,\
scan_speed_mm_per_s,dose_rate_scale,status,total_s,beam_on_s,spot_irradiation_s,scanning_s,energy_switching_s,lost_s,speedup,\
limited_elst,limited_speed,limited_accel,limited_jerk,limited_none,violations,speed_use,accel_use,jerk_use,window_slack_deg,\
elst_slack_s,message";

/// The header of an older arcsim's tables: no `scan_speed_mm_per_s`, `dose_rate_scale`,
/// `spot_irradiation_s` or `scanning_s` columns, the others in the order of [`CSV_HEADER`]. Such
/// tables merge (with tables of the same header; the merged table keeps it) and read back
/// ([`Evaluator::rows_from_csv`]).
pub const CSV_HEADER_V1: &str = "index,plan,schedule,jerk_deg_per_s3,accel_deg_per_s2,speed_deg_per_s,elst_up_s,elst_down_s,window_deg,\
status,total_s,beam_on_s,energy_switching_s,lost_s,speedup,limited_elst,limited_speed,limited_accel,limited_jerk,limited_none,\
violations,speed_use,accel_use,jerk_use,window_slack_deg,elst_slack_s,message";

/// The certificate's columns, which [`CSV_HEADER_V2`]'s tables do not have.
const CERTIFICATE_COLUMNS: [&str; 2] = ["lower_bound_s", "gap_s"];

/// Which header a table has.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Layout {
    /// [`CSV_HEADER`]'s columns.
    Current,
    /// [`CSV_HEADER_V3`]'s columns.
    V3,
    /// [`CSV_HEADER_V2`]'s columns.
    V2,
    /// [`CSV_HEADER_V1`]'s columns.
    V1,
}

impl Layout {
    /// Newest first: a header is read as the first layout that has all of its columns.
    const ALL: [Layout; 4] = [Layout::Current, Layout::V3, Layout::V2, Layout::V1];

    /// Whether tables of this layout have `column`.
    fn has(self, column: &Column) -> bool {
        match self {
            Layout::Current => true,
            Layout::V3 => column.name != "combinations",
            Layout::V2 => {
                column.name != "combinations" && !CERTIFICATE_COLUMNS.contains(&column.name)
            }
            Layout::V1 => CSV_HEADER_V1.split(',').any(|n| n == column.name),
        }
    }

    /// The columns of this layout, in the order written.
    fn columns(self) -> impl Iterator<Item = &'static Column> {
        COLUMNS.iter().filter(move |c| self.has(c))
    }

    fn describe(self) -> &'static str {
        match self {
            Layout::Current => "the current arcsim sweep CSV header",
            Layout::V3 => "an older arcsim's header (without the combinations column)",
            Layout::V2 => "an older arcsim's header (without the lower_bound_s and gap_s columns)",
            Layout::V1 => "an older arcsim's header (without the scan_speed_mm_per_s, dose_rate_scale, spot_irradiation_s and scanning_s columns)",
        }
    }
}

/// A table's header: its layout and where each of [`COLUMNS`] is (`None`: not in this layout).
struct Header {
    layout: Layout,
    at: Vec<Option<usize>>,
    /// The positions of the layout's columns, in the layout's order.
    order: Vec<usize>,
    len: usize,
}

impl Header {
    /// Finds the columns by name; every name must be a column of the table, once, and the names
    /// must be those of [`CSV_HEADER`], [`CSV_HEADER_V3`], [`CSV_HEADER_V2`] or [`CSV_HEADER_V1`]
    /// (in any order).
    fn parse(names: &StringRecord) -> Result<Header, String> {
        const EXPECTED: &str = "expected the arcsim sweep CSV header";
        if names.iter().all(str::is_empty) {
            return Err(format!("empty file; {EXPECTED}"));
        }
        let mut at = vec![None; COLUMNS.len()];
        for (i, name) in names.iter().enumerate() {
            let k = COLUMNS
                .iter()
                .position(|c| c.name == name)
                .ok_or_else(|| format!("line 1: unknown column {name:?}; {EXPECTED}"))?;
            if at[k].replace(i).is_some() {
                return Err(format!("line 1: column {name} appears twice; {EXPECTED}"));
            }
        }
        let present = |c: &Column| at[column_index(c.name)].is_some();
        // The oldest layout with every column the table has: the table must have all of its.
        let layout = Layout::ALL
            .into_iter()
            .rev()
            .find(|l| COLUMNS.iter().all(|c| !present(c) || l.has(c)))
            .unwrap_or(Layout::Current);
        if let Some(missing) = layout.columns().find(|c| !present(c)) {
            return Err(format!("line 1: no column {}; {EXPECTED}", missing.name));
        }
        let order = COLUMNS
            .iter()
            .zip(&at)
            .filter(|(c, _)| layout.has(c))
            .filter_map(|(_, i)| *i)
            .collect();
        Ok(Header {
            layout,
            at,
            order,
            len: names.len(),
        })
    }

    /// The field of `COLUMNS[k]` in `record`; `None` when the table has no such column.
    fn get<'r>(&self, record: &'r StringRecord, k: usize) -> Option<&'r str> {
        self.at[k].and_then(|i| record.get(i))
    }
}

/// The position of the column named `name` in [`COLUMNS`] (a name of the list).
fn column_index(name: &str) -> usize {
    COLUMNS
        .iter()
        .position(|c| c.name == name)
        .unwrap_or_else(|| unreachable!("{name} is a column of COLUMNS"))
}

/// A reader of a table's text: columns by name, quoted fields, a byte-order mark, CRLF.
fn reader(text: &str) -> csv::Reader<&[u8]> {
    csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_reader(text.as_bytes())
}

/// The records of `text` after its header, each with its line number, and the header.
fn records(text: &str) -> Result<(Header, Vec<(usize, StringRecord)>), String> {
    let mut rd = reader(text);
    let header = Header::parse(rd.headers().map_err(|e| e.to_string())?)?;
    let mut lines = CsvLineNumbers::new(text);
    let mut out = Vec::new();
    for record in rd.records() {
        let record = record.map_err(|e| e.to_string())?;
        let line = lines.at(record.position().map_or(0, |p| p.byte()));
        if record.len() != header.len {
            return Err(format!(
                "line {line}: {} fields; expected {} (as the header)",
                record.len(),
                header.len
            ));
        }
        out.push((line, record));
    }
    Ok((header, out))
}

/// Line numbers (from 1) of the records of a CSV text, in order, for errors that name the line.
/// (The `csv` reader's own count lags a line behind after a CRLF line end.) Also used by the
/// CLI's batch input.
pub struct CsvLineNumbers<'a> {
    text: &'a [u8],
    /// Bytes counted so far, and the line they end on.
    byte: usize,
    line: usize,
}

impl<'a> CsvLineNumbers<'a> {
    /// Line numbers of the records of `text`.
    pub fn new(text: &'a str) -> Self {
        CsvLineNumbers {
            text: text.as_bytes(),
            byte: 0,
            line: 1,
        }
    }

    /// The line of the record the reader places at `byte`: the first line with content from
    /// there (the position may be at the line end before it). Positions must not decrease.
    pub fn at(&mut self, byte: u64) -> usize {
        let mut end = usize::try_from(byte).map_or(self.text.len(), |b| b.min(self.text.len()));
        while self
            .text
            .get(end)
            .is_some_and(|b| matches!(b, b'\r' | b'\n'))
        {
            end += 1;
        }
        if end > self.byte {
            self.line += self.text[self.byte..end]
                .iter()
                .filter(|&&b| b == b'\n')
                .count();
            self.byte = end;
        }
        self.line
    }
}

/// A text field on one line: a table row is one line (line breaks become spaces).
fn one_line(s: &str) -> String {
    s.chars()
        .map(|c| if c == '\n' || c == '\r' { ' ' } else { c })
        .collect()
}

/// Writes `records` as CSV lines (quoted where a field needs it).
fn write_records<'a, I, R>(out: &mut impl Write, records: I) -> std::io::Result<()>
where
    I: IntoIterator<Item = R>,
    R: IntoIterator<Item = &'a str>,
{
    let mut w = csv::WriterBuilder::new()
        .flexible(true)
        .buffer_capacity(4096)
        .from_writer(out);
    for r in records {
        w.write_record(r).map_err(csv_io)?;
    }
    w.flush()
}

fn csv_io(e: csv::Error) -> std::io::Error {
    match e.into_kind() {
        csv::ErrorKind::Io(e) => e,
        kind => std::io::Error::other(format!("{kind:?}")),
    }
}

/// Writes the header line.
pub fn write_csv_header(out: &mut impl Write) -> std::io::Result<()> {
    writeln!(out, "{CSV_HEADER}")
}

/// Writes one row as one line. The limit columns hold the values used (see the module
/// documentation); empty fields: a result the row does not have (and the upward ELST of a
/// polynomial ELST model).
pub fn write_csv_row(out: &mut impl Write, r: &Row) -> std::io::Result<()> {
    let fields: Vec<String> = COLUMNS.iter().map(|c| field_text(c.field, r)).collect();
    write_records(out, [fields.iter().map(String::as_str)])
}

/// The text of one field of `r`; numbers are written without the sign of a zero.
fn field_text(field: Field, r: &Row) -> String {
    let outcome = |f: &dyn Fn(&Outcome) -> Option<String>| r.outcome.as_ref().and_then(f);
    let number = |x: f64| arcsim_plan::without_zero_sign(x.to_string());
    let text = match field {
        Field::Index => Some(r.index.to_string()),
        Field::Combinations => Some(r.combinations.to_string()),
        Field::Name(get) => Some(one_line(&get(r))),
        Field::Limit(axis) => r.setting.get_or(axis, &r.defaults).map(number),
        Field::Status => Some(r.status.name().to_string()),
        Field::Number(get, _) => outcome(&|o| Some(number(get(o)))),
        Field::Optional(get, _) => outcome(&|o| get(o).map(number)),
        Field::Count(get, _) => outcome(&|o| Some(get(o).to_string())),
        Field::Margin(get) => outcome(&|o| o.margins.as_ref().map(|m| number(get(m)))),
        Field::Message => Some(one_line(&r.message)),
    };
    text.unwrap_or_default()
}

/// Joins shard outputs (`(name, text)` pairs, in any order) into the table a single run writes.
/// Every input must have the sweep header, all the same one ([`CSV_HEADER`], or all an older
/// arcsim's [`CSV_HEADER_V3`], [`CSV_HEADER_V2`] or [`CSV_HEADER_V1`], which the merged table then
/// keeps; the columns of an input may be in any order, the merged table has them in the
/// header's); indices must not repeat and must be exactly `0..n`, where `n` is the sweep's
/// combination count: `expected` when given (from the sweep file), and the `combinations`
/// column of every row (which must agree with each other and with `expected`). A table without
/// that column (an older arcsim's) and no `expected` must cover `0..n` without gaps.
pub fn merge_csv(
    inputs: &[(String, String)],
    expected: Option<usize>,
) -> Result<String, EvalError> {
    // (index, fields in the layout's order, input name)
    let mut rows: Vec<(usize, Vec<String>, &str)> = Vec::new();
    // The layout of the first input, and its name.
    let mut first: Option<(Layout, &str)> = None;
    // The sweep's size as the first row that says it does, and where.
    let mut size: Option<(usize, String)> = expected.map(|n| (n, "the sweep file".to_string()));
    for (name, text) in inputs {
        let merr = |message: String| EvalError::Merge {
            file: name.clone(),
            message,
        };
        let (header, records) = records(text).map_err(merr)?;
        match first {
            None => first = Some((header.layout, name)),
            Some((layout, first_name)) if layout != header.layout => {
                return Err(merr(format!(
                    "line 1: {}, but {first_name} has {}; expected the tables of one run",
                    header.layout.describe(),
                    layout.describe()
                )));
            }
            Some(_) => {}
        }
        if !text.ends_with('\n') {
            return Err(merr(
                "the last line is incomplete (no newline): was the run killed while writing?"
                    .into(),
            ));
        }
        let index_column = column_index("index");
        let size_column = column_index("combinations");
        for (line, record) in records {
            let count = |column: usize, what: &str| -> Result<Option<usize>, EvalError> {
                let Some(field) = header.get(&record, column) else {
                    return Ok(None);
                };
                field.trim().parse::<usize>().map(Some).map_err(|_| {
                    merr(format!(
                        "line {line}: column {}: expected {what}, found {field:?}",
                        COLUMNS[column].name
                    ))
                })
            };
            let index = count(index_column, "a row index (a count)")?.unwrap_or_default();
            if let Some(n) = count(size_column, "the sweep's number of combinations")? {
                match &size {
                    None => size = Some((n, format!("{name} line {line}"))),
                    Some((m, from)) if *m != n => {
                        return Err(merr(format!(
                            "line {line}: a sweep of {n} combinations, but {from} says {m}; expected the tables of one sweep"
                        )));
                    }
                    Some(_) => {}
                }
                if index >= n {
                    return Err(merr(format!(
                        "line {line}: row {index} of a sweep of {n} combinations"
                    )));
                }
            }
            let fields = header
                .order
                .iter()
                .map(|&i| record[i].to_string())
                .collect();
            rows.push((index, fields, name));
        }
    }
    rows.sort_by_key(|r| r.0);
    for pair in rows.windows(2) {
        if pair[0].0 == pair[1].0 {
            return Err(EvalError::Merge {
                file: pair[1].2.to_string(),
                message: format!(
                    "row {} also appears in {}; expected each combination once",
                    pair[1].0, pair[0].2
                ),
            });
        }
    }
    let present = rows.len();
    let total = size.as_ref().map(|s| s.0);
    let missing = rows
        .iter()
        .enumerate()
        .find(|(i, r)| r.0 != *i)
        .map(|(i, _)| i)
        .or_else(|| total.filter(|&n| present < n).map(|_| present));
    if let Some(i) = missing {
        let of = total.map_or(String::new(), |n| format!(" of {n}"));
        return Err(EvalError::Merge {
            file: "merged shards".into(),
            message: format!(
                "row {i}{of} is missing; {present} rows present (is a shard missing or interrupted?)"
            ),
        });
    }
    if let Some(n) = expected {
        if present != n {
            return Err(EvalError::Merge {
                file: "merged shards".into(),
                message: format!("{present} rows; the sweep has {n} combinations (is a shard missing or interrupted?)"),
            });
        }
    }
    let layout = first.map_or(Layout::Current, |f| f.0);
    let header: Vec<&str> = layout.columns().map(|c| c.name).collect();
    let lines = rows
        .iter()
        .map(|r| r.1.iter().map(String::as_str).collect::<Vec<_>>());
    let mut out = Vec::with_capacity(inputs.iter().map(|(_, t)| t.len()).sum());
    write_records(&mut out, std::iter::once(header).chain(lines))?;
    String::from_utf8(out).map_err(|e| EvalError::Merge {
        file: "merged shards".into(),
        message: format!("not UTF-8 text ({e})"),
    })
}

/// An outcome to fill from a table row: the numbers unknown (NaN) until read.
fn unknown_outcome() -> Outcome {
    Outcome {
        total_s: f64::NAN,
        breakdown: Breakdown {
            beam_on_s: f64::NAN,
            spot_irradiation_s: f64::NAN,
            scanning_s: f64::NAN,
            energy_switching_s: f64::NAN,
            lost_s: f64::NAN,
        },
        speedup: None,
        lower_bound_s: None,
        gap_s: None,
        limiter_counts: LimiterCounts::default(),
        violations: 0,
        margins: None,
    }
}

/// One data row of a table being read: its fields by column name, and where it is.
struct Fields<'a> {
    header: &'a Header,
    record: &'a StringRecord,
    line: usize,
}

impl Fields<'_> {
    /// The field of `COLUMNS[k]`; `None` when the table has no such column.
    fn get(&self, k: usize) -> Option<&str> {
        self.header.get(self.record, k)
    }

    /// A located error about this row.
    fn error(&self, message: String) -> String {
        format!("line {}: {message}", self.line)
    }

    fn expected(&self, column: &str, what: &str, found: &str) -> String {
        self.error(format!("column {column}: expected {what}, found {found:?}"))
    }

    fn number(&self, column: &str, text: &str) -> Result<f64, String> {
        text.trim()
            .parse::<f64>()
            .map_err(|_| self.expected(column, "a number", text))
    }

    fn optional(&self, column: &str, text: &str) -> Result<Option<f64>, String> {
        if text.trim().is_empty() {
            Ok(None)
        } else {
            self.number(column, text).map(Some)
        }
    }

    fn count(&self, column: &str, text: &str) -> Result<usize, String> {
        text.trim()
            .parse::<usize>()
            .map_err(|_| self.expected(column, "a count", text))
    }
}

impl Evaluator {
    /// Reads back the rows of a results table of this sweep (e.g. merged shards) to summarise
    /// them. Each line must match the combination its index names (plan, schedule, and the limit
    /// columns as [`write_csv_row`] writes them); margins are not read back (summaries do not use
    /// them).
    ///
    /// Columns are found by their name in the header, which must have the columns of
    /// [`CSV_HEADER`] or an older arcsim's [`CSV_HEADER_V2`] (its rows read back without a
    /// certificate) or [`CSV_HEADER_V1`], in any order. A V1 table
    /// has no beam axes (its rows must be combinations that do not sweep them) and no split of
    /// the beam-on time: its rows read back with `spot_irradiation_s` and `scanning_s` NaN
    /// (unknown). Quoted fields, a UTF-8 byte-order mark and CRLF line ends read as well.
    pub fn rows_from_csv(&self, name: &str, text: &str) -> Result<Vec<Row>, EvalError> {
        let merr = |message: String| EvalError::Merge {
            file: name.to_string(),
            message,
        };
        let (header, records) = records(text).map_err(merr)?;
        records
            .iter()
            .map(|(line, record)| {
                let fields = Fields {
                    header: &header,
                    record,
                    line: *line,
                };
                self.row_from_fields(&fields).map_err(merr)
            })
            .collect()
    }

    /// The row of one table line, checked against the sweep's combination of its index.
    fn row_from_fields(&self, f: &Fields) -> Result<Row, String> {
        let index_column = column_index("index");
        let index = f.count("index", f.get(index_column).unwrap_or_default())?;
        if index >= self.len() {
            return Err(f.error(format!(
                "row {index}: the sweep has {} combinations",
                self.len()
            )));
        }
        let size_column = column_index("combinations");
        if let Some(t) = f.get(size_column) {
            let n = f.count("combinations", t)?;
            if n != self.len() {
                return Err(f.error(format!(
                    "a sweep of {n} combinations; this sweep has {}",
                    self.len()
                )));
            }
        }
        let (plan, run, setting) = self.combination(index);
        let mut row = Row {
            index,
            combinations: self.len(),
            plan: self.sweep().plans[plan].label.clone(),
            schedule: self.sweep().schedule_grids[run].schedule,
            setting,
            defaults: self.sweep().defaults(),
            status: Status::Ok,
            outcome: None,
            message: String::new(),
        };
        // The columns naming the combination: as the sweep's row of that index writes them.
        let mut same = true;
        for (k, c) in COLUMNS.iter().enumerate() {
            match (c.field, f.get(k)) {
                (Field::Name(get), Some(t)) => same &= t == one_line(&get(&row)),
                (Field::Limit(axis), Some(t)) => {
                    same &= f.optional(c.name, t)? == setting.get_or(axis, &row.defaults);
                }
                // An older table's combinations leave the axis to the base machine.
                (Field::Limit(axis), None) => same &= setting.get(axis).is_none(),
                _ => {}
            }
        }
        if !same {
            return Err(f.error(other_combination(&row)));
        }
        // The results.
        let mut outcome = unknown_outcome();
        for (k, c) in COLUMNS.iter().enumerate() {
            let Some(t) = f.get(k) else { continue };
            match c.field {
                Field::Status => {
                    row.status = STATUSES
                        .into_iter()
                        .find(|s| s.name() == t.trim())
                        .ok_or_else(|| f.expected(c.name, "ok, infeasible, invalid or error", t))?;
                }
                Field::Message => row.message = t.to_string(),
                _ => {}
            }
        }
        if row.status == Status::Ok {
            for (k, c) in COLUMNS.iter().enumerate() {
                let Some(t) = f.get(k) else { continue };
                match c.field {
                    Field::Number(_, set) => *set(&mut outcome) = f.number(c.name, t)?,
                    Field::Optional(_, set) => *set(&mut outcome) = f.optional(c.name, t)?,
                    Field::Count(_, set) => *set(&mut outcome) = f.count(c.name, t)?,
                    _ => {}
                }
            }
            row.outcome = Some(outcome);
        }
        Ok(row)
    }
}

/// Every status, as a table names them.
const STATUSES: [Status; 4] = [
    Status::Ok,
    Status::Infeasible,
    Status::Invalid,
    Status::Error,
];

/// The error for a table row that is not the sweep's combination `row` (of the same index).
fn other_combination(row: &Row) -> String {
    let limits: Vec<String> = Axis::ALL
        .into_iter()
        .filter_map(|a| {
            let v = field_text(Field::Limit(a), row);
            (!v.is_empty()).then(|| format!("{} {v}", a.symbol().0))
        })
        .collect();
    format!(
        "row {} is {} {} {} in this sweep; the file has another combination (a different sweep \
         file, or an older arcsim's table, which left the ELST and window columns empty when \
         they were not swept?)",
        row.index,
        row.plan,
        row.schedule.name(),
        limits.join(" ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A table of rows `rows` of a sweep of 5 (index, combinations, plan and schedule filled,
    /// the other fields empty).
    fn file(rows: &[usize], end: &str) -> String {
        let mut s = format!("{CSV_HEADER}{end}");
        let empty = ",".repeat(COLUMNS.len() - 4);
        for r in rows {
            s.push_str(&format!("{r},5,p,scan{empty}{end}"));
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
        assert_eq!(v3.len(), COLUMNS.len() - 1);
        assert_eq!(v2.len(), COLUMNS.len() - 3);
        assert_eq!(old.len(), COLUMNS.len() - 7);
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
        // A table without the column (an older arcsim's) still merges on its indices.
        let v3 = |rows: &[usize]| {
            let mut s = format!("{CSV_HEADER_V3}\n");
            for r in rows {
                s.push_str(&format!("{r},p,scan{}\n", ",".repeat(COLUMNS.len() - 4)));
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
}
