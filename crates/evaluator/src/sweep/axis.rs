//! The swept quantities: their names and symbols, and a setting's value of each.

use super::*;

impl Axis {
    /// Every axis, in column order.
    pub const ALL: [Axis; 12] = [
        Axis::Jerk,
        Axis::Accel,
        Axis::Speed,
        Axis::ElstUp,
        Axis::ElstDown,
        Axis::Window,
        Axis::ScanSpeed,
        Axis::DoseRateScale,
        Axis::BurstSwitching,
        Axis::SpillCharge,
        Axis::SpillRefill,
        Axis::SpillMaxLayers,
    ];

    /// The gantry's own limits (J, A, V): raising one admits every timeline the lower value
    /// admitted, so it never makes the best delivery longer.
    pub fn is_gantry_limit(self) -> bool {
        matches!(self, Axis::Jerk | Axis::Accel | Axis::Speed)
    }

    /// For an axis only a `scanning` beam model has: what a `per_mu` model lacks, and what the
    /// axis sweeps (for the refusal's message).
    pub(crate) fn scanning_only(self) -> Option<(&'static str, &'static str)> {
        match self {
            Axis::ScanSpeed => Some(("scanning speed", "the scanning speed")),
            Axis::BurstSwitching => Some(("bursts", "the burst switching time")),
            _ => None,
        }
    }

    /// For an axis only a beam model with spills has: what it sweeps (for the refusal's message).
    pub(crate) fn spill_only(self) -> Option<&'static str> {
        match self {
            Axis::SpillCharge => Some("the spill charge"),
            Axis::SpillRefill => Some("the spill refill time"),
            Axis::SpillMaxLayers => Some("the layers per spill"),
            _ => None,
        }
    }

    /// The axes that set the beam model, in the order a variant applies them.
    pub(crate) const BEAM: [Axis; 6] = [
        Axis::ScanSpeed,
        Axis::DoseRateScale,
        Axis::BurstSwitching,
        Axis::SpillCharge,
        Axis::SpillRefill,
        Axis::SpillMaxLayers,
    ];

    /// `beam` with this beam axis set to `x`; `None` for an axis of [`Axis::BEAM`] the model
    /// lacks (scanning speed or bursts on `per_mu`, spills on a model without them) and for any
    /// other axis.
    pub(crate) fn set_beam(
        self,
        beam: &arcsim_plan::BeamModel,
        x: f64,
    ) -> Option<arcsim_plan::BeamModel> {
        match self {
            Axis::ScanSpeed => beam.with_scan_speed(x),
            Axis::DoseRateScale => Some(beam.with_dose_rate_scale(x)),
            Axis::BurstSwitching => beam.with_burst_switching_time(x),
            Axis::SpillCharge => beam.with_spill_charge(x),
            Axis::SpillRefill => beam.with_spill_refill_time(x),
            // Whole numbers from 1, checked when the sweep is loaded.
            Axis::SpillMaxLayers => beam.with_spill_max_layers(x as u32),
            _ => None,
        }
    }

    /// The field name in sweep files and output columns.
    pub fn field(self) -> &'static str {
        match self {
            Axis::Jerk => "jerk_deg_per_s3",
            Axis::Accel => "accel_deg_per_s2",
            Axis::Speed => "speed_deg_per_s",
            Axis::ElstUp => "elst_up_s",
            Axis::ElstDown => "elst_down_s",
            Axis::Window => "window_deg",
            Axis::ScanSpeed => "scan_speed_mm_per_s",
            Axis::DoseRateScale => "dose_rate_scale",
            Axis::BurstSwitching => "burst_switching_time_s",
            Axis::SpillCharge => "spill_charge_mu",
            Axis::SpillRefill => "spill_refill_time_s",
            Axis::SpillMaxLayers => "spill_max_layers",
        }
    }

    /// The unit as figures and plot titles print it ("°/s³"; [`Axis::symbol`] has the plain-text
    /// one of the tables).
    pub fn unit(self) -> &'static str {
        match self {
            Axis::Jerk => "°/s³",
            Axis::Accel => "°/s²",
            Axis::Speed => "°/s",
            Axis::ElstUp | Axis::ElstDown | Axis::BurstSwitching | Axis::SpillRefill => "s",
            Axis::SpillCharge => "MU",
            Axis::SpillMaxLayers => "layers",
            Axis::Window => "°",
            Axis::ScanSpeed => "mm/s",
            Axis::DoseRateScale => "×",
        }
    }

    /// Whether the axis takes whole numbers only (a machine applies it rounded down).
    pub fn is_whole(self) -> bool {
        matches!(self, Axis::SpillMaxLayers)
    }

    /// Short symbol and unit for tables ("J", "deg/s^3").
    pub fn symbol(self) -> (&'static str, &'static str) {
        match self {
            Axis::Jerk => ("J", "deg/s^3"),
            Axis::Accel => ("A", "deg/s^2"),
            Axis::Speed => ("V", "deg/s"),
            Axis::ElstUp => ("ELST up", "s"),
            Axis::ElstDown => ("ELST down", "s"),
            Axis::Window => ("window", "deg"),
            Axis::ScanSpeed => ("scan speed", "mm/s"),
            Axis::DoseRateScale => ("dose rate", "×"),
            Axis::BurstSwitching => ("burst switching", "s"),
            Axis::SpillCharge => ("spill charge", "MU"),
            Axis::SpillRefill => ("spill refill", "s"),
            Axis::SpillMaxLayers => ("layers per spill", "layers"),
        }
    }
}

