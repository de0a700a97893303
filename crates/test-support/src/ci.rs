//! Tests that need something outside the repository: under CI (`CI` set) a test that cannot run
//! fails and says why; elsewhere it says so on standard error and the caller returns.

use std::io::Write;
use std::path::PathBuf;

/// Whether the tests run under CI (the environment variable `CI` is set).
pub fn under_ci() -> bool {
    std::env::var_os("CI").is_some()
}

/// A test that cannot run: panics under CI naming `what` and `why`; elsewhere prints a notice, and
/// the caller returns. The notice goes to the process's standard error directly, past the test
/// harness's capture, so a plain `cargo test` shows it.
pub fn skip_or_fail(what: &str, why: &str) {
    if under_ci() {
        panic!("CI: {what} cannot run: {why}");
    }
    let _ = writeln!(std::io::stderr(), "NOTICE: {what} skipped: {why}");
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

#[cfg(test)]
mod tests {
    use super::skip_or_fail;
    use crate::in_own_process;

    #[test]
    fn skip_or_fail_fails_under_ci_naming_what_and_why() {
        if !in_own_process(
            module_path!(),
            "skip_or_fail_fails_under_ci_naming_what_and_why",
            &[("CI", "true".as_ref())],
        ) {
            return;
        }
        let panic = std::panic::catch_unwind(|| skip_or_fail("the widget test", "no widget"))
            .expect_err("a failure under CI");
        let message = panic.downcast_ref::<String>().expect("a message");
        assert_eq!(message, "CI: the widget test cannot run: no widget");
    }
}
