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

/// How well a calibration knows each fitted value: the standard deviation of the value itself
/// (from its 95 % interval), not of one switch. A draw moves the whole delivery at once (every
/// up switch by the same error of `elst.up_s`), which is why it is kept apart from
/// [`TimingSpread`]. Zero (or absent) for a value the logs did not determine.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FitUncertainty {
    /// Of `elst.up_s` (constant ELST model), s.
    pub elst_up_s_sd: f64,
    /// Of `elst.down_s`, s.
    pub elst_down_s_sd: f64,
    /// Of `elst.same_s`, s.
    pub elst_same_s_sd: f64,
    /// Of `beam.s_per_mu` (`per_mu` beam model), s/MU.
    pub s_per_mu_sd: f64,
    /// Of `beam.spot_switch_time_s` (`per_mu` beam model), s.
    pub spot_switch_time_s_sd: f64,
    /// Of `gantry.max_speed_deg_per_s`, deg/s.
    pub max_speed_deg_per_s_sd: f64,
    /// Of `gantry.max_accel_deg_per_s2` (and the deceleration, drawn together), deg/s².
    pub max_accel_deg_per_s2_sd: f64,
    /// Of `gantry.max_jerk_deg_per_s3`, deg/s³.
    pub max_jerk_deg_per_s3_sd: f64,
    /// Of the one factor a calibration puts on a `scanning` beam's times per MU
    /// (`beam.s_per_mu_scale`), as a fraction of it: a draw scales the whole table.
    pub s_per_mu_scale_sd_fraction: f64,
    /// Of a `scanning` beam's `burst_switching_time_s`, s.
    pub burst_switching_time_s_sd: f64,
}

impl FitUncertainty {
    /// Each value with its machine-file name.
    pub fn fields(&self) -> [(&'static str, f64); 10] {
        [
            ("elst_up_s_sd", self.elst_up_s_sd),
            ("elst_down_s_sd", self.elst_down_s_sd),
            ("elst_same_s_sd", self.elst_same_s_sd),
            ("s_per_mu_sd", self.s_per_mu_sd),
            ("spot_switch_time_s_sd", self.spot_switch_time_s_sd),
            ("max_speed_deg_per_s_sd", self.max_speed_deg_per_s_sd),
            ("max_accel_deg_per_s2_sd", self.max_accel_deg_per_s2_sd),
            ("max_jerk_deg_per_s3_sd", self.max_jerk_deg_per_s3_sd),
            (
                "s_per_mu_scale_sd_fraction",
                self.s_per_mu_scale_sd_fraction,
            ),
            ("burst_switching_time_s_sd", self.burst_switching_time_s_sd),
        ]
    }

    /// `machine` with every uncertain value drawn once, `value + sd × normal()`: times kept
    /// ≥ 0, limits kept inside the ranges a machine file accepts.
    pub fn draw(
        &self,
        machine: &crate::Machine,
        normal: &mut dyn FnMut() -> f64,
    ) -> crate::Machine {
        use crate::{BeamModel, ElstModel};
        let mut m = machine.clone();
        let mut time = |x: &mut f64, sd: f64| {
            let z = normal();
            if sd > 0.0 {
                *x = (*x + sd * z).max(0.0);
            }
        };
        match &mut m.elst {
            ElstModel::Constant {
                up_s,
                down_s,
                same_s,
            } => {
                time(up_s, self.elst_up_s_sd);
                time(down_s, self.elst_down_s_sd);
                time(same_s, self.elst_same_s_sd);
            }
            ElstModel::Polynomial { down_s, same_s, .. } => {
                time(down_s, self.elst_down_s_sd);
                time(same_s, self.elst_same_s_sd);
            }
            _ => {}
        }
        match &mut m.beam {
            BeamModel::PerMu(b) => {
                time(&mut b.s_per_mu, self.s_per_mu_sd);
                time(&mut b.spot_switch_time_s, self.spot_switch_time_s_sd);
            }
            BeamModel::Scanning(b) => {
                let mut factor = 1.0;
                time(&mut factor, self.s_per_mu_scale_sd_fraction);
                for row in &mut b.s_per_mu_by_energy {
                    row[1] *= factor;
                }
                time(
                    &mut b.burst_switching_time_s,
                    self.burst_switching_time_s_sd,
                );
            }
        }
        let mut limit = |x: &mut f64, sd: f64, (lo, hi): (f64, f64)| {
            let z = normal();
            if sd > 0.0 {
                *x = (*x + sd * z).clamp(lo, hi);
            }
        };
        let g = &mut m.gantry;
        limit(
            &mut g.max_speed_deg_per_s,
            self.max_speed_deg_per_s_sd,
            crate::SPEED_RANGE_DEG_PER_S,
        );
        let before = g.max_accel_deg_per_s2;
        limit(
            &mut g.max_accel_deg_per_s2,
            self.max_accel_deg_per_s2_sd,
            crate::ACCEL_RANGE_DEG_PER_S2,
        );
        if let Some(d) = &mut g.max_decel_deg_per_s2 {
            let (lo, hi) = crate::ACCEL_RANGE_DEG_PER_S2;
            *d = (*d + g.max_accel_deg_per_s2 - before).clamp(lo, hi);
        }
        limit(
            &mut g.max_jerk_deg_per_s3,
            self.max_jerk_deg_per_s3_sd,
            crate::JERK_RANGE_DEG_PER_S3,
        );
        m
    }

    /// Whether any value is uncertain.
    pub fn any(&self) -> bool {
        self.fields().iter().any(|(_, x)| *x > 0.0)
    }
}
