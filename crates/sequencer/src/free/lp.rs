//! A primal–dual interior-point method (Mehrotra's predictor–corrector) for the banded linear
//! programmes of the transcription:
//!
//! minimise cᵀz subject to E·z = f and l ≤ z ≤ u (bounds may be infinite).
//!
//! The rows of E are added along the arc and each variable touches only nearby rows, so the
//! normal matrix E·D⁻¹·Eᵀ of a Newton step is banded: one step costs O(rows · band²), which is
//! what makes a transcription with thousands of pieces cheap enough to solve many times per
//! plan. Variables without bounds get a small primal regularisation.

/// A linear programme in the form above, built variable by variable and row by row.
#[derive(Clone, Debug, Default)]
pub(crate) struct Lp {
    cost: Vec<f64>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    /// Each variable's (row, coefficient) entries.
    cols: Vec<Vec<(usize, f64)>>,
    rhs: Vec<f64>,
}

/// Convergence tolerances (relative to the data's size) and iteration limit.
const TOL_FEAS: f64 = 1e-9;
const TOL_GAP: f64 = 1e-10;
/// The dual residual only makes the step slightly less than optimal, never infeasible.
const TOL_DUAL: f64 = 1e-7;
const MAX_ITER: usize = 80;
/// Primal residual accepted when rounding stops the method short of `TOL_FEAS`.
const TOL_STALL: f64 = 1e-6;
/// Primal regularisation (added to every variable's barrier weight) and dual regularisation
/// (added to the normal matrix's diagonal).
const REG_PRIMAL: f64 = 1e-6;
const REG_DUAL: f64 = 1e-13;

impl Lp {
    /// A new variable with bounds `lo ≤ z ≤ hi` (infinite for none) and cost `cost`.
    pub fn var(&mut self, lo: f64, hi: f64, cost: f64) -> usize {
        self.cost.push(cost);
        self.lo.push(lo);
        self.hi.push(hi.max(lo));
        self.cols.push(Vec::new());
        self.cost.len() - 1
    }

    /// A new row `Σ coef · z = rhs`.
    pub fn row(&mut self, terms: &[(usize, f64)], rhs: f64) {
        let r = self.rhs.len();
        for &(j, c) in terms {
            if c != 0.0 {
                self.cols[j].push((r, c));
            }
        }
        self.rhs.push(rhs);
    }

