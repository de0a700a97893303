//! The statistics of the fits: medians, robust spreads, the lowest cluster of a set of gaps, and
//! the bootstrap behind every timing's interval.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::types::*;

/// The median (the mean of the middle two for an even count); sorts `v`.
pub(crate) fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

pub(crate) fn mad_sd(v: &[f64], centre: f64) -> f64 {
    let mut dev: Vec<f64> = v.iter().map(|x| (x - centre).abs()).collect();
    1.4826 * median(&mut dev)
}

/// The lowest cluster of `residuals` (gaps less a model, or the gaps themselves): from the
/// median of the lowest tenth, a mean shift (Gaussian kernel, bandwidth 3 % of that start, at
/// least `floor_sd`, the time resolution) climbs to the nearest peak of the values' density;
/// the spread is 1.4826 × the median distance below the peak (which the gaps the gantry
/// lengthened do not reach); the cluster holds the values within three spreads of the peak.
pub fn lowest_cluster(residuals: &[f64], floor_sd: f64) -> Option<Cluster> {
    if residuals.is_empty() {
        return None;
    }
    let mut sorted = residuals.to_vec();
    sorted.sort_by(f64::total_cmp);
    let k0 = (sorted.len() / 10).max(3).min(sorted.len());
    let mut centre = median(&mut sorted[..k0].to_vec());
    let h = (0.03 * centre.abs()).max(floor_sd).max(1e-9);
    for _ in 0..500 {
        let (mut sw, mut swx) = (0.0, 0.0);
        for x in &sorted {
            let w = (-0.5 * ((x - centre) / h).powi(2)).exp();
            sw += w;
            swx += w * x;
        }
        let next = if sw > 0.0 { swx / sw } else { centre };
        let settled = (next - centre).abs() <= 1e-12 * centre.abs().max(1.0);
        centre = next;
        if settled {
            break;
        }
    }
    let mut below: Vec<f64> = sorted
        .iter()
        .filter(|x| **x < centre)
        .map(|x| centre - x)
        .collect();
    let sd = match below.len() {
        0 | 1 => floor_sd,
        _ => (1.4826 * median(&mut below)).max(floor_sd),
    };
    let count = sorted
        .iter()
        .filter(|x| (**x - centre).abs() <= 3.0 * sd)
        .count();
    Some(Cluster { centre, sd, count })
}

/// Percentile interval (2.5 %, 97.5 %) of a statistic over bootstrap resamples of `n` items.
pub(super) fn bootstrap(
    n: usize,
    seed: u64,
    stat: &dyn Fn(&[usize]) -> Option<f64>,
) -> Option<[f64; 2]> {
    if n < 2 {
        return None;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut values: Vec<f64> = (0..BOOTSTRAP_DRAWS)
        .filter_map(|_| {
            let idx: Vec<usize> = (0..n).map(|_| rng.random_range(0..n)).collect();
            stat(&idx).filter(|x| x.is_finite())
        })
        .collect();
    if values.len() < BOOTSTRAP_DRAWS / 2 {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let at = |q: f64| values[((values.len() - 1) as f64 * q).round() as usize];
    Some([at(0.025), at(0.975)])
}

/// The bracket (in the logarithm) the one-at-a-time fits by the model (J, each ELST) stop at:
/// 0.2 %, a start for the joint fit ([`crate::joint::refine_jointly`]), which refines them
/// together; golden sections to finer brackets cost a simulation per 0.48 of a bracket's log.
pub(super) const SEED_TOLERANCE: f64 = 2e-3;
