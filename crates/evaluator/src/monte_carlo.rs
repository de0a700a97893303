//! Monte Carlo of one plan's delivery time: the machine's timing spreads (from `arcsim
//! calibrate`) drawn per switch and per layer, each draw simulated, the totals' percentiles.

use arcsim_plan::{ResolvedArc, TimingSpread};
use arcsim_planner::Limits;
use arcsim_sequencer::{simulate_resolved, Options, SequenceError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
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

/// A standard normal number (Box–Muller).
fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Percentile `q` (0–1) of sorted values, linearly interpolated.
fn percentile(sorted: &[f64], q: f64) -> f64 {
    let x = q * (sorted.len() - 1) as f64;
    let (i, f) = (x.floor() as usize, x.fract());
    let next = sorted.get(i + 1).copied().unwrap_or(sorted[i]);
    sorted[i] + f * (next - sorted[i])
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
            let drawn = spread.draw(arcs, &mut || normal(&mut rng));
            simulate_resolved(&drawn, limits, &opts).map(|d| d.total_s)
        })
        .collect::<Result<Vec<f64>, SequenceError>>()?;
    let mut sorted = totals_s.clone();
    sorted.sort_by(f64::total_cmp);
    let n = draws as f64;
    let mean_s = sorted.iter().sum::<f64>() / n;
    let var = sorted.iter().map(|x| (x - mean_s).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    Ok(MonteCarlo {
        draws,
        seed,
        spread: *spread,
        p5_s: percentile(&sorted, 0.05),
        p50_s: percentile(&sorted, 0.5),
        p95_s: percentile(&sorted, 0.95),
        mean_s,
        sd_s: var.sqrt(),
        totals_s,
    })
}
