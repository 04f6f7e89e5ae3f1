//! Fixed-size Kalman filter pieces (Groves 2nd ed. §3.2).
//!
//! Const-generic over state size `N` and measurement size `M`. Every function
//! here works on stack-allocated `SMatrix`/`SVector` values and never touches
//! the heap (checked by `tests/kalman_no_alloc.rs`); only the RTS smoother
//! store ([`RtsStore`], feature `alloc`) keeps a history.
//!
//! - [`predict`]: `P ← F P Fᵀ + Q` (Groves §3.2.2), symmetrised;
//!   [`predict_sparse`] computes the same, skipping zero entries of `F`
//!   (an INS `F = I + F_c Δt` is ~70 % zeros).
//! - [`update_joseph`]: Joseph-form covariance update (Bucy & Joseph 1968;
//!   Groves eq. 3.58) with the normalised innovation squared and optional χ² gate;
//!   `S` is factorised by Cholesky.
//! - [`chi2_quantile`] / [`chi2_cdf`]: χ² distribution for gate thresholds.

#[allow(unused_imports)]
use crate::prelude::*;
use nalgebra::{Cholesky, SMatrix, SVector};

mod chi2;
pub use chi2::{chi2_cdf, chi2_quantile, chi2_sf};

#[cfg(feature = "alloc")]
mod rts;
#[cfg(feature = "alloc")]
pub use rts::{RtsError, RtsStep, RtsStore, Smoothed};

/// Replace `P` by `(P + Pᵀ)/2` in place.
#[inline]
pub fn symmetrize<const N: usize>(p: &mut SMatrix<f64, N, N>) {
    for j in 0..N {
        for i in 0..j {
            let m = 0.5 * (p[(i, j)] + p[(j, i)]);
            p[(i, j)] = m;
            p[(j, i)] = m;
        }
    }
}

/// Covariance predict in place: `P ← F P Fᵀ + Q`, then symmetrised
/// (Groves §3.2.2; `F` the transition matrix Φ, `Q` the discrete process noise).
pub fn predict<const N: usize>(
    p: &mut SMatrix<f64, N, N>,
    f: &SMatrix<f64, N, N>,
    q: &SMatrix<f64, N, N>,
) {
    let fp = f * *p;
    p.copy_from(q);
    // P ← 1·(F P)·Fᵀ + 1·Q, written into P without a heap temporary.
    p.gemm(1.0, &fp, &f.transpose(), 1.0);
    symmetrize(p);
}

/// Same result as [`predict`] (to rounding), skipping the zero entries of `F`.
///
/// With `P` symmetric, `W = P Fᵀ` has columns `w_j = Σ_k F[j,k] · p_k` and
/// `F P Fᵀ = F W` has columns `Σ_k F[j,k] · (row k of W)ᵀ`; both are sums of
/// contiguous column `axpy`s over the non-zeros of row `j` of `F`, about
/// 2·nnz(F)·N multiply-adds instead of 2·N³. General: any `F` is accepted (a
/// dense one just gains nothing). Assumes `P` symmetric on entry, as every
/// function in this module leaves it; the result is symmetrised like [`predict`].
pub fn predict_sparse<const N: usize>(
    p: &mut SMatrix<f64, N, N>,
    f: &SMatrix<f64, N, N>,
    q: &SMatrix<f64, N, N>,
) {
    // Row-wise non-zeros of F: (column, value), stack arrays.
    let mut nz = [[(0usize, 0.0f64); N]; N];
    let mut cnt = [0usize; N];
    for k in 0..N {
        for j in 0..N {
            let v = f[(j, k)];
            if v != 0.0 {
                nz[j][cnt[j]] = (k, v);
                cnt[j] += 1;
            }
        }
    }
    // W = P Fᵀ (column-major slices: column k of P is ps[k*N..][..N]).
    let mut w = SMatrix::<f64, N, N>::zeros();
    {
        let ps = p.as_slice();
        let ws = w.as_mut_slice();
        for j in 0..N {
            let dst = &mut ws[j * N..(j + 1) * N];
            for &(k, a) in &nz[j][..cnt[j]] {
                let src = &ps[k * N..(k + 1) * N];
                for (d, s) in dst.iter_mut().zip(src) {
                    *d += a * s;
                }
            }
        }
    }
    // Wᵀ, so that rows of W become contiguous columns.
    let wt = w.transpose();
    // P' = F W + Q: column j = q_j + Σ_k F[j,k] · (Wᵀ)_k.
    p.copy_from(q);
    {
        let ws = wt.as_slice();
        let out = p.as_mut_slice();
        for j in 0..N {
            let dst = &mut out[j * N..(j + 1) * N];
            for &(k, a) in &nz[j][..cnt[j]] {
                let src = &ws[k * N..(k + 1) * N];
                for (d, s) in dst.iter_mut().zip(src) {
                    *d += a * s;
                }
            }
        }
    }
    symmetrize(p);
}

/// Result of one measurement update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateInfo {
    /// Normalised innovation squared νᵀ S⁻¹ ν. `+∞` when `S` is not positive
    /// definite (see [`UpdateInfo::singular`]); NaN if the innovation was not finite.
    pub nis: f64,
    /// Whether the update was applied (false: gated out or S not invertible).
    pub accepted: bool,
}

