//! `arcsim sweep SWEEP.json`: evaluate plans × machine variants × schedules in parallel, write the
//! rows (CSV as they complete, in order; JSON at the end) and print the summary tables.
//! `arcsim sweep-merge A.csv B.csv .. --out all.csv`: join shard outputs into the single-run table.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use arcsim_evaluator::{
    merge_csv, write_csv_header, write_csv_row, EvalError, Evaluator, Results, Row, Shard,
    ShardIndices, Sweep, RESULTS_FORMAT,
};
use arcsim_sequencer::Motion;
use indicatif::{ProgressBar, ProgressStyle};

use crate::output::AtomicFile;
use crate::CliError;

#[derive(clap::Args)]
pub struct Args {
    /// Sweep file (arcsim-sweep/1 JSON, see scenarios/README.md).
    sweep: PathBuf,
    /// Write the rows as CSV here, each as soon as it and all before it are done.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write the rows and the summary as JSON here when the run ends.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Worker threads (default: one per core).
    #[arg(long)]
    threads: Option<usize>,
    /// Run only shard K of N (the combinations whose index mod N is K-1), e.g. --shard 2/3.
    #[arg(long)]
    shard: Option<String>,
    /// Write the rows for the Rerun viewer (.rrd) when the run ends (also after Ctrl-C).
    #[arg(long)]
    rrd: Option<PathBuf>,
    /// Write a static report (one self-contained HTML file: heatmaps of the delivery time over
    /// J x A at each V, sensitivities, breakdowns) when the run completes.
    #[arg(long, value_name = "FILE.html")]
    report: Option<PathBuf>,
    /// Write the report's figures as SVG files into this directory (created if missing).
    #[arg(long, value_name = "DIR")]
    plot: Option<PathBuf>,
}

#[derive(clap::Args)]
pub struct MergeArgs {
    /// Shard outputs (CSV written by `arcsim sweep --shard K/N --out ..`), in any order.
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// The merged table: byte-identical to the CSV of an unsharded run.
    #[arg(long)]
    out: PathBuf,
    /// The sweep file: checks that no combination is missing, then prints the summary table of
    /// the whole sweep (as an unsharded run does).
    #[arg(long)]
    sweep: Option<PathBuf>,
    /// Write the whole sweep for the Rerun viewer (.rrd), as `sweep --rrd` does (needs --sweep).
    #[arg(long, requires = "sweep")]
    rrd: Option<PathBuf>,
    /// Write the whole sweep's static report, as `sweep --report` does (needs --sweep).
    #[arg(long, requires = "sweep", value_name = "FILE.html")]
    report: Option<PathBuf>,
    /// Write the report's figures as SVG files into this directory (needs --sweep).
    #[arg(long, requires = "sweep", value_name = "DIR")]
    plot: Option<PathBuf>,
}

/// Set by Ctrl-C: the run stops after the rows in progress and writes what it has.
static CANCEL: AtomicBool = AtomicBool::new(false);

fn failed(e: EvalError) -> CliError {
    CliError::failed(e.to_string())
}

fn load(path: &Path) -> Result<Sweep, CliError> {
    Sweep::load_with(path, &|p: &Path| {
        crate::input::load_plan(p).map_err(|e| e.to_string())
    })
    .map_err(failed)
}

fn write_err(path: &Path) -> impl Fn(std::io::Error) -> EvalError + '_ {
    move |e| {
        EvalError::Io(std::io::Error::new(
            e.kind(),
            format!("{}: {e}", path.display()),
        ))
    }
}

