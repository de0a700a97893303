//! Candidates and the choice: for each arrangement of the arcs allowed (as planned, or each arc
//! turned and the arcs reordered), the layer order of least switching time; every candidate
//! simulated on the machine's controller; the shortest kept only where it is shorter than the
//! plan as given, and only once it is proven to deliver the same dose.

use arcsim_plan::{ArcPlan, Machine, RotationDirection};
use arcsim_planner::Limits;
use arcsim_sequencer::{machine_limits, simulate, Delivery, Options, SequenceError};
use rayon::prelude::*;
use serde::Serialize;

use crate::{best_orders, best_orders_by, check_same_dose, order_cost_s, DoseChange, GantryCost};

/// What may change besides the order of layers inside a control point.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ArcFreedom {
    /// Arcs as planned: their order and directions.
    #[default]
    Keep,
    /// Each arc may be delivered the other way round (the same control points, the energy order
    /// then judged the other way), and the arcs in another order: every direction for up to 4
    /// arcs, every order for up to 3.
    Turn,
}

/// How to re-sequence.
#[derive(Clone, Debug)]
pub struct ResequenceOptions {
    /// The simulation that judges each candidate (the machine's controller).
    pub simulation: Options,
    /// What may change besides the layer order.
    pub arcs: ArcFreedom,
    /// The search's budget in layers simulated ([`SEARCH_LAYER_BUDGET`] by default; 0: none).
    pub search_layer_budget: usize,
    /// Where every order of an arrangement fits the budget, simulate them all (exact); else, and
    /// when false, the orders found without simulating and a local search.
    pub exhaustive: bool,
}

impl Default for ResequenceOptions {
    fn default() -> Self {
        ResequenceOptions {
            simulation: Options::default(),
            arcs: ArcFreedom::Keep,
            search_layer_budget: SEARCH_LAYER_BUDGET,
            exhaustive: true,
        }
    }
}

/// One arrangement tried, with its simulated total.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Candidate {
    /// The original arc delivered in each place.
    pub arc_order: Vec<usize>,
    /// Per place: whether that arc is turned the other way.
    pub reversed: Vec<bool>,
    /// Σ switching time in this candidate's order (s).
    pub switching_s: f64,
    /// Its simulated total (s); `None` where it could not be delivered.
    pub total_s: Option<f64>,
    /// Why it could not be delivered.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// What re-sequencing found.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The plan to deliver: the shortest candidate, or the original where none is shorter.
    pub plan: ArcPlan,
    /// The original's delivery.
    pub before: Delivery,
    /// The chosen plan's delivery (the original's when nothing is shorter).
    pub after: Delivery,
    /// Σ switching time of the original order (s).
    pub switching_before_s: f64,
    /// Σ switching time of the chosen plan (s).
    pub switching_after_s: f64,
    /// Index in `candidates` of the one chosen; `None`: the original is kept.
    pub chosen: Option<usize>,
    /// Layers not at their place in their control point's list (chosen plan, its own arc
    /// direction).
    pub moved_layers: usize,
    /// Every candidate, in the order tried.
    pub candidates: Vec<Candidate>,
}

/// Why a plan could not be re-sequenced.
#[derive(Debug, thiserror::Error)]
pub enum ResequenceError {
    /// The plan as given cannot be simulated.
    #[error("{0}")]
    Original(SequenceError),
    /// A candidate failed the dose check (a bug: nothing is written).
    #[error(
        "a re-sequenced plan does not deliver the original's dose (a bug; nothing written): {0}"
    )]
    Dose(DoseChange),
}

/// `plan` with its arcs in `order` (original indices), each turned where `reversed` says.
pub fn arrange(plan: &ArcPlan, order: &[usize], reversed: &[bool]) -> ArcPlan {
    let mut out = plan.clone();
    out.arcs = order
        .iter()
        .zip(reversed)
        .filter_map(|(&i, &rev)| {
            let mut arc = plan.arcs.get(i)?.clone();
            if rev {
                arc.control_points.reverse();
                arc.direction = match arc.direction {
                    RotationDirection::Cw => RotationDirection::Cc,
                    RotationDirection::Cc => RotationDirection::Cw,
                };
            }
            Some(arc)
        })
        .collect();
    out
}

/// Every permutation of `0..n`, in lexicographic order.
fn permutations(n: usize) -> Vec<Vec<usize>> {
    if n == 0 {
        return vec![Vec::new()];
    }
    let mut out = Vec::new();
    for rest in permutations(n - 1) {
        for at in 0..=rest.len() {
            let mut p = rest.clone();
            p.insert(at, n - 1);
            out.push(p);
        }
    }
    out.sort();
    out
}

