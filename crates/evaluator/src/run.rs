//! Evaluation: each combination is one `simulate_resolved` call with its own limits, on its
//! (plan × ELST/window/beam) variant resolved once and kept in a bounded cache. Runs are parallel
//! (rayon, the current pool) and deliver rows in combination order, chunk by chunk, whatever the
//! thread count. Nothing is allocated per combination ahead of its chunk: the combinations are
//! decoded from their indices, and a chunk resolves the variants it needs.

use std::collections::{HashMap, HashSet};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use arcsim_plan::{ArcPlan, ElstModel, Machine, ResolvedArc};
use arcsim_planner::Limits;
use arcsim_sequencer::{
    certify, machine_limits, simulate_resolved, Breakdown, LimiterCounts, Margins, Options,
    SequenceError, CERTIFY_ROUNDS,
};
use rayon::prelude::*;
use serde::Serialize;

use crate::error::VariantError;
use crate::shard::IndexList;
use crate::sweep::{check_combinations, Axis, Defaults, Setting, Sweep};
use crate::{EvalError, RunMode};

/// What became of one combination.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Simulated; the row has its times.
    Ok,
    /// The sequencer found no feasible timeline (e.g. a move that cannot last its ELST).
    Infeasible,
    /// The plan does not resolve with this ELST / window (e.g. a window wider than the spacing).
    Invalid,
    /// Anything else (invalid limits, a failed timeline verification, a panic): a bug or bad input.
    Error,
}

impl Status {
    /// The status as the CSV and JSON rows write it (`ok`, `infeasible`, `invalid`, `error`).
    pub fn name(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Infeasible => "infeasible",
            Status::Invalid => "invalid",
            Status::Error => "error",
        }
    }
}

/// The times of a feasible combination.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Outcome {
    /// Total delivery time (s).
    pub total_s: f64,
    /// Where the total time goes (s).
    pub breakdown: Breakdown,
    /// Base machine's total / this total (same plan and schedule); `None` when the base is infeasible.
    pub speedup: Option<f64>,
    /// The certificate's lower bound (s), when the sweep asks for it (`"certify": true`): of
    /// every constant-speed schedule on a constant-speed row, of every free motion on a
    /// free-motion row.
    pub lower_bound_s: Option<f64>,
    /// `total_s` minus `lower_bound_s`: at most this much is left to gain (s).
    pub gap_s: Option<f64>,
    /// Counts of transitions by what limited them.
    pub limiter_counts: LimiterCounts,
    /// Prescribed schedule: number of prescribed speeds that could not be delivered.
    pub violations: usize,
    /// Kinematic margins, when the sweep asks for them (`"margins": true`).
    pub margins: Option<Margins>,
}

/// One combination's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Row {
    /// Combination index (the row's position in a full, unsharded run).
    pub index: usize,
    /// The sweep's number of combinations (the CSV's `combinations` column; the JSON results
    /// say it once).
    #[serde(skip)]
    pub combinations: usize,
    /// Plan label (path relative to the sweep file, or `atom:CASE`).
    pub plan: String,
    /// The schedule entry's way of moving.
    pub schedule: RunMode,
    /// The machine values of this combination.
    pub setting: Setting,
    /// The base machine's values of the limits `setting` keeps (`None`), which the CSV writes in
    /// their columns; not in the JSON rows, where `null` still means "as in the base machine".
    #[serde(skip)]
    pub defaults: Defaults,
    /// Whether the combination was delivered and, if not, why.
    pub status: Status,
    /// The times; present when `status` is `ok`.
    pub outcome: Option<Outcome>,
    /// Why the combination is not `ok` (empty when it is).
    pub message: String,
}

/// The combinations of one plan under one schedule entry: a contiguous index range.
#[derive(Debug, Clone)]
struct Block {
    plan: usize,
    run: usize,
    offset: usize,
    len: usize,
    base_total_s: Option<f64>,
    /// The base machine's delivery's peak use of each limit (what the summary's sensitivities
    /// need to know where that delivery is still feasible).
    base_margins: Option<Margins>,
}

