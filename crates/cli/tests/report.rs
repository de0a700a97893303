//! `sweep --report/--plot` and `sweep-merge --report/--plot/--rrd`: the static report's structure
//! checked against the sweep's own rows and summary (`--json`), as a user would run it.

use std::path::{Path, PathBuf};

use arcsim_test_support::temp_dir;

use crate::util::{arcsim, path_str, sweep_file, text};
use serde_json::Value;

/// An HTML attribute's value in `tag` (the report writes `name="value"`).
fn attr(tag: &str, name: &str) -> Option<String> {
    let start = tag.find(&format!(" {name}=\""))? + name.len() + 3;
    let len = tag[start..].find('"')?;
    Some(
        tag[start..start + len]
            .replace("&quot;", "\"")
            .replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&amp;", "&"),
    )
}

/// One `<section class="entry">` of the report.
struct Section {
    plan: String,
    schedule: String,
    /// (V, SVG) of each heatmap, in order.
    heatmaps: Vec<(f64, String)>,
    other_figures: Vec<String>,
}

fn sections(html: &str) -> Vec<Section> {
    html.split("<section class=\"entry\"")
        .skip(1)
        .map(|part| {
            let open = &part[..part.find('>').expect("section tag")];
            let mut s = Section {
                plan: attr(open, "data-plan").expect("data-plan"),
                schedule: attr(open, "data-schedule").expect("data-schedule"),
                heatmaps: vec![],
                other_figures: vec![],
            };
            for fig in part.split("<figure class=\"").skip(1) {
                let tag = &fig[..fig.find('>').expect("figure tag")];
                let body = &fig[..fig.find("</figure>").expect("figure end")];
                if fig.starts_with("heatmap\"") {
                    let v = attr(tag, "data-speed-deg-per-s").expect("V of a heatmap");
                    s.heatmaps
                        .push((v.parse().expect("V is a number"), body.to_string()));
                } else {
                    s.other_figures.push(tag.to_string());
                }
            }
            s
        })
        .collect()
}

/// How many SVG text elements of `svg` read `text` (surrounding white space aside).
fn texts(svg: &str, text: &str) -> usize {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let body = &t[t.find('>')? + 1..];
            Some(body[..body.find("</text>")?].trim())
        })
        .filter(|t| *t == text)
        .count()
}

fn same(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs())
}

/// The rows of the results document for one plan and schedule.
fn rows_of<'a>(results: &'a Value, plan: &str, schedule: &str) -> Vec<&'a Value> {
    results["rows"]
        .as_array()
        .expect("rows")
        .iter()
        .filter(|r| r["plan"] == plan && r["schedule"] == schedule)
        .collect()
}

fn num(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

fn svg_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("plot dir")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "svg"))
        .collect();
    files.sort();
    files
}

/// Checks a report against the sweep's results document: one heatmap per plan, schedule and V
/// of the rows; units on the axes; every feasible row's total in its heatmap; the base machine
/// marked exactly once, in the heatmap of its V; the cheapest change (when it is a grid row)
/// outlined in the heatmap of its V; a sensitivity and a breakdown figure per section.
fn check_report(html: &str, results: &Value, base: (f64, f64, f64)) -> usize {
    let entries = results["summary"]["entries"].as_array().expect("entries");
    let secs = sections(html);
    assert_eq!(secs.len(), entries.len(), "a section per plan and schedule");
    let mut figures = 0;
    for (sec, entry) in secs.iter().zip(entries) {
        let what = format!("{} · {}", sec.plan, sec.schedule);
        assert_eq!(sec.plan, entry["plan"].as_str().expect("plan"), "{what}");
        assert_eq!(sec.schedule, entry["schedule"].as_str().expect("schedule"));
        let rows = rows_of(results, &sec.plan, &sec.schedule);
        let mut speeds: Vec<f64> = rows
            .iter()
            .map(|r| num(&r["setting"]["speed_deg_per_s"]))
            .collect();
        speeds.sort_by(f64::total_cmp);
        speeds.dedup();
        let drawn: Vec<f64> = sec.heatmaps.iter().map(|h| h.0).collect();
        assert_eq!(drawn, speeds, "{what}: one heatmap per V, in order");
        for (v, svg) in &sec.heatmaps {
            for label in ["J (°/s³)", "A (°/s²)", "total (s)"] {
                assert_eq!(texts(svg, label), 1, "{what} V {v}: axis label {label}");
            }
            for r in rows
                .iter()
                .filter(|r| same(num(&r["setting"]["speed_deg_per_s"]), *v))
            {
                let shown = match r["outcome"]["total_s"].as_f64() {
                    Some(t) => format!("{t:.1}"),
                    None => "infeasible".into(),
                };
                assert!(
                    texts(svg, &shown) >= 1,
                    "{what} V {v}: row {} ({shown}) not in its heatmap",
                    r["index"]
                );
            }
            let base_here = same(*v, base.2)
                && rows.iter().any(|r| {
                    same(num(&r["setting"]["jerk_deg_per_s3"]), base.0)
                        && same(num(&r["setting"]["accel_deg_per_s2"]), base.1)
                        && same(num(&r["setting"]["speed_deg_per_s"]), base.2)
                });
            assert_eq!(
                texts(svg, "base"),
                usize::from(base_here),
                "{what} V {v}: base machine marked iff its cell is here"
            );
            let target_here = entry["cheapest"]["index"].as_u64().is_some_and(|i| {
                rows.iter().any(|r| {
                    r["index"].as_u64() == Some(i)
                        && same(num(&r["setting"]["speed_deg_per_s"]), *v)
                })
            });
            assert_eq!(
                texts(svg, "target"),
                usize::from(target_here),
                "{what} V {v}: the cheapest change outlined iff it is a row of this V"
            );
        }
        let kinds: Vec<&str> = sec
            .other_figures
            .iter()
            .map(|t| t.split('"').next().unwrap_or(""))
            .collect();
        assert_eq!(kinds, ["sensitivity", "breakdown"], "{what}");
        figures += sec.heatmaps.len() + sec.other_figures.len();
    }
    figures
}

