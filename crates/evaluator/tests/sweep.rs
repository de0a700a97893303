//! Acceptance tests of the evaluator: determinism across thread counts, shards that merge into
//! the single-run table byte for byte, located errors for bad sweep files, empty sweeps refused,
//! infeasible combinations reported as rows, absurd sweeps refused up front and huge ones run
//! lazily, every number of a sweep file checked.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::util::{csv, from_text, scenarios};
use arcsim_evaluator::{
    merge_csv, parse_sweep_file, Axis, Evaluator, Row, Shard, Status, Sweep, Target,
    MAX_COMBINATIONS, PROFILE_MAX_POINTS,
};
use arcsim_test_support::temp_dir;

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool")
}

#[test]
fn atom_1000_settings_same_with_1_and_2_threads_and_shards_merge_byte_identical() {
    let sweep = Sweep::load(&scenarios().join("sweep-atom-1000.json")).expect("sweep loads");
    assert_eq!(sweep.combinations(), 3000);
    let ev = pool(2).install(|| Evaluator::new(sweep)).expect("prepare");
    let all: Vec<usize> = (0..ev.len()).collect();
    let one = pool(1).install(|| ev.run_collect(&all));
    let two = pool(2).install(|| ev.run_collect(&all));
    assert_eq!(one.len(), 3000);
    assert_eq!(one, two);
    let single = csv(&one);
    assert_eq!(single, csv(&two));
    let ok = one.iter().filter(|r| r.status == Status::Ok).count();
    println!("{ok} of 3000 combinations feasible");
    assert!(ok > 2900, "only {ok} feasible");
    assert!(one.iter().enumerate().all(|(i, r)| r.index == i));

    // Shards 1/3, 2/3, 3/3, merged in any order, equal the single run byte for byte.
    let shards: Vec<(String, String)> = (1..=3)
        .rev()
        .map(|k| {
            let shard = Shard::new(k, 3).expect("shard");
            let rows = pool(2).install(|| ev.run_collect(&shard.indices(ev.len())));
            (format!("shard-{k}.csv"), csv(&rows))
        })
        .collect();
    let merged = merge_csv(&shards, Some(ev.len())).expect("merge");
    assert_eq!(merged.as_bytes(), single.as_bytes());
    assert!(
        merge_csv(&shards[..2], None).is_err(),
        "a missing shard is an error"
    );

    // The summary covers every plan; a faster machine never takes longer than the base one.
    let summary = pool(2).install(|| ev.summarize(&one));
    print!("{}", summary.to_table());
    assert_eq!(summary.entries.len(), 3);
    for e in &summary.entries {
        assert_eq!(e.rows, 1000);
        let base = e.base_total_s.expect("base feasible");
        let fastest = e.fastest.expect("fastest");
        assert!(fastest.total_s <= base);
        for s in &e.sensitivity {
            assert!(
                s.s_per_10_percent.expect("finite difference") <= 1e-9,
                "{s:?}"
            );
        }
    }
}

#[test]
fn run_stops_on_cancel_after_whole_rows() {
    let sweep = Sweep::load(&scenarios().join("sweep-atom-1000.json")).expect("sweep loads");
    let ev = Evaluator::new(sweep).expect("prepare");
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let mut got: Vec<Row> = Vec::new();
    let all: Vec<usize> = (0..ev.len()).collect();
    let n = pool(2)
        .install(|| {
            ev.run(&all, &cancel, |rows| {
                got.extend_from_slice(rows);
                if got.len() >= 10 {
                    cancel.store(true, std::sync::atomic::Ordering::Relaxed);
                }
                Ok(())
            })
        })
        .expect("run");
    assert_eq!(n, got.len());
    assert!(n >= 10 && n < ev.len());
    assert!(
        got.iter().enumerate().all(|(i, r)| r.index == i),
        "rows in order, no gap"
    );
}

const GOOD: &str = r#"{
  "format": "arcsim-sweep/1", "name": "t",
  "plans": ["../plans/prostate.json"],
  "machine": "machine-atom.json",
  "axes": {"jerk_deg_per_s3": [0.5, 1]},
  "schedules": ["scan"]
}"#;

fn error_of(text: &str) -> String {
    match from_text(text) {
        Ok(_) => panic!("expected an error for {text}"),
        Err(e) => e.to_string(),
    }
}

