//! Tests that need something outside the repository: under CI (`CI` set) a test that cannot run
//! fails and says why; elsewhere it says so on standard error and the caller returns.

use std::path::PathBuf;

/// Whether the tests run under CI (the environment variable `CI` is set).
pub fn under_ci() -> bool {
    std::env::var_os("CI").is_some()
}

/// A test that cannot run: panics under CI naming `what` and `why`; elsewhere prints a notice, and
/// the caller returns.
pub fn skip_or_fail(what: &str, why: &str) {
    if under_ci() {
        panic!("CI: {what} cannot run: {why}");
    }
    eprintln!("NOTICE: {what} skipped: {why}");
}

/// `../shared/reference/atom-article-cases.json` beside the repository: the ATOM article's data,
/// which CI has and a clone alone does not.
pub fn atom_reference_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/reference/atom-article-cases.json")
}

/// The text of [`atom_reference_path`]; `None` (after [`skip_or_fail`] for `what`) when it cannot
/// be read, so under CI a missing file fails.
pub fn atom_reference(what: &str) -> Option<String> {
    let path = atom_reference_path();
    match std::fs::read_to_string(&path) {
        Ok(text) => Some(text),
        Err(e) => {
            skip_or_fail(what, &format!("{} not readable ({e})", path.display()));
            None
        }
    }
}
