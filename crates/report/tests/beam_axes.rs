//! The beam axes in a report: like the ELST and window axes, each value of the dose-rate scale
//! gets heatmaps of its own (J × A at each V), named with the axis and its unit, and the axis has
//! its sensitivity bar.

use std::path::Path;

use arcsim_evaluator::{Evaluator, Sweep};
use arcsim_report::{build, FigureKind};

#[test]
fn each_dose_rate_scale_gets_its_own_heatmaps() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios");
    let text = r#"{"format": "arcsim-sweep/1", "name": "beam", "plans": ["../plans/prostate.json"],
        "machine": "machine-atom.json",
        "axes": {"jerk_deg_per_s3": [0.5, 1], "accel_deg_per_s2": [0.5, 1], "dose_rate_scale": [1, 2]},
        "schedules": ["scan"]}"#;
    let sweep = Sweep::from_text(text, "beam.json", &dir, &|p: &Path| {
        arcsim_plan::load_plan(p).map_err(|e| e.to_string())
    })
    .expect("sweep");
    let ev = Evaluator::new(sweep).expect("prepare");
    assert_eq!(ev.len(), 8);
    let rows = ev.run_collect(&(0..ev.len()).collect::<Vec<_>>());
    let summary = ev.summarize(&rows);
    let report = build(&ev, &rows, &summary).expect("report");
    let section = &report.sections[0];
    let heatmaps: Vec<(f64, &str, &str)> = section
        .figures
        .iter()
        .filter_map(|f| match &f.kind {
            FigureKind::Heatmap {
                speed_deg_per_s,
                others,
            } => Some((*speed_deg_per_s, others.as_str(), f.file_stem.as_str())),
            _ => None,
        })
        .collect();
    assert_eq!(
        heatmaps.iter().map(|h| (h.0, h.1)).collect::<Vec<_>>(),
        [(5.0, "dose rate 1 ×"), (5.0, "dose rate 2 ×")],
        "{heatmaps:?}"
    );
    assert_ne!(heatmaps[0].2, heatmaps[1].2, "file names differ");
    let sensitivity = section
        .figures
        .iter()
        .find(|f| f.kind == FigureKind::Sensitivity)
        .expect("sensitivity figure");
    assert!(
        sensitivity.svg.contains("dose rate (base 1 ×)"),
        "{}",
        sensitivity.svg
    );
    // Each heatmap holds its own scale's totals: the J 0.5, A 0.5 cell at scale 2 is row 4's.
    let total = |i: usize| rows[i].outcome.expect("ok").total_s;
    assert!(total(4) < total(0), "twice the dose rate is faster");
    let svg = |k: usize| {
        &section
            .figures
            .iter()
            .filter(|f| matches!(f.kind, FigureKind::Heatmap { .. }))
            .nth(k)
            .expect("heatmap")
            .svg
    };
    assert!(svg(0).contains(&format!("{:.1}", total(0))), "{}", svg(0));
    assert!(svg(1).contains(&format!("{:.1}", total(4))), "{}", svg(1));
}
