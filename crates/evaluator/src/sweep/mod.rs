//! A loaded sweep: its plans and base machine read, its axes checked into one grid per schedule.
//!
//! Combinations are numbered plan-major: for each plan (in file order, glob matches sorted), for
//! each schedule entry, every grid point, with the jerk varying fastest, then acceleration, speed,
//! downward ELST, upward ELST, window, scanning speed and dose-rate scale (slowest).
//!
//! Nothing here is proportional to the number of combinations: a grid keeps its axes as written
//! (a range is its ends and step count), and [`Grid::setting`] decodes a grid index by mixed radix,
//! computing each axis value on demand. A sweep of more than [`MAX_COMBINATIONS`] combinations is
//! refused when it is loaded.

use std::path::PathBuf;

use arcsim_plan::{ArcPlan, Machine};
use serde::Serialize;

use crate::sweep_file::{AxisSpec, Target};
use crate::RunMode;

/// The most combinations (plans × grid points of every schedule entry) a sweep may have; also the
/// most values one axis may have. A sweep over it is refused when it is loaded, with its size:
/// its rows are kept in memory for the summary, and at thousands of evaluations per second it
/// would run for days.
pub const MAX_COMBINATIONS: usize = 100_000_000;

/// One plan of the sweep.
#[derive(Debug, Clone)]
pub struct SweepPlan {
    /// How rows name it: the path relative to the sweep file, `atom:CASE`, or the entry's `name`.
    pub label: String,
    /// The plan as loaded.
    pub plan: ArcPlan,
}

/// The machine values of one combination. `None` keeps the base machine's (or plan's) value.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Setting {
    /// Gantry jerk limit J (deg/s³).
    pub jerk_deg_per_s3: f64,
    /// Gantry acceleration limit A (deg/s²).
    pub accel_deg_per_s2: f64,
    /// Gantry speed limit V (deg/s).
    pub speed_deg_per_s: f64,
    /// Upward energy-layer switching time, ELST (s).
    pub elst_up_s: Option<f64>,
    /// Downward ELST (s).
    pub elst_down_s: Option<f64>,
    /// Window each layer is irradiated in (deg).
    pub window_deg: Option<f64>,
    /// Scanning speed of a `scanning` beam model (mm/s, both axes).
    pub scan_speed_mm_per_s: Option<f64>,
    /// Dose-rate scale: every time per MU of the beam model divided by it (2: twice the dose rate).
    pub dose_rate_scale: Option<f64>,
    /// Pause between two bursts of a layer, of a `scanning` beam model (s).
    pub burst_switching_time_s: Option<f64>,
    /// Charge of one spill, of a beam model with spills (MU).
    #[serde(default)]
    pub spill_charge_mu: Option<f64>,
    /// Time to the next spill, of a beam model with spills (s).
    #[serde(default)]
    pub spill_refill_time_s: Option<f64>,
    /// Most layers one spill serves, of a beam model with multi-energy extraction (1: none).
    #[serde(default)]
    pub spill_max_layers: Option<f64>,
}

/// The base machine's values of the limits a [`Setting`] may leave unset (`None`): what a
/// combination that does not sweep them runs with, and what the CSV's limit columns hold for them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Defaults {
    /// Upward ELST (s); `None` for a polynomial or table ELST model (no single value; the axis
    /// cannot be swept then).
    pub elst_up_s: Option<f64>,
    /// Downward ELST (s); `None` for a table ELST model.
    pub elst_down_s: Option<f64>,
    /// The machine's default window (deg). Control points with a window of their own keep it
    /// unless the window is swept.
    pub window_deg: f64,
    /// The scanning speed (mm/s) of a `scanning` beam model with one speed for both axes; `None`
    /// for a `per_mu` model (no scanning speed) or separate x and y speeds (no single value).
    pub scan_speed_mm_per_s: Option<f64>,
    /// The dose-rate scale of the base machine: 1.
    pub dose_rate_scale: f64,
    /// The burst switching time (s) of a `scanning` beam model (0 without bursts); `None` for a
    /// `per_mu` model.
    pub burst_switching_time_s: Option<f64>,
    /// The spill charge (MU) of a beam model with spills; `None` without spills.
    pub spill_charge_mu: Option<f64>,
    /// The time to the next spill (s) of a beam model with spills; `None` without spills.
    pub spill_refill_time_s: Option<f64>,
    /// The most layers per spill of a beam model with multi-energy extraction (`None` without
    /// spills, or unlimited).
    pub spill_max_layers: Option<f64>,
}

