//! Reading a log: streamed row by row, every value checked where it is read.

use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;

use csv::StringRecord;

use crate::{ColumnMap, DeliveryLog, Field, LogError, LogSample};

/// Largest log file read, bytes (256 MiB): a 10 ms log of an hour of delivery is about 20 MB, so
/// a larger file is not a log of one plan (and would not fit in memory as samples).
pub const MAX_LOG_BYTES: u64 = 256 << 20;

/// Largest time magnitude read, s: 1e10 s is 317 years, so a clock counting seconds from any
/// origin (even 1970: 1.7e9 s today) stays within it, and one counting milliseconds since 1970
/// (1.7e12) or holding a corrupt value (1e300) does not.
pub const MAX_TIME_S: f64 = 1e10;

/// Longest log read, s (1e6 s is 11.6 days; a delivery lasts minutes, an hour at most): a longer
/// span is a clock in another unit or a corrupt time.
pub const MAX_SPAN_S: f64 = 1e6;

/// Largest angle magnitude read, degrees: beyond any plan's angles (±1e4°) and any encoder's;
/// it keeps the unwrapping's turn counts exact ([`crate::DeliveryLog::clean`]). A larger value
/// is not an angle in degrees, not a glitch to mend.
pub const MAX_ANGLE_MAGNITUDE_DEG: f64 = 1e9;

/// Reads the log at `path`, its columns found through `map`. A file above [`MAX_LOG_BYTES`] is
/// refused with its size before anything is read.
pub fn read_log(path: &Path, map: &ColumnMap) -> Result<DeliveryLog, LogError> {
    let name = path.display().to_string();
    let meta = std::fs::metadata(path)
        .map_err(|e| LogError::file(&name, format!("cannot read the log: {e}")))?;
    if meta.len() > MAX_LOG_BYTES {
        return Err(LogError::file(
            &name,
            format!(
                "{} bytes ({:.2} GiB); expected a log of at most {MAX_LOG_BYTES} bytes (256 MiB; a 10 ms log of an hour of delivery is about 20 MB)",
                meta.len(),
                meta.len() as f64 / f64::from(1u32 << 30)
            ),
        ));
    }
    let file =
        File::open(path).map_err(|e| LogError::file(&name, format!("cannot open the log: {e}")))?;
    parse_log(BufReader::new(file), &name, map)
}

/// A reader that fails once more than [`MAX_LOG_BYTES`] have come through it: the size limit for
/// a FIFO, standard input or any stream whose size is not known before it is read.
pub(crate) struct Capped<R> {
    inner: R,
    left: u64,
}

impl<R> Capped<R> {
    /// `inner`, failing past [`MAX_LOG_BYTES`].
    pub(crate) fn new(inner: R) -> Self {
        Capped {
            inner,
            left: MAX_LOG_BYTES,
        }
    }
}

impl<R: Read> Read for Capped<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.left == 0 {
            let mut one = [0u8; 1];
            return match self.inner.read(&mut one)? {
                0 => Ok(0),
                _ => Err(std::io::Error::other(format!(
                    "more than {MAX_LOG_BYTES} bytes (256 MiB); expected a log of at most that (a 10 ms log of an hour of delivery is about 20 MB)"
                ))),
            };
        }
        let n = buf
            .len()
            .min(usize::try_from(self.left).unwrap_or(usize::MAX));
        let got = self.inner.read(&mut buf[..n])?;
        self.left -= got as u64;
        Ok(got)
    }
}

