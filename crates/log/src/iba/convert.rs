//! An IBA-style log as the logs arcsim's analyses take: beam-on intervals for `compare` and
//! `calibrate`, spot deliveries for `calibrate-spots`.

use arcsim_plan::ArcPlan;

use super::{IbaLog, SAMPLE_PERIOD_S};
use crate::{BeamInterval, DeliveryLog, LogError, LoggedSpot, SpotLog};

impl IbaLog {
    /// Each layer's beam on, from its first spot's start to its last spot's end (edges known to
    /// [`IbaBeam::edge_resolution_s`](super::IbaBeam::edge_resolution_s)), the gantry at its arc irradiation's start and end (`Actual=`)
    /// or, without an events file, the beam file's gantry angle; MU from the charge where
    /// `beam_config` gives the charge per MU. The log has no energies (IBA's records hold a range
    /// instead): layers are matched to the plan's in order and by time, as for any log without
    /// energies.
    pub fn to_delivery_log(&self) -> Result<DeliveryLog, LogError> {
        let mut intervals = Vec::new();
        for beam in &self.beams {
            for (k, layer) in beam.layers.iter().enumerate() {
                let (first, last) = (&layer.spots[0], &layer.spots[layer.spots.len() - 1]);
                let (on, off) = match (beam.arcs.get(k), beam.gantry_angle_deg) {
                    (Some(a), _) => (a.actual_start_deg, a.actual_end_deg),
                    (None, Some(g)) => (g, g),
                    (None, None) => {
                        return Err(LogError::file(
                            &beam.folder,
                            "no gantry angle: no events file (arc irradiations) and no <GantryAngle> in a beam file",
                        ))
                    }
                };
                let charge: f64 = layer.spots.iter().map(|s| s.charge_c).sum();
                intervals.push(BeamInterval {
                    start_s: first.t_start_s,
                    end_s: last.t_end_s,
                    angle_start_deg: on,
                    angle_end_deg: off,
                    energy_mev: 0.0,
                    mu: beam.mu_per_coulomb.map_or(0.0, |f| f * charge),
                });
            }
        }
        intervals.sort_by(|a, b| a.start_s.total_cmp(&b.start_s));
        let step = self
            .beams
            .iter()
            .map(|b| b.edge_resolution_s)
            .fold(SAMPLE_PERIOD_S, f64::max);
        let mut log =
            DeliveryLog::from_intervals(&self.source, &intervals, step).ok_or_else(|| {
                LogError::file(
                    &self.source,
                    "no layer with a spot; expected a delivered beam",
                )
            })?;
        for s in &mut log.samples {
            s.energy_mev = None;
        }
        log.has_energy = false;
        if self.beams.iter().any(|b| b.mu_per_coulomb.is_none()) {
            for s in &mut log.samples {
                s.mu = None;
            }
            log.has_mu = false;
        }
        Ok(log)
    }

    /// Every spot delivery, in order, as a per-spot log of `plan`: the beam folders are the
    /// plan's arcs in order and each beam's layers its arc's layers in order (the log has no
    /// energies to match them by). A spot's MU is its charge times the MU per coulomb, or, where
    /// `beam_config` gives no charge per MU, its share of its layer's charge times the plan's
    /// layer MU. The pass over the layer each spot belongs to is found by [`passes`].
    pub fn to_spot_log(&self, plan: &ArcPlan) -> Result<SpotLog, LogError> {
        if self.beams.len() != plan.arcs.len() {
            return Err(LogError::file(
                &self.source,
                format!("{} beam folder(s) for a plan of {} arc(s); expected one per arc, in the plan's order", self.beams.len(), plan.arcs.len()),
            ));
        }
        let mut spots = Vec::new();
        for (a, (beam, arc)) in self.beams.iter().zip(&plan.arcs).enumerate() {
            let planned: Vec<(usize, usize, &arcsim_plan::EnergyLayer)> = arc
                .control_points
                .iter()
                .enumerate()
                .flat_map(|(c, cp)| {
                    cp.layers
                        .iter()
                        .enumerate()
                        .map(move |(l, layer)| (c, l, layer))
                })
                .collect();
            if planned.len() != beam.layers.len() {
                return Err(LogError::file(
                    &beam.folder,
                    format!(
                        "{} layers with spots; the plan's arc {a} has {}",
                        beam.layers.len(),
                        planned.len()
                    ),
                ));
            }
            if !beam.positions_at_isocentre {
                return Err(LogError::file(
                    &beam.folder,
                    "beam_config gives no SAD parameter and distanceFromIcToIsocenter: the spots' positions cannot be taken to the isocentre plane",
                ));
            }
            for (layer, (cp, l, energy_layer)) in beam.layers.iter().zip(planned) {
                let count = energy_layer.spots.as_ref().map_or(0, |s| s.count as usize);
                let per_coulomb = match beam.mu_per_coulomb {
                    Some(f) => f,
                    None => {
                        let planned_mu = energy_layer.spots.as_ref().and_then(|s| {
                            s.mu.as_ref().map(|m| m.iter().sum::<f64>()).or(s.total_mu)
                        });
                        let charge: f64 = layer.spots.iter().map(|s| s.charge_c).sum();
                        match planned_mu {
                            Some(mu) if charge > 0.0 => mu / charge,
                            _ => {
                                return Err(LogError::file(
                                    &beam.folder,
                                    format!("layer {}: no charge per MU in beam_config and no MU in the plan's layer; expected one of them", layer.number),
                                ))
                            }
                        }
                    }
                };
                let passes = passes(&layer.spots, energy_layer, count);
                for (s, painting) in layer.spots.iter().zip(passes) {
                    spots.push(LoggedSpot {
                        arc: a,
                        control_point: cp,
                        layer: l,
                        painting,
                        x_mm: s.x_mm,
                        y_mm: s.y_mm,
                        mu: s.charge_c * per_coulomb,
                        t_start_s: s.t_start_s,
                        t_end_s: s.t_end_s,
                        line: s.line,
                    });
                }
            }
        }
        spots.sort_by(|x, y| x.t_start_s.total_cmp(&y.t_start_s));
        Ok(SpotLog {
            time_step_s: Some(
                self.beams
                    .iter()
                    .map(|b| b.time_step_s)
                    .fold(SAMPLE_PERIOD_S, f64::max),
            ),
            source: self.source.clone(),
            spots,
        })
    }
}

/// The pass over the layer's spots each logged spot belongs to: where the plan gives spot
/// positions, each logged spot is the planned spot nearest to it, and a new pass starts where
/// one is not after the spot before it in the plan's order (a beam in bursts revisits only the
/// spots with MU left, so passes differ in length); without positions, the spot's place in the
/// layer divided by the plan's spot count.
fn passes(logged: &[super::IbaSpot], layer: &arcsim_plan::EnergyLayer, count: usize) -> Vec<usize> {
    let planned = layer.spots.as_ref().and_then(|s| s.positions_mm.as_ref());
    let Some(planned) = planned.filter(|p| !p.is_empty()) else {
        return (0..logged.len())
            .map(|k| k.checked_div(count).unwrap_or(0))
            .collect();
    };
    let nearest = |s: &super::IbaSpot| {
        planned
            .iter()
            .enumerate()
            .map(|(i, p)| (i, (p[0] - s.x_mm).powi(2) + (p[1] - s.y_mm).powi(2)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map_or(0, |(i, _)| i)
    };
    let mut pass = 0;
    let mut last = None;
    logged
        .iter()
        .map(|s| {
            let i = nearest(s);
            if last.is_some_and(|j| i <= j) {
                pass += 1;
            }
            last = Some(i);
            pass
        })
        .collect()
}
