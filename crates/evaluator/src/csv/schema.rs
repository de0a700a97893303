//! The columns of the sweep table and the headers a table may have.

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
    /// base machine; on reading it must be the sweep's combination's. A table without the column
    /// (an earlier header's) holds only combinations that leave the axis to the base machine.
    Limit(Axis),
    Status,
    /// A number of an `ok` row's outcome; a table without the column (an earlier header's) reads
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

/// A header without the spill axes' columns (`spill_charge_mu`, `spill_refill_time_s`,
/// `spill_max_layers`) and the
/// beam-on terms `burst_switching_s` and `spill_waiting_s` (its `scanning_s` includes the burst
/// switching): [`CSV_HEADER`] without them. Such tables merge and read back
/// (the two read as unknown).
pub const CSV_HEADER_V5: &str = "index,combinations,plan,schedule,jerk_deg_per_s3,accel_deg_per_s2,speed_deg_per_s,elst_up_s,elst_down_s,window_deg,\
scan_speed_mm_per_s,dose_rate_scale,burst_switching_time_s,status,total_s,beam_on_s,spot_irradiation_s,scanning_s,energy_switching_s,lost_s,speedup,\
lower_bound_s,gap_s,limited_elst,limited_speed,limited_accel,limited_jerk,limited_none,violations,speed_use,accel_use,jerk_use,\
window_slack_deg,elst_slack_s,message";

/// A header without the `burst_switching_time_s` column: [`CSV_HEADER_V5`] without it. Such tables
/// merge and read back (the base machine's burst switching).
pub const CSV_HEADER_V4: &str = "index,combinations,plan,schedule,jerk_deg_per_s3,accel_deg_per_s2,speed_deg_per_s,elst_up_s,elst_down_s,window_deg,\
scan_speed_mm_per_s,dose_rate_scale,status,total_s,beam_on_s,spot_irradiation_s,scanning_s,energy_switching_s,lost_s,speedup,\
lower_bound_s,gap_s,limited_elst,limited_speed,limited_accel,limited_jerk,limited_none,violations,speed_use,accel_use,jerk_use,\
window_slack_deg,elst_slack_s,message";

/// A header without the `combinations` column: [`CSV_HEADER_V4`] without
/// it. Such tables merge (the sweep's size then comes from `--sweep`, or from the indices) and
/// read back.
pub const CSV_HEADER_V3: &str = "index,plan,schedule,jerk_deg_per_s3,accel_deg_per_s2,speed_deg_per_s,elst_up_s,elst_down_s,window_deg,\
scan_speed_mm_per_s,dose_rate_scale,status,total_s,beam_on_s,spot_irradiation_s,scanning_s,energy_switching_s,lost_s,speedup,\
lower_bound_s,gap_s,limited_elst,limited_speed,limited_accel,limited_jerk,limited_none,violations,speed_use,accel_use,jerk_use,\
window_slack_deg,elst_slack_s,message";

/// A header without the certificate: [`CSV_HEADER`] without the
/// `lower_bound_s` and `gap_s` columns. Such tables merge and read back (no certificate).
pub const CSV_HEADER_V2: &str = "index,plan,schedule,jerk_deg_per_s3,accel_deg_per_s2,speed_deg_per_s,elst_up_s,elst_down_s,window_deg,\
scan_speed_mm_per_s,dose_rate_scale,status,total_s,beam_on_s,spot_irradiation_s,scanning_s,energy_switching_s,lost_s,speedup,\
limited_elst,limited_speed,limited_accel,limited_jerk,limited_none,violations,speed_use,accel_use,jerk_use,window_slack_deg,\
elst_slack_s,message";

/// The first header of the sweep table: no `scan_speed_mm_per_s`, `dose_rate_scale`,
/// `spot_irradiation_s` or `scanning_s` columns, the others in the order of [`CSV_HEADER`]. Such
/// tables merge (with tables of the same header; the merged table keeps it) and read back
/// ([`Evaluator::rows_from_csv`]).
pub const CSV_HEADER_V1: &str = "index,plan,schedule,jerk_deg_per_s3,accel_deg_per_s2,speed_deg_per_s,elst_up_s,elst_down_s,window_deg,\
status,total_s,beam_on_s,energy_switching_s,lost_s,speedup,limited_elst,limited_speed,limited_accel,limited_jerk,limited_none,\
violations,speed_use,accel_use,jerk_use,window_slack_deg,elst_slack_s,message";

