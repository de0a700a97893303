//! arcsim's reading of IBA-style logs against two public readers': REGGUI's `load_PBS_logs.m`
//! and OncoRay's `logfile_extractor.py`, run on the same folders (tests/data/reggui/README.md
//! says how). Each spot's position, MU and time agree, up to each reader's stated convention:
//! REGGUI places a layer at its millisecond `START_IRRADIATION` stamp where arcsim places it
//! mid-way in what the stamp allows, ends an element-layout spot at its last element where
//! arcsim adds the element period, and gives a 250 µs-row spot the charge of the two rows
//! before it where arcsim counts only the spot's own; OncoRay keeps only the stamp of a spot's
//! last row.

use std::path::PathBuf;

use arcsim_log::iba::{read_iba_log, SAMPLE_PERIOD_S};

fn data(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/reggui")
        .join(rel)
}

/// One spot as REGGUI gives it: layer (from 1), times in s, position (mm), MU.
struct Reggui {
    layer: usize,
    start_s: f64,
    stop_s: f64,
    xy_mm: [f64; 2],
    mu: f64,
}

fn reggui(layout: &str) -> Vec<Reggui> {
    let text = std::fs::read_to_string(data(&format!("{layout}.csv"))).expect("REGGUI's output");
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|v| v.parse().expect("a number")).collect();
            Reggui {
                layer: f[0] as usize,
                start_s: f[2] * 1e-6,
                stop_s: f[3] * 1e-6,
                xy_mm: [f[4], f[5]],
                mu: f[6],
            }
        })
        .collect()
}

/// Both readers' spots of `layout`, layer by layer: (arcsim's start, end, x, y, MU, REGGUI's).
fn both(layout: &str) -> Vec<Vec<([f64; 5], Reggui)>> {
    let log = read_iba_log(&data(layout)).expect("arcsim reads the folder");
    assert_eq!(log.beams.len(), 1);
    let beam = &log.beams[0];
    let per_coulomb = beam.mu_per_coulomb.expect("a charge per MU");
    let mut theirs = reggui(layout).into_iter().peekable();
    let mut out = Vec::new();
    for (k, layer) in beam.layers.iter().enumerate() {
        let mut pairs = Vec::new();
        for s in &layer.spots {
            let r = theirs.next().expect("REGGUI has as many spots");
            assert_eq!(r.layer, k + 1, "{layout}: layer {k}: spot counts differ");
            pairs.push((
                [
                    s.t_start_s,
                    s.t_end_s,
                    s.x_mm,
                    s.y_mm,
                    s.charge_c * per_coulomb,
                ],
                r,
            ));
        }
        assert!(
            theirs.peek().is_none_or(|r| r.layer != k + 1),
            "{layout}: layer {k}: REGGUI has more spots"
        );
        out.push(pairs);
    }
    assert!(theirs.next().is_none(), "{layout}: REGGUI has more layers");
    assert_eq!(out.len(), 4, "{layout}");
    out
}

/// Positions agree to the files' rounding (0.1 µm on the chamber, scaled to the isocentre).
fn positions_agree(layout: &str, layers: &[Vec<([f64; 5], Reggui)>]) {
    for (ours, r) in layers.iter().flatten() {
        for (a, b) in [(ours[2], r.xy_mm[0]), (ours[3], r.xy_mm[1])] {
            assert!(
                (a - b).abs() < 2e-4,
                "{layout}: position {a} against REGGUI's {b}"
            );
        }
    }
}

/// The element layouts: times agree once each reader's convention is applied (arcsim places
/// each layer half the stamp's millisecond later, and adds `period_s` to an element-layout
/// spot's end where REGGUI adds `reggui_tail_s`); MU to the files' rounding.
fn element_layout_agrees(layout: &str, period_s: f64, reggui_tail_s: f64) {
    let layers = both(layout);
    positions_agree(layout, &layers);
    for (ours, r) in layers.iter().flatten() {
        let shift = 0.5e-3;
        let (ds, de) = (
            ours[0] - (r.start_s + shift),
            ours[1] - (r.stop_s - reggui_tail_s + period_s + shift),
        );
        // Both are counted from the log's first spot: REGGUI's from midnight.
        let origin = layers[0][0].1.start_s + shift - layers[0][0].0[0];
        assert!(
            (ds + origin).abs() < 1e-6 && (de + origin).abs() < 1e-6,
            "{layout}: start {} end {} against REGGUI's {} {}",
            ours[0],
            ours[1],
            r.start_s - origin,
            r.stop_s - origin
        );
        assert!(
            (ours[4] - r.mu).abs() < 1e-6,
            "{layout}: MU {} against {}",
            ours[4],
            r.mu
        );
    }
}

