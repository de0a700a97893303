//! The columns of the sweep table and its header.

use csv::StringRecord;

use arcsim_sequencer::Margins;

use crate::run::{Outcome, Row};
use crate::sweep::Axis;

/// How one column of the sweep table is written from a row and read back into one.
#[derive(Clone, Copy)]
pub(super) enum Field {
    /// The combination's index: read first, it names the combination the rest is checked against.
    Index,
    /// The sweep's number of combinations: a shard's table says how many rows the whole sweep
    /// has, so a merge finds a missing last row without the sweep file.
    Combinations,
    /// Text naming the combination (plan label, schedule entry): written from the row, and on
    /// reading it must be what the sweep's combination of that index writes.
    Name(fn(&Row) -> String),
    /// The value of a limit used (see the module documentation): written from the setting and the
    /// base machine; on reading it must be the sweep's combination's.
    Limit(Axis),
    Status,
    /// A number of an `ok` row's outcome.
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
pub(super) struct Column {
    pub(super) name: &'static str,
    pub(super) field: Field,
}

/// Defines [`CSV_HEADER`] and [`COLUMNS`] from one list of `name => field`.
macro_rules! sweep_columns {
    ($first:literal => $first_field:expr, $($name:literal => $field:expr),+ $(,)?) => {
        /// The CSV header line (without the newline): the names of the table's columns.
        pub const CSV_HEADER: &str = concat!($first $(, ",", $name)+);

        /// The columns of the sweep table, in the order written.
        pub(super) const COLUMNS: &[Column] = &[
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
    "burst_switching_time_s" => Field::Limit(Axis::BurstSwitching),
    "spill_charge_mu" => Field::Limit(Axis::SpillCharge),
    "spill_refill_time_s" => Field::Limit(Axis::SpillRefill),
    "spill_max_layers" => Field::Limit(Axis::SpillMaxLayers),
    "status" => Field::Status,
    "total_s" => outcome!(Number, total_s),
    "beam_on_s" => outcome!(Number, breakdown.beam_on_s),
    "spot_irradiation_s" => outcome!(Number, breakdown.spot_irradiation_s),
    "scanning_s" => outcome!(Number, breakdown.scanning_s),
    "burst_switching_s" => outcome!(Number, breakdown.burst_switching_s),
    "spill_waiting_s" => outcome!(Number, breakdown.spill_waiting_s),
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

/// A table's header: where each of [`COLUMNS`] is.
pub(super) struct Header {
    at: Vec<usize>,
    pub(super) len: usize,
}

impl Header {
    /// Finds the columns by name: the names must be those of [`CSV_HEADER`], each once, in any
    /// order. A table of an earlier arcsim (other columns) is refused, naming the first column
    /// that differs and the header expected.
    pub(super) fn parse(names: &StringRecord) -> Result<Header, String> {
        let expected = || format!("expected the arcsim sweep CSV header: {CSV_HEADER}");
        if names.iter().all(str::is_empty) {
            return Err(format!("empty file; {}", expected()));
        }
        let mut at = vec![None; COLUMNS.len()];
        for (i, name) in names.iter().enumerate() {
            let k = COLUMNS
                .iter()
                .position(|c| c.name == name)
                .ok_or_else(|| format!("line 1: unknown column {name:?}; {}", expected()))?;
            if at[k].replace(i).is_some() {
                return Err(format!(
                    "line 1: column {name} appears twice; {}",
                    expected()
                ));
            }
        }
        let at = COLUMNS
            .iter()
            .zip(at)
            .map(|(c, i)| {
                i.ok_or_else(|| {
                    format!(
                        "line 1: no column {} (a table of an earlier arcsim? run its sweep again); {}",
                        c.name,
                        expected()
                    )
                })
            })
            .collect::<Result<_, _>>()?;
        Ok(Header {
            at,
            len: names.len(),
        })
    }

    /// The field of `COLUMNS[k]` in `record` (a record with as many fields as the header).
    pub(super) fn get<'r>(&self, record: &'r StringRecord, k: usize) -> &'r str {
        record.get(self.at[k]).unwrap_or_default()
    }

    /// The fields of `record` in [`COLUMNS`]'s order, the order a table is written in.
    pub(super) fn in_order<'a>(
        &'a self,
        record: &'a StringRecord,
    ) -> impl Iterator<Item = &'a str> + 'a {
        (0..COLUMNS.len()).map(move |k| self.get(record, k))
    }
}

/// The position of the column named `name` in [`COLUMNS`] (a name of the list).
pub(super) fn column_index(name: &str) -> usize {
    COLUMNS
        .iter()
        .position(|c| c.name == name)
        .unwrap_or_else(|| unreachable!("{name} is a column of COLUMNS"))
}