pub fn run(args: Args) -> Result<(), CliError> {
    let shard = parse_shard(args.shard.as_deref())?;
    check_threads(args.threads)?;
    // The sweep file first, then every file it names: no output may overwrite one.
    check_paths(&args, &[])?;
    let sweep = load(&args.sweep)?;
    check_paths(&args, &sweep.inputs)?;
    let pool = worker_pool(args.threads, sweep.combinations())?;
    let ev = pool.install(|| Evaluator::new(sweep)).map_err(failed)?;
    let indices = shard.indices(ev.len());
    announce(&ev, shard, indices.len(), pool.current_num_threads());
    check_memory(&ev, indices.len(), available_memory_bytes())?;
    save_partial_results_on_ctrl_c();

    let bar = progress_bar(indices.len())?;
    let csv = args.out.as_deref().map(start_csv).transpose()?;
    let rows = evaluate(&pool, &ev, &indices, csv, &bar)?;
    let complete = rows.len() == indices.len();

    let summary = complete
        .then(|| pool.install(|| summarize(&ev, &rows)))
        .transpose()?;
    if let Some(path) = &args.json {
        let results = Results {
            format: RESULTS_FORMAT,
            sweep: ev.sweep().name.clone(),
            combinations: ev.len(),
            shard: (shard != Shard::ALL).then(|| shard.to_string()),
            complete,
            rows: &rows,
            summary: summary.as_ref(),
        };
        write_json(path, &results)?;
    }
    if let Some(path) = &args.rrd {
        let title = match shard {
            Shard::ALL => format!("sweep {}", ev.sweep().name),
            _ => format!("sweep {} (shard {shard})", ev.sweep().name),
        };
        write_rrd(path, &title, &rows, summary.as_ref())?;
    }
    match summary {
        Some(s) => {
            crate::report::write(&ev, &rows, &s, args.report.as_deref(), args.plot.as_deref())?;
            crate::output::print(&s.to_table());
            if let Some(line) = certificate_line(&rows) {
                crate::output::print(&line);
            }
            crate::output::print(&resequenced_lines(ev.sweep()));
            Ok(())
        }
        None => Err(interrupted(&args, rows.len(), indices.len())),
    }
}

/// With the sweep file's `resequence`: what re-sequencing does to each plan on the base machine,
/// beside what the gantry's axes buy in the table above.
fn resequenced_lines(sweep: &arcsim_evaluator::Sweep) -> String {
    let mut s = String::new();
    if sweep.resequenced.is_empty() {
        return s;
    }
    s.push_str("re-sequenced (same dose; on the base machine, its controller):\n");
    for r in &sweep.resequenced {
        let saved = r.before_s - r.after_s;
        s.push_str(&format!(
            "  {}: {:.2} → {:.2} s ({:.2} s, {:.1} %; {} moved), rows \"{}\"\n",
            crate::output::printable(&r.label),
            r.before_s,
            r.after_s,
            saved,
            100.0 * saved / r.before_s,
            crate::count(r.moved_layers, "layer"),
            crate::output::printable(&r.twin)
        ));
    }
    s
}

/// With `"certify": true`, a line per motion: how many rows are certified and the largest gap
/// (relative), named.
fn certificate_line(rows: &[arcsim_evaluator::Row]) -> Option<String> {
    let mut text = String::new();
    for (motion, what) in Motion::ALL.map(|m| (m, m.adjective())) {
        let gaps: Vec<(f64, &arcsim_evaluator::Row)> = rows
            .iter()
            .filter(|r| r.schedule.motion == motion)
            .filter_map(|r| {
                let o = r.outcome?;
                Some((o.gap_s? / o.total_s, r))
            })
            .collect();
        let Some((worst, r)) = gaps.iter().copied().max_by(|a, b| a.0.total_cmp(&b.0)) else {
            continue;
        };
        let s = &r.setting;
        text.push_str(&format!(
            "certificate: {} {what} rows bounded; largest gap {:.3} % (row {}: {}, {}, J {} A {} V {})\n",
            gaps.len(),
            100.0 * worst,
            r.index,
            r.plan,
            r.schedule.name(),
            s.jerk_deg_per_s3,
            s.accel_deg_per_s2,
            s.speed_deg_per_s
        ));
    }
    (!text.is_empty()).then_some(text)
}

/// `--shard K/N`, or every combination without it.
fn parse_shard(shard: Option<&str>) -> Result<Shard, CliError> {
    match shard {
        Some(s) => s
            .parse::<Shard>()
            .map_err(|e| CliError::usage(format!("--shard: {e}"))),
        None => Ok(Shard::ALL),
    }
}

