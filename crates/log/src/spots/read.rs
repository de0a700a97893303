//! Reading a per-spot log: one row per spot delivery, in delivery order, as `simulate --spots`
//! writes it (docs/commands.md); each value checked where it is read.

use std::io::Read;
use std::path::Path;

use csv::StringRecord;

use crate::read::{Capped, MAX_TIME_S};
use crate::LogError;

/// One delivery of one spot (one painting of it), as logged.
#[derive(Clone, Debug, PartialEq)]
pub struct LoggedSpot {
    /// Arc, control point and layer within the control point (from 0): the plan's layer.
    pub arc: usize,
    /// Control point within the arc, from 0.
    pub control_point: usize,
    /// Layer within the control point, from 0.
    pub layer: usize,
    /// Pass over the layer's spots that delivered it, from 0 (a new burst on a beam in bursts).
    pub painting: usize,
    /// Spot position at the isocentre plane, mm.
    pub x_mm: f64,
    /// Spot position at the isocentre plane, mm.
    pub y_mm: f64,
    /// MU delivered.
    pub mu: f64,
    /// Irradiation start and end, s (any origin, one clock for the file).
    pub t_start_s: f64,
    /// Irradiation end, s.
    pub t_end_s: f64,
    /// The 1-based line of the file, for messages.
    pub line: u64,
}

/// A per-spot log: its spots in delivery order.
#[derive(Clone, Debug, PartialEq)]
pub struct SpotLog {
    /// The file as named to the reader.
    pub source: String,
    /// Every spot delivery, in the file's order (checked to be the delivery order).
    pub spots: Vec<LoggedSpot>,
    /// The recorder's time step where the log's format says it (an IBA-style log's rows or
    /// elements), s; `None` where the fit reads the clock's resolution from the times.
    pub time_step_s: Option<f64>,
}

/// The columns a per-spot log must have (others, e.g. `layer_index` or the gantry angles, are
/// allowed and ignored).
pub const SPOT_LOG_COLUMNS: [&str; 9] = [
    "arc",
    "control_point",
    "layer",
    "painting",
    "x_mm",
    "y_mm",
    "mu",
    "t_start_s",
    "t_end_s",
];

/// Reads the per-spot log at `path` (at most [`crate::MAX_LOG_BYTES`]).
pub fn read_spot_log(path: &Path) -> Result<SpotLog, LogError> {
    let name = path.display().to_string();
    let file = std::fs::File::open(path)
        .map_err(|e| LogError::file(&name, format!("cannot open the per-spot log: {e}")))?;
    parse_spot_log(std::io::BufReader::new(file), &name)
}

/// Reads the per-spot log of `plan` at `path`: a folder as an IBA-style log (its spots mapped to
/// the plan's layers in order, [`crate::iba::IbaLog::to_spot_log`]), else a per-spot CSV log.
pub fn read_spots(path: &Path, plan: &arcsim_plan::ArcPlan) -> Result<SpotLog, LogError> {
    if crate::iba::is_iba_folder(path) {
        crate::iba::read_iba_log(path)?.to_spot_log(plan)
    } else {
        read_spot_log(path)
    }
}

/// Whether `header` (a CSV header line) is a per-spot log's.
pub fn is_spot_log_header(header: &str) -> bool {
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    SPOT_LOG_COLUMNS.iter().all(|c| names.contains(c))
}

/// Reads a per-spot log from `reader`; `source` names it in errors.
pub fn parse_spot_log(reader: impl Read, source: &str) -> Result<SpotLog, LogError> {
    let mut rd = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(false)
        .from_reader(Capped::new(reader));
    let header = rd
        .headers()
        .map_err(|e| LogError::at(source, 1, None, e.to_string()))?
        .clone();
    let mut index = [0usize; 9];
    for (slot, name) in index.iter_mut().zip(SPOT_LOG_COLUMNS) {
        *slot = header.iter().position(|h| h == name).ok_or_else(|| {
            LogError::at(
                source,
                1,
                None,
                format!(
                    "no column `{name}`; a per-spot log has the columns {} (as `arcsim simulate --spots` writes them)",
                    SPOT_LOG_COLUMNS.join(", ")
                ),
            )
        })?;
    }
    let mut spots: Vec<LoggedSpot> = Vec::new();
    let mut record = StringRecord::new();
    loop {
        match rd.read_record(&mut record) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => {
                let line = e.position().map_or(0, csv::Position::line);
                return Err(LogError::at(source, line, None, e.to_string()));
            }
        }
        let line = record.position().map_or(0, csv::Position::line);
        let spot = spot_of(&record, &index, source, line)?;
        if let Some(prev) = spots.last() {
            if spot.t_start_s < prev.t_start_s {
                return Err(LogError::at(
                    source,
                    line,
                    Some("t_start_s"),
                    format!(
                        "{} s is earlier than line {}'s {} s; expected the spots in delivery order",
                        spot.t_start_s, prev.line, prev.t_start_s
                    ),
                ));
            }
        }
        spots.push(spot);
    }
    if spots.is_empty() {
        return Err(LogError::file(
            source,
            "no spot rows; expected at least one",
        ));
    }
    Ok(SpotLog {
        time_step_s: None,
        source: source.to_string(),
        spots,
    })
}

fn spot_of(
    record: &StringRecord,
    index: &[usize; 9],
    source: &str,
    line: u64,
) -> Result<LoggedSpot, LogError> {
    let field = |k: usize| record.get(index[k]).unwrap_or("");
    let whole = |k: usize| -> Result<usize, LogError> {
        field(k).parse::<usize>().map_err(|_| {
            LogError::at(
                source,
                line,
                Some(SPOT_LOG_COLUMNS[k]),
                format!("`{}`; expected a whole number from 0", field(k)),
            )
        })
    };
    let number = |k: usize, lo: f64, hi: f64| -> Result<f64, LogError> {
        match field(k).parse::<f64>() {
            Ok(v) if v.is_finite() && (lo..=hi).contains(&v) => Ok(v),
            _ => Err(LogError::at(
                source,
                line,
                Some(SPOT_LOG_COLUMNS[k]),
                format!("`{}`; expected a number from {lo} to {hi}", field(k)),
            )),
        }
    };
    let spot = LoggedSpot {
        arc: whole(0)?,
        control_point: whole(1)?,
        layer: whole(2)?,
        painting: whole(3)?,
        x_mm: number(4, -1e4, 1e4)?,
        y_mm: number(5, -1e4, 1e4)?,
        mu: number(6, 0.0, 1e6)?,
        t_start_s: number(7, -MAX_TIME_S, MAX_TIME_S)?,
        t_end_s: number(8, -MAX_TIME_S, MAX_TIME_S)?,
        line,
    };
    if spot.t_end_s < spot.t_start_s {
        return Err(LogError::at(
            source,
            line,
            Some("t_end_s"),
            format!(
                "{} s is before the spot's start {} s; expected an end at or after the start",
                spot.t_end_s, spot.t_start_s
            ),
        ));
    }
    Ok(spot)
}
