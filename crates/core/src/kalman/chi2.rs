//! χ² distribution for innovation gating: CDF, survival function and quantile.
//!
//! `F(x; k) = P(k/2, x/2)`, the regularised lower incomplete gamma function,
//! evaluated by its power series for `x < a + 1` and by the Legendre continued
//! fraction for the upper tail `Q(a, x)` otherwise (modified Lentz;
//! Abramowitz & Stegun 6.5.29, 6.5.31). Γ(k/2) is computed exactly from
//! factorials, so no Γ approximation enters. The quantile is found by bisection
//! on the tail that is numerically better conditioned.

#[allow(unused_imports)]
use crate::prelude::*;

/// ln Γ(k/2) for k ≥ 1, exact up to summation rounding.
fn ln_gamma_half(k: usize) -> f64 {
    let mut s = 0.0;
    if k % 2 == 1 {
        // Γ(n + 1/2) = √π · Π_{i<n} (i + 1/2)
        s = 0.5 * core::f64::consts::PI.ln();
        for i in 0..k / 2 {
            s += (i as f64 + 0.5).ln();
        }
    } else {
        // Γ(n) = (n−1)!
        for i in 1..k / 2 {
            s += (i as f64).ln();
        }
    }
    s
}

/// (P(a, x), Q(a, x)) for a = k/2, x ≥ 0.
fn gamma_pq(k: usize, x: f64) -> (f64, f64) {
    let a = 0.5 * k as f64;
    if x <= 0.0 {
        return (0.0, 1.0);
    }
    // x^a e^{−x} / Γ(a)
    let front = (a * x.ln() - x - ln_gamma_half(k)).exp();
    if x < a + 1.0 {
        // P = front/a · Σ xⁿ / ((a+1)…(a+n))
        let mut term = 1.0 / a;
        let mut sum = term;
        for n in 1..1000 {
            term *= x / (a + n as f64);
            sum += term;
            if term < sum * 1e-17 {
                break;
            }
        }
        let p = (front * sum).min(1.0);
        (p, 1.0 - p)
    } else {
        // Q = front · 1/(x+1−a− 1·(1−a)/(x+3−a− 2·(2−a)/(x+5−a− …)))
        const TINY: f64 = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / TINY;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..1000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < TINY {
                d = TINY;
            }
            c = b + an / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        let q = (front * h).min(1.0);
        (1.0 - q, q)
    }
}

/// χ² cumulative distribution `Pr(X ≤ x)` for `dof` degrees of freedom.
/// `dof = 0` is the point mass at 0. NaN input gives NaN.
pub fn chi2_cdf(dof: usize, x: f64) -> f64 {
    if x.is_nan() {
        return f64::NAN;
    }
    if dof == 0 {
        return if x >= 0.0 { 1.0 } else { 0.0 };
    }
    if x == f64::INFINITY {
        return 1.0;
    }
    gamma_pq(dof, 0.5 * x).0
}

/// χ² survival function `Pr(X > x) = 1 − cdf`, accurate in the upper tail.
pub fn chi2_sf(dof: usize, x: f64) -> f64 {
    if x.is_nan() {
        return f64::NAN;
    }
    if dof == 0 {
        return if x >= 0.0 { 0.0 } else { 1.0 };
    }
    if x == f64::INFINITY {
        return 0.0;
    }
    gamma_pq(dof, 0.5 * x).1
}

/// χ² quantile for `dof` degrees of freedom at probability `p` (e.g. 0.999), for gating.
///
/// The `x` with `Pr(X ≤ x) = p`, to a relative 1e-12. Edge cases: `p ≤ 0` → 0,
/// `p ≥ 1` → +∞, `dof = 0` → 0, NaN `p` → NaN.
pub fn chi2_quantile(dof: usize, p: f64) -> f64 {
    if p.is_nan() {
        return f64::NAN;
    }
    if dof == 0 || p <= 0.0 {
        return 0.0;
    }
    if p >= 1.0 {
        return f64::INFINITY;
    }
    // Work with the smaller tail: F(x) < p or Q(x) > 1 − p means "x too small".
    let upper = p > 0.5;
    let tail = 1.0 - p;
    let too_small = |x: f64| {
        let (pl, qu) = gamma_pq(dof, 0.5 * x);
        if upper {
            qu > tail
        } else {
            pl < p
        }
    };
    let mut lo = 0.0;
    let mut hi = dof as f64 + 10.0;
    while too_small(hi) {
        lo = hi;
        hi *= 2.0;
        if hi > 1e300 {
            return f64::INFINITY;
        }
    }
    for _ in 0..2000 {
        let mid = 0.5 * (lo + hi);
        if too_small(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-13 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}
