//! Resolution: a plan plus a machine becomes the flat per-arc list of layers the sequencer consumes,
//! with every default filled in (window, ELST, irradiation time) and every number finite.

use crate::beam::SpotTimingError;
use crate::error::{At, PlanError, PlanIssue};
use crate::load::invalid_if_any;
use crate::machine::validate_machine;
use crate::model::{ArcPlan, Machine, ResolvedArc, ResolvedLayer};
use crate::spill::BeamSequence;
use crate::validate::validate_plan;
use crate::windows::layer_windows;

/// Validates plan and machine, then lists each arc's layers in delivery order with their window
/// centre and width, irradiation time and incoming switching time. Errors list every problem found.
///
/// Several layers at one control point split its window into sub-windows ([`layer_windows`]: equal,
/// or in proportion to the layers' `window_share`s), in delivery order along the rotation
/// direction, each layer centred in its own. The switch into the first layer of an arc after the
/// first comes from the last layer of the previous arc; a layer that continues the previous
/// layer's spill (a synchrotron's multi-energy extraction) switches in the spill model's
/// `in_spill_switching_time_s` instead of the ELST.
pub fn resolve(plan: &ArcPlan, machine: &Machine) -> Result<Vec<ResolvedArc>, PlanError> {
    let plan_source = format!("plan \"{}\"", plan.name);
    let mut issues = validate_plan(plan, &plan_source);
    issues.extend(validate_machine(
        machine,
        &format!("machine \"{}\"", machine.name),
    ));
    invalid_if_any(&plan_source, issues)?;

    let mut issues = Vec::new();
    let mut arcs = Vec::with_capacity(plan.arcs.len());
    let mut previous_energy: Option<f64> = None;
    let mut sequence = BeamSequence::new(&machine.beam);
    for (a, arc) in plan.arcs.iter().enumerate() {
        let sign = arc.direction.sign();
        let mut layers = Vec::new();
        for (c, cp) in arc.control_points.iter().enumerate() {
            let window = cp.window_deg.unwrap_or(machine.default_window_deg);
            if cp.window_deg.is_none() {
                check_default_window(&mut issues, &plan_source, arc, a, c, window);
            }
            let windows = layer_windows(cp, window);
            for ((l, layer), sub) in cp.layers.iter().enumerate().zip(&windows) {
                let at = At::layer(a, c, l);
                let offset = sub.offset_deg(window);
                let beam = match sequence.next_layer_time(a, layer) {
                    Ok(beam) => beam,
                    Err(SpotTimingError::NoPositions) => {
                        issues.push(PlanIssue::new(
                            &plan_source,
                            at,
                            "spots.positions_mm",
                            format!("machine \"{}\" has a `scanning` beam model, which times the spot-to-spot moves from the spot positions; expected `positions_mm` (one [x, y] in mm per spot), or `irradiation_time_s` for the layer", machine.name),
                        ));
                        continue;
                    }
                    Err(SpotTimingError::TooManyDeliveries { count }) => {
                        issues.push(PlanIssue::new(
                            &plan_source,
                            at,
                            "spots.mu",
                            format!("machine \"{}\" splits spots above its `max_mu_per_spot` into {count} spot deliveries in this layer; expected at most {}", machine.name, crate::beam::MAX_SPOT_DELIVERIES),
                        ));
                        continue;
                    }
                };
                let (same_spill, beam) = (beam.same_spill, beam.time);
                let irradiation_s = beam.total_s();
                if !irradiation_s.is_finite() || irradiation_s <= 0.0 {
                    issues.push(PlanIssue::new(
                        &plan_source,
                        at,
                        "spots",
                        format!("irradiation time under machine \"{}\" is {irradiation_s} s; expected a finite time > 0", machine.name),
                    ));
                }
                let switch_in_s = match (previous_energy, layer.switching_time_s) {
                    (None, _) => 0.0,
                    (Some(_), Some(t)) => t,
                    (Some(_), None) if same_spill => machine
                        .beam
                        .spill()
                        .map_or(0.0, |s| s.in_spill_switching_time_s),
                    (Some(e), None) => machine.elst.switch_time_s(e, layer.energy_mev),
                };
                previous_energy = Some(layer.energy_mev);
                layers.push(ResolvedLayer {
                    control_point: c,
                    layer: l,
                    angle_deg: cp.angle_deg + sign * offset,
                    window_deg: sub.width_deg,
                    energy_mev: layer.energy_mev,
                    irradiation_s,
                    spot_irradiation_s: beam.spot_irradiation_s,
                    scanning_s: beam.scanning_s,
                    burst_switching_s: beam.burst_switching_s,
                    spill_waiting_s: beam.spill_waiting_s,
                    required_speed_deg_per_s: cp.required_speed_deg_per_s,
                    switch_in_s,
                    mu: layer.spots.as_ref().map_or(0.0, crate::layer_mu),
                });
            }
        }
        arcs.push(ResolvedArc {
            arc_index: a,
            direction: arc.direction,
            layers,
        });
    }
    invalid_if_any(&plan_source, issues)?;
    Ok(arcs)
}

/// The machine's default window, like an explicit one, may not be wider than the spacing.
fn check_default_window(
    issues: &mut Vec<PlanIssue>,
    source: &str,
    arc: &crate::model::Arc,
    a: usize,
    c: usize,
    window: f64,
) {
    let angle = |i: usize| arc.control_points.get(i).map(|cp| cp.angle_deg);
    let this = arc.control_points[c].angle_deg;
    let neighbours = [c.checked_sub(1), Some(c + 1)];
    for n in neighbours.into_iter().flatten() {
        if let Some(other) = angle(n) {
            let spacing = (this - other).abs();
            if window > spacing + 1e-9 {
                issues.push(PlanIssue::new(
                    source,
                    At::cp(a, c),
                    "window_deg",
                    format!(
                        "no window given, and the machine's default window {} deg (machine field `default_window_deg`) is wider than the {} deg spacing to control point {n}; lower the machine's default_window_deg to at most {} deg, or give this control point a window_deg (JSON plans)",
                        crate::error::fmt_num(window),
                        crate::error::fmt_num(spacing),
                        crate::error::fmt_num(spacing)
                    ),
                ));
                return;
            }
        }
    }
}
