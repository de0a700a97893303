//! A switch's duration as the gantry would take it, for the order search: each layer swept at a
//! given speed (one a simulation of a neighbouring order flew it at, or the fastest its
//! sub-window allows), centred in the sub-window its place gives it; the move between two sweeps
//! the planner's shortest lasting at least the ELST. The simulation of every candidate has the
//! last word.

use arcsim_plan::{resolve, ArcPlan, Machine, PlanError};
use arcsim_planner::{Limits, Move};
use arcsim_sequencer::move_duration;

use crate::order::switch_cost_s;

/// What the cost needs of one control point (index over all arcs).
struct Point {
    arc: usize,
    /// Progress along the arc of the window's start (deg).
    start_deg: f64,
    /// Each layer's share of the window (deg).
    sub_deg: f64,
    /// Per layer: (fastest speed deg/s, irradiation time s).
    layers: Vec<(f64, f64)>,
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
                let k = cp.layers.len().max(1);
                let sub = window / k as f64;
                let g = points.len();
                let layers = it
                    .by_ref()
                    .take(cp.layers.len())
                    .enumerate()
                    .map(|(l, r)| {
                        let t = r.irradiation_s.max(1e-9);
                        let fastest = (sub / t).min(v_max);
                        (speed(g, l).map_or(fastest, |v| v.clamp(0.0, fastest)), t)
                    })
                    .collect();
                points.push(Point {
                    arc: a,
                    start_deg: sign * cp.angle_deg - window / 2.0,
                    sub_deg: sub,
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
        let centre = |p: &Point, place: usize| p.start_deg + p.sub_deg * (place as f64 + 0.5);
        let gap = (centre(pb_, pb) - centre(pa_, pa) - (va * ta + vb * tb) / 2.0).max(0.0);
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