/// The `pick`-th permutation of `0..k` in lexicographic order ([`permutations`]'s), decoded
/// from its factorial-base digits without listing the others.
fn nth_permutation(k: usize, mut pick: usize) -> Vec<usize> {
    let mut pool: Vec<usize> = (0..k).collect();
    let mut out = Vec::with_capacity(k);
    for left in (1..=k).rev() {
        let block: usize = (1..left).product();
        out.push(pool.remove(pick / block));
        pick %= block;
    }
    out
}

/// The arrangements of `n` arcs `freedom` allows, the plan's own first.
fn arrangements(n: usize, freedom: ArcFreedom) -> Vec<(Vec<usize>, Vec<bool>)> {
    let identity: Vec<usize> = (0..n).collect();
    if freedom == ArcFreedom::Keep || n == 0 {
        return vec![(identity, vec![false; n])];
    }
    let orders = if n <= 3 {
        permutations(n)
    } else {
        vec![identity]
    };
    let turns: Vec<Vec<bool>> = if n <= 4 {
        (0..1usize << n)
            .map(|m| (0..n).map(|i| m & (1 << i) != 0).collect())
            .collect()
    } else {
        vec![vec![false; n], vec![true; n]]
    };
    let mut out = Vec::new();
    for o in &orders {
        for t in &turns {
            out.push((o.clone(), t.clone()));
        }
    }
    out
}

/// `plan` with each control point's layers in `orders`' order.
fn reordered(plan: &ArcPlan, orders: &[Vec<Vec<usize>>]) -> (ArcPlan, usize) {
    let mut out = plan.clone();
    let mut moved = 0;
    for (arc, arc_orders) in out.arcs.iter_mut().zip(orders) {
        for (cp, order) in arc.control_points.iter_mut().zip(arc_orders) {
            if order.len() != cp.layers.len() {
                continue;
            }
            moved += order.iter().enumerate().filter(|(i, &l)| *i != l).count();
            cp.layers = order.iter().map(|&l| cp.layers[l].clone()).collect();
        }
    }
    (out, moved)
}

/// One candidate: its arrangement, plan, layers moved and simulation.
struct Built {
    order: Vec<usize>,
    reversed: Vec<bool>,
    plan: ArcPlan,
    moved: usize,
    delivery: Result<Delivery, SequenceError>,
}

/// The local search's budget: whole passes are run while their simulations, counted in layers
/// simulated, fit in this (a 20-layer arc gets about a thousand simulations, an 800-layer plan
/// none: there the orders found without simulating stand).
pub const SEARCH_LAYER_BUDGET: usize = 20_000;

/// Control points with more layers than this are left out of the local search (k! orders each).
const SEARCH_MAX_LAYERS: usize = 5;

type Orders = Vec<Vec<Vec<usize>>>;

/// How many times the order estimated at the flown speeds is re-estimated from the delivery it
/// gave, while each is shorter than the last (each round is one simulation).
const FLOWN_ROUNDS: usize = 3;

/// Every control point's layers in their own order.
fn identity_orders(plan: &ArcPlan) -> Orders {
    plan.arcs
        .iter()
        .map(|a| {
            a.control_points
                .iter()
                .map(|cp| (0..cp.layers.len()).collect())
                .collect()
        })
        .collect()
}

/// The `i`-th of every order of control points of `sizes` layers (mixed radix, the first
/// control point fastest; each control point's orders as [`permutations`] lists them).
fn nth_order(sizes: &[Vec<usize>], mut i: usize) -> Orders {
    sizes
        .iter()
        .map(|arc| {
            arc.iter()
                .map(|&k| {
                    let count: usize = (1..=k).product();
                    let pick = i % count;
                    i /= count;
                    nth_permutation(k, pick)
                })
                .collect()
        })
        .collect()
}

/// The order of least estimated switch duration with each layer at the speed `d` (a delivery of
/// `arranged` with its layers in `orders`) flew it at.
fn flown_order(
    arranged: &ArcPlan,
    machine: &Machine,
    limits: Limits,
    orders: &Orders,
    d: &Delivery,
) -> Option<Orders> {
    let offsets: Vec<usize> = arranged
        .arcs
        .iter()
        .scan(0, |n, a| {
            let at = *n;
            *n += a.control_points.len();
            Some(at)
        })
        .collect();
    let mut speed: std::collections::HashMap<(usize, usize), f64> = Default::default();
    for r in &d.layers {
        let layer = orders
            .get(r.arc)
            .and_then(|a| a.get(r.control_point))
            .and_then(|c| c.get(r.layer));
        if let (Some(o), Some(&l)) = (offsets.get(r.arc), layer) {
            speed.insert((o + r.control_point, l), r.speed_deg_per_s);
        }
    }
    let flown = |g: usize, l: usize| speed.get(&(g, l)).copied();
    let cost = GantryCost::new(arranged, machine, limits, &flown).ok()?;
    Some(best_orders_by(arranged, &|a, b| cost.switch_s(a, b)))
}

