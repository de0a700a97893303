//! A delivery log set beside the simulation of its plan: totals, breakdowns, per-class
//! differences, the worst layers, which motion model fits, and the gantry's observed limits.
//!
//! The log's clock is moved so that its first beam-on is the simulation's. The log's own
//! breakdown splits each beam-off gap between layers into energy switching (up to the
//! simulation's ELST for that switch) and gantry time (the rest), and counts the beam-off time
//! inside a layer (interruptions) apart.

use arcsim_plan::ResolvedArc;
use arcsim_sequencer::{Delivery, Limiter, LimitsOut};
use serde::Serialize;

use crate::kinematics::{observe, trace, ObservedKinematics};
use crate::matching::{match_layers, LoggedLayer, MatchError};
use crate::DeliveryLog;

/// How many of the worst layers a comparison lists.
pub const WORST_LAYERS: usize = 5;

/// Where a delivery's time goes, logged or simulated.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TimeSplit {
    /// From the first beam-on to the last beam-off, s.
    pub total_s: f64,
    /// Beam on, s.
    pub beam_on_s: f64,
    /// Energy switching, s (logged: each gap up to the simulation's ELST of that switch).
    pub energy_switching_s: f64,
    /// What the gantry added beyond the switches, s.
    pub gantry_s: f64,
    /// Beam off inside layers (interruptions), s (0 in a simulation).
    pub interruptions_s: f64,
}

/// Statistics of the logged-minus-simulated differences of one class, s.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ClassStats {
    /// The class: `upward switch`, `downward switch`, `same energy`, `arc change`,
    /// `gantry-limited transition` (the simulation's transitions not set by their ELST), or
    /// `beam-on per layer`.
    pub class: String,
    /// How many.
    pub count: usize,
    /// Mean difference, s.
    pub mean_s: f64,
    /// Standard deviation, s.
    pub sd_s: f64,
    /// Smallest difference, s.
    pub min_s: f64,
    /// Largest difference, s.
    pub max_s: f64,
}

/// One layer, logged and simulated (times on the simulation's clock).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LayerComparison {
    /// Index in delivery order.
    pub index: usize,
    /// The arc.
    pub arc: usize,
    /// The control point within the arc.
    pub control_point: usize,
    /// The layer within the control point.
    pub layer: usize,
    /// The layer's energy, MeV.
    pub energy_mev: f64,
    /// The plan's angle (window centre), degrees.
    pub angle_deg: f64,
    /// Logged beam-on, s.
    pub logged_start_s: f64,
    /// Logged beam-off, s.
    pub logged_end_s: f64,
    /// Simulated beam-on, s.
    pub simulated_start_s: f64,
    /// Simulated beam-off, s.
    pub simulated_end_s: f64,
    /// Logged gantry angle at beam-on, degrees.
    pub logged_angle_start_deg: f64,
    /// Logged gantry angle at beam-off, degrees.
    pub logged_angle_end_deg: f64,
    /// Simulated gantry angle at beam-on, degrees (the layer's angle without a timeline).
    pub simulated_angle_start_deg: f64,
    /// Simulated gantry angle at beam-off, degrees.
    pub simulated_angle_end_deg: f64,
    /// Logged beam-on time (its segments and the machine's pauses between them), s.
    pub logged_beam_on_s: f64,
    /// Simulated beam-on time, s.
    pub simulated_beam_on_s: f64,
    /// Logged beam-off gap before it, s (0 for the first layer).
    pub logged_transition_in_s: f64,
    /// Simulated transition into it, s.
    pub simulated_transition_in_s: f64,
    /// How many beam-on segments the log has for it (1: no pause, no interruption).
    pub segments: usize,
    /// Of the gaps between them, the interruptions (the rest are the machine's pauses).
    pub interruptions: usize,
    /// Logged minus simulated (transition in + beam on), s: what this layer adds to the
    /// difference of the totals.
    pub difference_s: f64,
}

/// How well one motion model's simulation fits the log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MotionFit {
    /// `free` or `constant`.
    pub motion: String,
    /// Its total, s.
    pub total_s: f64,
    /// Root mean square of logged minus simulated beam-on times over the layers, s.
    pub rms_start_s: f64,
}

