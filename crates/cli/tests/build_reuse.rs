//! The README's two set-up commands share one build: after the test suite's build, the first
//! command (`cargo run -p arcsim -- …`) compiles nothing new. The workspace's dependency features
//! and profiles are chosen for that (root `Cargo.toml`, `crates/viewer/Cargo.toml`); a new
//! dependency that turns on a feature only in the test build would have a newcomer compile the
//! rerun stack twice (about 15 minutes on 2 cores).

use crate::util;

use std::path::Path;
use std::process::Command;

/// Packages `cargo build -p arcsim` compiled, from its JSON messages (artifacts not fresh).
fn compiled_packages(messages: &str) -> Vec<String> {
    messages
        .lines()
        .filter_map(|line| serde_json::from_str::<serde_json::Value>(line).ok())
        .filter(|m| m["reason"] == "compiler-artifact" && m["fresh"] == false)
        .map(|m| m["package_id"].as_str().unwrap_or("?").to_string())
        .collect()
}

#[test]
fn the_main_command_reuses_the_test_build() {
    let _turn = crate::util::one_heavy_test_at_a_time();
    let exe = Path::new(env!("CARGO_BIN_EXE_arcsim"));
    // target/<profile>/arcsim: build the same profile the tests were built with.
    let profile = match exe.parent().and_then(Path::file_name) {
        Some(p) if p == "release" => "release",
        _ => "dev",
    };
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    let mut build = Command::new(cargo);
    util::without_test_environment(&mut build);
    let out = build
        .current_dir(&repo)
        .args(["build", "-p", "arcsim", "--profile", profile])
        .args(["--message-format", "json"])
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "cargo build -p arcsim failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let compiled = compiled_packages(&String::from_utf8_lossy(&out.stdout));
    let dependencies: Vec<&String> = compiled
        .iter()
        .filter(|id| !id.starts_with("path+file://"))
        .collect();
    assert!(
        dependencies.is_empty(),
        "after the test build, `cargo build -p arcsim` compiled {} dependencies again (features \
         or profile differ between the two; compare `cargo tree -e features -p arcsim` with \
         `--workspace`): {:?}",
        dependencies.len(),
        dependencies.iter().take(20).collect::<Vec<_>>()
    );
}
