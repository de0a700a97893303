//! The chosen order against every order: the dynamic programme's switching time equals the least
//! over all orders (counted here from the ELST model directly), and the simulated total of the
//! plan `resequence` returns is within 0.1 % of the best simulated total over all orders, under
//! constant speed per layer and free motion.

use arcsim_plan::{ArcPlan, Machine};
use arcsim_resequence::{best_orders, resequence, ResequenceOptions, SEARCH_LAYER_BUDGET};
use arcsim_sequencer::{simulate, Motion, Options, Schedule};
use arcsim_test_support::Rng;
use rayon::prelude::*;

use crate::util::{machine, small_plan};

/// Every plan made of `plan` with each control point's layers in some order (odometer over the
/// permutations of each control point).
fn every_order(plan: &ArcPlan) -> Vec<ArcPlan> {
    fn perms(k: usize) -> Vec<Vec<usize>> {
        if k == 0 {
            return vec![vec![]];
        }
        let mut out = Vec::new();
        for p in perms(k - 1) {
            for i in 0..=p.len() {
                let mut q = p.clone();
                q.insert(i, k - 1);
                out.push(q);
            }
        }
        out
    }
    let cps: Vec<(usize, usize)> = plan
        .arcs
        .iter()
        .enumerate()
        .flat_map(|(a, arc)| (0..arc.control_points.len()).map(move |c| (a, c)))
        .collect();
    let choices: Vec<Vec<Vec<usize>>> = cps
        .iter()
        .map(|&(a, c)| perms(plan.arcs[a].control_points[c].layers.len()))
        .collect();
    let mut out = Vec::new();
    let mut at = vec![0usize; cps.len()];
    loop {
        let mut p = plan.clone();
        for (i, &(a, c)) in cps.iter().enumerate() {
            let layers = &plan.arcs[a].control_points[c].layers;
            p.arcs[a].control_points[c].layers = choices[i][at[i]]
                .iter()
                .map(|&l| layers[l].clone())
                .collect();
        }
        out.push(p);
        let mut i = 0;
        loop {
            if i == cps.len() {
                return out;
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

/// How many orders `plan` has (the product of its control points' k!), without building them.
fn order_count(plan: &ArcPlan) -> usize {
    plan.arcs
        .iter()
        .flat_map(|a| &a.control_points)
        .map(|cp| (1..=cp.layers.len()).product::<usize>())
        .fold(1usize, |n, k| n.saturating_mul(k))
}

/// Σ switching time, straight from the ELST model's `switch_time_s` (no layer overrides here).
fn switching(plan: &ArcPlan, m: &Machine) -> f64 {
    let e: Vec<f64> = plan
        .arcs
        .iter()
        .flat_map(|a| &a.control_points)
        .flat_map(|cp| &cp.layers)
        .map(|l| l.energy_mev)
        .collect();
    e.windows(2).map(|w| m.elst.switch_time_s(w[0], w[1])).sum()
}

#[test]
fn the_dynamic_programme_finds_the_least_switching_time_of_all_orders() {
    let mut rng = Rng::new(4801);
    let machines = [
        machine("machine-atom.json"),
        machine("machine-probeat-v5-like.json"),
        machine("machine-proteusone-like.json"),
    ];
    for case in 0..300 {
        let m = &machines[case % machines.len()];
        let arcs = 1 + usize::from(case % 5 == 0);
        let cps = 1 + rng.below(6);
        let plan = small_plan(&mut rng, arcs, cps, &|r: &mut Rng| 1 + r.below(4));
        if order_count(&plan) > 20_000 {
            continue;
        }
        let best = every_order(&plan)
            .iter()
            .map(|p| switching(p, m))
            .fold(f64::INFINITY, f64::min);
        let orders = best_orders(&plan, &m.elst);
        let mut chosen = plan.clone();
        for (a, arc) in chosen.arcs.iter_mut().enumerate() {
            for (c, cp) in arc.control_points.iter_mut().enumerate() {
                let order = &orders[a][c];
                let mut seen = order.clone();
                seen.sort();
                assert_eq!(
                    seen,
                    (0..cp.layers.len()).collect::<Vec<_>>(),
                    "case {case}: not a permutation"
                );
                cp.layers = order.iter().map(|&l| cp.layers[l].clone()).collect();
            }
        }
        let got = switching(&chosen, m);
        assert!(
            (got - best).abs() <= 1e-9 * best.max(1.0) + 1e-6,
            "case {case} on {}: the programme's order switches for {got} s, the best order {best} s",
            m.name
        );
    }
}

fn brute_force_simulated(
    motion: Motion,
    seeds: std::ops::Range<u64>,
    max_orders: usize,
    exhaustive: bool,
    bound: f64,
) {
    let m = machine("machine-atom.json");
    let opts = Options {
        motion,
        schedule: Schedule::Optimal,
        ..Options::default()
    };
    let mut worst = 0.0f64;
    let mut tried = 0;
    for seed in seeds {
        let mut rng = Rng::new(seed);
        let cps = 2 + rng.below(5); // 2–6 control points
        let plan = small_plan(&mut rng, 1, cps, &|r: &mut Rng| 2 + r.below(3)); // 2–4 layers
        if order_count(&plan) > max_orders {
            continue;
        }
        let all = every_order(&plan);
        tried += 1;
        let best = all
            .par_iter()
            .filter_map(|p| simulate(p, &m, &opts).ok())
            .map(|d| d.total_s)
            .reduce(|| f64::INFINITY, f64::min);
        let out = resequence(
            &plan,
            &m,
            &ResequenceOptions {
                simulation: opts.clone(),
                exhaustive,
                ..ResequenceOptions::default()
            },
        )
        .expect("resequenced");
        // The returned plan, simulated afresh, is what the outcome says.
        let again = simulate(&out.plan, &m, &opts).expect("again").total_s;
        assert_eq!(again, out.after.total_s, "seed {seed}");
        assert!(
            out.after.total_s <= out.before.total_s,
            "seed {seed}: slower"
        );
        let excess = out.after.total_s / best - 1.0;
        worst = worst.max(excess);
        if std::env::var_os("SHOW").is_some() {
            eprintln!(
                "seed {seed}: {} orders, excess {:.4} %",
                all.len(),
                100.0 * excess
            );
        }
        assert!(
            excess <= bound,
            "seed {seed} ({motion:?}): re-sequenced {} s, best of {} orders {best} s ({:+.3} %)",
            out.after.total_s,
            all.len(),
            100.0 * excess
        );
    }
    assert!(tried >= 5, "only {tried} cases small enough");
    eprintln!(
        "{motion:?} (exhaustive: {exhaustive}): {tried} arcs, worst excess over the best order {:.4} %",
        100.0 * worst
    );
}

#[test]
fn resequenced_constant_speed_totals_are_within_0_1_percent_of_every_order() {
    brute_force_simulated(Motion::Constant, 0..30, 400, true, 1e-3);
}

/// Without the exhaustive search (as on plans too large for it): the orders found without
/// simulating and the local search, measured against every order.
#[test]
fn without_exhaustive_search_totals_stay_within_2_percent_of_every_order() {
    brute_force_simulated(Motion::Constant, 0..30, 300, false, 2e-2);
}

#[test]
fn resequenced_free_motion_totals_are_within_0_1_percent_of_every_order() {
    brute_force_simulated(Motion::Free, 100..125, 150, true, 1e-3);
}

/// Under the default options on arcs too large to simulate every order within the budget (the
/// local search decides), up to 3,500 orders: still within 0.1 % of the best of every order.
#[test]
fn beyond_the_budget_the_local_search_is_within_0_1_percent_of_every_order() {
    let m = machine("machine-atom.json");
    let opts = ResequenceOptions {
        simulation: Options {
            motion: Motion::Constant,
            schedule: Schedule::Optimal,
            ..Options::default()
        },
        ..ResequenceOptions::default()
    };
    let mut tried = 0;
    for seed in [19u64, 23, 33] {
        let mut rng = Rng::new(seed);
        let cps = 2 + rng.below(5);
        let plan = small_plan(&mut rng, 1, cps, &|r: &mut Rng| 2 + r.below(3));
        let layers: usize = plan.arcs[0]
            .control_points
            .iter()
            .map(|c| c.layers.len())
            .sum();
        let n = order_count(&plan);
        assert!(
            n * layers > SEARCH_LAYER_BUDGET && n <= 3500,
            "seed {seed}: {n} orders of {layers} layers; expected an arc beyond the budget"
        );
        tried += 1;
        let best = every_order(&plan)
            .par_iter()
            .filter_map(|p| simulate(p, &m, &opts.simulation).ok())
            .map(|d| d.total_s)
            .reduce(|| f64::INFINITY, f64::min);
        let out = resequence(&plan, &m, &opts).expect("resequenced");
        let excess = out.after.total_s / best - 1.0;
        assert!(
            excess <= 1e-3,
            "seed {seed}: re-sequenced {} s, best of {n} orders {best} s ({:+.3} %)",
            out.after.total_s,
            100.0 * excess
        );
    }
    assert_eq!(tried, 3);
}
