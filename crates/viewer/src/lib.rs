//! # arcsim-viewer
//!
//! Writes arcsim results for the [Rerun](https://rerun.io) viewer (SDK 0.36.3): a simulated
//! [`Delivery`](arcsim_sequencer::Delivery) as time series, a layer log, beam/switching phases and a 2D view of the gantry,
//! with a default layout (blueprint); optionally the spots of the layer being delivered in a 2D
//! beam's-eye view. Output goes to an `.rrd` file ([`save_delivery`]), to a newly spawned viewer
//! ([`spawn_delivery`], needs the `rerun` binary on `PATH`) or to a running viewer over gRPC
//! ([`connect_delivery`]). The steps they take are public for a caller's own recording stream:
//! [`send_delivery_blueprint`], [`log_delivery`] and [`log_spots`].
//! [`save_sweep`] writes the rows of an `arcsim-evaluator` sweep: per plan a tab of plots of the
//! delivery time against each swept limit, one line per setting of the other limits.
//!
//! Every entity is logged on two timelines: `time` (a duration timeline, seconds from the start
//! of delivery) and `angle_cdeg` (a sequence timeline holding the signed gantry angle in
//! hundredths of a degree; Rerun indexes only by integers, durations or timestamps, and a
//! duration would print angles as `1m 30s`). See [`paths`] for the entity paths.

#![warn(missing_docs)]

mod compare;
mod delivery;
mod error;
mod layout;
mod output;
mod spots;
mod sweep;

pub use compare::{save_comparison, AngleSeries, COMPARISON_APP_ID};
pub use delivery::log_delivery;
pub use error::ViewerError;
pub use layout::send_delivery_blueprint;
pub use output::{connect_delivery, save_delivery, spawn_delivery, DELIVERY_APP_ID};
pub use spots::{log_spots, MAX_SPOT_UPDATES_PER_LAYER};
pub use sweep::{
    save_sweep, COMBINATION, MAX_LINES, SWEEP_APP_ID, SWEEP_ROWS, SWEEP_SUMMARY, SWEEP_X,
};

/// The Rerun SDK this crate logs with (re-exported so callers need no direct dependency).
pub use rerun;

/// Timeline names.
pub mod timelines {
    /// Seconds from the start of delivery (duration timeline).
    pub const TIME: &str = "time";
    /// Signed gantry angle in hundredths of a degree (sequence timeline).
    pub const ANGLE_CDEG: &str = "angle_cdeg";
}

/// Entity paths of a logged delivery.
pub mod paths {
    /// `Scalars` [gantry angle] (deg, signed, CW positive).
    pub const ANGLE: &str = "angle";
    /// `Scalars` [speed, limits] (deg/s): +V when the gantry turns CW, −V when it turns CCW.
    pub const SPEED: &str = "speed";
    /// `Scalars` [acceleration, limits] (deg/s²): +A and −D for CW motion, −A and +D for CCW
    /// (named ±A when the deceleration limit D equals A).
    pub const ACCEL: &str = "accel";
    /// `Scalars` [jerk, +J, −J] (deg/s³).
    pub const JERK: &str = "jerk";
    /// `Scalars` [nominal energy] (MeV), one row per layer start (drawn as steps).
    pub const ENERGY: &str = "energy";
    /// `Scalars` [lost time] (s): each transition's time beyond its ELST, from its start to its
    /// end (drawn as steps), so the expensive stretches of the arc stand out.
    pub const LOST: &str = "lost_time";
    /// `StateChange`: "beam on", "energy switch" (within the ELST), "gantry" (beyond the ELST).
    pub const PHASE: &str = "phase";
    /// `TextLog`: one entry per layer, plus warnings for prescribed-speed violations.
    pub const LAYERS: &str = "layers";
    /// 2D: `Arrows2D` from the gantry head to the isocentre, red while the beam is on.
    pub const GANTRY_BEAM: &str = "gantry/beam";
    /// 2D (static): `Points2D`, one per layer at its angle, coloured by energy (viridis).
    pub const GANTRY_CONTROL_POINTS: &str = "gantry/control_points";
    /// 2D (static): `LineStrips2D`, the circle the gantry head runs on.
    pub const GANTRY_RING: &str = "gantry/ring";
    /// 2D (static): `Points2D` at the isocentre.
    pub const GANTRY_ISOCENTRE: &str = "gantry/isocentre";
    /// Root of the 2D beam's-eye view of the spots ([`crate::log_spots`]): positions in mm in
    /// the isocentre plane, y negated so that +y points up on screen.
    pub const BEAM_EYE_VIEW: &str = "beam_eye_view";
    /// 2D: `Points2D`, the spots of the layer being delivered (positions logged at the layer's
    /// start, colours as partial updates): grey until delivered, then viridis by MU delivered so
    /// far; empty between layers.
    pub const BEV_SPOTS: &str = "beam_eye_view/spots";
    /// 2D: `Points2D`, the spots being irradiated (the current batch), larger.
    pub const BEV_CURRENT: &str = "beam_eye_view/current";
    /// 2D: `Boxes2D`, the outline of the layer being delivered, labelled with the layer index,
    /// energy (when known), painting and progress.
    pub const BEV_LAYER: &str = "beam_eye_view/layer";
    /// 2D (static): `LineStrips2D`, x and y axes through the isocentre across all spots.
    pub const BEV_AXES: &str = "beam_eye_view/axes";
}

/// How a delivery is logged.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewerOptions {
    /// Interval between gantry-state samples (s). Piece boundaries of the timeline are logged
    /// too, so jerk steps stay sharp whatever the interval.
    pub sample_dt_s: f64,
}

impl Default for ViewerOptions {
    fn default() -> Self {
        ViewerOptions { sample_dt_s: 0.02 }
    }
}