#[test]
fn the_element_layout_reads_as_reggui_reads_it() {
    element_layout_agrees("elements", SAMPLE_PERIOD_S, 0.0);
}

#[test]
fn a_synchrocyclotrons_burst_records_read_as_reggui_reads_them() {
    element_layout_agrees("bursts", 1e-3, 1e-3);
}

/// The 250 µs rows: a spot's rows are the same for both readers (durations agree); its start
/// within a row of REGGUI's (which places a row from its millisecond stamp and the count of
/// rows sharing it); its MU the same where the two rows before it hold no charge, else REGGUI's
/// larger by at most two rows of the spot before.
#[test]
fn the_row_layout_reads_as_reggui_reads_it() {
    let layers = both("rows");
    positions_agree("rows", &layers);
    let first = &layers[0][0];
    let origin = first.1.start_s - first.0[0];
    for layer in &layers {
        for (i, (ours, r)) in layer.iter().enumerate() {
            let start = r.start_s - origin;
            assert!(
                (ours[0] - start).abs() <= SAMPLE_PERIOD_S,
                "rows: start {} against REGGUI's {start}",
                ours[0]
            );
            let (d_ours, d_theirs) = (ours[1] - ours[0], r.stop_s - r.start_s);
            assert!(
                (d_ours - d_theirs).abs() < 1e-6,
                "rows: duration {d_ours} against {d_theirs}"
            );
            let extra = r.mu - ours[4];
            match i.checked_sub(1).map(|j| &layer[j].0) {
                Some(prev) if ours[0] - prev[1] < 2.0 * SAMPLE_PERIOD_S - 1e-9 => {
                    let per_row = prev[4] / ((prev[1] - prev[0]) / SAMPLE_PERIOD_S).round();
                    assert!(
                        extra > -1e-6 && extra < 2.0 * per_row + 1e-6,
                        "rows: MU {} against REGGUI's {} (a row's MU before: {per_row})",
                        ours[4],
                        r.mu
                    );
                }
                _ => assert!(
                    extra.abs() < 1e-6,
                    "rows: MU {} against REGGUI's {}",
                    ours[4],
                    r.mu
                ),
            }
        }
    }
}

/// OncoRay's reader on the same rows (tests/data/reggui/README.md says how it was run): the same
/// spots; positions (it takes the mean of a spot's rows, arcsim the last: one here) and MU (its
/// air-density correction is arcsim's) to the files' rounding; its drill time (rows × 0.25 ms)
/// is arcsim's duration; its time, the millisecond stamp of the spot's last row, holds arcsim's
/// time of that row (its end less a row) to within the stamp.
#[test]
fn the_row_layout_reads_as_oncorays_reader_reads_it() {
    let log = read_iba_log(&data("rows")).expect("arcsim reads the folder");
    let beam = &log.beams[0];
    let per_coulomb = beam.mu_per_coulomb.expect("a charge per MU");
    let text = std::fs::read_to_string(data("rows-oncoray.csv")).expect("OncoRay's output");
    let theirs: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().expect("a number")).collect())
        .collect();
    let ours: Vec<(usize, &arcsim_log::iba::IbaSpot)> = beam
        .layers
        .iter()
        .enumerate()
        .flat_map(|(k, l)| l.spots.iter().map(move |s| (k + 1, s)))
        .collect();
    assert_eq!(ours.len(), theirs.len(), "spot counts differ");
    // The log starts at 08:00:00 plus the first spot's place in its first millisecond: arcsim
    // counts from the first spot's start, OncoRay from 08:00.
    let first_start = reggui("rows")[0].start_s - 8.0 * 3600.0;
    for ((layer, s), o) in ours.iter().zip(&theirs) {
        assert_eq!(*layer, o[0] as usize, "layer of spot {o:?}");
        assert!(
            (s.x_mm - o[3]).abs() < 2e-4 && (s.y_mm - o[4]).abs() < 2e-4,
            "{s:?} {o:?}"
        );
        assert!(
            (s.charge_c * per_coulomb - o[5]).abs() < 1e-6,
            "MU: {s:?} {o:?}"
        );
        assert!(
            (s.t_end_s - s.t_start_s - o[6]).abs() < 1e-9,
            "duration: {s:?} {o:?}"
        );
        let last_row = first_start + s.t_end_s - SAMPLE_PERIOD_S;
        assert!(
            last_row >= o[2] - SAMPLE_PERIOD_S && last_row < o[2] + 1e-3 + SAMPLE_PERIOD_S,
            "last row at {last_row} s, stamped {} s",
            o[2]
        );
    }
}
