//! The delivered gantry motion as one list of constant-jerk pieces in absolute time and angle.

use serde::{Deserialize, Serialize};

/// What the gantry is doing during a piece.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum PieceKind {
    /// Irradiating layer `layer` (delivery order); at constant speed unless the motion is free.
    Beam {
        /// The layer (delivery order).
        layer: usize,
    },
    /// Beam off, moving (or waiting) between layers: transition `transition`.
    Move {
        /// The transition (delivery order).
        transition: usize,
    },
    /// Beam off, running up from rest before arc `arc`'s first beam (free arc ends).
    RunUp {
        /// The arc (index in the plan).
        arc: usize,
    },
}

/// One constant-jerk piece. Angles and speeds are signed gantry values (CW positive).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Piece {
    /// Start (s).
    pub t_start_s: f64,
    /// Duration (s).
    pub duration_s: f64,
    /// Angle at its start (deg).
    pub angle_deg: f64,
    /// Speed at its start (deg/s).
    pub speed_deg_per_s: f64,
    /// Acceleration at its start (deg/s²).
    pub accel_deg_per_s2: f64,
    /// Jerk throughout (deg/s³).
    pub jerk_deg_per_s3: f64,
    /// What the gantry does.
    pub kind: PieceKind,
}

/// Gantry state at one instant (signed, CW positive).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GantryState {
    /// Angle (deg).
    pub angle_deg: f64,
    /// Speed (deg/s).
    pub speed_deg_per_s: f64,
    /// Acceleration (deg/s²).
    pub accel_deg_per_s2: f64,
    /// Jerk (deg/s³).
    pub jerk_deg_per_s3: f64,
}

/// The whole delivery's motion.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timeline {
    /// The pieces, end to end from t = 0.
    pub pieces: Vec<Piece>,
}

impl Piece {
    /// State `dt` seconds into the piece.
    pub fn state_after(&self, dt: f64) -> GantryState {
        let (v, a, j) = (
            self.speed_deg_per_s,
            self.accel_deg_per_s2,
            self.jerk_deg_per_s3,
        );
        GantryState {
            angle_deg: self.angle_deg + dt * (v + dt * (a / 2.0 + dt * j / 6.0)),
            speed_deg_per_s: v + dt * (a + dt * j / 2.0),
            accel_deg_per_s2: a + dt * j,
            jerk_deg_per_s3: j,
        }
    }
}

impl Timeline {
    /// Total duration (s).
    pub fn duration_s(&self) -> f64 {
        self.pieces
            .last()
            .map_or(0.0, |p| p.t_start_s + p.duration_s)
    }

    /// Index of the piece active at `t` (the last one at or after the end).
    pub fn piece_at(&self, t: f64) -> Option<usize> {
        if self.pieces.is_empty() {
            return None;
        }
        let i = self.pieces.partition_point(|p| p.t_start_s <= t);
        Some(i.saturating_sub(1))
    }

    /// State at time `t` (clamped to the timeline).
    pub fn state_at(&self, t: f64) -> GantryState {
        match self.piece_at(t) {
            None => GantryState::default(),
            Some(i) => {
                let p = &self.pieces[i];
                let s = p.state_after((t - p.t_start_s).clamp(0.0, p.duration_s));
                // At rest in the CC direction the signed speed (and acceleration, jerk) is -0.
                GantryState {
                    angle_deg: arcsim_plan::unsigned_zero(s.angle_deg),
                    speed_deg_per_s: arcsim_plan::unsigned_zero(s.speed_deg_per_s),
                    accel_deg_per_s2: arcsim_plan::unsigned_zero(s.accel_deg_per_s2),
                    jerk_deg_per_s3: arcsim_plan::unsigned_zero(s.jerk_deg_per_s3),
                }
            }
        }
    }

    /// The layer being irradiated at `t`, if the beam is on.
    pub fn beam_layer_at(&self, t: f64) -> Option<usize> {
        self.piece_at(t).and_then(|i| match self.pieces[i].kind {
            PieceKind::Beam { layer } => Some(layer),
            PieceKind::Move { .. } | PieceKind::RunUp { .. } => None,
        })
    }

    /// Samples every `dt` seconds, always including the end.
    pub fn samples(&self, dt: f64) -> Vec<(f64, GantryState)> {
        let total = self.duration_s();
        if !(dt.is_finite() && dt > 0.0) {
            return Vec::new();
        }
        let n = (total / dt).floor() as usize;
        let mut out: Vec<(f64, GantryState)> = (0..=n)
            .map(|i| i as f64 * dt)
            .map(|t| (t, self.state_at(t)))
            .collect();
        if out.last().is_none_or(|(t, _)| *t < total) {
            out.push((total, self.state_at(total)));
        }
        out
    }
}
