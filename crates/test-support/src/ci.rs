//! Tests that need something outside the repository's code: a test that cannot run fails and says
//! why (it never passes without running); the published reference data it may need is in the
//! repository (`reference/`).

use std::path::PathBuf;

/// A test that cannot run fails, naming `what` and `why`: a test that did not run never passes.
/// (Tests that need a tool this machine may lack say how to install it in `why`.)
pub fn cannot_run(what: &str, why: &str) -> ! {
    panic!("{what} cannot run: {why}");
}

/// `reference/atom-article-cases.json` in the repository: the ATOM article's published data
/// (Wase et al., Phys. Med. Biol. 2024; its source is named inside the file).
pub fn atom_reference_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../reference/atom-article-cases.json")
}

/// The text of [`atom_reference_path`]; a test that needs it fails, naming `what`, when it
/// cannot be read.
pub fn atom_reference(what: &str) -> String {
    let path = atom_reference_path();
    std::fs::read_to_string(&path)
        .unwrap_or_else(|e| cannot_run(what, &format!("{} not readable ({e})", path.display())))
}

#[cfg(test)]
mod tests {
    use super::{atom_reference, cannot_run};

    #[test]
    fn a_test_that_cannot_run_fails_naming_what_and_why() {
        let panic = std::panic::catch_unwind(|| cannot_run("the widget test", "no widget"))
            .expect_err("a failure");
        let message = panic.downcast_ref::<String>().expect("a message");
        assert_eq!(message, "the widget test cannot run: no widget");
    }

    #[test]
    fn the_atom_reference_is_in_the_repository() {
        let text = atom_reference("this test");
        assert!(text.contains("Wase et al., Phys. Med. Biol. 2024"));
    }
}