/// A variant's resolved arcs, or why it does not resolve (its rows are then `invalid`).
type Resolved = Result<Vec<ResolvedArc>, VariantError>;
/// The plan and the bits of every setting that changes the resolved layers (window, ELST up and
/// down, scanning speed, dose-rate scale, burst switching, spill charge, refill and layers).
type VariantKey = (usize, [Option<u64>; 9]);
type Variants = HashMap<VariantKey, Arc<Resolved>>;

/// Most resolved variants kept between chunks and calls (a chunk resolves whatever it needs on
/// top; a sweep with more variants than this resolves some of them again).
const VARIANT_CACHE: usize = 256;

/// A sweep prepared for evaluation.
pub struct Evaluator {
    sweep: Sweep,
    /// The sweep's [`Sweep::defaults`], given to every row.
    defaults: Defaults,
    base_limits: Limits,
    blocks: Vec<Block>,
    /// Resolved (plan × window × ELST × beam) variants, at most [`VARIANT_CACHE`].
    variants: Mutex<Variants>,
}

fn key(plan: usize, s: &Setting) -> VariantKey {
    let values = [
        s.window_deg,
        s.elst_up_s,
        s.elst_down_s,
        s.scan_speed_mm_per_s,
        s.dose_rate_scale,
        s.burst_switching_time_s,
        s.spill_charge_mu,
        s.spill_refill_time_s,
        s.spill_max_layers,
    ];
    (plan, values.map(|v| v.map(f64::to_bits)))
}

/// The plan and machine of one (window, ELST, beam) variant, resolved: the beam axes
/// ([`Axis::BEAM`]) applied to a copy of the machine's beam model.
fn resolve_variant(plan: &ArcPlan, machine: &Machine, s: &Setting) -> Resolved {
    let mut m = machine.clone();
    // A sweep refuses a beam axis on a machine that lacks what it sets when it is loaded.
    let lacks = |axis: Axis| match axis.spill_only() {
        Some(_) => VariantError::NoSpills {
            machine: machine.name.clone(),
        },
        None => VariantError::NotScanning {
            machine: machine.name.clone(),
            kind: machine.beam.kind(),
            lacks: axis.scanning_only().map_or("", |(lacks, _)| lacks),
        },
    };
    for axis in Axis::BEAM {
        if let Some(x) = s.get(axis) {
            m.beam = axis.set_beam(&m.beam, x).ok_or_else(|| lacks(axis))?;
        }
    }
    match &mut m.elst {
        ElstModel::Constant { up_s, down_s, .. } => {
            *up_s = s.elst_up_s.unwrap_or(*up_s);
            *down_s = s.elst_down_s.unwrap_or(*down_s);
        }
        ElstModel::Polynomial { down_s, .. } => *down_s = s.elst_down_s.unwrap_or(*down_s),
        // A loaded sweep sets neither on a table model.
        ElstModel::ByEnergy { .. } | ElstModel::ByEnergyPair { .. } => {}
    }
    let resolved = match s.window_deg {
        None => arcsim_plan::resolve(plan, &m),
        Some(w) => {
            let mut p = plan.clone();
            p.arcs
                .iter_mut()
                .flat_map(|a| a.control_points.iter_mut())
                .for_each(|cp| cp.window_deg = Some(w));
            arcsim_plan::resolve(&p, &m)
        }
    };
    resolved.map_err(VariantError::Plan)
}

