//! The per-spot timeline: when every spot of every layer is delivered and at which gantry angle.
//!
//! The beam model lays each layer's spots out after the layer's beam-on, carrying a synchrotron's
//! spill from layer to layer as resolution does ([`arcsim_plan::BeamSequence`]); the delivery says
//! when each layer's beam-on starts, and its timeline where the gantry is then.

use arcsim_plan::{ArcPlan, BeamSequence, Machine};
use serde::{Deserialize, Serialize};

use crate::{Delivery, InputError, SequenceError};

/// One delivery of one spot (one painting of it).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpotRow {
    /// Index of the layer in delivery order over the whole plan.
    pub layer_index: usize,
    /// The arc (index in the plan).
    pub arc: usize,
    /// The control point within the arc.
    pub control_point: usize,
    /// Index of the layer within its control point.
    pub layer: usize,
    /// Index of the spot in the layer's list (from 0).
    pub spot: usize,
    /// Painting (pass over the layer's spots) that delivers it, from 0.
    pub painting: usize,
    /// The burst that delivers it (the painting), on a machine with burst switching.
    #[serde(default)]
    pub burst: Option<usize>,
    /// The spill it is extracted from (from 0 over the whole plan), on a machine with spills.
    #[serde(default)]
    pub spill: Option<usize>,
    /// Spot position in the isocentre plane, mm (absent when the plan gives no positions).
    pub x_mm: Option<f64>,
    /// Spot position, mm (y).
    pub y_mm: Option<f64>,
    /// MU delivered by this painting of the spot.
    pub mu: f64,
    /// Irradiation start and end, s from the start of the delivery.
    pub t_start_s: f64,
    /// Irradiation end, s.
    pub t_end_s: f64,
    /// Gantry angle at the spot's start and end, degrees.
    pub angle_start_deg: f64,
    /// Gantry angle at the spot's end, degrees.
    pub angle_end_deg: f64,
}

/// Every spot delivery of `delivery`, in delivery order. `plan` and `machine` must be the ones
/// the delivery was simulated from (the layer rows index into the plan), and the delivery must
/// carry its timeline ([`crate::Options::build_timeline`]).
pub fn spot_timeline(
    plan: &ArcPlan,
    machine: &Machine,
    delivery: &Delivery,
) -> Result<Vec<SpotRow>, SequenceError> {
    let timeline = delivery
        .timeline
        .as_ref()
        .ok_or_else(|| SequenceError::from(InputError::NoTimeline))?;
    let mut rows = Vec::new();
    let bursts = machine
        .beam
        .burst_switching_time_s()
        .is_some_and(|s| s > 0.0);
    let mut sequence = BeamSequence::new(&machine.beam);
    for row in &delivery.layers {
        let layer = plan
            .arcs
            .get(row.arc)
            .and_then(|a| a.control_points.get(row.control_point))
            .and_then(|cp| cp.layers.get(row.layer))
            .ok_or_else(|| {
                SequenceError::from(InputError::LayerNotInPlan {
                    index: row.index,
                    arc: row.arc,
                    control_point: row.control_point,
                    layer: row.layer,
                    plan: plan.name.clone(),
                })
            })?;
        let angle = |t: f64| {
            timeline
                .state_at(t.clamp(row.t_start_s, row.t_end_s))
                .angle_deg
        };
        let mut visit = |e: &arcsim_plan::SpotEvent| {
            let (t0, t1) = (row.t_start_s + e.start_s, row.t_start_s + e.end_s);
            rows.push(SpotRow {
                layer_index: row.index,
                arc: row.arc,
                control_point: row.control_point,
                layer: row.layer,
                spot: e.spot,
                painting: e.painting,
                burst: bursts.then_some(e.painting),
                spill: e.spill,
                x_mm: e.position_mm.map(|p| p[0]),
                y_mm: e.position_mm.map(|p| p[1]),
                mu: e.mu,
                t_start_s: t0,
                t_end_s: t1,
                angle_start_deg: angle(t0),
                angle_end_deg: angle(t1),
            });
        };
        sequence
            .next_layer(row.arc, layer, &mut visit)
            .map_err(|reason| InputError::SpotsUntimed {
                index: row.index,
                arc: row.arc,
                control_point: row.control_point,
                layer: row.layer,
                machine: machine.name.clone(),
                reason,
            })?;
    }
    Ok(rows)
}