    /// The optimal `z`, or `None` when the method does not converge (an infeasible or
    /// numerically hopeless programme).
    pub fn solve(&self) -> Option<Vec<f64>> {
        let n = self.cost.len();
        let m = self.rhs.len();
        if m == 0
            || self
                .lo
                .iter()
                .zip(&self.hi)
                .any(|(l, h)| l.is_nan() || h.is_nan())
        {
            return None;
        }
        // Columns as flat arrays, and the half-bandwidth of E·D⁻¹·Eᵀ (rows sharing a variable).
        let mut colptr = Vec::with_capacity(n + 1);
        let mut rows = Vec::new();
        let mut vals = Vec::new();
        colptr.push(0);
        let mut bw = 0;
        for col in &self.cols {
            let mut col = col.clone();
            col.sort_by_key(|e| e.0);
            if let (Some(a), Some(b)) = (col.first(), col.last()) {
                bw = bw.max(b.0 - a.0);
            }
            for (r, c) in col {
                rows.push(r);
                vals.push(c);
            }
            colptr.push(rows.len());
        }
        let col = |j: usize| colptr[j]..colptr[j + 1];
        // Which bounds count: a variable with equal bounds is fixed (no barrier, no step).
        let fixed: Vec<bool> = (0..n)
            .map(|j| self.lo[j].is_finite() && self.hi[j].is_finite() && self.hi[j] <= self.lo[j])
            .collect();
        let has_lo: Vec<bool> = (0..n)
            .map(|j| self.lo[j].is_finite() && !fixed[j])
            .collect();
        let has_hi: Vec<bool> = (0..n)
            .map(|j| self.hi[j].is_finite() && !fixed[j])
            .collect();
        // Start inside the bounds, duals at one.
        let mut z: Vec<f64> = (0..n)
            .map(|j| match (has_lo[j], has_hi[j]) {
                _ if fixed[j] => self.lo[j],
                (true, true) => 0.5 * (self.lo[j] + self.hi[j]),
                (true, false) => self.lo[j] + 1.0f64.max(self.lo[j].abs()),
                (false, true) => self.hi[j] - 1.0f64.max(self.hi[j].abs()),
                (false, false) => 0.0,
            })
            .collect();
        let mut yl: Vec<f64> = has_lo.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect();
        let mut yu: Vec<f64> = has_hi.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect();
        let mut lam = vec![0.0; m];
        let pairs = has_lo.iter().filter(|&&b| b).count() + has_hi.iter().filter(|&&b| b).count();
        let norm_f = self.rhs.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        let norm_c = self.cost.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        let mut band = Band::new(m, bw);
        let mut rp = vec![0.0; m];
        let mut rd = vec![0.0; n];
        // The slacks to the bounds are iterates of their own: recomputed from `z`, a slack
        // that has become tiny next to `z` would round to zero.
        let mut sl: Vec<f64> = (0..n)
            .map(|j| if has_lo[j] { z[j] - self.lo[j] } else { 0.0 })
            .collect();
        let mut su: Vec<f64> = (0..n)
            .map(|j| if has_hi[j] { self.hi[j] - z[j] } else { 0.0 })
            .collect();
        let mut dinv = vec![0.0; n];
        let mut g = vec![0.0; n];
        let mut dz = vec![0.0; n];
        let mut dyl = vec![0.0; n];
        let mut dyu = vec![0.0; n];
        let mut adz = vec![0.0; n];
        let mut adyl = vec![0.0; n];
        let mut adyu = vec![0.0; n];
        let mut dlam = vec![0.0; m];
        let mut rhs = vec![0.0; m];
        let mut pinf_seen = Vec::with_capacity(MAX_ITER);
        for _ in 0..MAX_ITER {
            // Residuals, slacks and the gap.
            rp.copy_from_slice(&self.rhs);
            let mut gap = 0.0;
            for j in 0..n {
                let mut s = self.cost[j] - yl[j] + yu[j];
                for e in col(j) {
                    rp[rows[e]] -= vals[e] * z[j];
                    s -= vals[e] * lam[rows[e]];
                }
                rd[j] = if fixed[j] { 0.0 } else { s };
                gap += sl[j] * yl[j] + su[j] * yu[j];
            }
            let mu = if pairs > 0 { gap / pairs as f64 } else { 0.0 };
            let pinf = rp.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
            let dinf = rd.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
            if pinf <= TOL_FEAS * (1.0 + norm_f)
                && dinf <= TOL_DUAL * (1.0 + norm_c)
                && mu <= TOL_GAP * (1.0 + norm_c)
            {
                return Some(z);
            }
            if !(pinf.is_finite() && dinf.is_finite() && mu.is_finite()) {
                return None;
            }
            // No progress towards feasibility over ten iterations while the gap closed:
            // rounding keeps the rows from closing further (good enough if nearly closed: the
            // caller re-integrates and checks exactly), or the programme has no solution.
            pinf_seen.push(pinf);
            let stalled = pinf_seen.len() > 10 && pinf > 0.5 * pinf_seen[pinf_seen.len() - 11];
            if stalled && mu <= TOL_GAP * (1.0 + norm_c) && dinf <= TOL_DUAL * (1.0 + norm_c) {
                return (pinf <= TOL_STALL * (1.0 + norm_f)).then_some(z);
            }
            if stalled && mu < 1e-3 * pinf {
                return None;
            }
            // Normal matrix E·D⁻¹·Eᵀ.
            band.clear();
            for j in 0..n {
                if fixed[j] {
                    dinv[j] = 0.0;
                    continue;
                }
                let mut d = REG_PRIMAL;
                if has_lo[j] {
                    d += yl[j] / sl[j];
                }
                if has_hi[j] {
                    d += yu[j] / su[j];
                }
                dinv[j] = 1.0 / d;
                let c = col(j);
                for a in c.clone() {
                    let (ra, ca) = (rows[a], vals[a] * dinv[j]);
                    for b in c.start..=a {
                        band.add(ra, rows[b], ca * vals[b]);
                    }
                }
            }
            band.add_diagonal(REG_DUAL * (1.0 + band.max_diagonal()));
            band.factor();
            // Predictor (σ = 0), then the corrector with its second-order term.
            let mut sigma_mu = 0.0;
            let mut steps = (0.0, 0.0);
            for pass in 0..2 {
                let corr = pass == 1;
                // Complementarity targets.
                let rcl =
                    |j: usize| sigma_mu - sl[j] * yl[j] - if corr { adz[j] * adyl[j] } else { 0.0 };
                let rcu =
                    |j: usize| sigma_mu - su[j] * yu[j] + if corr { adz[j] * adyu[j] } else { 0.0 };
                rhs.copy_from_slice(&rp);
                for j in 0..n {
                    let mut gj = -rd[j];
                    if has_lo[j] {
                        gj += rcl(j) / sl[j];
                    }
                    if has_hi[j] {
                        gj -= rcu(j) / su[j];
                    }
                    g[j] = gj;
                    let t = dinv[j] * gj;
                    for e in col(j) {
                        rhs[rows[e]] -= vals[e] * t;
                    }
                }
                band.solve(&rhs, &mut dlam);
                let mut ap = 1.0f64;
                let mut ad = 1.0f64;
                for j in 0..n {
                    let mut s = g[j];
                    for e in col(j) {
                        s += vals[e] * dlam[rows[e]];
                    }
                    dz[j] = dinv[j] * s;
                    dyl[j] = if has_lo[j] {
                        (rcl(j) - yl[j] * dz[j]) / sl[j]
                    } else {
                        0.0
                    };
                    dyu[j] = if has_hi[j] {
                        (rcu(j) + yu[j] * dz[j]) / su[j]
                    } else {
                        0.0
                    };
                    // Longest steps that keep the slacks and duals positive.
                    if has_lo[j] {
                        if dz[j] < 0.0 {
                            ap = ap.min(-sl[j] / dz[j]);
                        }
                        if dyl[j] < 0.0 {
                            ad = ad.min(-yl[j] / dyl[j]);
                        }
                    }
                    if has_hi[j] {
                        if dz[j] > 0.0 {
                            ap = ap.min(su[j] / dz[j]);
                        }
                        if dyu[j] < 0.0 {
                            ad = ad.min(-yu[j] / dyu[j]);
                        }
                    }
                }
                if corr {
                    steps = ((0.995 * ap).min(1.0), (0.995 * ad).min(1.0));
                } else {
                    let mut gap_aff = 0.0;
                    for j in 0..n {
                        if has_lo[j] {
                            gap_aff += (sl[j] + ap * dz[j]) * (yl[j] + ad * dyl[j]);
                        }
                        if has_hi[j] {
                            gap_aff += (su[j] - ap * dz[j]) * (yu[j] + ad * dyu[j]);
                        }
                    }
                    let mu_aff = if pairs > 0 {
                        gap_aff / pairs as f64
                    } else {
                        0.0
                    };
                    let sigma = if mu > 0.0 {
                        (mu_aff / mu).powi(3).min(1.0)
                    } else {
                        0.0
                    };
                    sigma_mu = sigma * mu;
                    std::mem::swap(&mut adz, &mut dz);
                    std::mem::swap(&mut adyl, &mut dyl);
                    std::mem::swap(&mut adyu, &mut dyu);
                }
            }
            let (ap, ad) = steps;
            for j in 0..n {
                z[j] += ap * dz[j];
                if has_lo[j] {
                    sl[j] += ap * dz[j];
                }
                if has_hi[j] {
                    su[j] -= ap * dz[j];
                }
                yl[j] += ad * dyl[j];
                yu[j] += ad * dyu[j];
            }
            for r in 0..m {
                lam[r] += ad * dlam[r];
            }
        }
        None
    }
}

