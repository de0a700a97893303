//! The gantry's speed, acceleration and jerk observed in a log's angle trace.
//!
//! An encoder's angle noise (0.01° at 10 ms is 1.4 deg/s in a plain difference) hides the
//! derivatives, so they come from local polynomial fits by least squares over a window of
//! [`WINDOW_S`] centred on each sample (quadratic for speed and acceleration, cubic for jerk),
//! which also estimate the noise. A limit shows as a plateau: the gantry holds it. The
//! *plateau level* of a quantity is the median of the fitted values within four noise standard
//! deviations of the largest one (two for jerk), and the time spent there says whether the limit
//! was reached at all: a top speed held less than [`HOLD_SPEED_S`] is a peak, not the limit.
//! A fit averages over its window, so a plateau level is a lower bound of the limit when the
//! limit is not held. Jerk phases are often shorter than the window, so the jerk limit is read
//! from the acceleration instead ([`jerk_from_reversals`]): how fast it turns from one plateau
//! to the other, with the window's averaging undone.

use serde::Serialize;

use crate::DeliveryLog;

/// Width of the local fits' window, s.
pub const WINDOW_S: f64 = 2.0;

/// A top speed counts as the speed limit only when held this long in all, s.
pub const HOLD_SPEED_S: f64 = 1.0;

/// A top acceleration or deceleration counts as a limit only when held this long, s.
pub const HOLD_ACCEL_S: f64 = 0.5;

/// A top jerk counts as the limit only when held this long, s (jerk phases are short).
pub const HOLD_JERK_S: f64 = 0.2;

/// Reversals of the acceleration needed to read the jerk from them.
pub const MIN_REVERSALS: usize = 3;

/// Most fit centres per log (longer logs are fitted at every k-th sample).
const MAX_CENTRES: usize = 400_000;

/// One quantity's plateau in a trace: its level, how long it is held and how well it is known.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Plateau {
    /// The plateau level (deg/s, deg/s² or deg/s³).
    pub level: f64,
    /// The largest fitted value (same unit).
    pub peak: f64,
    /// Time the fitted value spends on the plateau, s.
    pub held_s: f64,
    /// Standard deviation of one fitted value from the angle noise (same unit).
    pub fit_sd: f64,
    /// 95 % interval of the level: ±1.96 fit_sd over the independent windows on the plateau.
    pub interval: [f64; 2],
    /// Whether it is held long enough to be the machine's limit.
    pub reached: bool,
}

/// What a log's angle trace shows of the gantry's motion.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ObservedKinematics {
    /// Width of the fits' window, s.
    pub window_s: f64,
    /// Standard deviation of the angle noise (residuals of the fits), degrees.
    pub angle_noise_deg: f64,
    /// Speed (magnitude).
    pub speed: Option<Plateau>,
    /// Acceleration along the direction of travel.
    pub accel: Option<Plateau>,
    /// Deceleration (acceleration against the direction of travel, as a magnitude).
    pub decel: Option<Plateau>,
    /// Jerk (magnitude) read directly from the cubic fits: a lower bound where jerk phases are
    /// shorter than the window, never taken as the limit itself.
    pub jerk: Option<Plateau>,
    /// The jerk from the acceleration's reversals between its plateaus ([`jerk_from_reversals`]):
    /// `reached` with at least [`MIN_REVERSALS`] of them.
    pub jerk_reversals: Option<Plateau>,
}

/// Fitted values at the fit centres: `(speed, accel, jerk)` and their standard deviations per
/// unit noise, and the time between centres.
#[derive(Debug, Default, Clone)]
pub struct Trace {
    /// Time of each centre, s (log time).
    pub t_s: Vec<f64>,
    /// (speed deg/s, acceleration deg/s², jerk deg/s³) at each centre.
    pub values: Vec<[f64; 3]>,
    /// Time each centre stands for, s.
    pub dt: Vec<f64>,
    /// Residual standard deviation of the angles, degrees.
    pub noise_deg: f64,
    /// Standard deviation of (speed, accel, jerk) of one fit at unit angle noise.
    pub unit_sd: [f64; 3],
}

/// Logs sampled faster than this are averaged into bins of [`BIN_S`] before the local fits.
pub const BIN_BELOW_S: f64 = 0.005;

/// Bin width of fast logs, s: a 2 s window then holds 200 points whatever the log's rate, so the
/// fits cost the same per second of log (a 4 kHz per-spot record of a 300 s arc is 1.2M rows),
/// and a bin mean loses nothing a polynomial fit over 2 s would use.
pub const BIN_S: f64 = 0.01;

