//! The shell examples of the README and `docs/` run as written, so they cannot rot.
//!
//! Every ```` ```sh ```` block runs in bash (`set -euo pipefail`) in a fresh directory in which
//! `plans`, `scenarios` and `docs` link to the repository's, so what a command writes lands there.
//! `arcsim …` and `cargo run [--release] -p arcsim -- …` run the `arcsim` binary under test; any
//! other `cargo` command fails the block. A command meant to fail ends with `# exits N` and must
//! exit with N. A block that cannot run here (it needs the Rerun viewer, the network, or builds
//! the whole workspace) is preceded by `<!-- not run: why -->`; those are counted and listed.

use std::path::{Path, PathBuf};
use std::process::Command;

use arcsim_test_support::temp_dir;

use crate::util::repo;

/// A fenced code block of a Markdown file.
struct Block {
    /// `path:line` of the opening fence.
    place: String,
    lang: String,
    text: String,
    /// The reason given by a `<!-- not run: … -->` line just before the fence.
    not_run: Option<String>,
}

fn blocks(path: &Path) -> Vec<Block> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut found = Vec::new();
    let mut open: Option<Block> = None;
    let mut last_text_line = "";
    for (i, line) in text.lines().enumerate() {
        let fence = line.trim_start().strip_prefix("```");
        match (&mut open, fence) {
            (Some(_), Some(_)) => {
                found.extend(open.take());
                last_text_line = line;
            }
            (Some(block), None) => {
                block.text.push_str(line);
                block.text.push('\n');
            }
            (None, Some(info)) => {
                let not_run = last_text_line
                    .trim()
                    .strip_prefix("<!-- not run:")
                    .and_then(|r| r.strip_suffix("-->"))
                    .map(|r| r.trim().to_string());
                open = Some(Block {
                    place: format!("{}:{}", path.display(), i + 1),
                    lang: info.trim().to_string(),
                    text: String::new(),
                    not_run,
                });
            }
            (None, None) => {
                if !line.trim().is_empty() {
                    last_text_line = line;
                }
            }
        }
    }
    assert!(
        open.is_none(),
        "{}: a code block is not closed",
        path.display()
    );
    found
}

/// Joins `\` continuations and turns `CMD  # exits N` into a check of CMD's exit code.
fn script_of(block: &str) -> String {
    let mut joined = Vec::new();
    let mut current = String::new();
    for line in block.lines() {
        match line.strip_suffix('\\') {
            Some(head) => {
                current.push_str(head);
                current.push(' ');
            }
            None => {
                current.push_str(line);
                joined.push(std::mem::take(&mut current));
            }
        }
    }
    let mut script = String::new();
    for line in joined {
        let expected = line
            .rsplit_once("# exits ")
            .and_then(|(cmd, code)| Some((cmd, code.trim().parse::<i32>().ok()?)));
        match expected {
            Some((cmd, code)) => script.push_str(&format!(
                "if {cmd}; then echo 'expected exit {code}, got 0: {cmd}' >&2; exit 98; \
                 else rc=$?; if [ $rc -ne {code} ]; then \
                 echo \"expected exit {code}, got $rc: {cmd}\" >&2; exit 98; fi; fi\n"
            )),
            None => {
                script.push_str(&line);
                script.push('\n');
            }
        }
    }
    script
}

const PRELUDE: &str = r#"set -euo pipefail
arcsim() { "$ARCSIM_BIN" "$@"; }
cargo() {
  if [ "${1-}" = run ]; then
    shift
    if [ "${1-}" = --release ]; then shift; fi
    if [ "${1-}" = -p ] && [ "${2-}" = arcsim ] && [ "${3-}" = -- ]; then
      shift 3
      "$ARCSIM_BIN" "$@"
      return
    fi
  fi
  echo "docs_examples: 'cargo $*' cannot run in this test; mark its block <!-- not run: why -->" >&2
  return 97
}
"#;

fn documents() -> Vec<PathBuf> {
    let repo = repo();
    let mut docs = vec![repo.join("README.md")];
    let mut pages: Vec<PathBuf> = std::fs::read_dir(repo.join("docs"))
        .expect("docs/ is readable")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    pages.sort();
    docs.extend(pages);
    docs
}

fn run_block(block: &Block) -> Result<(), String> {
    let repo = repo().canonicalize().expect("repository path");
    let dir = temp_dir();
    for name in ["plans", "scenarios", "docs"] {
        std::os::unix::fs::symlink(repo.join(name), dir.join(name)).expect("symlink");
    }
    let out = Command::new("bash")
        .arg("-c")
        .arg(format!("{PRELUDE}{}", script_of(&block.text)))
        .current_dir(&dir)
        .env("ARCSIM_BIN", env!("CARGO_BIN_EXE_arcsim"))
        .output()
        .map_err(|e| format!("bash: {e}"))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "{} failed ({}):\n{}\n--- stderr (last 2000 bytes) ---\n{}",
            block.place,
            out.status,
            block.text,
            String::from_utf8_lossy(&out.stderr)
                .chars()
                .rev()
                .take(2000)
                .collect::<String>()
                .chars()
                .rev()
                .collect::<String>()
        ))
    }
}

#[test]
fn the_script_checks_an_expected_failure() {
    let script = script_of("arcsim validate x.json  # exits 1\narcsim a \\\n  --b c\n");
    assert!(
        script.starts_with("if arcsim validate x.json  ; then"),
        "{script}"
    );
    assert!(script.contains("[ $rc -ne 1 ]"), "{script}");
    assert!(script.ends_with("arcsim a    --b c\n"), "{script}");
}

/// Not one of the heavy tests that take turns (`util::one_heavy_test_at_a_time`): it has no time
/// limit, and its blocks run one command at a time, so it runs beside them on the other core.
#[test]
fn every_shell_example_in_the_docs_runs() {
    let mut ran = 0;
    let mut not_run = Vec::new();
    let mut failures = Vec::new();
    for doc in documents() {
        for block in blocks(&doc).into_iter().filter(|b| b.lang == "sh") {
            if let Some(why) = &block.not_run {
                assert!(
                    !why.is_empty(),
                    "{}: `not run` without a reason",
                    block.place
                );
                not_run.push(format!("{}: {why}", block.place));
                continue;
            }
            ran += 1;
            let t0 = std::time::Instant::now();
            let res = run_block(&block);
            // Where the test's minutes go (printed with --nocapture or on failure).
            eprintln!(
                "docs_examples: {} ran in {:.1} s",
                block.place,
                t0.elapsed().as_secs_f64()
            );
            if let Err(e) = res {
                failures.push(e);
            }
        }
    }
    eprintln!(
        "docs_examples: {ran} blocks ran; {} not run:\n  {}",
        not_run.len(),
        not_run.join("\n  ")
    );
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
    assert!(
        ran >= 5,
        "only {ran} shell blocks found in the README and docs/"
    );
    assert!(
        not_run.len() <= ran,
        "more blocks are marked `not run` ({}) than run ({ran})",
        not_run.len()
    );
}
