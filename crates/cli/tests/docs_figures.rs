//! The figures the README's prose quotes, produced by the commands that make them: each
//! paragraph's numbers are computed here from `arcsim simulate --json` runs, formatted as the
//! text quotes them, and the text must hold them (line breaks compare as spaces). A claim without
//! a number ("doubling V changes nothing") is checked as a law of the runs.
//!
//! When a change of the solver or a model moves the figures, run
//! `ARCSIM_BLESS_DOCS=1 cargo test -p arcsim --test integration docs_figures` to write the new
//! figures into the documents (each quoted passage found by its words, its numbers replaced in
//! place), then read the diff: a claim in words may no longer hold.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use arcsim_test_support::temp_dir;
use serde_json::Value;

use crate::util::{arcsim, path_str, repo, text};

/// A passage a document must hold.
struct Quote {
    doc: &'static str,
    text: String,
    /// A line of a quoted output block: the document holds it as a whole line, spaces and
    /// all (trailing spaces aside), and blessing replaces the whole line.
    line: bool,
}

impl Quote {
    /// A passage of prose (line breaks and runs of spaces compare as one space).
    fn prose(doc: &'static str, text: String) -> Quote {
        Quote {
            doc,
            text,
            line: false,
        }
    }
}

/// Runs `simulate` once per argument list and keeps its JSON result.
struct Runs {
    dir: PathBuf,
    /// Each run's result and its printed summary.
    results: HashMap<Vec<String>, (Value, String)>,
    machines: usize,
}

/// A JSON file's value.
fn json_file(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

impl Runs {
    fn new() -> Runs {
        Runs {
            dir: temp_dir(),
            results: HashMap::new(),
            machines: 0,
        }
    }

    /// A copy of the bundled machine `base` (in `scenarios/`) changed by `edit`: its path.
    fn machine(&mut self, base: &str, edit: impl FnOnce(&mut Value)) -> String {
        let mut m = json_file(&repo().join("scenarios").join(base));
        edit(&mut m);
        self.machines += 1;
        let path = self.dir.join(format!("machine-{}.json", self.machines));
        std::fs::write(&path, m.to_string()).expect("write machine");
        path_str(&path).to_string()
    }

    /// `arcsim simulate ARGS --json …`, once per argument list: its result and what it printed.
    fn run(&mut self, args: &[&str]) -> &(Value, String) {
        let key: Vec<String> = args.iter().map(ToString::to_string).collect();
        if !self.results.contains_key(&key) {
            let out_path = self.dir.join(format!("result-{}.json", self.results.len()));
            let mut all = vec!["simulate"];
            all.extend_from_slice(args);
            all.extend_from_slice(&["--json", path_str(&out_path)]);
            let printed = stdout_of(&all);
            self.results
                .insert(key.clone(), (json_file(&out_path), printed));
        }
        &self.results[&key]
    }

    /// `arcsim simulate ARGS`: the result.
    fn simulate(&mut self, args: &[&str]) -> &Value {
        &self.run(args).0
    }

    /// `arcsim simulate ARGS`: the summary it printed.
    fn printed(&mut self, args: &[&str]) -> String {
        self.run(args).1.clone()
    }

    /// The total delivery time of `simulate ARGS` (s).
    fn total(&mut self, args: &[&str]) -> f64 {
        number(self.simulate(args), "/total_s")
    }
}

fn number(v: &Value, pointer: &str) -> f64 {
    v.pointer(pointer)
        .and_then(Value::as_f64)
        .unwrap_or_else(|| panic!("no number at {pointer}"))
}

/// Words of `text` with their byte ranges.
fn words(text: &str) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = None;
    for (i, c) in text.char_indices() {
        match (c.is_whitespace(), start) {
            (true, Some(s)) => {
                out.push((s, i));
                start = None;
            }
            (false, None) => start = Some(i),
            _ => {}
        }
    }
    if let Some(s) = start {
        out.push((s, text.len()));
    }
    out
}

/// A word with every run of digits as `#`: two words that differ only in their numbers have
/// the same shape.
fn shape(word: &str) -> String {
    let mut out = String::new();
    let mut in_digits = false;
    for c in word.chars() {
        if c.is_ascii_digit() {
            if !in_digits {
                out.push('#');
            }
            in_digits = true;
        } else {
            out.push(c);
            in_digits = false;
        }
    }
    out
}