/// `(t, angle)` of a fast log averaged over bins of [`BIN_S`], and the mean samples per bin;
/// the samples themselves (and 1) otherwise.
fn binned(log: &DeliveryLog) -> (Vec<crate::LogSample>, f64) {
    let s = &log.samples;
    let n = s.len();
    if n < 3 || log.duration_s() / (n - 1) as f64 >= BIN_BELOW_S {
        return (s.clone(), 1.0);
    }
    let t0 = s[0].t_s;
    let mut out: Vec<crate::LogSample> =
        Vec::with_capacity((log.duration_s() / BIN_S) as usize + 2);
    let (mut key, mut count, mut st, mut sa) = (0i64, 0.0, 0.0, 0.0);
    let mut push = |count: f64, st: f64, sa: f64, proto: &crate::LogSample| {
        out.push(crate::LogSample {
            t_s: st / count,
            gantry_angle_deg: sa / count,
            ..*proto
        });
    };
    for (i, x) in s.iter().enumerate() {
        let k = ((x.t_s - t0) / BIN_S).floor() as i64;
        if i > 0 && k != key {
            push(count, st, sa, &s[i - 1]);
            (count, st, sa) = (0.0, 0.0, 0.0);
        }
        key = k;
        count += 1.0;
        st += x.t_s - t0;
        sa += x.gantry_angle_deg;
    }
    push(count, st, sa, &s[n - 1]);
    for b in &mut out {
        b.t_s += t0;
    }
    let per_bin = n as f64 / out.len() as f64;
    (out, per_bin)
}

/// Local fits of the log's angle trace (see the module documentation).
pub fn trace(log: &DeliveryLog) -> Trace {
    // A log of beam-on intervals has no angle trace between its edges.
    if log.edge_resolution_s.is_some() {
        return Trace::default();
    }
    let (samples, per_bin) = binned(log);
    let s = &samples;
    let h = WINDOW_S / 2.0;
    let Some((first, last)) = s.first().zip(s.last()) else {
        return Trace::default();
    };
    let stride = (s.len() / MAX_CENTRES).max(1);
    let mut out = Trace::default();
    let (mut rss, mut dof) = (0.0, 0.0);
    let mut unit = [0.0; 3];
    let (mut lo, mut hi) = (0, 0);
    for i in (0..s.len()).step_by(stride) {
        let tc = s[i].t_s;
        if tc - first.t_s < h || last.t_s - tc < h {
            continue;
        }
        while s[lo].t_s < tc - h {
            lo += 1;
        }
        while hi + 1 < s.len() && s[hi + 1].t_s <= tc + h {
            hi += 1;
        }
        let pts = || {
            s[lo..=hi]
                .iter()
                .map(|p| (p.t_s - tc, p.gantry_angle_deg - s[i].gantry_angle_deg))
        };
        let (Some(quad), Some(cubic)) = (local_fit::<3>(pts()), local_fit::<4>(pts())) else {
            continue;
        };
        rss += cubic.rss;
        dof += cubic.n - 4.0;
        unit = [
            quad.unit_sd[1],
            2.0 * quad.unit_sd[2],
            6.0 * cubic.unit_sd[3],
        ];
        out.values
            .push([quad.coef[1], 2.0 * quad.coef[2], 6.0 * cubic.coef[3]]);
        let dt = s.get(i + stride).map_or(0.0, |n| n.t_s - tc);
        out.dt.push(dt);
        out.t_s.push(tc);
    }
    // A bin mean's noise is the samples' over the root of their count.
    out.noise_deg = if dof > 0.0 {
        (rss / dof * per_bin).sqrt()
    } else {
        0.0
    };
    // The unit standard deviations are per unit noise of a fitted point (a bin): in units of a
    // sample's noise, a bin's is smaller by the root of its count.
    out.unit_sd = unit.map(|u| u / per_bin.sqrt());
    out
}

/// A least-squares polynomial fit of `M - 1`-th degree.
struct Fit<const M: usize> {
    coef: [f64; M],
    /// sqrt of the diagonal of the inverse normal matrix.
    unit_sd: [f64; M],
    rss: f64,
    n: f64,
}

fn local_fit<const M: usize>(pts: impl Iterator<Item = (f64, f64)>) -> Option<Fit<M>> {
    let mut xtx = [[0.0; M]; M];
    let mut xty = [0.0; M];
    let (mut yy, mut n) = (0.0, 0.0);
    for (x, y) in pts {
        let mut p = [1.0; M];
        for k in 1..M {
            p[k] = p[k - 1] * x;
        }
        for a in 0..M {
            xty[a] += p[a] * y;
            for b in 0..M {
                xtx[a][b] += p[a] * p[b];
            }
        }
        yy += y * y;
        n += 1.0;
    }
    if n < (M + 2) as f64 {
        return None;
    }
    let inv = invert(xtx)?;
    let mut coef = [0.0; M];
    for a in 0..M {
        coef[a] = (0..M).map(|b| inv[a][b] * xty[b]).sum();
    }
    let fitted: f64 = (0..M).map(|a| coef[a] * xty[a]).sum();
    let mut unit_sd = [0.0; M];
    for a in 0..M {
        unit_sd[a] = inv[a][a].max(0.0).sqrt();
    }
    Some(Fit {
        coef,
        unit_sd,
        rss: (yy - fitted).max(0.0),
        n,
    })
}

