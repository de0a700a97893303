//! Reading a table back into rows, each checked against the sweep's combination of its index.

use arcsim_sequencer::{Breakdown, LimiterCounts};
use csv::StringRecord;

use super::lines::CsvLineNumbers;
use super::schema::{column_index, Field, Header, COLUMNS};
use super::write::{field_text, one_line};
use crate::run::{Evaluator, Outcome, Row, Status};
use crate::sweep::Axis;
use crate::EvalError;

/// A reader of a table's text: columns by name, quoted fields, a byte-order mark, CRLF.
pub(super) fn reader(text: &str) -> csv::Reader<&[u8]> {
    csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_reader(text.as_bytes())
}

/// The records of `text` after its header, each with its line number, and the header.
pub(super) fn records(text: &str) -> Result<(Header, Vec<(usize, StringRecord)>), String> {
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

/// An outcome to fill from a table row: the numbers unknown (NaN) until read (every one is).
fn unknown_outcome() -> Outcome {
    Outcome {
        total_s: f64::NAN,
        breakdown: Breakdown {
            beam_on_s: f64::NAN,
            spot_irradiation_s: f64::NAN,
            scanning_s: f64::NAN,
            burst_switching_s: f64::NAN,
            spill_waiting_s: f64::NAN,
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
    /// The field of `COLUMNS[k]`.
    fn get(&self, k: usize) -> &str {
        self.header.get(self.record, k)
    }

    /// A located error about this row.
    fn error(&self, message: String) -> String {
        format!("line {}: {message}", self.line)
    }

    fn expected(&self, column: &str, what: &str, found: &str) -> String {
        self.error(format!("column {column}: expected {what}, found {found:?}"))
    }

    /// A result's number: finite, and not below 0 except the certificate's gap (a merged shard
    /// with `NaN` or `-5` s once became the sweep's fastest delivery).
    fn number(&self, column: &str, text: &str) -> Result<f64, String> {
        let x = text
            .trim()
            .parse::<f64>()
            .map_err(|_| self.expected(column, "a number", text))?;
        if !x.is_finite() || (x < 0.0 && column != "gap_s") {
            let what = if column == "gap_s" {
                "a finite number"
            } else {
                "a finite number ≥ 0"
            };
            return Err(self.expected(column, what, text));
        }
        Ok(x)
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
    /// [`CSV_HEADER`], in any order; a table with other columns (an earlier arcsim's) is an
    /// error naming the file and the header expected. Quoted fields, a UTF-8 byte-order mark and
    /// CRLF line ends read as well.
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
        let index = f.count("index", f.get(index_column))?;
        if index >= self.len() {
            return Err(f.error(format!(
                "row {index}: the sweep has {} combinations",
                self.len()
            )));
        }
        let n = f.count("combinations", f.get(column_index("combinations")))?;
        if n != self.len() {
            return Err(f.error(format!(
                "a sweep of {n} combinations; this sweep has {}",
                self.len()
            )));
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
            match c.field {
                Field::Name(get) => same &= f.get(k) == one_line(&get(&row)),
                Field::Limit(axis) => {
                    same &= f.optional(c.name, f.get(k))? == setting.get_or(axis, &row.defaults);
                }
                _ => {}
            }
        }
        if !same {
            return Err(f.error(other_combination(&row)));
        }
        (row.status, row.message, row.outcome) = results(f)?;
        Ok(row)
    }
}

/// The status, message and (for a row that is ok) the outcome of a table line, each field
/// checked: a known status, every number finite and not negative.
fn results(f: &Fields) -> Result<(Status, String, Option<Outcome>), String> {
    let mut status = Status::Ok;
    let mut message = String::new();
    for (k, c) in COLUMNS.iter().enumerate() {
        let t = f.get(k);
        match c.field {
            Field::Status => {
                status = STATUSES
                    .into_iter()
                    .find(|s| s.name() == t.trim())
                    .ok_or_else(|| f.expected(c.name, "ok, infeasible, invalid or error", t))?;
            }
            Field::Message => message = t.to_string(),
            _ => {}
        }
    }
    if status != Status::Ok {
        return Ok((status, message, None));
    }
    let mut outcome = unknown_outcome();
    for (k, c) in COLUMNS.iter().enumerate() {
        let t = f.get(k);
        match c.field {
            Field::Number(_, set) => *set(&mut outcome) = f.number(c.name, t)?,
            Field::Optional(_, set) => *set(&mut outcome) = f.optional(c.name, t)?,
            Field::Count(_, set) => *set(&mut outcome) = f.count(c.name, t)?,
            _ => {}
        }
    }
    Ok((status, message, Some(outcome)))
}

/// Checks the results of line `line` of a table (`record` under `header`): as a read-back
/// does, without a sweep to hold the combination against.
pub(super) fn check_results(
    header: &Header,
    record: &StringRecord,
    line: usize,
) -> Result<(), String> {
    results(&Fields {
        header,
        record,
        line,
    })
    .map(|_| ())
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
        "row {} is {} {} {} in this sweep; the file has another combination (a table of a \
         different sweep file?)",
        row.index,
        row.plan,
        row.schedule.name(),
        limits.join(" ")
    )
}
