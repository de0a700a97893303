//! What limits a transition, checked against re-simulations of the whole plan with one gantry
//! limit raised: the limit with the most labelled lost time is the one whose raise saves the most
//! delivery time, on the ATOM machine and a two-arc plan with slow layers, where most lost time is
//! in moves that reach A but spend most of their time in jerk ramps.

use crate::util;

use arcsim_plan::{parse_plan, resolve, ArcPlan};
use arcsim_planner::{Limits, Move, MoveAnalysis, Reversal};
use arcsim_sequencer::{
    machine_limits, move_duration, raised_limits, simulate_resolved, Delivery, Limiter, Motion,
    Options, Schedule, LIMIT_RAISE_FACTOR,
};

const GANTRY: [Limiter; 3] = [Limiter::Jerk, Limiter::Accel, Limiter::Speed];

/// The bundled two-arc plan (161 transitions, 4 deg apart) with every spot's MU × 20: layers of
/// about 1–6 s, so the gantry nearly stops at every layer and each move starts and ends slowly.
fn two_arc_slow_layers() -> ArcPlan {
    let path = format!("{}/../../plans/two-arc.json", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).expect("plan file");
    let mut plan: serde_json::Value = serde_json::from_str(&text).expect("plan JSON");
    for arc in plan["arcs"].as_array_mut().expect("arcs") {
        for cp in arc["control_points"]
            .as_array_mut()
            .expect("control points")
        {
            for layer in cp["layers"].as_array_mut().expect("layers") {
                for mu in layer["spots"]["mu"].as_array_mut().expect("mu") {
                    *mu = serde_json::json!(mu.as_f64().expect("MU") * 20.0);
                }
            }
        }
    }
    parse_plan(&plan.to_string(), "two-arc.json, MU x 20").expect("plan")
}

/// Lost seconds labelled `which`.
fn lost_labelled(d: &Delivery, which: Limiter) -> f64 {
    d.transitions
        .iter()
        .filter(|t| t.limited_by == which)
        .map(|t| t.lost_s)
        .sum()
}

/// The gantry limit with the largest value of `f` (ties: the first of J, A, V).
fn argmax(f: impl Fn(Limiter) -> f64) -> (Limiter, f64) {
    GANTRY
        .iter()
        .map(|&l| (l, f(l)))
        .fold((Limiter::None, f64::NEG_INFINITY), |best, x| {
            if x.1 > best.1 {
                x
            } else {
                best
            }
        })
}

/// Lost seconds of the constant-speed transitions whose fastest profile reaches A (the label
/// the peak acceleration reached would give).
fn lost_reaching_a(d: &Delivery, lim: &Limits) -> f64 {
    d.transitions
        .iter()
        .filter(|t| {
            let mv = Move {
                distance: t.gap_deg,
                v_start: t.v_start_deg_per_s,
                v_end: t.v_end_deg_per_s,
            };
            let shape = MoveAnalysis::new(&mv, lim, Reversal::Forbid)
                .expect("move")
                .min_time_phases();
            let cruise_at_v = shape.t3 > 0.0 && shape.v_peak >= lim.max_vel * (1.0 - 1e-9);
            !cruise_at_v && (shape.t2 > 0.0 || shape.t5 > 0.0)
        })
        .map(|t| t.lost_s)
        .sum()
}

