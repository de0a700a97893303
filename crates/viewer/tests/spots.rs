//! The beam's-eye view of the spots: written to .rrd files and read back with Rerun's decoder.

use std::path::{Path, PathBuf};

use crate::util::{out_path, read_rrd, Rrd};
use arcsim_sequencer::SpotRow;
use arcsim_viewer::rerun::log::{Chunk, RowId};
use arcsim_viewer::rerun::time::TimeInt;
use arcsim_viewer::rerun::TimelineName;
use arcsim_viewer::rerun::{self, ComponentIdentifier, RecordingStreamBuilder};
use arcsim_viewer::{paths, timelines, MAX_SPOT_UPDATES_PER_LAYER};

/// One temporal row of one component: time (ns), row id (order at equal times), values.
type Row<T> = (TimeInt, RowId, Vec<T>);

impl Rrd {
    /// Temporal rows of `component` at `path` on the `time` timeline, in logging order;
    /// `slices` reads the component's values of every (non-null) row of a chunk.
    fn logged_rows<T>(
        &self,
        path: &str,
        component: ComponentIdentifier,
        slices: impl Fn(&Chunk) -> Vec<Vec<T>>,
    ) -> Vec<Row<T>> {
        let time = TimelineName::from_static_str(timelines::TIME);
        let mut rows = vec![];
        for chunk in self.chunks(path).iter().filter(|c| !c.is_static()) {
            let indices = chunk.iter_component_indices(time, component);
            for ((t, id), values) in indices.zip(slices(chunk)) {
                rows.push((t, id, values));
            }
        }
        rows.sort_by_key(|r| (r.0, r.1));
        rows
    }

    fn positions(&self, path: &str) -> Vec<Row<[f32; 2]>> {
        let component = rerun::Points2D::descriptor_positions().component;
        self.logged_rows(path, component, |c| {
            c.iter_slices::<[f32; 2]>(component)
                .map(<[[f32; 2]]>::to_vec)
                .collect()
        })
    }

    fn colors(&self, path: &str) -> Vec<Row<u32>> {
        let component = rerun::Points2D::descriptor_colors().component;
        self.logged_rows(path, component, |c| {
            c.iter_slices::<u32>(component)
                .map(<[u32]>::to_vec)
                .collect()
        })
    }

    fn labels(&self, path: &str) -> Vec<Row<String>> {
        let component = rerun::Boxes2D::descriptor_labels().component;
        self.logged_rows(path, component, |c| {
            c.iter_slices::<String>(component)
                .map(|r| r.iter().map(|s| s.to_string()).collect())
                .collect()
        })
    }

    fn is_static(&self, path: &str) -> bool {
        self.chunks(path).iter().any(Chunk::is_static)
    }
}

/// The values of the last row at or before `t_s` (latest-at, as the viewer shows them).
fn latest_at<T: Clone>(rows: &[Row<T>], t_s: f64) -> Vec<T> {
    let t = TimeInt::new_temporal((t_s * 1e9).round() as i64);
    rows.iter()
        .rev()
        .find(|r| r.0 <= t)
        .map(|r| r.2.clone())
        .unwrap_or_default()
}

/// A spot row of layer `layer_index`, delivered from `t` for 0.1 s.
fn row(
    layer_index: usize,
    spot: usize,
    painting: usize,
    pos: Option<[f64; 2]>,
    mu: f64,
    t: f64,
) -> SpotRow {
    SpotRow {
        layer_index,
        arc: 0,
        control_point: layer_index,
        layer: 0,
        spot,
        painting,
        burst: None,
        spill: None,
        x_mm: pos.map(|p| p[0]),
        y_mm: pos.map(|p| p[1]),
        mu,
        t_start_s: t,
        t_end_s: t + 0.1,
        angle_start_deg: 10.0 * layer_index as f64 + t,
        angle_end_deg: 10.0 * layer_index as f64 + t + 0.1,
    }
}

/// Layer 0: four spots (1.0–1.4 s); layer 1: no positions (skipped); layer 2: three spots
/// painted twice (3.0–3.6 s), each painting a burst and a spill.
fn synthetic() -> Vec<SpotRow> {
    let mut rows = vec![];
    let layer0 = [[-10.0, -5.0], [0.0, -5.0], [10.0, -5.0], [0.0, 5.0]];
    for (k, p) in layer0.into_iter().enumerate() {
        rows.push(row(
            0,
            k,
            0,
            Some(p),
            0.1 * (k + 1) as f64,
            1.0 + 0.1 * k as f64,
        ));
    }
    for k in 0..3 {
        rows.push(row(1, k, 0, None, 0.2, 2.0 + 0.1 * k as f64));
    }
    let mut t = 3.0;
    for painting in 0..2 {
        for (k, p) in [[-4.0, 0.0], [0.0, 0.0], [4.0, 0.0]]
            .into_iter()
            .enumerate()
        {
            let mut r = row(2, k, painting, Some(p), 0.05, t);
            // Each painting a burst, delivered from spills 7 and 8.
            r.burst = Some(painting);
            r.spill = Some(7 + painting);
            rows.push(r);
            t += 0.1;
        }
    }
    rows
}

