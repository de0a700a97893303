//! A bounded adversarial probe of the `arcsim` binary: seeded byte and number mutations of the
//! bundled plan, machine and sweep files and of a DICOM RT Ion Plan, each run through the command
//! that reads it. Every run must end with exit code 0, 1 or 2, print no panic, write no NaN or
//! infinity, finish within its time limit and stay under 1 GiB of address space.
//!
//! `probe_bounded` runs for `ARCSIM_PROBE_SECONDS` (default 45 s) in the normal test suite;
//! `probe_long` (ignored) runs for 20 minutes: `cargo test -p arcsim --test integration -- --ignored probe::`.
//!
//! The output-path probe (`outputs_bounded`, `outputs_long`) runs `simulate` with seeded sets of
//! outputs inside a temporary directory: symlinks (to files, dangling, chained), files whose
//! temporary-looking names (`NAME.partial`) are symlinks to a victim file, FIFOs or directories,
//! outputs that are FIFOs or symlinks to FIFOs (with a reader), outputs that alias each other or
//! the input; never a system path. After each run no file other than the named outputs' targets may have changed, and
//! each named output is complete or as it was.

use crate::util;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use arcsim_test_support::{dicom, temp_dir, Rng};

use crate::util::{path_str, repo};

/// Numbers a careless or hostile file might hold.
const EXTREMES: &[&str] = &[
    "0",
    "-0",
    "-1",
    "1e308",
    "-1e308",
    "1e-308",
    "5e-324",
    "1e300",
    "4294967296",
    "1e7",
    "1e-9",
    "99999999999999999999",
    "0.0000001",
    "360",
    "-360",
    "1e5",
    "2",
    "NaN",
    "\"x\"",
    "null",
    "[]",
    "{}",
    "true",
];

fn mutate(rng: &mut Rng, seed: &[u8], text: bool) -> Vec<u8> {
    let mut b = seed.to_vec();
    for _ in 0..=rng.below(3) {
        if b.is_empty() {
            break;
        }
        let i = rng.below(b.len());
        match rng.below(if text { 7 } else { 5 }) {
            0 => b[i] ^= 1 << rng.below(8),
            1 => {
                b.remove(i);
            }
            2 => b.truncate(i),
            3 => {
                let j = (i + 1 + rng.below(64)).min(b.len());
                let chunk = b[i..j].to_vec();
                b.splice(i..i, chunk);
            }
            4 => b[i] = rng.next_u64() as u8,
            _ => {
                // Replace the number (or token) starting near i with an extreme value.
                let start = b[i..]
                    .iter()
                    .position(|c| c.is_ascii_digit())
                    .map_or(i, |p| i + p);
                let end = b[start..]
                    .iter()
                    .position(|c| !(c.is_ascii_digit() || b".eE+-".contains(c)))
                    .map_or(b.len(), |p| start + p);
                let with = EXTREMES[rng.below(EXTREMES.len())].as_bytes();
                b.splice(start..end, with.iter().copied());
            }
        }
    }
    b
}

struct Target {
    name: &'static str,
    seed: Vec<u8>,
    text: bool,
    /// The command, with `{}` for the mutated file and `{out}` for an output path.
    args: &'static [&'static str],
}

fn read(rel: &str) -> Vec<u8> {
    std::fs::read(repo().join(rel)).expect("bundled file")
}

