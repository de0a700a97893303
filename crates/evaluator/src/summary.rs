//! Summaries of a sweep, per plan and schedule entry:
//!
//! - **time at each setting of one limit**: the total with one axis at each of its swept values
//!   and every other limit at the base machine's value, with the speed-up (base total / total);
//!   an axis of more than [`PROFILE_MAX_POINTS`] values is profiled at that many of them, evenly
//!   spread by position, both ends included (so a shard of a huge axis is not summarised by
//!   simulating every value of it);
//! - **fastest row** of the grid, with its speed-up against the base machine. Totals within
//!   [`TIE_TOLERANCE`] (relative) of the fastest tie, and ties go to the setting closest to the
//!   base machine ([`Evaluator::closest_to_base`]): fewest limits changed, then smallest
//!   `Σ |ln(value / base value)|`, then the lower values in axis order (J, A, V, ELST up, ELST
//!   down, window, scanning speed, dose-rate scale), then a grid row before a computed setting,
//!   the lower index first. The pick depends only on the set of rows, not on their order (so a
//!   shard and the merged table agree whenever they hold the same tied rows);
//! - **sensitivity** of the total to each limit L at the base machine, by central finite
//!   differences: `s_per_10_percent = (T(1.1 L) - T(L / 1.1)) / 2`, the change in total time for a
//!   +10 % change of L (≈ ln(1.1) · dT/d ln L; negative: raising L saves time), and
//!   `s_per_ln = dT/d ln L` itself (an axis of whole numbers, the layers per spill, is evaluated
//!   at L − 1 and L + 1 instead, which a machine can apply, and the difference scaled to +10 %
//!   of L). For a gantry limit (J, A, V) each of the three settings
//!   takes the shortest of the three deliveries feasible there: one found at a lower value of
//!   the limit, or one whose peak use of the limit (the delivery's margins) stays within it. So
//!   the sensitivity is never positive, and it is 0 for a limit none of them uses up to `L / 1.1`,
//!   even where a solver's local optima at the three settings came out apart (free motion on the
//!   bundled lung plan once reported −1.28 s per +10 % of a V it never used). A limit has **no effect** (`no_effect`) when every value of it
//!   the summary evaluated with the other limits at the base machine (L / 1.1, L, 1.1 L and the
//!   profile's values; from `evaluated_min` to `evaluated_max`) is feasible and gives the same
//!   total within [`TIE_TOLERANCE`] (relative);
//! - **cheapest change reaching the target**: among the grid rows and the one-limit settings
//!   whose total reaches the target time, the one whose limits differ least from the base
//!   machine, where the cost of a setting is `Σ |ln(value / base value)|` over the limits it
//!   changes (doubling or halving one limit costs ln 2 ≈ 0.69; doubling two costs 1.39). Costs
//!   within [`TIE_TOLERANCE`] tie; ties go to the shorter total (within [`TIE_TOLERANCE`],
//!   relative), then as the fastest row's. Changes from or to a zero value (e.g. an ELST of 0 s)
//!   are not ranked.

mod pick;
mod render;

use rayon::prelude::*;
use serde::Serialize;

use arcsim_sequencer::Margins;

use crate::run::{Evaluator, Row, Status};
use crate::sweep::{Axis, Grid, Setting};
use crate::sweep_file::Target;
use crate::RunMode;

use pick::total_slack;
pub use pick::TIE_TOLERANCE;
pub use render::{describe_setting, describe_steps, short, table};

/// A sweep's summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// The sweep's name.
    pub sweep: String,
    /// Combinations in the whole sweep.
    pub combinations: usize,
    /// Rows summarised (fewer for a shard or an interrupted run).
    pub rows: usize,
    /// What the cheapest change must reach.
    pub target: Target,
    /// One entry per (plan × schedule entry).
    pub entries: Vec<Entry>,
}

