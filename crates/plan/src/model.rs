//! The serde types of the two JSON formats (`arcsim-plan/1`, `arcsim-machine/1`) and of the resolved
//! layers the sequencer consumes. Field-by-field meaning and units: `docs/plan-format.md`.
//!
//! Every struct denies unknown fields so that a misspelt field is an error, not a silent default.

use serde::{Deserialize, Serialize};

pub(crate) use crate::beam::BeamModel;

/// Value of the `format` field of every plan file; bumped on any incompatible change.
pub const PLAN_FORMAT: &str = "arcsim-plan/1";
/// Value of the `format` field of every machine file.
pub const MACHINE_FORMAT: &str = "arcsim-machine/1";

/// A proton-arc plan: one or more arcs (sub-arcs), delivered in order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArcPlan {
    /// Must equal [`PLAN_FORMAT`].
    pub format: String,
    /// The plan's name.
    pub name: String,
    /// Free text about the plan (its origin, what it tests).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// The arcs, in delivery order.
    pub arcs: Vec<Arc>,
}

/// Direction of gantry rotation within one arc.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum RotationDirection {
    /// Clockwise: the gantry angle increases from one control point to the next.
    #[serde(rename = "CW")]
    Cw,
    /// Counter-clockwise: the gantry angle decreases.
    #[serde(rename = "CC")]
    Cc,
}

impl RotationDirection {
    /// +1 for CW, -1 for CC: multiply an angle difference by it to get the progress along the arc.
    pub fn sign(self) -> f64 {
        match self {
            RotationDirection::Cw => 1.0,
            RotationDirection::Cc => -1.0,
        }
    }

    /// The name used in the JSON format ("CW" / "CC").
    pub fn as_str(self) -> &'static str {
        match self {
            RotationDirection::Cw => "CW",
            RotationDirection::Cc => "CC",
        }
    }
}

/// One sub-arc: the gantry turns one way through its control points, starting and ending at rest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Arc {
    /// The one way the gantry turns through this arc.
    pub direction: RotationDirection,
    /// The control points, in the order the gantry reaches them.
    pub control_points: Vec<ControlPoint>,
}

/// A gantry angle at which one or more energy layers are delivered.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlPoint {
    /// Gantry angle in degrees. Not limited to [0, 360): an arc may pass 360 (350 -> 370).
    pub angle_deg: f64,
    /// Prescribed gantry speed magnitude in deg/s while this control point is delivered (>= 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub required_speed_deg_per_s: Option<f64>,
    /// Full width in degrees of the tolerance window; the machine's default when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub window_deg: Option<f64>,
    /// At least one layer, in delivery order.
    pub layers: Vec<EnergyLayer>,
}

/// One energy layer: an energy and either its spots or its irradiation time (exactly one).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnergyLayer {
    /// Nominal beam energy in MeV, 1..=400.
    pub energy_mev: f64,
    /// The layer's spots, from which the beam model computes the beam-on time.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spots: Option<Spots>,
    /// Beam-on time in seconds, given directly instead of spots.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub irradiation_time_s: Option<f64>,
    /// Seconds for the switch INTO this layer; overrides the machine's ELST.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub switching_time_s: Option<f64>,
    /// This layer's share of its control point's window (a positive weight): the window is split
    /// in proportion to the layers' shares, in delivery order. Every layer of a control point
    /// gives one or none does (equal sub-windows). See [`crate::layer_windows`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub window_share: Option<f64>,
}

/// The spots of a layer: a count and either every spot's MU or the layer's total MU.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Spots {
    /// The number of spots.
    pub count: u32,
    /// MU of each spot; exactly `count` values.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mu: Option<Vec<f64>>,
    /// Total MU of the layer, shared equally by its spots.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub total_mu: Option<f64>,
    /// Spot positions `[x, y]` in mm at the isocentre plane, one per spot in delivery order. The
    /// `scanning` beam model needs them (spot-to-spot scanning time); the `per_mu` model ignores them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub positions_mm: Option<Vec<[f64; 2]>>,
    /// Number of paintings (passes over the layer's spots, in order), each delivering
    /// `mu / paintings` per spot; 1 when absent (DICOM NumberOfPaintings).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub paintings: Option<u32>,
}