/// Inverse of a small symmetric positive-definite matrix (Gauss–Jordan with pivoting).
fn invert<const M: usize>(mut a: [[f64; M]; M]) -> Option<[[f64; M]; M]> {
    let mut inv = [[0.0; M]; M];
    for (k, row) in inv.iter_mut().enumerate() {
        row[k] = 1.0;
    }
    for c in 0..M {
        let p = (c..M).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        if a[p][c].abs() < 1e-300 {
            return None;
        }
        a.swap(c, p);
        inv.swap(c, p);
        let d = a[c][c];
        for k in 0..M {
            a[c][k] /= d;
            inv[c][k] /= d;
        }
        for r in 0..M {
            if r != c {
                let f = a[r][c];
                for k in 0..M {
                    a[r][k] -= f * a[c][k];
                    inv[r][k] -= f * inv[c][k];
                }
            }
        }
    }
    Some(inv)
}

/// The plateau of `values` (each standing for `dt` seconds) with one value's noise `sd`: the
/// median of the values within `band_sd` noise deviations of the largest; `None` without values.
pub fn plateau(values: &[(f64, f64)], sd: f64, band_sd: f64, hold_s: f64) -> Option<Plateau> {
    let peak = values.iter().map(|v| v.0).fold(f64::NAN, f64::max);
    if !peak.is_finite() {
        return None;
    }
    // A noiseless trace still has a band: 1 % of the peak.
    let floor = peak - (band_sd * sd).max(0.01 * peak.abs());
    let mut band: Vec<(f64, f64)> = values.iter().copied().filter(|v| v.0 >= floor).collect();
    band.sort_by(|a, b| a.0.total_cmp(&b.0));
    let level = band[band.len() / 2].0;
    let held_s: f64 = band.iter().map(|v| v.1).sum();
    let independent = (held_s / WINDOW_S).max(1.0);
    let half = 1.96 * sd / independent.sqrt();
    Some(Plateau {
        level,
        peak,
        held_s,
        fit_sd: sd,
        interval: [level - half, level + half],
        reached: held_s >= hold_s,
    })
}

/// The plateaus of one or more traces pooled (a calibration's logs).
pub fn observe(traces: &[Trace]) -> ObservedKinematics {
    let noise = {
        let n = traces
            .iter()
            .filter(|t| !t.values.is_empty())
            .count()
            .max(1) as f64;
        traces.iter().map(|t| t.noise_deg).sum::<f64>() / n
    };
    let unit = traces
        .iter()
        .find(|t| !t.values.is_empty())
        .map_or([0.0; 3], |t| t.unit_sd);
    let pooled = |pick: &dyn Fn([f64; 3]) -> Option<f64>| -> Vec<(f64, f64)> {
        traces
            .iter()
            .flat_map(|t| t.values.iter().zip(&t.dt))
            .filter_map(|(v, dt)| pick(*v).map(|x| (x, *dt)))
            .collect()
    };
    // Travel direction: the sign of the speed; at (near) rest the acceleration has none.
    let moving = |v: [f64; 3]| v[0].abs() > 1e-3;
    let speed = pooled(&|v| Some(v[0].abs()));
    let accel = pooled(&|v| moving(v).then(|| v[1] * v[0].signum()).filter(|a| *a > 0.0));
    let decel = pooled(&|v| {
        moving(v)
            .then(|| -v[1] * v[0].signum())
            .filter(|a| *a > 0.0)
    });
    let jerk = pooled(&|v| Some(v[2].abs()));
    let accel = plateau(&accel, noise * unit[1], 4.0, HOLD_ACCEL_S);
    let decel = plateau(&decel, noise * unit[1], 4.0, HOLD_ACCEL_S);
    let mut jerk = plateau(&jerk, noise * unit[2], 2.0, HOLD_JERK_S);
    if let Some(j) = jerk.as_mut() {
        j.reached = false;
    }
    // Reversals need both plateaus resolved: the level they run between.
    let level = match (accel, decel) {
        (Some(a), Some(d)) if a.reached && d.reached => Some(a.level.min(d.level)),
        _ => None,
    };
    ObservedKinematics {
        window_s: WINDOW_S,
        angle_noise_deg: noise,
        speed: plateau(&speed, noise * unit[0], 4.0, HOLD_SPEED_S),
        accel,
        decel,
        jerk,
        jerk_reversals: level.and_then(|l| jerk_from_reversals(traces, l)),
    }
}