/// The summary of one plan under one schedule entry.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Entry {
    /// Plan label (as in the rows).
    pub plan: String,
    /// The schedule entry's way of moving.
    pub schedule: RunMode,
    /// Rows of this plan and schedule entry summarised.
    pub rows: usize,
    /// Of those, the feasible ones.
    pub feasible: usize,
    /// Total on the base machine.
    pub base_total_s: Option<f64>,
    /// The fastest row; of rows tied within [`TIE_TOLERANCE`], the one closest to the base
    /// machine ([`Evaluator::fastest`]).
    pub fastest: Option<Point>,
    /// Time at each value of one axis, the others at the base machine (one per swept axis).
    pub profiles: Vec<AxisTotals>,
    /// How the total responds to each limit at the base machine.
    pub sensitivity: Vec<Sensitivity>,
    /// The target total (from the sweep's `target` and the base total).
    pub target_total_s: Option<f64>,
    /// The cheapest change reaching the target; `None` when no evaluated setting reaches it.
    pub cheapest: Option<Change>,
}

/// A setting and its total.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Point {
    /// Row index when the point is a grid row.
    pub index: Option<usize>,
    /// The machine values.
    pub setting: Setting,
    /// Total delivery time (s).
    pub total_s: f64,
    /// Base machine's total / this total; `None` when the base is infeasible.
    pub speedup: Option<f64>,
}

/// Most points of a one-limit profile ([`AxisTotals`]): a longer axis is profiled at this many of
/// its values, evenly spread by position, both ends included.
pub const PROFILE_MAX_POINTS: usize = 1000;

/// The positions of an axis of `n` values that its profile evaluates: all of them, or
/// [`PROFILE_MAX_POINTS`] evenly spread, both ends included.
fn profile_positions(n: usize) -> impl Iterator<Item = usize> {
    let m = n.min(PROFILE_MAX_POINTS);
    (0..m).map(move |k| {
        if m == n {
            k
        } else {
            // m >= 2 here; the widening keeps k·(n − 1) from overflowing.
            (k as u128 * (n - 1) as u128 / (m - 1) as u128) as usize
        }
    })
}

/// The total at each profiled value of one swept axis (at most [`PROFILE_MAX_POINTS`] of them),
/// every other limit at the base machine: the summary's one-limit profile.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxisTotals {
    /// The profiled axis.
    pub axis: Axis,
    /// One point per profiled value, in the axis's order.
    pub points: Vec<AxisTotal>,
}

/// The total at one value of an axis ([`AxisTotals`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AxisTotal {
    /// The axis value, in the axis's unit (see [`Axis`]).
    pub value: f64,
    /// `None` when the setting is not feasible.
    pub total_s: Option<f64>,
    /// Base machine's total / this total.
    pub speedup: Option<f64>,
}

/// Sensitivity of the total to one limit at the base machine.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Sensitivity {
    /// The limit.
    pub axis: Axis,
    /// The base machine's value of it, in the axis's unit (see [`Axis`]).
    pub base_value: f64,
    /// dT / d ln L (s).
    pub s_per_ln: Option<f64>,
    /// Change of the total for +10 % of the limit (s).
    pub s_per_10_percent: Option<f64>,
    /// The limit has no effect: every value of it evaluated with the other limits at the base
    /// machine (`evaluated_min` to `evaluated_max`) is feasible and gives the same total, within
    /// [`TIE_TOLERANCE`] (relative).
    pub no_effect: bool,
    /// The lowest value of the limit evaluated with the others at the base machine (L / 1.1, or
    /// L − 1 for whole numbers, or the lowest profiled value).
    pub evaluated_min: f64,
    /// The highest such value (1.1 L, or L + 1 for whole numbers, or the highest profiled value).
    pub evaluated_max: f64,
}

/// One limit changed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Step {
    /// The changed limit.
    pub axis: Axis,
    /// The base machine's value, in the axis's unit (see [`Axis`]).
    pub from: f64,
    /// The changed value.
    pub to: f64,
}

