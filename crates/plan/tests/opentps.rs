//! `scenarios/machine-opentps-pbs.json` against OpenTPS's own timing model, computed here from
//! its published formula and table on random static fields: every spot's start time and the
//! beam's end agree to 1e-9 relative.
//!
//! OpenTPS (opentps-core, `processing/planDeliverySimulation/simpleBeamDeliveryTimings.py` and
//! `LUT_irradiation_durations.txt`), as read for this test:
//! - a spot takes `max(MU × s_per_mu(E), 250 µs)`, `s_per_mu` interpolated linearly in the layer's
//!   nominal energy in the table below and clamped outside it;
//! - between two spots of a layer the beam moves the straight-line distance at 8000 mm/s, with no
//!   settling time;
//! - before every layer but the first the energy switches: 6.0 s up, 0.6 s down or to the same
//!   energy; the beam's first spot starts at 0 and each layer follows the previous one's last spot;
//! - OpenTPS's "total irradiation time" of a beam is the start of its last spot; the beam ends when
//!   that spot ends.

use arcsim_plan::{load_machine, time_spots, BeamModel, Machine, ScanDistance, Spots};
use arcsim_test_support::Rng;

/// OpenTPS's `LUT_irradiation_durations.txt`: (energy MeV, s per MU), 150–227 MeV all 0.006.
const LUT: &[(f64, f64)] = &[
    (60.0, 0.038),
    (70.0, 0.023),
    (80.0, 0.017),
    (90.0, 0.013),
    (100.0, 0.010),
    (110.0, 0.008),
    (120.0, 0.006),
    (130.0, 0.007),
    (140.0, 0.007),
    (150.0, 0.006),
    (160.0, 0.006),
    (170.0, 0.006),
    (180.0, 0.006),
    (190.0, 0.006),
    (200.0, 0.006),
    (210.0, 0.006),
    (220.0, 0.006),
    (227.0, 0.006),
];
const SCANNING_SPEED_MM_PER_S: f64 = 8000.0;
const MIN_SPOT_TIME_S: f64 = 250e-6;
const SWITCH_UP_S: f64 = 6.0;
const SWITCH_DOWN_S: f64 = 0.6;

/// `numpy.interp` over [`LUT`]: linear inside, the end values outside.
fn s_per_mu(e: f64) -> f64 {
    if e <= LUT[0].0 {
        return LUT[0].1;
    }
    for w in LUT.windows(2) {
        let ((e0, r0), (e1, r1)) = (w[0], w[1]);
        if e <= e1 {
            return r0 + (r1 - r0) * (e - e0) / (e1 - e0);
        }
    }
    LUT[LUT.len() - 1].1
}

/// One layer of a static field: nominal energy, and per spot (x mm, y mm, MU).
struct Layer {
    energy_mev: f64,
    spots: Vec<(f64, f64, f64)>,
}

/// OpenTPS's spot start times of a beam (layers in the given order) and the end of its last spot.
fn opentps_starts(layers: &[Layer]) -> (Vec<f64>, f64) {
    let mut starts = Vec::new();
    let mut total = 0.0;
    for (j, layer) in layers.iter().enumerate() {
        let rate = s_per_mu(layer.energy_mev);
        let mut scan = Vec::with_capacity(layer.spots.len());
        let mut irradiation = Vec::with_capacity(layer.spots.len());
        for (i, &(x, y, mu)) in layer.spots.iter().enumerate() {
            scan.push(if i == 0 {
                match j {
                    0 => 0.0,
                    _ if layer.energy_mev - layers[j - 1].energy_mev > 0.0 => SWITCH_UP_S,
                    _ => SWITCH_DOWN_S,
                }
            } else {
                let (px, py, _) = layer.spots[i - 1];
                ((x - px).powi(2) + (y - py).powi(2)).sqrt() / SCANNING_SPEED_MM_PER_S
            });
            irradiation.push((mu * rate).max(MIN_SPOT_TIME_S));
        }
        for i in 0..layer.spots.len() {
            let scanned: f64 = scan[..=i].iter().sum();
            let irradiated: f64 = irradiation[..i].iter().sum();
            starts.push(total + scanned + irradiated);
        }
        total += scan.iter().sum::<f64>() + irradiation.iter().sum::<f64>();
    }
    (starts, total)
}