fn write(name: &str, spots: &[SpotRow], energies: &[f64]) -> PathBuf {
    let path = out_path(name);
    let rec = RecordingStreamBuilder::new(arcsim_viewer::DELIVERY_APP_ID)
        .enabled(true)
        .save(&path)
        .expect("rrd");
    arcsim_viewer::send_delivery_blueprint(&rec, true).expect("blueprint");
    arcsim_viewer::log_spots(&rec, spots, energies).expect("log spots");
    rec.flush_blocking().expect("flush");
    drop(rec);
    path
}

#[test]
fn spots_are_lit_as_delivered() {
    let spots = synthetic();
    let path = write("spots.rrd", &spots, &[150.0, 140.0, 130.5]);
    let rrd = read_rrd(&path);

    assert!(
        rrd.blueprint_names
            .iter()
            .any(|n| n.starts_with("Beam's-eye view")),
        "{:?}",
        rrd.blueprint_names
    );
    assert!(rrd.is_static(paths::BEV_AXES));

    // Positions: each drawable layer at its first spot's start, cleared at its last spot's end.
    let positions = rrd.positions(paths::BEV_SPOTS);
    let counts: Vec<(i64, usize)> = positions
        .iter()
        .map(|r| (r.0.as_i64(), r.2.len()))
        .collect();
    let ns = |s: f64| (s * 1e9).round() as i64;
    assert_eq!(
        counts,
        vec![(ns(1.0), 4), (ns(1.4), 0), (ns(3.0), 3), (ns(3.6), 0)],
        "layer 1 has no positions and is skipped; a repainted spot is one point"
    );
    // y points up on screen.
    assert_eq!(latest_at(&positions, 1.05)[3], [0.0, -5.0]);
    for t in [0.5, 1.45, 2.1, 3.65, 10.0] {
        assert!(
            latest_at(&positions, t).is_empty(),
            "nothing shown at {t} s"
        );
    }

    // Inside layer 0 (4 rows: one update per spot), after two spots.
    let colors = rrd.colors(paths::BEV_SPOTS);
    let at = latest_at(&colors, 1.15);
    assert_eq!(at.len(), 4, "one colour per point");
    let pending = at[3];
    assert_eq!(at[2], pending, "spot 2 pending at 1.15 s");
    assert!(at[0] != pending && at[1] != pending, "{at:x?}");
    assert!(at[0] != at[1], "different MU, different colour");
    // At the last spot all are lit; the highest MU is the brightest.
    let all = latest_at(&colors, 1.35);
    assert!(all.iter().all(|&c| c != pending), "{all:x?}");
    let luma = |c: u32| {
        let [r, g, b, _] = c.to_be_bytes();
        0.2126 * f64::from(r) + 0.7152 * f64::from(g) + 0.0722 * f64::from(b)
    };
    assert!(all.windows(2).all(|w| luma(w[0]) < luma(w[1])), "{all:x?}");
    // Repainting: after one painting a spot is dimmer than after both.
    let half = latest_at(&colors, 3.25);
    let full = latest_at(&colors, 3.55);
    assert!(half.iter().all(|&c| c != pending));
    assert!(luma(half[0]) < luma(full[0]), "{half:x?} {full:x?}");

    // The spot being irradiated is highlighted.
    let current = rrd.positions(paths::BEV_CURRENT);
    assert_eq!(latest_at(&current, 1.15), vec![[0.0, 5.0]]);
    assert!(latest_at(&current, 1.45).is_empty());

    // The layer's label names index, energy and painting.
    let labels = rrd.labels(paths::BEV_LAYER);
    let label = latest_at(&labels, 3.45);
    assert_eq!(label.len(), 1);
    assert!(
        label[0].starts_with("layer 2 ")
            && label[0].contains("130.5 MeV")
            && label[0].contains("painting 2 of 2, burst 2, spill 8:"),
        "{label:?}"
    );
    let first = latest_at(&labels, 3.05);
    assert!(
        first[0].contains("painting 1 of 2, burst 1, spill 7:"),
        "{first:?}"
    );
    // No bursts or spills: the label does not mention them.
    let plain = latest_at(&labels, 1.05);
    assert!(
        !plain[0].contains("burst") && !plain[0].contains("spill"),
        "{plain:?}"
    );
    assert!(latest_at(&labels, 3.7).is_empty());

    // Both timelines on every temporal chunk.
    let angle = TimelineName::from_static_str(timelines::ANGLE_CDEG);
    for p in [paths::BEV_SPOTS, paths::BEV_CURRENT, paths::BEV_LAYER] {
        for c in rrd.chunks(p).iter().filter(|c| !c.is_static()) {
            assert!(c.timelines().contains_key(&angle), "{p}: angle timeline");
        }
    }
}

