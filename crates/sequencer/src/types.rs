//! The sequencer's inputs (options) and results (delivery, rows, margins).

use arcsim_planner::Limits;
use serde::{Deserialize, Serialize};

use crate::error::UnknownName;
use crate::Timeline;
use arcsim_plan::ResolvedArc;
pub use arcsim_plan::{Motion, Schedule};

/// What the gantry does at the ends of an arc.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ArcEnds {
    /// The first and last layers of an arc are irradiated at rest (ATOM's convention).
    #[default]
    Rest,
    /// The gantry may already move at the first beam-on and still move at the last beam-off;
    /// the run-up from rest before the first beam counts, braking after the last does not.
    /// Only free motion can use it (a constant-speed arc starts and ends at rest).
    Free,
}

impl ArcEnds {
    /// Both, rest first.
    pub const ALL: [ArcEnds; 2] = [ArcEnds::Rest, ArcEnds::Free];

    /// The name the CLI and the files use.
    pub fn name(self) -> &'static str {
        match self {
            ArcEnds::Rest => "rest",
            ArcEnds::Free => "free",
        }
    }
}

impl std::str::FromStr for ArcEnds {
    type Err = UnknownName;
    fn from_str(s: &str) -> Result<Self, UnknownName> {
        ArcEnds::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| UnknownName {
                what: "arc ends",
                name: s.to_string(),
                expected: "rest or free".into(),
            })
    }
}

/// Options of one simulation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Options {
    /// How the layer speeds are chosen.
    pub schedule: Schedule,
    /// Build the sampled-ready timeline and its margins (off for fast sweeps: totals only).
    pub build_timeline: bool,
    /// Servo period (s): every transition lasts a whole number of periods (the shortest such
    /// duration the move can last, never shorter than in continuous time). `None`: continuous.
    #[serde(default)]
    pub servo_period_s: Option<f64>,
    /// Constant speed per layer, or free motion (seeded by `schedule`'s constant speeds).
    #[serde(default)]
    pub motion: Motion,
    /// Arc ends at rest, or free (free motion only).
    #[serde(default)]
    pub arc_ends: ArcEnds,
}

/// Constant motion with the `scan` schedule, arc ends at rest, continuous time, timeline built:
/// the cheapest full simulation. The CLI and the Python package default instead to free motion
/// with the `optimal` schedule (constant motion where a servo period applies or the schedule is
/// `prescribed` or `step-and-shoot`).
impl Default for Options {
    fn default() -> Self {
        Options {
            schedule: Schedule::Scan,
            build_timeline: true,
            servo_period_s: None,
            motion: Motion::Constant,
            arc_ends: ArcEnds::Rest,
        }
    }
}

impl Options {
    /// The default options with `schedule`.
    pub fn new(schedule: Schedule) -> Self {
        Options {
            schedule,
            ..Options::default()
        }
    }
}

/// What bounded a layer's speed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SpeedBound {
    /// First or last layer of an arc: delivered at rest.
    Rest,
    /// The window: speed × irradiation time = window width.
    Window,
    /// The gantry's speed limit V.
    MaxSpeed,
    /// Lowered so a neighbouring transition fits its gap (acceleration/jerk limits).
    Gap,
    /// Lowered so a neighbouring transition can last its ELST.
    Elst,
    /// The plan's required speed.
    Prescribed,
    /// Step-and-shoot: at rest by definition.
    StepAndShoot,
    /// Chosen by the optimiser below every cap (trading speed for transition time).
    Optimised,
    /// Lowered so a neighbouring transition can be timed on the servo period.
    Servo,
    /// Free motion: the speed changes while the beam is on (the row gives its mean).
    Free,
    /// One speed for the whole arc, set by its most demanding layer or move.
    OneSpeed,
}

/// What limits a transition: the gantry limit whose raise by [`crate::LIMIT_RAISE_FACTOR`]
/// shortens it most, or the ELST when no raise shortens it (module `raise`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Limiter {
    /// The energy-layer switching time: no raise shortens the move (the gantry could have been
    /// faster).
    Elst,
    /// Raising V shortens the move most.
    Speed,
    /// Raising A and D together shortens the move most.
    Accel,
    /// Raising J shortens the move most.
    Jerk,
    /// No motion (zero-length, zero-time transition).
    None,
}

