//! A switch's duration as the gantry would take it, for the order search: each layer swept at a
//! given speed (one a simulation of a neighbouring order flew it at, or the fastest its
//! sub-window allows), centred in the sub-window its place gives it; the move between two sweeps
//! the planner's shortest lasting at least the ELST. The simulation of every candidate has the
//! last word.
//!
//! The sub-windows are [`layer_windows`]'s. Equal ones depend on the place alone; where the
//! layers give `window_share`s a layer keeps its width at every place, and its centre depends on
//! which layers go before it, which a cost of (layer, place) cannot know: it is estimated as if
//! the layers before it had the mean width of the others.

use arcsim_plan::{layer_windows, resolve, ArcPlan, Machine, PlanError};
use arcsim_planner::{Limits, Move};
use arcsim_sequencer::move_duration;

use crate::order::switch_cost_s;

/// What the cost needs of one control point (index over all arcs).
struct Point {
    arc: usize,
    /// Progress along the arc of the window's start (deg).
    start_deg: f64,
    /// The window's full width (deg).
    window_deg: f64,
    /// Per layer: the width of its sub-window (deg).
    width_deg: Vec<f64>,
    /// Per place, where the sub-windows are equal (no shares): the centre of the place's
    /// sub-window from the window's start (deg); `None` where the layers give shares.
    equal_centres: Option<Vec<f64>>,
    /// Per layer: (fastest speed deg/s, irradiation time s).
    layers: Vec<(f64, f64)>,
}

impl Point {
    /// Progress along the arc of the centre of `layer`'s sub-window at `place` (deg): exact for
    /// equal sub-windows, else as if the layers before it had the mean width of the others.
    fn centre(&self, layer: usize, place: usize) -> f64 {
        let from_start = match &self.equal_centres {
            Some(c) => c.get(place).copied().unwrap_or(0.0),
            None => {
                let k = self.width_deg.len();
                let own = self.width_deg.get(layer).copied().unwrap_or(0.0);
                let others = if k > 1 {
                    (self.window_deg - own) / (k - 1) as f64
                } else {
                    0.0
                };
                place as f64 * others + own / 2.0
            }
        };
        self.start_deg + from_start
    }
}

/// The estimated switch durations of `plan` on `machine` (see the module docs).
pub struct GantryCost<'a> {
    plan_layers: Vec<Vec<&'a arcsim_plan::EnergyLayer>>,
    points: Vec<Point>,
    machine: &'a Machine,
    limits: Limits,
}

impl<'a> GantryCost<'a> {
    /// The estimate for `plan` (its layers' irradiation times as the machine gives them), each
    /// layer at `speed(control point over all arcs, layer)` where that gives one (deg/s), else at
    /// the fastest speed its sub-window allows.
    pub fn new(
        plan: &'a ArcPlan,
        machine: &'a Machine,
        limits: Limits,
        speed: &dyn Fn(usize, usize) -> Option<f64>,
    ) -> Result<Self, PlanError> {
        let arcs = resolve(plan, machine)?;
        let v_max = limits.max_vel;
        let mut points = Vec::new();
        let mut plan_layers = Vec::new();
        for (a, (arc, resolved)) in plan.arcs.iter().zip(&arcs).enumerate() {
            let sign = arc.direction.sign();
            let mut it = resolved.layers.iter();
            for cp in &arc.control_points {
                let window = cp.window_deg.unwrap_or(machine.default_window_deg);
                let subs = layer_windows(cp, window);
                let width_deg: Vec<f64> = subs.iter().map(|w| w.width_deg).collect();
                let g = points.len();
                let layers = it
                    .by_ref()
                    .take(cp.layers.len())
                    .zip(&width_deg)
                    .enumerate()
                    .map(|(l, (r, &sub))| {
                        let t = r.irradiation_s.max(1e-9);
                        let fastest = (sub / t).min(v_max);
                        (speed(g, l).map_or(fastest, |v| v.clamp(0.0, fastest)), t)
                    })
                    .collect();
                let shares = cp.layers.iter().any(|l| l.window_share.is_some());
                points.push(Point {
                    arc: a,
                    start_deg: sign * cp.angle_deg - window / 2.0,
                    window_deg: window,
                    width_deg,
                    equal_centres: (!shares)
                        .then(|| subs.iter().map(|w| w.centre_from_start_deg).collect()),
                    layers,
                });
                plan_layers.push(cp.layers.iter().collect());
            }
        }
        Ok(GantryCost {
            plan_layers,
            points,
            machine,
            limits,
        })
    }

    /// The estimated duration of the switch from layer `a` at place `pa` of control point `ga`
    /// to layer `b` at place `pb` of control point `gb` (s).
    pub fn switch_s(
        &self,
        (ga, la, pa): (usize, usize, usize),
        (gb, lb, pb): (usize, usize, usize),
    ) -> f64 {
        let elst = switch_cost_s(
            &self.machine.elst,
            self.plan_layers[ga][la],
            self.plan_layers[gb][lb],
        );
        let (pa_, pb_) = (&self.points[ga], &self.points[gb]);
        if pa_.arc != pb_.arc {
            return elst;
        }
        let ((va, ta), (vb, tb)) = (pa_.layers[la], pb_.layers[lb]);
        let gap = (pb_.centre(lb, pb) - pa_.centre(la, pa) - (va * ta + vb * tb) / 2.0).max(0.0);
        let timed = |v0: f64, v1: f64| {
            move_duration(
                &Move {
                    distance: gap,
                    v_start: v0,
                    v_end: v1,
                },
                elst,
                &self.limits,
            )
        };
        let slow = va.min(vb);
        timed(va, vb)
            .or_else(|| timed(slow, slow))
            .or_else(|| timed(0.0, 0.0))
            .unwrap_or(elst)
    }
}