/// A symmetric banded matrix (lower half-band) and its Cholesky factor, in place.
struct Band {
    n: usize,
    bw: usize,
    /// Row `i`, column `i - k` at `i * (bw + 1) + k`.
    a: Vec<f64>,
    /// The reciprocals of the factor's diagonal: the factor and the solves multiply by them
    /// (a division in their serial chains costs several times a multiplication).
    inv: Vec<f64>,
}

impl Band {
    fn new(n: usize, bw: usize) -> Self {
        Band {
            n,
            bw,
            a: vec![0.0; n * (bw + 1)],
            inv: vec![0.0; n],
        }
    }

    fn clear(&mut self) {
        self.a.iter_mut().for_each(|x| *x = 0.0);
    }

    /// Adds `v` at (i, j) and (j, i).
    fn add(&mut self, i: usize, j: usize, v: f64) {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        self.a[i * (self.bw + 1) + (i - j)] += v;
    }

    fn max_diagonal(&self) -> f64 {
        (0..self.n).fold(0.0f64, |m, i| m.max(self.a[i * (self.bw + 1)]))
    }

    fn add_diagonal(&mut self, v: f64) {
        for i in 0..self.n {
            self.a[i * (self.bw + 1)] += v;
        }
    }

    /// Cholesky in place; a pivot that is not safely positive (a dependent row) is replaced by
    /// a huge one, which drops that direction.
    fn factor(&mut self) {
        let w = self.bw + 1;
        for i in 0..self.n {
            let j0 = i.saturating_sub(self.bw);
            for j in j0..=i {
                let mut s = self.a[i * w + (i - j)];
                let k0 = j0.max(j.saturating_sub(self.bw));
                for k in k0..j {
                    s -= self.a[i * w + (i - k)] * self.a[j * w + (j - k)];
                }
                if i == j {
                    let scale = self.a[i * w].abs().max(1e-300);
                    let d = if s > 1e-14 * scale && s.is_finite() {
                        s.sqrt()
                    } else {
                        1e64
                    };
                    self.a[i * w] = d;
                    self.inv[i] = 1.0 / d;
                } else {
                    self.a[i * w + (i - j)] = s * self.inv[j];
                }
            }
        }
    }