/// A `{"path", "name"}` entry loads one file under the given name; a name already taken or a
/// missing file is a located error.
#[test]
fn named_plans_keep_their_name_and_names_are_unique() {
    let named =
        r#"["../plans/prostate.json", {"path": "../plans/atom/liver.json", "name": "atom:liver"}]"#;
    let sweep = from_text(&GOOD.replace(r#"["../plans/prostate.json"]"#, named)).expect("valid");
    let labels: Vec<&str> = sweep.plans.iter().map(|p| p.label.as_str()).collect();
    assert_eq!(labels, ["../plans/prostate.json", "atom:liver"]);
    assert_eq!(sweep.plans[1].plan.name, "ATOM article case liver");
    let taken = r#"["../plans/prostate.json", {"path": "../plans/lung.json", "name": "../plans/prostate.json"}]"#;
    let e = error_of(&GOOD.replace(r#"["../plans/prostate.json"]"#, taken));
    assert!(
        e.starts_with("test-sweep.json: plans[1].name:") && e.contains("no earlier plan has"),
        "{e}"
    );
    let missing = r#"[{"path": "../plans/nope.json", "name": "x"}]"#;
    let e = error_of(&GOOD.replace(r#"["../plans/prostate.json"]"#, missing));
    assert!(
        e.starts_with("test-sweep.json: plans[0].path:") && e.contains("nope.json"),
        "{e}"
    );
}

#[test]
fn bad_sweep_files_get_located_errors() {
    assert!(from_text(GOOD).is_ok());
    let cases: [(&str, &str, &str); 9] = [
        (
            "\"plans\": [\"../plans/prostate.json\"]",
            "\"plans\": [\"../plans/nothing-*.json\"]",
            "test-sweep.json: plans[0]: \"../plans/nothing-*.json\" matches no file",
        ),
        (
            "\"machine-atom.json\"",
            "\"machine-missing.json\"",
            "test-sweep.json: machine: ",
        ),
        (
            "[0.5, 1]",
            "[0.5, -1]",
            "test-sweep.json: axes.jerk_deg_per_s3[1]: expected a value finite and > 0, got -1",
        ),
        (
            "[0.5, 1]",
            "[0.5, 0.5]",
            "test-sweep.json: axes.jerk_deg_per_s3: value 0.5 appears twice",
        ),
        (
            "[0.5, 1]",
            "{\"from\": 1, \"to\": 2}",
            "test-sweep.json: axes.jerk_deg_per_s3: expected {\"values\": [..]} or all three",
        ),
        (
            "\"jerk_deg_per_s3\"",
            "\"jerk\"",
            "test-sweep.json: axes.jerk: unknown field `jerk`",
        ),
        (
            "\"scan\"",
            "\"scam\"",
            "test-sweep.json: schedules[0]: unknown schedule 'scam'",
        ),
        (
            "\"name\": \"t\",",
            "\"name\": \"t\", \"extra\": 1,",
            "test-sweep.json: extra: unknown field `extra`",
        ),
        (
            "\"machine-atom.json\",",
            "\"machine-fast.json\", \"axes\": {\"elst_up_s\": [1, 2]},",
            "test-sweep.json: axes.elst_up_s: machine \"fast\" has a polynomial ELST model",
        ),
    ];
    for (from, to, expected) in cases {
        let text = GOOD.replacen(from, to, 1);
        let text = if to.contains("elst_up_s") {
            text.replacen("\"axes\": {\"jerk_deg_per_s3\": [0.5, 1]},", "", 1)
        } else {
            text
        };
        let e = error_of(&text);
        assert!(e.starts_with(expected), "expected «{expected}», got «{e}»");
    }
    let e = error_of(&GOOD.replace(
        "\"../plans/prostate.json\"",
        "{\"atom_case\": \"kidney\", \"reference\": \"../reference/atom-article-cases.json\"}",
    ));
    assert!(
        e.starts_with("test-sweep.json: plans[0].atom_case:") && e.contains("kidney"),
        "{e}"
    );
}

#[test]
fn empty_sweeps_are_errors() {
    for (from, to, field) in [
        ("[\"../plans/prostate.json\"]", "[]", "plans"),
        ("[\"scan\"]", "[]", "schedules"),
        ("[0.5, 1]", "[]", "axes.jerk_deg_per_s3"),
        ("[0.5, 1]", "{\"values\": []}", "axes.jerk_deg_per_s3"),
        (
            "[0.5, 1]",
            "{\"from\": 1, \"to\": 2, \"steps\": 0}",
            "axes.jerk_deg_per_s3.steps",
        ),
    ] {
        let e = error_of(&GOOD.replace(from, to));
        assert!(
            e.starts_with(&format!("test-sweep.json: {field}: expected at least")),
            "{e}"
        );
    }
}

#[test]
fn infeasible_combinations_are_rows() {
    // A 3 deg window does not fit prostate's 2 deg spacing: those rows are `invalid`, with the reason.
    let text = GOOD.replace("\"axes\": {", "\"axes\": {\"window_deg\": [1, 3], ");
    let sweep = from_text(&text).expect("sweep");
    let ev = Evaluator::new(sweep).expect("prepare");
    assert_eq!(ev.len(), 4);
    let rows = ev.run_collect(&[0, 1, 2, 3]);
    assert_eq!(
        rows.iter().map(|r| r.status).collect::<Vec<_>>(),
        [Status::Ok, Status::Ok, Status::Invalid, Status::Invalid]
    );
    assert!(rows[2].message.contains("window"), "{}", rows[2].message);
    assert!(rows[2].outcome.is_none());
    let o = rows[1].outcome.expect("ok row");
    let b = o.breakdown;
    assert!((b.beam_on_s + b.energy_switching_s + b.lost_s - o.total_s).abs() < 1e-6 * o.total_s);
    let c = o.limiter_counts;
    assert_eq!(c.elst + c.speed + c.accel + c.jerk + c.none, 179);
    let text = csv(&rows);
    assert_eq!(text.lines().count(), 5);
    assert!(text.lines().nth(3).is_some_and(|l| l.contains(",invalid,")));
}

#[test]
fn summary_finds_the_cheapest_change() {
    let text = GOOD.replace("[0.5, 1]", "[0.25, 0.5, 1, 2, 4]").replace(
        "\"schedules\"",
        "\"target\": {\"saving_percent\": 1}, \"schedules\"",
    );
    let ev = Evaluator::new(from_text(&text).expect("sweep")).expect("prepare");
    let rows = ev.run_collect(&(0..ev.len()).collect::<Vec<_>>());
    let s = ev.summarize(&rows);
    print!("{}", s.to_table());
    let e = &s.entries[0];
    let base = e.base_total_s.expect("base");
    assert_eq!(
        rows[1].outcome.map(|o| o.total_s),
        Some(base),
        "grid point J = 0.5 is the base machine"
    );
    assert_eq!(rows[1].outcome.and_then(|o| o.speedup), Some(1.0));
    let c = e.cheapest.as_ref().expect("some J reaches a 1 % saving");
    assert!(c.total_s <= 0.99 * base && c.steps.len() == 1);
    // No cheaper grid point reaches the target: every J closer to 0.5 (in ratio) misses it.
    for r in &rows {
        let Some(o) = r.outcome else { continue };
        let ratio = (r.setting.jerk_deg_per_s3 / 0.5_f64).ln().abs();
        if ratio < c.cost - 1e-12 {
            assert!(o.total_s > 0.99 * base);
        }
    }
    assert_eq!(e.profiles.len(), 1);
    assert_eq!(e.profiles[0].points.len(), 5);
}

/// Merged shards read back with the sweep file summarise exactly as the single run does; a
/// table from another sweep, or a damaged line, is a located error.
/// The summary simulates only what the rows do not hold: a profiled value that is a grid row (or
/// the base machine) is taken from it, and its total equals a fresh simulation of that setting;
/// the progress callback runs once per setting the summary does simulate.
#[test]
fn summary_reuses_grid_rows_and_counts_what_it_simulates() {
    let text = GOOD.replace(
        "[0.5, 1]",
        "[0.25, 0.5, 1], \"accel_deg_per_s2\": [0.5, 0.7]",
    );
    let ev = Evaluator::new(from_text(&text).expect("sweep")).expect("prepare");
    let rows = ev.run_collect(&(0..ev.len()).collect::<Vec<_>>());
    // J and A swept (J, A, V nudged ±10 %); every profiled value is a grid row with the other
    // limit at the base machine's value, so only the six nudges are simulated.
    assert_eq!(ev.summary_evaluations(&rows), 6);
    let calls = std::sync::atomic::AtomicUsize::new(0);
    let s = ev.summarize_with(&rows, &|| {
        calls.fetch_add(1, Ordering::Relaxed);
    });
    assert_eq!(calls.load(Ordering::Relaxed), 6);
    assert_eq!(s, ev.summarize(&rows));
    let base = ev.sweep().base_setting();
    for profile in &s.entries[0].profiles {
        for point in &profile.points {
            let setting = base.with(profile.axis, point.value);
            let fresh = ev.simulate(
                0,
                s.entries[0].schedule,
                &setting,
                s.entries[0].base_total_s,
            );
            assert_eq!(point.total_s, fresh.1.map(|o| o.total_s), "{setting:?}");
        }
    }
    // A shard's rows hold fewer of the profiled values: the summary simulates the rest.
    let first = &rows[..2];
    assert_eq!(ev.summary_evaluations(first), 6 + 2);
}

#[test]
fn merged_shards_summarise_like_a_single_run() {
    let text = GOOD
        .replace("[0.5, 1]", "[0.25, 0.5, 1]")
        .replace("\"schedules\": [\"scan\"]", "\"axes\": {\"jerk_deg_per_s3\": [0.25, 0.5, 1], \"speed_deg_per_s\": [3, 5]}, \"schedules\": [\"scan\", \"step-and-shoot\"]")
        .replace("\"axes\": {\"jerk_deg_per_s3\": [0.25, 0.5, 1]},", "");
    let ev = Evaluator::new(from_text(&text).expect("sweep")).expect("prepare");
    assert_eq!(ev.len(), 12);
    let rows = ev.run_collect(&(0..ev.len()).collect::<Vec<_>>());
    let shards: Vec<(String, String)> = (1..=2)
        .map(|k| {
            let shard = Shard::new(k, 2).expect("shard");
            (
                format!("shard-{k}.csv"),
                csv(&ev.run_collect(&shard.indices(ev.len()))),
            )
        })
        .collect();
    let merged = merge_csv(&shards, Some(ev.len())).expect("merge");
    let back = ev.rows_from_csv("merged.csv", &merged).expect("read back");
    assert_eq!(back.len(), rows.len());
    for (a, b) in back.iter().zip(&rows) {
        assert_eq!(
            (a.index, a.status, a.setting),
            (b.index, b.status, b.setting)
        );
        assert_eq!(
            a.outcome
                .map(|o| (o.total_s, o.speedup, o.breakdown, o.limiter_counts)),
            b.outcome
                .map(|o| (o.total_s, o.speedup, o.breakdown, o.limiter_counts))
        );
    }
    assert_eq!(
        ev.summarize(&back).to_table(),
        ev.summarize(&rows).to_table()
    );

    // Another sweep's table: its row 0 is at V 5, this sweep's at V 3.
    let other = Evaluator::new(from_text(GOOD).expect("sweep")).expect("prepare");
    let other_rows = other.run_collect(&[0, 1]);
    let err = ev
        .rows_from_csv("other.csv", &csv(&other_rows))
        .expect_err("a different sweep");
    assert!(
        err.to_string()
            .contains("other.csv: line 2: a sweep of 2 combinations; this sweep has 12"),
        "{err}"
    );
    // A damaged number.
    let damaged = merged.replacen(",ok,", ",ok,x", 1);
    let err = ev.rows_from_csv("bad.csv", &damaged).expect_err("damaged");
    assert!(err.to_string().contains("expected a number"), "{err}");
}

/// A schedule entry with free motion runs it: rows named `optimal+free`, never slower than the
/// same schedule with constant speed, and the CSV merge reads the label back.
#[test]
fn free_motion_entries_run_and_merge() {
    let text = GOOD.replace(
        "\"schedules\": [\"scan\"]",
        "\"schedules\": [\"optimal\", {\"schedule\": \"optimal\", \"motion\": \"free\"}, {\"schedule\": \"optimal\", \"motion\": \"free\", \"arc_ends\": \"free\"}]",
    );
    let sweep = from_text(&text).expect("sweep");
    let ev = Evaluator::new(sweep).expect("prepare");
    assert_eq!(ev.len(), 6);
    let rows = ev.run_collect(&(0..6).collect::<Vec<_>>());
    let names: Vec<String> = rows.iter().map(|r| r.schedule.name()).collect();
    assert_eq!(
        names,
        [
            "optimal",
            "optimal",
            "optimal+free",
            "optimal+free",
            "optimal+free+free-ends",
            "optimal+free+free-ends"
        ]
    );
    for j in 0..2 {
        let total = |r: &Row| r.outcome.expect("ok").total_s;
        let constant = total(&rows[j]);
        assert!(
            total(&rows[2 + j]) <= constant,
            "free motion slower than constant"
        );
        assert!(
            total(&rows[4 + j]) <= total(&rows[2 + j]) + 1e-9 || total(&rows[4 + j]) <= constant
        );
    }
    let table = csv(&rows);
    assert!(table.contains(",optimal+free,"), "{table}");
    let back = ev.rows_from_csv("merged.csv", &table).expect("read back");
    assert_eq!(back.len(), 6);
    assert_eq!(back[4].schedule.name(), "optimal+free+free-ends");
    // Free arc ends without free motion are refused, located.
    let bad = GOOD.replace(
        "\"schedules\": [\"scan\"]",
        "\"schedules\": [{\"schedule\": \"optimal\", \"arc_ends\": \"free\"}]",
    );
    let e = error_of(&bad);
    assert!(e.contains("schedules[0]") && e.contains("motion"), "{e}");
    // A schedule that fixes the speeds with a motion that chooses them is refused at the entry
    // (it once loaded and then failed on every row).
    for schedule in ["step-and-shoot", "prescribed"] {
        let bad = GOOD.replace(
            "\"schedules\": [\"scan\"]",
            &format!(
                "\"schedules\": [\"scan\", {{\"schedule\": \"{schedule}\", \"motion\": \"free\"}}]"
            ),
        );
        let e = error_of(&bad);
        assert!(
            e.contains("schedules[1].motion")
                && e.contains(&format!(
                    "expected the optimal or scan schedule with it, not {schedule}"
                )),
            "{e}"
        );
    }
}

/// The summary's sensitivities follow the problem's law: a delivery within a lowered limit is
/// also a delivery at the limit, and one found at a lower limit is one at a higher. On the
/// bundled lung plan free motion never uses more than half the ATOM machine's V, so V's
/// sensitivity is exactly 0 and it has no effect (free motion's solver once reported -1.28 s
/// per +10 % there: its local optima at the nudged settings differed); the others never come
/// out positive, and each nudge agrees with a plain simulation of its setting.
#[test]
fn a_limit_free_motion_never_uses_has_no_sensitivity() {
    let text = GOOD.replace("prostate.json", "lung.json").replace(
        "\"schedules\": [\"scan\"]",
        "\"schedules\": [{\"schedule\": \"optimal\", \"motion\": \"free\"}]",
    );
    let ev = Evaluator::new(from_text(&text).expect("sweep")).expect("prepare");
    let rows = ev.run_collect(&(0..ev.len()).collect::<Vec<_>>());
    let s = ev.summarize(&rows);
    print!("{}", s.to_table());
    let e = &s.entries[0];
    let of = |axis: Axis| {
        e.sensitivity
            .iter()
            .find(|x| x.axis == axis)
            .expect("reported")
    };
    // The premise: the base delivery uses less than half of V (docs/model.md).
    let plan = arcsim_plan::load_plan(scenarios().join("../plans/lung.json")).expect("plan");
    let atom = arcsim_plan::load_machine(scenarios().join("machine-atom.json")).expect("machine");
    let opts = arcsim_sequencer::Options {
        motion: arcsim_sequencer::Motion::Free,
        ..arcsim_sequencer::Options::new(arcsim_sequencer::Schedule::Optimal)
    };
    let d = arcsim_sequencer::simulate(&plan, &atom, &opts).expect("simulates");
    let speed_use = d.margins.expect("margins").speed_use.value;
    assert!(speed_use < 0.5, "{speed_use}");
    let v = of(Axis::Speed);
    assert_eq!(v.s_per_10_percent, Some(0.0), "{v:?}");
    assert!(v.no_effect, "{v:?}");
    for axis in [Axis::Jerk, Axis::Accel] {
        let x = of(axis);
        assert!(x.s_per_10_percent.is_some_and(|d| d <= 0.0), "{x:?}");
    }
    // Each finite difference is one between deliveries a plain simulation gives: the law only
    // ever gives a setting a shorter delivery that is feasible there.
    let base = e.base_total_s.expect("base");
    for axis in [Axis::Jerk, Axis::Accel, Axis::Speed] {
        let x = of(axis);
        let found: Vec<f64> = [1.0 / 1.1, 1.1]
            .into_iter()
            .map(|f| {
                let setting = ev.sweep().base_setting().with(axis, x.base_value * f);
                let (_, o, _) = ev.simulate(0, rows[0].schedule, &setting, Some(base));
                o.expect("feasible").total_s
            })
            .chain([base])
            .collect();
        let d = 2.0 * x.s_per_10_percent.expect("both nudges feasible");
        let matches = found
            .iter()
            .any(|a| found.iter().any(|b| (a - b - d).abs() <= 1e-9 * base));
        assert!(matches, "{axis:?}: {d} is no difference of {found:?}");
    }
}

/// `"certify": true` gives every row its certificate: a constant-speed row's bound at most every
/// constant-speed total of the same setting (scan's and optimal's), a free-motion row's at most
/// the free total, the gap the row's total minus it; the columns read back from the CSV.
#[test]
fn certified_sweeps_bound_every_constant_speed_row() {
    let text = r#"{
      "format": "arcsim-sweep/1", "name": "t",
      "plans": ["../plans/lung.json"],
      "machine": "machine-atom.json",
      "axes": {"jerk_deg_per_s3": [0.5, 2]},
      "schedules": ["scan", "optimal", {"schedule": "optimal", "motion": "free"}],
      "certify": true
    }"#;
    let ev = Evaluator::new(from_text(text).expect("sweep")).expect("prepare");
    let rows = ev.run_collect(&(0..ev.len()).collect::<Vec<_>>());
    assert_eq!(rows.len(), 6);
    for j in 0..2 {
        let (scan, optimal, free) = (&rows[j], &rows[2 + j], &rows[4 + j]);
        let o = |r: &Row| {
            r.outcome
                .unwrap_or_else(|| panic!("{}: {}", r.index, r.message))
        };
        let fastest_constant = o(scan).total_s.min(o(optimal).total_s);
        for r in [scan, optimal] {
            let (lb, gap) = (o(r).lower_bound_s.expect("bound"), o(r).gap_s.expect("gap"));
            assert!(
                lb > 0.0 && lb <= fastest_constant,
                "{lb} > {fastest_constant}"
            );
            assert!((o(r).total_s - lb - gap).abs() <= 1e-9 * o(r).total_s);
            // Far from zero: the bound is a useful one (within 2 % on lung).
            assert!(gap <= 0.02 * o(r).total_s, "gap {gap}");
        }
        let (lb, gap) = (
            o(free).lower_bound_s.expect("free bound"),
            o(free).gap_s.expect("free gap"),
        );
        assert!(lb > 0.0 && lb <= o(free).total_s, "{lb}");
        assert!((o(free).total_s - lb - gap).abs() <= 1e-9 * o(free).total_s);
    }
    let table = csv(&rows);
    assert!(table
        .lines()
        .next()
        .expect("header")
        .contains(",lower_bound_s,gap_s,"));
    let back = ev
        .rows_from_csv("certified.csv", &table)
        .expect("read back");
    for (a, r) in back.iter().zip(&rows) {
        let pair = |r: &Row| r.outcome.map(|o| (o.lower_bound_s, o.gap_s));
        assert_eq!(pair(a), pair(r));
    }
    // Without the flag, no row is certified.
    let plain = Evaluator::new(
        from_text(&text.replace("\"certify\": true", "\"certify\": false")).expect("sweep"),
    )
    .expect("prepare");
    let row = plain.evaluate(2);
    assert_eq!(row.outcome.expect("ok").lower_bound_s, None);
}

/// GOOD with its top-level axes replaced.
fn with_axes(axes: &str) -> String {
    let text = GOOD.replacen("{\"jerk_deg_per_s3\": [0.5, 1]}", axes, 1);
    assert_ne!(text, GOOD);
    text
}

/// An absurd sweep is refused when it is loaded, with its size and the limit, before anything
/// the size of the sweep is allocated (a trillion steps would abort on allocation).
#[test]
fn absurd_sweeps_are_refused_up_front_with_their_size() {
    let started = Instant::now();
    let e = error_of(&with_axes(
        r#"{"jerk_deg_per_s3": {"from": 0.1, "to": 4, "steps": 1000000000000}}"#,
    ));
    assert!(
        e.starts_with(&format!("test-sweep.json: axes.jerk_deg_per_s3.steps: 1000000000000 steps; expected at most {MAX_COMBINATIONS}")),
        "{e}"
    );
    // Each axis within the limit, their product beyond usize.
    let e = error_of(&with_axes(
        r#"{"jerk_deg_per_s3": {"from": 0.1, "to": 4, "steps": 100000000},
            "accel_deg_per_s2": {"from": 0.1, "to": 4, "steps": 100000000},
            "speed_deg_per_s": {"from": 1, "to": 9, "steps": 10000}}"#,
    ));
    assert!(
        e.starts_with("test-sweep.json: 2^64 or more combinations per plan"),
        "{e}"
    );
    // Beyond the limit for one plan.
    let e = error_of(&with_axes(
        r#"{"jerk_deg_per_s3": {"from": 0.1, "to": 4, "steps": 10000},
            "accel_deg_per_s2": {"from": 0.1, "to": 4, "steps": 10001}}"#,
    ));
    assert!(
        e.starts_with(&format!("test-sweep.json: 100010000 combinations per plan (grid points summed over the schedule entries); expected at most {MAX_COMBINATIONS}")),
        "{e}"
    );
    // Within it per plan, beyond it with the plans (4 plan files) and schedule entries (2).
    let text = with_axes(
        r#"{"jerk_deg_per_s3": {"from": 0.1, "to": 4, "steps": 5000},
            "accel_deg_per_s2": {"from": 0.1, "to": 4, "steps": 3000}}"#,
    )
    .replace("\"../plans/prostate.json\"", "\"../plans/*.json\"")
    .replace("[\"scan\"]", "[\"scan\", \"optimal\"]");
    let e = error_of(&text);
    assert!(
        e.starts_with(&format!("test-sweep.json: 120000000 combinations (4 plans × 30000000 grid points summed over the schedule entries); expected at most {MAX_COMBINATIONS}")),
        "{e}"
    );
    assert!(
        started.elapsed() < Duration::from_secs(10),
        "refusing took {:?}",
        started.elapsed()
    );
}

/// Ten million grid points load at once; a shard of them runs without listing the others, each
/// value computed from its index exactly as the eager expansion did.
#[test]
fn huge_grids_are_evaluated_lazily() {
    let steps = 10_000_000usize;
    let text = with_axes(&format!(
        r#"{{"jerk_deg_per_s3": {{"from": 0.1, "to": 4, "steps": {steps}}},
            "speed_deg_per_s": {{"from": 2, "to": 8, "steps": 3, "scale": "log"}}}}"#
    ));
    let ev = Evaluator::new(from_text(&text).expect("sweep")).expect("prepare");
    assert_eq!(ev.len(), 3 * steps);
    let shard = Shard::new(2, 7_000_000).expect("shard").indices(ev.len());
    assert_eq!(
        shard.iter().collect::<Vec<_>>(),
        [1, 7_000_001, 14_000_001, 21_000_001, 28_000_001]
    );
    let rows = ev.run_collect(&shard);
    assert_eq!(rows.len(), 5);
    for r in &rows {
        let (j, v) = (r.index % steps, r.index / steps);
        let f = j as f64 / (steps - 1) as f64;
        let jerk = 0.1 + f * (4.0 - 0.1);
        let speed = [2.0, 2.0 * (8.0_f64 / 2.0).powf(0.5), 8.0][v];
        assert_eq!(r.setting.jerk_deg_per_s3.to_bits(), jerk.to_bits(), "{r:?}");
        assert_eq!(
            r.setting.speed_deg_per_s.to_bits(),
            speed.to_bits(),
            "{r:?}"
        );
        assert_eq!(r.status, Status::Ok, "{r:?}");
    }
    let last = ev.evaluate(ev.len() - 1);
    assert_eq!(
        (last.setting.jerk_deg_per_s3, last.setting.speed_deg_per_s),
        (4.0, 8.0)
    );
    // The whole sweep as one shard: the first chunk comes, then the run stops on request.
    let cancel = AtomicBool::new(false);
    let mut got = 0;
    let done = ev
        .run(&Shard::ALL.indices(ev.len()), &cancel, |chunk| {
            got += chunk.len();
            cancel.store(true, Ordering::Relaxed);
            Ok(())
        })
        .expect("run");
    assert!(done == got && done > 0 && done < 1000, "{done}");
    // Ranges and explicit lists of indices run alike.
    assert_eq!(ev.run_collect(&(5..8)), ev.run_collect(&[5, 6, 7]));
    // The summary profiles the ten-million-value axis at PROFILE_MAX_POINTS of its values.
    let summary = ev.summarize(&rows);
    let e = &summary.entries[0];
    assert_eq!(e.rows, 5);
    let points: Vec<usize> = e.profiles.iter().map(|p| p.points.len()).collect();
    assert_eq!(points, [PROFILE_MAX_POINTS, 3]);
    let jerk = &e.profiles[0].points;
    assert_eq!((jerk[0].value, jerk[jerk.len() - 1].value), (0.1, 4.0));
}

