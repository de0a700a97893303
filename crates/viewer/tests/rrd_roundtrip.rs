//! Writes deliveries to .rrd files, reads them back with Rerun's own decoder (the `rrd` feature)
//! and checks entity paths, timelines and values against the simulated timeline.

use std::path::{Path, PathBuf};

use crate::util::{out_path, read_rrd, Rrd};
use arcsim_sequencer::{simulate, Delivery, Options, Schedule};
use arcsim_viewer::rerun::log::Chunk;
use arcsim_viewer::rerun::{self, TimelineName};
use arcsim_viewer::{paths, save_delivery, timelines, ViewerError, ViewerOptions};

fn repo_file(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(rel)
}

fn simulated(plan: &str, schedule: Schedule) -> Delivery {
    let plan = arcsim_plan::load_plan(repo_file(plan)).expect("plan");
    let machine =
        arcsim_plan::load_machine(repo_file("scenarios/machine-atom.json")).expect("machine");
    simulate(&plan, &machine, &Options::new(schedule)).expect("simulation")
}

/// One logged row: its `time` (s), its `angle_cdeg`, and the row's values of one component.
#[derive(Debug)]
struct Row<T> {
    t: f64,
    angle_cdeg: i64,
    values: Vec<T>,
}

impl Rrd {
    /// Temporal rows of `path`, in time order (stable, so rows logged at one instant keep their order).
    fn rows<T: Clone>(
        &self,
        path: &str,
        component: rerun::ComponentIdentifier,
        slices: impl Fn(&Chunk) -> Vec<Vec<T>>,
    ) -> Vec<Row<T>> {
        let mut rows = vec![];
        for chunk in self.chunks(path).iter().filter(|c| !c.is_static()) {
            let time = chunk
                .timelines()
                .get(&TimelineName::from_static_str(timelines::TIME))
                .expect("time timeline");
            let angle = chunk
                .timelines()
                .get(&TimelineName::from_static_str(timelines::ANGLE_CDEG))
                .expect("angle timeline");
            let values = slices(chunk);
            assert_eq!(
                values.len(),
                chunk.num_rows(),
                "{path}: {component} in every row"
            );
            for ((&ns, &cdeg), values) in time.times_raw().iter().zip(angle.times_raw()).zip(values)
            {
                rows.push(Row {
                    t: ns as f64 * 1e-9,
                    angle_cdeg: cdeg,
                    values,
                });
            }
        }
        rows.sort_by(|a, b| a.t.total_cmp(&b.t));
        rows
    }

    fn scalar_rows(&self, path: &str) -> Vec<Row<f64>> {
        let component = rerun::Scalars::descriptor_scalars().component;
        self.rows(path, component, |c| {
            c.iter_slices::<f64>(component)
                .map(<[f64]>::to_vec)
                .collect()
        })
    }

    fn text_rows(&self, path: &str, component: rerun::ComponentIdentifier) -> Vec<Row<String>> {
        self.rows(path, component, |c| {
            c.iter_slices::<String>(component)
                .map(|row| row.iter().map(|s| s.to_string()).collect())
                .collect()
        })
    }
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + b.abs())
}

