//! One arc as a scheduling problem, and the duration of its transitions.
//!
//! Layer `k` sits at `s_k` degrees along the direction of travel and is irradiated for `t_k` at
//! speed `v_k`, sweeping `v_k·t_k` of its window. Transition `k` (layer k → k+1) covers the gap
//! `s_{k+1} - s_k - (v_k·t_k + v_{k+1}·t_{k+1})/2` from `v_k` to `v_{k+1}` without reversing and
//! lasts at least the ELST of layer k+1.

use crate::servo::grid_duration_in;
use arcsim_plan::ResolvedArc;
use arcsim_planner::{Limits, LinearGap, Move, MoveAnalysis, Reversal};

use crate::SpeedBound;

/// One arc, ready for scheduling (all speeds are magnitudes along the arc's direction).
#[derive(Clone, Debug)]
pub(crate) struct ArcProblem {
    /// +1 for CW (angle increases), -1 for CC.
    pub dir: f64,
    /// Each layer's angle (deg).
    pub angle: Vec<f64>,
    /// Position along travel, from the first layer (deg, non-decreasing).
    pub travel_deg: Vec<f64>,
    /// Each layer's irradiation time (s).
    pub irradiation_s: Vec<f64>,
    /// Each layer's tolerance window (deg).
    pub window: Vec<f64>,
    /// ELST of the switch into each layer (s); entry 0 is the switch into the arc.
    pub elst: Vec<f64>,
    /// Highest speed each layer may have on its own (deg/s): 0 at the ends, else
    /// min(V, window / irradiation time).
    pub speed_cap: Vec<f64>,
    /// What sets each layer's `speed_cap`.
    pub cap_bound: Vec<SpeedBound>,
}

impl ArcProblem {
    pub fn new(arc: &ResolvedArc, lim: &Limits) -> Self {
        let dir = arc.direction.sign();
        let n = arc.layers.len();
        let first = arc.layers.first().map_or(0.0, |l| l.angle_deg);
        let mut p = ArcProblem {
            dir,
            angle: Vec::with_capacity(n),
            travel_deg: Vec::with_capacity(n),
            irradiation_s: Vec::with_capacity(n),
            window: Vec::with_capacity(n),
            elst: Vec::with_capacity(n),
            speed_cap: Vec::with_capacity(n),
            cap_bound: Vec::with_capacity(n),
        };
        for (k, l) in arc.layers.iter().enumerate() {
            p.angle.push(l.angle_deg);
            p.travel_deg.push((dir * (l.angle_deg - first)).max(0.0));
            p.irradiation_s.push(l.irradiation_s);
            p.window.push(l.window_deg);
            p.elst.push(l.switch_in_s);
            let (cap, bound) = if k == 0 || k + 1 == n {
                (0.0, SpeedBound::Rest)
            } else if l.irradiation_s > 0.0 && l.window_deg / l.irradiation_s < lim.max_vel {
                (l.window_deg / l.irradiation_s, SpeedBound::Window)
            } else {
                (lim.max_vel, SpeedBound::MaxSpeed)
            };
            p.speed_cap.push(cap);
            p.cap_bound.push(bound);
        }
        p
    }

    pub fn len(&self) -> usize {
        self.travel_deg.len()
    }

    /// The gap of transition `k` as a linear function of its boundary speeds (planner eq. 5).
    pub fn gap(&self, k: usize) -> LinearGap {
        LinearGap {
            distance: (self.travel_deg[k + 1] - self.travel_deg[k]).max(0.0),
            t_start: self.irradiation_s[k],
            t_end: self.irradiation_s[k + 1],
        }
    }

    /// The planner move of transition `k` at speeds `vs`, `ve`.
    pub fn transition_move(&self, k: usize, vs: f64, ve: f64) -> Move {
        Move {
            distance: self.gap(k).at(vs, ve).max(0.0),
            v_start: vs,
            v_end: ve,
        }
    }

    /// Whether the gap of transition `k` is not negative at speeds `vs`, `ve` (the two layers'
    /// swept windows do not overlap), to rounding.
    pub(crate) fn gap_open(&self, k: usize, vs: f64, ve: f64) -> bool {
        self.gap(k).at(vs, ve) >= -1e-12 * (1.0 + self.travel_deg[k + 1])
    }

    /// The planner's analysis of transition `k`'s forward move at speeds `vs`, `ve`; `None` when
    /// the two layers' sweeps overlap or no forward move fits the gap.
    pub(crate) fn analysis(
        &self,
        k: usize,
        vs: f64,
        ve: f64,
        lim: &Limits,
    ) -> Option<MoveAnalysis> {
        if !self.gap_open(k, vs, ve) {
            return None;
        }
        let mv = self.transition_move(k, vs, ve);
        MoveAnalysis::new(&mv, lim, Reversal::Forbid).ok()
    }

