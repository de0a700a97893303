//! What clinics' records cost (issue 46): a DICOM RT Ion Beams Treatment Record of a 299-layer
//! plan (the prostate kind at 1.2° spacing) read and compared with its simulation (goal: ≤ 1 s
//! on 2 cores), and the spot-level fit of a scanning beam on the bundled prostate's per-spot
//! log (6,627 spot deliveries), and the 299-layer plan's IBA-style log on a scanning machine read
//! and compared (its 0.25 ms spot records). `cargo bench --bench records`

#![allow(
    clippy::too_many_lines,
    reason = "the 100-line rule is for the crates' code; a test or benchmark reads top to bottom"
)]

use std::hint::black_box;
use std::time::Duration;

use arcsim_dicom::{
    read_delivery_log, treatment_record_bytes, BeamOnInterval, RecordStart, RecordedBeam,
};
use arcsim_log::iba::{iba_log_files, IbaLayout, IbaNozzle};
use arcsim_log::{calibrate_spots, compare, BeamInterval, ColumnMap, LoggedSpot, SpotLog, SpotRun};
use arcsim_plan::{generate_shaped, load_machine, load_plan, resolve, PlanKind, Shape};
use arcsim_sequencer::{machine_limits, simulate_resolved, spot_timeline, Options, Schedule};
use criterion::{criterion_group, criterion_main, Criterion};

fn bench_record(c: &mut Criterion) {
    let root = arcsim_suite::repo_root();
    let shape = Shape {
        spacing_deg: Some(1.2),
        layers_per_cp: None,
        energy_mev: None,
        spot_spacing_mm: None,
    };
    let plan = generate_shaped(PlanKind::Prostate, 1, &shape).expect("plan");
    let atom = load_machine(root.join("scenarios/machine-atom.json")).expect("atom");
    let opts = Options::new(Schedule::Optimal);
    let arcs = resolve(&plan, &atom).expect("resolves");
    let limits = machine_limits(&atom).expect("limits");
    let delivered = simulate_resolved(&arcs, &limits, &opts).expect("simulated");
    let planned: Vec<_> = arcs.iter().flat_map(|a| a.layers.iter()).collect();
    let mut beams: Vec<RecordedBeam> = Vec::new();
    for row in &delivered.layers {
        let tl = delivered.timeline.as_ref().expect("timeline");
        let interval = BeamOnInterval {
            control_point: 0,
            interval: BeamInterval {
                start_s: row.t_start_s,
                end_s: row.t_end_s,
                angle_start_deg: tl.state_at(row.t_start_s).angle_deg,
                angle_end_deg: tl.state_at(row.t_end_s).angle_deg,
                energy_mev: row.energy_mev,
                mu: planned[row.index].mu,
            },
        };
        let number = i64::try_from(row.arc).expect("arc") + 1;
        match beams.last_mut() {
            Some(b) if b.beam_number == Some(number) => b.intervals.push(interval),
            _ => beams.push(RecordedBeam {
                beam_number: Some(number),
                termination: Some("NORMAL".into()),
                intervals: vec![interval],
            }),
        }
    }
    let start = RecordStart::parse("20260101080000").expect("start");
    let (bytes, _) = treatment_record_bytes(&beams, start, 3, None).expect("record");
    let path = std::env::temp_dir().join(format!("arcsim-bench-record-{}.dcm", std::process::id()));
    std::fs::write(&path, &bytes).expect("record written");
    let map = ColumnMap::default();
    let layers = delivered.layers.len();
    let mut group = c.benchmark_group("records");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(20));
    group.bench_function(
        format!("read and compare a treatment record ({layers} layers), the simulation included"),
        |b| {
            b.iter(|| {
                let log = read_delivery_log(black_box(&path), &map, None).expect("reads");
                let sim = simulate_resolved(&arcs, &limits, &opts).expect("simulated");
                black_box(
                    compare(&arcs, &sim, &[], &log)
                        .expect("compare")
                        .difference_s,
                )
            })
        },
    );
    let prostate = load_plan(root.join("plans/prostate.json")).expect("plan");
    let scanning =
        load_machine(root.join("scenarios/machine-proteusone-like.json")).expect("machine");
    let arcs = resolve(&prostate, &scanning).expect("resolves");
    let limits = machine_limits(&scanning).expect("limits");
    let sim = simulate_resolved(&arcs, &limits, &opts).expect("simulated");
    let spots: Vec<LoggedSpot> = spot_timeline(&prostate, &scanning, &sim)
        .expect("spots")
        .iter()
        .enumerate()
        .map(|(i, s)| LoggedSpot {
            arc: s.arc,
            control_point: s.control_point,
            layer: s.layer,
            painting: s.painting,
            x_mm: s.x_mm.expect("x"),
            y_mm: s.y_mm.expect("y"),
            mu: s.mu,
            t_start_s: s.t_start_s,
            t_end_s: s.t_end_s,
            line: i as u64 + 2,
        })
        .collect();
    let n = spots.len();
    let runs = [SpotRun {
        plan_name: "prostate".into(),
        plan: prostate.clone(),
        log: SpotLog {
            time_step_s: None,
            source: "prostate-spots.csv".into(),
            spots,
        },
    }];
    group.bench_function(
        format!("calibrate-spots on prostate ({n} spot deliveries)"),
        |b| b.iter(|| black_box(calibrate_spots(&scanning, &runs).expect("fit").values.len())),
    );
    // The same plan's IBA-style log on a scanning machine: read and compared.
    let pbs = load_machine(root.join("scenarios/machine-opentps-pbs.json")).expect("machine");
    let arcs = resolve(&plan, &pbs).expect("resolves");
    let limits = machine_limits(&pbs).expect("limits");
    let sim = simulate_resolved(&arcs, &limits, &opts).expect("simulated");
    let rows = spot_timeline(&plan, &pbs, &sim).expect("spots");
    let start = arcsim_log::iba::start_seconds("20260101080000").expect("start");
    let dir = std::env::temp_dir().join(format!("arcsim-bench-iba-{}", std::process::id()));
    for (rel, text) in iba_log_files(&sim, &rows, start, &IbaNozzle::default(), IbaLayout::Rows) {
        let file = dir.join(rel);
        std::fs::create_dir_all(file.parent().expect("folder")).expect("folder");
        std::fs::write(file, text).expect("written");
    }
    group.bench_function(
        format!("read and compare an IBA-style log ({layers} layers, {} spots), the simulation included", rows.len()),
        |b| {
            b.iter(|| {
                let log = read_delivery_log(black_box(&dir), &map, None).expect("reads");
                let sim = simulate_resolved(&arcs, &limits, &opts).expect("simulated");
                black_box(
                    compare(&arcs, &sim, &[], &log)
                        .expect("compare")
                        .difference_s,
                )
            })
        },
    );
    group.finish();
    let _ = std::fs::remove_file(&path);
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, bench_record);
criterion_main!(benches);