/// The bundled ATOM sweep, its three schedule entries as they are (V swept by `scan` only), on 6 of
/// its 7 plans: the 722-layer head-neck is left out, whose three free-motion settings alone take
/// about three minutes.
#[test]
fn atom_sweep_report_has_a_heatmap_per_plan_and_speed_with_the_base_marked() {
    let _turn = crate::util::one_heavy_test_at_a_time();
    let dir = temp_dir();
    let (html, json, plots) = (dir.join("report.html"), dir.join("r.json"), dir.join("svg"));
    let mut sweep = crate::util::repo_json("scenarios/sweep-atom.json");
    let repo = crate::util::repo();
    let plans = sweep["plans"].as_array_mut().expect("plans");
    assert_eq!(
        plans[0], "../plans/*.json",
        "the sweep's first entry globs the bundled plans"
    );
    plans[0] = serde_json::json!(path_str(&repo.join("plans/lung.json")));
    plans.insert(
        1,
        serde_json::json!(path_str(&repo.join("plans/prostate.json"))),
    );
    plans.insert(
        2,
        serde_json::json!(path_str(&repo.join("plans/two-arc.json"))),
    );
    for p in plans.iter_mut().skip(3) {
        let rel = p["path"].as_str().expect("path").trim_start_matches("../");
        p["path"] = serde_json::json!(path_str(&repo.join(rel)));
    }
    sweep["machine"] = serde_json::json!(path_str(&repo.join("scenarios/machine-atom.json")));
    let sweep_path = dir.join("sweep-atom-6.json");
    std::fs::write(&sweep_path, sweep.to_string()).expect("write sweep");
    let o = arcsim(&[
        "sweep",
        path_str(&sweep_path),
        "--report",
        path_str(&html),
        "--plot",
        path_str(&plots),
        "--json",
        path_str(&json),
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}\n{err}");
    assert!(err.contains("report: "), "{err}");
    let results: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("json");
    let html = std::fs::read_to_string(&html).expect("report");
    assert!(html.starts_with("<!DOCTYPE html>") && html.trim_end().ends_with("</html>"));
    assert!(
        !html.contains("src=\"http") && !html.contains("href=\"http"),
        "self-contained"
    );
    let figures = check_report(&html, &results, (0.5, 0.5, 5.0));
    let secs = sections(&html);
    assert_eq!(secs.len(), 6 * 3);
    // scan sweeps V over 3, 5, 6; the optimal entries only V 5.
    let per_schedule = |s: &str| {
        secs.iter()
            .filter(|x| x.schedule == s)
            .map(|x| x.heatmaps.len())
            .collect::<Vec<_>>()
    };
    assert_eq!(per_schedule("scan"), vec![3; 6]);
    assert_eq!(per_schedule("optimal"), vec![1; 6]);
    assert_eq!(per_schedule("optimal+free"), vec![1; 6]);

    let files = svg_files(&plots);
    assert_eq!(files.len(), figures, "--plot writes every figure");
    for f in &files {
        let svg = std::fs::read_to_string(f).expect("svg");
        assert!(
            svg.contains("<svg") && svg.trim_end().ends_with("</svg>"),
            "{f:?}"
        );
    }
}

/// A sharded sweep's report after `sweep-merge --sweep` is the single run's, byte for byte, and
/// so is its Rerun recording's size class (same rows); flags that need the sweep file say so.
#[test]
fn merged_shards_give_the_single_run_report() {
    let _turn = crate::util::one_heavy_test_at_a_time();
    let dir = temp_dir();
    let sweep = sweep_file(
        &dir,
        "pictures",
        "plans/prostate.json",
        serde_json::json!({
            "jerk_deg_per_s3": [0.5, 1, 2],
            "accel_deg_per_s2": [0.5, 1],
            "speed_deg_per_s": [3, 5]
        }),
    );
    let sweep = path_str(&sweep).to_string();
    let single = dir.join("single.html");
    let json = dir.join("single.json");
    let o = arcsim(&[
        "sweep",
        &sweep,
        "--report",
        path_str(&single),
        "--json",
        path_str(&json),
    ]);
    assert!(o.status.success(), "{:?}", text(&o));
    let results: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("json");
    let single = std::fs::read_to_string(&single).expect("report");
    assert_eq!(check_report(&single, &results, (0.5, 0.5, 5.0)), 2 + 2);

    let mut shards = vec![];
    for k in 1..=2 {
        let csv = dir.join(format!("shard{k}.csv"));
        let shard = format!("{k}/2");
        let o = arcsim(&["sweep", &sweep, "--shard", &shard, "--out", path_str(&csv)]);
        assert!(o.status.success(), "{:?}", text(&o));
        shards.push(csv);
    }
    let (merged, html, rrd, plots) = (
        dir.join("merged.csv"),
        dir.join("merged.html"),
        dir.join("merged.rrd"),
        dir.join("svg"),
    );
    let o = arcsim(&[
        "sweep-merge",
        path_str(&shards[0]),
        path_str(&shards[1]),
        "--out",
        path_str(&merged),
        "--sweep",
        &sweep,
        "--report",
        path_str(&html),
        "--rrd",
        path_str(&rrd),
        "--plot",
        path_str(&plots),
    ]);
    assert!(o.status.success(), "{:?}", text(&o));
    let merged_html = std::fs::read_to_string(&html).expect("merged report");
    assert!(
        merged_html == single,
        "the merged report differs from the single run's"
    );
    assert_eq!(svg_files(&plots).len(), 4);
    let rrd_bytes = std::fs::read(&rrd).expect("rrd");
    assert!(rrd_bytes.starts_with(b"RRF2"), "an rrd file");

    // Without the sweep file there are no rows to draw: a usage error, nothing written.
    for flag in ["--report", "--rrd", "--plot"] {
        let out = dir.join("nothing");
        let o = arcsim(&[
            "sweep-merge",
            path_str(&shards[0]),
            path_str(&shards[1]),
            "--out",
            path_str(&dir.join("m2.csv")),
            flag,
            path_str(&out),
        ]);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{flag}: {err}");
        assert!(err.contains("--sweep"), "{flag}: {err}");
        assert!(!out.exists() && !dir.join("m2.csv").exists());
    }
}

/// `--plot` must name a directory (or a new one in an existing directory); checked before the
/// sweep runs.
#[test]
fn plot_dir_is_checked_before_the_sweep() {
    let dir = temp_dir();
    let sweep = sweep_file(
        &dir,
        "p",
        "plans/prostate.json",
        serde_json::json!({ "jerk_deg_per_s3": [0.5, 1] }),
    );
    let file = dir.join("a-file");
    std::fs::write(&file, "x").expect("write");
    let missing = dir.join("no-such-dir").join("svg");
    for (plot, expect) in [(&file, "is a file"), (&missing, "does not exist")] {
        let o = arcsim(&["sweep", path_str(&sweep), "--plot", path_str(plot)]);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(expect), "{err}");
        assert!(!err.contains("evaluated"), "refused before the run: {err}");
    }
    // A new directory is created.
    let new = dir.join("new");
    let o = arcsim(&["sweep", path_str(&sweep), "--plot", path_str(&new)]);
    assert!(o.status.success(), "{:?}", text(&o));
    assert_eq!(
        svg_files(&new).len(),
        1 + 2,
        "one heatmap (one V), sensitivity, breakdown"
    );
}