/// `--threads` is 1 to [`MAX_THREADS`].
fn check_threads(threads: Option<usize>) -> Result<(), CliError> {
    if let Some(n) = threads {
        if !(1..=MAX_THREADS).contains(&n) {
            return Err(CliError::usage(format!(
                "--threads {n}: expected 1 to {MAX_THREADS} (this machine has {})",
                crate::count(cores(), "core")
            )));
        }
    }
    Ok(())
}

/// Refuses outputs that would overwrite the sweep file, the files it names (`named`) or each
/// other, and a `--plot` that is not a directory, before anything runs.
fn check_paths(args: &Args, named: &[PathBuf]) -> Result<(), CliError> {
    let inputs: Vec<&Path> = std::iter::once(args.sweep.as_path())
        .chain(named.iter().map(PathBuf::as_path))
        .collect();
    crate::output::check_outputs(
        &inputs,
        &[
            ("--out", args.out.as_deref()),
            ("--json", args.json.as_deref()),
            ("--rrd", args.rrd.as_deref()),
            ("--report", args.report.as_deref()),
        ],
    )?;
    crate::output::check_output_dir("--plot", args.plot.as_deref())
}

/// The worker threads: `--threads` or one per core, but no more than combinations (each extra
/// thread would only wait).
fn worker_pool(threads: Option<usize>, combinations: usize) -> Result<rayon::ThreadPool, CliError> {
    let threads = threads.unwrap_or_else(cores).min(combinations.max(1));
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| CliError::failed(format!("cannot start worker threads: {e}")))
}

/// Says what is about to run: the sweep, its plans and combinations (of this shard) and threads.
fn announce(ev: &Evaluator, shard: Shard, to_run: usize, threads: usize) {
    let part = if shard == Shard::ALL {
        String::new()
    } else {
        format!(", shard {shard}: {to_run} of them")
    };
    eprintln!(
        "sweep \"{}\": {}, {}{part}, {}",
        crate::output::printable(&ev.sweep().name),
        crate::count(ev.sweep().plans.len(), "plan"),
        crate::count(ev.len(), "combination"),
        crate::count(threads, "thread")
    );
}

/// Bytes one row held for the summary takes: the row itself and its plan label (a message
/// where a row failed is short and rare).
fn row_bytes(ev: &Evaluator) -> usize {
    let label = ev.sweep().plans.iter().map(|p| p.label.len()).max();
    std::mem::size_of::<Row>() + label.unwrap_or(0) + 16
}

/// The memory a sweep's rows may take: `ARCSIM_MEMORY_LIMIT_BYTES` when set (a cap of one's
/// own, e.g. on a shared node), else what this machine has available (`MemAvailable` of
/// `/proc/meminfo`), where it says.
fn available_memory_bytes() -> Option<u64> {
    if let Some(cap) = std::env::var("ARCSIM_MEMORY_LIMIT_BYTES")
        .ok()
        .and_then(|v| v.trim().parse::<u64>().ok())
    {
        return Some(cap);
    }
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Refuses, before any work, a run whose rows (held for the summary) would not fit in
/// `available` bytes: a sweep of 1e8 rows once started towards 69 GB. Shards hold only their
/// own rows.
fn check_memory(ev: &Evaluator, to_run: usize, available: Option<u64>) -> Result<(), CliError> {
    let need = to_run as u64 * row_bytes(ev) as u64;
    match available {
        Some(have) if need > have => Err(CliError::usage(format!(
            "{} would hold about {} of rows in memory for the summary; this machine has {} \
             available: run it in shards (--shard K/N, each holds its own rows)",
            crate::count(to_run, "combination"),
            bytes_text(need),
            bytes_text(have)
        ))),
        _ => Ok(()),
    }
}

/// A byte count as "12.3 GB" or "450 MB".
fn bytes_text(b: u64) -> String {
    let b = b as f64;
    if b >= 1e9 {
        format!("{:.1} GB", b / 1e9)
    } else {
        format!("{:.0} MB", (b / 1e6).max(1.0))
    }
}

/// The first Ctrl-C (or SIGTERM, SIGHUP) sets [`CANCEL`]: the run stops after the rows in progress
/// and writes what it has. A second one aborts.
fn save_partial_results_on_ctrl_c() {
    if let Err(e) = ctrlc::set_handler(|| {
        if CANCEL.swap(true, Ordering::SeqCst) {
            eprintln!("\naborted");
            std::process::exit(130);
        }
        eprintln!("\ninterrupted: finishing the rows in progress (Ctrl-C again to abort)");
    }) {
        eprintln!("warning: Ctrl-C, SIGTERM and SIGHUP will not save partial results: {e}");
    }
}

/// A progress bar over `len` combinations on a terminal; hidden otherwise.
pub(crate) fn progress_bar(len: usize) -> Result<ProgressBar, CliError> {
    if !std::io::stderr().is_terminal() {
        return Ok(ProgressBar::hidden());
    }
    let style = ProgressStyle::with_template(
        "{elapsed_precise} [{wide_bar}] {human_pos}/{human_len} {rate} ETA {eta}",
    )
    .map_err(|e| CliError::failed(format!("progress bar: {e}")))?
    .with_key(
        "rate",
        |s: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
            let _ = write!(w, "{:.0}/s", s.per_sec());
        },
    );
    Ok(ProgressBar::new(len as u64).with_style(style))
}