/// The values of every axis for one schedule entry, kept as written: a range is computed value
/// by value when needed ([`AxisSpec::value`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// J (an absent axis is the base machine's value, one value).
    pub jerk: AxisSpec,
    /// A (as `jerk`).
    pub accel: AxisSpec,
    /// V (as `jerk`).
    pub speed: AxisSpec,
    /// Upward ELST; `None`: the base machine's (one grid point).
    pub elst_up: Option<AxisSpec>,
    /// Downward ELST; `None`: the base machine's (one grid point).
    pub elst_down: Option<AxisSpec>,
    /// Window; `None`: the plan's and machine's (one grid point).
    pub window: Option<AxisSpec>,
    /// Scanning speed; `None`: the base machine's beam model (one grid point).
    pub scan_speed: Option<AxisSpec>,
    /// Dose-rate scale; `None`: the base machine's beam model (one grid point).
    pub dose_rate_scale: Option<AxisSpec>,
    /// Burst switching time; `None`: the base machine's beam model (one grid point).
    pub burst_switching: Option<AxisSpec>,
    /// Spill charge; `None`: the base machine's beam model (one grid point).
    pub spill_charge: Option<AxisSpec>,
    /// Spill refill time; `None`: the base machine's beam model (one grid point).
    pub spill_refill: Option<AxisSpec>,
    /// Most layers per spill; `None`: the base machine's beam model (one grid point).
    pub spill_max_layers: Option<AxisSpec>,
}

/// One schedule entry of a sweep: how it moves (schedule, motion, arc ends) and the grid of
/// settings it is evaluated at.
#[derive(Debug, Clone, PartialEq)]
pub struct ScheduleGrid {
    /// How the entry moves.
    pub schedule: RunMode,
    /// The settings it is evaluated at.
    pub grid: Grid,
}

/// A sweep ready to evaluate.
#[derive(Debug, Clone)]
pub struct Sweep {
    /// The sweep's name (from the sweep file).
    pub name: String,
    /// Free text from the sweep file.
    pub description: Option<String>,
    /// The sweep file as named on the command line.
    pub source: String,
    /// The plans, in the sweep file's order.
    pub plans: Vec<SweepPlan>,
    /// The base machine every axis varies.
    pub machine: Machine,
    /// The schedule entries, in the sweep file's order (a plan's combinations follow it).
    pub schedule_grids: Vec<ScheduleGrid>,
    /// Build timelines so rows carry kinematic margins.
    pub margins: bool,
    /// Certify every constant-speed row (lower bound and gap).
    pub certify: bool,
    /// What the summary's cheapest change must reach.
    pub target: Target,
    /// Every file the sweep file names and that was read (the machine, the plans, ATOM reference
    /// files), as joined to the sweep file's directory: a command must not write over them.
    pub inputs: Vec<PathBuf>,
    /// With the sweep file's `resequence`: what re-sequencing did to each plan on the base
    /// machine (its twin's rows are labelled `LABEL (re-sequenced)`).
    pub resequenced: Vec<ResequencedPlan>,
}

/// A plan re-sequenced for a sweep, on the base machine under its controller.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResequencedPlan {
    /// The plan's label as given.
    pub label: String,
    /// The label of its re-sequenced twin's rows.
    pub twin: String,
    /// The plan as given on the base machine (s).
    pub before_s: f64,
    /// Re-sequenced (s): equal to `before_s` where no faster order was found.
    pub after_s: f64,
    /// Layers moved inside their control points.
    pub moved_layers: usize,
}

/// The axes, in the order of [`Axis::ALL`] (also the order of the summary's columns).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Axis {
    /// Gantry jerk limit J (deg/s³).
    Jerk,
    /// Gantry acceleration limit A (deg/s²).
    Accel,
    /// Gantry speed limit V (deg/s).
    Speed,
    /// Upward energy-layer switching time, ELST (s).
    ElstUp,
    /// Downward ELST (s).
    ElstDown,
    /// Window each layer is irradiated in (deg).
    Window,
    /// Scanning speed of a `scanning` beam model (mm/s).
    ScanSpeed,
    /// Dose-rate scale of the beam model (dimensionless; 2: twice the dose rate).
    DoseRateScale,
    /// Pause between two bursts of a layer, of a `scanning` beam model (s).
    BurstSwitching,
    /// Charge of one spill, of a beam model with spills (MU).
    SpillCharge,
    /// Time to the next spill, of a beam model with spills (s).
    SpillRefill,
    /// Most layers one spill serves, of a beam model with multi-energy extraction (1: none).
    SpillMaxLayers,
}

mod axes;
mod axis;
mod grid;
mod load;
mod plans;

pub(crate) use axes::check_combinations;
pub use axes::DOSE_RATE_SCALE_RANGE;
pub use plans::RESEQUENCED_SUFFIX;

#[cfg(test)]
mod tests;
