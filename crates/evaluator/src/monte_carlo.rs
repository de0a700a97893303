//! Monte Carlo of one plan's delivery time: the machine's timing spreads (from `arcsim
//! calibrate`) drawn per switch and per layer, each draw simulated, the totals' percentiles.

use arcsim_plan::{ArcPlan, FitUncertainty, Machine, ResolvedArc, TimingSpread};
use arcsim_planner::Limits;
use arcsim_sequencer::{machine_limits, simulate_resolved, Options, SequenceError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use rayon::prelude::*;
use serde::Serialize;

/// Most draws one Monte Carlo may ask for.
pub const MAX_DRAWS: usize = 100_000;

/// The spread of a plan's total delivery time over the draws.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MonteCarlo {
    /// Number of draws.
    pub draws: usize,
    /// Seed of the first draw (draw `k` uses `seed + k`).
    pub seed: u64,
    /// The spreads drawn.
    pub spread: TimingSpread,
    /// 5th percentile of the total, s.
    pub p5_s: f64,
    /// Median of the total, s.
    pub p50_s: f64,
    /// 95th percentile of the total, s.
    pub p95_s: f64,
    /// Mean of the total, s.
    pub mean_s: f64,
    /// Standard deviation of the total, s.
    pub sd_s: f64,
    /// Every draw's total, s, in draw order.
    pub totals_s: Vec<f64>,
}

/// Percentile `q` (0–1) of sorted values, linearly interpolated.
fn percentile(sorted: &[f64], q: f64) -> f64 {
    let x = q * (sorted.len() - 1) as f64;
    let (i, f) = (x.floor() as usize, x.fract());
    let next = sorted.get(i + 1).copied().unwrap_or(sorted[i]);
    sorted[i] + f * (next - sorted[i])
}

/// What a Monte Carlo of a calibrated machine draws, and which part of the total's spread each
/// source makes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MachineMonteCarlo {
    /// Both sources drawn together: the total's percentiles (its fields inlined in JSON).
    #[serde(flatten)]
    pub both: MonteCarlo,
    /// The timing spreads alone (per switch and layer), when the machine has them.
    pub spreads_only_sd_s: Option<f64>,
    /// The fitted values' uncertainty alone (one draw per delivery), when the machine has it.
    pub parameters_only_sd_s: Option<f64>,
    /// The fitted values' standard deviations drawn.
    pub uncertainty: Option<FitUncertainty>,
    /// `spreads`, `parameters`, or `one source` (only one is present).
    pub dominant: &'static str,
}

/// Draws of `plan` on `machine`: each draw moves the machine's fitted values once by their
/// uncertainty (`parameters`) and every switch and layer by the timing spreads (`spreads`).
fn draws_of(
    plan: &ArcPlan,
    machine: &Machine,
    opts: &Options,
    (draws, seed): (usize, u64),
    (spreads, parameters): (bool, bool),
    on_draw: &(dyn Fn() + Sync),
) -> Result<MonteCarlo, SequenceError> {
    let draws = draws.clamp(1, MAX_DRAWS);
    let opts = Options {
        build_timeline: false,
        servo_period_s: opts.servo_period_s.or(machine.servo_period_s),
        ..opts.clone()
    };
    let none = TimingSpread {
        elst_up_sd_s: 0.0,
        elst_down_sd_s: 0.0,
        elst_same_sd_s: 0.0,
        beam_time_sd_fraction: 0.0,
    };
    let spread = machine.spread.filter(|_| spreads).unwrap_or(none);
    let uncertainty = machine
        .uncertainty
        .filter(|_| parameters)
        .unwrap_or_default();
    let totals_s = (0..draws)
        .into_par_iter()
        .map(|k| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(k as u64));
            let drawn_machine = uncertainty.draw(machine, &mut || rng.sample(StandardNormal));
            let arcs = arcsim_plan::resolve(plan, &drawn_machine)?;
            let limits = machine_limits(&drawn_machine)?;
            let drawn = spread.draw(&arcs, &mut || rng.sample(StandardNormal));
            let total = simulate_resolved(&drawn, &limits, &opts).map(|d| d.total_s);
            on_draw();
            total
        })
        .collect::<Result<Vec<f64>, SequenceError>>()?;
    Ok(summarise(totals_s, seed, spread))
}

