//! The Monte Carlo of a calibrated machine against the problem's own law: the optimal total's
//! derivative in a fitted value is the sum over the switches it binds (an optimum's envelope), so
//! for a small standard deviation σ of that value the total's standard deviation is
//! |dT/dx| · σ. The derivative comes from two plain simulations, not from any draw.

use std::path::PathBuf;

use arcsim_evaluator::machine_monte_carlo;
use arcsim_plan::{load_machine, load_plan, ElstModel, FitUncertainty, Machine, TimingSpread};
use arcsim_sequencer::{simulate, Options, Schedule};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn with_up(m: &Machine, up: f64) -> Machine {
    let mut m = m.clone();
    if let ElstModel::Constant { up_s, .. } = &mut m.elst {
        *up_s = up;
    }
    m
}

#[test]
fn a_fitted_value_s_uncertainty_spreads_the_total_by_its_derivative() {
    let plan = load_plan(repo().join("plans/prostate.json")).expect("plan");
    let atom = load_machine(repo().join("scenarios/machine-atom.json")).expect("atom");
    let opts = Options {
        build_timeline: false,
        ..Options::new(Schedule::Optimal)
    };
    let h = 0.05;
    let total = |m: &Machine| simulate(&plan, m, &opts).expect("simulates").total_s;
    let slope = (total(&with_up(&atom, 5.0 + h)) - total(&with_up(&atom, 5.0 - h))) / (2.0 * h);
    assert!(
        slope > 1.0,
        "some upward switches last their ELST: dT/dELST_up = {slope}"
    );
    let sigma = 0.1;
    let mut machine = atom.clone();
    machine.uncertainty = Some(FitUncertainty {
        elst_up_s_sd: sigma,
        ..FitUncertainty::default()
    });
    let mc = machine_monte_carlo(&plan, &machine, &opts, 200, 11).expect("draws");
    let expected = slope * sigma;
    assert!(
        (mc.both.sd_s / expected - 1.0).abs() < 0.2,
        "sd {} against |dT/dx| σ = {expected}",
        mc.both.sd_s
    );
    assert_eq!(mc.dominant, "one source");
    // With timing spreads too, each source alone and which dominates: per-switch jitter of the
    // same size averages out over the switches, a systematic error does not.
    machine.spread = Some(TimingSpread {
        elst_up_sd_s: sigma,
        elst_down_sd_s: 0.0,
        elst_same_sd_s: 0.0,
        beam_time_sd_fraction: 0.0,
    });
    let mc = machine_monte_carlo(&plan, &machine, &opts, 200, 11).expect("draws");
    let (s, p) = (
        mc.spreads_only_sd_s.expect("spreads"),
        mc.parameters_only_sd_s.expect("parameters"),
    );
    assert!(p > 2.0 * s, "systematic {p} against per-switch {s}");
    assert_eq!(mc.dominant, "parameters");
    let both = mc.both.sd_s;
    assert!(
        (both / (s * s + p * p).sqrt() - 1.0).abs() < 0.2,
        "independent sources add in quadrature: {both} against {s} and {p}"
    );
}