/// Counts of transitions by what limited them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LimiterCounts {
    /// Limited by the ELST.
    pub elst: usize,
    /// Limited by V.
    pub speed: usize,
    /// Limited by A and D.
    pub accel: usize,
    /// Limited by J.
    pub jerk: usize,
    /// Not moving.
    pub none: usize,
}

/// One delivered layer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LayerRow {
    /// Index of the layer in delivery order over the whole plan.
    pub index: usize,
    /// The arc (index in the plan).
    pub arc: usize,
    /// The control point within the arc.
    pub control_point: usize,
    /// The layer within the control point.
    pub layer: usize,
    /// The layer's gantry angle (deg).
    pub angle_deg: f64,
    /// The layer's energy (MeV).
    pub energy_mev: f64,
    /// Beam-on time (s).
    pub irradiation_s: f64,
    /// Gantry speed while irradiating (magnitude, deg/s); with free motion, the mean speed.
    pub speed_deg_per_s: f64,
    /// Speed at beam-on and at beam-off (deg/s; equal to the speed with constant motion).
    pub speed_on_deg_per_s: f64,
    /// Speed at beam-off (deg/s).
    pub speed_off_deg_per_s: f64,
    /// What bounds the layer's speed.
    pub speed_bound: SpeedBound,
    /// The layer's tolerance window (deg).
    pub window_deg: f64,
    /// Degrees swept while irradiating (speed × irradiation time).
    pub window_used_deg: f64,
    /// Beam-on (s from the start of the delivery).
    pub t_start_s: f64,
    /// Beam-off (s).
    pub t_end_s: f64,
    /// Duration of the transition into this layer (0 for the first layer of the plan).
    pub transition_in_s: f64,
    /// What set the duration of the transition into this layer.
    pub transition_limited_by: Limiter,
}

/// One beam-off move between two layers (or between two arcs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransitionRow {
    /// Index in delivery order.
    pub index: usize,
    /// Layer indices (delivery order) before and after.
    pub from_layer: usize,
    /// Layer index (delivery order) after.
    pub to_layer: usize,
    /// True for the stop-and-turn between two arcs.
    pub arc_change: bool,
    /// Start, at the beam-off before it (s).
    pub t_start_s: f64,
    /// Duration (s).
    pub duration_s: f64,
    /// Minimum-time duration without the ELST (s); with free motion, the transition's duration
    /// (its motion is shaped together with the layers around it).
    pub min_time_s: f64,
    /// The energy-layer switching time this move must last (s).
    pub elst_s: f64,
    /// Beam-off gap covered (deg, magnitude).
    pub gap_deg: f64,
    /// Speed at its start (deg/s, magnitude).
    pub v_start_deg_per_s: f64,
    /// Speed at its end (deg/s, magnitude).
    pub v_end_deg_per_s: f64,
    /// What limits it.
    pub limited_by: Limiter,
    /// Time beyond the ELST that the gantry needed (s).
    pub lost_s: f64,
}

/// Where the total time goes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Breakdown {
    /// Σ irradiation times: `spot_irradiation_s + scanning_s + burst_switching_s +
    /// spill_waiting_s`.
    pub beam_on_s: f64,
    /// Of the beam-on time, the spots' irradiation (dose delivered).
    #[serde(default)]
    pub spot_irradiation_s: f64,
    /// Of the beam-on time, the time between spots: scanning (or spot switching), settling and
    /// layer overhead.
    #[serde(default)]
    pub scanning_s: f64,
    /// Of the beam-on time, the pauses between a layer's bursts (a synchrocyclotron).
    #[serde(default)]
    pub burst_switching_s: f64,
    /// Of the beam-on time, the waits for the next spill (a synchrotron).
    #[serde(default)]
    pub spill_waiting_s: f64,
    /// Σ energy-layer switching times.
    pub energy_switching_s: f64,
    /// What the gantry adds beyond the two: Σ max(0, transition − ELST).
    pub lost_s: f64,
}

