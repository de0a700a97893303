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

/// The README's log example: the fast gantry's virtual log, compared on the ATOM machine and
/// calibrated from it.
#[test]
fn the_readme_s_log_example_gives_its_figures() {
    let dir = temp_dir().join("readme-logs");
    std::fs::create_dir_all(&dir).expect("dir");
    let log = dir.join("lung-log.csv");
    let out = arcsim(&[
        "simulate",
        "plans/lung.json",
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
    let out = arcsim(&["compare", "plans/lung.json", path_str(&log)]);
    let stdout = text(&out).0;
    assert!(out.status.success(), "{}", text(&out).1);
    assert!(
        stdout.contains("total                       90.45         158.23          -67.78")
            && stdout.contains("difference of the totals: -67.78 s (-42.84 %)")
            && stdout.contains("the log fits free motion better"),
        "{stdout}"
    );
    let out = arcsim(&[
        "calibrate",
        "--machine",
        "scenarios/machine-atom.json",
        "--elst",
        "poly",
        "plans/lung.json",
        path_str(&log),
        "-o",
        path_str(&dir.join("lung-fitted.json")),
    ]);
    let stdout = text(&out).0;
    assert!(out.status.success(), "{}", text(&out).1);
    assert!(
        stdout.contains("controller: free motion")
            && stdout.contains("12.0 times better (rms 1.241 s against 14.914 s")
            && stdout.contains("fitted 92.72 s (+2.51 %)")
            && stdout.contains("the fitted machine is +2.51 % off this log"),
        "{stdout}"
    );
    let readme = doc("README.md");
    for figure in [
        "158.23 s for a 90.45 s log",
        "(12× better)",
        "predicts 92.72 s (+2.51 %",
        "ATOM predicts 67.8 s (43 %) too much",
    ] {
        assert!(readme.contains(figure), "README lacks {figure:?}");
    }
}