#[test]
fn prostate_scan_round_trip() {
    let d = simulated("plans/prostate.json", Schedule::Scan);
    let tl = d.timeline.as_ref().expect("timeline");
    let opts = ViewerOptions { sample_dt_s: 0.05 };
    let path = out_path("prostate-scan.rrd");
    save_delivery(&path, "prostate (scan)", &d, &[], &opts).expect("save");
    let rrd = read_rrd(&path);

    for p in [
        paths::ANGLE,
        paths::SPEED,
        paths::ACCEL,
        paths::JERK,
        paths::ENERGY,
        paths::LOST,
        paths::PHASE,
        paths::LAYERS,
        paths::GANTRY_BEAM,
        paths::GANTRY_CONTROL_POINTS,
        paths::GANTRY_RING,
        paths::GANTRY_ISOCENTRE,
    ] {
        rrd.chunks(p);
    }
    // Lost time: each transition's, held over it; the values add up to the breakdown's.
    let lost = rrd.scalar_rows(paths::LOST);
    assert_eq!(lost.len(), 2 * d.transitions.len());
    let sum: f64 = lost.iter().map(|r| r.values[0]).sum();
    assert!(
        close(sum, d.breakdown.lost_s, 1e-9),
        "{sum} vs {}",
        d.breakdown.lost_s
    );
    for (r, t) in lost.iter().step_by(2).zip(&d.transitions) {
        assert!(close(r.t, t.t_start_s, 1e-9) && r.values[0] == t.lost_s.max(0.0));
    }
    for p in [
        paths::GANTRY_CONTROL_POINTS,
        paths::GANTRY_RING,
        paths::SPEED,
    ] {
        assert!(
            rrd.static_entities.contains(&format!("/{p}")),
            "{p} has static data (style or geometry)"
        );
    }
    assert!(
        rrd.blueprint_chunks > 0 && rrd.blueprint_activated,
        "the file carries an active blueprint"
    );

    // Speed: the value equals the timeline's at the logged instant, then the limit line(s).
    let total = tl.duration_s();
    let speed = rrd.scalar_rows(paths::SPEED);
    assert!(
        speed.len() as f64 >= total / opts.sample_dt_s,
        "{} rows over {total} s",
        speed.len()
    );
    assert!(
        close(speed.last().expect("rows").t, total, 1e-9),
        "the last sample is the end of delivery"
    );
    let v = d.limits.max_speed_deg_per_s;
    let mut moving = 0;
    for r in &speed {
        let s = tl.state_at(r.t);
        assert!(
            close(r.values[0], s.speed_deg_per_s, 1e-6),
            "speed at {}: {} vs {}",
            r.t,
            r.values[0],
            s.speed_deg_per_s
        );
        assert_eq!(r.values[1..], [v], "a CW-only arc gets the +V line only");
        assert_eq!(
            r.angle_cdeg,
            (s.angle_deg * 100.0).round() as i64,
            "angle timeline at {}",
            r.t
        );
        moving += usize::from(r.values[0].abs() > 1e-9);
    }
    assert!(
        moving > speed.len() / 2,
        "the gantry moves during most of an arc delivery"
    );

    // Angle and acceleration are continuous, so they match at every row too.
    for (p, f) in [
        (
            paths::ANGLE,
            (|s| s.angle_deg) as fn(&arcsim_sequencer::GantryState) -> f64,
        ),
        (paths::ACCEL, |s| s.accel_deg_per_s2),
    ] {
        for r in rrd.scalar_rows(p) {
            assert!(
                close(r.values[0], f(&tl.state_at(r.t)), 1e-6),
                "{p} at {}",
                r.t
            );
        }
    }

    // Jerk is piecewise constant: both sides of each piece boundary are logged, and grid
    // samples away from boundaries match the timeline.
    let jerk = rrd.scalar_rows(paths::JERK);
    let j = d.limits.max_jerk_deg_per_s3;
    let boundaries: Vec<f64> = tl.pieces.iter().map(|p| p.t_start_s).collect();
    let mut checked = 0;
    for r in &jerk {
        assert!(
            r.values[0].abs() <= j * (1.0 + 1e-9),
            "|jerk| <= J at {}",
            r.t
        );
        assert_eq!(r.values[1..], [j, -j]);
        if boundaries.iter().all(|b| (b - r.t).abs() > 1e-6) {
            assert!(
                close(r.values[0], tl.state_at(r.t).jerk_deg_per_s3, 1e-9),
                "jerk at {}",
                r.t
            );
            checked += 1;
        }
    }
    assert!(checked > jerk.len() / 2);
    assert!(jerk.len() >= speed.len(), "jerk has the boundary rows too");

    // Energy: one step per layer at its beam-on start, held to the end.
    let energy = rrd.scalar_rows(paths::ENERGY);
    assert_eq!(energy.len(), d.layers.len() + 1);
    for (r, l) in energy.iter().zip(&d.layers) {
        assert!(
            close(r.t, l.t_start_s, 1e-9) && r.values == [l.energy_mev],
            "energy of layer {}",
            l.index
        );
    }

    // Phases: one "beam on" per layer; the last state resets.
    let phase = rrd.text_rows(
        paths::PHASE,
        rerun::StateChange::descriptor_state().component,
    );
    assert_eq!(
        phase.iter().filter(|r| r.values == ["beam on"]).count(),
        d.layers.len()
    );
    assert_eq!(
        phase.last().map(|r| r.values.clone()),
        Some(vec![String::new()])
    );
    let switches = d
        .transitions
        .iter()
        .filter(|t| t.elst_s > 0.0 && t.duration_s > 0.0)
        .count();
    assert_eq!(
        phase
            .iter()
            .filter(|r| r.values == ["energy switch"])
            .count(),
        switches
    );

    // Layer log: a summary, then one line per layer with its energy.
    let text = rrd.text_rows(paths::LAYERS, rerun::TextLog::descriptor_text().component);
    assert_eq!(text.len(), 1 + d.layers.len() + d.violations.len());
    assert!(
        text[0].values[0].contains(&format!("total {:.1} s", d.total_s)),
        "{:?}",
        text[0]
    );
    let l = &d.layers[5];
    let line = text
        .iter()
        .find(|r| r.values[0].starts_with("layer 5 "))
        .expect("layer 5 logged");
    assert!(close(line.t, l.t_start_s, 1e-9));
    assert!(
        line.values[0].contains(&format!("{:.1} MeV", l.energy_mev)),
        "{:?}",
        line.values
    );

    // The beam arrow: a row per sample, labelled on/off as the timeline says.
    let labels = rrd.text_rows(
        paths::GANTRY_BEAM,
        rerun::Arrows2D::descriptor_labels().component,
    );
    assert_eq!(labels.len(), jerk.len());
    let on = labels
        .iter()
        .filter(|r| r.values[0].starts_with("beam on"))
        .count();
    let beam_share = d.breakdown.beam_on_s / total;
    assert!(
        close(on as f64 / labels.len() as f64, beam_share, 0.2),
        "beam-on rows {on}/{} vs {beam_share}",
        labels.len()
    );
}