/// A change of the base machine and what it saves.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Change {
    /// The changed limits (empty: the base machine already reaches the target).
    pub steps: Vec<Step>,
    /// Σ |ln(to / from)|.
    pub cost: f64,
    /// Total delivery time with the change (s).
    pub total_s: f64,
    /// Time saved against the base machine's total (s).
    pub saving_s: f64,
    /// Row index when the setting is a grid row.
    pub index: Option<usize>,
}

/// Factor of the finite differences (±10 %).
const FD_FACTOR: f64 = 1.1;

/// The values a finite difference of `axis` at base value `b` evaluates, below and above it:
/// `b / 1.1` and `1.1 b`, or for an axis of whole numbers the whole numbers next to `b` (not
/// below 1): ±10 % of 5 layers per spill is 4.5 and 5.5, which a machine applies as 4 and 5, so
/// the difference measured half a step and the summary printed "no effect (1–5.5 layers)".
fn nudge_values(axis: Axis, b: f64) -> (f64, f64) {
    if axis.is_whole() {
        ((b - 1.0).max(1.0).min(b), b + 1.0)
    } else {
        (b / FD_FACTOR, b * FD_FACTOR)
    }
}

/// A setting the summary evaluates besides the grid rows: the base machine with one limit changed.
#[derive(Debug, Clone, Copy)]
enum Extra {
    /// One value of a swept axis (a point of its [`AxisTotals`]).
    AxisValue { axis: Axis, value: f64 },
    /// A limit's base value times (`up`) or divided by [`FD_FACTOR`] (a finite difference).
    Nudge { axis: Axis, up: bool },
}

/// The extra settings of one entry with their totals (`None`: not feasible), in the order they
/// were listed: the profiles' values axis by axis, then the nudges.
/// The extra settings' totals, and the margins of those simulated with them (a gantry limit's
/// nudges; same order).
struct ExtraTotals(Vec<(Extra, Option<f64>)>, Vec<Option<Margins>>);

impl ExtraTotals {
    /// The margins of the delivery with `axis` nudged up or down, when simulated with them.
    fn nudged_margins(&self, axis: Axis, up: bool) -> Option<Margins> {
        self.0
            .iter()
            .zip(&self.1)
            .find_map(|(&(extra, _), &m)| match extra {
                Extra::Nudge { axis: a, up: u } if a == axis && u == up => m,
                _ => None,
            })
    }

    /// The profiled values of `axis` and their totals.
    fn along(&self, axis: Axis) -> impl Iterator<Item = (f64, Option<f64>)> + '_ {
        self.0
            .iter()
            .filter_map(move |&(extra, total)| match extra {
                Extra::AxisValue { axis: a, value } if a == axis => Some((value, total)),
                _ => None,
            })
    }

    /// The total with `axis` nudged up or down; `None` when not feasible (or not evaluated).
    fn nudged(&self, axis: Axis, up: bool) -> Option<f64> {
        self.0.iter().find_map(|&(extra, total)| match extra {
            Extra::Nudge { axis: a, up: u } if a == axis && u == up => total,
            _ => None,
        })
    }
}

/// A delivery found at one value `at` of a gantry limit: its total (`None`: infeasible) and its
/// peak use of that limit (in the limit's unit), when known.
#[derive(Clone, Copy, Debug)]
struct Found {
    at: f64,
    total_s: Option<f64>,
    peak: Option<f64>,
}

/// The shortest delivery known to be feasible at limit value `y`: found at a value no higher
/// (raising a limit admits every delivery a lower one did), or using no more of the limit than
/// `y`. Solvers find local optima: by this law a limit that no delivery found uses up to its
/// lowered value has the same time at all three settings, so its sensitivity is 0, and raising
/// a limit never costs time.
fn best_known_at(y: f64, found: &[Found]) -> Option<f64> {
    found
        .iter()
        .filter(|f| f.at <= y || f.peak.is_some_and(|p| p <= y))
        .filter_map(|f| f.total_s)
        .min_by(f64::total_cmp)
}

