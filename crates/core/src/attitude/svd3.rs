//! 3×3 singular value decomposition with proper-rotation factors.
//!
//! One-sided Jacobi (Hestenes 1958; Golub & Van Loan 4th ed. §8.6.4): plane
//! rotations on the right orthogonalise the columns of `A V`, so `V` stays a
//! product of rotations (det +1) and the singular values keep high relative
//! accuracy. `U` is completed with `u3 = u1 × u2`, so det U = +1 as well and the
//! smallest singular value carries the sign of det A:
//! `A = U · diag(s1, s2, s3) · Vᵀ`, `s1 ≥ s2 ≥ |s3|`.
//!
//! Used instead of nalgebra's 3×3 `svd()`, which for `Matrix3<f64>` switches to
//! an eigen-decomposition of `AᵀA` (squares the condition number; unsorted
//! output reported in dimforge/nalgebra#1215).

#[allow(unused_imports)]
use crate::prelude::*;
use crate::{Mat3, Vec3};

/// `A = u · diag(s) · vᵀ` with `u`, `v` proper rotations (det +1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProperSvd3 {
    /// Left factor, a rotation.
    pub u: Mat3,
    /// Signed singular values `s1 ≥ s2 ≥ |s3|`; `s3 < 0` iff det A < 0.
    pub s: Vec3,
    /// Right factor, a rotation.
    pub v: Mat3,
}

/// Maximum Jacobi sweeps; 3×3 converges to machine precision in ≤ 6–8.
const MAX_SWEEPS: usize = 40;

/// Proper SVD of a 3×3 matrix. `None` if `a` has a non-finite entry.
pub fn proper_svd3(a: &Mat3) -> Option<ProperSvd3> {
    if !a.iter().all(|x| x.is_finite()) {
        return None;
    }
    let mut b = *a;
    let mut v = Mat3::identity();
    for _ in 0..MAX_SWEEPS {
        let mut rotated = false;
        for (p, q) in [(0usize, 1usize), (0, 2), (1, 2)] {
            let alpha = b.column(p).norm_squared();
            let beta = b.column(q).norm_squared();
            let gamma = b.column(p).dot(&b.column(q));
            if gamma == 0.0 || gamma.abs() <= 1e-15 * (alpha * beta).sqrt() {
                continue;
            }
            rotated = true;
            // Rotation angle that zeroes the (p, q) entry of BᵀB.
            let zeta = (beta - alpha) / (2.0 * gamma);
            let t = zeta.signum() / (zeta.abs() + (1.0 + zeta * zeta).sqrt());
            let c = 1.0 / (1.0 + t * t).sqrt();
            let s = c * t;
            for m in [&mut b, &mut v] {
                for r in 0..3 {
                    let xp = m[(r, p)];
                    let xq = m[(r, q)];
                    m[(r, p)] = c * xp - s * xq;
                    m[(r, q)] = s * xp + c * xq;
                }
            }
        }
        if !rotated {
            break;
        }
    }

    // Sort the columns by norm, descending. Each swap negates one column of
    // both B and V so that det V stays +1 and A = B Vᵀ still holds.
    let mut norms = Vec3::new(b.column(0).norm(), b.column(1).norm(), b.column(2).norm());
    for (i, j) in [(0usize, 1usize), (0, 2), (1, 2)] {
        if norms[j] > norms[i] {
            b.swap_columns(i, j);
            v.swap_columns(i, j);
            norms.swap_rows(i, j);
            b.column_mut(j).neg_mut();
            v.column_mut(j).neg_mut();
        }
    }

    let s1 = norms[0];
    if s1 == 0.0 {
        return Some(ProperSvd3 {
            u: Mat3::identity(),
            s: Vec3::zeros(),
            v,
        });
    }
    let u1: Vec3 = b.column(0) / s1;
    let u2: Vec3 = if norms[1] > 1e-300 && norms[1] > f64::EPSILON * s1 * 1e-3 {
        b.column(1) / norms[1]
    } else {
        any_perpendicular(&u1)
    };
    // Re-orthogonalise u2 against u1 (Gram–Schmidt) for a clean rotation.
    let u2 = (u2 - u1 * u1.dot(&u2)).normalize();
    let u3 = u1.cross(&u2);
    let s2 = u2.dot(&b.column(1));
    let s3 = u3.dot(&b.column(2));
    Some(ProperSvd3 {
        u: Mat3::from_columns(&[u1, u2, u3]),
        s: Vec3::new(s1, s2, s3),
        v,
    })
}

/// A unit vector perpendicular to the unit vector `a`.
fn any_perpendicular(a: &Vec3) -> Vec3 {
    // Cross with the axis least aligned with `a`.
    let axis = if a.x.abs() <= a.y.abs() && a.x.abs() <= a.z.abs() {
        Vec3::x()
    } else if a.y.abs() <= a.z.abs() {
        Vec3::y()
    } else {
        Vec3::z()
    };
    a.cross(&axis).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn check(a: &Mat3) {
        let d = proper_svd3(a).unwrap();
        let scale = a.norm().max(1e-300);
        let recon = d.u * Mat3::from_diagonal(&d.s) * d.v.transpose();
        assert!((recon - a).norm() <= 1e-13 * scale, "recon {recon} vs {a}");
        assert!((d.u.transpose() * d.u - Mat3::identity()).norm() < 1e-13);
        assert!((d.v.transpose() * d.v - Mat3::identity()).norm() < 1e-13);
        assert!((d.u.determinant() - 1.0).abs() < 1e-13);
        assert!((d.v.determinant() - 1.0).abs() < 1e-13);
        assert!(d.s[0] >= d.s[1] && d.s[1] >= d.s[2].abs() - 1e-15 * scale);
        // Signed s3: the product of the singular values is det A.
        assert!((d.s.product() - a.determinant()).abs() <= 1e-12 * scale.powi(3));
    }

    #[test]
    fn special_matrices() {
        check(&Mat3::identity());
        check(&Mat3::zeros());
        check(&Mat3::from_diagonal(&Vec3::new(1.0, -2.0, 3.0)));
        check(&Mat3::from_diagonal(&Vec3::new(0.0, 0.0, 5.0)));
        // rank 1
        let a = Vec3::new(1.0, 2.0, 3.0) * Vec3::new(-1.0, 0.5, 2.0).transpose();
        check(&a);
        // reflection
        check(&Mat3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0));
        // the matrix of nalgebra issue #1215
        check(&Mat3::new(
            1.0,
            0.0,
            0.0,
            0.0,
            0.99999994,
            0.0,
            0.0,
            -0.00000054691924,
            1.0000005,
        ));
        assert!(proper_svd3(&Mat3::repeat(f64::NAN)).is_none());
    }

    proptest! {
        #[test]
        fn random_matrices(e in proptest::array::uniform9(-10.0f64..10.0)) {
            check(&Mat3::from_row_slice(&e));
        }
    }
}
