//! IBA-style beam logs: the folder of CSV files a scanning nozzle's data recorder leaves for each
//! beam, as the public readers describe it (docs/records.md#iba-logs lists every assumption).
//!
//! - `map_record_NNNN_part_MM.*` per layer NNNN: one row per 0.25 ms (`SUBMAP_NUMBER`, `TIME`,
//!   positions on the ionisation chamber, `DOSE_PRIM(C)` the charge collected in the row).
//! - `map_specif_NNNN_part_MM.*`: the layer's range and the chamber's offsets.
//! - `beam_config.*`: the nozzle's constants (charge per MU, SAD, chamber-to-isocentre distance).
//! - `beam.*`: the beam's gantry angle and the chamber's temperature and pressure.
//! - `events.*`, for arcs: each layer's arc irradiation start and end, target and actual angles.
//!
//! [`read_iba_log`] reads a beam folder (or a folder of beam folders, one per arc); the log
//! becomes the delivery log `compare` and `calibrate` take ([`IbaLog::to_delivery_log`]) and the
//! per-spot log `calibrate-spots` takes ([`IbaLog::to_spot_log`]). [`iba_log_files`] writes one
//! from a simulated delivery, the fixtures the tests calibrate hidden machines from.

mod convert;
mod element;
mod events;
mod read;
mod settings;
mod time;
mod write;

pub use read::{is_iba_folder, read_iba_log};
pub use time::days_from_civil;
pub use write::{iba_log_files, start_seconds, IbaLayout, IbaNozzle};

/// The recorder's sampling period, s: one `map_record` row per 0.25 ms (4 rows per ms, as both
/// public readers take it).
pub const SAMPLE_PERIOD_S: f64 = 0.25e-3;

/// A synchrocyclotron's pulse period, s: each element of a `burst_record` is one pulse, and
/// a spot lasts until one period after its last pulse (as REGGUI's S2C2 reader takes it) where
/// the file does not show the period itself.
pub const BURST_PERIOD_S: f64 = 1e-3;

/// The element layout's `FPGA_COUNT` counts microseconds in 23 bits: it wraps at this.
const COUNTER_WRAP_US: i64 = 1 << 23;

/// Reference conditions of the chamber's charge when the beam file gives none: 1013 hPa and
/// 293 K, as the OncoRay reader takes them.
pub const DEFAULT_REFERENCE_PRESSURE_HPA: f64 = 1013.0;
/// See [`DEFAULT_REFERENCE_PRESSURE_HPA`].
pub const DEFAULT_REFERENCE_TEMPERATURE_K: f64 = 293.0;

/// An IBA-style log: every beam read, in the order of their folders.
#[derive(Clone, Debug, PartialEq)]
pub struct IbaLog {
    /// The folder as named to the reader.
    pub source: String,
    /// One per beam folder, in name order.
    pub beams: Vec<IbaBeam>,
    /// What the reader assumed or left out, for the report (e.g. tuning spots not read).
    pub notes: Vec<String>,
}

/// One beam's folder, read.
#[derive(Clone, Debug, PartialEq)]
pub struct IbaBeam {
    /// The folder as named to the reader.
    pub folder: String,
    /// `<GantryAngle>` of the beam file, degrees: the angle of a fixed beam.
    pub gantry_angle_deg: Option<f64>,
    /// MU per coulomb of `DOSE_PRIM(C)`: 1 / (charge per MU × the chamber's correction), when
    /// `beam_config` gives the charge per MU.
    pub mu_per_coulomb: Option<f64>,
    /// Whether `beam_config` gave the SAD and the chamber-to-isocentre distance, so the spots'
    /// positions are at the isocentre plane (else the chamber's, offsets removed).
    pub positions_at_isocentre: bool,
    /// The longest time step of its records (0.25 ms rows, or the element layout's element
    /// period): the resolution of its spots' start and end.
    pub time_step_s: f64,
    /// The resolution of its layers' beam edges in time: the time step, or the element layout's
    /// `START_IRRADIATION` stamp (which places each layer) where that is coarser.
    pub edge_resolution_s: f64,
    /// The layers with at least one spot, in the order of their numbers.
    pub layers: Vec<IbaLayer>,
    /// The events file's arc irradiations, in time order (empty for a fixed beam).
    pub arcs: Vec<ArcIrradiation>,
}

/// One layer's record (its parts merged).
#[derive(Clone, Debug, PartialEq)]
pub struct IbaLayer {
    /// The layer number in the file names (`map_record_NNNN`).
    pub number: u32,
    /// The range its `map_specif` gives (as written; not converted to an energy).
    pub range: Option<f64>,
    /// Its spot deliveries in time order.
    pub spots: Vec<IbaSpot>,
}

/// One spot delivery: a run of consecutive rows of one `SUBMAP_NUMBER` with charge and a valid
/// position.
#[derive(Clone, Debug, PartialEq)]
pub struct IbaSpot {
    /// Irradiation start (the first row's time) and end (the last row's time plus one sampling
    /// period), s from the log's first row.
    pub t_start_s: f64,
    /// See `t_start_s`.
    pub t_end_s: f64,
    /// Position at the isocentre plane (IEC gantry x), mm: the last row's chamber position, its
    /// offset removed and scaled by SAD / (SAD − chamber-to-isocentre distance).
    pub x_mm: f64,
    /// Position at the isocentre plane (IEC gantry y), mm.
    pub y_mm: f64,
    /// Charge collected, C: the sum of the rows' `DOSE_PRIM(C)`.
    pub charge_c: f64,
    /// The record file and the 1-based line of the spot's first row, for messages.
    pub file: String,
    /// See `file`.
    pub line: u64,
}

/// One `START_ARC_ANGLE_IRRADIATION` / `END_ARC_ANGLE_IRRADIATION` pair of the events file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArcIrradiation {
    /// Event times, s from the log's first row.
    pub start_s: f64,
    /// See `start_s`.
    pub end_s: f64,
    /// `Actual=` angles at start and end, degrees.
    pub actual_start_deg: f64,
    /// See `actual_start_deg`.
    pub actual_end_deg: f64,
    /// `Target=` angles at start and end, degrees.
    pub target_start_deg: f64,
    /// See `target_start_deg`.
    pub target_end_deg: f64,
    /// The 1-based line of the start event.
    pub line: u64,
}
