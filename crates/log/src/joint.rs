//! Values fitted by the model one at a time ([`crate::transitions::fit_by_gaps`]) refined
//! together, with intervals that hold: each move's duration depends on J and on which ELST its
//! schedule stretches it to, so values fitted one by one each absorb the others' error, and a
//! misfit's curvature (one residual variance over every gap, the schedule's coupling taken as
//! information) reads their intervals narrow.

use arcsim_plan::Machine;
use arcsim_plan::TimingSpread;
use arcsim_sequencer::{machine_limits, simulate_resolved, Options};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use rayon::prelude::*;

use crate::calibrate::LoggedRun;
use crate::matching::LoggedLayer;
use crate::transitions::{gap_pairs, misfit_of, pairs_of, student_t95, Switches, H, ROBUST_CAP_S};

/// One value of a joint fit by the model: how to set it, its start and its range.
pub(crate) struct Param<'a> {
    pub set: &'a (dyn Fn(&mut Machine, f64) + Sync),
    pub start: f64,
    pub range: (f64, f64),
}

/// A value the gaps depend on that is fitted elsewhere (A, from the trace's plateaus): held at
/// its value, its standard deviation (in the logarithm) carried into the fitted values'.
pub(crate) struct Nuisance<'a> {
    pub set: &'a (dyn Fn(&mut Machine, f64) + Sync),
    pub value: f64,
    pub sd_ln: f64,
}

/// Values fitted jointly by the model, each with its 95 % interval and the gaps it moves.
pub(crate) struct JointFit {
    pub values: Vec<f64>,
    pub intervals: Vec<[f64; 2]>,
    pub moved: Vec<usize>,
}

/// The values of `params` (J and each ELST, fitted one at a time by [`fit_by_gaps`]) refined
/// together: Gauss–Newton over their logarithms on every beam-off gap, the Jacobian by central
/// differences (each move's duration depends on J and on which ELST its schedule stretches it
/// to, so values fitted one by one each absorb the others' error), a step taken only where it
/// lowers the robust misfit. The 95 % intervals are the wider of the logs' jitter replayed
/// ([`jitter_replay`], when `noise` is given: the fit's spread with the coupling through the
/// schedule) and the joint sandwich
/// (GᵀG)⁻¹ Gᵀdiag(r²)G (GᵀG)⁻¹ · n/(n − p) with Student's t on n − p degrees of freedom, n the
/// gaps any value moves; gaps beyond the robust cap are left out. The error of each `nuisance`
/// value (held, not fitted) is carried into the variances. `None` when a simulation fails
/// or the values are not separately determined (a singular GᵀG).
pub(crate) fn refine_jointly(
    machine: &Machine,
    params: &[Param],
    data: (&[LoggedRun], &[&[LoggedLayer]]),
    options: &Options,
    noise: Option<Noise>,
    nuisance: &[Nuisance],
) -> Option<JointFit> {
    let p = params.len();
    if p == 0 {
        return None;
    }
    let model = Model {
        machine,
        params,
        data,
        opts: Options {
            build_timeline: false,
            ..options.clone()
        },
    };
    let (theta, (centre, g)) = gauss_newton(&model)?;
    let normal = normal_equations(&centre, &g);
    let n = normal.used;
    if n <= p + 1 {
        return None;
    }
    let inv = invert(&normal.gtg)?;
    let lin = Linearised {
        centre: &centre,
        g: &g,
        inv: &inv,
    };
    // The gaps each value moves, and those it moves by at least half its most: the latter
    // carry it, and are its own degrees of freedom when fewer than the fit's.
    let count = |k: usize, fraction: f64| {
        let g_max = g[k].iter().map(|x| x.abs()).fold(0.0, f64::max);
        g[k].iter().filter(|x| x.abs() > fraction * g_max).count()
    };
    let moved: Vec<usize> = (0..p).map(|k| count(k, 1e-3)).collect();
    let carried: Vec<usize> = (0..p).map(|k| count(k, 0.5)).collect();
    let sandwich = joint_sandwich(&lin, &carried, n);
    // The logs' own jitter, replayed: its spread (with the coupling through the schedule) a
    // floor under the sandwich's.
    let spread = match noise {
        Some(noise) => jitter_replay(&model.machine_at(&theta), &lin, data, &model.opts, noise)?,
        None => vec![0.0; p],
    };
    let from_nuisance = nuisance_variances(&model, &theta, &lin, nuisance)?;
    let mut intervals = Vec::with_capacity(p);
    let mut values = Vec::with_capacity(p);
    for (k, q) in params.iter().enumerate() {
        let var = sandwich[k].max(spread[k]) + from_nuisance[k];
        let sd = var.max(0.0).sqrt().max(1e-9);
        let t95 = student_t95(((n - p).min(carried[k].max(2) - 1)) as f64);
        let clamp = |x: f64| x.exp().clamp(q.range.0, q.range.1);
        values.push(clamp(theta[k]));
        intervals.push([clamp(theta[k] - t95 * sd), clamp(theta[k] + t95 * sd)]);
    }
    Some(JointFit {
        values,
        intervals,
        moved,
    })
}