/// A delivery's peak use of gantry limit `axis` as a fraction of it (the margins' `*_use`; the
/// acceleration's counts braking against D, which the sweep scales with A).
fn peak_use(axis: Axis, m: &Margins) -> Option<f64> {
    match axis {
        Axis::Jerk => Some(m.jerk_use.value),
        Axis::Accel => Some(m.accel_use.value),
        Axis::Speed => Some(m.speed_use.value),
        _ => None,
    }
}

/// Base total / total, when both are known.
fn speedup(base_total: Option<f64>, total: Option<f64>) -> Option<f64> {
    base_total.zip(total).map(|(b, t)| b / t)
}

/// The smallest and largest of `xs` (+∞ and −∞ when there are none).
fn min_max(xs: impl Iterator<Item = f64>) -> (f64, f64) {
    xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    })
}

/// Whether every total is feasible and all are the same within [`TIE_TOLERANCE`] (relative).
fn all_feasible_and_equal(totals: impl Iterator<Item = Option<f64>>) -> bool {
    let all: Option<Vec<f64>> = totals.collect();
    all.is_some_and(|t| {
        let (lo, hi) = min_max(t.into_iter());
        hi - lo <= total_slack(lo)
    })
}

/// The axes a grid varies: all but those held at the base machine's value (one value, the base's).
fn swept_axes(grid: &Grid, base: &Setting) -> Vec<Axis> {
    Axis::ALL
        .into_iter()
        .filter(|&a| !(grid.axis_len(a) == 1 && grid.value(a, 0) == base.get(a)))
        .collect()
}

/// The extra settings of an entry: each swept axis at its profiled values, then each sensitivity
/// axis nudged up and down.
fn extra_settings(grid: &Grid, swept: &[Axis], sensitivity_axes: &[Axis]) -> Vec<Extra> {
    let profiled = swept.iter().flat_map(|&axis| {
        profile_positions(grid.axis_len(axis))
            .filter_map(move |i| grid.value(axis, i))
            .map(move |value| Extra::AxisValue { axis, value })
    });
    let nudges = sensitivity_axes.iter().flat_map(|&axis| {
        [
            Extra::Nudge { axis, up: true },
            Extra::Nudge { axis, up: false },
        ]
    });
    profiled.chain(nudges).collect()
}

/// The profile of `axis`: its profiled values' totals, with speed-ups against `base_total`.
fn axis_totals(axis: Axis, extras: &ExtraTotals, base_total: Option<f64>) -> AxisTotals {
    AxisTotals {
        axis,
        points: extras
            .along(axis)
            .map(|(value, total_s)| AxisTotal {
                value,
                total_s,
                speedup: speedup(base_total, total_s),
            })
            .collect(),
    }
}

/// The grid rows among `rows` that are feasible, as points.
fn feasible_points(rows: &[&Row]) -> Vec<Point> {
    rows.iter()
        .filter(|row| row.status == Status::Ok)
        .filter_map(|row| {
            row.outcome.map(|o| Point {
                index: Some(row.index),
                setting: row.setting,
                total_s: o.total_s,
                speedup: o.speedup,
            })
        })
        .collect()
}

/// The total of a setting the summary needs, when a grid row among `rows` or the base machine
/// already has it (`Some(None)`: known to be infeasible); `None` when it must be simulated.
fn known_total(
    setting: &Setting,
    base: &Setting,
    base_total: Option<f64>,
    rows: &[&Row],
) -> Option<Option<f64>> {
    if setting == base {
        return Some(base_total);
    }
    rows.iter()
        .find(|row| row.setting == *setting)
        .map(|row| row.outcome.map(|o| o.total_s))
}

impl Evaluator {
    /// Summarises `rows` (any subset of the sweep's, e.g. a shard's), evaluating on the current
    /// rayon pool the extra settings the summary needs (one-limit profiles, finite differences).
    pub fn summarize(&self, rows: &[Row]) -> Summary {
        self.summarize_with(rows, &|| {})
    }

