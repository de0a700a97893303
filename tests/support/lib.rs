//! Helpers shared by the workspace-level acceptance tests and benchmarks.

use std::path::PathBuf;

/// `../shared/reference/atom-article-cases.json` beside the repository (CI has `shared/` next to
/// the clone). `None` when it is not there, so callers can say so and skip.
pub fn atom_cases_path() -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/reference/atom-article-cases.json");
    p.exists().then_some(p)
}

/// The repository root.
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}
