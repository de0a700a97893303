//! A primal–dual interior-point method (Mehrotra's predictor–corrector) for the banded linear
//! programmes of the transcription:
//!
//! minimise cᵀz subject to E·z = f and l ≤ z ≤ u (bounds may be infinite).
//!
//! The rows of E are added along the arc and each variable touches only nearby rows, so the
//! normal matrix E·D⁻¹·Eᵀ of a Newton step is banded: one step costs O(rows · band²), which is
//! what makes a transcription with thousands of pieces cheap enough to solve many times per
//! plan. Every variable's barrier weight gets a small primal regularisation (`REG_PRIMAL`), which
//! keeps the normal matrix definite where a variable has no bounds.

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
        if self.rhs.is_empty()
            || self
                .lo
                .iter()
                .zip(&self.hi)
                .any(|(l, h)| l.is_nan() || h.is_nan())
        {
            return None;
        }
        let mut ipm = Ipm::start(self);
        let mut pinf_seen = Vec::with_capacity(MAX_ITER);
        for _ in 0..MAX_ITER {
            let (pinf, dinf, mu) = ipm.residuals();
            if let Some(verdict) = ipm.verdict(pinf, dinf, mu, &mut pinf_seen) {
                return verdict;
            }
            ipm.normal_matrix();
            // Predictor (σ = 0), then the corrector with its second-order term.
            let (ap, ad) = ipm.direction(false, 0.0);
            let sigma_mu = ipm.centring(ap, ad, mu);
            ipm.keep_predictor();
            let (ap, ad) = ipm.direction(true, sigma_mu);
            ipm.step((0.995 * ap).min(1.0), (0.995 * ad).min(1.0));
        }
        None
    }
}

/// The columns of E as flat arrays, and the half-bandwidth of E·D⁻¹·Eᵀ (rows sharing a
/// variable).
struct Columns {
    colptr: Vec<usize>,
    rows: Vec<usize>,
    vals: Vec<f64>,
    bw: usize,
}

impl Columns {
    fn of(lp: &Lp) -> Self {
        let mut colptr = Vec::with_capacity(lp.cost.len() + 1);
        let mut rows = Vec::new();
        let mut vals = Vec::new();
        colptr.push(0);
        let mut bw = 0;
        for col in &lp.cols {
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
        Columns {
            colptr,
            rows,
            vals,
            bw,
        }
    }

    /// The entries of column `j`.
    fn col(&self, j: usize) -> std::ops::Range<usize> {
        self.colptr[j]..self.colptr[j + 1]
    }
}

/// The iterates of the interior-point method and its work arrays.
struct Ipm<'a> {
    lp: &'a Lp,
    c: Columns,
    n: usize,
    /// Which bounds count: a variable with equal bounds is fixed (no barrier, no step).
    fixed: Vec<bool>,
    has_lo: Vec<bool>,
    has_hi: Vec<bool>,
    z: Vec<f64>,
    yl: Vec<f64>,
    yu: Vec<f64>,
    lam: Vec<f64>,
    /// The slacks to the bounds are iterates of their own: recomputed from `z`, a slack that
    /// has become tiny next to `z` would round to zero.
    sl: Vec<f64>,
    su: Vec<f64>,
    /// Bound pairs with a barrier (for the mean complementarity).
    pairs: usize,
    norm_f: f64,
    norm_c: f64,
    band: Band,
    rp: Vec<f64>,
    rd: Vec<f64>,
    dinv: Vec<f64>,
    /// Reciprocals of the slacks (zero without the bound), set with the normal matrix.
    isl: Vec<f64>,
    isu: Vec<f64>,
    /// The complementarity targets of the direction being computed.
    cl: Vec<f64>,
    cu: Vec<f64>,
    g: Vec<f64>,
    dz: Vec<f64>,
    dyl: Vec<f64>,
    dyu: Vec<f64>,
    /// The predictor's direction, for the corrector's second-order term.
    adz: Vec<f64>,
    adyl: Vec<f64>,
    adyu: Vec<f64>,
    dlam: Vec<f64>,
    rhs: Vec<f64>,
}