/// Fraction of a ramp's true slope that the local quadratic fits show between its half-way
/// points: a ramp of `tau_s` from -1 to +1, averaged by the fits' kernel (the second-derivative
/// kernel of a least-squares quadratic over the window, 15/16 (1 - u²)² per half-width).
fn ramp_slope_factor(tau_s: f64) -> f64 {
    let h = WINDOW_S / 2.0;
    let ramp = |t: f64| (2.0 * t / tau_s).clamp(-1.0, 1.0);
    let fitted = |t: f64| {
        let n = 400;
        let du = 2.0 / n as f64;
        (0..n)
            .map(|k| {
                let u = -1.0 + (k as f64 + 0.5) * du;
                15.0 / 16.0 * (1.0 - u * u).powi(2) * ramp(t - u * h) * du
            })
            .sum::<f64>()
    };
    // The fitted ramp is odd and increasing: bisect for where it is 1/2.
    let (mut lo, mut hi) = (0.0, tau_s / 2.0 + h);
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if fitted(mid) < 0.5 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    // Measured slope: 1 over the time between the half-way points; true slope 2 / tau.
    (1.0 / (2.0 * lo)) / (2.0 / tau_s)
}

/// The jerk limit from the acceleration's reversals: every turn of the fitted acceleration from
/// one plateau to the other (from above 0.9 `level` to below -0.9 `level`, or back) gives its
/// slope between the half-way points ±`level`/2, with the fits' averaging undone
/// ([`ramp_slope_factor`], by fixed-point iteration); the median over the reversals within 25 %
/// of their 90th percentile (a slower turn is the gantry in no hurry, not its limit), `reached`
/// with [`MIN_REVERSALS`] of them.
pub fn jerk_from_reversals(traces: &[Trace], level: f64) -> Option<Plateau> {
    let mut found = Vec::new();
    for t in traces {
        let a: Vec<f64> = t.values.iter().map(|v| v[1]).collect();
        let mut from: Option<(usize, f64)> = None; // last index on a plateau, its sign
        for k in 0..a.len() {
            if a[k].abs() >= 0.9 * level {
                let sign = a[k].signum();
                if let Some((i, s)) = from.filter(|(_, s)| *s != sign) {
                    if let Some(slope) = half_way_slope(&t.t_s[i..=k], &a[i..=k], s * level) {
                        found.push(deblurred(slope, level));
                    }
                }
                from = Some((k, sign));
            }
        }
    }
    if found.is_empty() {
        return None;
    }
    found.sort_by(f64::total_cmp);
    // Turns slower than the limit (the gantry in no hurry) are left out: the median of those
    // within 25 % of the 90th percentile.
    let q90 = found[((found.len() - 1) as f64 * 0.9).round() as usize];
    found.retain(|x| *x >= 0.75 * q90);
    let n = found.len() as f64;
    let level_j = found[found.len() / 2];
    let mean = found.iter().sum::<f64>() / n;
    let sd = (found.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();
    let half = 1.96 * 1.2533 * sd / n.sqrt();
    Some(Plateau {
        level: level_j,
        peak: found[found.len() - 1],
        held_s: n * 2.0 * level / level_j.max(1e-12),
        fit_sd: sd,
        interval: [level_j - half, level_j + half],
        reached: found.len() >= MIN_REVERSALS,
    })
}

/// The slope of `a` (times `t`) between its crossings of `+start/2` and `-start/2`, going from
/// `start` to `-start`; `None` if it does not cross both.
fn half_way_slope(t: &[f64], a: &[f64], start: f64) -> Option<f64> {
    let cross = |target: f64| -> Option<f64> {
        (1..a.len()).find_map(|k| {
            let (a0, a1) = (a[k - 1] - target, a[k] - target);
            (a0 * start > 0.0 && a1 * start <= 0.0)
                .then(|| t[k - 1] + (t[k] - t[k - 1]) * a0 / (a0 - a1))
        })
    };
    let (t1, t2) = (cross(start / 2.0)?, cross(-start / 2.0)?);
    (t2 > t1).then(|| start.abs() / (t2 - t1))
}

/// The jerk whose ramp between ±`level`, averaged by the fits, shows `slope`.
fn deblurred(slope: f64, level: f64) -> f64 {
    let mut j = slope;
    for _ in 0..30 {
        j = slope / ramp_slope_factor(2.0 * level / j);
    }
    j
}