fn targets() -> Vec<Target> {
    // A small sweep: two plans' worth of settings at most, whatever the mutation does to it...
    let sweep = serde_json::json!({
        "format": "arcsim-sweep/1",
        "name": "probe",
        "plans": [repo().join("plans/prostate.json").to_str().expect("utf-8")],
        "machine": repo().join("scenarios/machine-atom.json").to_str().expect("utf-8"),
        "axes": { "jerk_deg_per_s3": [0.5, 1], "accel_deg_per_s2": { "from": 0.25, "to": 1, "steps": 2 } },
        "schedules": ["scan", { "schedule": "optimal", "axes": { "jerk_deg_per_s3": [1] } }]
    });
    vec![
        Target {
            name: "plan.json",
            seed: read("plans/prostate.json"),
            text: true,
            args: &[
                "simulate",
                "{}",
                "--schedule",
                "scan",
                "--motion",
                "constant",
                "--json",
                "{out}",
            ],
        },
        Target {
            name: "plan.json",
            seed: read("plans/two-arc.json"),
            text: true,
            args: &["validate", "{}"],
        },
        Target {
            name: "machine.json",
            seed: read("scenarios/machine-atom.json"),
            text: true,
            args: &[
                "simulate",
                "plans/prostate.json",
                "--machine",
                "{}",
                "--schedule",
                "scan",
                "--motion",
                "constant",
                "--json",
                "{out}",
            ],
        },
        Target {
            name: "sweep.json",
            seed: sweep.to_string().into_bytes(),
            text: true,
            args: &["sweep", "{}", "--threads", "2", "--json", "{out}"],
        },
        Target {
            name: "plan.dcm",
            seed: dicom::dynamic_arc_plan().to_bytes(),
            text: false,
            args: &["import", "{}", "-o", "{out}"],
        },
    ]
}

/// Whether `text` holds a NaN or an infinity as a word (not "infeasible").
fn has_non_finite(text: &str) -> bool {
    text.split(|c: char| !(c.is_ascii_alphanumeric()))
        .any(|w| matches!(w, "NaN" | "nan" | "inf" | "infinity" | "Infinity"))
}

/// A JSON output must parse, and its times must be numbers: serde_json writes a NaN or an
/// infinity as `null`, and text fields (a mutated description) may say "NaN" harmlessly.
fn check_json(text: &str) -> Result<(), String> {
    if !text.trim_start().starts_with('{') {
        return Ok(()); // not a JSON output (a plan written by `import` is JSON too: checked below)
    }
    let v: serde_json::Value =
        serde_json::from_str(text).map_err(|e| format!("invalid JSON output: {e}"))?;
    let mut times = vec![&v["total_s"]];
    if let Some(b) = v["breakdown"].as_object() {
        times.extend(b.values());
    }
    if let Some(rows) = v["rows"].as_array() {
        times.extend(rows.iter().map(|r| &r["outcome"]["total_s"]));
    }
    for t in times {
        if !(t.is_null() && v["total_s"].is_null() || t.is_number()) {
            return Err(format!("a time is {t} in the JSON output (NaN or inf?)"));
        }
    }
    Ok(())
}

/// Runs one command under a 1 GiB address-space limit and a time limit; `Err` says what broke.
fn run_one(args: &[String], limit: Duration) -> Result<(), String> {
    let mut child = Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 1048576 && exec \"$@\"")
        .arg("sh")
        .arg(env!("CARGO_BIN_EXE_arcsim"))
        .args(args)
        .current_dir(repo())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("spawn: {e}"))?;
    // Drain the pipes on threads so a chatty child cannot block.
    let mut out = child.stdout.take().expect("stdout");
    let mut err = child.stderr.take().expect("stderr");
    let out_t = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut out, &mut s);
        s
    });
    let err_t = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut err, &mut s);
        s
    });
    let started = Instant::now();
    let status = loop {
        if let Some(st) = child.try_wait().map_err(|e| e.to_string())? {
            break st;
        }
        if started.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("no answer within {} s", limit.as_secs()));
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let (stdout, stderr) = (
        out_t.join().unwrap_or_default(),
        err_t.join().unwrap_or_default(),
    );
    match status.code() {
        Some(0..=2) => {}
        code => return Err(format!("exit {code:?} ({status}); stderr: {stderr}")),
    }
    if stderr.contains("panicked") {
        return Err(format!("panic: {stderr}"));
    }
    if has_non_finite(&stdout) {
        return Err(format!("NaN or inf on standard output:\n{stdout}"));
    }
    Ok(())
}

