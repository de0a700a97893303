//! One test run alone in a child process of its test binary: for a test that changes what the
//! whole process shares (the environment, the global allocator's counts, the global thread pool).

use std::ffi::OsStr;
use std::process::Command;

/// Set in the child to the name of the test it runs.
const CHILD: &str = "ARCSIM_TEST_ALONE";

/// Whether the caller is the child that runs test `name` (`module_path!()` and the function's
/// name, as in `in_own_process(module_path!(), "my_test", &[])`). In the parent, runs this test
/// binary again with only that test (`--exact`, one thread) and `envs` added to its environment,
/// panics with the child's output unless exactly that one test ran and passed, and returns
/// `false`; in the child, returns `true`: the caller then runs the test's body.
pub fn in_own_process(module: &str, name: &str, envs: &[(&str, &OsStr)]) -> bool {
    // `module_path!()` starts with the test binary's crate name, which the harness leaves out.
    let path = match module.split_once("::") {
        Some((_, rest)) => format!("{rest}::{name}"),
        None => name.to_string(),
    };
    if std::env::var_os(CHILD).is_some_and(|v| v == path.as_str()) {
        return true;
    }
    let exe = std::env::current_exe().expect("the test binary's path");
    let out = Command::new(exe)
        .args([path.as_str(), "--exact", "--test-threads=1", "--nocapture"])
        .env(CHILD, &path)
        .envs(envs.iter().copied())
        .output()
        .expect("run the test binary");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && stdout.contains("test result: ok. 1 passed"),
        "{path} in its own process: {}\n--- stdout\n{stdout}\n--- stderr\n{stderr}",
        out.status
    );
    print!("{stdout}");
    eprint!("{stderr}");
    false
}

#[cfg(test)]
mod tests {
    use super::in_own_process;

    #[test]
    fn a_child_that_runs_no_test_is_a_failure() {
        let failed = std::panic::catch_unwind(|| {
            in_own_process(module_path!(), "no_such_test", &[]);
        });
        assert!(failed.is_err(), "a child that ran nothing passed");
    }

    #[test]
    fn the_child_sees_the_added_environment() {
        if in_own_process(
            module_path!(),
            "the_child_sees_the_added_environment",
            &[("ARCSIM_ALONE_PROBE", "42".as_ref())],
        ) {
            assert_eq!(std::env::var("ARCSIM_ALONE_PROBE").as_deref(), Ok("42"));
        }
    }
}
