//! Safeguarded root finders: the planner's speeds are exact to machine precision, never the
//! result of a fixed number of bisections.

/// Root of an increasing `f` in `[lo, hi]` (`f(lo) <= 0 <= f(hi)`) by Newton's method with a
/// bisection safeguard (a Newton step that leaves the bracket or does not halve the error is
/// replaced by a bisection), to machine precision. `fdf` returns (f, f').
///
/// The iteration runs in `w = sqrt(x - lo)`: the planner's distance functions behave like
/// `sqrt(x - lo)` next to the low end (a speed change that has just started), which would turn
/// Newton in `x` into a slow bisection towards `lo`; in `w` they are smooth.
pub(crate) fn newton_bracketed(
    mut fdf: impl FnMut(f64) -> (f64, f64),
    lo: f64,
    hi: f64,
    x0: f64,
) -> f64 {
    let (f_lo, _) = fdf(lo);
    if f_lo >= 0.0 {
        // A root at the low end (e.g. an extreme speed exactly at its base) is common: take it.
        return lo;
    }
    let span = hi - lo;
    let to_x = |w: f64| (lo + w * w).min(hi);
    let (mut a, mut b) = (0.0f64, span.sqrt());
    let mut w = if x0 > lo && x0 < hi {
        (x0 - lo).sqrt()
    } else {
        0.5 * b
    };
    let floor = f64::EPSILON * f64::EPSILON * b;
    let mut dw_old = b - a;
    let mut dw = dw_old;
    for _ in 0..200 {
        let x = to_x(w);
        let (f, dfx) = fdf(x);
        if f == 0.0 {
            return x;
        }
        if f < 0.0 {
            a = w;
        } else {
            b = w;
        }
        let df = dfx * 2.0 * w;
        // At the rounding floor of f a Newton step moves w by an ulp or two and f keeps its sign;
        // without this exit the halving test below would throw the iterate back to the far end
        // of a bracket that was never updated.
        if df.is_finite() && df > 0.0 && (f / df).abs() <= 8.0 * f64::EPSILON * w.abs() {
            return to_x((w - f / df).clamp(a, b));
        }
        let newton_leaves = !df.is_finite()
            || df <= 0.0
            || ((w - b) * df - f) * ((w - a) * df - f) > 0.0
            || (2.0 * f).abs() > (dw_old * df).abs();
        dw_old = dw;
        let next = if newton_leaves {
            dw = 0.5 * (b - a);
            a + dw
        } else {
            dw = f / df;
            w - dw
        };
        let tol = (2.0 * f64::EPSILON * next.abs()).max(floor);
        if next == w || dw.abs() <= tol || b - a <= tol {
            return to_x(next);
        }
        w = next;
    }
    to_x(w)
}

/// Root of a continuous `f` on `[a, b]` with `f(a)` and `f(b)` of opposite signs (or zero), by
/// Brent's method (inverse quadratic interpolation, secant and bisection), to machine precision.
pub(crate) fn brent(mut f: impl FnMut(f64) -> f64, a: f64, b: f64) -> f64 {
    let (mut a, mut b) = (a, b);
    let (mut fa, mut fb) = (f(a), f(b));
    if fa == 0.0 {
        return a;
    }
    if fb == 0.0 {
        return b;
    }
    let mut c = a;
    let mut fc = fa;
    let mut d = b - a;
    let mut e = d;
    for _ in 0..300 {
        if (fb > 0.0) == (fc > 0.0) {
            c = a;
            fc = fa;
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            a = b;
            b = c;
            c = a;
            fa = fb;
            fb = fc;
            fc = fa;
        }
        let tol = 2.0 * f64::EPSILON * b.abs() + f64::MIN_POSITIVE;
        let m = 0.5 * (c - b);
        if m.abs() <= tol || fb == 0.0 {
            return b;
        }
        if e.abs() >= tol && fa.abs() > fb.abs() {
            let s = fb / fa;
            let (mut p, mut q);
            if a == c {
                p = 2.0 * m * s;
                q = 1.0 - s;
            } else {
                let qq = fa / fc;
                let r = fb / fc;
                p = s * (2.0 * m * qq * (qq - r) - (b - a) * (r - 1.0));
                q = (qq - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if p > 0.0 {
                q = -q;
            } else {
                p = -p;
            }
            if 2.0 * p < (3.0 * m * q - (tol * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = m;
                e = m;
            }
        } else {
            d = m;
            e = m;
        }
        a = b;
        fa = fb;
        b += if d.abs() > tol { d } else { tol.copysign(m) };
        fb = f(b);
    }
    b
}

/// Maximum of a unimodal `f` on `[a, b]` by golden-section search to relative width ~1e-12.
pub(crate) fn golden_max(f: impl FnMut(f64) -> f64, a: f64, b: f64) -> (f64, f64) {
    golden_max_tol(f, a, b, 1e-13)
}

/// [`golden_max`] to a relative width `tol` of the interval (for brackets that a root finder
/// refines afterwards).
pub(crate) fn golden_max_tol(
    mut f: impl FnMut(f64) -> f64,
    mut a: f64,
    mut b: f64,
    tol: f64,
) -> (f64, f64) {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let mut x1 = b - g * (b - a);
    let mut x2 = a + g * (b - a);
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..200 {
        if (b - a) <= tol * (a.abs() + b.abs()).max(1e-300) {
            break;
        }
        if f1 < f2 {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + g * (b - a);
            f2 = f(x2);
        } else {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - g * (b - a);
            f1 = f(x1);
        }
    }
    if f1 >= f2 {
        (x1, f1)
    } else {
        (x2, f2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn newton_finds_cube_root_to_machine_precision() {
        let x = newton_bracketed(|x| (x * x * x - 2.0, 3.0 * x * x), 0.0, 2.0, 1.0);
        assert!((x - 2f64.cbrt()).abs() <= 2.0 * f64::EPSILON * 2f64.cbrt());
    }

    #[test]
    fn brent_finds_root_of_sqrt_function() {
        let x = brent(|x| x.sqrt() + x - 1.0, 0.0, 1.0);
        let exact = ((5f64).sqrt() - 1.0) / 2.0;
        assert!((x - exact * exact).abs() < 1e-15);
    }

    #[test]
    fn golden_finds_parabola_top() {
        let (x, fx) = golden_max(|x| -(x - 0.3) * (x - 0.3) + 1.0, 0.0, 1.0);
        assert!((x - 0.3).abs() < 1e-6 && (fx - 1.0).abs() < 1e-12);
    }
}