/// Opens `--out` with its header written. Rows go to a temporary file beside OUT as they complete
/// (named on standard error: watch it grow; after a crash it holds the rows done); it is renamed
/// to OUT at the end, also after an interrupt, and removed if the run fails.
fn start_csv(path: &Path) -> Result<AtomicFile, CliError> {
    let mut f = AtomicFile::create(path)?;
    if let Some(temp) = f.temporary() {
        eprintln!(
            "rows go to {} as they complete; it becomes {} when the run ends",
            temp.display(),
            path.display()
        );
    }
    let w = f.writer();
    let header = write_csv_header(w).and_then(|()| w.flush());
    header.map_err(|e| f.error(e))?;
    Ok(f)
}

/// Evaluates `indices` on `pool`, appending each finished chunk of rows to `csv` (committed at the
/// end) and advancing `bar`; stops early after Ctrl-C. Returns the rows done, in order, and says
/// how long they took.
fn evaluate(
    pool: &rayon::ThreadPool,
    ev: &Evaluator,
    indices: &ShardIndices,
    mut csv: Option<AtomicFile>,
    bar: &ProgressBar,
) -> Result<Vec<Row>, CliError> {
    let mut rows: Vec<Row> = Vec::new();
    let started = Instant::now();
    let mut estimated = false;
    let total = indices.len();
    let done = pool
        .install(|| {
            ev.run(indices, &CANCEL, |chunk| {
                // Once the first rows have run for a few seconds: how long the rest will take,
                // on standard error whether or not a progress bar shows (a job log too).
                let elapsed = started.elapsed().as_secs_f64();
                let so_far = rows.len() + chunk.len();
                if !estimated && elapsed >= ESTIMATE_AFTER_S {
                    estimated = true;
                    if let Some(line) = estimate_line(so_far, total, elapsed, "row") {
                        bar.suspend(|| eprintln!("{line}; Ctrl-C stops and keeps the rows done"));
                    }
                }
                if let Some(f) = csv.as_mut() {
                    let path = f.path().to_path_buf();
                    let w = f.writer();
                    chunk
                        .iter()
                        .try_for_each(|r| write_csv_row(w, r))
                        .and_then(|()| w.flush())
                        .map_err(write_err(&path))?;
                }
                rows.extend_from_slice(chunk);
                bar.inc(chunk.len() as u64);
                Ok(())
            })
        })
        .map_err(failed)?;
    bar.finish_and_clear();
    if let Some(f) = csv {
        f.commit()?;
    }
    let seconds = started.elapsed().as_secs_f64();
    eprintln!(
        "evaluated {} in {seconds:.2} s ({})",
        crate::count(done, "combination"),
        rate(done, seconds)
    );
    Ok(rows)
}

/// Seconds of running after which a long run says how long the rest will take.
pub(crate) const ESTIMATE_AFTER_S: f64 = 3.0;