/// `target` takes one of two fields: both, neither, an unknown one or a value out of range is
/// named, with what is expected.
#[test]
fn target_errors_say_what_is_expected() {
    let with_target =
        |t: &str| GOOD.replace("\"schedules\"", &format!("\"target\": {t}, \"schedules\""));
    let sweep = from_text(&with_target("{\"total_s\": 250}")).expect("valid");
    assert_eq!(sweep.target, Target::TotalS(250.0));
    let sweep = from_text(&with_target("{\"saving_percent\": 0}")).expect("valid");
    assert_eq!(sweep.target, Target::SavingPercent(0.0));
    for (target, expected) in [
        (
            "{\"total_s\": 250, \"saving_percent\": 10}",
            "test-sweep.json: target: give either `total_s` (a total time in s) or `saving_percent` (a saving in percent of the base machine's total), not both",
        ),
        (
            "{}",
            "test-sweep.json: target: expected `total_s` (a total time in s) or `saving_percent`",
        ),
        (
            "{\"fraction\": 0.1}",
            "test-sweep.json: target.fraction: unknown field `fraction`, expected `total_s` or `saving_percent`",
        ),
        (
            "10",
            "test-sweep.json: target: invalid type: integer `10`, expected {\"total_s\": SECONDS} or {\"saving_percent\": PERCENT}",
        ),
        (
            "{\"total_s\": 0}",
            "test-sweep.json: target.total_s: expected a total time finite and > 0 s, got 0",
        ),
        (
            "{\"total_s\": -250}",
            "test-sweep.json: target.total_s: expected a total time finite and > 0 s, got -250",
        ),
        (
            "{\"saving_percent\": 100}",
            "test-sweep.json: target.saving_percent: expected a saving >= 0 and < 100",
        ),
        (
            "{\"saving_percent\": -5}",
            "test-sweep.json: target.saving_percent: expected a saving >= 0 and < 100",
        ),
    ] {
        let e = error_of(&with_target(target));
        assert!(e.starts_with(expected), "{target}: expected «{expected}», got «{e}»");
        assert!(!e.contains("malformed JSON"), "{e}");
    }
}

