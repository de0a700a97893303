//! One row of a delivery log, and a whole log.

use serde::Serialize;

/// One sample of a delivery: where the gantry was and what the beam did at `t_s`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LogSample {
    /// Time, s, from any origin (strictly increasing along a log).
    pub t_s: f64,
    /// Gantry angle, degrees, as the plan gives angles (not wrapped).
    pub gantry_angle_deg: f64,
    /// Whether the beam is on.
    pub beam_on: bool,
    /// The layer's nominal energy while the beam is on, MeV, when the log has it.
    pub energy_mev: Option<f64>,
    /// Index of the spot being delivered in its layer, when known.
    pub spot: Option<u32>,
    /// MU delivered since the previous sample, when the log has it.
    pub mu: Option<f64>,
}

/// A delivery log read from a file: its samples in time order and which optional columns it
/// had.
#[derive(Debug, Clone, PartialEq)]
pub struct DeliveryLog {
    /// The file as named to the reader.
    pub source: String,
    /// The samples, times strictly increasing.
    pub samples: Vec<LogSample>,
    /// Whether the log has an `energy_mev` column.
    pub has_energy: bool,
    /// Whether the log has a `spot` column.
    pub has_spot: bool,
    /// Whether the log has an `mu` column.
    pub has_mu: bool,
}

impl DeliveryLog {
    /// Time from the first sample to the last, s.
    pub fn duration_s(&self) -> f64 {
        match (self.samples.first(), self.samples.last()) {
            (Some(a), Some(b)) => b.t_s - a.t_s,
            _ => 0.0,
        }
    }
}
