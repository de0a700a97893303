//! Conversion of the beams read from the file into arcs, control points and energy layers.
//!
//! Rules (also in the crate documentation and `docs/dicom-import.md`):
//! - Every control point whose ScanSpotMetersetWeights sum above 0 is one energy layer.
//! - Spot MU = weight x BeamMeterset / FinalCumulativeMetersetWeight; with N paintings the spot list is
//!   repeated N times and every spot delivers MU / N each time (count x N spots, same total MU).
//! - Consecutive layers at the same gantry angle form one native control point; a new angle starts a new one.
//! - A DYNAMIC beam is one arc; it is split where its rotation reverses. Consecutive STATIC beams (by
//!   BeamNumber) form one arc while the angle keeps progressing in one direction.

use arcsim_plan::{Arc, ArcPlan, ControlPoint, EnergyLayer, RotationDirection, Spots, PLAN_FORMAT};

use crate::read::{BeamKind, IonBeam, IonLayer, IonPlan, Rotation};

/// Angles closer than this (degrees) are the same gantry angle.
pub const SAME_ANGLE_TOLERANCE_DEG: f64 = 1e-6;

/// Builds the native plan. `fallback_name` names it when the file has neither RTPlanLabel nor RTPlanName.
pub(crate) fn to_arc_plan(plan: &IonPlan, fallback_name: &str) -> ArcPlan {
    let mut arcs = Vec::new();
    let mut statics: Option<ArcBuilder> = None;
    for beam in &plan.beams {
        match beam.kind {
            BeamKind::Static => {
                for (angle, rotation, layer) in beam_layers(beam) {
                    if let Some(arc) = statics.as_mut() {
                        let delta = shortest_delta(arc.angle, angle);
                        if arc.accepts(delta) {
                            arc.push(delta, angle, layer);
                            continue;
                        }
                    }
                    arcs.extend(statics.take().map(ArcBuilder::finish));
                    let mut arc = ArcBuilder::new(angle, rotation);
                    arc.push(0.0, angle, layer);
                    statics = Some(arc);
                }
            }
            BeamKind::Dynamic => {
                arcs.extend(statics.take().map(ArcBuilder::finish));
                arcs.extend(dynamic_arcs(beam));
            }
        }
    }
    arcs.extend(statics.take().map(ArcBuilder::finish));

    let name = plan
        .label
        .clone()
        .or_else(|| plan.plan_name.clone())
        .unwrap_or_else(|| fallback_name.to_string());
    ArcPlan {
        format: PLAN_FORMAT.to_string(),
        name,
        description: Some(describe(plan, arcs.len())),
        arcs,
    }
}

/// Provenance for the plan description: where it came from, which beams made it.
fn describe(plan: &IonPlan, n_arcs: usize) -> String {
    let mut text = String::from("Imported from DICOM RT Ion Plan");
    if let Some(label) = &plan.label {
        text.push_str(&format!(" \"{label}\""));
    }
    if let Some(uid) = &plan.sop_instance_uid {
        text.push_str(&format!(" (SOPInstanceUID {uid})"));
    }
    let beams: Vec<String> = plan
        .beams
        .iter()
        .map(|b| {
            let kind = match b.kind {
                BeamKind::Static => "static",
                BeamKind::Dynamic => "dynamic",
            };
            match &b.name {
                Some(name) => format!("{} \"{name}\" ({kind})", b.number),
                None => format!("{} ({kind})", b.number),
            }
        })
        .collect();
    text.push_str(&format!(": beams {} -> {n_arcs} arc(s)", beams.join(", ")));
    if !plan.skipped.is_empty() {
        text.push_str(&format!("; left out {}", plan.skipped.join(", ")));
    }
    text
}

/// The arcs of one DYNAMIC beam: one arc, split where the rotation reverses.
fn dynamic_arcs(beam: &IonBeam) -> Vec<Arc> {
    let mut arcs = Vec::new();
    let mut current: Option<ArcBuilder> = None;
    // Rotation accumulated since the last layer, following the declared direction of each step.
    let mut pending = 0.0;
    let mut previous: Option<(f64, Rotation)> = None;
    for cp in &beam.control_points {
        if let Some((angle, rotation)) = previous {
            pending += step_delta(angle, cp.angle_deg, rotation);
        }
        previous = Some((cp.angle_deg, cp.rotation));
        let Some(layer) = &cp.layer else { continue };
        let layer = native_layer(layer, beam.mu_per_weight);
        match current.as_mut() {
            Some(arc) if arc.accepts(pending) => arc.push(pending, cp.angle_deg, layer),
            _ => {
                arcs.extend(current.take().map(ArcBuilder::finish));
                let mut arc = ArcBuilder::new(cp.angle_deg, cp.rotation);
                arc.push(0.0, cp.angle_deg, layer);
                current = Some(arc);
            }
        }
        pending = 0.0;
    }
    arcs.extend(current.map(ArcBuilder::finish));
    arcs
}

/// The layers of a beam with their gantry angle and declared rotation, in control-point order.
fn beam_layers(beam: &IonBeam) -> impl Iterator<Item = (f64, Rotation, EnergyLayer)> + '_ {
    beam.control_points.iter().filter_map(|cp| {
        let layer = cp.layer.as_ref()?;
        Some((
            cp.angle_deg,
            cp.rotation,
            native_layer(layer, beam.mu_per_weight),
        ))
    })
}