/// How many simulations [`machine_monte_carlo`] runs per draw: 3 when the machine has both
/// timing spreads and fitted values' uncertainty (together, then each alone), else 1.
pub fn monte_carlo_passes(machine: &Machine) -> usize {
    if machine.spread.is_some() && machine.uncertainty.is_some_and(|u| u.any()) {
        3
    } else {
        1
    }
}

/// The Monte Carlo of `plan` on a calibrated `machine`: its timing spreads and its fitted
/// values' uncertainty drawn together, and each alone (the same draws' seeds) to say which
/// makes more of the total's spread.
pub fn machine_monte_carlo(
    plan: &ArcPlan,
    machine: &Machine,
    opts: &Options,
    draws: usize,
    seed: u64,
) -> Result<MachineMonteCarlo, SequenceError> {
    machine_monte_carlo_observed(plan, machine, opts, (draws, seed), &|| {})
}

/// [`machine_monte_carlo`], calling `on_draw` after each simulation (of
/// [`monte_carlo_passes`] × `draws`), from any thread: a progress display's hook.
pub fn machine_monte_carlo_observed(
    plan: &ArcPlan,
    machine: &Machine,
    opts: &Options,
    (draws, seed): (usize, u64),
    on_draw: &(dyn Fn() + Sync),
) -> Result<MachineMonteCarlo, SequenceError> {
    let has_spreads = machine.spread.is_some();
    let has_parameters = machine.uncertainty.is_some_and(|u| u.any());
    let both = draws_of(plan, machine, opts, (draws, seed), (true, true), on_draw)?;
    let (spreads_only_sd_s, parameters_only_sd_s, dominant) = if has_spreads && has_parameters {
        let s = draws_of(plan, machine, opts, (draws, seed), (true, false), on_draw)?.sd_s;
        let p = draws_of(plan, machine, opts, (draws, seed), (false, true), on_draw)?.sd_s;
        (
            Some(s),
            Some(p),
            if p > s { "parameters" } else { "spreads" },
        )
    } else {
        (None, None, "one source")
    };
    Ok(MachineMonteCarlo {
        both,
        spreads_only_sd_s,
        parameters_only_sd_s,
        uncertainty: machine.uncertainty.filter(|_| has_parameters),
        dominant,
    })
}

/// Simulates `draws` (1 to [`MAX_DRAWS`]) deliveries of `arcs`, each with the switch and beam
/// times drawn from `spread` (seeded: the same for any thread count), on the current rayon pool.
pub fn monte_carlo(
    arcs: &[ResolvedArc],
    limits: &Limits,
    opts: &Options,
    spread: &TimingSpread,
    draws: usize,
    seed: u64,
) -> Result<MonteCarlo, SequenceError> {
    let draws = draws.clamp(1, MAX_DRAWS);
    let opts = Options {
        build_timeline: false,
        ..opts.clone()
    };
    let totals_s = (0..draws)
        .into_par_iter()
        .map(|k| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(k as u64));
            let drawn = spread.draw(arcs, &mut || rng.sample(StandardNormal));
            simulate_resolved(&drawn, limits, &opts).map(|d| d.total_s)
        })
        .collect::<Result<Vec<f64>, SequenceError>>()?;
    Ok(summarise(totals_s, seed, *spread))
}

/// Percentiles, mean and standard deviation of the draws' totals.
fn summarise(totals_s: Vec<f64>, seed: u64, spread: TimingSpread) -> MonteCarlo {
    let draws = totals_s.len();
    let mut sorted = totals_s.clone();
    sorted.sort_by(f64::total_cmp);
    let n = draws as f64;
    let mean_s = sorted.iter().sum::<f64>() / n;
    let var = sorted.iter().map(|x| (x - mean_s).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    MonteCarlo {
        draws,
        seed,
        spread,
        p5_s: percentile(&sorted, 0.05),
        p50_s: percentile(&sorted, 0.5),
        p95_s: percentile(&sorted, 0.95),
        mean_s,
        sd_s: var.sqrt(),
        totals_s,
    }
}