#[test]
fn two_arcs_log_signed_speed() {
    let d = simulated("plans/two-arc.json", Schedule::Scan);
    let path = out_path("two-arc.rrd");
    save_delivery(&path, "two-arc", &d, &[], &ViewerOptions::default()).expect("save");
    let speed = read_rrd(&path).scalar_rows(paths::SPEED);
    assert!(speed.iter().any(|r| r.values[0] > 1.0), "clockwise arc");
    assert!(
        speed.iter().any(|r| r.values[0] < -1.0),
        "counter-clockwise arc"
    );
    let v = d.limits.max_speed_deg_per_s;
    assert!(
        speed.iter().all(|r| r.values[1..] == [v, -v]),
        "both directions get their limit line"
    );
}

#[test]
fn bad_inputs_are_errors() {
    let d = simulated("plans/lung.json", Schedule::StepAndShoot);
    let path = out_path("never.rrd");
    for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let err = save_delivery(&path, "x", &d, &[], &ViewerOptions { sample_dt_s: dt });
        assert!(
            matches!(err, Err(ViewerError::InvalidSampleDt(_))),
            "{dt}: {err:?}"
        );
    }
    assert!(!path.exists(), "nothing written for a bad dt");
    let err = save_delivery(&path, "x", &d, &[], &ViewerOptions { sample_dt_s: 1e-6 });
    assert!(!path.exists(), "nothing written for a tiny dt");
    assert!(
        matches!(err, Err(ViewerError::TooManySamples { .. })),
        "{err:?}"
    );

    let mut no_timeline = d.clone();
    no_timeline.timeline = None;
    let err = save_delivery(&path, "x", &no_timeline, &[], &ViewerOptions::default());
    assert!(matches!(err, Err(ViewerError::NoTimeline)), "{err:?}");

    assert!(
        !path.exists(),
        "nothing is written when the input is rejected"
    );

    let missing_dir = out_path("no-such-dir").join("out.rrd");
    let err = save_delivery(&missing_dir, "x", &d, &[], &ViewerOptions::default());
    assert!(matches!(err, Err(ViewerError::Save { .. })), "{err:?}");
}

