//! `scenarios/slurm/`: the job-array script run once per task id as SLURM would run it, then the
//! merge script; the merged table must be the single run's, byte for byte.

use crate::util;

use std::path::Path;
use std::process::{Command, Output};

use arcsim_test_support::{cannot_run, temp_dir};

use crate::util::{path_str, repo, sweep_file, text};

const SHARDS: usize = 3;

fn have_bash() -> bool {
    Command::new("bash")
        .args(["-c", "true"])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// `bash scenarios/slurm/SCRIPT` in the repository root with the environment of array task
/// `task` (`None`: the merge job) of `SHARDS`.
fn sbatch(script: &str, task: Option<usize>, sweep: &Path, out_dir: &Path) -> Output {
    let mut c = Command::new("bash");
    c.arg(format!("scenarios/slurm/{script}"))
        .current_dir(repo())
        .env("SLURM_ARRAY_TASK_COUNT", SHARDS.to_string())
        .env("SWEEP", sweep)
        .env("OUT_DIR", out_dir)
        .env("ARCSIM", env!("CARGO_BIN_EXE_arcsim"))
        .env_remove("ARCSIM_SHARDS")
        .env_remove("SLURM_CPUS_PER_TASK")
        .env_remove("SLURM_ARRAY_TASK_ID");
    if let Some(k) = task {
        c.env("SLURM_ARRAY_TASK_ID", k.to_string());
    }
    c.output().expect("run bash")
}

#[test]
fn job_array_and_merge_give_the_single_run() {
    let _turn = crate::util::one_heavy_test_at_a_time();
    if !have_bash() {
        cannot_run("the SLURM script test", "bash is not available");
    }
    let dir = temp_dir();
    let out_dir = dir.join("out");
    let sweep = sweep_file(
        &dir,
        "slurm",
        "plans/prostate.json",
        serde_json::json!({
            "jerk_deg_per_s3": [0.5, 1, 2],
            "accel_deg_per_s2": [0.5, 1]
        }),
    );

    for k in 1..=SHARDS {
        let o = sbatch("sweep-array.sbatch", Some(k), &sweep, &out_dir);
        let (out, err) = text(&o);
        assert!(o.status.success(), "task {k}: {out}\n{err}");
        let shard = out_dir.join(format!("shard-{k}.csv"));
        assert!(shard.is_file(), "task {k} wrote no {}", shard.display());
        assert!(
            !out_dir.join(format!("shard-{k}.csv.tmp")).exists(),
            "task {k} left its temporary file"
        );
    }

    let o = sbatch("merge.sbatch", None, &sweep, &out_dir);
    let (out, err) = text(&o);
    assert!(o.status.success(), "merge: {out}\n{err}");

    let single = dir.join("single.csv");
    let o = util::arcsim(&["sweep", path_str(&sweep), "--out", path_str(&single)]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "single run: {out}\n{err}");

    let merged = std::fs::read(out_dir.join("merged.csv")).expect("merged.csv");
    let single = std::fs::read(&single).expect("single.csv");
    assert_eq!(
        String::from_utf8_lossy(&merged),
        String::from_utf8_lossy(&single),
        "merged.csv differs from the single run's CSV"
    );
    assert_eq!(merged, single);
    // 3 x 2 settings, one schedule: a header and 6 rows.
    assert_eq!(merged.iter().filter(|&&b| b == b'\n').count(), 7);

    let report = std::fs::read_to_string(out_dir.join("report.html")).expect("report.html");
    assert!(report.contains("<svg"), "report.html has no figure");

    // A missing shard: the merge fails, naming it, and writes nothing new.
    let merged_path = out_dir.join("merged.csv");
    std::fs::remove_file(&merged_path).expect("remove merged.csv");
    std::fs::remove_file(out_dir.join("shard-2.csv")).expect("remove shard-2.csv");
    let o = sbatch("merge.sbatch", None, &sweep, &out_dir);
    let (out, err) = text(&o);
    assert!(
        !o.status.success(),
        "merge without shard 2 succeeded: {out}\n{err}"
    );
    assert!(
        err.contains("missing") && err.contains("shard-2.csv"),
        "merge error does not name the missing shard: {err}"
    );
    assert!(
        !err.contains("shard-1.csv") && !err.contains("shard-3.csv"),
        "{err}"
    );
    assert!(
        !merged_path.exists(),
        "merge wrote merged.csv without shard 2"
    );
}

#[test]
fn array_task_outside_the_shards_fails_clearly() {
    if !have_bash() {
        cannot_run("the SLURM script test", "bash is not available");
    }
    let dir = temp_dir();
    let out_dir = dir.join("out");
    let sweep = sweep_file(
        &dir,
        "slurm-outside",
        "plans/prostate.json",
        serde_json::json!({ "jerk_deg_per_s3": [0.5, 1] }),
    );
    let o = sbatch("sweep-array.sbatch", Some(SHARDS + 1), &sweep, &out_dir);
    let (out, err) = text(&o);
    assert!(
        !o.status.success(),
        "task beyond the shards succeeded: {out}\n{err}"
    );
    assert!(err.contains("ARCSIM_SHARDS"), "{err}");

    let o = sbatch("sweep-array.sbatch", None, &sweep, &out_dir);
    let (out, err) = text(&o);
    assert!(
        !o.status.success(),
        "run without a task id succeeded: {out}\n{err}"
    );
    assert!(err.contains("SLURM_ARRAY_TASK_ID"), "{err}");
}