/// "about 2.5 h to go (…)" after `done` of `total` units (`noun`s) in `elapsed` seconds, when
/// the rest is expected to take over a minute; `None` otherwise.
pub(crate) fn estimate_line(done: usize, total: usize, elapsed: f64, noun: &str) -> Option<String> {
    if done == 0 || done >= total {
        return None;
    }
    let rest = elapsed / done as f64 * (total - done) as f64;
    (rest > 60.0).then(|| {
        format!(
            "about {} to go at the pace of the first {} ({})",
            duration_text(rest),
            crate::count(done, noun),
            rate(done, elapsed)
        )
    })
}

/// A duration as "45 s", "12 min", "3.4 h" or "2.1 days".
fn duration_text(s: f64) -> String {
    if s < 120.0 {
        format!("{s:.0} s")
    } else if s < 7200.0 {
        format!("{:.0} min", s / 60.0)
    } else if s < 172_800.0 {
        format!("{:.1} h", s / 3600.0)
    } else {
        format!("{:.1} days", s / 86_400.0)
    }
}

/// How fast `done` evaluations in `seconds` went, readable at any speed: "120 per second", or
/// "8.4 s each" below one a second (it printed "0 per second").
fn rate(done: usize, seconds: f64) -> String {
    let per_s = done as f64 / seconds.max(1e-9);
    if per_s >= 1.0 || done == 0 {
        format!("{per_s:.0} per second")
    } else {
        format!("{:.1} s each", seconds / done as f64)
    }
}

/// The summary of `rows`, with a progress bar over the extra settings it simulates (one-limit
/// profiles and ±10 % finite differences that are not grid rows), and how long they took.
fn summarize(ev: &Evaluator, rows: &[Row]) -> Result<arcsim_evaluator::Summary, CliError> {
    let extra = ev.summary_evaluations(rows);
    let bar = progress_bar(extra)?;
    let started = Instant::now();
    let summary = ev.summarize_with(rows, &|| bar.inc(1));
    bar.finish_and_clear();
    if extra > 0 {
        eprintln!(
            "summarised in {:.2} s ({} besides the rows: one-limit profiles and ±10 % finite differences)",
            started.elapsed().as_secs_f64(),
            crate::count(extra, "setting")
        );
    }
    Ok(summary)
}

/// Writes the `--json` results document.
fn write_json(path: &Path, results: &Results) -> Result<(), CliError> {
    let mut f = AtomicFile::create(path)?;
    let w = f.writer();
    let written = serde_json::to_writer_pretty(&mut *w, results)
        .map_err(std::io::Error::from)
        .and_then(|()| w.write_all(b"\n"));
    written.map_err(|e| f.error(e))?;
    f.commit()
}

/// The error of a run stopped after `done` of `total` combinations, naming the files that hold
/// the rows done.
fn interrupted(args: &Args, done: usize, total: usize) -> CliError {
    let saved: Vec<String> = [&args.out, &args.json, &args.rrd]
        .into_iter()
        .flatten()
        .map(|p| p.display().to_string())
        .collect();
    if args.report.is_some() || args.plot.is_some() {
        eprintln!("report: not written (the run did not complete)");
    }
    let saved = if saved.is_empty() {
        String::new()
    } else {
        let verb = if saved.len() == 1 { "holds" } else { "hold" };
        format!("; {} {verb} them", saved.join(" and "))
    };
    CliError::interrupted(format!(
        "interrupted after {done} of {}{saved}",
        crate::count(total, "combination")
    ))
}

/// The sweep's Rerun recording, with the summary tables in its Summary tab when there is one.
fn write_rrd(
    path: &Path,
    title: &str,
    rows: &[Row],
    summary: Option<&arcsim_evaluator::Summary>,
) -> Result<(), CliError> {
    let text = summary.map(|s| format!("```\n{}```\n", s.to_table()));
    crate::output::write_via_path(path, |tmp| {
        arcsim_viewer::save_sweep(tmp, title, rows, text.as_deref())
            .map_err(|e| CliError::failed(format!("--rrd {}: {e}", path.display())))
    })
}