/// One arrangement's candidates, and the plan as given's delivery when it is the plan's own.
type Searched = (Vec<Built>, Option<Result<Delivery, SequenceError>>);

/// A candidate before it is labelled: its orders, plan, layers moved and simulation.
type Simulated = (Orders, ArcPlan, usize, Result<Delivery, SequenceError>);

/// `orders` of `arranged`, each simulated (in parallel).
fn simulate_orders(
    arranged: &ArcPlan,
    machine: &Machine,
    opts: &ResequenceOptions,
    orders: Vec<Orders>,
) -> Vec<Simulated> {
    orders
        .into_par_iter()
        .map(|o| {
            let (p, moved) = reordered(arranged, &o);
            let d = simulate(&p, machine, &opts.simulation);
            (o, p, moved, d)
        })
        .collect()
}

/// First-improvement local search by simulation from `start`: the layers of one control point
/// in every other order, then of two neighbouring control points together, kept where the whole
/// plan's simulated total falls; passes until one improves nothing or the next would not fit the
/// budget.
fn local_search(
    arranged: &ArcPlan,
    machine: &Machine,
    opts: &ResequenceOptions,
    start: (Orders, Delivery),
) -> (Orders, Delivery) {
    let (mut orders, mut best) = start;
    let layers: usize = best.layers.len().max(1);
    let cps: Vec<(usize, usize, usize)> = arranged
        .arcs
        .iter()
        .enumerate()
        .flat_map(|(a, arc)| {
            arc.control_points
                .iter()
                .enumerate()
                .map(move |(c, cp)| (a, c, cp.layers.len()))
        })
        .filter(|&(_, _, k)| (2..=SEARCH_MAX_LAYERS).contains(&k))
        .collect();
    let fact = |k: usize| (1..=k).product::<usize>();
    // Neighbourhoods: single control points, then neighbouring pairs (same arc).
    let singles: Vec<Vec<(usize, usize, usize)>> = cps.iter().map(|&x| vec![x]).collect();
    let pairs: Vec<Vec<(usize, usize, usize)>> = cps
        .windows(2)
        .filter(|w| w[0].0 == w[1].0 && w[1].1 == w[0].1 + 1)
        .map(|w| w.to_vec())
        .collect();
    let perms: Vec<Vec<Vec<usize>>> = (0..=SEARCH_MAX_LAYERS).map(permutations).collect();
    let mut budget = opts.search_layer_budget;
    for moves in [singles, pairs] {
        let pass_cost: usize = moves
            .iter()
            .map(|m| (m.iter().map(|&(_, _, k)| fact(k)).product::<usize>() - 1) * layers)
            .sum();
        while pass_cost > 0 && pass_cost <= budget {
            budget -= pass_cost;
            let mut improved = false;
            for m in &moves {
                let current: Vec<Vec<usize>> =
                    m.iter().map(|&(a, c, _)| orders[a][c].clone()).collect();
                let choices: Vec<&Vec<Vec<usize>>> = m.iter().map(|&(_, _, k)| &perms[k]).collect();
                let mut at = vec![0usize; m.len()];
                'odometer: loop {
                    let mut o = orders.clone();
                    for (i, &(a, c, _)) in m.iter().enumerate() {
                        o[a][c] = choices[i][at[i]].iter().map(|&j| current[i][j]).collect();
                    }
                    if o != orders {
                        let (p, _) = reordered(arranged, &o);
                        if let Ok(d) = simulate(&p, machine, &opts.simulation) {
                            if d.total_s < best.total_s - 1e-9 {
                                orders = o;
                                best = d;
                                improved = true;
                            }
                        }
                    }
                    let mut i = 0;
                    loop {
                        if i == m.len() {
                            break 'odometer;
                        }
                        at[i] += 1;
                        if at[i] < choices[i].len() {
                            break;
                        }
                        at[i] = 0;
                        i += 1;
                    }
                }
            }
            if !improved {
                break;
            }
        }
    }
    (orders, best)
}