    /// How many settings [`Evaluator::summarize`] simulates besides `rows`: the extra settings
    /// that are neither a grid row among `rows` nor the base machine (for a progress bar).
    pub fn summary_evaluations(&self, rows: &[Row]) -> usize {
        let sweep = self.sweep();
        let base = sweep.base_setting();
        self.entries()
            .map(|(plan, run)| {
                let (extras, mine) = self.entry_extras(plan, run, rows);
                let base_total = self.base_total_s(plan, run);
                extras
                    .into_iter()
                    .filter(|&e| {
                        known_total(&self.extra_setting(e), &base, base_total, &mine).is_none()
                    })
                    .count()
            })
            .sum()
    }

    /// [`Evaluator::summarize`], calling `on_evaluated` after each of the
    /// [`Evaluator::summary_evaluations`] extra settings it simulates.
    pub fn summarize_with(&self, rows: &[Row], on_evaluated: &(dyn Fn() + Sync)) -> Summary {
        let sweep = self.sweep();
        let entries = self
            .entries()
            .map(|(plan, run)| self.summarize_entry(plan, run, rows, on_evaluated))
            .collect();
        Summary {
            sweep: sweep.name.clone(),
            combinations: self.len(),
            rows: rows.len(),
            target: sweep.target,
            entries,
        }
    }

    /// Every (plan, schedule entry) pair, in the summary's order.
    fn entries(&self) -> impl Iterator<Item = (usize, usize)> {
        let runs = self.sweep().schedule_grids.len();
        (0..self.sweep().plans.len()).flat_map(move |plan| (0..runs).map(move |run| (plan, run)))
    }