/// The machine and logs a joint fit simulates.
struct Model<'a> {
    machine: &'a Machine,
    params: &'a [Param<'a>],
    data: (&'a [LoggedRun], &'a [&'a [LoggedLayer]]),
    opts: Options,
}

impl Model<'_> {
    /// The machine with the values at the logarithms `theta`.
    fn machine_at(&self, theta: &[f64]) -> Machine {
        let mut m = self.machine.clone();
        for (q, t) in self.params.iter().zip(theta) {
            (q.set)(&mut m, t.exp().clamp(q.range.0, q.range.1));
        }
        m
    }

    /// Every (logged, simulated) beam-off gap with the values at `theta`.
    fn gaps(&self, theta: &[f64]) -> Option<Vec<(f64, f64)>> {
        self.gaps_of(&self.machine_at(theta))
    }

    fn gaps_of(&self, m: &Machine) -> Option<Vec<(f64, f64)>> {
        gap_pairs(m, &|_, _| {}, 0.0, self.data, Switches::All, &self.opts)
    }

    /// The gaps at `theta` and each value's column of derivatives (central differences), the
    /// 2p + 1 simulations in parallel (one log alone would leave a core idle).
    fn jacobian(&self, theta: &[f64]) -> Option<Linearisation> {
        let points: Vec<Vec<f64>> = std::iter::once(theta.to_vec())
            .chain((0..theta.len()).flat_map(|k| {
                [H, -H].map(|h| {
                    let mut t = theta.to_vec();
                    t[k] += h;
                    t
                })
            }))
            .collect();
        let gaps: Vec<Vec<(f64, f64)>> = points
            .par_iter()
            .map(|t| self.gaps(t))
            .collect::<Option<_>>()?;
        let (centre, shifted) = gaps.split_first()?;
        let columns = shifted
            .chunks(2)
            .map(|pair| central(centre, &pair[0], &pair[1]))
            .collect::<Option<_>>()?;
        Some((centre.clone(), columns))
    }
}

/// Each gap's derivative from its simulations a step `H` up and down.
fn central(centre: &[(f64, f64)], up: &[(f64, f64)], down: &[(f64, f64)]) -> Option<Vec<f64>> {
    if up.len() != centre.len() || down.len() != centre.len() {
        return None;
    }
    Some(
        up.iter()
            .zip(down)
            .map(|((_, a), (_, b))| (a - b) / (2.0 * H))
            .collect(),
    )
}

/// Up to three Gauss–Newton steps from the values' starts (each step clamped to 0.1 in the
/// logarithm, halved up to three times until the robust misfit falls; none kept otherwise),
/// with the gaps and the Jacobian at the values returned (computed once more only when the last
/// step was taken).
fn gauss_newton(model: &Model) -> Option<(Vec<f64>, Linearisation)> {
    let mut theta: Vec<f64> = model
        .params
        .iter()
        .map(|q| q.start.max(1e-9).ln())
        .collect();
    let (mut centre, mut g) = model.jacobian(&theta)?;
    let mut current = misfit_of(&centre).0;
    for _ in 0..3 {
        let normal = normal_equations(&centre, &g);
        let step = solve(&normal.gtg, &normal.gtr)?;
        if step.iter().all(|d| d.abs() < 1e-4) {
            break;
        }
        let mut accepted = false;
        let mut scale = 1.0;
        for _ in 0..3 {
            let trial: Vec<f64> = theta
                .iter()
                .zip(&step)
                .map(|(t, d)| t + (scale * d).clamp(-0.1, 0.1))
                .collect();
            let f = misfit_of(&model.gaps(&trial)?).0;
            if f < current {
                (theta, current, accepted) = (trial, f, true);
                break;
            }
            scale *= 0.5;
        }
        if !accepted {
            break;
        }
        (centre, g) = model.jacobian(&theta)?;
    }
    Some((theta, (centre, g)))
}

