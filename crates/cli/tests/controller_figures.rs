//! The figures the README and the guide quote for the machine's controller (issue 44), produced
//! by the commands they name: every quoted output line is in the command's output, and every
//! quoted number is in the text.

use arcsim_test_support::temp_dir;

use crate::util::{arcsim, path_str, repo, text};

fn doc(name: &str) -> String {
    std::fs::read_to_string(repo().join(name)).expect("doc")
}

/// The lines of the ```text block that follows `marker` in `doc`.
fn block_after(doc: &str, marker: &str) -> Vec<String> {
    let at = doc.find(marker).unwrap_or_else(|| panic!("no {marker:?}"));
    let rest = &doc[at..];
    let start = rest.find("```text\n").expect("a text block") + "```text\n".len();
    let end = rest[start..].find("```").expect("closed");
    rest[start..start + end]
        .lines()
        .map(str::to_string)
        .collect()
}

#[test]
fn the_quoted_outputs_of_the_atom_machine_s_controller_are_what_simulate_prints() {
    let out = arcsim(&["simulate", "plans/prostate.json", "--schedule", "optimal"]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    let readme = doc("README.md");
    for line in block_after(&readme, "## Example: where the time is lost") {
        assert!(
            stdout.contains(&line),
            "README line not printed: {line:?}\n{stdout}"
        );
    }
    assert!(readme.contains("273.85 s in total"));
    let guide = doc("docs/guide.md");
    let out = arcsim(&["simulate", "plans/prostate.json"]);
    let stdout = text(&out).0;
    for marker in [
        "## 2. How long does it take?",
        "## 3. Where does the time go?",
    ] {
        for line in block_after(&guide, marker) {
            assert!(
                stdout.contains(&line),
                "guide line not printed: {line:?}\n{stdout}"
            );
        }
    }
    let free = arcsim(&["simulate", "plans/prostate.json", "--motion", "free"]);
    let stdout = text(&free).0;
    assert!(
        stdout.contains("total delivery time     190.16 s"),
        "{stdout}"
    );
    assert!(readme.contains("190.16 s") && guide.contains("190.16 s"));
}

/// The README's log example: the fast gantry's virtual logs of three plans, the lung one
/// compared on the ATOM machine, the machine calibrated from all three (and from lung's alone,
/// which does not determine the controller); docs/logs.md quotes the calibration's output.
#[test]
fn the_readme_s_log_example_gives_its_figures() {
    let dir = temp_dir().join("readme-logs");
    std::fs::create_dir_all(&dir).expect("dir");
    let mut pairs = Vec::new();
    for plan in ["lung", "prostate", "two-arc"] {
        let log = dir.join(format!("{plan}-log.csv"));
        let out = arcsim(&[
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
        assert!(out.status.success(), "{}", text(&out).1);
        pairs.push((format!("plans/{plan}.json"), log));
    }
    let lung_log = path_str(&pairs[0].1).to_string();
    let out = arcsim(&["compare", "plans/lung.json", &lung_log]);
    let stdout = text(&out).0;
    assert!(out.status.success(), "{}", text(&out).1);
    assert!(
        stdout.contains("total                       90.45         158.23          -67.78")
            && stdout.contains("difference of the totals: -67.78 s (-42.84 %)")
            && stdout.contains("the log fits free motion better")
            && stdout.contains("angle noise 0.0123 deg"),
        "{stdout}"
    );
    let base = [
        "calibrate",
        "--machine",
        "scenarios/machine-atom.json",
        "--elst",
        "poly",
        "-o",
    ];
    let mut args: Vec<String> = base.iter().map(ToString::to_string).collect();
    args.push(path_str(&dir.join("fitted.json")).to_string());
    for (plan, log) in &pairs {
        args.push(plan.clone());
        args.push(path_str(log).to_string());
    }
    let arg_refs: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = arcsim(&arg_refs);
    // The logs are named as given: here with the test's directory, in the docs without.
    let stdout = text(&out).0.replace(&format!("{}/", dir.display()), "");
    assert!(out.status.success(), "{}", text(&out).1);
    let logs = doc("docs/logs.md");
    for line in block_after(&logs, "On the example (three logs") {
        if line != "..." {
            assert!(
                stdout.contains(line.trim_end()),
                "docs/logs.md line not printed: {line:?}\n{stdout}"
            );
        }
    }
    assert!(
        stdout.contains("11.5 times better (rms 0.426 s against 4.891 s")
            && stdout.contains("fitted 88.85 s (-1.77 %)")
            && stdout.contains("fitted 126.94 s (+0.08 %)")
            && stdout.contains("fitted 180.58 s (+0.14 %)")
            && stdout.contains("the fitted machine is -1.77 % off this log"),
        "{stdout}"
    );
    // Lung's log alone: free motion fits 2.2× better, short of the 3× the rule asks.
    let out = arcsim(&[
        "calibrate",
        "--machine",
        "scenarios/machine-atom.json",
        "--elst",
        "poly",
        "plans/lung.json",
        &lung_log,
        "-o",
        path_str(&dir.join("lung-fitted.json")),
    ]);
    let stdout = text(&out).0;
    assert!(out.status.success(), "{}", text(&out).1);
    assert!(
        stdout.contains("optimal schedule (not determined)")
            && stdout.contains("constant 1.968 s, free 0.914 s")
            && stdout.contains("plateau 1.3166 held 0.26 s")
            && logs.contains("free motion fits\nit 2.2× better, not 3×"),
        "{stdout}"
    );
    let readme = doc("README.md")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    for figure in [
        "predicts 158.23 s for the 90.45 s lung log",
        "(11.5× better)",
        "(6.00, 1.499 and 2.94 against 6, 1.5 and 3)",
        "logs within 0.2 % and lung's 1.77 % short",
        "ATOM predicts 67.8 s (43 %) too much",
    ] {
        assert!(readme.contains(figure), "README lacks {figure:?}");
    }
}