/// The candidates of one arrangement: every order where they fit the budget; else the order of
/// least switching time, then the order of least estimated switch duration at the speeds the
/// shortest delivery so far flew (re-estimated from each shorter one, [`FLOWN_ROUNDS`]), each
/// simulated, then a local search by simulation from the shortest. For the plan's own
/// arrangement (`own`), the plan as given is simulated beside the first candidate and counts as
/// a delivery to estimate speeds from; its delivery is returned.
fn search(
    plan: &ArcPlan,
    machine: &Machine,
    limits: Limits,
    opts: &ResequenceOptions,
    (order, reversed): (Vec<usize>, Vec<bool>),
    own: bool,
) -> Searched {
    let arranged = arrange(plan, &order, &reversed);
    let as_given = || own.then(|| simulate(plan, machine, &opts.simulation));
    let built = |(p, moved, delivery): (ArcPlan, usize, Result<Delivery, SequenceError>)| Built {
        order: order.clone(),
        reversed: reversed.clone(),
        plan: p,
        moved,
        delivery,
    };
    if let Some(n) = exhaustive_count(&arranged, opts) {
        let (before, best) = rayon::join(as_given, || every_order(&arranged, machine, opts, n));
        return (best.into_iter().map(built).collect(), before);
    }
    let (before, mut simulated) = rayon::join(as_given, || {
        simulate_orders(
            &arranged,
            machine,
            opts,
            vec![best_orders(&arranged, &machine.elst)],
        )
    });
    // The orders estimated at the speeds each delivery so far flew (the plan as given's and
    // the first candidate's), simulated; then again from the shortest of each round while it
    // is shorter than every delivery before it.
    let mut frontier: Vec<(Orders, Delivery)> = simulated
        .iter()
        .filter_map(|(o, _, _, d)| d.as_ref().ok().map(|d| (o.clone(), d.clone())))
        .chain(
            before
                .as_ref()
                .and_then(|d| d.as_ref().ok())
                .map(|d| (identity_orders(&arranged), d.clone())),
        )
        .collect();
    let mut shortest_s = frontier
        .iter()
        .map(|(_, d)| d.total_s)
        .fold(f64::INFINITY, f64::min);
    for _ in 0..FLOWN_ROUNDS {
        let mut next: Vec<Orders> = frontier
            .iter()
            .filter_map(|(o, d)| flown_order(&arranged, machine, limits, o, d))
            .collect();
        next.sort();
        next.dedup();
        next.retain(|o| !simulated.iter().any(|s| s.0 == *o));
        if next.is_empty() {
            break;
        }
        let round = simulate_orders(&arranged, machine, opts, next);
        frontier = round
            .iter()
            .filter_map(|(o, _, _, d)| d.as_ref().ok().map(|d| (o, d)))
            .min_by(|a, b| a.1.total_s.total_cmp(&b.1.total_s))
            .filter(|(_, d)| d.total_s < shortest_s - 1e-9)
            .map(|(o, d)| (o.clone(), d.clone()))
            .into_iter()
            .collect();
        shortest_s = frontier.first().map_or(shortest_s, |(_, d)| d.total_s);
        simulated.extend(round);
    }
    let shortest = simulated
        .iter()
        .filter_map(|(o, _, _, d)| d.as_ref().ok().map(|d| (o, d)))
        .min_by(|a, b| a.1.total_s.total_cmp(&b.1.total_s))
        .map(|(o, d)| (o.clone(), d.clone()));
    let mut out: Vec<Built> = simulated
        .into_iter()
        .map(|(_, p, moved, d)| built((p, moved, d)))
        .collect();
    if let Some(start) = shortest {
        let first = start.1.total_s;
        let (o, d) = local_search(&arranged, machine, opts, start);
        if d.total_s < first {
            let (p, moved) = reordered(&arranged, &o);
            out.push(built((p, moved, Ok(d))));
        }
    }
    (out, before)
}

/// The number of orders of `arranged` when simulating them all fits the budget.
fn exhaustive_count(arranged: &ArcPlan, opts: &ResequenceOptions) -> Option<usize> {
    let sizes = || {
        arranged
            .arcs
            .iter()
            .flat_map(|a| &a.control_points)
            .map(|cp| cp.layers.len())
    };
    let layers: usize = sizes().sum();
    let count = sizes().try_fold(1usize, |n, k| n.checked_mul((1..=k).product::<usize>()))?;
    (opts.exhaustive && count.saturating_mul(layers) <= opts.search_layer_budget).then_some(count)
}