/// A sweep row of plan `plans/prostate.json` under `scan` at J `j`, A `a`, V 5, with `total`
/// (`None`: infeasible).
fn sweep_row(index: usize, j: f64, a: f64, total: Option<f64>) -> arcsim_evaluator::Row {
    use arcsim_evaluator::{Outcome, Row, Setting, Status};
    use arcsim_sequencer::{Breakdown, LimiterCounts};
    let outcome = |total_s: f64| Outcome {
        total_s,
        breakdown: Breakdown {
            beam_on_s: 30.0,
            spot_irradiation_s: 30.0,
            scanning_s: 0.0,
            burst_switching_s: 0.0,
            spill_waiting_s: 0.0,
            energy_switching_s: 130.0,
            lost_s: total_s - 160.0,
        },
        speedup: None,
        lower_bound_s: None,
        gap_s: None,
        limiter_counts: LimiterCounts::default(),
        violations: 0,
        margins: None,
    };
    Row {
        index,
        combinations: 4,
        plan: "plans/prostate.json".into(),
        schedule: arcsim_evaluator::RunMode::constant(Schedule::Scan),
        setting: Setting {
            jerk_deg_per_s3: j,
            accel_deg_per_s2: a,
            speed_deg_per_s: 5.0,
            elst_up_s: None,
            elst_down_s: None,
            window_deg: None,
            scan_speed_mm_per_s: None,
            dose_rate_scale: None,
            burst_switching_time_s: None,
            spill_charge_mu: None,
            spill_refill_time_s: None,
            spill_max_layers: None,
        },
        status: if total.is_some() {
            Status::Ok
        } else {
            Status::Infeasible
        },
        outcome: total.map(outcome),
        message: if total.is_some() {
            String::new()
        } else {
            "no feasible timeline".into()
        },
        defaults: arcsim_evaluator::Defaults {
            elst_up_s: Some(5.0),
            elst_down_s: Some(0.5),
            window_deg: 1.0,
            scan_speed_mm_per_s: None,
            dose_rate_scale: 1.0,
            burst_switching_time_s: None,
            spill_charge_mu: None,
            spill_refill_time_s: None,
            spill_max_layers: None,
        },
    }
}

