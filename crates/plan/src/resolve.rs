//! Resolution: a plan plus a machine becomes the flat per-arc list of layers the sequencer consumes,
//! with every default filled in (window, ELST, irradiation time) and every number finite.

use crate::error::{At, PlanError, PlanIssue};
use crate::load::invalid_if_any;
use crate::machine::validate_machine;
use crate::model::{ArcPlan, BeamModel, EnergyLayer, Machine, ResolvedArc, ResolvedLayer, Spots};
use crate::validate::validate_plan;

/// Beam-on time of a layer with spots: `sum_i max(mu_i * s_per_mu, min_spot_time_s) + (count - 1) *
/// spot_switch_time_s`. With `total_mu` the spots share it equally.
pub fn spots_irradiation_time_s(spots: &Spots, beam: &BeamModel) -> f64 {
    let n = f64::from(spots.count);
    let spot_time = |mu: f64| (mu * beam.s_per_mu).max(beam.min_spot_time_s);
    let beam_on = match (&spots.mu, spots.total_mu) {
        (Some(mu), _) => mu.iter().map(|&m| spot_time(m)).sum(),
        (None, Some(total)) if spots.count > 0 => n * spot_time(total / n),
        _ => 0.0,
    };
    beam_on + (n - 1.0).max(0.0) * beam.spot_switch_time_s
}

/// Beam-on time of a layer under `beam`: the explicit time, else the spots' time.
pub fn layer_irradiation_time_s(layer: &EnergyLayer, beam: &BeamModel) -> f64 {
    match (layer.irradiation_time_s, &layer.spots) {
        (Some(t), _) => t,
        (None, Some(spots)) => spots_irradiation_time_s(spots, beam),
        (None, None) => 0.0,
    }
}

/// Validates plan and machine, then lists each arc's layers in delivery order with their window
/// centre and width, irradiation time and incoming switching time. Errors list every problem found.
///
/// Several layers at one control point split its window into equal sub-windows, in delivery order
/// along the rotation direction, each layer centred in its own. The switch into the first layer of
/// an arc after the first comes from the last layer of the previous arc.
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
    for (a, arc) in plan.arcs.iter().enumerate() {
        let sign = arc.direction.sign();
        let mut layers = Vec::new();
        for (c, cp) in arc.control_points.iter().enumerate() {
            let window = cp.window_deg.unwrap_or(machine.default_window_deg);
            if cp.window_deg.is_none() {
                check_default_window(&mut issues, &plan_source, arc, a, c, window);
            }
            let sub_window = window / cp.layers.len() as f64;
            for (l, layer) in cp.layers.iter().enumerate() {
                let at = At::layer(a, c, l);
                let offset = -window / 2.0 + sub_window * (l as f64 + 0.5);
                let irradiation_s = layer_irradiation_time_s(layer, &machine.beam);
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
                    (Some(e), None) => machine.elst.switch_time_s(e, layer.energy_mev),
                };
                previous_energy = Some(layer.energy_mev);
                layers.push(ResolvedLayer {
                    control_point: c,
                    layer: l,
                    angle_deg: cp.angle_deg + sign * offset,
                    window_deg: sub_window,
                    energy_mev: layer.energy_mev,
                    irradiation_s,
                    required_speed_deg_per_s: cp.required_speed_deg_per_s,
                    switch_in_s,
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
