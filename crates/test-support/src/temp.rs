//! Temporary directories and files for tests.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// A fresh, empty directory, different at every call of this test binary run:
/// `TMP/arcsim-tests/PID-N`, where TMP is the target directory's `tmp/` (what Cargo gives tests as
/// `CARGO_TARGET_TMPDIR`), found from the running test binary, else the system's temporary
/// directory.
pub fn temp_dir() -> PathBuf {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let dir = base().join("arcsim-tests").join(format!(
        "{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    dir
}

/// Writes `bytes` as `file_name` in a fresh [`temp_dir`] and returns its path.
pub fn temp_file(file_name: &str, bytes: &[u8]) -> PathBuf {
    let path = temp_dir().join(file_name);
    std::fs::write(&path, bytes).expect("temporary file written");
    path
}

/// `TARGET/tmp` when the running binary is a test, bench or example Cargo built
/// (`TARGET/PROFILE/deps/NAME` or `TARGET/PROFILE/examples/NAME`); else the system's temporary
/// directory. (`CARGO_TARGET_TMPDIR` itself is only set when Cargo compiles integration tests and
/// benches, not their dependencies.)
fn base() -> PathBuf {
    std::env::current_exe()
        .ok()
        .as_deref()
        .and_then(target_tmp_of)
        .unwrap_or_else(std::env::temp_dir)
}

fn target_tmp_of(exe: &Path) -> Option<PathBuf> {
    let dir = exe.parent()?;
    let kind = dir.file_name()?;
    if kind != "deps" && kind != "examples" {
        return None;
    }
    Some(dir.parent()?.parent()?.join("tmp"))
}