/// The joint sandwich's diagonal, (GᵀG)⁻¹ Σ rᵢ² gᵢgᵢᵀ (GᵀG)⁻¹, scaled by the larger of
/// n/(n − p) and m/(m − 1), m the gaps that carry the value.
fn joint_sandwich(lin: &Linearised, carried: &[usize], n: usize) -> Vec<f64> {
    let p = lin.g.len();
    let mut meat = vec![vec![0.0; p]; p];
    for (i, (l, s)) in lin.centre.iter().enumerate() {
        let r = l - s;
        if r.abs() >= ROBUST_CAP_S {
            continue;
        }
        for (a, row) in meat.iter_mut().enumerate() {
            for (b, x) in row.iter_mut().enumerate() {
                *x += r * r * lin.g[a][i] * lin.g[b][i];
            }
        }
    }
    (0..p)
        .map(|k| {
            let m = carried[k].max(2) as f64;
            (0..p)
                .flat_map(|a| (0..p).map(move |b| (a, b)))
                .map(|(a, b)| lin.inv[k][a] * meat[a][b] * lin.inv[b][k])
                .sum::<f64>()
                * (n as f64 / (n - p) as f64).max(m / (m - 1.0))
        })
        .collect()
}

/// What each held value's error adds to the fitted values' variances: it moves the fit by
/// (GᵀG)⁻¹Gᵀ g_ν per unit of its logarithm.
fn nuisance_variances(
    model: &Model,
    theta: &[f64],
    lin: &Linearised,
    nuisance: &[Nuisance],
) -> Option<Vec<f64>> {
    let p = lin.g.len();
    let mut out = vec![0.0; p];
    for nu in nuisance {
        // The held value touches none of the fitted ones (A, against J and the ELSTs).
        let gaps_at = |x: f64| {
            let mut m = model.machine_at(theta);
            (nu.set)(&mut m, x);
            model.gaps_of(&m)
        };
        let ln = nu.value.max(1e-12).ln();
        let g_nu = central(
            lin.centre,
            &gaps_at((ln + H).exp())?,
            &gaps_at((ln - H).exp())?,
        )?;
        let mut gt_gnu = vec![0.0; p];
        for (i, (l, s)) in lin.centre.iter().enumerate() {
            if (l - s).abs() >= ROBUST_CAP_S {
                continue;
            }
            for (acc, col) in gt_gnu.iter_mut().zip(lin.g) {
                *acc += col[i] * g_nu[i];
            }
        }
        for (k, row) in lin.inv.iter().enumerate() {
            let shift: f64 = row.iter().zip(&gt_gnu).map(|(a, b)| a * b).sum();
            out[k] += (shift * nu.sd_ln).powi(2);
        }
    }
    Some(out)
}

/// The logs' own noise, for [`jitter_replay`]: the measured spread of the switches and beam
/// times, and the standard deviation a log's resolution adds to a gap (s).
#[derive(Clone, Copy)]
pub(crate) struct Noise<'a> {
    pub spread: &'a TimingSpread,
    pub resolution_sd_s: f64,
}

/// One column per value: each gap's derivative in the value's logarithm.
type Columns = Vec<Vec<f64>>;

/// The (logged, simulated) gaps at some values and the Jacobian's columns there.
type Linearisation = (Vec<(f64, f64)>, Columns);

/// A joint fit linearised at its values: the (logged, simulated) gaps there, the Jacobian's
/// columns, and (GᵀG)⁻¹.
struct Linearised<'a> {
    centre: &'a [(f64, f64)],
    g: &'a [Vec<f64>],
    inv: &'a [Vec<f64>],
}

/// How many jittered deliveries [`jitter_replay`] draws.
const JITTER_REPLAYS: usize = 12;