/// Where `quote` stands in `doc` with other numbers: the byte ranges of the document's words,
/// if exactly one passage matches.
fn passage(doc: &str, quote: &str) -> Result<Vec<(usize, usize)>, usize> {
    let dw = words(doc);
    let qw: Vec<&str> = words(quote).iter().map(|&(a, b)| &quote[a..b]).collect();
    if qw.is_empty() {
        return Err(0);
    }
    let same = |d: &str, q: &str| {
        d == q || (q.contains(|c: char| c.is_ascii_digit()) && shape(d) == shape(q))
    };
    let found: Vec<usize> = (0..dw.len().saturating_sub(qw.len() - 1))
        .filter(|&i| {
            qw.iter()
                .enumerate()
                .all(|(j, q)| same(&doc[dw[i + j].0..dw[i + j].1], q))
        })
        .collect();
    // Of passages alike (rows of a table), the one that shares the longest beginning with
    // the quote.
    let common = |i: usize| {
        doc[dw[i].0..]
            .chars()
            .zip(quote.trim_start().chars())
            .take_while(|(a, b)| a == b)
            .count()
    };
    let best = found.iter().map(|&i| common(i)).max().unwrap_or(0);
    let found: Vec<usize> = found.into_iter().filter(|&i| common(i) == best).collect();
    match found.as_slice() {
        [i] => Ok(dw[*i..*i + qw.len()].to_vec()),
        other => Err(other.len()),
    }
}

