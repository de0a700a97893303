//! Issue 48: what the plan's energy order costs (the switching table of `simulate` and
//! `validate`, the small upward steps located) and `arcsim resequence`, as a user runs them.

use std::path::Path;

use arcsim_test_support::{dicom, temp_dir};
use serde_json::Value;

use crate::util::{arcsim, path_str, repo_json, stderr, stdout};

/// Each control point's layers sorted by energy, ascending or descending.
fn sorted(mut plan: Value, ascending: bool) -> Value {
    for arc in plan["arcs"].as_array_mut().expect("arcs") {
        for cp in arc["control_points"]
            .as_array_mut()
            .expect("control points")
        {
            let layers = cp["layers"].as_array_mut().expect("layers");
            layers.sort_by(|a, b| {
                let (a, b) = (a["energy_mev"].as_f64(), b["energy_mev"].as_f64());
                let o = a.partial_cmp(&b).expect("energies");
                if ascending {
                    o
                } else {
                    o.reverse()
                }
            });
        }
    }
    plan
}

fn write(dir: &Path, name: &str, v: &Value) -> String {
    let p = dir.join(name);
    std::fs::write(&p, v.to_string()).expect("write");
    path_str(&p).to_string()
}

fn report(dir: &Path, args: &[&str]) -> Value {
    let out = dir.join("report.json");
    let mut all = vec!["resequence"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--json", path_str(&out)]);
    let o = arcsim(&all);
    assert!(o.status.success(), "{}", stderr(&o));
    serde_json::from_str(&std::fs::read_to_string(&out).expect("report")).expect("json")
}

/// `generate-plan --kind two-arc --spacing 2.5 --layers 2-4 --energy 70-230` (docs/commands.md's
/// plan) written in `dir`: its path and its JSON.
fn generated_two_arc(dir: &Path) -> (std::path::PathBuf, Value) {
    let gen = dir.join("two-arc-large.json");
    let o = arcsim(&[
        "generate-plan",
        "--kind",
        "two-arc",
        "--spacing",
        "2.5",
        "--layers",
        "2-4",
        "--energy",
        "70-230",
        "-o",
        path_str(&gen),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let plan = serde_json::from_str(&std::fs::read_to_string(&gen).expect("plan")).expect("json");
    (gen, plan)
}

fn total(plan: &str) -> f64 {
    let dir = temp_dir();
    let json = dir.join("total.json");
    let o = arcsim(&["simulate", plan, "--json", path_str(&json)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("json");
    v["total_s"].as_f64().expect("total_s")
}

/// A generated two-arc plan of 800–900 layers (2–4 per control point) with each control point's
/// layers in ascending energy: re-sequencing recovers at least the time of the same plan in
/// descending order; the written plan simulates to the reported total.
#[test]
fn resequencing_an_ascending_plan_recovers_the_descending_time() {
    let dir = temp_dir();
    let (_, plan) = generated_two_arc(&dir);
    let layers: usize = plan["arcs"]
        .as_array()
        .expect("arcs")
        .iter()
        .flat_map(|a| a["control_points"].as_array().expect("cps"))
        .map(|cp| cp["layers"].as_array().expect("layers").len())
        .sum();
    assert!((800..=900).contains(&layers), "{layers} layers");
    let up = write(&dir, "ascending.json", &sorted(plan.clone(), true));
    let down = write(&dir, "descending.json", &sorted(plan, false));
    let out = dir.join("out.json");
    let r = report(&dir, &[&up, "-o", path_str(&out)]);
    let descending = total(&down);
    let after = r["total_after_s"].as_f64().expect("after");
    let before = r["total_before_s"].as_f64().expect("before");
    assert!(
        after <= descending * (1.0 + 1e-9),
        "re-sequenced {after} s, the descending plan {descending} s (ascending {before} s)"
    );
    assert!(
        before - after > 100.0,
        "only {} s recovered",
        before - after
    );
    assert_eq!(total(path_str(&out)), after);
    let ups = |k: &str| {
        r[k]["by_class"]
            .as_array()
            .expect("classes")
            .iter()
            .find(|g| g["switch"] == "up")
            .map_or(0, |g| g["count"].as_u64().unwrap_or(0))
    };
    assert!(ups("switching_after") < ups("switching_before") / 2, "{r}");
}

/// docs/commands.md's figures are what `resequence` reports on the plan its commands make, and on
/// that plan with each control point's layers ascending.
#[test]
fn the_commands_doc_figures_are_what_resequence_reports() {
    let dir = temp_dir();
    let (gen, plan) = generated_two_arc(&dir);
    let r = report(&dir, &[path_str(&gen)]);
    let f = |k: &str| r[k].as_f64().expect(k);
    let plain = format!(
        "saves {:.2} s ({:.2} → {:.2} s; {} layers\nmoved)",
        f("total_before_s") - f("total_after_s"),
        f("total_before_s"),
        f("total_after_s"),
        r["moved_layers"]
    );
    let up = write(&dir, "ascending.json", &sorted(plan, true));
    let r = report(&dir, &[&up]);
    let f = |k: &str| r[k].as_f64().expect(k);
    let ascending = format!(
        "takes {:.2} s and\nre-sequencing brings it to {:.2} s",
        f("total_before_s"),
        f("total_after_s")
    );
    let doc = std::fs::read_to_string(crate::util::repo().join("docs/commands.md")).expect("doc");
    let doc = doc.replace("\r\n", "\n");
    assert!(doc.contains(&plain), "docs/commands.md should say: {plain}");
    assert!(
        doc.contains(&ascending),
        "docs/commands.md should say: {ascending}"
    );
}

/// A bundled plan is never slower: on each, re-sequencing keeps the plan or finds a shorter one,
/// and says which.
#[test]
fn bundled_plans_are_never_slower() {
    let dir = temp_dir();
    for name in ["prostate", "lung", "two-arc", "head-neck"] {
        let plan = format!("plans/{name}.json");
        let r = report(&dir, &[&plan]);
        let (b, a) = (
            r["total_before_s"].as_f64().expect("b"),
            r["total_after_s"].as_f64().expect("a"),
        );
        assert!(a <= b, "{name}: {a} > {b}");
        assert_eq!(r["resequenced"].as_bool(), Some(a < b), "{name}");
    }
}

/// Small upward steps (a layer a fraction of an MeV above the one before it): `validate` names
/// them with their control points and cost, `simulate` prints the switching table and writes it,
/// and re-sequencing removes those it can (here: all, each being inside a control point).
#[test]
fn small_upward_steps_are_named_costed_and_removed() {
    let dir = temp_dir();
    let mut plan = repo_json("plans/lung.json");
    // Three two-layer control points: the second layer 0.4 MeV above the first.
    let mut planted = Vec::new();
    for (c, cp) in plan["arcs"][0]["control_points"]
        .as_array_mut()
        .expect("cps")
        .iter_mut()
        .enumerate()
    {
        let layers = cp["layers"].as_array_mut().expect("layers");
        if layers.len() == 2 && planted.len() < 3 {
            let e = layers[0]["energy_mev"].as_f64().expect("energy");
            layers[1]["energy_mev"] = serde_json::json!(((e + 0.4) * 10.0).round() / 10.0);
            planted.push(c);
        }
    }
    assert_eq!(planted.len(), 3);
    let path = write(&dir, "small-steps.json", &plan);
    let o = arcsim(&["validate", &path]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("3 upward steps below 1 MeV: 15.00 s"),
        "{text}"
    );
    for c in &planted {
        assert!(
            text.lines()
                .any(|l| l.split_whitespace().take(4).collect::<Vec<_>>()
                    == ["0", &c.to_string(), "→", &c.to_string()]),
            "control point {c} not named:\n{text}"
        );
    }
    let json = dir.join("sim.json");
    let o = arcsim(&["simulate", &path, "--json", path_str(&json)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("energy switches by class and step"),
        "{}",
        stdout(&o)
    );
    let v: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("json");
    assert_eq!(
        v["switching"]["small_upward"].as_array().map(Vec::len),
        Some(3)
    );
    assert_eq!(v["switching"]["small_upward_cost_s"].as_f64(), Some(15.0));
    let r = report(&dir, &[&path]);
    assert_eq!(
        r["switching_before"]["small_upward"]
            .as_array()
            .map(Vec::len),
        Some(3)
    );
    assert_eq!(
        r["switching_after"]["small_upward"]
            .as_array()
            .map(Vec::len),
        Some(0),
        "{r}"
    );
}

/// Outputs are checked before any work: the plan is never overwritten, DICOM write-back is
/// refused with the reason.
#[test]
fn resequence_refuses_unsafe_or_unavailable_outputs() {
    let dir = temp_dir();
    let plan = write(&dir, "p.json", &repo_json("plans/lung.json"));
    let o = arcsim(&["resequence", &plan, "-o", &plan]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let dcm = dir.join("p.dcm");
    let o = arcsim(&["resequence", &plan, "-o", path_str(&dcm)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("written back from a DICOM input"),
        "{}",
        stderr(&o)
    );
    assert!(!dcm.exists());
    let original = dir.join("multi.dcm");
    std::fs::write(&original, dicom::multi_layer_arc_plan().to_bytes()).expect("write");
    let o = arcsim(&[
        "resequence",
        path_str(&original),
        "--turn-arcs",
        "-o",
        path_str(&dcm),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("drop --turn-arcs"), "{}", stderr(&o));
    assert!(!dcm.exists());
}

/// The bundled DICOM plan re-sequenced and written back as DICOM: the file imports to exactly
/// the plan written as JSON by the same run; docs/commands.md's figures are what it reports.
#[test]
fn a_dicom_plan_is_written_back_as_dicom() {
    let dir = temp_dir();
    let original = crate::util::repo().join("plans/dicom/multi.dcm");
    let (dcm, json) = (dir.join("fast.dcm"), dir.join("fast.json"));
    let r = report(&dir, &[path_str(&original), "-o", path_str(&dcm)]);
    assert!(r["moved_layers"].as_u64().is_some_and(|n| n > 0), "{r}");
    let f = |k: &str| r[k].as_f64().expect(k);
    let figures = format!(
        "goes from {:.2} to {:.2} s ({} layers moved)",
        f("total_before_s"),
        f("total_after_s"),
        r["moved_layers"]
    );
    let doc = std::fs::read_to_string(crate::util::repo().join("docs/commands.md")).expect("doc");
    assert!(
        doc.replace("\r\n", "\n")
            .replace('\n', " ")
            .contains(&figures),
        "docs/commands.md should say: {figures}"
    );
    let o = arcsim(&["resequence", path_str(&original), "-o", path_str(&json)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let back = dir.join("back.json");
    let o = arcsim(&["import", path_str(&dcm), "-o", path_str(&back)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let read = |p: &Path| -> Value {
        serde_json::from_str(&std::fs::read_to_string(p).expect("read")).expect("json")
    };
    assert_eq!(read(&back)["arcs"], read(&json)["arcs"]);
    assert_ne!(read(&back)["arcs"], {
        let o = dir.join("as-given.json");
        let out = arcsim(&["import", path_str(&original), "-o", path_str(&o)]);
        assert!(out.status.success(), "{}", stderr(&out));
        read(&o)["arcs"].clone()
    });
}

/// A sweep file's `resequence: [false, true]` runs each plan as given and re-sequenced, beside
/// the gantry's axes: the twin's rows carry `(re-sequenced)`, its base-machine total is what
/// `resequence` reports, and the sweep says what re-sequencing bought. `true` runs twins only;
/// `[]` is refused naming the field.
#[test]
fn a_sweep_runs_plans_as_given_and_resequenced() {
    let dir = temp_dir();
    let up = write(
        &dir,
        "ascending.json",
        &sorted(repo_json("plans/lung.json"), true),
    );
    let machine = crate::util::repo().join("scenarios/machine-atom.json");
    let sweep = |name: &str, resequence: Value| {
        let v = serde_json::json!({
            "format": "arcsim-sweep/1", "name": "reseq", "plans": [up],
            "machine": path_str(&machine),
            "axes": {"jerk_deg_per_s3": [0.5, 1]},
            "schedules": ["optimal"], "resequence": resequence
        });
        write(&dir, name, &v)
    };
    let csv = dir.join("rows.csv");
    let o = arcsim(&[
        "sweep",
        &sweep("both.json", serde_json::json!([false, true])),
        "--out",
        path_str(&csv),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&csv).expect("csv");
    // Rows are labelled by the plan's path relative to the sweep file.
    let (label, twin) = ("ascending.json", "ascending.json (re-sequenced)");
    assert_eq!(
        text.lines().filter(|l| l.contains(twin)).count(),
        2,
        "{text}"
    );
    assert_eq!(
        text.lines()
            .filter(|l| l.contains(label) && !l.contains(twin))
            .count(),
        2
    );
    let r = report(&dir, &[&up]);
    let after = r["total_after_s"].as_f64().expect("after");
    let line = stdout(&o)
        .lines()
        .find(|l| l.trim_start().starts_with(&format!("{label}: ")))
        .map(str::to_string)
        .unwrap_or_else(|| panic!("no re-sequencing line:\n{}", stdout(&o)));
    assert!(
        line.contains(&format!("→ {after:.2} s")),
        "{line} (resequence: {after})"
    );
    // The twin's row at the base machine (J 0.5) is that total.
    let header: Vec<&str> = text.lines().next().expect("header").split(',').collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .unwrap_or_else(|| panic!("{name}: {header:?}"))
    };
    let (plan_col, j_col, total_col) = (col("plan"), col("jerk_deg_per_s3"), col("total_s"));
    let base = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .find(|f| f[plan_col].contains("re-sequenced") && f[j_col] == "0.5")
        .expect("twin row at the base machine");
    let total: f64 = base[total_col].parse().expect("total");
    assert!((total - after).abs() <= 1e-9 * after, "{total} vs {after}");

    let only = arcsim(&[
        "sweep",
        &sweep("only.json", serde_json::json!(true)),
        "--out",
        path_str(&dir.join("only.csv")),
    ]);
    assert!(only.status.success(), "{}", stderr(&only));
    let text = std::fs::read_to_string(dir.join("only.csv")).expect("csv");
    assert_eq!(
        text.lines().skip(1).filter(|l| !l.contains(twin)).count(),
        0,
        "{text}"
    );

    let none = arcsim(&["sweep", &sweep("none.json", serde_json::json!([]))]);
    assert_eq!(none.status.code(), Some(1), "{}", stderr(&none));
    assert!(stderr(&none).contains("resequence"), "{}", stderr(&none));
}
