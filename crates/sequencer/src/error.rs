//! Sequencer errors.

use arcsim_plan::SpotTimingError;
use arcsim_planner::PlannerError;

use crate::types::{Motion, Schedule};
use thiserror::Error;

pub use arcsim_plan::UnknownName;

/// Why a delivery cannot be sequenced.
#[derive(Debug, Error)]
pub enum SequenceError {
    /// The plan or machine failed validation / resolution.
    #[error("{0}")]
    Plan(#[from] arcsim_plan::PlanError),
    /// Machine limits the planner rejects.
    #[error("machine gantry limits: {0}")]
    Limits(PlannerError),
    /// No feasible timeline (should not happen for valid plans: rest is always feasible).
    #[error("arc {arc}, layer {layer}: {reason}")]
    Infeasible {
        /// The arc's index in the plan.
        arc: usize,
        /// The layer's index within the arc.
        layer: usize,
        /// What could not be done; a planner refusal is kept as it is.
        #[source]
        reason: Infeasibility,
    },
    /// The integrated timeline broke a constraint: a bug, reported instead of ignored.
    #[error("timeline verification failed (a bug): {0}")]
    Verification(#[from] VerificationError),
    /// Wrong input to a lower-level entry point (e.g. speed list of the wrong length).
    #[error(transparent)]
    Input(#[from] InputError),
}

/// Options or arguments that do not go together.
#[derive(Debug, Error)]
pub enum InputError {
    /// The servo period is not a finite positive number.
    #[error("servo period {period_s} s: expected a finite number > 0")]
    ServoPeriod {
        /// The period given (s).
        period_s: f64,
    },
    /// Free arc ends asked of a model whose speed is constant while the beam is on.
    #[error("free arc ends need free motion (--motion free): a {} arc starts and ends at rest", .motion.adjective())]
    FreeEndsNeedFreeMotion {
        /// The motion model asked for.
        motion: Motion,
    },
    /// A continuous-time model asked on a servo period.
    #[error("{} is continuous-time only ({why}): drop the servo period (--period or the machine's servo_period_s), or use --motion constant, which supports one", .motion.describe())]
    ContinuousTimeOnly {
        /// The motion model asked for.
        motion: Motion,
        /// Why it has no servo-period version.
        why: &'static str,
    },
    /// A model that chooses its own speeds asked with a schedule that fixes them.
    #[error("{} chooses its own speeds: use it with the optimal or scan schedule, not {}", .motion.describe(), .schedule.name())]
    MotionSchedule {
        /// The motion model asked for.
        motion: Motion,
        /// The schedule asked for.
        schedule: Schedule,
    },
    /// A speed list whose length is not the number of layers.
    #[error("{given} speeds given for {layers} layers")]
    SpeedCount {
        /// Speeds given.
        given: usize,
        /// Layers of the arcs.
        layers: usize,
    },
    /// Spot times asked of a delivery built without its timeline.
    #[error("the spot timeline needs the delivery's timeline")]
    NoTimeline,
    /// A delivery layer that the plan does not have.
    #[error("delivery layer {index} (arc {arc}, control point {control_point}, layer {layer}) is not in plan \"{plan}\"")]
    LayerNotInPlan {
        /// The layer's delivery index.
        index: usize,
        /// Its arc.
        arc: usize,
        /// Its control point.
        control_point: usize,
        /// Its layer within the control point.
        layer: usize,
        /// The plan's name.
        plan: String,
    },
    /// A layer whose spots the machine's beam model cannot time.
    #[error("layer {index} (arc {arc}, control point {control_point}, layer {layer}): its spots cannot be timed under machine \"{machine}\": {reason:?}")]
    SpotsUntimed {
        /// The layer's delivery index.
        index: usize,
        /// Its arc.
        arc: usize,
        /// Its control point.
        control_point: usize,
        /// Its layer within the control point.
        layer: usize,
        /// The machine's name.
        machine: String,
        /// Why the beam model cannot time them.
        reason: SpotTimingError,
    },
    /// A delivery whose layers are not those of the arcs given.
    #[error("the delivery does not belong to these arcs")]
    DeliveryNotOfArcs,
}

/// The constraint an integrated timeline broke (a bug of the sequencer).
#[derive(Debug, Error)]
pub enum VerificationError {
    /// Two consecutive pieces do not meet in time.
    #[error("time jumps between pieces {piece} and {}", .piece + 1)]
    TimeJump {
        /// The first piece's index.
        piece: usize,
    },
    /// The angle jumps between pieces.
    #[error("angle jumps by {jump_deg:e} deg at t = {t_s:.6} s")]
    AngleJump {
        /// The jump (deg).
        jump_deg: f64,
        /// Where (s).
        t_s: f64,
    },
    /// The speed jumps between pieces.
    #[error("speed jumps by {jump_deg_per_s:e} deg/s at t = {t_s:.6} s")]
    SpeedJump {
        /// The jump (deg/s).
        jump_deg_per_s: f64,
        /// Where (s).
        t_s: f64,
    },
    /// The acceleration jumps between pieces.
    #[error("acceleration jumps at t = {t_s:.6} s")]
    AccelJump {
        /// Where (s).
        t_s: f64,
    },
    /// A piece's jerk is above J.
    #[error("jerk {jerk_deg_per_s3} above J at t = {t_s:.6} s")]
    JerkAboveLimit {
        /// The jerk (deg/s³).
        jerk_deg_per_s3: f64,
        /// The piece's start (s).
        t_s: f64,
    },
    /// A beam piece starts or ends outside its layer's window.
    #[error(
        "layer {layer}: beam at {angle_deg:.9} deg outside its window [{lo_deg:.6}, {hi_deg:.6}]"
    )]
    BeamOutsideWindow {
        /// The layer (delivery index).
        layer: usize,
        /// The beam's angle (deg).
        angle_deg: f64,
        /// The window's edges (deg).
        lo_deg: f64,
        /// The window's upper edge (deg).
        hi_deg: f64,
    },
    /// Constant motion changed speed while irradiating.
    #[error("layer {layer}: speed not constant while irradiating")]
    SpeedNotConstant {
        /// The layer (delivery index).
        layer: usize,
    },
    /// A move piece names a transition that has no row.
    #[error("a move belongs to transition {transition}, which does not exist")]
    UnknownTransition {
        /// The transition named.
        transition: usize,
    },
    /// The acceleration is above its limit (A, or D when braking).
    #[error(
        "acceleration {accel_deg_per_s2} above its limit {limit_deg_per_s2} at t = {t_s:.6} s"
    )]
    AccelAboveLimit {
        /// The acceleration (deg/s²).
        accel_deg_per_s2: f64,
        /// Its limit (deg/s²).
        limit_deg_per_s2: f64,
        /// Where (s).
        t_s: f64,
    },
    /// The speed is above V.
    #[error("speed {speed_deg_per_s} above V at t = {t_s:.6} s")]
    SpeedAboveLimit {
        /// The speed (deg/s).
        speed_deg_per_s: f64,
        /// The piece's start (s).
        t_s: f64,
    },
    /// The gantry moves backwards inside an arc.
    #[error("gantry reverses inside an arc at t = {t_s:.6} s (speed {speed_deg_per_s})")]
    Reversal {
        /// The piece's start (s).
        t_s: f64,
        /// The speed (deg/s).
        speed_deg_per_s: f64,
    },
    /// A transition is shorter than its ELST.
    #[error("transition {transition} lasts {duration_s} s, less than its ELST {elst_s} s")]
    ShorterThanElst {
        /// The transition's index.
        transition: usize,
        /// Its duration (s).
        duration_s: f64,
        /// Its ELST (s).
        elst_s: f64,
    },
    /// The timeline's duration is not the end of the last layer.
    #[error("timeline lasts {timeline_s} s but the layers end at {layers_end_s} s")]
    DurationMismatch {
        /// The timeline's duration (s).
        timeline_s: f64,
        /// The last layer's end (s).
        layers_end_s: f64,
    },
}