/// Checks every quote against its document; with `ARCSIM_BLESS_DOCS` set, writes the figures
/// into the documents instead (a passage found once by its words, its words replaced).
fn check(quotes: &[Quote]) {
    let bless = std::env::var_os("ARCSIM_BLESS_DOCS").is_some();
    let mut failures = Vec::new();
    let mut docs: HashMap<&str, String> = HashMap::new();
    for q in quotes {
        let doc = docs
            .entry(q.doc)
            .or_insert_with(|| std::fs::read_to_string(repo().join(q.doc)).expect("doc"));
        let flat = doc.split_whitespace().collect::<Vec<_>>().join(" ");
        let want = q.text.split_whitespace().collect::<Vec<_>>().join(" ");
        let holds = if q.line {
            doc.lines().any(|l| l.trim_end() == q.text.trim_end())
        } else {
            flat.contains(&want)
        };
        if holds {
            continue;
        }
        match passage(doc, &q.text) {
            Ok(at) if bless && q.line => {
                let start = doc[..at[0].0].rfind('\n').map_or(0, |i| i + 1);
                let end = doc[at[0].0..].find('\n').map_or(doc.len(), |i| at[0].0 + i);
                doc.replace_range(start..end, q.text.trim_end());
            }
            Ok(at) if bless => {
                let new: Vec<&str> = q.text.split_whitespace().collect();
                for (&(a, b), w) in at.iter().zip(new).rev() {
                    doc.replace_range(a..b, w);
                }
            }
            Ok(at) => failures.push(format!(
                "{}: {:?}\n    the commands give {:?}",
                q.doc,
                &doc[at[0].0..at[at.len() - 1].1],
                if q.line {
                    q.text.trim_end().to_string()
                } else {
                    want
                }
            )),
            Err(n) => failures.push(format!(
                "{}: {want:?} is not there ({n} passages of its words with other numbers)",
                q.doc
            )),
        }
    }
    if bless {
        for (name, text) in &docs {
            std::fs::write(repo().join(name), text).expect("write doc");
        }
    }
    assert!(
        failures.is_empty(),
        "{} figures differ from what the commands give (ARCSIM_BLESS_DOCS=1 writes them):\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn a_passage_is_found_by_its_words_whatever_its_numbers() {
    let doc = "saves 32.6 s on prostate\n(263.8 → 231.2 s) and 59.8 s on two-arc";
    let at = passage(doc, "saves 32.8 s on prostate (263.99 → 231.2 s)").expect("found");
    assert_eq!(
        &doc[at[0].0..at[at.len() - 1].1],
        "saves 32.6 s on prostate\n(263.8 → 231.2 s)"
    );
    // Other words, or a passage twice: not found.
    assert_eq!(passage(doc, "saves 32.6 s on lung"), Err(0));
    assert_eq!(passage("1 s and 2 s", "3 s"), Err(2));
    assert_eq!(shape("(263.99"), "(#.#");
}

/// The ATOM article's cases under free motion (README, "On the ATOM article cases").
fn atom_cases_free(r: &mut Runs) -> Vec<Quote> {
    let t: Vec<f64> = ["prostate", "head-and-neck", "liver"]
        .iter()
        .map(|c| r.total(&[&format!("plans/atom/{c}.json"), "--motion", "free"]))
        .collect();
    vec![Quote::prose(
        "README.md",
        format!(
            "Free motion on the same cases (prostate {:.2} s, head-and-neck {:.2} s, liver {:.2} s with the gantry at rest at the arc ends)",
            t[0], t[1], t[2]
        ),
    )]
}

/// README, "On a synchrocyclotron: gantry or bursts?": the sweep `sweep-proteusone.json`'s
/// corners, each one simulation.
fn synchrocyclotron(r: &mut Runs) -> Vec<Quote> {
    let base = "machine-proteusone-like.json";
    let fast = r.machine(base, |m| {
        m["gantry"]["max_jerk_deg_per_s3"] = 1.0.into();
        m["gantry"]["max_accel_deg_per_s2"] = 1.0.into();
    });
    let half = r.machine(base, |m| m["beam"]["burst_switching_time_s"] = 0.075.into());
    let quick = r.machine(base, |m| m["gantry"]["max_speed_deg_per_s"] = 10.0.into());
    let base = format!("scenarios/{base}");
    let free = ["--motion", "free", "--schedule", "optimal"];
    let scan = ["--schedule", "scan"];
    // (base, J and A doubled, bursts halved) of each plan under each motion.
    let mut corners = |plan: &str, motion: &[&str]| -> [f64; 3] {
        let plan = format!("plans/{plan}.json");
        [&base, &fast, &half].map(|m| {
            let mut args = vec![plan.as_str(), "--machine", m];
            args.extend_from_slice(motion);
            r.total(&args)
        })
    };
    let [pf, pf_ja, pf_b] = corners("prostate", &free);
    let [tf, tf_ja, tf_b] = corners("two-arc", &free);
    let [lf, lf_ja, lf_b] = corners("lung", &free);
    let [ps, ps_ja, ps_b] = corners("prostate", &scan);
    let [ls, ls_ja, ls_b] = corners("lung", &scan);
    let [ts, ts_ja, ts_b] = corners("two-arc", &scan);
    let lung_bursts = number(
        r.simulate(&[
            "plans/lung.json",
            "--machine",
            &base,
            "--motion",
            "free",
            "--schedule",
            "optimal",
        ]),
        "/breakdown/burst_switching_s",
    );
    // Doubling V changes nothing under scan.
    for plan in ["prostate", "lung", "two-arc"] {
        let p = format!("plans/{plan}.json");
        let (a, b) = (
            r.total(&[&p, "--machine", &base, "--schedule", "scan"]),
            r.total(&[&p, "--machine", &quick, "--schedule", "scan"]),
        );
        assert!(
            (a - b).abs() < 0.005,
            "README says doubling V changes nothing: {plan} {a} s against {b} s"
        );
    }
    vec![
        Quote::prose(
            "README.md",
            format!(
                "With free motion, halving the burst switching saves {:.1} s on prostate ({pf:.1} → {pf_b:.1} s) and {:.1} s on two-arc, doubling both J and A {:.1} s and {:.1} s; on lung, where all its bursts cost {lung_bursts:.1} s, the gantry wins ({:.1} s against {:.1} s).",
                pf - pf_b,
                tf - tf_b,
                pf - pf_ja,
                tf - tf_ja,
                lf - lf_ja,
                lf - lf_b
            ),
        ),
        Quote::prose(
            "README.md",
            format!(
                "the gantry weighs more: doubling J and A saves {:.1} s on prostate ({ps:.1} → {ps_ja:.1} s) against {:.1} s for halved bursts, {:.1} s on lung against {:.1} s, {:.1} s on two-arc against {:.1} s.",
                ps - ps_ja,
                ps - ps_b,
                ls - ls_ja,
                ls - ls_b,
                ts - ts_ja,
                ts - ts_b
            ),
        ),
    ]
}

/// README, "On a synchrotron: what does multi-energy extraction buy?": the sweep
/// `sweep-probeat.json`'s cells, each one simulation.
fn synchrotron(r: &mut Runs) -> Vec<Quote> {
    let base = "machine-probeat-v5-like-mee.json";
    let spills = |charge: f64, layers: u32| {
        move |m: &mut Value| {
            m["beam"]["spill"]["charge_mu"] = charge.into();
            m["beam"]["spill"]["max_layers_per_spill"] = layers.into();
        }
    };
    let m40_1 = r.machine(base, spills(40.0, 1));
    let m40_5 = r.machine(base, spills(40.0, 5));
    let m160_1 = r.machine(base, spills(160.0, 1));
    let m160_5 = r.machine(base, spills(160.0, 5));
    let m40_left = r.machine(base, |m| {
        spills(40.0, 5)(m);
        m["beam"]["spill"]["continue_spill_if"] = "charge_left".into();
    });
    let free = ["--motion", "free", "--schedule", "optimal"];
    let scan = ["--schedule", "scan"];
    let mut total = |plan: &str, m: &str, motion: &[&str]| -> f64 {
        let plan = format!("plans/{plan}.json");
        let mut args = vec![plan.as_str(), "--machine", m];
        args.extend_from_slice(motion);
        r.total(&args)
    };
    let p40 = [
        total("prostate", &m40_1, &free),
        total("prostate", &m40_5, &free),
    ];
    let l40_scan = total("lung", &m40_1, &scan) - total("lung", &m40_5, &scan);
    let l40_free_more = total("lung", &m40_5, &free) - total("lung", &m40_1, &free);
    let p160 = [
        total("prostate", &m160_1, &free),
        total("prostate", &m160_5, &free),
    ];
    let p160_scan = total("prostate", &m160_1, &scan) - total("prostate", &m160_5, &scan);
    let l160 = [
        total("lung", &m160_1, &scan) - total("lung", &m160_5, &scan),
        total("lung", &m160_1, &free) - total("lung", &m160_5, &free),
    ];
    let p40_left = total("prostate", &m40_left, &free);
    // Two-arc: nothing (under 0.05 % of its total), at 40 and at 160 MU, under both motions.
    for (a, b) in [(&m40_1, &m40_5), (&m160_1, &m160_5)] {
        for motion in [&free[..], &scan[..]] {
            let (x, y) = (total("two-arc", a, motion), total("two-arc", b, motion));
            assert!(
                (x - y).abs() < 5e-4 * x,
                "README says extraction buys two-arc nothing: {x} s against {y} s ({motion:?})"
            );
        }
    }
    let switching = |r: &mut Runs, m: &str| {
        number(
            r.simulate(&[
                "plans/prostate.json",
                "--machine",
                m,
                "--motion",
                "free",
                "--schedule",
                "optimal",
            ]),
            "/breakdown/energy_switching_s",
        )
    };
    let (sw1, sw5) = (switching(r, &m160_1), switching(r, &m160_5));
    let (lo, hi) = (l160[0].min(l160[1]), l160[0].max(l160[1]));
    vec![
        Quote::prose(
            "README.md",
            format!(
                "(prostate {:.1} → {:.1} s with free motion, lung {l40_scan:.1} s with constant speed per layer, two-arc nothing)",
                p40[0], p40[1]
            ),
        ),
        Quote::prose(
            "README.md",
            format!(
                "it cuts the energy switching of prostate from {sw1:.1} to {sw5:.1} s, but the gantry needs most of that time anyway to reach the next control point: free motion saves {:.1} s ({:.1} → {:.1} s), constant speed per layer (`scan`) only {p160_scan:.1} s; lung saves {lo:.1}–{hi:.1} s, two-arc nothing. (On lung at 40 MU free motion gives {l40_free_more:.1} s *more*",
                p160[0] - p160[1],
                p160[0],
                p160[1]
            ),
        ),
        Quote::prose(
            "README.md",
            format!("prostate at 40 MU takes {p40_left:.1} s instead of {:.1} s.", p40[0]),
        ),
    ]
}

/// `scenarios/README.md`'s notes on the burst and spill machines (the bundled prostate, free
/// motion).
fn scenario_notes(r: &mut Runs) -> Vec<Quote> {
    let mut free = |machine: &str| {
        r.simulate(&[
            "plans/prostate.json",
            "--machine",
            &format!("scenarios/{machine}.json"),
            "--motion",
            "free",
        ])
        .clone()
    };
    let pbs = free("machine-opentps-pbs");
    let bursts = free("machine-proteusone-like");
    let spills = free("machine-probeat-v5-like");
    let added = number(&bursts, "/breakdown/beam_on_s") - number(&pbs, "/breakdown/beam_on_s");
    vec![
        Quote::prose(
            "scenarios/README.md",
            format!(
                "On the bundled prostate the bursts add {added:.0} s of beam-on time ({:.1} s on `machine-opentps-pbs.json`, {:.1} s here).",
                number(&pbs, "/total_s"),
                number(&bursts, "/total_s")
            ),
        ),
        Quote::prose(
            "scenarios/README.md",
            format!(
                "On the bundled prostate: {:.1} s with free motion, {:.1} s of it waiting for spills.",
                number(&spills, "/total_s"),
                number(&spills, "/breakdown/spill_waiting_s")
            ),
        ),
    ]
}

/// `x` with two decimals and no trailing zeros, as JSON prints a rounded number.
fn short(x: f64) -> String {
    let s = format!("{x:.2}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// The guide's and the result format's figures on the bundled prostate (ATOM machine).
fn prostate_on_atom(r: &mut Runs) -> Vec<Quote> {
    let prostate = "plans/prostate.json";
    let constant = r.simulate(&[prostate]).clone();
    let free = r.simulate(&[prostate, "--motion", "free"]).clone();
    let one_speed = r.total(&[prostate, "--motion", "one-speed"]);
    let j1 = r.machine("machine-atom.json", |m| {
        m["gantry"]["max_jerk_deg_per_s3"] = 1.0.into();
    });
    let j2 = r.machine("machine-atom.json", |m| {
        m["gantry"]["max_jerk_deg_per_s3"] = 2.0.into();
    });
    let mut scaled = |field: &'static str, f: f64| {
        let m = r.machine("machine-atom.json", move |m| {
            let g = &mut m["gantry"][field];
            *g = (g.as_f64().expect("limit") * f).into();
        });
        r.total(&[prostate, "--machine", &m, "--motion", "free"])
    };
    // The summary's sensitivity: (T(1.1 L) - T(L / 1.1)) / 2, s per +10 %.
    let per_10 = |up: f64, down: f64| (up - down) / 2.0;
    let a_sens = per_10(
        scaled("max_accel_deg_per_s2", 1.1),
        scaled("max_accel_deg_per_s2", 1.0 / 1.1),
    );
    let j_sens = per_10(
        scaled("max_jerk_deg_per_s3", 1.1),
        scaled("max_jerk_deg_per_s3", 1.0 / 1.1),
    );
    let t = |v: &Value| number(v, "/total_s");
    let c_j1 = r.total(&[prostate, "--machine", &j1]);
    let f_j2 = r.total(&[prostate, "--machine", &j2, "--motion", "free"]);
    vec![
        Quote::prose(
            "docs/guide.md",
            format!(
                "well past their 0.5 s ELST ({:.0} s lost); the energy switching itself ({:.1} s)",
                number(&constant, "/breakdown/lost_s"),
                number(&constant, "/breakdown/energy_switching_s")
            ),
        ),
        Quote::prose(
            "docs/guide.md",
            format!(
                "With constant speed that is J 0.5 → 1 °/s³ ({:.1} → {c_j1:.1} s). Under free motion J 2 °/s³ buys only {:.1} s ({:.1} → {f_j2:.1} s)",
                t(&constant),
                t(&free) - f_j2,
                t(&free)
            ),
        ),
        Quote::prose(
            "docs/guide.md",
            format!("(−{:.2} s per +10 % of A, against −{:.2} s for J)", -a_sens, -j_sens),
        ),
        Quote::prose(
            "docs/results.md",
            format!(
                "\"constant_speed_total_s\": {}, \"total_s\": {}, \"breakdown\": {{ \"beam_on_s\": {}, \"energy_switching_s\": {}, \"lost_s\": {} }},",
                short(number(&free, "/constant_speed_total_s")),
                short(t(&free)),
                short(number(&free, "/breakdown/beam_on_s")),
                short(number(&free, "/breakdown/energy_switching_s")),
                short(number(&free, "/breakdown/lost_s"))
            ),
        ),
        Quote::prose(
            "docs/model.md",
            format!(
                "takes {one_speed:.2} s, against {:.2} s with a constant speed per layer",
                t(&constant)
            ),
        ),
    ]
}

/// The shapes of a line's words (numbers as `#`).
fn shapes(line: &str) -> Vec<String> {
    line.split_whitespace().map(shape).collect()
}

/// The lines of the ```` ```text ```` block that follows `marker` in `doc`, each as the line of
/// `output` with the same words (numbers aside): what the document quotes of a command's output.
/// A quoted line the output has no such line for is reported as not printed.
fn output_block(doc: &'static str, marker: &str, output: &str) -> Vec<Quote> {
    let text = std::fs::read_to_string(repo().join(doc)).expect("doc");
    let at = text
        .find(marker)
        .unwrap_or_else(|| panic!("{doc}: no {marker:?}"));
    let rest = &text[at..];
    let start = rest.find("```text\n").expect("a text block") + "```text\n".len();
    let end = rest[start..].find("```").expect("closed");
    rest[start..start + end]
        .lines()
        .filter(|l| l.trim() != "..." && !l.trim().is_empty())
        .map(|quoted| {
            let want = shapes(quoted);
            // Of the lines shaped alike (rows of a table), the one that shares the longest
            // beginning with the quoted line.
            let prefix = |l: &str| {
                l.trim_start()
                    .chars()
                    .zip(quoted.trim_start().chars())
                    .take_while(|(a, b)| a == b)
                    .count()
            };
            let alike: Vec<&str> = output.lines().filter(|l| shapes(l) == want).collect();
            let best = alike.iter().map(|l| prefix(l)).max().unwrap_or(0);
            let printed: Vec<&str> = alike.into_iter().filter(|l| prefix(l) == best).collect();
            Quote {
                doc,
                line: true,
                text: match printed.as_slice() {
                    [one] => (*one).to_string(),
                    _ if output.lines().any(|l| l.trim_end() == quoted.trim_end()) => {
                        quoted.to_string()
                    }
                    _ => format!("(printed {} times) {quoted}", printed.len()),
                },
            }
        })
        .collect()
}

/// `arcsim ARGS`: its standard output, which must succeed.
fn stdout_of(args: &[&str]) -> String {
    let out = arcsim(args);
    assert!(out.status.success(), "{args:?}: {}", text(&out).1);
    text(&out).0
}

/// The numbers of the first line of `output` that starts with `prefix` (after spaces).
fn numbers_after(output: &str, prefix: &str) -> Vec<f64> {
    let line = output
        .lines()
        .find(|l| l.trim_start().starts_with(prefix))
        .unwrap_or_else(|| panic!("no line {prefix:?} in\n{output}"));
    line[line.find(prefix).unwrap_or(0) + prefix.len()..]
        .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == '+'))
        .filter_map(|w| w.trim_end_matches('.').parse::<f64>().ok())
        .collect()
}