pub fn merge(args: MergeArgs) -> Result<(), CliError> {
    let check = |named: &[PathBuf]| {
        let inputs: Vec<&Path> = args
            .inputs
            .iter()
            .chain(args.sweep.as_ref())
            .chain(named)
            .map(PathBuf::as_path)
            .collect();
        crate::output::check_outputs(
            &inputs,
            &[
                ("--out", Some(&args.out)),
                ("--rrd", args.rrd.as_deref()),
                ("--report", args.report.as_deref()),
            ],
        )
    };
    check(&[])?;
    crate::output::check_output_dir("--plot", args.plot.as_deref())?;
    let sweep = match &args.sweep {
        Some(path) => Some(load(path)?),
        None => None,
    };
    check(sweep.as_ref().map_or(&[], |s| &s.inputs))?;
    let inputs = args
        .inputs
        .iter()
        .map(|p| crate::input::read_text(p).map(|t| (crate::input::input_name(p), t)))
        .collect::<Result<Vec<_>, _>>()?;
    let merged = merge_csv(&inputs, sweep.as_ref().map(|s| s.combinations())).map_err(failed)?;
    // With the sweep file, every shard's rows are read back against it (a shard of another sweep
    // fails here, named) before anything is written; then the summary of the whole run.
    let whole = match sweep {
        Some(sweep) => {
            let ev = Evaluator::new(sweep).map_err(failed)?;
            // The shards' rows, in index order, are the merged table's: each is read once.
            let mut rows = Vec::new();
            for (name, text) in &inputs {
                rows.extend(ev.rows_from_csv(name, text).map_err(failed)?);
            }
            rows.sort_by_key(|r| r.index);
            let summary = summarize(&ev, &rows)?;
            Some((ev, rows, summary))
        }
        None => None,
    };
    crate::output::write_file(&args.out, merged.as_bytes())?;
    if let Some((ev, rows, summary)) = &whole {
        if let Some(path) = &args.rrd {
            write_rrd(
                path,
                &format!("sweep {}", ev.sweep().name),
                rows,
                Some(summary),
            )?;
        }
        crate::report::write(
            ev,
            rows,
            summary,
            args.report.as_deref(),
            args.plot.as_deref(),
        )?;
    }
    let table = whole.map(|(_, _, summary)| summary.to_table());
    eprintln!(
        "merged {}: {} -> {}",
        crate::count(inputs.len(), "file"),
        crate::count(merged.lines().count().saturating_sub(1), "row"),
        args.out.display()
    );
    if let Some(table) = table {
        crate::output::print(&table);
    }
    Ok(())
}

/// Most worker threads a sweep starts: beyond this, threads only add start-up and switching
/// costs on any machine arcsim targets.
const MAX_THREADS: usize = 256;

fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

#[cfg(test)]
mod tests {
    /// A rate below one a second reads as seconds per evaluation, not "0 per second".
    #[test]
    fn slow_rates_read_as_seconds_each() {
        assert_eq!(super::rate(300, 2.5), "120 per second");
        assert_eq!(super::rate(5, 42.0), "8.4 s each");
        assert_eq!(super::rate(0, 0.0), "0 per second");
    }

    /// The estimate: the rest at the first rows' pace, said only when it is over a minute.
    #[test]
    fn a_long_sweep_says_how_long_it_will_take() {
        let line = super::estimate_line(10, 100_010, 3.0, "row").expect("long");
        assert_eq!(
            line,
            "about 8.3 h to go at the pace of the first 10 rows (3 per second)"
        );
        assert_eq!(super::estimate_line(10, 100, 3.0, "row"), None);
        assert_eq!(super::estimate_line(0, 100, 3.0, "row"), None);
        assert_eq!(super::duration_text(90.0), "90 s");
        assert_eq!(super::duration_text(3.0 * 86_400.0), "3.0 days");
    }

    /// Byte counts read as GB or MB.
    #[test]
    fn byte_counts_read_short() {
        assert_eq!(super::bytes_text(69_000_000_000), "69.0 GB");
        assert_eq!(super::bytes_text(450_000_000), "450 MB");
    }
}
