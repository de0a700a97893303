//! Totals of every schedule on every bundled plan, pinned (the ATOM machine, constant speed per
//! layer; free motion where it is quick), so that a change that alters a result fails here and
//! says which. The values are what `arcsim simulate plans/NAME.json --schedule S --motion constant
//! --json` gives (`--motion free` for [`FREE`], `--period` for [`ON_PERIOD`]); a pin changes only
//! with the reason given in the commit and the changelog.
//!
//! What the totals reflect: the scan avoids stops at ELSTs, lowers a stopping transition's speeds
//! only as far as its stop-and-go fits the ELST, rebalances the transitions it slowed down for an
//! ELST (end speeds tried every 2.5 %), starts from the scan of the arc without V, and ends with a
//! local search over single speeds and neighbour pairs (`polish` in `scan.rs`). `optimal` searches
//! each layer's provable speed range (never worse than `scan`), spans its first grids on
//! limit-free speeds, repeats a refinement whose path ended on its grid's edge and refines once
//! more while the last refinement gained 1e-6 of the moving time; on a servo period it searches the
//! grid-timed problem itself. Free motion is a direct transcription refined by sequential linear
//! programming from both of its seeds, with an upper-speed cut; its search is local, and on the
//! lung plan, whose landscape is rugged, it ends in one local optimum of several.

use arcsim_plan::{load_machine, load_plan};
use arcsim_sequencer::{simulate, Motion, Options, Schedule};

const CONSTANT: [(&str, Schedule, f64); 16] = [
    ("prostate", Schedule::Scan, 273.852546),
    ("prostate", Schedule::Optimal, 273.852546),
    ("prostate", Schedule::StepAndShoot, 948.244332),
    ("prostate", Schedule::Prescribed, 273.965561),
    // Set by the rebalance (end speeds every 2.5 %) and `polish`.
    ("head-neck", Schedule::Scan, 759.439520),
    // Set by the limit-free first grids and the refinement repeated while it gains.
    ("head-neck", Schedule::Optimal, 757.730462),
    ("head-neck", Schedule::StepAndShoot, 2435.063092),
    ("head-neck", Schedule::Prescribed, 760.645846),
    ("two-arc", Schedule::Scan, 324.120665),
    ("two-arc", Schedule::Optimal, 324.120665),
    ("two-arc", Schedule::StepAndShoot, 1112.177933),
    ("two-arc", Schedule::Prescribed, 339.677097),
    ("lung", Schedule::Scan, 158.291440),
    // Set by the same as head-neck's.
    ("lung", Schedule::Optimal, 158.232315),
    ("lung", Schedule::StepAndShoot, 399.228603),
    ("lung", Schedule::Prescribed, 158.328633),
];

/// `arcsim simulate PLAN` (optimal, free motion, arc ends at rest).
const FREE: [(&str, f64); 3] = [
    ("prostate", 190.155237),
    // One local optimum of several: the lung plan's landscape is rugged (114.303418 s before the
    // interior point's Newton direction changed its rounding and so the refinement's path).
    ("lung", 113.966765),
    // The upper-speed cut keeps beams at full speed within V.
    ("two-arc", 251.813754),
];

/// The README's servo-period example: prostate, `--motion constant --period TS`.
const ON_PERIOD: [(Schedule, f64, f64); 4] = [
    (Schedule::Scan, 0.001, 275.009425),
    // The grid-timed search, refined while it gains.
    (Schedule::Optimal, 0.001, 274.113425),
    (Schedule::Scan, 0.004, 277.960425),
    (Schedule::Optimal, 0.004, 274.792425),
];

fn pinned(what: &str, got: f64, want: f64) {
    assert!(
        (got - want).abs() <= 1e-6,
        "{what}: {got:.6} s, pinned {want:.6} s"
    );
}

#[test]
fn every_schedule_on_every_bundled_plan() {
    let root = arcsim_suite::repo_root();
    let machine = load_machine(root.join("scenarios/machine-atom.json")).expect("machine");
    for (name, schedule, want) in CONSTANT {
        let plan = load_plan(root.join(format!("plans/{name}.json"))).expect("plan");
        let opts = Options {
            motion: Motion::Constant,
            ..Options::new(schedule)
        };
        let d = simulate(&plan, &machine, &opts).expect("simulate");
        pinned(&format!("{name} {}", schedule.name()), d.total_s, want);
    }
    let prostate = load_plan(root.join("plans/prostate.json")).expect("plan");
    for (schedule, period, want) in ON_PERIOD {
        let opts = Options {
            motion: Motion::Constant,
            servo_period_s: Some(period),
            ..Options::new(schedule)
        };
        let d = simulate(&prostate, &machine, &opts).expect("simulate");
        pinned(
            &format!("prostate {} on {period} s", schedule.name()),
            d.total_s,
            want,
        );
    }
    for (name, want) in FREE {
        let plan = load_plan(root.join(format!("plans/{name}.json"))).expect("plan");
        let opts = Options {
            motion: Motion::Free,
            ..Options::new(Schedule::Optimal)
        };
        let d = simulate(&plan, &machine, &opts).expect("simulate");
        pinned(&format!("{name} free motion"), d.total_s, want);
    }
}