/// The README's and the guide's prostate example on the ATOM machine under its controller.
fn controller_example(r: &mut Runs) -> Vec<Quote> {
    let optimal = r.printed(&["plans/prostate.json", "--schedule", "optimal"]);
    let default = r.printed(&["plans/prostate.json"]);
    let free = r.printed(&["plans/prostate.json", "--motion", "free"]);
    let total = numbers_after(&default, "total delivery time")[0];
    let free_total = numbers_after(&free, "total delivery time")[0];
    let mut quotes = output_block("README.md", "## Example: where the time is lost", &optimal);
    quotes.extend(output_block(
        "docs/guide.md",
        "## 2. How long does it take?",
        &default,
    ));
    quotes.extend(output_block(
        "docs/guide.md",
        "## 3. Where does the time go?",
        &default,
    ));
    quotes.push(Quote::prose(
        "README.md",
        format!("`optimal` schedule): {total:.2} s in total:"),
    ));
    quotes.push(Quote::prose(
        "README.md",
        format!("would deliver the same plan in {free_total:.2} s"),
    ));
    quotes.push(Quote::prose(
        "docs/guide.md",
        format!("takes {free_total:.2} s here,"),
    ));
    quotes
}

/// The README's and `docs/logs.md`'s log example: the fast gantry's virtual logs of three
/// plans, the lung one compared on the ATOM machine, the machine calibrated from all three and
/// from lung's alone.
fn log_example() -> Vec<Quote> {
    let dir = temp_dir();
    let mut pairs = Vec::new();
    for plan in ["lung", "prostate", "two-arc"] {
        let log = dir.join(format!("{plan}-log.csv"));
        stdout_of(&[
            "simulate",
            &format!("plans/{plan}.json"),
            "--machine",
            "scenarios/machine-fast.json",
            "--log",
            path_str(&log),
            "--angle-noise-deg",
            "0.01",
            "--seed",
            "1",
        ]);
        pairs.push((format!("plans/{plan}.json"), path_str(&log).to_string()));
    }
    // The logs are named as given: here with the test's directory, in the docs without.
    let bare = |out: String| out.replace(&format!("{}/", dir.display()), "");
    let compare = bare(stdout_of(&["compare", "plans/lung.json", &pairs[0].1]));
    let fitted = dir.join("fitted.json");
    let mut args = vec![
        "calibrate",
        "--machine",
        "scenarios/machine-atom.json",
        "--elst",
        "poly",
        "-o",
        path_str(&fitted),
    ];
    for (plan, log) in &pairs {
        args.push(plan);
        args.push(log);
    }
    let calibrate = bare(stdout_of(&args));
    let lung_alone = stdout_of(&[
        "calibrate",
        "--machine",
        "scenarios/machine-atom.json",
        "--elst",
        "poly",
        "plans/lung.json",
        &pairs[0].1,
        "-o",
        path_str(&dir.join("lung-fitted.json")),
    ]);
    assert!(
        lung_alone.contains("optimal schedule (not determined)"),
        "docs/logs.md says one lung log does not determine the controller:\n{lung_alone}"
    );
    let machine = json_file(&fitted);
    let gantry = |f: &str| number(&machine, &format!("/gantry/{f}"));
    let [logged, simulated, _] = numbers_after(&compare, "total")[..] else {
        panic!("compare's total line:\n{compare}")
    };
    let diff = numbers_after(&compare, "difference of the totals:");
    let better: f64 = calibrate
        .split(" times better")
        .next()
        .and_then(|head| head.rsplit(' ').next())
        .and_then(|w| w.parse().ok())
        .expect("how many times better");
    let residual = |log: &str| {
        *numbers_after(&calibrate, &format!("{log}: logged"))
            .last()
            .expect("residual")
    };
    for log in ["prostate-log.csv", "two-arc-log.csv"] {
        assert!(
            residual(log).abs() < 0.2,
            "the README says the fitted machine predicts {log} within 0.2 %:\n{calibrate}"
        );
    }
    // Lung's log alone: the rms of the two models' beam-on errors.
    let pick = |name: &str| {
        let at = lung_alone.find(name).expect("rms") + name.len();
        numbers_after(&lung_alone[at..], "")[0]
    };
    let (constant_rms, free_rms) = (pick("differ by less than 3×: constant "), pick(", free "));
    let (v, a, j) = (
        gantry("max_speed_deg_per_s"),
        gantry("max_accel_deg_per_s2"),
        gantry("max_jerk_deg_per_s3"),
    );
    let mut quotes = output_block("docs/logs.md", "On the example (the ATOM machine", &compare);
    quotes.extend(output_block(
        "docs/logs.md",
        "On the example (three logs",
        &calibrate,
    ));
    quotes.extend([
        Quote::prose(
            "README.md",
            format!(
                "predicts {simulated:.2} s for the {logged:.2} s lung log; calibrated from the three logs, it learns free motion ({better:.1}× better) and the fast gantry's V, A and J ({v:.2}, {a:.3} and {j:.2} against 6, 1.5 and 3)"
            ),
        ),
        Quote::prose(
            "README.md",
            format!(
                "and two-arc logs within 0.2 % and lung's {:.2} % short",
                -residual("lung-log.csv")
            ),
        ),
        Quote::prose(
            "README.md",
            format!(
                "# ATOM predicts {:.1} s ({:.0} %) too much",
                -diff[0],
                -diff[1]
            ),
        ),
        Quote::prose(
            "docs/logs.md",
            format!("predicts {:.1} s too much; the log shows free motion", -diff[0]),
        ),
        Quote::prose(
            "docs/logs.md",
            format!(
                "free motion fits it {:.1}× better, not 3×",
                constant_rms / free_rms
            ),
        ),
        Quote::prose(
            "docs/logs.md",
            format!("resolve A 1.5 and J 3 deg/s³ as {a:.3} and {j:.2});"),
        ),
    ]);
    quotes
}