    /// The extra settings of plan `plan` under schedule entry `run`, and that entry's rows among
    /// `rows`.
    fn entry_extras<'r>(
        &self,
        plan: usize,
        run: usize,
        rows: &'r [Row],
    ) -> (Vec<Extra>, Vec<&'r Row>) {
        let sweep = self.sweep();
        let entry = &sweep.schedule_grids[run];
        let swept = swept_axes(&entry.grid, &sweep.base_setting());
        let sensitivity_axes = self.sensitivity_axes(&swept);
        let extras = extra_settings(&entry.grid, &swept, &sensitivity_axes);
        (extras, self.rows_of(plan, run, rows))
    }

    /// The summary of plan `plan` under schedule entry `run`, from that entry's rows among `rows`
    /// and the extra settings it evaluates.
    fn summarize_entry(
        &self,
        plan: usize,
        run: usize,
        rows: &[Row],
        on_evaluated: &(dyn Fn() + Sync),
    ) -> Entry {
        let sweep = self.sweep();
        let entry = &sweep.schedule_grids[run];
        let base_total = self.base_total_s(plan, run);
        let base_margins = self.base_margins(plan, run);
        let swept = swept_axes(&entry.grid, &sweep.base_setting());
        let sensitivity_axes = self.sensitivity_axes(&swept);
        let (extras, mine) = self.entry_extras(plan, run, rows);
        let extras = self.evaluate_extras(
            plan,
            entry.schedule,
            extras,
            base_total,
            &mine,
            on_evaluated,
        );
        let feasible = feasible_points(&mine);
        let target_total_s = base_total.map(|b| sweep.target.total_s(b));
        let cheapest = target_total_s.zip(base_total).and_then(|(target, b)| {
            let candidates = self.change_candidates(&feasible, &extras, base_total);
            self.cheapest(&candidates, target, b)
        });
        Entry {
            plan: sweep.plans[plan].label.clone(),
            schedule: entry.schedule,
            rows: mine.len(),
            feasible: feasible.len(),
            base_total_s: base_total,
            fastest: self.fastest(&feasible),
            profiles: swept
                .iter()
                .map(|&axis| axis_totals(axis, &extras, base_total))
                .collect(),
            sensitivity: sensitivity_axes
                .iter()
                .map(|&axis| self.sensitivity(axis, &extras, (base_total, base_margins)))
                .collect(),
            target_total_s,
            cheapest,
        }
    }

    /// The axes whose sensitivity the summary reports: J, A, V and the swept ones, each with a
    /// positive base value (the finite differences scale it).
    fn sensitivity_axes(&self, swept: &[Axis]) -> Vec<Axis> {
        Axis::ALL
            .into_iter()
            .filter(|&a| matches!(a, Axis::Jerk | Axis::Accel | Axis::Speed) || swept.contains(&a))
            .filter(|&a| self.sweep().base_value(a).is_some_and(|b| b > 0.0))
            .collect()
    }

    /// The setting of an extra: the base machine with its one limit changed.
    fn extra_setting(&self, extra: Extra) -> Setting {
        let sweep = self.sweep();
        let base = sweep.base_setting();
        match extra {
            Extra::AxisValue { axis, value } => base.with(axis, value),
            Extra::Nudge { axis, up } => {
                // Nudged axes have a positive base value ([`Evaluator::sensitivity_axes`]).
                let b = sweep.base_value(axis).unwrap_or(1.0);
                let (lo, hi) = nudge_values(axis, b);
                base.with(axis, if up { hi } else { lo })
            }
        }
    }

    /// The totals of `extras` for a plan under a schedule: taken from the entry's grid rows
    /// (`rows`) or the base machine where they hold the setting (the same simulation), the others
    /// simulated on the current rayon pool.
    fn evaluate_extras(
        &self,
        plan: usize,
        schedule: RunMode,
        extras: Vec<Extra>,
        base_total: Option<f64>,
        rows: &[&Row],
        on_evaluated: &(dyn Fn() + Sync),
    ) -> ExtraTotals {
        let base = self.sweep().base_setting();
        let done: Vec<(Option<f64>, Option<Margins>)> = extras
            .par_iter()
            .map(|&extra| {
                let setting = self.extra_setting(extra);
                if let Some(known) = known_total(&setting, &base, base_total, rows) {
                    return (known, None);
                }
                // A gantry limit's nudges with their peak use of it (the sensitivity's law).
                let outcome = match extra {
                    Extra::Nudge { axis, .. } if axis.is_gantry_limit() => {
                        self.simulate_measured(plan, schedule, &setting, base_total)
                            .1
                    }
                    _ => self.simulate(plan, schedule, &setting, base_total).1,
                };
                on_evaluated();
                (outcome.map(|o| o.total_s), outcome.and_then(|o| o.margins))
            })
            .collect();
        let (totals, margins): (Vec<_>, Vec<_>) = done.into_iter().unzip();
        ExtraTotals(extras.into_iter().zip(totals).collect(), margins)
    }

    /// The sensitivity of the total to `axis` at the base machine, from its nudges; no effect when
    /// every value of it evaluated (nudges, base, profile) gives the same feasible total.
    fn sensitivity(
        &self,
        axis: Axis,
        extras: &ExtraTotals,
        (base_total, base_margins): (Option<f64>, Option<Margins>),
    ) -> Sensitivity {
        let b = self.sweep().base_value(axis).unwrap_or(f64::NAN);
        let (lo, hi) = nudge_values(axis, b);
        let (mut up, mut down) = (extras.nudged(axis, true), extras.nudged(axis, false));
        let mut base_total = base_total;
        if axis.is_gantry_limit() {
            // Each of the three settings gets the shortest delivery known to be feasible there.
            let found = [
                (lo, down, extras.nudged_margins(axis, false)),
                (b, base_total, base_margins),
                (hi, up, extras.nudged_margins(axis, true)),
            ]
            .map(|(at, total, m)| Found {
                at,
                total_s: total,
                peak: m.and_then(|m| peak_use(axis, &m)).map(|u| u * at),
            });
            down = best_known_at(lo, &found);
            base_total = best_known_at(b, &found);
            up = best_known_at(hi, &found);
        }
        let diff = up.zip(down).map(|(p, m)| p - m);
        // Every value of this limit evaluated with the others at the base machine.
        let mut evaluated = vec![(lo, down), (b, base_total), (hi, up)];
        evaluated.extend(extras.along(axis));
        let (evaluated_min, evaluated_max) = min_max(evaluated.iter().map(|e| e.0));
        // The change per unit of ln L over the span evaluated and for +10 %: (T(1.1 L) − T(L / 1.1))
        // / 2 for ±10 %; for whole numbers, the difference across L ± 1 scaled to 10 %.
        let (per_ln, per_10) = if axis.is_whole() {
            let span = (hi / lo).ln();
            let per_ln = diff.filter(|_| span > 0.0).map(|d| d / span);
            (per_ln, per_ln.map(|s| s * FD_FACTOR.ln()))
        } else {
            (
                diff.map(|d| d / (2.0 * FD_FACTOR.ln())),
                diff.map(|d| d / 2.0),
            )
        };
        Sensitivity {
            axis,
            base_value: b,
            s_per_ln: per_ln,
            s_per_10_percent: per_10,
            no_effect: all_feasible_and_equal(evaluated.iter().map(|e| e.1)),
            evaluated_min,
            evaluated_max,
        }
    }

    /// The rows of plan `plan` under schedule entry `run` among `rows`.
    fn rows_of<'r>(&self, plan: usize, run: usize, rows: &'r [Row]) -> Vec<&'r Row> {
        rows.iter()
            .filter(|row| {
                let (p, r, _) = self.combination(row.index);
                p == plan && r == run
            })
            .collect()
    }

    /// The settings the cheapest change is picked from: the feasible grid rows, then the
    /// feasible profile points.
    fn change_candidates(
        &self,
        feasible: &[Point],
        extras: &ExtraTotals,
        base_total: Option<f64>,
    ) -> Vec<Point> {
        let profiled = extras
            .0
            .iter()
            .filter_map(|&(extra, total)| match (extra, total) {
                (Extra::AxisValue { .. }, Some(total_s)) => Some(Point {
                    index: None,
                    setting: self.extra_setting(extra),
                    total_s,
                    speedup: speedup(base_total, Some(total_s)),
                }),
                _ => None,
            });
        feasible.iter().copied().chain(profiled).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_setting_takes_the_shortest_delivery_feasible_there() {
        let f = |at, total: f64, peak| Found {
            at,
            total_s: Some(total),
            peak,
        };
        // A limit nobody uses past 0.4: all three settings share the shortest delivery.
        let unused = [
            f(0.9, 101.0, Some(0.4)),
            f(1.0, 100.0, Some(0.4)),
            f(1.1, 100.5, None),
        ];
        for y in [0.9, 1.0, 1.1] {
            assert_eq!(best_known_at(y, &unused), Some(100.0));
        }
        // A binding limit: the lower setting cannot borrow the base's delivery (it uses 1.0).
        let binding = [
            f(0.9, 110.0, Some(0.9)),
            f(1.0, 100.0, Some(1.0)),
            f(1.1, 102.0, Some(1.1)),
        ];
        assert_eq!(best_known_at(0.9, &binding), Some(110.0));
        assert_eq!(best_known_at(1.0, &binding), Some(100.0));
        // The higher setting came out longer (a solver's other local optimum): it takes the base's.
        assert_eq!(best_known_at(1.1, &binding), Some(100.0));
        // An infeasible setting's total is not a delivery.
        let none = [Found {
            at: 0.9,
            total_s: None,
            peak: None,
        }];
        assert_eq!(best_known_at(1.1, &none), None);
    }

    #[test]
    fn long_axes_are_profiled_at_spread_positions() {
        assert_eq!(profile_positions(5).collect::<Vec<_>>(), [0, 1, 2, 3, 4]);
        let n = PROFILE_MAX_POINTS;
        assert!(profile_positions(n).eq(0..n));
        for n in [n + 1, 3 * n + 7, 10_000_000, usize::MAX] {
            let p: Vec<usize> = profile_positions(n).collect();
            assert_eq!(p.len(), PROFILE_MAX_POINTS);
            assert_eq!((p[0], p[p.len() - 1]), (0, n - 1));
            assert!(p.windows(2).all(|w| w[0] < w[1]), "{n}");
        }
    }
}
