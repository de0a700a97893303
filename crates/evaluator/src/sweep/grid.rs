//! A schedule entry's grid: its size, and the setting of a grid index (mixed radix).

use super::*;
use crate::sweep_file::AxisSpec;

impl Grid {
    fn axis(&self, axis: Axis) -> Option<&AxisSpec> {
        match axis {
            Axis::Jerk => Some(&self.jerk),
            Axis::Accel => Some(&self.accel),
            Axis::Speed => Some(&self.speed),
            Axis::ElstUp => self.elst_up.as_ref(),
            Axis::ElstDown => self.elst_down.as_ref(),
            Axis::Window => self.window.as_ref(),
            Axis::ScanSpeed => self.scan_speed.as_ref(),
            Axis::DoseRateScale => self.dose_rate_scale.as_ref(),
            Axis::BurstSwitching => self.burst_switching.as_ref(),
            Axis::SpillCharge => self.spill_charge.as_ref(),
            Axis::SpillRefill => self.spill_refill.as_ref(),
            Axis::SpillMaxLayers => self.spill_max_layers.as_ref(),
        }
    }

    /// Number of values of one axis (1 for an absent ELST, window or beam axis).
    pub fn axis_len(&self, axis: Axis) -> usize {
        self.axis(axis).map_or(1, AxisSpec::len)
    }

    /// Value `i` (< [`Grid::axis_len`]) of one axis (`None`: the base value).
    pub fn value(&self, axis: Axis, i: usize) -> Option<f64> {
        match self.axis(axis) {
            Some(a) => Some(a.value(i)),
            None => {
                assert!(i == 0, "value {i} of an absent axis");
                None
            }
        }
    }

    /// Number of grid points, `None` when it overflows `usize` (a loaded sweep has at most
    /// [`MAX_COMBINATIONS`]).
    pub fn checked_len(&self) -> Option<usize> {
        Axis::ALL
            .into_iter()
            .try_fold(1usize, |n, a| n.checked_mul(self.axis_len(a)))
    }

    /// Number of grid points (at least 1 once loaded; saturates at `usize::MAX`).
    pub fn len(&self) -> usize {
        self.checked_len().unwrap_or(usize::MAX)
    }

    /// Whether the grid has no point.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The setting at grid index `i` (< [`Grid::len`]; jerk fastest, layers per spill slowest): `i`
    /// read as a mixed-radix number whose digits index the axes, each value computed on demand.
    pub fn setting(&self, i: usize) -> Setting {
        let mut rest = i;
        let mut digit = |axis: Axis| {
            let n = self.axis_len(axis);
            let d = rest % n;
            rest /= n;
            d
        };
        // The digits from the fastest: J, A, V, ELST down, ELST up, window, scanning speed,
        // dose-rate scale, burst switching, spill charge, spill refill, layers per spill.
        let j = digit(Axis::Jerk);
        let a = digit(Axis::Accel);
        let v = digit(Axis::Speed);
        let d = digit(Axis::ElstDown);
        let u = digit(Axis::ElstUp);
        let w = digit(Axis::Window);
        let sc = digit(Axis::ScanSpeed);
        let r = digit(Axis::DoseRateScale);
        let b = digit(Axis::BurstSwitching);
        let q = digit(Axis::SpillCharge);
        let f = digit(Axis::SpillRefill);
        let n = digit(Axis::SpillMaxLayers);
        assert!(rest == 0, "grid index {i} of {}", self.len());
        Setting {
            jerk_deg_per_s3: self.jerk.value(j),
            accel_deg_per_s2: self.accel.value(a),
            speed_deg_per_s: self.speed.value(v),
            elst_up_s: self.value(Axis::ElstUp, u),
            elst_down_s: self.value(Axis::ElstDown, d),
            window_deg: self.value(Axis::Window, w),
            scan_speed_mm_per_s: self.value(Axis::ScanSpeed, sc),
            dose_rate_scale: self.value(Axis::DoseRateScale, r),
            burst_switching_time_s: self.value(Axis::BurstSwitching, b),
            spill_charge_mu: self.value(Axis::SpillCharge, q),
            spill_refill_time_s: self.value(Axis::SpillRefill, f),
            spill_max_layers: self.value(Axis::SpillMaxLayers, n),
        }
    }

    /// The values of one axis (`None`: the base value). Materialises the axis: prefer
    /// [`Grid::axis_len`] and [`Grid::value`].
    pub fn values(&self, axis: Axis) -> Vec<Option<f64>> {
        (0..self.axis_len(axis))
            .map(|i| self.value(axis, i))
            .collect()
    }
}