/// arcsim's spot start times of the same beam under `machine`: each layer's spots timed by its
/// beam model, the energy switch before every layer but the first by its ELST model.
fn arcsim_starts(layers: &[Layer], machine: &Machine) -> (Vec<f64>, f64) {
    let mut starts = Vec::new();
    let mut t = 0.0;
    for (j, layer) in layers.iter().enumerate() {
        if j > 0 {
            t += machine
                .elst
                .switch_time_s(layers[j - 1].energy_mev, layer.energy_mev);
        }
        let spots = Spots {
            count: layer.spots.len() as u32,
            mu: Some(layer.spots.iter().map(|s| s.2).collect()),
            total_mu: None,
            positions_mm: Some(layer.spots.iter().map(|s| [s.0, s.1]).collect()),
            paintings: None,
        };
        let beam_on = t;
        let time = time_spots(&spots, layer.energy_mev, &machine.beam, |e| {
            starts.push(beam_on + e.start_s)
        })
        .expect("timed");
        t += time.total_s();
    }
    (starts, t)
}

/// A static field: 5–25 layers (energies mostly falling, some rising or repeated, some outside
/// the table), 1–40 spots each at random positions with MU from 0 (below the minimum spot time)
/// to 3.
fn random_field(rng: &mut Rng) -> Vec<Layer> {
    let n = 5 + rng.below(21);
    let mut energy = rng.range(120.0, 240.0);
    (0..n)
        .map(|_| {
            let spots = (0..1 + rng.below(40))
                .map(|_| {
                    let mu = if rng.below(10) == 0 {
                        rng.range(0.0, 0.01)
                    } else {
                        rng.range(0.01, 3.0)
                    };
                    (rng.range(-80.0, 80.0), rng.range(-80.0, 80.0), mu)
                })
                .collect();
            let layer = Layer {
                energy_mev: energy,
                spots,
            };
            energy = match rng.below(8) {
                0 => energy + rng.range(0.5, 20.0),
                1 => energy,
                _ => (energy - rng.range(0.5, 12.0)).max(50.0),
            };
            layer
        })
        .collect()
}

fn machine() -> Machine {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/machine-opentps-pbs.json"
    );
    load_machine(path).expect("scenarios/machine-opentps-pbs.json")
}

#[test]
fn the_opentps_machine_gives_opentps_spot_times() {
    let machine = machine();
    let BeamModel::Scanning(beam) = &machine.beam else {
        panic!("the OpenTPS machine has a scanning beam");
    };
    assert_eq!(beam.scan_distance, ScanDistance::Euclidean);
    let mut rng = Rng::new(0x0b7_2026);
    for e in [
        10.0, 60.0, 65.0, 118.0, 125.0, 135.0, 149.0, 151.0, 226.9, 300.0,
    ] {
        let (ours, theirs) = (beam.s_per_mu_at(e), s_per_mu(e));
        assert!(
            (ours - theirs).abs() <= 1e-15,
            "{e} MeV: {ours} vs {theirs}"
        );
    }
    for case in 0..300 {
        let field = random_field(&mut rng);
        let (want, want_end) = opentps_starts(&field);
        let (got, got_end) = arcsim_starts(&field, &machine);
        assert_eq!(got.len(), want.len(), "case {case}");
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert!(
                (g - w).abs() <= 1e-9 * w.max(1.0),
                "case {case}, spot {i}: arcsim starts it at {g} s, OpenTPS at {w} s"
            );
        }
        assert!(
            (got_end - want_end).abs() <= 1e-9 * want_end,
            "case {case}: the beam ends at {got_end} s, OpenTPS {want_end} s"
        );
    }
}

/// The same fields with the slower axis setting the move (`per_axis`) come out shorter than
/// OpenTPS's: the check above can tell the two apart.
#[test]
fn per_axis_scanning_is_not_opentps() {
    let mut machine = machine();
    if let BeamModel::Scanning(beam) = &mut machine.beam {
        beam.scan_distance = ScanDistance::PerAxis;
    }
    let mut rng = Rng::new(0x0b7_2026);
    let field = random_field(&mut rng);
    let (_, want_end) = opentps_starts(&field);
    let (_, got_end) = arcsim_starts(&field, &machine);
    assert!(got_end < want_end - 1e-6, "{got_end} vs {want_end}");
}