#[test]
fn sweep_round_trip() {
    let row = sweep_row;
    // J varies fastest, as in a sweep; the row at J 0.5, A 0.5 is infeasible.
    let rows = [
        row(0, 0.25, 0.5, Some(300.0)),
        row(1, 0.5, 0.5, None),
        row(2, 1.0, 0.5, Some(250.0)),
        row(3, 0.25, 1.0, Some(290.0)),
        row(4, 0.5, 1.0, Some(260.0)),
        row(5, 1.0, 1.0, Some(240.0)),
    ];
    let path = out_path("sweep.rrd");
    arcsim_viewer::save_sweep(&path, "sweep", &rows, Some("summary table")).expect("save sweep");
    let rrd = read_rrd(&path);
    assert!(rrd.blueprint_chunks > 0 && rrd.blueprint_activated);

    let x = TimelineName::from_static_str(arcsim_viewer::SWEEP_X);
    let combination = TimelineName::from_static_str(arcsim_viewer::COMBINATION);
    let scalars = rerun::Scalars::descriptor_scalars().component;
    // (x, combination index, total) of one line, in x order.
    let line = |entity: &str| {
        let mut points = vec![];
        for chunk in rrd.chunks(entity).iter().filter(|c| !c.is_static()) {
            let times = |name: &TimelineName| {
                chunk
                    .timelines()
                    .get(name)
                    .unwrap_or_else(|| panic!("{entity}: {name} timeline"))
                    .times_raw()
                    .to_vec()
            };
            let (xs, index) = (times(&x), times(&combination));
            for (k, values) in chunk.iter_slices::<f64>(scalars).enumerate() {
                assert_eq!(values.len(), 1, "{entity}: one scalar per row");
                points.push((xs[k], index[k], values[0]));
            }
        }
        points.sort_by_key(|p| p.0);
        points
    };
    // Against J (in hundredths: 0.25 needs two decimals), one line per A; the infeasible row
    // is left out.
    let origin = "sweep/plans_prostate.json/scan";
    assert_eq!(
        line(&format!("{origin}/vs_J/00_A_0.5__V_5")),
        vec![(25, 0, 300.0), (100, 2, 250.0)]
    );
    assert_eq!(
        line(&format!("{origin}/vs_J/01_A_1__V_5")),
        vec![(25, 3, 290.0), (50, 4, 260.0), (100, 5, 240.0)]
    );
    // Against A (in tenths), one line per J.
    assert_eq!(
        line(&format!("{origin}/vs_A/00_J_0.25__V_5")),
        vec![(5, 0, 300.0), (10, 3, 290.0)]
    );
    assert_eq!(
        line(&format!("{origin}/vs_A/01_J_0.5__V_5")),
        vec![(10, 4, 260.0)]
    );
    // V has one value: no plot against it.
    assert!(
        !rrd.entities.keys().any(|k| k.contains("vs_V")),
        "{:?}",
        rrd.entities.keys()
    );

    // Plot titles name the x axis's unit; the plan is a tab, then Summary and Rows.
    for name in [
        "scan: total (s) vs J (x: J in 0.01 °/s³)",
        "scan: total (s) vs A (x: A in 0.1 °/s²)",
        "plans/prostate.json",
        "Summary",
        "Rows",
    ] {
        assert!(
            rrd.blueprint_names.iter().any(|n| n == name),
            "no {name:?} in {:?}",
            rrd.blueprint_names
        );
    }

    let document = rerun::TextDocument::descriptor_text().component;
    let summary: Vec<String> = rrd
        .chunks(arcsim_viewer::SWEEP_SUMMARY)
        .iter()
        .flat_map(|c| {
            c.iter_slices::<String>(document)
                .flat_map(|r| r.into_iter().map(|s| s.to_string()))
                .collect::<Vec<_>>()
        })
        .collect();
    assert!(summary.iter().all(|s| s == "summary table") && !summary.is_empty());

    let text = rerun::TextLog::descriptor_text().component;
    let lines: Vec<String> = rrd
        .chunks(arcsim_viewer::SWEEP_ROWS)
        .iter()
        .flat_map(|c| {
            c.iter_slices::<String>(text)
                .flat_map(|r| r.into_iter().map(|s| s.to_string()))
                .collect::<Vec<_>>()
        })
        .collect();
    assert_eq!(lines.len(), 6);
    assert!(
        lines
            .iter()
            .any(|l| l.starts_with("#1 ") && l.contains("infeasible: no feasible timeline")),
        "{lines:?}"
    );
}

/// A plot keeps at most `MAX_LINES` lines, spread over the other limit's values, ends included,
/// and says so in its title.
#[test]
fn sweep_plots_keep_their_legends_short() {
    let accels: Vec<f64> = (1..=20).map(|k| k as f64 * 0.1).collect();
    let mut rows = vec![];
    for &a in &accels {
        for j in [0.5, 1.0] {
            rows.push(sweep_row(rows.len(), j, a, Some(300.0 - 10.0 * j - a)));
        }
    }
    let path = out_path("sweep-thin.rrd");
    arcsim_viewer::save_sweep(&path, "thin", &rows, None).expect("save sweep");
    let rrd = read_rrd(&path);
    let lines: Vec<&String> = rrd
        .entities
        .keys()
        .filter(|k| k.contains("/vs_J/"))
        .collect();
    assert_eq!(lines.len(), arcsim_viewer::MAX_LINES, "{lines:?}");
    for end in [
        "/00_A_0.1__V_5",
        &format!("/{:02}_A_2__V_5", arcsim_viewer::MAX_LINES - 1),
    ] {
        assert!(lines.iter().any(|l| l.ends_with(end)), "{end} in {lines:?}");
    }
    let title = format!(
        "scan: total (s) vs J (x: J in 0.1 °/s³; {} of 20 lines)",
        arcsim_viewer::MAX_LINES
    );
    assert!(
        rrd.blueprint_names.contains(&title),
        "{title:?} not in {:?}",
        rrd.blueprint_names
    );
    // Against A, two lines (one per J): all of them.
    assert_eq!(
        rrd.entities.keys().filter(|k| k.contains("/vs_A/")).count(),
        2
    );
}
