//! The layer order inside each control point that minimises the plan's summed energy-layer
//! switching time, exactly. Control points are coupled only through the energy one ends on and
//! the next starts with, so a dynamic programme over the control points (state: the last layer
//! delivered) is exact; inside a control point, Held–Karp over its layers gives the cheapest path
//! for every first and last layer.

use arcsim_plan::{ArcPlan, ControlPoint, ElstModel, EnergyLayer};

/// Control points with more layers than this keep their order (Held–Karp is 2^k k³ per control
/// point).
pub const MAX_LAYERS_REORDERED: usize = 10;

/// A tie-breaker per layer moved from its place (s): among orders of equal switching time the
/// one that moves fewest layers wins, so a plan with nothing to gain is left as it is.
const MOVE_PENALTY_S: f64 = 1e-9;

/// The switching time from layer `from` to layer `to`: the layer's own `switching_time_s` when
/// the plan gives one, else the machine's ELST model (as the resolver times it outside a spill).
pub fn switch_cost_s(elst: &ElstModel, from: &EnergyLayer, to: &EnergyLayer) -> f64 {
    to.switching_time_s
        .unwrap_or_else(|| elst.switch_time_s(from.energy_mev, to.energy_mev))
}

/// Σ switching time of `plan` in its own order (arc changes included).
pub fn order_cost_s(plan: &ArcPlan, elst: &ElstModel) -> f64 {
    let layers: Vec<&EnergyLayer> = plan
        .arcs
        .iter()
        .flat_map(|a| &a.control_points)
        .flat_map(|cp| &cp.layers)
        .collect();
    layers
        .windows(2)
        .map(|w| switch_cost_s(elst, w[0], w[1]))
        .sum()
}

/// The cheapest path through one control point's layers for each (first, last) pair.
struct Paths {
    /// `cost[f * k + l]`: the switching time inside the control point (plus move penalties).
    cost: Vec<f64>,
    /// `path[f * k + l]`: the layer indices in order.
    path: Vec<Vec<usize>>,
    k: usize,
}

/// The cost of a switch: (control point, layer, place) before and after, control points as
/// indices into the plan's control points over all arcs, places in the control point's order.
pub type SwitchCost<'a> = dyn Fn((usize, usize, usize), (usize, usize, usize)) -> f64 + Sync + 'a;

impl Paths {
    fn of(g: usize, cp: &ControlPoint, cost_of: &SwitchCost) -> Paths {
        let k = cp.layers.len();
        let inf = f64::INFINITY;
        let mut cost = vec![inf; k * k];
        let mut path = vec![Vec::new(); k * k];
        if k == 0 {
            return Paths { cost, path, k };
        }
        if k > MAX_LAYERS_REORDERED {
            let order: Vec<usize> = (0..k).collect();
            cost[k - 1] = order
                .windows(2)
                .map(|w| cost_of((g, w[0], w[0]), (g, w[1], w[1])))
                .sum();
            path[k - 1] = order;
            return Paths { cost, path, k };
        }
        // sw[(p * k + a) * k + b]: layer a at place p, then layer b at place p + 1.
        let sw: Vec<f64> = (0..k * k * k)
            .map(|i| {
                let (p, a, b) = (i / (k * k), (i / k) % k, i % k);
                if p + 1 < k {
                    cost_of((g, a, p), (g, b, p + 1))
                } else {
                    f64::INFINITY
                }
            })
            .collect();
        let moved = |layer: usize, place: usize| if layer == place { 0.0 } else { MOVE_PENALTY_S };
        let full = (1usize << k) - 1;
        for f in 0..k {
            // dp[mask * k + last]: cheapest path from f through `mask`, ending at `last`.
            let mut dp = vec![inf; (full + 1) * k];
            let mut from = vec![usize::MAX; (full + 1) * k];
            dp[(1 << f) * k + f] = moved(f, 0);
            for mask in 1..=full {
                if mask & (1 << f) == 0 {
                    continue;
                }
                let place = mask.count_ones() as usize; // where the next layer goes
                for last in 0..k {
                    let here = dp[mask * k + last];
                    if !here.is_finite() {
                        continue;
                    }
                    for next in 0..k {
                        if mask & (1 << next) != 0 {
                            continue;
                        }
                        let m = mask | (1 << next);
                        let c = here + sw[((place - 1) * k + last) * k + next] + moved(next, place);
                        if c < dp[m * k + next] {
                            dp[m * k + next] = c;
                            from[m * k + next] = last;
                        }
                    }
                }
            }
            for l in 0..k {
                let c = dp[full * k + l];
                if !c.is_finite() {
                    continue;
                }
                let (mut order, mut mask, mut at) = (Vec::with_capacity(k), full, l);
                while at != usize::MAX {
                    order.push(at);
                    let prev = from[mask * k + at];
                    mask &= !(1 << at);
                    at = prev;
                }
                order.reverse();
                cost[f * k + l] = c;
                path[f * k + l] = order;
            }
        }
        Paths { cost, path, k }
    }
}