/// A treatment machine: gantry limits, beam timing and energy-switching model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Machine {
    /// Must equal [`MACHINE_FORMAT`].
    pub format: String,
    /// The machine's name.
    pub name: String,
    /// Free text about the machine.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Where the numbers come from (papers, code repositories), or why they are assumptions.
    #[serde(default)]
    pub sources: Vec<String>,
    /// The gantry's kinematic limits.
    pub gantry: GantryLimitsSpec,
    /// How long a layer's beam-on takes.
    pub beam: BeamModel,
    /// How long a switch between energy layers takes.
    pub elst: ElstModel,
    /// Window width in degrees for control points that give none.
    pub default_window_deg: f64,
    /// Servo period in seconds when motion is discretised; continuous time when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub servo_period_s: Option<f64>,
    /// How much the switch and beam-on times vary (measured by `arcsim calibrate`); drawn by
    /// `simulate --monte-carlo`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spread: Option<crate::TimingSpread>,
    /// How well a calibration knows its fitted values (their standard deviations, from the 95 %
    /// intervals); `simulate --monte-carlo` draws them with the spreads.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<crate::FitUncertainty>,
    /// How the gantry moves (motion model and schedule) and where that comes from; a machine
    /// without one is simulated under [`crate::Controller::assumed`], and the output says so.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub controller: Option<crate::Controller>,
}

impl Machine {
    /// The machine's controller, or the documented assumption when its file names none.
    pub fn controller_or_assumed(&self) -> crate::Controller {
        self.controller
            .clone()
            .unwrap_or_else(crate::Controller::assumed)
    }
}

/// Kinematic limits of the gantry (magnitudes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GantryLimitsSpec {
    /// Speed limit, degrees per second.
    pub max_speed_deg_per_s: f64,
    /// Acceleration limit, degrees per second squared (also the deceleration limit unless
    /// `max_decel_deg_per_s2` is given).
    pub max_accel_deg_per_s2: f64,
    /// Deceleration limit when it differs from `max_accel_deg_per_s2`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_decel_deg_per_s2: Option<f64>,
    /// Jerk limit, degrees per second cubed.
    pub max_jerk_deg_per_s3: f64,
}

/// Energy-layer switching time (ELST) as a function of the energy step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ElstModel {
    /// Fixed times for an upward, a downward and a same-energy switch.
    Constant {
        /// Seconds for a switch to a higher energy.
        up_s: f64,
        /// Seconds for a switch to a lower energy.
        down_s: f64,
        /// Seconds between two layers of the same energy.
        same_s: f64,
    },
    /// Upward time grows with the step: `sum_i up_coeffs_s[i] * dE^i`, dE in MeV.
    Polynomial {
        /// Seconds for a switch to a lower energy.
        down_s: f64,
        /// Seconds between two layers of the same energy.
        same_s: f64,
        /// Coefficients of the upward time in the energy step, lowest power first.
        up_coeffs_s: Vec<f64>,
    },
    /// Tables by the target energy, one for upward and one for downward switches: `[MeV, s]`
    /// rows, energies strictly increasing, interpolated linearly in the energy switched to and
    /// clamped to the first / last row outside them.
    ByEnergy {
        /// Seconds for a switch up to an energy, by that energy.
        up_s_by_energy: Vec<[f64; 2]>,
        /// Seconds for a switch down to an energy, by that energy.
        down_s_by_energy: Vec<[f64; 2]>,
        /// Seconds between two layers of the same energy.
        same_s: f64,
    },
    /// A table by energy pair: `switch_s[i][j]` is the time from `energies_mev[i]` to
    /// `energies_mev[j]`; other pairs are interpolated bilinearly in (from, to) inside the grid
    /// and clamped to its edges outside it.
    ByEnergyPair {
        /// Grid energies, MeV, strictly increasing.
        energies_mev: Vec<f64>,
        /// Switching times, seconds: one row per energy switched from, one column per energy
        /// switched to.
        switch_s: Vec<Vec<f64>>,
        /// Seconds between two layers of the same energy.
        same_s: f64,
    },
}

/// `rows` (`[x, y]`, x strictly increasing) interpolated linearly at `x`, clamped to the first /
/// last row outside them; NaN without rows.
pub(crate) fn interpolate_clamped(rows: &[[f64; 2]], x: f64) -> f64 {
    let Some(first) = rows.first() else {
        return f64::NAN;
    };
    if x <= first[0] {
        return first[1];
    }
    for w in rows.windows(2) {
        let ([x0, y0], [x1, y1]) = (w[0], w[1]);
        if x <= x1 {
            return y0 + (y1 - y0) * (x - x0) / (x1 - x0);
        }
    }
    rows[rows.len() - 1][1]
}

/// Where `x` falls on the increasing `grid`: the cell's lower index and the fraction across it,
/// clamped to the grid (a one-point grid is its only point).
fn grid_cell(grid: &[f64], x: f64) -> (usize, f64) {
    let n = grid.len();
    if n < 2 || x <= grid[0] {
        return (0, 0.0);
    }
    if x >= grid[n - 1] {
        return (n - 2, 1.0);
    }
    let i = grid
        .partition_point(|&g| g <= x)
        .saturating_sub(1)
        .min(n - 2);
    (i, (x - grid[i]) / (grid[i + 1] - grid[i]))
}

