//! What the plan's energy order costs: its switches by class (up, down, same energy, arc change)
//! and by band of energy step, each with count, ELST, time taken and time lost; and the small
//! upward steps (rounding in a plan more often than a clinical need), located, each with what it
//! costs over the quicker switch it could have been.
//!
//! The plan's part (counts, ELSTs, small steps) needs no simulation, so `validate` prints it;
//! a delivery adds the time each switch took and the time the gantry lost beyond its ELST.

use arcsim_plan::{ElstModel, ResolvedArc, ResolvedLayer, SAME_ENERGY_TOLERANCE_MEV};
use serde::{Deserialize, Serialize};

use crate::{Delivery, SwitchKind};

/// An upward step below this (MeV) is listed as small.
pub const SMALL_UPWARD_STEP_MEV: f64 = 1.0;

/// Lower edges of the energy-step bands (MeV); the last band is open above.
pub const STEP_BANDS_MEV: [f64; 5] = [0.0, 1.0, 5.0, 10.0, 20.0];

/// The switches of one class in one band of energy step (or over all steps).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SwitchGroup {
    /// The class.
    pub switch: SwitchKind,
    /// The band's lower edge, |ΔE| ≥ this (MeV); 0 over all steps.
    pub step_from_mev: f64,
    /// The band's upper edge, |ΔE| < this (MeV); `None`: open above.
    pub step_to_mev: Option<f64>,
    /// Number of switches.
    pub count: usize,
    /// Σ their ELSTs (s).
    pub elst_s: f64,
    /// Σ the time they took (s); `None` for a plan not simulated.
    pub time_s: Option<f64>,
    /// Σ time beyond the ELST (s); `None` for a plan not simulated.
    pub lost_s: Option<f64>,
}

/// One upward step smaller than the threshold, located.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SmallUpwardStep {
    /// The arc of the layer switched to (index in the plan).
    pub arc: usize,
    /// Control point of the layer before (in its arc).
    pub from_control_point: usize,
    /// Control point of the layer after.
    pub to_control_point: usize,
    /// Gantry angle of the layer before (deg).
    pub from_angle_deg: f64,
    /// Gantry angle of the layer after (deg).
    pub to_angle_deg: f64,
    /// Energy before (MeV).
    pub from_energy_mev: f64,
    /// Energy after (MeV).
    pub to_energy_mev: f64,
    /// The step (MeV, > 0).
    pub step_mev: f64,
    /// Its ELST (s).
    pub elst_s: f64,
    /// The quicker switch it could have been: the machine's downward switch of the same step, or
    /// no energy change (s), whichever is shorter.
    pub quicker_elst_s: f64,
    /// `elst_s - quicker_elst_s`, at least 0: the ELST this step adds (s).
    pub cost_s: f64,
}

/// The energy switches of a plan, by class and step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Switching {
    /// One group per class that occurs (up, down, same, arc change), over all steps.
    pub by_class: Vec<SwitchGroup>,
    /// One group per class and band of energy step that occurs ([`STEP_BANDS_MEV`]).
    pub by_step: Vec<SwitchGroup>,
    /// Upward steps below this are listed (MeV).
    pub small_upward_threshold_mev: f64,
    /// The upward steps below the threshold (inside an arc), plan order.
    pub small_upward: Vec<SmallUpwardStep>,
    /// Σ their costs (s).
    pub small_upward_cost_s: f64,
}

fn class_of(from: &ResolvedLayer, to: &ResolvedLayer, arc_change: bool) -> SwitchKind {
    if arc_change {
        SwitchKind::ArcChange
    } else if to.energy_mev > from.energy_mev + SAME_ENERGY_TOLERANCE_MEV {
        SwitchKind::Up
    } else if to.energy_mev < from.energy_mev - SAME_ENERGY_TOLERANCE_MEV {
        SwitchKind::Down
    } else {
        SwitchKind::Same
    }
}

/// The band of a step: (index, lower edge, upper edge).
fn band(step_mev: f64) -> (usize, f64, Option<f64>) {
    let i = STEP_BANDS_MEV
        .iter()
        .rposition(|&lo| step_mev >= lo)
        .unwrap_or(0);
    (i, STEP_BANDS_MEV[i], STEP_BANDS_MEV.get(i + 1).copied())
}