    /// Solves L·Lᵀ·x = b.
    fn solve(&self, b: &[f64], x: &mut [f64]) {
        let w = self.bw + 1;
        for i in 0..self.n {
            let k0 = i.saturating_sub(self.bw);
            let mut s = b[i];
            for (k, xk) in x[k0..i].iter().enumerate().map(|(o, xk)| (k0 + o, xk)) {
                s -= self.a[i * w + (i - k)] * xk;
            }
            x[i] = s * self.inv[i];
        }
        for i in (0..self.n).rev() {
            let k1 = (i + w).min(self.n);
            let mut s = x[i];
            for (k, xk) in x[i + 1..k1]
                .iter()
                .enumerate()
                .map(|(o, xk)| (i + 1 + o, xk))
            {
                s -= self.a[k * w + (k - i)] * xk;
            }
            x[i] = s * self.inv[i];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small programme with a known optimum: min -x - y, x + y + s = 4 (s ≥ 0), x ≤ 3,
    /// y ≤ 2, x, y ≥ 0: every point with x + y = 4 is optimal; the value is -4.
    #[test]
    fn solves_a_small_programme() {
        let mut lp = Lp::default();
        let x = lp.var(0.0, 3.0, -1.0);
        let y = lp.var(0.0, 2.0, -1.0);
        let s = lp.var(0.0, f64::INFINITY, 0.0);
        lp.row(&[(x, 1.0), (y, 1.0), (s, 1.0)], 4.0);
        let z = lp.solve().expect("solved");
        assert!((z[x] + z[y] - 4.0).abs() < 1e-8, "{z:?}");
        assert!(z[x] <= 3.0 + 1e-9 && z[y] <= 2.0 + 1e-9);
    }

    /// Random banded programmes against brute force over the vertices is too costly; instead
    /// a chain where the optimum is known: z_{i+1} = z_i + d_i, 0 ≤ d_i ≤ 1, z_0 = 0 (fixed),
    /// z_n ≤ 2.5, maximise z_n: value 2.5 whatever n ≥ 3.
    #[test]
    fn solves_a_chain() {
        for n in [3usize, 10, 200] {
            let mut lp = Lp::default();
            let mut prev = lp.var(0.0, 0.0, 0.0);
            let mut last = prev;
            for i in 0..n {
                let d = lp.var(0.0, 1.0, 0.0);
                let hi = if i + 1 == n { 2.5 } else { f64::INFINITY };
                let cost = if i + 1 == n { -1.0 } else { 0.0 };
                let next = lp.var(f64::NEG_INFINITY, hi, cost);
                lp.row(&[(next, 1.0), (prev, -1.0), (d, -1.0)], 0.0);
                prev = next;
                last = next;
            }
            let z = lp.solve().expect("solved");
            assert!((z[last] - 2.5).abs() < 1e-7, "n {n}: {}", z[last]);
        }
    }
}