/// `docs/commands.md`'s examples: the spot-timed summary, `--spots` rows and the large
/// generated plan.
fn commands_examples() -> Vec<Quote> {
    let dir = temp_dir();
    let spots = dir.join("spots.csv");
    let summary = stdout_of(&[
        "simulate",
        "plans/prostate.json",
        "--machine",
        "scenarios/machine-opentps-pbs.json",
        "--spots",
        path_str(&spots),
    ]);
    let rows = std::fs::read_to_string(&spots).expect("spots");
    let layer_90 = rows.lines().filter(|l| l.starts_with("90,")).count();
    let plan = dir.join("two-arc-large.json");
    stdout_of(&[
        "generate-plan",
        "--kind",
        "two-arc",
        "--spacing",
        "2.2",
        "--layers",
        "2-4",
        "--energy",
        "70-230",
        "-o",
        path_str(&plan),
    ]);
    let plan = json_file(&plan);
    let arcs = plan["arcs"].as_array().expect("arcs");
    let per_arc: Vec<usize> = arcs
        .iter()
        .map(|a| {
            a["control_points"]
                .as_array()
                .expect("control points")
                .len()
        })
        .collect();
    let layers: usize = arcs
        .iter()
        .flat_map(|a| a["control_points"].as_array().expect("control points"))
        .map(|cp| cp["layers"].as_array().expect("layers").len())
        .sum();
    assert!(
        per_arc.windows(2).all(|w| w[0] == w[1]),
        "docs/commands.md gives one count per arc: {per_arc:?}"
    );
    let mut quotes = output_block(
        "docs/commands.md",
        "beam-on time into spot irradiation and the time between spots",
        &summary,
    );
    quotes.extend(output_block(
        "docs/commands.md",
        "through its window while its",
        &rows,
    ));
    quotes.push(Quote::prose(
        "docs/commands.md",
        format!("through its window while its {layer_90} spots are delivered"),
    ));
    quotes.push(Quote::prose(
        "docs/commands.md",
        format!(
            "writes a two-arc plan of {} control points ({} per arc, 320° every 2.2°) and {layers} layers",
            per_arc.iter().sum::<usize>(),
            per_arc[0]
        ),
    ));
    quotes
}

