//! The code's shape, as the project's conventions state it: no function in `crates/*/src` longer
//! than 100 lines, no glob re-exports, and every library crate warns about missing docs. rustfmt
//! puts a function's closing brace at the indentation of its `fn`, which is what the length
//! count relies on.

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

/// The line's `fn` name when it opens a function item (after visibility and qualifiers).
fn function_name(line: &str) -> Option<&str> {
    let mut rest = line.trim_start();
    for prefix in [
        "pub(crate) ",
        "pub(super) ",
        "pub ",
        "const ",
        "async ",
        "unsafe ",
        "extern \"C\" ",
    ] {
        rest = rest.strip_prefix(prefix).unwrap_or(rest);
    }
    let rest = rest.strip_prefix("fn ")?;
    let end = rest.find(|c: char| !(c.is_alphanumeric() || c == '_'))?;
    Some(&rest[..end])
}

/// (length in lines, name) of every function in `text` with a body.
fn function_lengths(text: &str) -> Vec<(usize, String, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut found = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let Some(name) = function_name(line) else {
            continue;
        };
        if line.trim_end().ends_with(';') {
            continue;
        }
        let indent = &line[..line.len() - line.trim_start().len()];
        let closing = format!("{indent}}}");
        if let Some(end) = lines[i + 1..].iter().position(|l| *l == closing) {
            found.push((end + 2, name.to_string(), i + 1));
        }
    }
    found
}

#[test]
fn the_length_count_sees_a_function() {
    let text = "impl X {\n    pub(crate) fn short(&self) -> u8 {\n        1\n    }\n}\n\nfn f() {\n    let a = 1;\n    let b = 2;\n}\n";
    let lengths = function_lengths(text);
    assert_eq!(
        lengths,
        vec![(3, "short".to_string(), 2), (4, "f".to_string(), 7)]
    );
}

#[test]
fn no_function_is_longer_than_100_lines() {
    let mut long = Vec::new();
    for file in crate_sources() {
        let text = std::fs::read_to_string(&file).expect("source is readable");
        let place = under_crates(&file);
        for (length, name, line) in function_lengths(&text) {
            if length > MAX_FUNCTION_LINES {
                long.push(format!("crates/{place}:{line} {name} ({length} lines)"));
            }
        }
    }
    assert!(
        long.is_empty(),
        "functions over {MAX_FUNCTION_LINES} lines (split them into named steps):\n{}",
        long.join("\n")
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