/// Spot MU are rounded to this step (far below any machine's resolution) so that they print with few
/// digits and read back exactly, also with serde_json's default (not round-trip exact) float parser.
pub const MU_RESOLUTION: f64 = 1e-9;

/// One native energy layer: per-spot MU, the spot list repeated once per painting.
fn native_layer(layer: &IonLayer, mu_per_weight: f64) -> EnergyLayer {
    let paintings = layer.paintings.max(1);
    let per_painting = mu_per_weight / f64::from(paintings);
    // Dividing the integer count of steps by 1e9 (exact in f64) gives the f64 nearest to the decimal.
    let steps_per_mu = MU_RESOLUTION.recip().round();
    let once: Vec<f64> = layer
        .weights
        .iter()
        .map(|w| (w * per_painting * steps_per_mu).round() / steps_per_mu)
        .collect();
    let mu: Vec<f64> = (0..paintings).flat_map(|_| once.iter().copied()).collect();
    EnergyLayer {
        energy_mev: layer.energy_mev,
        // The reader bounds spots x paintings by MAX_SPOTS, far below u32::MAX.
        spots: Some(Spots {
            count: u32::try_from(mu.len()).unwrap_or(u32::MAX),
            mu: Some(mu),
            total_mu: None,
        }),
        irradiation_time_s: None,
        switching_time_s: None,
    }
}

/// Rotation in degrees from `from` to `to` the way the control point's direction says (CW: angle
/// increases); NONE or a standstill takes the shortest way.
fn step_delta(from: f64, to: f64, rotation: Rotation) -> f64 {
    let shortest = shortest_delta(from, to);
    if shortest.abs() <= SAME_ANGLE_TOLERANCE_DEG {
        return 0.0;
    }
    match rotation {
        Rotation::Cw => (to - from).rem_euclid(360.0),
        Rotation::Cc => -(from - to).rem_euclid(360.0),
        Rotation::None => shortest,
    }
}

/// Signed shortest rotation from `from` to `to`, in (-180, 180] degrees.
fn shortest_delta(from: f64, to: f64) -> f64 {
    let d = (to - from).rem_euclid(360.0);
    if d > 180.0 {
        d - 360.0
    } else {
        d
    }
}

/// Collects the control points of one arc at unwrapped angles.
struct ArcBuilder {
    /// Set by the first move; every later move must go the same way.
    direction: Option<RotationDirection>,
    /// Declared direction, used when the arc never moves (a single angle).
    declared: Option<RotationDirection>,
    /// Current unwrapped gantry angle.
    angle: f64,
    control_points: Vec<ControlPoint>,
}

impl ArcBuilder {
    fn new(angle: f64, rotation: Rotation) -> Self {
        let declared = match rotation {
            Rotation::Cw => Some(RotationDirection::Cw),
            Rotation::Cc => Some(RotationDirection::Cc),
            Rotation::None => None,
        };
        ArcBuilder {
            direction: None,
            declared,
            angle: angle.rem_euclid(360.0),
            control_points: Vec::new(),
        }
    }

    /// Whether a move of `delta` degrees continues this arc (a standstill always does).
    fn accepts(&self, delta: f64) -> bool {
        delta.abs() <= SAME_ANGLE_TOLERANCE_DEG
            || self.direction.is_none_or(|d| d == direction_of(delta))
    }

    /// Moves by `delta` degrees to the file's angle `raw_angle` (unwrapped: the turn of `raw_angle` nearest
    /// to the current angle + `delta`, so no rounding error accumulates), then adds `layer` there: to the
    /// last control point when the gantry did not move, else to a new control point.
    fn push(&mut self, delta: f64, raw_angle: f64, layer: EnergyLayer) {
        let moved = delta.abs() > SAME_ANGLE_TOLERANCE_DEG;
        if moved {
            let target = self.angle + delta;
            self.angle = raw_angle + 360.0 * ((target - raw_angle) / 360.0).round();
            self.direction = Some(direction_of(delta));
        }
        match self.control_points.last_mut() {
            Some(cp) if !moved => cp.layers.push(layer),
            _ => self.control_points.push(ControlPoint {
                angle_deg: self.angle,
                required_speed_deg_per_s: None,
                window_deg: None,
                layers: vec![layer],
            }),
        }
    }

    /// The finished arc; angles shifted by 360 degrees when a CC arc went below 0.
    fn finish(mut self) -> Arc {
        let lowest = self
            .control_points
            .iter()
            .map(|cp| cp.angle_deg)
            .fold(f64::INFINITY, f64::min);
        if lowest < 0.0 {
            let shift = 360.0 * (-lowest / 360.0).ceil();
            for cp in &mut self.control_points {
                cp.angle_deg += shift;
            }
        }
        Arc {
            direction: self
                .direction
                .or(self.declared)
                .unwrap_or(RotationDirection::Cw),
            control_points: self.control_points,
        }
    }
}

fn direction_of(delta: f64) -> RotationDirection {
    if delta > 0.0 {
        RotationDirection::Cw
    } else {
        RotationDirection::Cc
    }
}