/// Every number of a sweep file is checked when it is loaded, located: ranges, steps, and the
/// values a machine file would accept (no J of 1e300, no deceleration scaled past its limit).
/// A byte-order mark is no error.
#[test]
fn sweep_numbers_are_checked_at_the_boundary() {
    let j = "test-sweep.json: axes.jerk_deg_per_s3";
    for (axes, expected) in [
        (
            r#"{"jerk_deg_per_s3": {"from": 1, "to": 2, "steps": 1}}"#,
            format!(
                "{j}.steps: 1 step gives only `from` (1), not `to` (2); expected at least 2 steps"
            ),
        ),
        (
            r#"{"jerk_deg_per_s3": {"from": 1, "to": 1, "steps": 3}}"#,
            format!("{j}: value 1 appears twice (positions 0 and 1)"),
        ),
        (
            r#"{"jerk_deg_per_s3": {"from": 1, "to": 1.0000000000000002, "steps": 3}}"#,
            format!("{j}: value 1 appears twice (positions 0 and 1)"),
        ),
        (
            r#"{"jerk_deg_per_s3": {"from": -1, "to": 2, "steps": 3}}"#,
            format!("{j}.from: expected a value finite and > 0, got -1"),
        ),
        (
            r#"{"jerk_deg_per_s3": {"from": 0, "to": 2, "steps": 3, "scale": "log"}}"#,
            format!("{j}.from: expected a value finite and > 0 (log scale), got 0"),
        ),
        (r#"{"jerk_deg_per_s3": [0.5, 1e300]}"#, format!("{j}[1]: ")),
        (
            r#"{"jerk_deg_per_s3": {"from": 1e-300, "to": 1, "steps": 4, "scale": "log"}}"#,
            format!("{j}.from: "),
        ),
        (
            r#"{"speed_deg_per_s": [5, 1e300]}"#,
            "test-sweep.json: axes.speed_deg_per_s[1]: ".to_string(),
        ),
        (
            r#"{"elst_down_s": [-1]}"#,
            "test-sweep.json: axes.elst_down_s[0]: expected a value finite and >= 0, got -1"
                .to_string(),
        ),
        (
            r#"{"elst_down_s": {"from": 0, "to": 1e300, "steps": 2}}"#,
            "test-sweep.json: axes.elst_down_s.to: ".to_string(),
        ),
        (
            r#"{"window_deg": [0]}"#,
            "test-sweep.json: axes.window_deg[0]: expected a value finite and > 0, got 0"
                .to_string(),
        ),
        (
            r#"{"window_deg": [1, 400]}"#,
            "test-sweep.json: axes.window_deg[1]: ".to_string(),
        ),
    ] {
        let e = error_of(&with_axes(axes));
        assert!(
            e.starts_with(&expected),
            "{axes}: expected «{expected}», got «{e}»"
        );
    }
    // The limits beyond physical sense are the machine format's, named as such.
    let e = error_of(&with_axes(r#"{"jerk_deg_per_s3": [0.5, 1e300]}"#));
    assert!(
        e.contains("1e300") && e.contains("`gantry.max_jerk_deg_per_s3`"),
        "{e}"
    );

    // A descending range is fine: its values run from `from` to `to`.
    let sweep = from_text(&with_axes(
        r#"{"jerk_deg_per_s3": {"from": 2, "to": 0.5, "steps": 4}}"#,
    ))
    .expect("descending range");
    assert_eq!(
        sweep.schedule_grids[0].grid.jerk.values(),
        [2.0, 1.5, 1.0, 0.5]
    );
    // One step from a value to itself is that value.
    let sweep = from_text(&with_axes(
        r#"{"jerk_deg_per_s3": {"from": 2, "to": 2, "steps": 1}}"#,
    ))
    .expect("one step");
    assert_eq!(sweep.combinations(), 1);

    // A machine with an explicit deceleration limit: A scales it, within what a machine accepts.
    let dir = temp_dir();
    let atom = std::fs::read_to_string(scenarios().join("machine-atom.json")).expect("machine");
    let decel = atom.replacen(
        "\"max_accel_deg_per_s2\": 0.5,",
        "\"max_accel_deg_per_s2\": 0.5, \"max_decel_deg_per_s2\": 1.0,",
        1,
    );
    assert_ne!(decel, atom);
    let machine = dir.join("machine-decel.json");
    std::fs::write(&machine, decel).expect("write machine");
    let on_decel = |accel: &str| {
        let text = with_axes(&format!("{{\"accel_deg_per_s2\": {accel}}}")).replace(
            "\"machine-atom.json\"",
            &format!("{:?}", machine.display().to_string()),
        );
        from_text(&text)
    };
    assert!(on_decel("[0.25, 1]").is_ok());
    let e = on_decel("[0.25, 800]").expect_err("D = 1600").to_string();
    assert!(
        e.starts_with("test-sweep.json: axes.accel_deg_per_s2[1]: A = 800 deg/s^2 scales the deceleration limit (1 deg/s^2 at A = 0.5 deg/s^2) to 1600 deg/s^2: "),
        "{e}"
    );
    assert!(e.contains("`gantry.max_decel_deg_per_s2`"), "{e}");

    // A UTF-8 byte-order mark, as some editors write it.
    let bom = format!("\u{feff}{GOOD}");
    assert!(parse_sweep_file(&bom, "bom.json").is_ok());
    assert_eq!(from_text(&bom).expect("BOM").combinations(), 2);
    let path = dir.join("bom-sweep.json");
    std::fs::write(
        &path,
        bom.replace(
            "\"../plans/",
            &format!("\"{}/", scenarios().join("../plans").display()),
        )
        .replace(
            "\"machine-atom.json\"",
            &format!(
                "{:?}",
                scenarios().join("machine-atom.json").display().to_string()
            ),
        ),
    )
    .expect("write sweep");
    assert_eq!(Sweep::load(&path).expect("BOM file").combinations(), 2);
}

/// A reference file that is not the ATOM cases file is named in the error.
#[test]
fn wrong_atom_reference_file_is_named() {
    let dir = temp_dir();
    std::fs::write(dir.join("wrong.json"), r#"{"something": "else"}"#).expect("write");
    let text = r#"{"format": "arcsim-sweep/1", "name": "t",
        "plans": [{"atom_case": "liver", "reference": "wrong.json"}], "machine": "m.json",
        "axes": {"jerk_deg_per_s3": [0.5]}, "schedules": ["scan"]}"#;
    std::fs::write(dir.join("s.json"), text).expect("write");
    let machine = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/machine-atom.json");
    std::fs::copy(machine, dir.join("m.json")).expect("machine");
    let err = arcsim_evaluator::Sweep::load(&dir.join("s.json"))
        .map(|_| ())
        .expect_err("a wrong reference fails")
        .to_string();
    assert!(err.contains("wrong.json"), "{err}");
}

/// The lung plan's scan does not depend on V (3, 5 or 6 deg/s give the same totals, to rounding):
/// the fastest setting is the one at the base machine's V 5 whatever the order or subset of the
/// rows, and the summary says V has no effect, in the table and the JSON.
#[test]
fn fastest_setting_ties_go_to_the_base_machine_and_no_effect_is_said() {
    let text = with_axes(
        r#"{"jerk_deg_per_s3": [0.5, 2], "accel_deg_per_s2": [0.5, 1], "speed_deg_per_s": [3, 5, 6]}"#,
    )
    .replace("prostate.json", "lung.json");
    let ev = Evaluator::new(from_text(&text).expect("sweep")).expect("prepare");
    assert_eq!(ev.len(), 12);
    let rows = ev.run_collect(&(0..ev.len()).collect::<Vec<_>>());
    let total = |i: usize| rows[i].outcome.expect("ok").total_s;
    // J 2, A 1 at V 3, 5, 6: rows 3, 7, 11, equal to rounding (the premise of this test).
    let fastest = [3, 7, 11].map(total);
    for t in fastest {
        assert!((t - fastest[1]).abs() <= 1e-12 * t, "{fastest:?}");
    }
    assert!(rows
        .iter()
        .all(|r| r.outcome.expect("ok").total_s >= fastest[1] * (1.0 - 1e-12)));

    let s = ev.summarize(&rows);
    let table = s.to_table();
    print!("{table}");
    let e = &s.entries[0];
    let f = e.fastest.expect("fastest");
    assert_eq!(f.index, Some(7), "{f:?}");
    assert_eq!(
        (
            f.setting.jerk_deg_per_s3,
            f.setting.accel_deg_per_s2,
            f.setting.speed_deg_per_s
        ),
        (2.0, 1.0, 5.0)
    );
    assert!(table.contains("J 2, A 1, V 5\n"), "{table}");
    // The same pick from the rows in reverse order, and from each shard holding row 7.
    let reversed: Vec<Row> = rows.iter().rev().cloned().collect();
    assert_eq!(ev.summarize(&reversed).entries[0].fastest, Some(f));
    let odd: Vec<Row> = rows.iter().filter(|r| r.index % 2 == 1).cloned().collect();
    assert_eq!(
        ev.summarize(&odd).entries[0].fastest.and_then(|p| p.index),
        Some(7)
    );
    // Without V 5: V 6, the smaller change (|ln 6/5| < |ln 3/5|), in either order.
    let no_v5: Vec<Row> = rows.iter().filter(|r| r.index != 7).cloned().collect();
    let rev_no_v5: Vec<Row> = no_v5.iter().rev().cloned().collect();
    for r in [&no_v5, &rev_no_v5] {
        assert_eq!(
            ev.summarize(r).entries[0].fastest.and_then(|p| p.index),
            Some(11)
        );
    }

    // V: no effect over the values evaluated (3 to 6, and 5/1.1 and 5.5); J has an effect.
    let sens = |a: Axis| *e.sensitivity.iter().find(|x| x.axis == a).expect("axis");
    let v = sens(Axis::Speed);
    assert!(v.no_effect, "{v:?}");
    assert_eq!((v.evaluated_min, v.evaluated_max), (3.0, 6.0));
    let j = sens(Axis::Jerk);
    assert!(!j.no_effect, "{j:?}");
    assert_eq!((j.evaluated_min, j.evaluated_max), (0.5 / 1.1, 2.0));
    assert!(table.contains("no effect (3–6 deg/s)"), "{table}");
    let json = serde_json::to_value(&s).expect("json");
    let v_json = &json["entries"][0]["sensitivity"][2];
    assert_eq!(v_json["axis"], "speed");
    assert_eq!(v_json["no_effect"], true);
    assert_eq!(v_json["evaluated_min"], 3.0);
    assert_eq!(v_json["evaluated_max"], 6.0);
    assert_eq!(json["entries"][0]["sensitivity"][0]["no_effect"], false);
}

/// Every limit column holds the value used: swept, or the base machine's (ELST up 5 s, down
/// 0.5 s, window 1 deg, dose-rate scale 1 on the ATOM machine), empty only for the scanning speed
/// its `per_mu` beam model does not have; shards merge into the single-run table
/// byte for byte and the table reads back into rows that write it again byte for byte.
#[test]
fn csv_writes_the_limit_used_in_every_column() {
    let text = with_axes(r#"{"jerk_deg_per_s3": [0.5, 1], "elst_down_s": [0.5, 1]}"#);
    let ev = Evaluator::new(from_text(&text).expect("sweep")).expect("prepare");
    assert_eq!(ev.len(), 4);
    let rows = ev.run_collect(&(0..ev.len()).collect::<Vec<_>>());
    let single = csv(&rows);
    let limits: Vec<Vec<&str>> = single
        .lines()
        .skip(1)
        .map(|l| l.split(',').skip(4).take(8).collect())
        .collect();
    assert_eq!(
        limits,
        [
            ["0.5", "0.5", "5", "5", "0.5", "1", "", "1"],
            ["1", "0.5", "5", "5", "0.5", "1", "", "1"],
            ["0.5", "0.5", "5", "5", "1", "1", "", "1"],
            ["1", "0.5", "5", "5", "1", "1", "", "1"],
        ]
    );
    // The settings still say which limits the sweep left to the machine (and the plan).
    assert_eq!(rows[0].setting.elst_up_s, None);
    assert_eq!(rows[0].setting.window_deg, None);
    assert_eq!(rows[0].setting.elst_down_s, Some(0.5));

    let shards: Vec<(String, String)> = (1..=3)
        .rev()
        .map(|k| {
            let shard = Shard::new(k, 3).expect("shard");
            (
                format!("shard-{k}.csv"),
                csv(&ev.run_collect(&shard.indices(ev.len()))),
            )
        })
        .collect();
    let merged = merge_csv(&shards, Some(ev.len())).expect("merge");
    assert_eq!(merged.as_bytes(), single.as_bytes());
    let back = ev.rows_from_csv("merged.csv", &merged).expect("read back");
    assert_eq!(csv(&back).as_bytes(), single.as_bytes());
    assert_eq!(
        ev.summarize(&back).to_table(),
        ev.summarize(&rows).to_table()
    );
    // A table with those columns empty is another combination, and the error says so.
    let old = single.replace(",5,0.5,1,,1,,,,,ok,", ",,0.5,,,1,,,,,ok,");
    assert_ne!(old, single);
    let err = ev
        .rows_from_csv("old.csv", &old)
        .expect_err("empty columns")
        .to_string();
    assert!(
        err.contains("old.csv: line 2: row 0 is ../plans/prostate.json scan J 0.5 A 0.5 V 5 ELST up 5 ELST down 0.5 window 1")
            && err.contains("the file has another combination"),
        "{err}"
    );

    // A polynomial ELST model has no single upward time: that column only is empty.
    // The fast machine's controller is free motion: constant speed asked for, as the row shows.
    let text = GOOD
        .replace("machine-atom.json", "machine-fast.json")
        .replace(
            "\"schedules\": [\"scan\"]",
            "\"schedules\": [{\"schedule\": \"scan\", \"motion\": \"constant\"}]",
        );
    let ev = Evaluator::new(from_text(&text).expect("sweep")).expect("prepare");
    let rows = ev.run_collect(&[0, 1]);
    let table = csv(&rows);
    let line = table.lines().nth(1).expect("row 0");
    assert!(
        line.starts_with("0,2,../plans/prostate.json,scan,0.5,1.5,6,,0.3,1,,1,,,,,ok,"),
        "{line}"
    );
    let back = ev.rows_from_csv("fast.csv", &table).expect("read back");
    assert_eq!(csv(&back), table);
}

/// An ELST table has no single up or down time: sweeping either is refused, naming the model;
/// other axes run, and the ELST columns of the rows stay empty and read back.
#[test]
fn elst_tables_are_not_swept_but_run() {
    let dir = temp_dir().join("elst-table-sweep");
    std::fs::create_dir_all(&dir).expect("dir");
    let mut machine: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(scenarios().join("machine-atom.json")).expect("machine"),
    )
    .expect("machine json");
    machine["name"] = "pairs".into();
    machine["elst"] = serde_json::json!({
        "kind": "by_energy_pair",
        "energies_mev": [100, 200],
        "switch_s": [[0.4, 5.0], [0.6, 0.4]],
        "same_s": 0.1
    });
    std::fs::write(dir.join("machine-pairs.json"), machine.to_string()).expect("write");
    let plan = scenarios().join("../plans/prostate.json");
    let sweep = |axes: &str| {
        format!(
            r#"{{"format": "arcsim-sweep/1", "name": "t", "plans": [{plan:?}],
                "machine": "machine-pairs.json", "axes": {axes}, "schedules": ["scan"]}}"#,
            plan = plan.display().to_string()
        )
    };
    for (axis, expected) in [
        ("elst_up_s", "expected a constant one to sweep the upward"),
        (
            "elst_down_s",
            "expected a constant or polynomial one to sweep the downward",
        ),
    ] {
        let text = sweep(&format!("{{\"{axis}\": [0.5, 1]}}"));
        let e = match crate::util::from_text_in(&text, &dir) {
            Ok(_) => panic!("{axis}: expected an error"),
            Err(e) => e.to_string(),
        };
        assert!(
            e.starts_with(&format!(
                "test-sweep.json: axes.{axis}: machine \"pairs\" has a by energy pair ELST model"
            )) && e.contains(expected),
            "{e}"
        );
    }
    let text = sweep("{\"jerk_deg_per_s3\": [0.5, 1]}");
    let ev =
        Evaluator::new(crate::util::from_text_in(&text, &dir).expect("sweep")).expect("prepare");
    let rows = ev.run_collect(&[0, 1]);
    assert!(rows.iter().all(|r| r.outcome.is_some()), "{rows:?}");
    let table = csv(&rows);
    let line = table.lines().nth(1).expect("row 0");
    assert!(line.contains(",scan,0.5,0.5,5,,,1,"), "{line}");
    let back = ev.rows_from_csv("pairs.csv", &table).expect("read back");
    assert_eq!(csv(&back), table);
}

/// A schedule given by name runs under the base machine's controller (issue 44): the fast
/// machine's is free motion, the ATOM machine's constant speed per layer; free arc ends on a
/// constant-speed machine without `"motion": "free"` are refused, naming the entry.
#[test]
fn a_named_schedule_takes_the_machine_s_controller() {
    let fast = GOOD.replace("machine-atom.json", "machine-fast.json");
    let ev = Evaluator::new(from_text(&fast).expect("sweep")).expect("prepare");
    let rows = ev.run_collect(&[0]);
    assert_eq!(rows[0].schedule.motion, arcsim_sequencer::Motion::Free);
    assert_eq!(rows[0].schedule.name(), "scan+free");
    let ev = Evaluator::new(from_text(GOOD).expect("sweep")).expect("prepare");
    let rows = ev.run_collect(&[0]);
    assert_eq!(rows[0].schedule.name(), "scan");
    let ends = GOOD.replace(
        "\"schedules\": [\"scan\"]",
        "\"schedules\": [{\"schedule\": \"scan\", \"arc_ends\": \"free\"}]",
    );
    let err = error_of(&ends);
    assert!(
        err.contains("schedules[0].arc_ends") && err.contains("\"motion\": \"free\""),
        "{err}"
    );
}
