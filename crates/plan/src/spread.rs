//! How much a machine's timings vary from one switch or layer to the next, and resolved arcs
//! with those variations drawn (a Monte Carlo draw of a delivery).

use serde::{Deserialize, Serialize};

use crate::model::{ResolvedArc, SAME_ENERGY_TOLERANCE_MEV};

/// Standard deviations of a machine's timings, as `arcsim calibrate` measures them in logs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimingSpread {
    /// Standard deviation of an upward energy switch, s.
    pub elst_up_sd_s: f64,
    /// Standard deviation of a downward energy switch, s.
    pub elst_down_sd_s: f64,
    /// Standard deviation of a switch between two layers of one energy, s.
    #[serde(default)]
    pub elst_same_sd_s: f64,
    /// Standard deviation of a layer's beam-on time, as a fraction of the model's time.
    pub beam_time_sd_fraction: f64,
}

impl TimingSpread {
    /// Each value with its machine-file name.
    pub fn fields(&self) -> [(&'static str, f64); 4] {
        [
            ("elst_up_sd_s", self.elst_up_sd_s),
            ("elst_down_sd_s", self.elst_down_sd_s),
            ("elst_same_sd_s", self.elst_same_sd_s),
            ("beam_time_sd_fraction", self.beam_time_sd_fraction),
        ]
    }

    /// `arcs` with every switch time and beam-on time drawn: the switch into each layer (the
    /// plan's first has none) `+ sd × normal()` by its kind (up, down, same energy), every beam-on
    /// part scaled by `1 + beam_time_sd_fraction × normal()`; none below 0. `normal` draws a
    /// standard normal number.
    pub fn draw(&self, arcs: &[ResolvedArc], normal: &mut dyn FnMut() -> f64) -> Vec<ResolvedArc> {
        let mut out = arcs.to_vec();
        let mut prev_energy: Option<f64> = None;
        for layer in out.iter_mut().flat_map(|a| a.layers.iter_mut()) {
            if let Some(from) = prev_energy {
                let de = layer.energy_mev - from;
                let sd = if de.abs() <= SAME_ENERGY_TOLERANCE_MEV {
                    self.elst_same_sd_s
                } else if de > 0.0 {
                    self.elst_up_sd_s
                } else {
                    self.elst_down_sd_s
                };
                layer.switch_in_s = (layer.switch_in_s + sd * normal()).max(0.0);
            }
            prev_energy = Some(layer.energy_mev);
            let k = (1.0 + self.beam_time_sd_fraction * normal()).max(0.0);
            layer.spot_irradiation_s *= k;
            layer.scanning_s *= k;
            layer.burst_switching_s *= k;
            layer.spill_waiting_s *= k;
            layer.irradiation_s = layer.spot_irradiation_s
                + layer.scanning_s
                + layer.burst_switching_s
                + layer.spill_waiting_s;
        }
        out
    }
}
