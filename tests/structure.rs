//! The code's shape, as the project's conventions state it: no function longer than 100 lines
//! (clippy's `too_many_lines`, configured for every crate), no glob re-exports, and every library
//! crate warns about missing docs.

use std::path::{Path, PathBuf};

const MAX_FUNCTION_LINES: usize = 100;

/// The path of `file` under `crates/`, with `/` separators.
fn under_crates(file: &Path) -> String {
    let crates = workspace().join("crates");
    file.strip_prefix(&crates)
        .unwrap_or(file)
        .to_string_lossy()
        .replace('\\', "/")
}

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf()
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

fn crate_sources() -> Vec<PathBuf> {
    let mut files = Vec::new();
    let crates = std::fs::read_dir(workspace().join("crates")).expect("crates/ is readable");
    for krate in crates.flatten() {
        rust_files(&krate.path().join("src"), &mut files);
    }
    files.sort();
    assert!(files.len() > 50, "found only {} source files", files.len());
    files
}

/// Every crate takes the workspace's lints, among them clippy's `too_many_lines` at the
/// threshold of `clippy.toml` (100 lines): CI's `cargo clippy -- -D warnings` refuses a longer
/// function.
#[test]
fn every_crate_refuses_functions_over_100_lines() {
    let root = std::fs::read_to_string(workspace().join("Cargo.toml")).expect("Cargo.toml");
    assert!(
        root.contains("[workspace.lints.clippy]\ntoo_many_lines = \"warn\""),
        "Cargo.toml: [workspace.lints.clippy] too_many_lines = \"warn\" is missing"
    );
    let clippy = std::fs::read_to_string(workspace().join("clippy.toml")).expect("clippy.toml");
    assert!(
        clippy
            .lines()
            .any(|l| l.trim() == format!("too-many-lines-threshold = {MAX_FUNCTION_LINES}")),
        "clippy.toml: too-many-lines-threshold = {MAX_FUNCTION_LINES} is missing"
    );
    let mut missing = Vec::new();
    let mut manifests = vec![workspace().join("Cargo.toml")];
    for krate in std::fs::read_dir(workspace().join("crates"))
        .expect("crates/")
        .flatten()
    {
        manifests.push(krate.path().join("Cargo.toml"));
    }
    for manifest in &manifests {
        let text = std::fs::read_to_string(manifest).expect("a crate's Cargo.toml");
        if !text.contains("[lints]\nworkspace = true") {
            missing.push(manifest.display().to_string());
        }
    }
    assert!(
        missing.is_empty(),
        "without `[lints] workspace = true`:\n{}",
        missing.join("\n")
    );
}

#[test]
fn no_glob_re_exports_and_every_library_documents_its_items() {
    let mut problems = Vec::new();
    let crates = std::fs::read_dir(workspace().join("crates")).expect("crates/ is readable");
    let mut libraries = 0;
    for krate in crates.flatten() {
        let name = krate.file_name().to_string_lossy().into_owned();
        let lib = krate.path().join("src/lib.rs");
        let Ok(text) = std::fs::read_to_string(&lib) else {
            continue;
        };
        libraries += 1;
        if !text.contains("#![warn(missing_docs)]") {
            problems.push(format!(
                "crates/{name}/src/lib.rs: #![warn(missing_docs)] is missing"
            ));
        }
    }
    for file in crate_sources() {
        let text = std::fs::read_to_string(&file).expect("source is readable");
        for (index, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.starts_with("pub use ") && line.ends_with("::*;") {
                problems.push(format!(
                    "crates/{}:{}: glob re-export `{line}` (name the items)",
                    under_crates(&file),
                    index + 1
                ));
            }
        }
    }
    assert!(libraries >= 9, "found only {libraries} library crates");
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