/// `docs/model.md`'s servo-period figures: prostate and head-neck on a 1 and 4 ms period.
fn servo_periods(r: &mut Runs) -> Vec<Quote> {
    let mut t = |plan: &str, schedule: &str, period: Option<&str>| {
        let plan = format!("plans/{plan}.json");
        let mut args = vec![plan.as_str(), "--schedule", schedule];
        if let Some(p) = period {
            args.extend_from_slice(&["--period", p]);
        }
        r.total(&args)
    };
    let row = |t: &mut dyn FnMut(&str, &str, Option<&str>) -> f64, schedule: &str| {
        format!(
            "| `{schedule}` | {:.2} s | {:.2} s | {:.2} s |",
            t("prostate", schedule, None),
            t("prostate", schedule, Some("0.001")),
            t("prostate", schedule, Some("0.004"))
        )
    };
    let rows = [row(&mut t, "scan"), row(&mut t, "optimal")];
    let head_neck = format!(
        "On the bundled head-neck plan at 4 ms, `optimal` gives {:.2} s (`scan` {:.2} s; {:.2} s continuous)",
        t("head-neck", "optimal", Some("0.004")),
        t("head-neck", "scan", Some("0.004")),
        t("head-neck", "optimal", None)
    );
    let mut bound = |period: &str| {
        number(
            r.simulate(&[
                "plans/prostate.json",
                "--schedule",
                "scan",
                "--period",
                period,
                "--certify",
            ]),
            "/certificate/lower_bound_s",
        )
    };
    let certify = format!(
        "(prostate: {:.2} s at 1 ms, {:.2} s at 4 ms).",
        bound("0.001"),
        bound("0.004")
    );
    // The sensitivity to J at the ATOM machine: (T(1.1 J) - T(J / 1.1)) / 2, both schedules.
    let j_at = |f: f64| move |m: &mut Value| m["gantry"]["max_jerk_deg_per_s3"] = (0.5 * f).into();
    let (up, down) = (
        r.machine("machine-atom.json", j_at(1.1)),
        r.machine("machine-atom.json", j_at(1.0 / 1.1)),
    );
    let saves: Vec<String> = ["scan", "optimal"]
        .iter()
        .map(|sch| {
            let at = |r: &mut Runs, m: &str| {
                r.total(&["plans/prostate.json", "--machine", m, "--schedule", sch])
            };
            format!("{:.2}", (at(r, &down) - at(r, &up)) / 2.0)
        })
        .collect();
    assert_eq!(
        saves[0], saves[1],
        "docs/model.md says +10 % J saves the same on prostate with scan and optimal"
    );
    let j_sens = format!(
        "At the ATOM machine, +10 % J saves {} s on prostate with both.",
        saves[0]
    );
    rows.into_iter()
        .chain([head_neck, certify, j_sens])
        .map(|text| Quote::prose("docs/model.md", text))
        .collect()
}

