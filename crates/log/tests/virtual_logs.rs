//! Virtual logs of simulated deliveries, checked against the delivery they sample: they read
//! back unchanged, the beam is on where the layers are, the MU add up to the plan's, the angles
//! are the timeline's, and the noise has the asked spread and is seeded.

use std::path::PathBuf;

use arcsim_log::{parse_log, to_csv, virtual_log, ColumnMap, LogSample, VirtualLogOptions};
use arcsim_plan::{load_machine, load_plan};
use arcsim_sequencer::{simulate, spot_timeline, Delivery, Options, SpotRow};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `plans/PLAN.json` on `scenarios/machine-MACHINE.json` (scan, constant motion, timeline).
fn delivered(plan: &str, machine: &str) -> (Delivery, Vec<SpotRow>) {
    let plan = load_plan(repo().join(format!("plans/{plan}.json"))).expect("plan");
    let machine =
        load_machine(repo().join(format!("scenarios/machine-{machine}.json"))).expect("machine");
    let d = simulate(&plan, &machine, &Options::default()).expect("simulated");
    let spots = spot_timeline(&plan, &machine, &d).expect("spots");
    (d, spots)
}

/// Runs of consecutive beam-on samples: (first on sample's time, last on sample's time, energy).
fn on_runs(log: &[LogSample]) -> Vec<(f64, f64, f64)> {
    let mut runs: Vec<(f64, f64, f64)> = Vec::new();
    let mut open = false;
    for s in log {
        match (s.beam_on, open) {
            (true, false) => runs.push((s.t_s, s.t_s, s.energy_mev.expect("energy while on"))),
            (true, true) => {
                let r = runs.last_mut().expect("a run");
                assert_eq!(Some(r.2), s.energy_mev, "one energy per run at {} s", s.t_s);
                r.1 = s.t_s;
            }
            (false, _) => assert_eq!(s.energy_mev, None),
        }
        open = s.beam_on;
    }
    runs
}

#[test]
fn a_virtual_log_follows_its_delivery_and_reads_back_unchanged() {
    let (d, spots) = delivered("lung", "opentps-pbs");
    let period = 0.01;
    let opts = VirtualLogOptions {
        period_s: period,
        ..VirtualLogOptions::default()
    };
    let log = virtual_log(&d, &spots, &opts).expect("log");
    // Every period from 0 and the end.
    assert_eq!(log[0].t_s, 0.0);
    assert_eq!(log.last().map(|s| s.t_s), Some(d.total_s));
    assert!(log
        .windows(2)
        .all(|w| w[1].t_s - w[0].t_s <= period + 1e-12));
    // The file reads back to the same samples, bit for bit.
    let text = to_csv(&log);
    assert!(text.starts_with("t_s,gantry_angle_deg,beam_on,energy_mev,spot,mu\n"));
    let back = parse_log(text.as_bytes(), "lung.csv", &ColumnMap::default()).expect("reads");
    assert_eq!(back.samples, log);
    assert!(back.has_energy && back.has_spot && back.has_mu);
    // One beam-on run per layer, inside it and at most a period short at either end.
    let runs = on_runs(&log);
    assert_eq!(runs.len(), d.layers.len());
    for (r, l) in runs.iter().zip(&d.layers) {
        assert_eq!(r.2, l.energy_mev);
        assert!(
            r.0 >= l.t_start_s && r.0 - l.t_start_s <= period + 1e-9,
            "{r:?} {l:?}"
        );
        assert!(
            r.1 <= l.t_end_s && l.t_end_s - r.1 <= period + 1e-9,
            "{r:?} {l:?}"
        );
    }
    // The MU add up to the spots', and the angles are the timeline's.
    let logged: f64 = log.iter().filter_map(|s| s.mu).sum();
    let planned: f64 = spots.iter().map(|r| r.mu).sum();
    assert!(
        (logged - planned).abs() <= 1e-9 * planned,
        "{logged} vs {planned}"
    );
    let tl = d.timeline.as_ref().expect("timeline");
    assert!(log
        .iter()
        .all(|s| s.gantry_angle_deg == tl.state_at(s.t_s).angle_deg));
    // A spot is named only while the beam is on, and it is being irradiated then.
    let named: Vec<&LogSample> = log.iter().filter(|s| s.spot.is_some()).collect();
    assert!(named.len() > 100, "{} samples name a spot", named.len());
    for s in named {
        assert!(s.beam_on);
        assert!(spots
            .iter()
            .any(|r| Some(r.spot as u32) == s.spot && r.t_start_s <= s.t_s && s.t_s <= r.t_end_s));
    }
}

/// On a synchrotron a layer's beam stops while it waits for a spill: the log has one more
/// beam-on run per such wait, and the MU still add up.
#[test]
fn spill_waits_interrupt_the_beam_inside_a_layer() {
    let (d, spots) = delivered("lung", "probeat-v5-like");
    let opts = VirtualLogOptions::default();
    let log = virtual_log(&d, &spots, &opts).expect("log");
    let waits = spots
        .windows(2)
        .filter(|w| w[0].layer_index == w[1].layer_index && w[1].t_start_s - w[0].t_end_s > 0.01)
        .count();
    assert!(waits > 0, "no layer waits for a spill");
    assert_eq!(on_runs(&log).len(), d.layers.len() + waits);
    let logged: f64 = log.iter().filter_map(|s| s.mu).sum();
    let planned: f64 = spots.iter().map(|r| r.mu).sum();
    assert!((logged - planned).abs() <= 1e-9 * planned);
}

/// Encoder noise: zero mean and the asked standard deviation (to sampling error), the same log
/// for the same seed and another for another seed; a bad period or noise is refused.
#[test]
fn angle_noise_is_seeded_and_has_the_asked_spread() {
    let (d, spots) = delivered("prostate", "atom");
    let clean = virtual_log(&d, &spots, &VirtualLogOptions::default()).expect("log");
    let noisy = |seed: u64| {
        let opts = VirtualLogOptions {
            angle_noise_deg: 0.01,
            seed,
            ..VirtualLogOptions::default()
        };
        virtual_log(&d, &spots, &opts).expect("log")
    };
    let a = noisy(7);
    assert_eq!(a, noisy(7));
    assert_ne!(a, noisy(8));
    let e: Vec<f64> = a
        .iter()
        .zip(&clean)
        .map(|(x, y)| x.gantry_angle_deg - y.gantry_angle_deg)
        .collect();
    let n = e.len() as f64;
    let mean = e.iter().sum::<f64>() / n;
    let sd = (e.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    assert!(mean.abs() < 4.0 * 0.01 / n.sqrt(), "mean {mean}");
    assert!((sd / 0.01 - 1.0).abs() < 0.02, "sd {sd} over {n} samples");
    for (period, noise) in [(0.0, 0.0), (f64::NAN, 0.0), (0.01, -1.0), (1e-9, 0.0)] {
        let opts = VirtualLogOptions {
            period_s: period,
            angle_noise_deg: noise,
            seed: 0,
        };
        assert!(virtual_log(&d, &spots, &opts).is_err(), "{period} {noise}");
    }
}