impl Evaluator {
    /// Checks the sweep's size (at most [`crate::MAX_COMBINATIONS`] combinations), resolves each
    /// plan on the base machine and evaluates it there, for the speed-ups (in parallel, on the
    /// current rayon pool). The variants the grids use are resolved as the runs reach them.
    pub fn new(sweep: Sweep) -> Result<Evaluator, EvalError> {
        let base_limits = machine_limits(&sweep.machine).map_err(|e| EvalError::Input {
            file: sweep.source.clone(),
            field: "machine".into(),
            message: e.to_string(),
        })?;
        check_combinations(
            &sweep.source,
            Some(sweep.plans.len()),
            sweep.schedule_grids.iter().map(|r| &r.grid),
        )?;
        let base = sweep.base_setting();
        let mut blocks = Vec::new();
        let mut offset = 0;
        for plan in 0..sweep.plans.len() {
            for (run, r) in sweep.schedule_grids.iter().enumerate() {
                let len = r.grid.len();
                blocks.push(Block {
                    plan,
                    run,
                    offset,
                    len,
                    base_total_s: None,
                    base_margins: None,
                });
                offset += len;
            }
        }
        let mut ev = Evaluator {
            defaults: sweep.defaults(),
            sweep,
            base_limits,
            blocks,
            variants: Mutex::new(HashMap::new()),
        };
        let bases: Vec<(usize, Setting)> = (0..ev.sweep.plans.len()).map(|p| (p, base)).collect();
        ev.resolve(&bases);
        let base_outcomes: Vec<Option<Outcome>> = ev
            .blocks
            .par_iter()
            .map(|b| {
                let schedule = ev.sweep.schedule_grids[b.run].schedule;
                ev.simulate_measured(b.plan, schedule, &base, None).1
            })
            .collect();
        for (b, o) in ev.blocks.iter_mut().zip(base_outcomes) {
            b.base_total_s = o.map(|o| o.total_s);
            b.base_margins = o.and_then(|o| o.margins);
        }
        Ok(ev)
    }

    fn cache(&self) -> std::sync::MutexGuard<'_, Variants> {
        // Nothing panics while holding the lock; a poisoned cache is still a valid cache.
        self.variants.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The resolved variants of `wanted` (plan, setting) pairs: from the cache, the others
    /// resolved in parallel and cached (the cache is emptied first when they would overflow it).
    fn resolve(&self, wanted: &[(usize, Setting)]) -> Variants {
        let mut out = Variants::new();
        let mut missing: Vec<(VariantKey, usize, Setting)> = Vec::new();
        {
            let cache = self.cache();
            let mut seen = HashSet::new();
            for (plan, s) in wanted {
                let k = key(*plan, s);
                if !seen.insert(k) {
                    continue;
                }
                match cache.get(&k) {
                    Some(r) => {
                        out.insert(k, Arc::clone(r));
                    }
                    None => missing.push((k, *plan, *s)),
                }
            }
        }
        if missing.is_empty() {
            return out;
        }
        let resolve_one = |(k, plan, s): &(VariantKey, usize, Setting)| {
            let r = resolve_variant(&self.sweep.plans[*plan].plan, &self.sweep.machine, s);
            (*k, Arc::new(r))
        };
        let new: Vec<(VariantKey, Arc<Resolved>)> = if missing.len() == 1 {
            missing.iter().map(resolve_one).collect()
        } else {
            missing.par_iter().map(resolve_one).collect()
        };
        let mut cache = self.cache();
        if cache.len() + new.len() > VARIANT_CACHE {
            cache.clear();
        }
        for (k, r) in new {
            if cache.len() < VARIANT_CACHE {
                cache.insert(k, Arc::clone(&r));
            }
            out.insert(k, r);
        }
        out
    }

    /// The sweep being evaluated.
    pub fn sweep(&self) -> &Sweep {
        &self.sweep
    }

    /// Total number of combinations.
    pub fn len(&self) -> usize {
        self.blocks.last().map_or(0, |b| b.offset + b.len)
    }