impl UpdateInfo {
    /// Rejected because `S = H P Hᵀ + R` was not positive definite.
    pub fn singular(&self) -> bool {
        !self.accepted && self.nis == f64::INFINITY
    }

    /// Rejected by the χ² gate (or a non-finite innovation), `S` was fine.
    pub fn gated(&self) -> bool {
        !self.accepted && !self.singular()
    }
}

/// Joseph-form update of `(x, P)` with `z = H x + v`, `v ~ N(0, R)`.
/// `innovation` is `z − H x̂` computed by the caller. If `gate` is `Some(g)`
/// and the NIS exceeds `g`, nothing is changed and `accepted` is false.
///
/// `S = H P Hᵀ + R` (Cholesky), `K = P Hᵀ S⁻¹`, `x ← x + K ν`,
/// `P ← (I − K H) P (I − K H)ᵀ + K R Kᵀ` (Groves eq. 3.58), evaluated as
/// `A P = P − K (H P)`, `P ← A P + (K R − (A P) Hᵀ) Kᵀ` — the same Joseph
/// expression without forming the N×N product twice — then symmetrised.
/// Also rejected (state untouched): `S` not positive definite (`nis = +∞`),
/// or a non-finite innovation/NIS.
pub fn update_joseph<const N: usize, const M: usize>(
    x: &mut SVector<f64, N>,
    p: &mut SMatrix<f64, N, N>,
    h: &SMatrix<f64, M, N>,
    r: &SMatrix<f64, M, M>,
    innovation: &SVector<f64, M>,
    gate: Option<f64>,
) -> UpdateInfo {
    update_joseph_masked(x, p, h, r, innovation, gate, None)
}

/// [`update_joseph`] with the gain rows multiplied by `mask` (0 or 1 per
/// state): with zeros, the Schmidt–Kalman ("consider") update (Schmidt
/// 1966; Simon, *Optimal State Estimation*, 2006, §7.5): the masked states
/// keep their prior mean while `P` — the Joseph form is exact for any gain —
/// stays their joint error covariance; the other states get the best gain
/// among those that leave the masked ones unestimated. `None`: exactly
/// [`update_joseph`].
pub fn update_joseph_masked<const N: usize, const M: usize>(
    x: &mut SVector<f64, N>,
    p: &mut SMatrix<f64, N, N>,
    h: &SMatrix<f64, M, N>,
    r: &SMatrix<f64, M, M>,
    innovation: &SVector<f64, M>,
    gate: Option<f64>,
    mask: Option<&SVector<f64, N>>,
) -> UpdateInfo {
    update_joseph_gain(x, p, h, r, innovation, gate, mask, None)
}

/// [`update_joseph_masked`] that also writes the gain `K` it applied into
/// `gain` (untouched when the update is rejected). The arithmetic is the
/// same, so `x` and `P` are bit-identical to [`update_joseph_masked`]'s.
/// Used to propagate a second covariance under another error model with
/// this filter's gain (Gelb, *Applied Optimal Estimation*, 1974, §7.2).
#[allow(clippy::too_many_arguments)]
pub fn update_joseph_gain<const N: usize, const M: usize>(
    x: &mut SVector<f64, N>,
    p: &mut SMatrix<f64, N, N>,
    h: &SMatrix<f64, M, N>,
    r: &SMatrix<f64, M, M>,
    innovation: &SVector<f64, M>,
    gate: Option<f64>,
    mask: Option<&SVector<f64, N>>,
    gain: Option<&mut SMatrix<f64, N, M>>,
) -> UpdateInfo {
    let hp: SMatrix<f64, M, N> = h * *p;
    let mut s: SMatrix<f64, M, M> = r.clone_owned();
    s.gemm(1.0, &hp, &h.transpose(), 1.0);
    // S = H P Hᵀ + R, symmetrised before the factorisation.
    let s = (s + s.transpose()) * 0.5;
    let Some(chol) = Cholesky::new(s) else {
        return UpdateInfo {
            nis: f64::INFINITY,
            accepted: false,
        };
    };
    // NIS = |L⁻¹ ν|².
    let mut y = *innovation;
    if !chol.l_dirty().solve_lower_triangular_mut(&mut y) {
        return UpdateInfo {
            nis: f64::INFINITY,
            accepted: false,
        };
    }
    let nis = y.norm_squared();
    if !nis.is_finite() || gate.is_some_and(|g| nis > g) {
        return UpdateInfo {
            nis,
            accepted: false,
        };
    }
    // Kᵀ = S⁻¹ H P (S, P symmetric).
    let mut kt = hp;
    chol.solve_mut(&mut kt);
    if let Some(m) = mask {
        for j in 0..N {
            for i in 0..M {
                kt[(i, j)] *= m[j];
            }
        }
    }
    let k: SMatrix<f64, N, M> = kt.transpose();
    if let Some(g) = gain {
        g.copy_from(&k);
    }
    x.gemv(1.0, &k, innovation, 1.0);
    // A P = P − K (H P)
    p.gemm(-1.0, &k, &hp, 1.0);
    // B = K R − (A P) Hᵀ
    let mut b: SMatrix<f64, N, M> = k * r;
    b.gemm(-1.0, &*p, &h.transpose(), 1.0);
    // P ← A P + B Kᵀ
    p.gemm(1.0, &b, &kt, 1.0);
    symmetrize(p);
    UpdateInfo {
        nis,
        accepted: true,
    }
}

#[cfg(test)]
mod tests;