#[test]
fn a_large_layer_logs_a_bounded_number_of_updates() {
    let n = 10_000;
    let spots: Vec<SpotRow> = (0..n)
        .map(|k| {
            let pos = [(k % 100) as f64, (k / 100) as f64];
            row(
                0,
                k,
                0,
                Some(pos),
                1.0 + (k % 7) as f64,
                1.0 + 1e-3 * k as f64,
            )
        })
        .collect();
    let path = write("spots-large.rrd", &spots, &[]);
    let rrd = read_rrd(&path);

    let colors = rrd.colors(paths::BEV_SPOTS);
    assert_eq!(
        colors.len(),
        MAX_SPOT_UPDATES_PER_LAYER + 1,
        "the updates and the clear"
    );
    let logged: usize = colors.iter().map(|r| r.2.len()).sum();
    assert_eq!(logged, MAX_SPOT_UPDATES_PER_LAYER * n);
    let positions = rrd.positions(paths::BEV_SPOTS);
    assert_eq!(positions.len(), 2, "positions once, then the clear");
    assert_eq!(positions[0].2.len(), n);
    let current = rrd.positions(paths::BEV_CURRENT);
    assert_eq!(current.len(), MAX_SPOT_UPDATES_PER_LAYER + 1);
    assert_eq!(current.iter().map(|r| r.2.len()).sum::<usize>(), n);

    // Halfway, about half the spots are lit.
    let pending = latest_at(&colors, 0.999)
        .is_empty()
        .then(|| latest_at(&colors, 1.0)[n - 1])
        .expect("nothing before the layer");
    let mid = latest_at(&colors, 1.0 + 1e-3 * n as f64 / 2.0);
    let lit = mid.iter().filter(|&&c| c != pending).count();
    assert!((n / 2..=n / 2 + n / 32).contains(&lit), "{lit} lit");
}

#[test]
fn no_positions_log_nothing() {
    let spots: Vec<SpotRow> = (0..5).map(|k| row(0, k, 0, None, 1.0, k as f64)).collect();
    let path = write("spots-none.rrd", &spots, &[]);
    let rrd = read_rrd(&path);
    assert!(
        !rrd.entities.keys().any(|k| k.starts_with("/beam_eye_view")),
        "{:?}",
        rrd.entities.keys()
    );
}

/// `save_delivery` with spots lays the view out and names each layer's energy; without
/// positioned spots it writes what `save_delivery` writes.
#[test]
fn save_delivery_with_spots_adds_the_view() {
    use arcsim_sequencer::{simulate, Options, Schedule};
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let plan = arcsim_plan::load_plan(root.join("plans/prostate.json")).expect("plan");
    let machine =
        arcsim_plan::load_machine(root.join("scenarios/machine-atom.json")).expect("machine");
    let d = simulate(&plan, &machine, &Options::new(Schedule::Scan)).expect("simulation");
    // Five spots spread over each of the first three layers' beam-on.
    let mut spots = vec![];
    for l in d.layers.iter().take(3) {
        let dt = (l.t_end_s - l.t_start_s) / 5.0;
        for k in 0..5 {
            let mut r = row(
                l.index,
                k,
                0,
                Some([k as f64, 0.0]),
                1.0,
                l.t_start_s + dt * k as f64,
            );
            r.t_end_s = r.t_start_s + dt;
            spots.push(r);
        }
    }
    let opts = arcsim_viewer::ViewerOptions { sample_dt_s: 0.1 };

    let path = out_path("delivery-spots.rrd");
    arcsim_viewer::save_delivery(&path, "spots", &d, &spots, &opts).expect("save");
    let rrd = read_rrd(&path);
    assert!(rrd
        .blueprint_names
        .iter()
        .any(|n| n.starts_with("Beam's-eye view")));
    rrd.chunks(paths::SPEED);
    assert_eq!(
        rrd.positions(paths::BEV_SPOTS).len(),
        6,
        "three layers, each shown and cleared"
    );
    let l = &d.layers[1];
    let label = latest_at(
        &rrd.labels(paths::BEV_LAYER),
        (l.t_start_s + l.t_end_s) / 2.0,
    );
    assert!(
        label[0].starts_with("layer 1 ") && label[0].contains(&format!("{:.1} MeV", l.energy_mev)),
        "{label:?}"
    );

    let plain = out_path("delivery-no-spots.rrd");
    for r in &mut spots {
        r.x_mm = None;
    }
    arcsim_viewer::save_delivery(&plain, "no spots", &d, &spots, &opts).expect("save");
    let rrd = read_rrd(&plain);
    assert!(!rrd
        .blueprint_names
        .iter()
        .any(|n| n.starts_with("Beam's-eye view")));
    assert!(!rrd.entities.keys().any(|k| k.starts_with("/beam_eye_view")));
}
