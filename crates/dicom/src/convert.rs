//! Conversion of the beams read from the file into arcs, control points and energy layers.
//!
//! Rules (also in the crate documentation and `docs/dicom-import.md`):
//! - Every control point whose ScanSpotMetersetWeights sum above 0 is one energy layer.
//! - Spot MU = weight x BeamMeterset / FinalCumulativeMetersetWeight: the spot's total over all
//!   paintings, rounded to [`MU_RESOLUTION`]. One native spot per DICOM spot, in the file's order.
//! - NumberOfPaintings N > 1 becomes `spots.paintings = N` (absent when 1); the spot list is not
//!   repeated: the beam model delivers MU / N per spot in each of the N passes.
//! - ScanSpotPositionMap (x, y pairs in mm) becomes `spots.positions_mm`, one `[x, y]` per spot in the
//!   file's order, rounded to [`POSITION_RESOLUTION_MM`]; absent for a layer whose control point has
//!   no map (the `per_mu` beam model does not need positions).
//! - Consecutive layers at the same gantry angle form one native control point; a new angle starts a new one.
//! - A DYNAMIC beam is one arc; it is split where its rotation reverses. Consecutive STATIC beams (by
//!   BeamNumber) form one arc while the angle keeps progressing in one direction; each is delivered
//!   at rest (its control points get `window_deg: 0`), the gantry moving only between beams.

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
                    let mut arc = ArcBuilder::new(angle, rotation).at_rest();
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

/// Spot positions are rounded to this step in mm (a nanometre), for the same reason as
/// [`MU_RESOLUTION`]: the file's single-precision values (12.3 is stored as 12.300000190734863)
/// would otherwise print with 17 digits.
pub const POSITION_RESOLUTION_MM: f64 = 1e-6;

/// `x` rounded to a multiple of `resolution` (whose inverse is a whole number). Dividing the integer
/// count of steps by the inverse (exact in f64) gives the f64 nearest to the decimal; adding 0 turns
/// -0 into 0.
fn round_to(x: f64, resolution: f64) -> f64 {
    let steps_per_unit = resolution.recip().round();
    (x * steps_per_unit).round() / steps_per_unit + 0.0
}

/// One native energy layer: each spot's total MU over all paintings, the paintings, the positions.
fn native_layer(layer: &IonLayer, mu_per_weight: f64) -> EnergyLayer {
    let mu: Vec<f64> = layer
        .weights
        .iter()
        .map(|w| round_to(w * mu_per_weight, MU_RESOLUTION))
        .collect();
    let positions_mm = layer.positions_mm.as_ref().map(|positions| {
        positions
            .iter()
            .map(|p| p.map(|c| round_to(c, POSITION_RESOLUTION_MM)))
            .collect()
    });
    EnergyLayer {
        energy_mev: layer.energy_mev,
        spots: Some(Spots {
            // The reader bounds the spots of a layer by arcsim_plan::MAX_SPOTS_PER_LAYER.
            count: u32::try_from(mu.len()).unwrap_or(u32::MAX),
            mu: Some(mu),
            total_mu: None,
            positions_mm,
            paintings: (layer.paintings > 1).then_some(layer.paintings),
        }),
        irradiation_time_s: None,
        switching_time_s: None,
        window_share: None,
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
pub(crate) fn shortest_delta(from: f64, to: f64) -> f64 {
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
    /// STATIC beams: each control point is delivered with the gantry at rest (window 0).
    at_rest: bool,
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
            at_rest: false,
            control_points: Vec::new(),
        }
    }

    /// The builder of STATIC beams: their layers are delivered at rest at the beam's angle.
    fn at_rest(mut self) -> Self {
        self.at_rest = true;
        self
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
                window_deg: self.at_rest.then_some(0.0),
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