/// What made one transition or layer infeasible.
#[derive(Debug, Error)]
pub enum Infeasibility {
    /// The planner refused the move (gap too short, end speed unreachable, …).
    #[error(transparent)]
    Planner(#[from] PlannerError),
    /// The move has no duration at least as long as the energy switch.
    #[error("the move cannot last its {elst_s} s energy switch")]
    CannotLastElst {
        /// The energy-layer switching time (s).
        elst_s: f64,
    },
    /// The move has no duration that is a whole number of servo periods.
    #[error("the move cannot last a whole number of {period_s} s servo periods")]
    NotOnServoGrid {
        /// The servo period (s).
        period_s: f64,
    },
    /// A given layer speed is outside what the layer allows.
    #[error(
        "speed {speed_deg_per_s} deg/s is outside [0, {cap_deg_per_s}] (window, V, or rest at the arc's ends)"
    )]
    SpeedOutOfRange {
        /// The speed given (deg/s).
        speed_deg_per_s: f64,
        /// The layer's cap (deg/s).
        cap_deg_per_s: f64,
    },
    /// Free motion could not rebuild the constant-speed schedule.
    #[error("the constant-speed schedule could not be rebuilt as free motion")]
    FreeMotionRebuild,
    /// No single gantry speed delivers the arc's layers (one speed per arc).
    #[error("no single arc speed delivers it: {why}")]
    NoArcSpeed {
        /// What rules every speed out.
        why: String,
    },
    /// No stop-and-turn move between two arcs reaches the next arc's start.
    #[error("no stop-and-turn move reaches the arc's start")]
    NoStopAndTurn,
}