/// For every arc and control point of `plan`, the order of its layers (indices into the control
/// point's `layers`) that minimises the plan's summed switching time, arc changes included. Exact
/// for that sum; ties go to the order that moves fewest layers.
pub fn best_orders(plan: &ArcPlan, elst: &ElstModel) -> Vec<Vec<Vec<usize>>> {
    let cps: Vec<&ControlPoint> = plan.arcs.iter().flat_map(|a| &a.control_points).collect();
    let cost = |(ca, la, _): (usize, usize, usize), (cb, lb, _): (usize, usize, usize)| {
        switch_cost_s(elst, &cps[ca].layers[la], &cps[cb].layers[lb])
    };
    best_orders_by(plan, &cost)
}

/// [`best_orders`] under any switch cost that depends only on the two layers and their places:
/// exact for the sum of `cost` over the plan's switches.
pub fn best_orders_by(plan: &ArcPlan, cost: &SwitchCost) -> Vec<Vec<Vec<usize>>> {
    let cps: Vec<&ControlPoint> = plan.arcs.iter().flat_map(|a| &a.control_points).collect();
    let paths: Vec<Paths> = cps
        .iter()
        .enumerate()
        .map(|(g, cp)| Paths::of(g, cp, cost))
        .collect();
    // value[l]: cheapest plan prefix ending with layer l of the current control point;
    // back[c][l]: (first layer of control point c, last layer of the one before) on that path.
    let mut value: Vec<f64> = Vec::new();
    let mut back: Vec<Vec<(usize, usize)>> = Vec::with_capacity(cps.len());
    let mut previous: Option<usize> = None; // index of the last non-empty control point
    for (c, p) in paths.iter().enumerate() {
        let k = p.k;
        if k == 0 {
            back.push(Vec::new());
            continue;
        }
        let mut next = vec![f64::INFINITY; k];
        let mut choice = vec![(usize::MAX, usize::MAX); k];
        // between[f * n + pl]: the switch from the previous control point's last layer pl into
        // layer f here, once per pair (it does not depend on this control point's last layer).
        let between: Vec<f64> = previous.map_or_else(Vec::new, |pc| {
            let (n, last_place) = (paths[pc].k, paths[pc].k - 1);
            (0..k * n)
                .map(|i| cost((pc, i % n, last_place), (c, i / n, 0)))
                .collect()
        });
        for l in 0..k {
            for f in 0..k {
                let inside = p.cost[f * k + l];
                if !inside.is_finite() {
                    continue;
                }
                match previous {
                    None => {
                        if inside < next[l] {
                            next[l] = inside;
                            choice[l] = (f, usize::MAX);
                        }
                    }
                    Some(_) => {
                        let n = value.len();
                        for (pl, v) in value.iter().enumerate() {
                            let total = v + between[f * n + pl] + inside;
                            if total < next[l] {
                                next[l] = total;
                                choice[l] = (f, pl);
                            }
                        }
                    }
                }
            }
        }
        value = next;
        back.push(choice);
        previous = Some(c);
    }
    // Walk back from the cheapest last layer.
    let mut orders: Vec<Vec<usize>> = vec![Vec::new(); cps.len()];
    let mut last = value
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .map(|(l, _)| l);
    for c in (0..cps.len()).rev() {
        let (Some(l), Some(choice)) = (last, back.get(c)) else {
            continue;
        };
        if choice.is_empty() {
            continue; // no layers here: the state passes through
        }
        let (f, pl) = choice[l];
        orders[c] = paths[c].path[f * paths[c].k + l].clone();
        last = (pl != usize::MAX).then_some(pl);
    }
    // Back to arcs.
    let mut out = Vec::with_capacity(plan.arcs.len());
    let mut it = orders.into_iter();
    for arc in &plan.arcs {
        out.push(it.by_ref().take(arc.control_points.len()).collect());
    }
    out
}