impl Setting {
    /// The value of one axis (`None`: as in the base machine or plan).
    pub fn get(&self, axis: Axis) -> Option<f64> {
        match axis {
            Axis::Jerk => Some(self.jerk_deg_per_s3),
            Axis::Accel => Some(self.accel_deg_per_s2),
            Axis::Speed => Some(self.speed_deg_per_s),
            Axis::ElstUp => self.elst_up_s,
            Axis::ElstDown => self.elst_down_s,
            Axis::Window => self.window_deg,
            Axis::ScanSpeed => self.scan_speed_mm_per_s,
            Axis::DoseRateScale => self.dose_rate_scale,
            Axis::BurstSwitching => self.burst_switching_time_s,
            Axis::SpillCharge => self.spill_charge_mu,
            Axis::SpillRefill => self.spill_refill_time_s,
            Axis::SpillMaxLayers => self.spill_max_layers,
        }
    }

    /// The value of one axis, the base machine's (`defaults`) where the setting keeps it (`None`
    /// where the ELST model has no single value: see [`Defaults`]).
    pub fn get_or(&self, axis: Axis, defaults: &Defaults) -> Option<f64> {
        self.get(axis).or(match axis {
            Axis::ElstUp => defaults.elst_up_s,
            Axis::ElstDown => defaults.elst_down_s,
            Axis::Window => Some(defaults.window_deg),
            Axis::ScanSpeed => defaults.scan_speed_mm_per_s,
            Axis::DoseRateScale => Some(defaults.dose_rate_scale),
            Axis::BurstSwitching => defaults.burst_switching_time_s,
            Axis::SpillCharge => defaults.spill_charge_mu,
            Axis::SpillRefill => defaults.spill_refill_time_s,
            Axis::SpillMaxLayers => defaults.spill_max_layers,
            Axis::Jerk | Axis::Accel | Axis::Speed => None,
        })
    }

    /// A copy with one axis set.
    pub fn with(mut self, axis: Axis, value: f64) -> Setting {
        match axis {
            Axis::Jerk => self.jerk_deg_per_s3 = value,
            Axis::Accel => self.accel_deg_per_s2 = value,
            Axis::Speed => self.speed_deg_per_s = value,
            Axis::ElstUp => self.elst_up_s = Some(value),
            Axis::ElstDown => self.elst_down_s = Some(value),
            Axis::Window => self.window_deg = Some(value),
            Axis::ScanSpeed => self.scan_speed_mm_per_s = Some(value),
            Axis::DoseRateScale => self.dose_rate_scale = Some(value),
            Axis::BurstSwitching => self.burst_switching_time_s = Some(value),
            Axis::SpillCharge => self.spill_charge_mu = Some(value),
            Axis::SpillRefill => self.spill_refill_time_s = Some(value),
            Axis::SpillMaxLayers => self.spill_max_layers = Some(value),
        }
        self
    }
}