const CLASSES: [SwitchKind; 4] = [
    SwitchKind::Up,
    SwitchKind::Down,
    SwitchKind::Same,
    SwitchKind::ArcChange,
];

impl Switching {
    /// The switches of `arcs` (resolved on a machine whose ELST model is `elst`), with the times
    /// of `delivery` when given (a delivery of those arcs). Steps below `small_up_mev` are listed.
    pub fn of(
        arcs: &[ResolvedArc],
        delivery: Option<&Delivery>,
        elst: &ElstModel,
        small_up_mev: f64,
    ) -> Switching {
        let layers: Vec<(usize, &ResolvedLayer)> = arcs
            .iter()
            .flat_map(|a| a.layers.iter().map(move |l| (a.arc_index, l)))
            .collect();
        let mut by_class: Vec<SwitchGroup> = Vec::new();
        let mut by_step: Vec<(usize, SwitchGroup)> = Vec::new();
        let mut small = Vec::new();
        let add = |g: &mut SwitchGroup, elst_s: f64, t: Option<(f64, f64)>| {
            g.count += 1;
            g.elst_s += elst_s;
            if let Some((time, lost)) = t {
                g.time_s = Some(g.time_s.unwrap_or(0.0) + time);
                g.lost_s = Some(g.lost_s.unwrap_or(0.0) + lost);
            }
        };
        let empty = |switch, lo, hi| SwitchGroup {
            switch,
            step_from_mev: lo,
            step_to_mev: hi,
            count: 0,
            elst_s: 0.0,
            time_s: delivery.map(|_| 0.0),
            lost_s: delivery.map(|_| 0.0),
        };
        // The time each switch took, by the delivery-order index of the layer switched to.
        let mut transition_at: Vec<Option<(f64, f64)>> = vec![None; layers.len()];
        for t in delivery.map_or(&[][..], |d| &d.transitions[..]) {
            if let Some(slot) = transition_at.get_mut(t.to_layer) {
                *slot = Some((t.duration_s, t.lost_s));
            }
        }
        for (i, w) in layers.windows(2).enumerate() {
            let ((arc_from, from), (arc_to, to)) = (w[0], w[1]);
            let class = class_of(from, to, arc_from != arc_to);
            let step = (to.energy_mev - from.energy_mev).abs();
            let t = transition_at[i + 1];
            let elst_s = to.switch_in_s;
            let gi = match by_class.iter().position(|g| g.switch == class) {
                Some(gi) => gi,
                None => {
                    by_class.push(empty(class, 0.0, None));
                    by_class.len() - 1
                }
            };
            add(&mut by_class[gi], elst_s, t);
            let (b, lo, hi) = band(step);
            let key = CLASSES.iter().position(|&c| c == class).unwrap_or(0) * 10 + b;
            let si = match by_step.iter().position(|(k, _)| *k == key) {
                Some(si) => si,
                None => {
                    by_step.push((key, empty(class, lo, hi)));
                    by_step.len() - 1
                }
            };
            add(&mut by_step[si].1, elst_s, t);
            if class == SwitchKind::Up && step < small_up_mev {
                let quicker = elst
                    .switch_time_s(to.energy_mev, from.energy_mev)
                    .min(elst.same_s());
                small.push(SmallUpwardStep {
                    arc: arc_to,
                    from_control_point: from.control_point,
                    to_control_point: to.control_point,
                    from_angle_deg: from.angle_deg,
                    to_angle_deg: to.angle_deg,
                    from_energy_mev: from.energy_mev,
                    to_energy_mev: to.energy_mev,
                    step_mev: step,
                    elst_s,
                    quicker_elst_s: quicker,
                    cost_s: (elst_s - quicker).max(0.0),
                });
            }
        }
        by_class.sort_by_key(|g| CLASSES.iter().position(|&c| c == g.switch));
        by_step.sort_by_key(|(k, _)| *k);
        let small_upward_cost_s = arcsim_plan::unsigned_zero(small.iter().map(|s| s.cost_s).sum());
        Switching {
            by_class,
            by_step: by_step.into_iter().map(|(_, g)| g).collect(),
            small_upward_threshold_mev: small_up_mev,
            small_upward: small,
            small_upward_cost_s,
        }
    }

    /// The group of a class over all steps, if any switch is of that class.
    pub fn class(&self, switch: SwitchKind) -> Option<&SwitchGroup> {
        self.by_class.iter().find(|g| g.switch == switch)
    }
}