/// The `ByEnergyPair` table at (`from`, `to`), bilinear (see [`ElstModel::ByEnergyPair`]).
fn pair_table(energies: &[f64], table: &[Vec<f64>], from: f64, to: f64) -> f64 {
    let at = |i: usize, j: usize| {
        table
            .get(i)
            .and_then(|row| row.get(j))
            .copied()
            .unwrap_or(f64::NAN)
    };
    if energies.len() < 2 {
        return at(0, 0);
    }
    let ((i, u), (j, w)) = (grid_cell(energies, from), grid_cell(energies, to));
    (1.0 - u) * ((1.0 - w) * at(i, j) + w * at(i, j + 1))
        + u * ((1.0 - w) * at(i + 1, j) + w * at(i + 1, j + 1))
}

/// Value of the polynomial `Σ c[i] x^i` (Horner's scheme, highest power first).
pub(crate) fn poly(c: &[f64], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, k| acc * x + k)
}

/// Energies closer than this (MeV) count as the same energy: no switch needed beyond `same_s`.
pub const SAME_ENERGY_TOLERANCE_MEV: f64 = 1e-6;

impl ElstModel {
    /// Seconds needed to switch the beam from `e_from_mev` to `e_to_mev`.
    pub fn switch_time_s(&self, e_from_mev: f64, e_to_mev: f64) -> f64 {
        let de = e_to_mev - e_from_mev;
        if de.abs() <= SAME_ENERGY_TOLERANCE_MEV {
            return self.same_s();
        }
        let up = de > 0.0;
        match self {
            ElstModel::Constant { up_s, down_s, .. } => {
                if up {
                    *up_s
                } else {
                    *down_s
                }
            }
            ElstModel::Polynomial {
                up_coeffs_s,
                down_s,
                ..
            } => {
                if up {
                    poly(up_coeffs_s, de)
                } else {
                    *down_s
                }
            }
            ElstModel::ByEnergy {
                up_s_by_energy,
                down_s_by_energy,
                ..
            } => interpolate_clamped(if up { up_s_by_energy } else { down_s_by_energy }, e_to_mev),
            ElstModel::ByEnergyPair {
                energies_mev,
                switch_s,
                ..
            } => pair_table(energies_mev, switch_s, e_from_mev, e_to_mev),
        }
    }

    /// Seconds between two layers of the same energy.
    pub fn same_s(&self) -> f64 {
        match self {
            ElstModel::Constant { same_s, .. }
            | ElstModel::Polynomial { same_s, .. }
            | ElstModel::ByEnergy { same_s, .. }
            | ElstModel::ByEnergyPair { same_s, .. } => *same_s,
        }
    }

    /// The model's `kind` as machine files name it.
    pub fn kind(&self) -> &'static str {
        match self {
            ElstModel::Constant { .. } => "constant",
            ElstModel::Polynomial { .. } => "polynomial",
            ElstModel::ByEnergy { .. } => "by_energy",
            ElstModel::ByEnergyPair { .. } => "by_energy_pair",
        }
    }
}

/// One energy layer as the sequencer sees it: located, timed, with its window and incoming switch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResolvedLayer {
    /// Index of the control point within its arc (from 0).
    pub control_point: usize,
    /// Index of the layer within its control point (from 0).
    pub layer: usize,
    /// Centre of this layer's window (gantry angle, degrees).
    pub angle_deg: f64,
    /// Full window width available to this layer, degrees.
    pub window_deg: f64,
    /// Nominal beam energy, MeV.
    pub energy_mev: f64,
    /// Beam-on time, seconds: `spot_irradiation_s + scanning_s + burst_switching_s +
    /// spill_waiting_s`.
    pub irradiation_s: f64,
    /// Of the beam-on time, the time the spots are irradiated (dose delivered), seconds.
    pub spot_irradiation_s: f64,
    /// Of the beam-on time, the time between spots (scanning, settling, layer overhead), seconds.
    pub scanning_s: f64,
    /// Of the beam-on time, the pauses between bursts (a synchrocyclotron), seconds.
    #[serde(default)]
    pub burst_switching_s: f64,
    /// Of the beam-on time, the waits for a new spill (a synchrotron), seconds.
    #[serde(default)]
    pub spill_waiting_s: f64,
    /// The gantry speed the plan prescribes through this layer, degrees per second, if any.
    pub required_speed_deg_per_s: Option<f64>,
    /// Switching time from the previous layer of the plan, seconds (0 for the very first).
    pub switch_in_s: f64,
    /// The layer's planned MU (its spots'), 0 when the plan gives none: what a log's MU column
    /// is matched against.
    #[serde(default)]
    pub mu: f64,
}

/// One arc's layers in delivery order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResolvedArc {
    /// Index of the arc within the plan (from 0).
    pub arc_index: usize,
    /// The way the gantry turns through the arc.
    pub direction: RotationDirection,
    /// The arc's layers, in delivery order.
    pub layers: Vec<ResolvedLayer>,
}