/// Runs the plan with the machine's limits and with each limit raised; checks the labels rank
/// the limits as the whole-plan re-simulations do, and returns (labelled lost s, saving s) per
/// limit in the order J, A, V.
fn check_ranking(opts: &Options, what: &str) -> (Delivery, Limits, Vec<(f64, f64)>) {
    let machine = util::machine("machine-atom.json");
    let arcs = resolve(&two_arc_slow_layers(), &machine).expect("resolve");
    let lim = machine_limits(&machine).expect("limits");
    let base = simulate_resolved(&arcs, &lim, opts).expect("simulate");
    let saving = |which: Limiter| {
        let raised = raised_limits(&lim, which, LIMIT_RAISE_FACTOR);
        base.total_s
            - simulate_resolved(&arcs, &raised, opts)
                .expect("simulate raised")
                .total_s
    };
    let rows: Vec<(f64, f64)> = GANTRY
        .iter()
        .map(|&l| (lost_labelled(&base, l), saving(l)))
        .collect();
    let at = |l: Limiter| GANTRY.iter().position(|&g| g == l).expect("gantry limit");
    let (most_lost, _) = argmax(|l| rows[at(l)].0);
    let (most_saved, _) = argmax(|l| rows[at(l)].1);
    assert_eq!(
        most_lost, most_saved,
        "{what}: most labelled lost time on {most_lost:?}, most saved by raising \
         {most_saved:?} (labelled lost s, whole-plan saving s, J A V: {rows:?})"
    );
    (base, lim, rows)
}

#[test]
fn labels_rank_limits_as_whole_plan_resimulation_constant_speed() {
    let opts = Options {
        build_timeline: false,
        ..Options::new(Schedule::Optimal)
    };
    let (base, lim, rows) = check_ranking(&opts, "constant speed");
    // The scenario: most lost time is in moves that reach A, yet raising J saves more.
    let lost: f64 = base.transitions.iter().map(|t| t.lost_s).sum();
    assert!(
        lost_reaching_a(&base, &lim) > 0.5 * lost,
        "moves reaching A hold {} of {lost} lost s",
        lost_reaching_a(&base, &lim)
    );
    assert!(
        rows[0].1 > rows[1].1,
        "J saves {}, A {}",
        rows[0].1,
        rows[1].1
    );
}

#[test]
fn labels_rank_limits_as_whole_plan_resimulation_free_motion() {
    let opts = Options {
        build_timeline: false,
        motion: Motion::Free,
        ..Options::new(Schedule::Optimal)
    };
    let (_, _, rows) = check_ranking(&opts, "free motion");
    assert!(
        rows[0].1 > rows[1].1,
        "J saves {}, A {}",
        rows[0].1,
        rows[1].1
    );
}

/// Every constant-speed transition of the plan, re-planned on its own with each limit doubled:
/// the labelled limit saves at least as much as any other (and something); ELST-labelled ones
/// are saved nothing by any raise.
#[test]
fn each_transition_label_matches_its_own_replans() {
    let machine = util::machine("machine-atom.json");
    let arcs = resolve(&two_arc_slow_layers(), &machine).expect("resolve");
    let lim = machine_limits(&machine).expect("limits");
    let opts = Options {
        build_timeline: false,
        ..Options::new(Schedule::Optimal)
    };
    let d = simulate_resolved(&arcs, &lim, &opts).expect("simulate");
    let mut seen = Vec::new();
    for t in &d.transitions {
        let mv = Move {
            distance: t.gap_deg,
            v_start: t.v_start_deg_per_s,
            v_end: t.v_end_deg_per_s,
        };
        let base = move_duration(&mv, t.elst_s, &lim).expect("move");
        assert!((base - t.duration_s).abs() < 1e-9, "transition {}", t.index);
        let saving = |l: Limiter| {
            base - move_duration(&mv, t.elst_s, &raised_limits(&lim, l, LIMIT_RAISE_FACTOR))
                .expect("raised move")
        };
        let best = GANTRY.iter().map(|&l| saving(l)).fold(0.0f64, f64::max);
        match t.limited_by {
            Limiter::Elst => assert!(best <= 1e-9, "transition {}: ELST, saves {best}", t.index),
            Limiter::None => assert!(t.duration_s <= 0.0, "transition {}", t.index),
            l => {
                let own = saving(l);
                assert!(
                    own > 0.0 && own >= best - 1e-12,
                    "transition {}: {l:?} saves {own}, best {best}",
                    t.index
                );
            }
        }
        if !seen.contains(&t.limited_by) {
            seen.push(t.limited_by);
        }
    }
    assert!(
        seen.contains(&Limiter::Jerk) && seen.contains(&Limiter::Elst),
        "{seen:?}"
    );
}