/// A log compared with a simulation of its plan.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Comparison {
    /// The log.
    pub log: String,
    /// The motion model of the main simulation.
    pub motion: String,
    /// Added to the log's times to put its first beam-on on the simulation's, s.
    pub log_shift_s: f64,
    /// Logged minus simulated total, s.
    pub difference_s: f64,
    /// The same in % of the simulated total.
    pub difference_pct: f64,
    /// The log's time split.
    pub logged: TimeSplit,
    /// The simulation's time split.
    pub simulated: TimeSplit,
    /// Layers with an interruption (a beam-off gap inside the layer that is not one of the
    /// machine's own pauses).
    pub interrupted_layers: usize,
    /// Beam interruptions in all ([`crate::LoggedLayer::interruptions`]).
    pub interruptions: usize,
    /// Gaps inside layers that are the machine's own pauses (burst switching, spill waits;
    /// [`crate::LoggedLayer::pauses`]): beam-on time, as in the simulation.
    pub machine_pauses: usize,
    /// Beam edges put at a sample across a sampling gap instead of halfway
    /// ([`crate::LoggedLayer::uncertain_edges`]): those layers' beam-on times are lower bounds.
    pub uncertain_edges: usize,
    /// Angle samples the reader rejected as encoder glitches and replaced
    /// ([`DeliveryLog::glitches_rejected`]).
    pub glitches_rejected: usize,
    /// A log of beam-on intervals (a DICOM treatment record): the resolution of its times, s
    /// ([`DeliveryLog::edge_resolution_s`]); it has no angle trace to observe.
    pub edge_resolution_s: Option<f64>,
    /// Differences by class.
    pub classes: Vec<ClassStats>,
    /// The layers with the largest |difference_s|, largest first.
    pub worst: Vec<LayerComparison>,
    /// Each motion model simulated, the main one first.
    pub motion_fits: Vec<MotionFit>,
    /// The model with the smaller `rms_start_s`.
    pub better_motion: String,
    /// The gantry's speed, acceleration and jerk seen in the log.
    pub observed: ObservedKinematics,
    /// The machine's limits.
    pub limits: LimitsOut,
    /// Every layer.
    pub layers: Vec<LayerComparison>,
}

/// Compares `log` with `simulated` (a delivery of `arcs`); `others` are the same plan simulated
/// with other motion models (to say which fits). Errors: a log that does not fit the plan.
pub fn compare(
    arcs: &[ResolvedArc],
    simulated: &Delivery,
    others: &[&Delivery],
    log: &DeliveryLog,
) -> Result<Comparison, MatchError> {
    let logged = match_layers(log, arcs)?;
    let shift = simulated.layers.first().map_or(0.0, |l| l.t_start_s) - logged[0].start_s;
    let layers = layer_rows(simulated, &logged, shift);
    let logged_split = logged_split(simulated, &layers);
    let simulated_split = TimeSplit {
        total_s: simulated.total_s,
        beam_on_s: simulated.breakdown.beam_on_s,
        energy_switching_s: simulated.breakdown.energy_switching_s,
        gantry_s: simulated.breakdown.lost_s,
        interruptions_s: 0.0,
    };
    let difference_s = logged_split.total_s - simulated.total_s;
    let mut worst = layers.clone();
    worst.sort_by(|a, b| b.difference_s.abs().total_cmp(&a.difference_s.abs()));
    worst.truncate(WORST_LAYERS);
    let mut motion_fits = vec![motion_fit(simulated, &layers)];
    for other in others {
        motion_fits.push(motion_fit(other, &layer_rows(other, &logged, shift)));
    }
    let better_motion = motion_fits
        .iter()
        .min_by(|a, b| a.rms_start_s.total_cmp(&b.rms_start_s))
        .map(|m| m.motion.clone())
        .unwrap_or_default();
    let interrupted_layers = logged.iter().filter(|l| l.interruptions > 0).count();
    Ok(Comparison {
        log: log.source.clone(),
        motion: simulated.motion.name().to_string(),
        log_shift_s: shift,
        difference_s,
        difference_pct: 100.0 * difference_s / simulated.total_s.max(f64::MIN_POSITIVE),
        logged: logged_split,
        simulated: simulated_split,
        interrupted_layers,
        interruptions: logged.iter().map(|l| l.interruptions).sum(),
        machine_pauses: logged.iter().map(LoggedLayer::pauses).sum(),
        uncertain_edges: logged.iter().map(|l| l.uncertain_edges).sum(),
        glitches_rejected: log.glitches_rejected,
        edge_resolution_s: log.edge_resolution_s,
        classes: classes(simulated, arcs, &layers),
        worst,
        motion_fits,
        better_motion,
        observed: observe(&[trace(log)]),
        limits: simulated.limits,
        layers,
    })
}

