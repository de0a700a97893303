//! Where the lost time goes: the transitions that take longer than their energy-layer switching
//! time, grouped by cause (the limit that set the duration, the kind of energy switch, how far
//! apart the two layers are), with counts, seconds and the gantry angles where they happen, and
//! the costliest ones located by arc, control point and angle.

use serde::{Deserialize, Serialize};

use crate::types::{LayerRow, Limiter, TransitionRow};

/// Lost time below this (s) counts as none: rounding of `duration - ELST`.
const LOST_EPS_S: f64 = 1e-9;
/// Costliest transitions listed.
const COSTLIEST: usize = 5;

/// Direction of the energy switch a transition covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SwitchKind {
    /// To a higher energy (usually the longest ELST).
    Up,
    /// To a lower energy.
    Down,
    /// Same energy (another layer, or repainting).
    Same,
    /// The stop and turn between two arcs.
    ArcChange,
}

impl SwitchKind {
    /// The name the reports print.
    pub fn name(self) -> &'static str {
        match self {
            SwitchKind::Up => "up",
            SwitchKind::Down => "down",
            SwitchKind::Same => "same",
            SwitchKind::ArcChange => "arc change",
        }
    }
}

/// How far apart the two layers of a transition are, in control points of the arc.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GapClass {
    /// Both layers at one control point (one angle).
    SameControlPoint,
    /// From one control point to the next.
    NextControlPoint,
    /// Over one or more control points (or to another arc).
    Further,
}

impl GapClass {
    /// The name the reports print.
    pub fn name(self) -> &'static str {
        match self {
            GapClass::SameControlPoint => "same control point",
            GapClass::NextControlPoint => "next control point",
            GapClass::Further => "further",
        }
    }
}

/// Transitions of one cause.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LostGroup {
    /// The limit that set these transitions' durations.
    pub limited_by: Limiter,
    /// The energy switch.
    pub switch: SwitchKind,
    /// How far apart the layers are.
    pub gap: GapClass,
    /// Number of transitions.
    pub count: usize,
    /// Σ time beyond the ELST (s).
    pub lost_s: f64,
    /// Mean time beyond the ELST per transition (s).
    pub mean_lost_s: f64,
    /// Gantry angles covered by these transitions (deg, [from, to] each, ascending), touching
    /// stretches merged: where on the arc the time goes.
    pub angle_ranges_deg: Vec<[f64; 2]>,
}

/// One costly transition, located.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LostTransition {
    /// Index in `transitions`.
    pub transition: usize,
    /// Arc, control point and gantry angle of the layers before and after.
    pub from_arc: usize,
    /// Control point of the layer before.
    pub from_control_point: usize,
    /// Gantry angle of the layer before (deg).
    pub from_angle_deg: f64,
    /// Arc of the layer after.
    pub to_arc: usize,
    /// Control point of the layer after.
    pub to_control_point: usize,
    /// Gantry angle of the layer after (deg).
    pub to_angle_deg: f64,
    /// The energy switch.
    pub switch: SwitchKind,
    /// What limits it.
    pub limited_by: Limiter,
    /// Its duration (s).
    pub duration_s: f64,
    /// Its ELST (s).
    pub elst_s: f64,
    /// Time beyond the ELST (s).
    pub lost_s: f64,
}

/// Where the lost time goes.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LostTime {
    /// Σ time beyond the ELST over the transitions (s): the breakdown's `lost_s`, less the
    /// run-up of free arc ends.
    pub total_s: f64,
    /// Transitions that lose time.
    pub count: usize,
    /// By cause, most lost time first.
    pub groups: Vec<LostGroup>,
    /// The costliest transitions, most lost time first.
    pub costliest: Vec<LostTransition>,
}

fn switch_kind(from: &LayerRow, to: &LayerRow, t: &TransitionRow) -> SwitchKind {
    if t.arc_change || from.arc != to.arc {
        SwitchKind::ArcChange
    } else if to.energy_mev > from.energy_mev + arcsim_plan::SAME_ENERGY_TOLERANCE_MEV {
        SwitchKind::Up
    } else if to.energy_mev < from.energy_mev - arcsim_plan::SAME_ENERGY_TOLERANCE_MEV {
        SwitchKind::Down
    } else {
        SwitchKind::Same
    }
}

fn gap_class(from: &LayerRow, to: &LayerRow) -> GapClass {
    if from.arc != to.arc {
        GapClass::Further
    } else if from.control_point == to.control_point {
        GapClass::SameControlPoint
    } else if to.control_point == from.control_point + 1 {
        GapClass::NextControlPoint
    } else {
        GapClass::Further
    }
}

/// Sorted, merged angle ranges.
fn merge(mut ranges: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    ranges.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    let mut out: Vec<[f64; 2]> = Vec::new();
    for r in ranges {
        match out.last_mut() {
            Some(last) if r[0] <= last[1] + 1e-9 => last[1] = last[1].max(r[1]),
            _ => out.push(r),
        }
    }
    out
}

impl LostTime {
    /// Groups the transitions of a delivery (`layers` in delivery order, as the rows index them).
    pub(crate) fn of(layers: &[LayerRow], transitions: &[TransitionRow]) -> LostTime {
        type Key = (Limiter, SwitchKind, GapClass);
        let mut groups: Vec<(Key, LostGroup, Vec<[f64; 2]>)> = Vec::new();
        let mut located: Vec<LostTransition> = Vec::new();
        let mut total = 0.0;
        for (i, t) in transitions.iter().enumerate() {
            let (Some(from), Some(to)) = (layers.get(t.from_layer), layers.get(t.to_layer)) else {
                continue;
            };
            total += t.lost_s;
            if t.lost_s <= LOST_EPS_S {
                continue;
            }
            let switch = switch_kind(from, to, t);
            let key = (t.limited_by, switch, gap_class(from, to));
            let range = [
                from.angle_deg.min(to.angle_deg),
                from.angle_deg.max(to.angle_deg),
            ];
            match groups.iter_mut().find(|(k, _, _)| *k == key) {
                Some((_, g, ranges)) => {
                    g.count += 1;
                    g.lost_s += t.lost_s;
                    ranges.push(range);
                }
                None => groups.push((
                    key,
                    LostGroup {
                        limited_by: key.0,
                        switch: key.1,
                        gap: key.2,
                        count: 1,
                        lost_s: t.lost_s,
                        mean_lost_s: 0.0,
                        angle_ranges_deg: Vec::new(),
                    },
                    vec![range],
                )),
            }
            located.push(LostTransition {
                transition: i,
                from_arc: from.arc,
                from_control_point: from.control_point,
                from_angle_deg: from.angle_deg,
                to_arc: to.arc,
                to_control_point: to.control_point,
                to_angle_deg: to.angle_deg,
                switch,
                limited_by: t.limited_by,
                duration_s: t.duration_s,
                elst_s: t.elst_s,
                lost_s: t.lost_s,
            });
        }
        let count = located.len();
        let mut groups: Vec<LostGroup> = groups
            .into_iter()
            .map(|(_, mut g, ranges)| {
                g.mean_lost_s = g.lost_s / g.count as f64;
                g.angle_ranges_deg = merge(ranges);
                g
            })
            .collect();
        groups.sort_by(|a, b| b.lost_s.total_cmp(&a.lost_s));
        located.sort_by(|a, b| {
            b.lost_s
                .total_cmp(&a.lost_s)
                .then(a.transition.cmp(&b.transition))
        });
        located.truncate(COSTLIEST);
        LostTime {
            total_s: total,
            count,
            groups,
            costliest: located,
        }
    }
}
