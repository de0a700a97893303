//! Memory before the first row: a sweep of ten million combinations (and one of a million ELST
//! variants) loads, prepares and delivers its first chunk without allocating anything the size of
//! the sweep. The counting allocator is the test binary's; the test runs alone in a child process
//! ([`in_own_process`]), so the counts are this test's only.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use arcsim_evaluator::{Evaluator, Shard, Sweep};
use arcsim_test_support::in_own_process;

struct Counting;

static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn grew(size: usize) {
    let now = CURRENT.fetch_add(size, Ordering::Relaxed) + size;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

// SAFETY: forwards to the system allocator, only counting the bytes.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's layout, as for `System`.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `alloc`/`realloc` with this layout.
        unsafe { System.dealloc(ptr, layout) };
        CURRENT.fetch_sub(layout.size(), Ordering::Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: as for `System`.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            CURRENT.fetch_sub(layout.size(), Ordering::Relaxed);
            grew(new_size);
        }
        p
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Most bytes held at once while loading, preparing and running the first chunk.
const BUDGET: usize = 16 << 20;

fn first_chunk_peak(axes: &str) -> (usize, usize) {
    let scenarios = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios");
    let text = format!(
        r#"{{"format": "arcsim-sweep/1", "name": "huge", "plans": ["../plans/prostate.json"],
            "machine": "machine-atom.json", "axes": {axes}, "schedules": ["scan"]}}"#
    );
    PEAK.store(CURRENT.load(Ordering::Relaxed), Ordering::Relaxed);
    let before = CURRENT.load(Ordering::Relaxed);
    let sweep = Sweep::from_text(&text, "huge.json", &scenarios, &|p: &Path| {
        arcsim_plan::load_plan(p).map_err(|e| e.to_string())
    })
    .expect("sweep");
    let ev = Evaluator::new(sweep).expect("prepare");
    let cancel = AtomicBool::new(false);
    let done = ev
        .run(&Shard::ALL.indices(ev.len()), &cancel, |rows| {
            assert!(rows.iter().all(|r| r.outcome.is_some()), "{rows:?}");
            cancel.store(true, Ordering::Relaxed);
            Ok(())
        })
        .expect("run");
    assert!(done > 0);
    let combinations = ev.len();
    drop(ev);
    (PEAK.load(Ordering::Relaxed) - before, combinations)
}

#[test]
fn huge_sweeps_allocate_nothing_per_combination_before_the_first_row() {
    if !in_own_process(
        module_path!(),
        "huge_sweeps_allocate_nothing_per_combination_before_the_first_row",
        &[],
    ) {
        return;
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build_global()
        .expect("pool");
    for axes in [
        r#"{"jerk_deg_per_s3": {"from": 0.1, "to": 4, "steps": 10000000}}"#,
        r#"{"jerk_deg_per_s3": [0.5, 1], "elst_down_s": {"from": 0, "to": 10, "steps": 1000000}}"#,
    ] {
        let (peak, combinations) = first_chunk_peak(axes);
        println!("{combinations} combinations: {} kB at most", peak >> 10);
        assert!(combinations >= 2_000_000);
        assert!(
            peak < BUDGET,
            "{axes}: {} MB held before the first row",
            peak >> 20
        );
    }
}