impl<'a> Ipm<'a> {
    /// The starting point: inside the bounds, duals at one.
    fn start(lp: &'a Lp) -> Self {
        let n = lp.cost.len();
        let m = lp.rhs.len();
        let c = Columns::of(lp);
        let fixed: Vec<bool> = (0..n)
            .map(|j| lp.lo[j].is_finite() && lp.hi[j].is_finite() && lp.hi[j] <= lp.lo[j])
            .collect();
        let has_lo: Vec<bool> = (0..n).map(|j| lp.lo[j].is_finite() && !fixed[j]).collect();
        let has_hi: Vec<bool> = (0..n).map(|j| lp.hi[j].is_finite() && !fixed[j]).collect();
        let z: Vec<f64> = (0..n)
            .map(|j| match (has_lo[j], has_hi[j]) {
                _ if fixed[j] => lp.lo[j],
                (true, true) => 0.5 * (lp.lo[j] + lp.hi[j]),
                (true, false) => lp.lo[j] + 1.0f64.max(lp.lo[j].abs()),
                (false, true) => lp.hi[j] - 1.0f64.max(lp.hi[j].abs()),
                (false, false) => 0.0,
            })
            .collect();
        let yl: Vec<f64> = has_lo.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect();
        let yu: Vec<f64> = has_hi.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect();
        let pairs = has_lo.iter().filter(|&&b| b).count() + has_hi.iter().filter(|&&b| b).count();
        let norm_f = lp.rhs.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        let norm_c = lp.cost.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        let band = Band::new(m, c.bw);
        let sl: Vec<f64> = (0..n)
            .map(|j| if has_lo[j] { z[j] - lp.lo[j] } else { 0.0 })
            .collect();
        let su: Vec<f64> = (0..n)
            .map(|j| if has_hi[j] { lp.hi[j] - z[j] } else { 0.0 })
            .collect();
        Ipm {
            lp,
            c,
            n,
            fixed,
            has_lo,
            has_hi,
            z,
            yl,
            yu,
            lam: vec![0.0; m],
            sl,
            su,
            pairs,
            norm_f,
            norm_c,
            band,
            rp: vec![0.0; m],
            rd: vec![0.0; n],
            dinv: vec![0.0; n],
            isl: vec![0.0; n],
            isu: vec![0.0; n],
            cl: vec![0.0; n],
            cu: vec![0.0; n],
            g: vec![0.0; n],
            dz: vec![0.0; n],
            dyl: vec![0.0; n],
            dyu: vec![0.0; n],
            adz: vec![0.0; n],
            adyl: vec![0.0; n],
            adyu: vec![0.0; n],
            dlam: vec![0.0; m],
            rhs: vec![0.0; m],
        }
    }

    /// The primal and dual residuals (max norms) and the mean complementarity.
    fn residuals(&mut self) -> (f64, f64, f64) {
        let (lp, c) = (self.lp, &self.c);
        self.rp.copy_from_slice(&lp.rhs);
        let mut gap = 0.0;
        for j in 0..self.n {
            let mut s = lp.cost[j] - self.yl[j] + self.yu[j];
            for e in c.col(j) {
                self.rp[c.rows[e]] -= c.vals[e] * self.z[j];
                s -= c.vals[e] * self.lam[c.rows[e]];
            }
            self.rd[j] = if self.fixed[j] { 0.0 } else { s };
            gap += self.sl[j] * self.yl[j] + self.su[j] * self.yu[j];
        }
        let mu = if self.pairs > 0 {
            gap / self.pairs as f64
        } else {
            0.0
        };
        let pinf = self.rp.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        let dinf = self.rd.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        (pinf, dinf, mu)
    }

    /// The answer when the method stops here: converged, stalled close enough, or failed;
    /// `None` to go on.
    fn verdict(
        &self,
        pinf: f64,
        dinf: f64,
        mu: f64,
        pinf_seen: &mut Vec<f64>,
    ) -> Option<Option<Vec<f64>>> {
        let (norm_f, norm_c) = (self.norm_f, self.norm_c);
        if pinf <= TOL_FEAS * (1.0 + norm_f)
            && dinf <= TOL_DUAL * (1.0 + norm_c)
            && mu <= TOL_GAP * (1.0 + norm_c)
        {
            return Some(Some(self.z.clone()));
        }
        if !(pinf.is_finite() && dinf.is_finite() && mu.is_finite()) {
            return Some(None);
        }
        // No progress towards feasibility over ten iterations while the gap closed: rounding
        // keeps the rows from closing further (good enough if nearly closed: the caller
        // re-integrates and checks exactly), or the programme has no solution.
        pinf_seen.push(pinf);
        let stalled = pinf_seen.len() > 10 && pinf > 0.5 * pinf_seen[pinf_seen.len() - 11];
        if stalled && mu <= TOL_GAP * (1.0 + norm_c) && dinf <= TOL_DUAL * (1.0 + norm_c) {
            return Some((pinf <= TOL_STALL * (1.0 + norm_f)).then(|| self.z.clone()));
        }
        if stalled && mu < 1e-3 * pinf {
            return Some(None);
        }
        None
    }

    /// Builds and factors the normal matrix E·D⁻¹·Eᵀ.
    fn normal_matrix(&mut self) {
        let c = &self.c;
        self.band.clear();
        for j in 0..self.n {
            if self.fixed[j] {
                self.dinv[j] = 0.0;
                self.isl[j] = 0.0;
                self.isu[j] = 0.0;
                continue;
            }
            self.isl[j] = if self.has_lo[j] {
                1.0 / self.sl[j]
            } else {
                0.0
            };
            self.isu[j] = if self.has_hi[j] {
                1.0 / self.su[j]
            } else {
                0.0
            };
            let d = REG_PRIMAL + self.yl[j] * self.isl[j] + self.yu[j] * self.isu[j];
            self.dinv[j] = 1.0 / d;
            let col = c.col(j);
            for a in col.clone() {
                let (ra, ca) = (c.rows[a], c.vals[a] * self.dinv[j]);
                for b in col.start..=a {
                    self.band.add(ra, c.rows[b], ca * c.vals[b]);
                }
            }
        }
        self.band
            .add_diagonal(REG_DUAL * (1.0 + self.band.max_diagonal()));
        self.band.factor();
    }