/// Reads a log from `reader`; `source` names it in errors. The log comes cleaned
/// ([`DeliveryLog::clean`]: the angle trace unwrapped, encoder glitches replaced and counted).
pub fn parse_log(
    reader: impl Read,
    source: &str,
    map: &ColumnMap,
) -> Result<DeliveryLog, LogError> {
    let capped = Capped::new(reader);
    let mut rd = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(false)
        .from_reader(capped);
    let header = rd
        .headers()
        .map_err(|e| LogError::at(source, 1, None, e.to_string()))?
        .clone();
    let columns = find_columns(&header, source, map)?;
    let mut samples: Vec<LogSample> = Vec::new();
    let mut record = StringRecord::new();
    loop {
        match rd.read_record(&mut record) {
            Ok(true) => {}
            Ok(false) => break,
            Err(e) => {
                let line = e.position().map_or(0, |p| p.line());
                return Err(LogError::at(source, line, None, csv_message(&e)));
            }
        }
        let line = record.position().map_or(0, |p| p.line());
        let row = Row {
            record: &record,
            columns: &columns,
            source,
            line,
        };
        let sample = row.sample()?;
        if let (Some(first), Some(prev)) = (samples.first(), samples.last()) {
            check_order(prev.t_s, sample.t_s, &row)?;
            check_span(first.t_s, sample.t_s, &row)?;
        }
        samples.push(sample);
    }
    if samples.is_empty() {
        return Err(LogError::file(
            source,
            "no samples (a header without rows); expected one row per sample",
        ));
    }
    let mut log = DeliveryLog {
        source: source.to_string(),
        samples,
        has_energy: columns[3].is_some(),
        has_spot: columns[4].is_some(),
        has_mu: columns[5].is_some(),
        wraps_unwrapped: 0,
        glitches_rejected: 0,
        edge_resolution_s: None,
    };
    log.clean();
    Ok(log)
}

/// The csv crate's error without its own position (the caller gives the line).
fn csv_message(e: &csv::Error) -> String {
    match e.kind() {
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => {
            format!("{len} fields; expected {expected_len} (as the header)")
        }
        csv::ErrorKind::Utf8 { .. } => "not UTF-8 text; expected a CSV file".into(),
        _ => e.to_string(),
    }
}

/// Where each of [`Field::ALL`] is in the header; a required one missing is an error naming it.
fn find_columns(
    header: &StringRecord,
    source: &str,
    map: &ColumnMap,
) -> Result<[Option<(usize, String)>; 6], LogError> {
    let names: Vec<&str> = header
        .iter()
        .map(|h| h.trim_start_matches('\u{feff}'))
        .collect();
    if names.iter().all(|n| n.is_empty()) {
        return Err(LogError::file(
            source,
            "empty file; expected a header line with t_s, gantry_angle_deg and beam_on, then one row per sample",
        ));
    }
    let mut out: [Option<(usize, String)>; 6] = Default::default();
    for (k, field) in Field::ALL.into_iter().enumerate() {
        let want = map.column(field);
        let mut at = names.iter().enumerate().filter(|(_, n)| **n == want);
        match (at.next(), at.next()) {
            (Some((i, _)), None) => out[k] = Some((i, want.to_string())),
            (Some(_), Some(_)) => {
                return Err(LogError::at(
                    source,
                    1,
                    Some(want),
                    "appears twice; expected each column once",
                ))
            }
            (None, _) if field.required() => {
                let mapped = if want == field.name() {
                    String::new()
                } else {
                    format!(" (mapped from {})", field.name())
                };
                return Err(LogError::at(
                    source,
                    1,
                    None,
                    format!(
                        "no column {want}{mapped}: {} (required); the header has {}",
                        field.meaning(),
                        names.join(", ")
                    ),
                ));
            }
            (None, _) => {}
        }
    }
    Ok(out)
}

/// One data row being read.
struct Row<'a> {
    record: &'a StringRecord,
    columns: &'a [Option<(usize, String)>; 6],
    source: &'a str,
    line: u64,
}