/// `docs/records.md`'s walk-through, as written: an ATOM machine with other timings plays the
/// real machine; the ATOM machine calibrated from three plans' records finds each timing within
/// 1 % and the gantry's A and J too, V not determined, and predicts the held-out plan's record
/// within 1 %.
fn records_example(r: &mut Runs) {
    let real = r.machine("machine-atom.json", |m| {
        m["elst"]["up_s"] = 4.2.into();
        m["elst"]["down_s"] = 0.7.into();
        m["beam"]["s_per_mu"] = 0.0056.into();
        m["gantry"]["max_accel_deg_per_s2"] = 0.4.into();
        m["gantry"]["max_jerk_deg_per_s3"] = 0.7.into();
    });
    let dir = temp_dir();
    let record = |plan: &str| path_str(&dir.join(format!("{plan}.dcm"))).to_string();
    for (plan, start) in [
        ("prostate", Some("20261231235800")),
        ("lung", Some("20260102080000")),
        ("two-arc", Some("20260103080000")),
        ("head-neck", None),
    ] {
        let plan_path = format!("plans/{plan}.json");
        let out = record(plan);
        let mut args = vec!["simulate", &plan_path, "--machine", &real, "--record", &out];
        if let Some(s) = start {
            args.extend_from_slice(&["--record-start", s]);
        }
        stdout_of(&args);
    }
    let fitted = dir.join("fitted.json");
    let (p, l, t) = (record("prostate"), record("lung"), record("two-arc"));
    let calibrate = stdout_of(&[
        "calibrate",
        "--machine",
        "scenarios/machine-atom.json",
        "plans/prostate.json",
        &p,
        "plans/lung.json",
        &l,
        "plans/two-arc.json",
        &t,
        "-o",
        path_str(&fitted),
    ]);
    let machine = json_file(&fitted);
    for (pointer, truth) in [
        ("/elst/up_s", 4.2),
        ("/elst/down_s", 0.7),
        ("/beam/s_per_mu", 0.0056),
        ("/gantry/max_accel_deg_per_s2", 0.4),
        ("/gantry/max_jerk_deg_per_s3", 0.7),
    ] {
        let got = number(&machine, pointer);
        assert!(
            (got / truth - 1.0).abs() < 0.01,
            "docs/records.md says each timing and A and J are found within 1 %: {pointer} {got} against {truth}\n{calibrate}"
        );
    }
    assert!(
        calibrate.contains("gantry.max_speed_deg_per_s: not determined"),
        "docs/records.md says V is not determined:\n{calibrate}"
    );
    let held_out = stdout_of(&[
        "compare",
        "plans/head-neck.json",
        &record("head-neck"),
        "--machine",
        path_str(&fitted),
    ]);
    let off = numbers_after(&held_out, "difference of the totals:")[1];
    assert!(
        off.abs() < 1.0,
        "docs/records.md says the fitted machine predicts the held-out record within 1 %: {off} %\n{held_out}"
    );
}