/// Every one of the `n` orders of `arranged` simulated; the shortest (first of equals).
fn every_order(
    arranged: &ArcPlan,
    machine: &Machine,
    opts: &ResequenceOptions,
    n: usize,
) -> Option<(ArcPlan, usize, Result<Delivery, SequenceError>)> {
    let sizes: Vec<Vec<usize>> = arranged
        .arcs
        .iter()
        .map(|a| a.control_points.iter().map(|cp| cp.layers.len()).collect())
        .collect();
    (0..n)
        .into_par_iter()
        .filter_map(|i| {
            let (p, moved) = reordered(arranged, &nth_order(&sizes, i));
            let d = simulate(&p, machine, &opts.simulation).ok()?;
            Some((d.total_s, i, p, moved, d))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        .map(|(_, _, p, moved, d)| (p, moved, Ok(d)))
}

/// Re-sequences `plan` on `machine` (see the module docs). The original is kept unless a
/// candidate's simulated total is shorter; every candidate is proven dose-neutral first.
pub fn resequence(
    plan: &ArcPlan,
    machine: &Machine,
    opts: &ResequenceOptions,
) -> Result<Outcome, ResequenceError> {
    let limits = machine_limits(machine).map_err(ResequenceError::Original)?;
    let searched: Vec<Searched> = arrangements(plan.arcs.len(), opts.arcs)
        .into_par_iter()
        .map(|(order, reversed)| {
            let own = order.iter().enumerate().all(|(i, &a)| i == a) && !reversed.contains(&true);
            search(plan, machine, limits, opts, (order, reversed), own)
        })
        .collect();
    let mut before = None;
    let mut found = Vec::new();
    for (b, d) in searched {
        found.push(b);
        before = before.or(d);
    }
    let before = match before {
        Some(d) => d.map_err(ResequenceError::Original)?,
        None => simulate(plan, machine, &opts.simulation).map_err(ResequenceError::Original)?,
    };
    let mut built: Vec<Built> = Vec::new();
    for b in found.into_iter().flatten() {
        if !built.iter().any(|o| o.plan == b.plan) {
            check_same_dose(plan, &b.plan).map_err(ResequenceError::Dose)?;
            built.push(b);
        }
    }
    let mut candidates = Vec::new();
    let mut best: Option<(usize, f64)> = None;
    for (i, b) in built.iter().enumerate() {
        let (total_s, error) = match &b.delivery {
            Ok(d) => (Some(d.total_s), None),
            Err(e) => (None, Some(e.to_string())),
        };
        if let Some(t) = total_s {
            if t < before.total_s - 1e-9 && best.is_none_or(|(_, b)| t < b) {
                best = Some((i, t));
            }
        }
        candidates.push(Candidate {
            arc_order: b.order.clone(),
            reversed: b.reversed.clone(),
            switching_s: order_cost_s(&b.plan, &machine.elst),
            total_s,
            error,
        });
    }
    let switching_before_s = order_cost_s(plan, &machine.elst);
    let chosen = best.map(|(i, _)| i);
    let (plan_out, after, moved_layers) = match chosen.map(|i| (i, &built[i])) {
        Some((
            i,
            Built {
                plan: p,
                moved,
                delivery: Ok(d),
                ..
            },
        )) => {
            let mut p = p.clone();
            p.description = Some(description(plan, &candidates[i], *moved));
            (p, d.clone(), *moved)
        }
        _ => (plan.clone(), before.clone(), 0),
    };
    Ok(Outcome {
        switching_after_s: order_cost_s(&plan_out, &machine.elst),
        plan: plan_out,
        before,
        after,
        switching_before_s,
        chosen,
        moved_layers,
        candidates,
    })
}

/// The re-sequenced plan's description: the original's, and what changed.
fn description(plan: &ArcPlan, c: &Candidate, moved: usize) -> String {
    let mut what = format!("{moved} layers reordered inside their control points");
    let turned: Vec<String> = c
        .reversed
        .iter()
        .zip(&c.arc_order)
        .filter(|(r, _)| **r)
        .map(|(_, a)| a.to_string())
        .collect();
    if !turned.is_empty() {
        what.push_str(&format!("; arcs turned: {}", turned.join(", ")));
    }
    if c.arc_order.windows(2).any(|w| w[0] > w[1]) {
        let order: Vec<String> = c.arc_order.iter().map(|a| a.to_string()).collect();
        what.push_str(&format!("; arcs in the order {}", order.join(", ")));
    }
    match &plan.description {
        Some(d) => format!("{d} (re-sequenced by arcsim, same dose: {what})"),
        None => format!("re-sequenced by arcsim, same dose: {what}"),
    }
}

#[cfg(test)]
mod tests {
    use super::{nth_permutation, permutations};

    #[test]
    fn the_nth_permutation_is_the_nth_listed() {
        for k in 0..=5 {
            for (i, p) in permutations(k).iter().enumerate() {
                assert_eq!(&nth_permutation(k, i), p, "k {k}, i {i}");
            }
        }
    }
}