impl Row<'_> {
    /// The field `k` of [`Field::ALL`] and its column name, if the log has the column.
    fn field(&self, k: usize) -> Option<(&str, &str)> {
        self.columns[k]
            .as_ref()
            .map(|(i, name)| (self.record.get(*i).unwrap_or(""), name.as_str()))
    }

    fn error(&self, column: &str, message: String) -> LogError {
        LogError::at(self.source, self.line, Some(column), message)
    }

    /// A finite number, or an error naming what the column holds.
    fn number(&self, text: &str, column: &str, field: Field) -> Result<f64, LogError> {
        match text.parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            _ => Err(self.error(
                column,
                format!(
                    "expected a finite number ({}), found \"{text}\"",
                    field.meaning()
                ),
            )),
        }
    }

    /// An optional number: empty is unknown.
    fn optional(&self, k: usize, field: Field) -> Result<Option<f64>, LogError> {
        match self.field(k) {
            Some((text, column)) if !text.is_empty() => self.number(text, column, field).map(Some),
            _ => Ok(None),
        }
    }

    fn sample(&self) -> Result<LogSample, LogError> {
        let required = |k: usize, f: Field| -> Result<(&str, &str), LogError> {
            // A required column is always found (checked with the header).
            self.field(k).ok_or_else(|| {
                LogError::at(
                    self.source,
                    self.line,
                    None,
                    format!("no column {}", f.name()),
                )
            })
        };
        let (t, tc) = required(0, Field::Time)?;
        let t_s = self.number(t, tc, Field::Time)?;
        if t_s.abs() > MAX_TIME_S {
            return Err(self.error(
                tc,
                format!("time {t_s:e} s is beyond ±{MAX_TIME_S:e} s (317 years); expected seconds from any origin (a clock in milliseconds, or a corrupt value?)"),
            ));
        }
        let (a, ac) = required(1, Field::GantryAngle)?;
        let gantry_angle_deg = self.number(a, ac, Field::GantryAngle)?;
        if gantry_angle_deg.abs() > MAX_ANGLE_MAGNITUDE_DEG {
            return Err(self.error(
                ac,
                format!("angle {gantry_angle_deg:e} deg is beyond ±{MAX_ANGLE_MAGNITUDE_DEG:e} deg; expected a gantry angle in degrees"),
            ));
        }
        let (b, bc) = required(2, Field::BeamOn)?;
        let beam_on = match b {
            "1" | "true" => true,
            "0" | "false" => false,
            other => {
                return Err(self.error(
                    bc,
                    format!("expected 1 or true (beam on), 0 or false (off), found \"{other}\""),
                ))
            }
        };
        let energy_mev = self.optional(3, Field::Energy)?;
        if let (Some(e), Some((_, c))) = (energy_mev, self.field(3)) {
            if !(e > 0.0 && e <= 1000.0) {
                return Err(self.error(
                    c,
                    format!("{e} MeV; expected an energy above 0 and at most 1000 MeV"),
                ));
            }
        }
        let spot = match self.field(4) {
            Some((text, c)) if !text.is_empty() => Some(text.parse::<u32>().map_err(|_| {
                self.error(
                    c,
                    format!("expected a spot index (a whole number ≥ 0), found \"{text}\""),
                )
            })?),
            _ => None,
        };
        let mu = self.optional(5, Field::Mu)?;
        if let (Some(m), Some((_, c))) = (mu, self.field(5)) {
            if m < 0.0 {
                return Err(
                    self.error(c, format!("{m} MU; expected MU ≥ 0 since the previous row"))
                );
            }
        }
        Ok(LogSample {
            t_s,
            gantry_angle_deg,
            beam_on,
            energy_mev,
            spot,
            mu,
        })
    }
}

/// The time column's name as the log has it.
fn time_column(row: &Row) -> String {
    row.field(0).map_or("t_s", |(_, c)| c).to_string()
}

/// A log spans at most [`MAX_SPAN_S`].
fn check_span(first: f64, t: f64, row: &Row) -> Result<(), LogError> {
    let span_s = t - first;
    if span_s > MAX_SPAN_S {
        return Err(row.error(
            &time_column(row),
            format!("time {t} s is {span_s:e} s after the first row's {first} s; expected a log of at most {MAX_SPAN_S:e} s (11.6 days) in seconds (a clock in another unit, or a corrupt value?)"),
        ));
    }
    Ok(())
}

/// Times must increase strictly from row to row.
fn check_order(prev: f64, t: f64, row: &Row) -> Result<(), LogError> {
    let column = time_column(row);
    if t == prev {
        return Err(row.error(
            &column,
            format!("time {t} s repeats the previous row's; expected strictly increasing times"),
        ));
    }
    if t < prev {
        return Err(row.error(
            &column,
            format!(
                "time {t} s is before the previous row's {prev} s; expected rows in time order"
            ),
        ));
    }
    Ok(())
}