    /// The Newton direction towards the complementarity target `sigma_mu` (with the
    /// predictor's second-order term when `corr`), and the longest primal and dual steps that
    /// keep the slacks and duals positive. A missing bound has a zero reciprocal slack, so its
    /// terms vanish without a branch.
    fn direction(&mut self, corr: bool, sigma_mu: f64) -> (f64, f64) {
        let corr = if corr { 1.0 } else { 0.0 };
        let n = self.n;
        let (sl, su, yl, yu) = (&self.sl[..n], &self.su[..n], &self.yl[..n], &self.yu[..n]);
        let (adz, adyl, adyu) = (&self.adz[..n], &self.adyl[..n], &self.adyu[..n]);
        let (isl, isu) = (&self.isl[..n], &self.isu[..n]);
        let (rd, dinv) = (&self.rd[..n], &self.dinv[..n]);
        let (cl, cu, g) = (&mut self.cl[..n], &mut self.cu[..n], &mut self.g[..n]);
        for j in 0..n {
            cl[j] = sigma_mu - sl[j] * yl[j] - corr * adz[j] * adyl[j];
            cu[j] = sigma_mu - su[j] * yu[j] + corr * adz[j] * adyu[j];
            g[j] = -rd[j] + cl[j] * isl[j] - cu[j] * isu[j];
        }
        let c = &self.c;
        self.rhs.copy_from_slice(&self.rp);
        for j in 0..n {
            let t = dinv[j] * g[j];
            for e in c.col(j) {
                self.rhs[c.rows[e]] -= c.vals[e] * t;
            }
        }
        self.band.solve(&self.rhs, &mut self.dlam);
        let mut ap = 1.0f64;
        let mut ad = 1.0f64;
        let (dz, dyl, dyu) = (&mut self.dz[..n], &mut self.dyl[..n], &mut self.dyu[..n]);
        for j in 0..n {
            let mut s = g[j];
            for e in c.col(j) {
                s += c.vals[e] * self.dlam[c.rows[e]];
            }
            let z = dinv[j] * s;
            let l = (cl[j] - yl[j] * z) * isl[j];
            let u = (cu[j] + yu[j] * z) * isu[j];
            dz[j] = z;
            dyl[j] = l;
            dyu[j] = u;
            // Longest steps that keep the slacks and duals positive.
            if self.has_lo[j] {
                if z < 0.0 {
                    ap = ap.min(-sl[j] / z);
                }
                if l < 0.0 {
                    ad = ad.min(-yl[j] / l);
                }
            }
            if self.has_hi[j] {
                if z > 0.0 {
                    ap = ap.min(su[j] / z);
                }
                if u < 0.0 {
                    ad = ad.min(-yu[j] / u);
                }
            }
        }
        (ap, ad)
    }

    /// Mehrotra's centring target σ·μ from the predictor's steps `ap`, `ad`.
    fn centring(&self, ap: f64, ad: f64, mu: f64) -> f64 {
        let mut gap_aff = 0.0;
        for j in 0..self.n {
            if self.has_lo[j] {
                gap_aff += (self.sl[j] + ap * self.dz[j]) * (self.yl[j] + ad * self.dyl[j]);
            }
            if self.has_hi[j] {
                gap_aff += (self.su[j] - ap * self.dz[j]) * (self.yu[j] + ad * self.dyu[j]);
            }
        }
        let mu_aff = if self.pairs > 0 {
            gap_aff / self.pairs as f64
        } else {
            0.0
        };
        let sigma = if mu > 0.0 {
            (mu_aff / mu).powi(3).min(1.0)
        } else {
            0.0
        };
        sigma * mu
    }

    /// Keeps the predictor's direction for the corrector's second-order term.
    fn keep_predictor(&mut self) {
        std::mem::swap(&mut self.adz, &mut self.dz);
        std::mem::swap(&mut self.adyl, &mut self.dyl);
        std::mem::swap(&mut self.adyu, &mut self.dyu);
    }

    /// Moves the iterates by the primal step `ap` and the dual step `ad`.
    fn step(&mut self, ap: f64, ad: f64) {
        for j in 0..self.n {
            self.z[j] += ap * self.dz[j];
            if self.has_lo[j] {
                self.sl[j] += ap * self.dz[j];
            }
            if self.has_hi[j] {
                self.su[j] -= ap * self.dz[j];
            }
            self.yl[j] += ad * self.dyl[j];
            self.yu[j] += ad * self.dyu[j];
        }
        for r in 0..self.lp.rhs.len() {
            self.lam[r] += ad * self.dlam[r];
        }
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
