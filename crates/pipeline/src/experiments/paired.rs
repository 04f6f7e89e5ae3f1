//! Paired comparison of two configurations run on the same simulated seeds.
//!
//! The matrix's strict targets compare pooled scores (`default ≤ k·other`);
//! when two configurations are equally good, that comparison flips with the
//! seeds drawn. The paired statistic says whether a difference is larger than
//! the seed-to-seed scatter: per seed the log-ratio `l_i = ln(a_i / b_i)` of
//! the two scores on the same data, its mean `l̄` and standard error
//! `s_l/√n`, and the 95 % Student-t interval of the geometric-mean ratio
//! `exp(l̄ ± t₀.₉₇₅,ₙ₋₁ · s_l/√n)` (a paired t-test on the log scale: Rice,
//! *Mathematical Statistics and Data Analysis*, 3rd ed., §11.3). Logs make a
//! ratio test symmetric and keep one wild seed from dominating the mean.
//! "Significantly above k" means the interval's lower end is above `k`.

use serde::Serialize;

/// Geometric-mean ratio a/b over the paired seeds with its 95 % interval.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PairedRatio {
    /// Seeds with a finite, positive score on both sides.
    pub n: usize,
    /// exp(mean log-ratio) (NaN when n = 0).
    pub gmean: f64,
    /// 95 % interval (NaN when n < 2).
    pub lo95: f64,
    pub hi95: f64,
}

impl PairedRatio {
    /// Whether the ratio is significantly above `k` (95 % interval entirely
    /// above it). With fewer than two pairs nothing is significant.
    pub fn significantly_above(&self, k: f64) -> bool {
        self.lo95.is_finite() && self.lo95 > k
    }
}

/// Student-t 0.975 quantiles for 1…30 degrees of freedom (Abramowitz &
/// Stegun Table 26.10); beyond 30 the normal 1.96 is within 2 %.
const T975: [f64; 30] = [
    12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
    2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
    2.052, 2.048, 2.045, 2.042,
];

fn t975(dof: usize) -> f64 {
    match dof {
        0 => f64::NAN,
        d if d <= T975.len() => T975[d - 1],
        _ => 1.96,
    }
}

/// The paired ratio of `a[i]` to `b[i]` (pairs with a non-finite or
/// non-positive score on either side are left out).
pub fn paired_ratio(a: &[f64], b: &[f64]) -> PairedRatio {
    let l: Vec<f64> = a
        .iter()
        .zip(b)
        .filter(|(x, y)| x.is_finite() && y.is_finite() && **x > 0.0 && **y > 0.0)
        .map(|(x, y)| (x / y).ln())
        .collect();
    let n = l.len();
    if n == 0 {
        return PairedRatio {
            n,
            gmean: f64::NAN,
            lo95: f64::NAN,
            hi95: f64::NAN,
        };
    }
    let mean = l.iter().sum::<f64>() / n as f64;
    let (lo, hi) = if n < 2 {
        (f64::NAN, f64::NAN)
    } else {
        let var = l.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        let half = t975(n - 1) * (var / n as f64).sqrt();
        ((mean - half).exp(), (mean + half).exp())
    };
    PairedRatio {
        n,
        gmean: mean.exp(),
        lo95: lo,
        hi95: hi,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Equal configurations with seed scatter are not significantly
    /// different; a consistent 10 % excess over the same scatter is.
    #[test]
    fn scatter_is_not_a_difference_but_a_consistent_excess_is() {
        let b = [0.34, 0.36, 0.23, 0.34, 0.37, 0.30, 0.24, 0.38, 0.39, 0.30];
        // Same mean, alternating ±8 % per seed.
        let same: Vec<f64> = b
            .iter()
            .enumerate()
            .map(|(i, x)| x * if i % 2 == 0 { 1.08 } else { 1.0 / 1.08 })
            .collect();
        let r = paired_ratio(&same, &b);
        assert_eq!(r.n, 10);
        assert!((r.gmean - 1.0).abs() < 1e-12, "{r:?}");
        assert!(!r.significantly_above(1.0), "{r:?}");
        // 10 % worse on every seed, ±2 % scatter.
        let worse: Vec<f64> = b
            .iter()
            .enumerate()
            .map(|(i, x)| x * 1.10 * if i % 2 == 0 { 1.02 } else { 1.0 / 1.02 })
            .collect();
        let r = paired_ratio(&worse, &b);
        assert!(r.significantly_above(1.0), "{r:?}");
        assert!(!r.significantly_above(1.2), "{r:?}");
        assert!(r.lo95 < 1.10 && r.hi95 > 1.10, "{r:?}");
    }

    #[test]
    fn bad_pairs_are_left_out_and_one_pair_has_no_interval() {
        let r = paired_ratio(&[1.0, f64::NAN, 2.0, 0.0], &[1.0, 1.0, f64::NAN, 1.0]);
        assert_eq!(r.n, 1);
        assert_eq!(r.gmean, 1.0);
        assert!(r.lo95.is_nan() && !r.significantly_above(0.5));
        assert!(paired_ratio(&[], &[]).gmean.is_nan());
    }
}
