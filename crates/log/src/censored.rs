//! The ELST from gaps the gantry may have lengthened: a censored (Tobit) fit. Under a
//! constant-speed controller a switch's logged gap is max(ELST + jitter, move) with the move's
//! own minimum time known from the planner, so a gap at its move's time only says the ELST (with
//! its jitter) was no longer; taking only the gaps above their moves would keep the switches whose
//! jitter happened to be large, and read the ELST long.

/// A normal law fitted to censored observations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CensoredFit {
    /// The mean (the ELST), s.
    pub mean: f64,
    /// The standard deviation of one switch (the jitter, without the log's resolution), s.
    pub sd: f64,
    /// Gaps longer than their move: the ELST itself, seen.
    pub seen: usize,
    /// Gaps at their move's time: the ELST was no longer.
    pub censored: usize,
}

/// ln Φ(x), accurate far into the lower tail (the complementary error function in log form,
/// Numerical Recipes' Chebyshev fit, relative error below 1.2e-7).
fn ln_normal_cdf(x: f64) -> f64 {
    let z = -x / std::f64::consts::SQRT_2;
    let ln_erfc_pos = |z: f64| {
        let t = 1.0 / (1.0 + 0.5 * z);
        let poly = -z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87
                                        + t * (-0.822_152_23 + t * 0.170_872_77))))))));
        t.ln() + poly
    };
    // Φ(x) = erfc(z) / 2.
    if z >= 0.0 {
        ln_erfc_pos(z) - std::f64::consts::LN_2
    } else {
        (1.0 - 0.5 * ln_erfc_pos(-z).exp()).ln()
    }
}

/// Log-likelihood of `(gap, move)` pairs under ELST ~ N(mean, sd²) seen through a clock of
/// resolution `res_sd`: a gap above its move by more than `cut` is a draw, the rest are censored.
fn log_likelihood(obs: &[(f64, f64)], mean: f64, sd: f64, res_sd: f64, cut: f64) -> f64 {
    let s = (sd * sd + res_sd * res_sd).sqrt();
    obs.iter()
        .map(|&(gap, mv)| {
            if gap > mv + cut {
                let u = (gap - mean) / s;
                -0.5 * u * u - s.ln()
            } else {
                ln_normal_cdf((mv + cut - mean) / s)
            }
        })
        .sum()
}

/// Golden-section maximum of `f` on `[a, b]`.
fn argmax(mut a: f64, mut b: f64, f: &dyn Fn(f64) -> f64) -> f64 {
    let phi = 0.5 * (5f64.sqrt() - 1.0);
    let mut c = b - phi * (b - a);
    let mut d = a + phi * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..60 {
        if fc >= fd {
            (b, d, fd) = (d, c, fc);
            c = b - phi * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + phi * (b - a);
            fd = f(d);
        }
    }
    0.5 * (a + b)
}

/// The maximum-likelihood ELST and jitter of `(gap, move)` pairs (s), a gap counting as its
/// move's time when within 2 × `res_sd` of it; `None` with fewer than 3 gaps above their moves
/// (the ELST is then bounded, not seen).
pub(crate) fn fit(obs: &[(f64, f64)], res_sd: f64) -> Option<CensoredFit> {
    let cut = 2.0 * res_sd;
    let seen = obs.iter().filter(|(g, m)| *g > m + cut).count();
    if seen < 3 {
        return None;
    }
    let hi = obs.iter().map(|o| o.0).fold(0.0, f64::max);
    let floor = (1e-3 * hi).max(1e-6);
    let best_mean = |sd: f64| argmax(0.0, hi, &|m| log_likelihood(obs, m, sd, res_sd, cut));
    let ln_sd = argmax(floor.ln(), hi.max(floor * 10.0).ln(), &|x| {
        let sd = x.exp();
        log_likelihood(obs, best_mean(sd), sd, res_sd, cut)
    });
    let sd = ln_sd.exp();
    Some(CensoredFit {
        mean: best_mean(sd),
        sd,
        seen,
        censored: obs.len() - seen,
    })
}

/// 95 % interval of the fit's mean from the log-likelihood's curvature in the mean (the jitter
/// held at its estimate).
pub(crate) fn interval(obs: &[(f64, f64)], f: &CensoredFit, res_sd: f64) -> [f64; 2] {
    let cut = 2.0 * res_sd;
    let h = (1e-3 * f.mean.abs()).max(1e-5);
    let l = |m: f64| log_likelihood(obs, m, f.sd, res_sd, cut);
    let curvature = -(l(f.mean + h) + l(f.mean - h) - 2.0 * l(f.mean)) / (h * h);
    let half = if curvature > 0.0 {
        1.96 / curvature.sqrt()
    } else {
        f64::INFINITY
    };
    [(f.mean - half).max(0.0), f.mean + half]
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn ln_normal_cdf_matches_known_values() {
        for (x, p) in [
            (0.0, 0.5),
            (1.0, 0.841_344_746_068_542_9),
            (-1.0, 0.158_655_253_931_457_05),
            (-5.0, 2.866_515_718_791_939e-7),
            (3.0, 0.998_650_101_968_369_9),
        ] {
            let got = ln_normal_cdf(x).exp();
            assert!((got / p - 1.0).abs() < 1e-6, "Φ({x}) = {got}, expected {p}");
        }
    }

    /// Against the truth a naive median of the gaps above their moves misses: half the switches
    /// have moves near the ELST.
    #[test]
    fn recovers_an_elst_the_gantry_often_hides() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (elst, jitter) = (0.7, 0.021);
        let obs: Vec<(f64, f64)> = (0..400)
            .map(|k| {
                let normal = {
                    let (u1, u2): (f64, f64) = (1.0 - rng.random::<f64>(), rng.random::<f64>());
                    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
                };
                let mv = if k % 2 == 0 {
                    0.5
                } else {
                    0.69 + 0.0001 * k as f64
                };
                ((elst + jitter * normal).max(mv), mv)
            })
            .collect();
        let f = fit(&obs, 1e-4).expect("fit");
        assert!((f.mean / elst - 1.0).abs() < 0.01, "{f:?}");
        assert!((f.sd / jitter - 1.0).abs() < 0.2, "{f:?}");
        let mut above: Vec<f64> = obs.iter().filter(|(g, m)| g > m).map(|o| o.0).collect();
        above.sort_by(f64::total_cmp);
        assert!(
            above[above.len() / 2] > elst * 1.005,
            "the naive median is biased"
        );
    }
}