/// `scenarios/README.md`'s example of a sweep summary's cheapest change (the guide's sweep).
fn sweep_summary() -> Vec<Quote> {
    let dir = temp_dir();
    let out = stdout_of(&[
        "sweep",
        "scenarios/sweep-guide.json",
        "--out",
        path_str(&dir.join("guide.csv")),
    ]);
    let change = out
        .lines()
        .find(|l| l.contains("scan") && l.contains("J 0.5 -> 1 deg/s^3"))
        .unwrap_or_else(|| panic!("no cheapest change J 0.5 -> 1 in\n{out}"));
    let words: Vec<&str> = change.split_whitespace().collect();
    let [.., total, saves] = words[..] else {
        panic!("{change}")
    };
    vec![Quote::prose(
        "scenarios/README.md",
        format!("\"J 0.5 -> 1 deg/s^3, total {total} s, saves {saves} s\";"),
    )]
}

#[test]
fn the_docs_figures_are_what_the_commands_give() {
    let mut r = Runs::new();
    let mut quotes = atom_cases_free(&mut r);
    quotes.extend(synchrocyclotron(&mut r));
    quotes.extend(synchrotron(&mut r));
    quotes.extend(scenario_notes(&mut r));
    quotes.extend(prostate_on_atom(&mut r));
    quotes.extend(controller_example(&mut r));
    quotes.extend(log_example());
    quotes.extend(commands_examples());
    quotes.extend(servo_periods(&mut r));
    records_example(&mut r);
    quotes.extend(sweep_summary());
    check(&quotes);
}
