//! Private fixed-size Kalman pieces for PF-LC (predict, Joseph update, NIS).
//!
//! Written here because `crate::kalman` was still a contract stub when this
//! module was built; same maths (Groves 2nd ed. §3.2.2, Joseph form eq. 3.58).
//! Allocation-free: fixed-size `SMatrix`, `try_inverse` of the M×M innovation
//! covariance.

use nalgebra::{SMatrix, SVector};

/// `P ← F P Fᵀ + Q`, symmetrised.
pub fn predict<const N: usize>(
    p: &mut SMatrix<f64, N, N>,
    f: &SMatrix<f64, N, N>,
    q: &SMatrix<f64, N, N>,
) {
    let fp = f * *p;
    *p = fp * f.transpose() + q;
    symmetrize(p);
}

fn symmetrize<const N: usize>(p: &mut SMatrix<f64, N, N>) {
    for i in 0..N {
        for j in (i + 1)..N {
            let m = 0.5 * (p[(i, j)] + p[(j, i)]);
            p[(i, j)] = m;
            p[(j, i)] = m;
        }
    }
}

/// Outcome of [`update`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Update {
    /// Normalised innovation squared νᵀ S⁻¹ ν (NaN when S is singular).
    pub nis: f64,
    /// Whether the state and covariance were changed.
    pub accepted: bool,
}

/// Joseph-form update with innovation `nu = z − H x̂`; gated when `nis > gate`.
pub fn update<const N: usize, const M: usize>(
    x: &mut SVector<f64, N>,
    p: &mut SMatrix<f64, N, N>,
    h: &SMatrix<f64, M, N>,
    r: &SMatrix<f64, M, M>,
    nu: &SVector<f64, M>,
    gate: f64,
) -> Update {
    let pht = *p * h.transpose();
    let s = h * pht + r;
    let Some(s_inv) = s.try_inverse() else {
        return Update {
            nis: f64::NAN,
            accepted: false,
        };
    };
    let nis = (nu.transpose() * s_inv * nu)[(0, 0)];
    if !nis.is_finite() || nis > gate {
        return Update {
            nis,
            accepted: false,
        };
    }
    let k = pht * s_inv;
    *x += k * nu;
    let ikh = SMatrix::<f64, N, N>::identity() - k * h;
    *p = ikh * *p * ikh.transpose() + k * r * k.transpose();
    symmetrize(p);
    Update {
        nis,
        accepted: true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};

    #[test]
    fn scalar_update_matches_closed_form_and_gates() {
        let mut x = Vector2::new(0.0, 0.0);
        let mut p = Matrix2::new(4.0, 0.0, 0.0, 1.0);
        let h = Matrix1x2::new(1.0, 0.0);
        let r = Matrix1::new(4.0);
        let u = update(&mut x, &mut p, &h, &r, &Vector1::new(2.0), 100.0);
        assert!(u.accepted);
        assert!((x[0] - 1.0).abs() < 1e-12 && (p[(0, 0)] - 2.0).abs() < 1e-12);
        assert!((u.nis - 0.5).abs() < 1e-12);
        let before = (x, p);
        let u = update(&mut x, &mut p, &h, &r, &Vector1::new(100.0), 9.0);
        assert!(!u.accepted);
        assert_eq!(before, (x, p));
    }
}