impl Breakdown {
    /// The breakdown of a delivery of `arcs`: beam-on parts from the layers, `energy_switching_s`
    /// and `lost_s` as computed from the transitions.
    pub(crate) fn of(arcs: &[ResolvedArc], energy_switching_s: f64, lost_s: f64) -> Breakdown {
        let layers = || arcs.iter().flat_map(|a| &a.layers);
        // An empty sum is -0 (no transitions, no layers): written 0.
        let sum = |x: f64| arcsim_plan::unsigned_zero(x);
        Breakdown {
            beam_on_s: sum(layers().map(|l| l.irradiation_s).sum()),
            spot_irradiation_s: sum(layers().map(|l| l.spot_irradiation_s).sum()),
            scanning_s: sum(layers().map(|l| l.scanning_s).sum()),
            burst_switching_s: sum(layers().map(|l| l.burst_switching_s).sum()),
            spill_waiting_s: sum(layers().map(|l| l.spill_waiting_s).sum()),
            energy_switching_s: sum(energy_switching_s),
            lost_s: sum(lost_s),
        }
    }
}

/// The tightest value of a quantity over the timeline and where it occurs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Margin {
    /// The value, in the unit of the quantity.
    pub value: f64,
    /// When it occurs (s).
    pub t_s: f64,
    /// Layer (delivery order) nearest to where it occurs.
    pub layer: usize,
}

/// Kinematic margins over the whole timeline.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Margins {
    /// Peak |speed| / V.
    pub speed_use: Margin,
    /// Peak |acceleration| / A (or D when braking).
    pub accel_use: Margin,
    /// Peak |jerk| / J.
    pub jerk_use: Margin,
    /// Smallest unused window (deg).
    pub window_slack_deg: Margin,
    /// Smallest time a transition lasts beyond its ELST (s).
    pub elst_slack_s: Margin,
}

/// A plan point where the prescribed speed cannot be delivered.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Violation {
    /// Layer index (delivery order).
    pub layer: usize,
    /// The arc (index in the plan).
    pub arc: usize,
    /// The control point within the arc.
    pub control_point: usize,
    /// The plan's required speed (deg/s).
    pub prescribed_deg_per_s: f64,
    /// The corrected speed used in the delivered timeline.
    pub corrected_deg_per_s: f64,
    /// Why it cannot be delivered.
    pub reason: String,
}

/// The result of one simulation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Delivery {
    /// The schedule that chose the speeds.
    pub schedule: Schedule,
    /// The motion model (the controller) that made the delivery.
    pub motion: Motion,
    /// What the gantry does at the arcs' ends.
    pub arc_ends: ArcEnds,
    /// Any model but constant speed per layer: the total with constant speed per layer (same
    /// schedule), so what the model saves (free motion) or costs (one speed per arc) is
    /// `constant_speed_total_s - total_s`.
    pub constant_speed_total_s: Option<f64>,
    /// Total delivery time (s).
    pub total_s: f64,
    /// Where the total time goes.
    pub breakdown: Breakdown,
    /// The gantry limits used.
    pub limits: LimitsOut,
    /// Servo period the transitions were timed on (s); `None`: continuous time.
    pub servo_period_s: Option<f64>,
    /// One row per layer, delivery order.
    pub layers: Vec<LayerRow>,
    /// One row per transition, delivery order.
    pub transitions: Vec<TransitionRow>,
    /// Transitions counted by what limits them.
    pub limiter_counts: LimiterCounts,
    /// Present when the options asked for a timeline.
    pub margins: Option<Margins>,
    /// Prescribed schedule only: every infeasible prescribed speed, with the reason.
    pub violations: Vec<Violation>,
    /// Where the lost time goes: by cause and place, and the costliest transitions.
    #[serde(default)]
    pub lost_time: crate::LostTime,
    #[serde(skip)]
    /// The gantry motion, when the options asked for it (not serialised).
    pub timeline: Option<Timeline>,
}

/// The gantry limits used, in the units of the output.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LimitsOut {
    /// V (deg/s).
    pub max_speed_deg_per_s: f64,
    /// A (deg/s²).
    pub max_accel_deg_per_s2: f64,
    /// D (deg/s²).
    pub max_decel_deg_per_s2: f64,
    /// J (deg/s³).
    pub max_jerk_deg_per_s3: f64,
}

impl From<Limits> for LimitsOut {
    fn from(l: Limits) -> Self {
        LimitsOut {
            max_speed_deg_per_s: l.max_vel,
            max_accel_deg_per_s2: l.max_accel,
            max_decel_deg_per_s2: l.max_decel,
            max_jerk_deg_per_s3: l.max_jerk,
        }
    }
}