    /// Whether the sweep has no combinations.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn block(&self, index: usize) -> &Block {
        let i = self.blocks.partition_point(|b| b.offset + b.len <= index);
        &self.blocks[i.min(self.blocks.len() - 1)]
    }

    /// Plan index, schedule entry index and setting of combination `index` (< [`Evaluator::len`]).
    pub fn combination(&self, index: usize) -> (usize, usize, Setting) {
        let b = self.block(index);
        (
            b.plan,
            b.run,
            self.sweep.schedule_grids[b.run]
                .grid
                .setting(index - b.offset),
        )
    }

    /// The base machine's delivery's margins for a plan under a schedule entry (`None`:
    /// infeasible there).
    pub(crate) fn base_margins(&self, plan: usize, run: usize) -> Option<Margins> {
        self.blocks
            .iter()
            .find(|b| b.plan == plan && b.run == run)
            .and_then(|b| b.base_margins)
    }

    /// The base machine's total for a plan under a schedule entry (`None`: infeasible there).
    pub fn base_total_s(&self, plan: usize, run: usize) -> Option<f64> {
        self.blocks
            .iter()
            .find(|b| b.plan == plan && b.run == run)
            .and_then(|b| b.base_total_s)
    }

    /// The planner limits of a setting: J, A, V as given; an explicit deceleration limit scaled
    /// like the acceleration.
    pub fn limits(&self, s: &Setting) -> Limits {
        let b = &self.base_limits;
        Limits {
            max_jerk: s.jerk_deg_per_s3,
            max_accel: s.accel_deg_per_s2,
            max_decel: b.max_decel * (s.accel_deg_per_s2 / b.max_accel),
            max_vel: s.speed_deg_per_s,
        }
    }

    /// Evaluates combination `index` (< [`Evaluator::len`]).
    pub fn evaluate(&self, index: usize) -> Row {
        let (plan, _, setting) = self.combination(index);
        let variants = self.resolve(&[(plan, setting)]);
        self.evaluate_with(index, &variants)
    }

    /// Evaluates combination `index` with its variant among `variants`.
    fn evaluate_with(&self, index: usize, variants: &Variants) -> Row {
        let b = self.block(index);
        let run = &self.sweep.schedule_grids[b.run];
        let setting = run.grid.setting(index - b.offset);
        let arcs = &variants[&key(b.plan, &setting)];
        let (status, outcome, message) = self.simulate_variant(
            arcs,
            run.schedule,
            &setting,
            b.base_total_s,
            self.sweep.certify,
        );
        Row {
            index,
            combinations: self.len(),
            plan: self.sweep.plans[b.plan].label.clone(),
            schedule: run.schedule,
            setting,
            defaults: self.defaults,
            status,
            outcome,
            message,
        }
    }

    /// Simulates any setting of a plan (resolving its variant if it is not cached); totals only,
    /// never the certificate.
    pub fn simulate(
        &self,
        plan: usize,
        schedule: RunMode,
        s: &Setting,
        base_total_s: Option<f64>,
    ) -> (Status, Option<Outcome>, String) {
        self.simulate_with(plan, schedule, s, base_total_s, self.sweep.margins)
    }

    /// [`Evaluator::simulate`] with the delivery's margins (its peak use of each limit), whether
    /// or not the sweep asks for them.
    pub(crate) fn simulate_measured(
        &self,
        plan: usize,
        schedule: RunMode,
        s: &Setting,
        base_total_s: Option<f64>,
    ) -> (Status, Option<Outcome>, String) {
        self.simulate_with(plan, schedule, s, base_total_s, true)
    }

    /// Any setting of a plan (its variant resolved if not cached), never the certificate, with
    /// the margins if `margins`.
    fn simulate_with(
        &self,
        plan: usize,
        schedule: RunMode,
        s: &Setting,
        base_total_s: Option<f64>,
        margins: bool,
    ) -> (Status, Option<Outcome>, String) {
        let variants = self.resolve(&[(plan, *s)]);
        let arcs = &variants[&key(plan, s)];
        self.simulate_opts(arcs, schedule, s, base_total_s, (false, margins))
    }

    /// `certify`: also the row's certificate (the sweep's rows; not the base
    /// totals and the summary's extra settings, which need only totals).
    fn simulate_variant(
        &self,
        arcs: &Resolved,
        schedule: RunMode,
        s: &Setting,
        base_total_s: Option<f64>,
        certify_row: bool,
    ) -> (Status, Option<Outcome>, String) {
        let margins = self.sweep.margins;
        self.simulate_opts(arcs, schedule, s, base_total_s, (certify_row, margins))
    }

    /// The simulation of a variant, with its certificate and its margins as `(certify_row,
    /// margins)` say.
    fn simulate_opts(
        &self,
        arcs: &Resolved,
        schedule: RunMode,
        s: &Setting,
        base_total_s: Option<f64>,
        (certify_row, margins): (bool, bool),
    ) -> (Status, Option<Outcome>, String) {
        let arcs = match arcs {
            Ok(a) => a,
            Err(e) => return (Status::Invalid, None, e.to_string()),
        };
        let opts = Options {
            schedule: schedule.schedule,
            build_timeline: margins,
            servo_period_s: self.sweep.machine.servo_period_s,
            motion: schedule.motion,
            arc_ends: schedule.arc_ends,
        };
        let limits = self.limits(s);
        let result = catch_unwind(AssertUnwindSafe(|| {
            let d = simulate_resolved(arcs, &limits, &opts)?;
            let certificate = if certify_row {
                Some(certify(arcs, &limits, &d, CERTIFY_ROUNDS)?)
            } else {
                None
            };
            Ok((d, certificate))
        }));
        match result {
            Ok(Ok((d, certificate))) => {
                let outcome = Outcome {
                    total_s: d.total_s,
                    breakdown: d.breakdown,
                    speedup: base_total_s.map(|b| b / d.total_s),
                    lower_bound_s: certificate.map(|c| c.lower_bound_s),
                    gap_s: certificate.map(|c| c.gap_s),
                    limiter_counts: d.limiter_counts,
                    violations: d.violations.len(),
                    margins: d.margins,
                };
                (Status::Ok, Some(outcome), String::new())
            }
            Ok(Err(e @ SequenceError::Infeasible { .. })) => {
                (Status::Infeasible, None, e.to_string())
            }
            Ok(Err(e @ SequenceError::Plan(_))) => (Status::Invalid, None, e.to_string()),
            Ok(Err(e)) => (Status::Error, None, e.to_string()),
            Err(panic) => {
                let what = panic
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "unknown panic".into());
                (
                    Status::Error,
                    None,
                    format!("the simulation panicked (a bug): {what}"),
                )
            }
        }
    }

    /// Evaluates `indices` (each < [`Evaluator::len`]; a [`crate::ShardIndices`], a range or a
    /// list, see [`IndexList`]) on the current rayon pool and hands the rows to `sink` in the order
    /// of `indices`, a chunk at a time (chunks last about 0.1 s). The indices are read a chunk at a
    /// time and each chunk resolves the variants it needs, so nothing is allocated per combination
    /// beyond the current chunk. Stops early, after the rows finished so far, when `cancel` becomes
    /// true; returns the number of rows sunk.
    pub fn run<I: IndexList + ?Sized>(
        &self,
        indices: &I,
        cancel: &AtomicBool,
        mut sink: impl FnMut(&[Row]) -> Result<(), EvalError>,
    ) -> Result<usize, EvalError> {
        let total = indices.index_count();
        let threads = rayon::current_num_threads().max(1);
        let mut chunk = 4 * threads;
        let mut done = 0;
        while done < total && !cancel.load(Ordering::Relaxed) {
            let started = Instant::now();
            let part: Vec<usize> = (done..total.min(done.saturating_add(chunk)))
                .map(|p| indices.index_at(p))
                .collect();
            let wanted: Vec<(usize, Setting)> = part
                .iter()
                .map(|&i| {
                    let (plan, _, s) = self.combination(i);
                    (plan, s)
                })
                .collect();
            let variants = self.resolve(&wanted);
            drop(wanted);
            let rows: Vec<Option<Row>> = part
                .par_iter()
                .map(|&i| {
                    (!cancel.load(Ordering::Relaxed)).then(|| self.evaluate_with(i, &variants))
                })
                .collect();
            let finished: Vec<Row> = rows.into_iter().map_while(|r| r).collect();
            sink(&finished)?;
            done += finished.len();
            if finished.len() < part.len() {
                break;
            }
            let per_item = started.elapsed().as_secs_f64() / part.len() as f64;
            let target = Duration::from_millis(100).as_secs_f64();
            chunk = ((target / per_item.max(1e-9)) as usize).clamp(threads, 1 << 16);
        }
        Ok(done)
    }

    /// Evaluates `indices` and returns their rows in order (no cancellation).
    pub fn run_collect<I: IndexList + ?Sized>(&self, indices: &I) -> Vec<Row> {
        let mut rows = Vec::new();
        let never = AtomicBool::new(false);
        // The sink cannot fail, so neither can the run.
        let _ = self.run(indices, &never, |r| {
            rows.extend_from_slice(r);
            Ok(())
        });
        rows
    }
}