/// A linearised parametric bootstrap of a joint fit by the model. The fitted machine delivers
/// each plan [`JITTER_REPLAYS`] times with each switch's ELST and each layer's beam time drawn
/// from the logs' measured spread (the schedule re-planned around them, as a real controller
/// does, which moves neighbouring gaps too) and each gap blurred by the log's resolution; one
/// Gauss–Newton step from the fit on each replay, δ = (GᵀG)⁻¹Gᵀ(y* − s), gives the fit's error
/// on data like the logs'; their variance is returned, per value, in the logarithm. (Their mean,
/// a bias, is not taken out: with a dozen replays it is mostly noise, and the fit's Jacobian
/// over a misfit with kinks makes it no better.)
fn jitter_replay(
    fitted: &Machine,
    &Linearised { centre, g, inv }: &Linearised,
    (runs, logged): (&[LoggedRun], &[&[LoggedLayer]]),
    opts: &Options,
    noise: Noise,
) -> Option<Vec<f64>> {
    let p = g.len();
    let limits = machine_limits(fitted).ok()?;
    let opts = &Options {
        servo_period_s: opts.servo_period_s.or(fitted.servo_period_s),
        ..opts.clone()
    };
    let arcs: Vec<_> = runs
        .iter()
        .map(|r| arcsim_plan::resolve(&r.plan, fitted).ok())
        .collect::<Option<_>>()?;
    let steps: Vec<Vec<f64>> = (0..JITTER_REPLAYS)
        .into_par_iter()
        .map(|replay| {
            let mut rng = ChaCha8Rng::seed_from_u64(0x6a17 + replay as u64);
            let mut gaps = Vec::with_capacity(centre.len());
            for (arc, layers) in arcs.iter().zip(logged) {
                let drawn = noise
                    .spread
                    .draw(arc, &mut || rng.sample::<f64, _>(StandardNormal));
                let d = simulate_resolved(&drawn, &limits, opts).ok()?;
                gaps.extend(
                    pairs_of(&d, layers, Switches::All)
                        .into_iter()
                        .map(|(_, s)| s),
                );
            }
            if gaps.len() != centre.len() {
                return None;
            }
            let mut gtr = vec![0.0; p];
            for (i, ((l, s), y)) in centre.iter().zip(&gaps).enumerate() {
                if (l - s).abs() >= ROBUST_CAP_S || g.iter().all(|col| col[i].abs() < 1e-9) {
                    continue;
                }
                let y = y + noise.resolution_sd_s * rng.sample::<f64, _>(StandardNormal);
                let r = (y - s).clamp(-ROBUST_CAP_S, ROBUST_CAP_S);
                for (acc, col) in gtr.iter_mut().zip(g) {
                    *acc += col[i] * r;
                }
            }
            Some(
                inv.iter()
                    .map(|row| row.iter().zip(&gtr).map(|(a, b)| a * b).sum())
                    .collect(),
            )
        })
        .collect::<Option<_>>()?;
    let r = JITTER_REPLAYS as f64;
    let mean: Vec<f64> = (0..p)
        .map(|k| steps.iter().map(|d| d[k]).sum::<f64>() / r)
        .collect();
    Some(
        (0..p)
            .map(|k| steps.iter().map(|d| (d[k] - mean[k]).powi(2)).sum::<f64>() / (r - 1.0))
            .collect(),
    )
}

/// GᵀG and Gᵀr over the gaps within the robust cap that some value moves, and how many.
struct Normal {
    gtg: Vec<Vec<f64>>,
    gtr: Vec<f64>,
    used: usize,
}

fn normal_equations(centre: &[(f64, f64)], g: &[Vec<f64>]) -> Normal {
    let p = g.len();
    let mut gtg = vec![vec![0.0; p]; p];
    let mut gtr = vec![0.0; p];
    let mut used = 0;
    for (i, (l, s)) in centre.iter().enumerate() {
        let r = l - s;
        if r.abs() >= ROBUST_CAP_S || g.iter().all(|col| col[i].abs() < 1e-9) {
            continue;
        }
        used += 1;
        for a in 0..p {
            gtr[a] += g[a][i] * r;
            for b in 0..p {
                gtg[a][b] += g[a][i] * g[b][i];
            }
        }
    }
    Normal { gtg, gtr, used }
}

/// The inverse of a small symmetric matrix (Gauss–Jordan with partial pivoting); `None` when
/// it is singular to working precision.
pub(crate) fn invert(a: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let p = a.len();
    let scale = (0..p).map(|k| a[k][k].abs()).fold(0.0, f64::max);
    if scale.is_nan() || scale <= 0.0 {
        return None;
    }
    let mut m: Vec<Vec<f64>> = a
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let mut r = row.clone();
            r.extend((0..p).map(|j| if i == j { 1.0 } else { 0.0 }));
            r
        })
        .collect();
    for c in 0..p {
        let pivot = (c..p).max_by(|&x, &y| m[x][c].abs().total_cmp(&m[y][c].abs()))?;
        if m[pivot][c].abs() < 1e-10 * scale {
            return None;
        }
        m.swap(c, pivot);
        let d = m[c][c];
        for x in m[c].iter_mut() {
            *x /= d;
        }
        for r in 0..p {
            if r != c {
                let f = m[r][c];
                let row_c = m[c].clone();
                for (x, y) in m[r].iter_mut().zip(&row_c) {
                    *x -= f * y;
                }
            }
        }
    }
    Some(m.into_iter().map(|r| r[p..].to_vec()).collect())
}

fn solve(a: &[Vec<f64>], b: &[f64]) -> Option<Vec<f64>> {
    let inv = invert(a)?;
    Some(
        inv.iter()
            .map(|row| row.iter().zip(b).map(|(x, y)| x * y).sum())
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The small inverse against a hand-computed one, and a singular matrix refused.
    #[test]
    fn inverse_of_a_small_matrix() {
        let a = vec![vec![4.0, 1.0], vec![1.0, 3.0]];
        let inv = invert(&a).expect("regular");
        let expected = [[3.0 / 11.0, -1.0 / 11.0], [-1.0 / 11.0, 4.0 / 11.0]];
        for i in 0..2 {
            for j in 0..2 {
                assert!((inv[i][j] - expected[i][j]).abs() < 1e-12);
            }
        }
        assert!(invert(&[vec![1.0, 2.0], vec![2.0, 4.0]]).is_none());
    }
}