fn layer_rows(sim: &Delivery, logged: &[LoggedLayer], shift: f64) -> Vec<LayerComparison> {
    let angle = |t: f64, fallback: f64| {
        sim.timeline
            .as_ref()
            .map_or(fallback, |tl| tl.state_at(t).angle_deg)
    };
    let mut prev_end: Option<(f64, f64)> = None;
    sim.layers
        .iter()
        .zip(logged)
        .map(|(s, l)| {
            let (ls, le) = (l.start_s + shift, l.end_s + shift);
            let (log_in, sim_in) =
                prev_end.map_or((0.0, 0.0), |(pl, ps)| (ls - pl, s.t_start_s - ps));
            prev_end = Some((le, s.t_end_s));
            LayerComparison {
                index: s.index,
                arc: s.arc,
                control_point: s.control_point,
                layer: s.layer,
                energy_mev: s.energy_mev,
                angle_deg: s.angle_deg,
                logged_start_s: ls,
                logged_end_s: le,
                simulated_start_s: s.t_start_s,
                simulated_end_s: s.t_end_s,
                logged_angle_start_deg: l.angle_start_deg,
                logged_angle_end_deg: l.angle_end_deg,
                simulated_angle_start_deg: angle(s.t_start_s, s.angle_deg),
                simulated_angle_end_deg: angle(s.t_end_s, s.angle_deg),
                logged_beam_on_s: l.beam_on_s,
                simulated_beam_on_s: s.t_end_s - s.t_start_s,
                logged_transition_in_s: log_in,
                simulated_transition_in_s: sim_in,
                segments: l.segments,
                interruptions: l.interruptions,
                difference_s: (log_in + le - ls) - (sim_in + s.t_end_s - s.t_start_s),
            }
        })
        .collect()
}

fn logged_split(sim: &Delivery, rows: &[LayerComparison]) -> TimeSplit {
    let (first, last) = (&rows[0], &rows[rows.len() - 1]);
    let mut split = TimeSplit {
        total_s: last.logged_end_s - first.logged_start_s,
        beam_on_s: 0.0,
        energy_switching_s: 0.0,
        gantry_s: 0.0,
        interruptions_s: 0.0,
    };
    for r in rows {
        split.beam_on_s += r.logged_beam_on_s;
    }
    for t in &sim.transitions {
        let gap = rows
            .get(t.to_layer)
            .map_or(0.0, |r| r.logged_transition_in_s);
        split.energy_switching_s += gap.min(t.elst_s).max(0.0);
        split.gantry_s += (gap - t.elst_s).max(0.0);
    }
    split.interruptions_s =
        split.total_s - split.beam_on_s - split.energy_switching_s - split.gantry_s;
    split.interruptions_s = split.interruptions_s.max(0.0);
    split
}

fn motion_fit(sim: &Delivery, rows: &[LayerComparison]) -> MotionFit {
    let n = rows.len().max(1) as f64;
    let ss: f64 = rows
        .iter()
        .map(|r| (r.logged_start_s - r.simulated_start_s).powi(2))
        .sum();
    MotionFit {
        motion: sim.motion.name().to_string(),
        total_s: sim.total_s,
        rms_start_s: (ss / n).sqrt(),
    }
}

/// The class of the switch into layer `to` from layer `from` (delivery order), by the plan's
/// energies.
pub(crate) fn switch_class(from_mev: f64, to_mev: f64) -> &'static str {
    let d = to_mev - from_mev;
    if d.abs() <= arcsim_plan::SAME_ENERGY_TOLERANCE_MEV {
        "same energy"
    } else if d > 0.0 {
        "upward switch"
    } else {
        "downward switch"
    }
}

fn classes(sim: &Delivery, arcs: &[ResolvedArc], rows: &[LayerComparison]) -> Vec<ClassStats> {
    let energies: Vec<f64> = arcs
        .iter()
        .flat_map(|a| a.layers.iter().map(|l| l.energy_mev))
        .collect();
    let mut by: Vec<(String, Vec<f64>)> = [
        "upward switch",
        "downward switch",
        "same energy",
        "arc change",
        "gantry-limited transition",
        "beam-on per layer",
    ]
    .iter()
    .map(|c| (c.to_string(), Vec::new()))
    .collect();
    let mut push = |class: &str, x: f64| {
        if let Some(v) = by.iter_mut().find(|(c, _)| c == class) {
            v.1.push(x);
        }
    };
    for t in &sim.transitions {
        let Some(r) = rows.get(t.to_layer) else {
            continue;
        };
        let d = r.logged_transition_in_s - r.simulated_transition_in_s;
        if t.arc_change {
            push("arc change", d);
        } else if let (Some(a), Some(b)) = (energies.get(t.from_layer), energies.get(t.to_layer)) {
            push(switch_class(*a, *b), d);
        }
        if !matches!(t.limited_by, Limiter::Elst | Limiter::None) {
            push("gantry-limited transition", d);
        }
    }
    for r in rows {
        push(
            "beam-on per layer",
            r.logged_beam_on_s - r.simulated_beam_on_s,
        );
    }
    by.into_iter()
        .filter(|(_, v)| !v.is_empty())
        .map(|(class, v)| stats(class, &v))
        .collect()
}

fn stats(class: String, v: &[f64]) -> ClassStats {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    ClassStats {
        class,
        count: v.len(),
        mean_s: mean,
        sd_s: var.sqrt(),
        min_s: v.iter().copied().fold(f64::INFINITY, f64::min),
        max_s: v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    }
}