    /// Layer `k`'s window along travel, `[θ_k − w_k/2, θ_k + w_k/2]` (deg).
    pub fn window_edges(&self, k: usize) -> (f64, f64) {
        let half = 0.5 * self.window[k];
        (self.travel_deg[k] - half, self.travel_deg[k] + half)
    }

    /// Duration of transition `k` at speeds `vs`, `ve`: the shortest feasible duration of at least
    /// max(minimum time, ELST), or `None` when no forward move fits the gap or none lasts the ELST.
    pub fn cost(&self, k: usize, vs: f64, ve: f64, lim: &Limits) -> Option<f64> {
        self.cost_on(k, vs, ve, lim, None)
    }

    /// [`Self::cost`] on a servo period: the shortest whole number of periods, at least the
    /// continuous cost, that the move can last ([`grid_duration_in`]); the continuous cost
    /// without a period.
    pub fn cost_on(
        &self,
        k: usize,
        vs: f64,
        ve: f64,
        lim: &Limits,
        period: Option<f64>,
    ) -> Option<f64> {
        let analysis = self.analysis(k, vs, ve, lim)?;
        let t_opt = analysis.min_time();
        let e = self.elst[k + 1];
        let d = if e <= t_opt {
            t_opt
        } else {
            analysis.shortest_duration_at_least(e)?
        };
        match period {
            Some(ts) => grid_duration_in(&analysis.durations(), d, ts),
            None => Some(d),
        }
    }
}

/// Σ transition durations of an arc at speeds `v` (infinite if one is infeasible).
pub(crate) fn moving_time(p: &ArcProblem, lim: &Limits, v: &[f64]) -> f64 {
    moving_time_on(p, lim, v, None)
}

/// Σ transition durations of speeds `v`, on `period` when given; infinite if one is infeasible.
pub(crate) fn moving_time_on(p: &ArcProblem, lim: &Limits, v: &[f64], period: Option<f64>) -> f64 {
    (0..p.len().saturating_sub(1))
        .map(|k| {
            p.cost_on(k, v[k], v[k + 1], lim, period)
                .unwrap_or(f64::INFINITY)
        })
        .sum()
}

/// Time of one arc at layer speeds `v` with every transition on the servo period (infinite when
/// a transition has no such duration).
pub(crate) fn arc_time_on_grid(p: &ArcProblem, v: &[f64], lim: &Limits, period: f64) -> f64 {
    moving_time_on(p, lim, v, Some(period)) + p.irradiation_s.iter().sum::<f64>()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use arcsim_plan::{ResolvedLayer, RotationDirection};
    use arcsim_test_support::Rng;

    /// Random limits of the unit tests: J 0.1–4, A and D 0.1–2, V 1–8.
    pub(crate) fn random_limits(rng: &mut Rng) -> Limits {
        Limits::with_decel(
            rng.range(0.1, 4.0),
            rng.range(0.1, 2.0),
            rng.range(0.1, 2.0),
            rng.range(1.0, 8.0),
        )
        .expect("limits")
    }

    /// A random arc of `n` layers: spacing, irradiation time and window drawn uniformly from
    /// the given ranges (deg, s, deg), the ELST of each switch one of `elsts_s`.
    pub(crate) fn random_arc_of(
        rng: &mut Rng,
        n: usize,
        spacing_deg: (f64, f64),
        irradiation_s: (f64, f64),
        window_deg: (f64, f64),
        elsts_s: &[f64],
    ) -> ResolvedArc {
        let mut angle = 0.0;
        let layers = (0..n)
            .map(|k| {
                if k > 0 {
                    angle += rng.range(spacing_deg.0, spacing_deg.1);
                }
                let t = rng.range(irradiation_s.0, irradiation_s.1);
                ResolvedLayer {
                    control_point: k,
                    layer: 0,
                    angle_deg: angle,
                    window_deg: rng.range(window_deg.0, window_deg.1),
                    energy_mev: 100.0,
                    irradiation_s: t,
                    spot_irradiation_s: t,
                    scanning_s: 0.0,
                    burst_switching_s: 0.0,
                    spill_waiting_s: 0.0,
                    required_speed_deg_per_s: None,
                    switch_in_s: elsts_s[rng.below(elsts_s.len())],
                    mu: 0.0,
                }
            })
            .collect();
        ResolvedArc {
            arc_index: 0,
            direction: RotationDirection::Cw,
            layers,
        }
    }
}