/// Probes for `budget`; returns the number of runs. Panics on the first failure, naming the
/// saved input and the command.
fn probe(budget: Duration, seed: u64) -> usize {
    let dir = temp_dir();
    let targets = targets();
    let mut rng = Rng::new(seed);
    let started = Instant::now();
    let mut runs = 0;
    while started.elapsed() < budget {
        let t = &targets[runs % targets.len()];
        let input = dir.join(t.name);
        let out = dir.join("out.json");
        let _ = std::fs::remove_file(&out);
        std::fs::write(&input, mutate(&mut rng, &t.seed, t.text)).expect("write input");
        let args: Vec<String> = t
            .args
            .iter()
            .map(|a| match *a {
                "{}" => input.display().to_string(),
                "{out}" => out.display().to_string(),
                other => other.to_string(),
            })
            .collect();
        let outcome = run_one(&args, Duration::from_secs(60)).and_then(|()| {
            match std::fs::read_to_string(&out) {
                Ok(text) => check_json(&text),
                Err(_) => Ok(()),
            }
        });
        if let Err(why) = outcome {
            let kept = dir.join(format!("failing-{runs}-{}", t.name));
            let _ = std::fs::copy(&input, &kept);
            panic!(
                "run {runs}: arcsim {} failed: {why}\ninput kept as {}",
                args.join(" "),
                kept.display()
            );
        }
        runs += 1;
    }
    runs
}

#[test]
fn probe_bounded() {
    let _turn = crate::util::one_heavy_test_at_a_time();
    let secs = std::env::var("ARCSIM_PROBE_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(45);
    let runs = probe(Duration::from_secs(secs), 0x5eed_2026);
    eprintln!("probe: {runs} inputs in {secs} s");
    assert!(runs > 0);
}

#[test]
#[ignore = "20-minute probe; run before a release"]
fn probe_long() {
    let _turn = crate::util::one_heavy_test_at_a_time();
    let runs = probe(Duration::from_secs(1200), 0xa5c1_2026);
    eprintln!("probe: {runs} inputs in 1200 s");
}

#[test]
fn non_finite_detection_ignores_words() {
    assert!(has_non_finite("total NaN s"));
    assert!(has_non_finite("speed: inf"));
    assert!(!has_non_finite("infeasible: gap too short; information"));
}

/// What a directory holds, by path relative to it (symlinks not followed): a file's bytes, a
/// link's target, or the kind of anything else.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, String> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("read dir") {
            let p = e.expect("entry").path();
            let rel = p.strip_prefix(dir).expect("inside").to_path_buf();
            let m = std::fs::symlink_metadata(&p).expect("metadata");
            let what = if m.file_type().is_symlink() {
                format!(
                    "link -> {}",
                    std::fs::read_link(&p).expect("link").display()
                )
            } else if m.is_dir() {
                stack.push(p.clone());
                "dir".to_string()
            } else if m.is_file() {
                format!(
                    "file {}",
                    String::from_utf8_lossy(&std::fs::read(&p).expect("read"))
                )
            } else {
                "special".to_string()
            };
            out.insert(rel, what);
        }
    }
    out
}

fn mkfifo(path: &Path) {
    let ok = Command::new("mkfifo").arg(path).status().expect("mkfifo");
    assert!(ok.success(), "mkfifo {}", path.display());
}

/// Whether `text` is a whole output of the flag: JSON that parses, or a CSV whose lines have
/// the header's number of fields and end with a newline.
fn complete(flag: &str, text: &str) -> Result<(), String> {
    if flag == "--json" {
        return serde_json::from_str::<serde_json::Value>(text)
            .map(|_| ())
            .map_err(|e| format!("not whole JSON: {e}"));
    }
    if !text.ends_with('\n') {
        return Err("CSV without its last newline".into());
    }
    let mut lines = text.lines();
    let fields = |l: &str| l.split(',').count();
    let header = lines.next().ok_or("empty CSV")?;
    match lines.find(|l| fields(l) != fields(header)) {
        Some(l) => Err(format!("CSV line of another width: {l}")),
        None if text.lines().count() < 2 => Err("CSV without rows".into()),
        None => Ok(()),
    }
}

