//! Double differences as in seed 003 (`SEEDS.md §3` eq. 8–10): single
//! difference between antennas A (master) and B, then differences between
//! satellites ordered by decreasing elevation, each against the next:
//! `DD_i = SD_i − SD_{i+1}`, `ΔS_i = s_i − s_{i+1}` (rows of the paper's ΔS).
//!
//! Covariance: the paper uses `R = (2σ)² I` ([`DdNoise::PaperDiagonal`]);
//! the exact one for independent undifferenced phases is tridiagonal
//! ([`DdNoise::Exact`]): with SD variances `v_i = σ²_A,i + σ²_B,i`,
//! `C_ii = v_i + v_{i+1}`, `C_{i,i+1} = −v_{i+1}`.

#![allow(clippy::needless_range_loop)] // index loops mirror the matrix equations

#[allow(unused_imports)]
use crate::prelude::*;
use crate::Vec3;
use nalgebra::SMatrix;

/// Largest number of satellites a double-difference set holds.
pub const MAX_SATS: usize = 14;
/// Largest number of double differences (`MAX_SATS − 1`).
pub const MAX_DD: usize = MAX_SATS - 1;

/// DD covariance model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum DdNoise {
    /// The paper's `R = (2σ)² I` (ignores the correlation of neighbouring DDs).
    #[default]
    PaperDiagonal,
    /// The exact tridiagonal covariance of successive differences.
    Exact,
}

/// Rows `ΔS_i = s_i − s_{i+1}` for the `n` lines of sight `los` (ordered by
/// elevation); writes `n − 1` rows, returns `n − 1` (0 when `n < 2`).
pub fn dd_geometry(los: &[Vec3], out: &mut [Vec3]) -> usize {
    if los.len() < 2 {
        return 0;
    }
    for i in 0..los.len() - 1 {
        out[i] = los[i] - los[i + 1];
    }
    los.len() - 1
}

/// `DD_i = SD_i − SD_{i+1}`; returns the number written.
pub fn dd_from_sd(sd: &[f64], out: &mut [f64]) -> usize {
    if sd.len() < 2 {
        return 0;
    }
    for i in 0..sd.len() - 1 {
        out[i] = sd[i] - sd[i + 1];
    }
    sd.len() - 1
}

/// DD covariance for `n` satellites with undifferenced phase standard
/// deviations `sigma[i]` [m] (same at both antennas). Entries beyond
/// `n − 1` are set to the identity so the matrix stays invertible.
pub fn dd_covariance(sigma: &[f64], model: DdNoise) -> SMatrix<f64, MAX_DD, MAX_DD> {
    let mut r = SMatrix::<f64, MAX_DD, MAX_DD>::identity();
    let n = sigma.len();
    if n < 2 {
        return r;
    }
    let m = n - 1;
    match model {
        DdNoise::PaperDiagonal => {
            for i in 0..m {
                // The paper's (2σ)² with its single σ; per-satellite σ averaged
                // over the pair keeps the preset exact for constant σ.
                let s = 0.5 * (sigma[i] + sigma[i + 1]);
                r[(i, i)] = 4.0 * s * s;
            }
        }
        DdNoise::Exact => {
            for i in 0..m {
                let vi = 2.0 * sigma[i] * sigma[i];
                let vj = 2.0 * sigma[i + 1] * sigma[i + 1];
                r[(i, i)] = vi + vj;
                if i + 1 < m {
                    r[(i, i + 1)] = -vj;
                    r[(i + 1, i)] = -vj;
                }
            }
        }
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact covariance equals D Σ Dᵀ formed explicitly.
    #[test]
    fn exact_covariance_matches_explicit_product() {
        let sigma = [0.002, 0.003, 0.0025, 0.004, 0.005];
        let n = sigma.len();
        let r = dd_covariance(&sigma, DdNoise::Exact);
        // Explicit: undifferenced vector [A1,B1,A2,B2,…], DD row i = A_i − B_i − A_{i+1} + B_{i+1}.
        for i in 0..n - 1 {
            for j in 0..n - 1 {
                let mut c = 0.0;
                for k in 0..n {
                    let coef = |row: usize| -> f64 {
                        if k == row {
                            1.0
                        } else if k == row + 1 {
                            -1.0
                        } else {
                            0.0
                        }
                    };
                    // Both antennas contribute σ_k² each, with the same sign pattern.
                    c += 2.0 * coef(i) * coef(j) * sigma[k] * sigma[k];
                }
                assert!((r[(i, j)] - c).abs() < 1e-15, "{i},{j}");
            }
        }
        assert_eq!(r[(n - 1, n - 1)], 1.0);
    }

    #[test]
    fn paper_preset_is_2sigma_squared() {
        let r = dd_covariance(&[0.002; 6], DdNoise::PaperDiagonal);
        assert!((r[(0, 0)] - 0.004f64.powi(2)).abs() < 1e-18);
        assert_eq!(r[(0, 1)], 0.0);
    }

    #[test]
    fn differences_successive() {
        let mut out = [0.0; 3];
        assert_eq!(dd_from_sd(&[5.0, 3.0, 2.5, -1.0], &mut out), 3);
        assert_eq!(out, [2.0, 0.5, 3.5]);
        let mut g = [Vec3::zeros(); 2];
        let los = [Vec3::x(), Vec3::y(), Vec3::z()];
        assert_eq!(dd_geometry(&los, &mut g), 2);
        assert_eq!(g[1], Vec3::new(0.0, 1.0, -1.0));
    }
}
