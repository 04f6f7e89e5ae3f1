//! Summary statistics of one error quantity.

use serde::{Deserialize, Serialize};

/// Summary of one error quantity over the evaluated epochs.
///
/// `mean` is of the signed values; `max_abs` and `p95_abs` are of the
/// absolute values (for magnitudes such as the horizontal error they are the
/// plain max and 95th percentile). Units are those of the quantity (m, m/s,
/// rad).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Number of values.
    pub count: usize,
    /// Root mean square √(Σx²/n).
    pub rms: f64,
    /// Mean Σx/n (signed).
    pub mean: f64,
    /// max |x|.
    pub max_abs: f64,
    /// 95th percentile of |x| by the nearest-rank rule (see [`percentile_nearest_rank`]).
    pub p95_abs: f64,
}

impl Stats {
    /// Statistics of `values`; `None` when there are none.
    ///
    /// Values must be finite (the evaluator only produces finite errors);
    /// a non-finite value propagates into `rms`/`mean` rather than being
    /// dropped, so it cannot go unnoticed.
    pub fn of(values: &[f64]) -> Option<Stats> {
        if values.is_empty() {
            return None;
        }
        let n = values.len() as f64;
        let mut sum = 0.0;
        let mut sum_sq = 0.0;
        let mut abs: Vec<f64> = Vec::with_capacity(values.len());
        for &x in values {
            sum += x;
            sum_sq += x * x;
            abs.push(x.abs());
        }
        abs.sort_by(f64::total_cmp);
        Some(Stats {
            count: values.len(),
            rms: (sum_sq / n).sqrt(),
            mean: sum / n,
            max_abs: *abs.last().expect("non-empty"),
            p95_abs: percentile_nearest_rank(&abs, 95.0),
        })
    }
}

/// The `p`-th percentile (0 < p ≤ 100) of ascending-sorted `sorted` by the
/// nearest-rank rule: the smallest value such that at least p % of the
/// values are ≤ it, i.e. `sorted[⌈p/100 · n⌉ − 1]` (1-based rank ⌈p n/100⌉,
/// clamped to 1..n). No interpolation: the result is always one of the values.
///
/// Panics if `sorted` is empty.
pub fn percentile_nearest_rank(sorted: &[f64], p: f64) -> f64 {
    assert!(!sorted.is_empty(), "percentile of an empty set");
    let n = sorted.len();
    // Round the product before the ceiling so that e.g. 95 % of 20 is rank 19,
    // not 20 because 0.95·20 = 19.000000000000004.
    let prod = p / 100.0 * n as f64;
    let rank = ((prod * 1e9).round() / 1e9).ceil() as usize;
    sorted[rank.clamp(1, n) - 1]
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn empty_is_none() {
        assert!(Stats::of(&[]).is_none());
    }

    #[test]
    fn known_values() {
        let s = Stats::of(&[3.0, -4.0]).unwrap();
        assert_eq!(s.count, 2);
        assert!((s.rms - (12.5f64).sqrt()).abs() < 1e-15);
        assert!((s.mean - -0.5).abs() < 1e-15);
        assert_eq!(s.max_abs, 4.0);
        assert_eq!(s.p95_abs, 4.0);
    }

    #[test]
    fn nearest_rank_on_1_to_100() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile_nearest_rank(&v, 95.0), 95.0);
        assert_eq!(percentile_nearest_rank(&v, 50.0), 50.0);
        assert_eq!(percentile_nearest_rank(&v, 100.0), 100.0);
        assert_eq!(percentile_nearest_rank(&v, 0.5), 1.0);
        let w: Vec<f64> = (1..=20).map(f64::from).collect();
        // 0.95·20 = 19 exactly → rank 19 (not 20 through a rounding artefact).
        assert_eq!(percentile_nearest_rank(&w, 95.0), 19.0);
        let x: Vec<f64> = (1..=21).map(f64::from).collect();
        // 0.95·21 = 19.95 → rank 20.
        assert_eq!(percentile_nearest_rank(&x, 95.0), 20.0);
    }

    proptest! {
        #[test]
        fn p95_bounds_and_definition(v in proptest::collection::vec(-1e3f64..1e3, 1..200)) {
            let s = Stats::of(&v).unwrap();
            let n = v.len();
            let le = v.iter().filter(|x| x.abs() <= s.p95_abs).count();
            let lt = v.iter().filter(|x| x.abs() < s.p95_abs).count();
            // At least 95 % are ≤ p95, fewer than 95 % are strictly below it.
            prop_assert!(le as f64 >= 0.95 * n as f64 - 1e-9);
            prop_assert!((lt as f64) < 0.95 * n as f64 + 1e-9);
            prop_assert!(s.p95_abs <= s.max_abs);
            prop_assert!(s.rms <= s.max_abs + 1e-12);
            prop_assert!(s.mean.abs() <= s.rms + 1e-9);
        }
    }
}