/// The burst axis's column, which the tables before [`CSV_HEADER_V5`] do not have.
const BURST_COLUMN: &str = "burst_switching_time_s";

/// The beam-on terms of bursts and spills, which the tables before [`CSV_HEADER`] do not have.
const BEAM_STRUCTURE_COLUMNS: [&str; 5] = [
    "spill_charge_mu",
    "spill_refill_time_s",
    "spill_max_layers",
    "burst_switching_s",
    "spill_waiting_s",
];

/// The certificate's columns, which [`CSV_HEADER_V2`]'s tables do not have.
const CERTIFICATE_COLUMNS: [&str; 2] = ["lower_bound_s", "gap_s"];

/// Which header a table has.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Layout {
    /// [`CSV_HEADER`]'s columns.
    Current,
    /// [`CSV_HEADER_V5`]'s columns.
    V5,
    /// [`CSV_HEADER_V4`]'s columns.
    V4,
    /// [`CSV_HEADER_V3`]'s columns.
    V3,
    /// [`CSV_HEADER_V2`]'s columns.
    V2,
    /// [`CSV_HEADER_V1`]'s columns.
    V1,
}

impl Layout {
    /// Newest first: a header is read as the first layout that has all of its columns.
    const ALL: [Layout; 6] = [
        Layout::Current,
        Layout::V5,
        Layout::V4,
        Layout::V3,
        Layout::V2,
        Layout::V1,
    ];

    /// Whether tables of this layout have `column`.
    fn has(self, column: &Column) -> bool {
        match self {
            Layout::Current => true,
            Layout::V5 => !BEAM_STRUCTURE_COLUMNS.contains(&column.name),
            Layout::V4 => Layout::V5.has(column) && column.name != BURST_COLUMN,
            Layout::V3 => Layout::V4.has(column) && column.name != "combinations",
            Layout::V2 => Layout::V3.has(column) && !CERTIFICATE_COLUMNS.contains(&column.name),
            Layout::V1 => CSV_HEADER_V1.split(',').any(|n| n == column.name),
        }
    }

    /// The columns of this layout, in the order written.
    pub(super) fn columns(self) -> impl Iterator<Item = &'static Column> {
        COLUMNS.iter().filter(move |c| self.has(c))
    }

    pub(super) fn describe(self) -> &'static str {
        match self {
            Layout::Current => "the current arcsim sweep CSV header",
            Layout::V5 => "an older arcsim's header (without the spill_charge_mu, spill_refill_time_s, spill_max_layers, burst_switching_s and spill_waiting_s columns)",
            Layout::V4 => "an older arcsim's header (without the burst_switching_time_s column)",
            Layout::V3 => "an older arcsim's header (without the combinations column)",
            Layout::V2 => "an older arcsim's header (without the lower_bound_s and gap_s columns)",
            Layout::V1 => "an older arcsim's header (without the scan_speed_mm_per_s, dose_rate_scale, spot_irradiation_s and scanning_s columns)",
        }
    }
}

/// A table's header: its layout and where each of [`COLUMNS`] is (`None`: not in this layout).
pub(super) struct Header {
    pub(super) layout: Layout,
    at: Vec<Option<usize>>,
    /// The positions of the layout's columns, in the layout's order.
    pub(super) order: Vec<usize>,
    pub(super) len: usize,
}

impl Header {
    /// Finds the columns by name; every name must be a column of the table, once, and the names
    /// must be those of [`CSV_HEADER`], [`CSV_HEADER_V5`], [`CSV_HEADER_V4`], [`CSV_HEADER_V3`], [`CSV_HEADER_V2`] or [`CSV_HEADER_V1`]
    /// (in any order).
    pub(super) fn parse(names: &StringRecord) -> Result<Header, String> {
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
        // The earliest layout with every column the table has: the table must have all of its.
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
    pub(super) fn get<'r>(&self, record: &'r StringRecord, k: usize) -> Option<&'r str> {
        self.at[k].and_then(|i| record.get(i))
    }
}

/// The position of the column named `name` in [`COLUMNS`] (a name of the list).
pub(super) fn column_index(name: &str) -> usize {
    COLUMNS
        .iter()
        .position(|c| c.name == name)
        .unwrap_or_else(|| unreachable!("{name} is a column of COLUMNS"))
}
