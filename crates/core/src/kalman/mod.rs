//! Fixed-size Kalman filter pieces (CONTRACT STUB — being filled in).
//!
//! Const-generic over state size `N` and measurement size `M`; no allocation.
//! Groves §3.2; Joseph form per Bucy & Joseph / Groves eq. 3.58.

use nalgebra::{SMatrix, SVector};

/// Covariance predict in place: `P ← F P Fᵀ + Q`, then symmetrised.
pub fn predict<const N: usize>(
    p: &mut SMatrix<f64, N, N>,
    f: &SMatrix<f64, N, N>,
    q: &SMatrix<f64, N, N>,
) {
    let _ = (p, f, q);
    unimplemented!()
}

/// Result of one measurement update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateInfo {
    /// Normalised innovation squared νᵀ S⁻¹ ν.
    pub nis: f64,
    /// Whether the update was applied (false: gated out or S not invertible).
    pub accepted: bool,
}

/// Joseph-form update of `(x, P)` with `z = H x + v`, `v ~ N(0, R)`.
/// `innovation` is `z − H x̂` computed by the caller. If `gate` is `Some(g)`
/// and the NIS exceeds `g`, nothing is changed and `accepted` is false.
pub fn update_joseph<const N: usize, const M: usize>(
    x: &mut SVector<f64, N>,
    p: &mut SMatrix<f64, N, N>,
    h: &SMatrix<f64, M, N>,
    r: &SMatrix<f64, M, M>,
    innovation: &SVector<f64, M>,
    gate: Option<f64>,
) -> UpdateInfo {
    let _ = (x, p, h, r, innovation, gate);
    unimplemented!()
}

/// χ² quantile for `dof` degrees of freedom at probability `p` (e.g. 0.999), for gating.
pub fn chi2_quantile(dof: usize, p: f64) -> f64 {
    let _ = (dof, p);
    unimplemented!()
}
