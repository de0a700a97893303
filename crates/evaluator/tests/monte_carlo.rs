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
    // Observed, every simulation is reported once (three passes of 200 draws here), from any
    // thread, and the result is the same.
    let seen = std::sync::atomic::AtomicUsize::new(0);
    let observed =
        arcsim_evaluator::machine_monte_carlo_observed(&plan, &machine, &opts, (200, 11), &|| {
            seen.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        })
        .expect("draws");
    assert_eq!(arcsim_evaluator::monte_carlo_passes(&machine), 3);
    assert_eq!(seen.into_inner(), 600);
    assert_eq!(observed.both.totals_s, mc.both.totals_s);
    let both = mc.both.sd_s;
    assert!(
        (both / (s * s + p * p).sqrt() - 1.0).abs() < 0.2,
        "independent sources add in quadrature: {both} against {s} and {p}"
    );
}

/// A `scanning` beam's fitted factor on its times per MU and its burst switching time are
/// drawn too: each spreads the total by its own derivative (two plain simulations with the
/// whole table scaled, or the burst time moved).
#[test]
fn a_scanning_beam_s_fitted_scale_and_burst_time_spread_the_total() {
    use arcsim_plan::BeamModel;
    let plan = load_plan(repo().join("plans/lung.json")).expect("plan");
    let base =
        load_machine(repo().join("scenarios/machine-proteusone-like.json")).expect("machine");
    let opts = Options {
        build_timeline: false,
        ..Options::new(Schedule::Optimal)
    };
    let total = |m: &Machine| simulate(&plan, m, &opts).expect("simulates").total_s;
    let scaled = |k: f64| {
        let mut m = base.clone();
        let BeamModel::Scanning(b) = &mut m.beam else {
            panic!("a scanning beam")
        };
        for row in &mut b.s_per_mu_by_energy {
            row[1] *= k;
        }
        m
    };
    let bursts = |dt: f64| {
        let mut m = base.clone();
        let BeamModel::Scanning(b) = &mut m.beam else {
            panic!("a scanning beam")
        };
        b.burst_switching_time_s += dt;
        m
    };
    let h = 0.01;
    let d_scale = (total(&scaled(1.0 + h)) - total(&scaled(1.0 - h))) / (2.0 * h);
    let d_burst = (total(&bursts(h)) - total(&bursts(-h))) / (2.0 * h);
    assert!(d_scale > 1.0 && d_burst > 1.0, "{d_scale} {d_burst}");
    for (u, expected) in [
        (
            FitUncertainty {
                s_per_mu_scale_sd_fraction: 0.01,
                ..FitUncertainty::default()
            },
            d_scale * 0.01,
        ),
        (
            FitUncertainty {
                burst_switching_time_s_sd: 0.01,
                ..FitUncertainty::default()
            },
            d_burst * 0.01,
        ),
    ] {
        let mut machine = base.clone();
        machine.uncertainty = Some(u);
        machine.spread = None;
        let mc = machine_monte_carlo(&plan, &machine, &opts, 200, 5).expect("draws");
        assert!(
            (mc.both.sd_s / expected - 1.0).abs() < 0.2,
            "sd {} against |dT/dx| σ = {expected} ({u:?})",
            mc.both.sd_s
        );
    }
}

/// Free motion under switches drawn with a spread of hours (`elst_up_sd_s` and
/// `elst_down_sd_s` 1e4 s: inside the documented range, any value ≥ 0) on the fast machine,
/// where beam edges fall within a few units in the last place of a move's segment ends far into
/// the delivery: the slivers between them stay in the timeline (dropped, they once broke the
/// verification's continuity, "a bug"), and every draw is delivered.
#[test]
fn free_motion_survives_switch_spreads_of_hours() {
    let plan = load_plan(repo().join("plans/lung.json")).expect("plan");
    let mut machine = load_machine(repo().join("scenarios/machine-fast.json")).expect("fast");
    machine.spread = Some(TimingSpread {
        elst_up_sd_s: 1e4,
        elst_down_sd_s: 1e4,
        elst_same_sd_s: 0.0,
        beam_time_sd_fraction: 0.0,
    });
    let opts = Options {
        build_timeline: false,
        motion: arcsim_sequencer::Motion::Free,
        ..Options::new(Schedule::Optimal)
    };
    for seed in 0..4 {
        let mc = machine_monte_carlo(&plan, &machine, &opts, 10, seed)
            .unwrap_or_else(|e| panic!("seed {seed}: a draw failed: {e}"));
        assert!(mc.both.p5_s > 0.0 && mc.both.p95_s >= mc.both.p5_s);
    }
}