/// One seeded case of the output-path probe in a fresh directory; `Err` says what broke.
fn output_case(rng: &mut Rng, case: usize) -> Result<(), String> {
    let dir = temp_dir();
    let plan = dir.join("plan.json");
    std::fs::copy(repo().join("plans/prostate.json"), &plan).map_err(|e| e.to_string())?;
    std::fs::create_dir(dir.join("sub")).map_err(|e| e.to_string())?;
    std::fs::write(dir.join("victim"), "victim\n").map_err(|e| e.to_string())?;
    let flags = ["--json", "--csv", "--spots"];
    let mut outputs: Vec<(&str, PathBuf)> = Vec::new();
    // Whether the command must refuse (two outputs on one file, or an output on the input).
    let mut refused = false;
    let mut readers = Vec::new();
    for (i, flag) in flags.iter().enumerate() {
        if rng.below(3) == 0 {
            continue;
        }
        let name = dir.join(format!("o{i}"));
        let path = match rng.below(12) {
            0 => name,
            1 => {
                std::fs::write(&name, "old contents\n").map_err(|e| e.to_string())?;
                name
            }
            2 => {
                std::fs::write(dir.join(format!("sub/real{i}")), "old\n")
                    .map_err(|e| e.to_string())?;
                std::os::unix::fs::symlink(format!("sub/real{i}"), &name)
                    .map_err(|e| e.to_string())?;
                name
            }
            3 => {
                std::os::unix::fs::symlink(format!("sub/new{i}"), &name)
                    .map_err(|e| e.to_string())?;
                name
            }
            4 => {
                std::os::unix::fs::symlink("victim", dir.join(format!("o{i}.partial")))
                    .map_err(|e| e.to_string())?;
                name
            }
            5 => {
                mkfifo(&dir.join(format!("o{i}.partial")));
                name
            }
            6 => {
                std::fs::create_dir(dir.join(format!("o{i}.partial")))
                    .map_err(|e| e.to_string())?;
                name
            }
            7 => {
                // A symlink to a FIFO (read to its end by a thread, below).
                mkfifo(&dir.join(format!("sub/fifo{i}")));
                std::os::unix::fs::symlink(format!("sub/fifo{i}"), &name)
                    .map_err(|e| e.to_string())?;
                name
            }
            8 => {
                std::os::unix::fs::symlink(format!("sub/chain{i}"), dir.join(format!("l{i}")))
                    .map_err(|e| e.to_string())?;
                std::os::unix::fs::symlink(format!("l{i}"), &name).map_err(|e| e.to_string())?;
                name
            }
            9 => {
                // A FIFO output (read to its end by a thread, below).
                mkfifo(&name);
                name
            }
            10 => match outputs.last() {
                // The name an earlier output's fixed temporary file once had.
                Some((_, earlier)) => {
                    let mut n = earlier.clone().into_os_string();
                    n.push(".partial");
                    // A directory of that name (case 6) is no file to write.
                    refused |= Path::new(&n).is_dir();
                    PathBuf::from(n)
                }
                _ => name,
            },
            _ => match (rng.below(2), outputs.last()) {
                (0, Some((_, earlier))) => {
                    refused = true;
                    earlier.clone()
                }
                _ => {
                    refused = true;
                    plan.clone()
                }
            },
        };
        outputs.push((flag, path));
    }
    // Every output that is a FIFO (also a `.partial` decoy named as an output) has a reader,
    // unless the command is to be refused and never opens it.
    for (flag, path) in outputs.iter().filter(|_| !refused) {
        use std::os::unix::fs::FileTypeExt;
        if std::fs::metadata(path).is_ok_and(|m| m.file_type().is_fifo()) {
            let fifo = path.clone();
            readers.push((
                *flag,
                std::thread::spawn(move || std::fs::read_to_string(fifo)),
            ));
        }
    }
    let before = snapshot(&dir);
    let mut args: Vec<String> = [
        "simulate",
        path_str(&plan),
        "--schedule",
        "scan",
        "--motion",
        "constant",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    for (flag, path) in &outputs {
        args.push(flag.to_string());
        args.push(path_str(path).to_string());
    }
    let shown = format!("case {case}: arcsim {}", args.join(" "));
    let o = util::bin()
        .args(&args)
        .output()
        .map_err(|e| e.to_string())?;
    let err = String::from_utf8_lossy(&o.stderr);
    let fifo_text: Vec<(&str, String)> = readers
        .into_iter()
        .map(|(f, t)| (f, t.join().expect("reader").unwrap_or_default()))
        .collect();
    let after = snapshot(&dir);
    if refused {
        if o.status.code() != Some(2) {
            return Err(format!(
                "{shown}: expected a refusal (exit 2), got {:?}: {err}",
                o.status.code()
            ));
        }
        if before != after {
            return Err(format!("{shown}: a refused command changed the directory"));
        }
        return Ok(());
    }
    if !o.status.success() {
        return Err(format!("{shown}: exit {:?}: {err}", o.status.code()));
    }
    // The files each output may change: its final target (symlinks followed).
    let mut allowed = Vec::new();
    for (flag, path) in &outputs {
        let target = path
            .canonicalize()
            .map_err(|e| format!("{shown}: {flag} {}: {e}", path.display()))?;
        let rel = target
            .strip_prefix(dir.canonicalize().map_err(|e| e.to_string())?)
            .map_err(|_| {
                format!(
                    "{shown}: {flag} was written outside the directory: {}",
                    target.display()
                )
            })?
            .to_path_buf();
        let m = std::fs::metadata(&target).map_err(|e| e.to_string())?;
        if m.is_file() {
            let text = std::fs::read_to_string(&target).map_err(|e| e.to_string())?;
            complete(flag, &text).map_err(|e| format!("{shown}: {flag}: {e}"))?;
        }
        allowed.push(rel);
    }
    for (flag, text) in &fifo_text {
        complete(flag, text).map_err(|e| format!("{shown}: {flag} (a FIFO): {e}"))?;
    }
    let keys: std::collections::BTreeSet<&PathBuf> = before.keys().chain(after.keys()).collect();
    for k in keys {
        if before.get(k) != after.get(k) && !allowed.contains(k) {
            return Err(format!(
                "{shown}: {} changed, and it is no named output's target ({} -> {})",
                k.display(),
                before.get(k).map_or("absent", |s| &s[..s.len().min(40)]),
                after.get(k).map_or("absent", |s| &s[..s.len().min(40)])
            ));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// Runs output-path cases for `budget`; returns how many. Panics on the first failure.
fn probe_outputs(budget: Duration, seed: u64) -> usize {
    let mut rng = Rng::new(seed);
    let started = Instant::now();
    let mut cases = 0;
    while started.elapsed() < budget {
        if let Err(why) = output_case(&mut rng, cases) {
            panic!("{why}");
        }
        cases += 1;
    }
    cases
}

#[cfg(unix)]
#[test]
fn outputs_bounded() {
    let _turn = crate::util::one_heavy_test_at_a_time();
    let cases = probe_outputs(Duration::from_secs(15), 0x0070_2026);
    eprintln!("output probe: {cases} cases in 15 s");
    assert!(cases > 0);
}

#[cfg(unix)]
#[test]
#[ignore = "10-minute output-path probe; run before a release"]
fn outputs_long() {
    let _turn = crate::util::one_heavy_test_at_a_time();
    let cases = probe_outputs(Duration::from_secs(600), 0xf1f0_2026);
    eprintln!("output probe: {cases} cases in 600 s");
}
