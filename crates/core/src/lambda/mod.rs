//! Integer least squares: LAMBDA decorrelation and search (Teunissen 1995;
//! de Jonge & Tiberius 1996; `SEEDS.md §3` "beyond").
//!
//! Given float ambiguities `â` (cycles) and their covariance `Q`, find the
//! integer vectors `ž` minimising `(â − ž)ᵀ Q⁻¹ (â − ž)`:
//! 1. `Q = Lᵀ D L` (L unit lower triangular);
//! 2. decorrelation `Z` (integer Gauss transformations and permutations, so
//!    `Q_z = Zᵀ Q Z` is nearly diagonal with ordered conditional variances);
//! 3. depth-first search of `ẑ = Zᵀ â` with a shrinking ellipsoid
//!    (Schnorr–Euchner enumeration), keeping the best `m ≤ 2` candidates;
//! 4. back-transformation `ž_a = Z⁻ᵀ ž`.
//!
//! Fixed maximum size [`MAX_N`], stack arrays only: no allocation, no_std.

#![allow(clippy::needless_range_loop)] // index loops mirror the published algorithm

#[allow(unused_imports)]
use crate::prelude::*;

/// Largest problem size: 48 = `MAX_RAW_SATS`, every record of a
/// dual-frequency epoch (24 satellites × 2 signals) in one search (the RTK
/// filter's ambiguity slots; was 32, which dual-frequency GPS + Galileo +
/// BeiDou exceeds).
pub const MAX_N: usize = 48;

/// Why LAMBDA could not run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LambdaError {
    /// `n` is 0 or larger than [`MAX_N`], or `m` not 1 or 2, or slices too short.
    BadSize,
    /// `Q` is not positive definite (a non-positive conditional variance).
    NotPositiveDefinite,
    /// The search visited too many nodes (ill-conditioned problem).
    SearchLimit,
}

/// The best (`[0]`) and second best (`[1]`) integer candidates and their
/// squared residual norms `(â − ž)ᵀ Q⁻¹ (â − ž)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LambdaResult {
    pub n: usize,
    pub m: usize,
    pub fixed: [[f64; MAX_N]; 2],
    pub sqnorm: [f64; 2],
}

impl LambdaResult {
    /// Ratio test statistic `s₂ / s₁` (∞ when `s₁` = 0 or only one candidate exists).
    pub fn ratio(&self) -> f64 {
        if self.m < 2 {
            return f64::INFINITY;
        }
        if self.sqnorm[0] <= 0.0 {
            return f64::INFINITY;
        }
        self.sqnorm[1] / self.sqnorm[0]
    }
    /// The best candidate.
    pub fn best(&self) -> &[f64] {
        &self.fixed[0][..self.n]
    }
}

struct Mat {
    a: [[f64; MAX_N]; MAX_N],
}

/// `Q = Lᵀ D L` of the row-major `n×n` matrix `q`.
fn ltdl(q: &[f64], n: usize, l: &mut Mat, d: &mut [f64; MAX_N]) -> Result<(), LambdaError> {
    let mut a = Mat {
        a: [[0.0; MAX_N]; MAX_N],
    };
    for i in 0..n {
        for j in 0..n {
            a.a[i][j] = q[i * n + j];
        }
    }
    for i in (0..n).rev() {
        d[i] = a.a[i][i];
        if d[i] <= 0.0 || !d[i].is_finite() {
            return Err(LambdaError::NotPositiveDefinite);
        }
        let s = d[i].sqrt();
        for j in 0..=i {
            l.a[i][j] = a.a[i][j] / s;
        }
        for j in 0..i {
            for k in 0..=j {
                a.a[j][k] -= l.a[i][k] * l.a[i][j];
            }
        }
        let lii = l.a[i][i];
        for j in 0..=i {
            l.a[i][j] /= lii;
        }
    }
    Ok(())
}

/// Decorrelation (de Jonge & Tiberius 1996, §3): updates L, D, the
/// transformation `Z` (`Q_z = Zᵀ Q Z`), held transposed in `zt` (row `j` =
/// column `j` of Z, so its column operations are contiguous), and its
/// inverse `zi`.
fn reduce(n: usize, l: &mut Mat, d: &mut [f64; MAX_N], zt: &mut Mat, zi: &mut Mat) {
    if n < 2 {
        return;
    }
    let gauss = |l: &mut Mat, zt: &mut Mat, zi: &mut Mat, i: usize, j: usize| {
        let mu = l.a[i][j].round();
        if mu != 0.0 {
            for r in i..n {
                l.a[r][j] -= mu * l.a[r][i];
            }
            // Column j of Z −= μ · column i (rows of `zt`; i > j here).
            let (row_i, row_j) = if i < j {
                let (lo, hi) = zt.a.split_at_mut(j);
                (&lo[i], &mut hi[0])
            } else {
                let (lo, hi) = zt.a.split_at_mut(i);
                (&hi[0], &mut lo[j])
            };
            for (dst, src) in row_j[..n].iter_mut().zip(&row_i[..n]) {
                *dst -= mu * src;
            }
            // Z⁻¹ ← G⁻¹ Z⁻¹, G⁻¹ = I + μ e_i e_jᵀ: row i += μ · row j.
            for c in 0..n {
                zi.a[i][c] += mu * zi.a[j][c];
            }
        }
    };
    let mut j = n as isize - 2;
    let mut k = n as isize - 2;
    while j >= 0 {
        let ju = j as usize;
        if j <= k {
            for i in ju + 1..n {
                gauss(l, zt, zi, i, ju);
            }
        }
        let del = d[ju] + l.a[ju + 1][ju] * l.a[ju + 1][ju] * d[ju + 1];
        if del + 1e-6 < d[ju + 1] {
            // Permute j and j+1.
            let eta = d[ju] / del;
            let lam = d[ju + 1] * l.a[ju + 1][ju] / del;
            d[ju] = eta * d[ju + 1];
            d[ju + 1] = del;
            for c in 0..ju {
                let a0 = l.a[ju][c];
                let a1 = l.a[ju + 1][c];
                l.a[ju][c] = -l.a[ju + 1][ju] * a0 + a1;
                l.a[ju + 1][c] = eta * a0 + lam * a1;
            }
            l.a[ju + 1][ju] = lam;
            for r in ju + 2..n {
                l.a[r].swap(ju, ju + 1);
            }
            zt.a.swap(ju, ju + 1);
            zi.a.swap(ju, ju + 1);
            k = j;
            j = n as isize - 2;
        } else {
            j -= 1;
        }
    }
}

/// Search the `m` best integer vectors for `ẑ` under `Q_z = Lᵀ D L`
/// (shrinking ellipsoid; conditional centres `c_i = ẑ_i + Σ_{j>i} L_ji (z_j − c_j)`).
#[allow(clippy::too_many_arguments)]
fn search(
    n: usize,
    m: usize,
    l: &Mat,
    d: &[f64; MAX_N],
    zhat: &[f64; MAX_N],
    out: &mut [[f64; MAX_N]; 2],
    s: &mut [f64; 2],
    max_nodes: u64,
) -> Result<usize, LambdaError> {
    let mut dist = [0.0f64; MAX_N];
    let mut c = [0.0f64; MAX_N];
    let mut z = [0.0f64; MAX_N];
    let mut step = [0.0f64; MAX_N];
    let sgn = |x: f64| if x <= 0.0 { -1.0 } else { 1.0 };
    let mut k = n - 1;
    c[k] = zhat[k];
    z[k] = c[k].round();
    let mut y = c[k] - z[k];
    step[k] = sgn(y);
    let mut maxdist = f64::INFINITY;
    let mut found = 0usize;
    let mut nodes = 0u64;
    loop {
        nodes += 1;
        if nodes > max_nodes {
            return Err(LambdaError::SearchLimit);
        }
        let newdist = dist[k] + y * y / d[k];
        if newdist < maxdist {
            if k != 0 {
                k -= 1;
                dist[k] = newdist;
                let mut acc = 0.0;
                for jj in k + 1..n {
                    acc += l.a[jj][k] * (z[jj] - c[jj]);
                }
                c[k] = zhat[k] + acc;
                z[k] = c[k].round();
                y = c[k] - z[k];
                step[k] = sgn(y);
            } else {
                // A candidate: insert keeping the list sorted.
                if found < m {
                    out[found][..n].copy_from_slice(&z[..n]);
                    s[found] = newdist;
                    found += 1;
                } else {
                    out[m - 1][..n].copy_from_slice(&z[..n]);
                    s[m - 1] = newdist;
                }
                let mut i = found - 1;
                while i > 0 && s[i] < s[i - 1] {
                    s.swap(i, i - 1);
                    out.swap(i, i - 1);
                    i -= 1;
                }
                if found == m {
                    maxdist = s[m - 1];
                }
                z[0] += step[0];
                y = c[0] - z[0];
                step[0] = -step[0] - sgn(step[0]);
            }
        } else {
            if k == n - 1 {
                break;
            }
            k += 1;
            z[k] += step[k];
            y = c[k] - z[k];
            step[k] = -step[k] - sgn(step[k]);
        }
    }
    Ok(found)
}

/// LAMBDA: the `m` (1 or 2) best integer vectors for float ambiguities `a`
/// (length `n`) with row-major covariance `q` (`n×n`), by integer least squares.
pub fn lambda(a: &[f64], q: &[f64], n: usize, m: usize) -> Result<LambdaResult, LambdaError> {
    lambda_with_limit(a, q, n, m, MAX_NODES)
}

/// The default bound on search nodes of [`lambda`] (an ill-conditioned
/// problem is reported as [`LambdaError::SearchLimit`], not searched forever).
pub const MAX_NODES: u64 = 10_000_000;

/// [`lambda`] with a bound on the number of search nodes.
pub fn lambda_with_limit(
    a: &[f64],
    q: &[f64],
    n: usize,
    m: usize,
    max_nodes: u64,
) -> Result<LambdaResult, LambdaError> {
    Decorrelated::new(q, n)?.search(a, m, max_nodes)
}

/// `Q = Lᵀ D L` decorrelated once (steps 1–2 of the module documentation),
/// for the success rate and the search of the same `Q` (the RTK filter asks
/// both at every fix attempt; the reduction is the costly part).
pub struct Decorrelated {
    n: usize,
    l: Mat,
    d: [f64; MAX_N],
    /// `Zᵀ` (row `j` = column `j` of Z) and `Z⁻¹`.
    zt: Mat,
    zi: Mat,
}

impl Decorrelated {
    /// Factor and decorrelate the row-major `n×n` covariance `q` [cycles²].
    pub fn new(q: &[f64], n: usize) -> Result<Self, LambdaError> {
        if n == 0 || n > MAX_N || q.len() < n * n {
            return Err(LambdaError::BadSize);
        }
        let mut r = Decorrelated {
            n,
            l: Mat {
                a: [[0.0; MAX_N]; MAX_N],
            },
            d: [0.0f64; MAX_N],
            zt: Mat {
                a: [[0.0; MAX_N]; MAX_N],
            },
            zi: Mat {
                a: [[0.0; MAX_N]; MAX_N],
            },
        };
        ltdl(q, n, &mut r.l, &mut r.d)?;
        for i in 0..n {
            r.zt.a[i][i] = 1.0;
            r.zi.a[i][i] = 1.0;
        }
        reduce(n, &mut r.l, &mut r.d, &mut r.zt, &mut r.zi);
        Ok(r)
    }

    /// Bootstrapped success rate of the decorrelated problem (Teunissen
    /// 1998): `P = Π_i (2 Φ(1 / (2 √D_i)) − 1)`, a sharp lower bound of the
    /// ILS success rate.
    pub fn success_rate(&self) -> f64 {
        let mut p = 1.0;
        for di in self.d.iter().take(self.n) {
            p *= 2.0 * phi(1.0 / (2.0 * di.sqrt())) - 1.0;
        }
        p
    }

    /// Steps 3–4: the `m` (1 or 2) best integer vectors for the float
    /// ambiguities `a` (length `n`), at most `max_nodes` search nodes.
    pub fn search(&self, a: &[f64], m: usize, max_nodes: u64) -> Result<LambdaResult, LambdaError> {
        let n = self.n;
        if !(1..=2).contains(&m) || a.len() < n {
            return Err(LambdaError::BadSize);
        }
        let (l, d, zt, zi) = (&self.l, &self.d, &self.zt, &self.zi);
        // Shift to the nearest integers first for numerical range (a may be ~1e9).
        let mut shift = [0.0f64; MAX_N];
        let mut zhat = [0.0f64; MAX_N];
        for i in 0..n {
            let mut acc = 0.0;
            for r in 0..n {
                acc += zt.a[i][r] * a[r];
            }
            shift[i] = acc.round();
            zhat[i] = acc - shift[i];
        }
        let mut cand = [[0.0f64; MAX_N]; 2];
        let mut s = [f64::INFINITY; 2];
        let found = search(n, m, l, d, &zhat, &mut cand, &mut s, max_nodes)?;
        let mut res = LambdaResult {
            n,
            m: found,
            fixed: [[0.0; MAX_N]; 2],
            sqnorm: s,
        };
        for k in 0..found {
            // ž_a = Z⁻ᵀ (ž + shift).
            for i in 0..n {
                let mut acc = 0.0;
                for r in 0..n {
                    acc += zi.a[r][i] * (cand[k][r] + shift[r]);
                }
                res.fixed[k][i] = acc.round();
            }
        }
        Ok(res)
    }
}

/// Standard normal CDF Φ(x).
fn phi(x: f64) -> f64 {
    0.5 * (1.0 + libm::erf(x / core::f64::consts::SQRT_2))
}

/// Bootstrapped success rate of the decorrelated problem (Teunissen 1998):
/// `P = Π_i (2 Φ(1 / (2 √D_i)) − 1)`, a sharp lower bound of the ILS success rate.
pub fn bootstrap_success_rate(q: &[f64], n: usize) -> Result<f64, LambdaError> {
    Ok(Decorrelated::new(q, n)?.success_rate())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    // RTKLIB's LAMBDA unit test vectors (test/utest/t_lambda.c), as cited by issue 7.
    const A1: [f64; 6] = [
        1585184.171,
        -6716599.430,
        3915742.905,
        7627233.455,
        9565990.879,
        989457273.200,
    ];

    fn q1() -> [f64; 36] {
        let mut q = [0.0; 36];
        for i in 0..6 {
            for j in 0..6 {
                q[i * 6 + j] = if i == 5 || j == 5 {
                    if i == j {
                        0.434339
                    } else {
                        0.103473
                    }
                } else if i == j {
                    0.227134
                } else {
                    0.112202
                };
            }
        }
        q
    }

    #[test]
    fn rtklib_vector_n6() {
        let r = lambda(&A1, &q1(), 6, 2).unwrap();
        let f1 = [
            1585184.0,
            -6716599.0,
            3915743.0,
            7627234.0,
            9565991.0,
            989457273.0,
        ];
        let f2 = [
            1585184.0,
            -6716600.0,
            3915743.0,
            7627233.0,
            9565991.0,
            989457273.0,
        ];
        assert_eq!(&r.fixed[0][..6], &f1);
        assert_eq!(&r.fixed[1][..6], &f2);
        assert!((r.sqnorm[0] - 3.507984).abs() < 1e-4, "{}", r.sqnorm[0]);
        assert!((r.sqnorm[1] - 3.708456).abs() < 1e-4, "{}", r.sqnorm[1]);
    }

    #[test]
    fn rtklib_vector_n10() {
        let a2 = [
            -13324172.755747,
            -10668894.713608,
            -7157225.010770,
            -6149367.974367,
            -7454133.571066,
            -5969200.494550,
            8336734.058423,
            6186974.084502,
            -17549093.883655,
            -13970158.922370,
        ];
        let (qa, qb, qc) = (0.223160, 0.286388, 0.367531);
        let mut q = [0.0; 100];
        for i in 0..10 {
            for j in 0..10 {
                let base = match (i < 5, j < 5) {
                    (true, true) => qa,
                    (false, false) => qc,
                    _ => qb,
                };
                q[i * 10 + j] = if i % 5 == j % 5 { 2.0 * base } else { base };
            }
        }
        // The published matrix prints 2·base rounded: restore those entries exactly.
        for i in 0..10 {
            for j in 0..10 {
                if i % 5 == j % 5 {
                    q[i * 10 + j] = match (i < 5, j < 5) {
                        (true, true) => 0.446320,
                        (false, false) => 0.735063,
                        _ => 0.572775,
                    };
                }
            }
        }
        let r = lambda(&a2, &q, 10, 2).unwrap();
        let f1 = [
            -13324188.0,
            -10668901.0,
            -7157236.0,
            -6149379.0,
            -7454143.0,
            -5969220.0,
            8336726.0,
            6186960.0,
            -17549108.0,
            -13970171.0,
        ];
        let f2 = [
            -13324188.0,
            -10668908.0,
            -7157236.0,
            -6149379.0,
            -7454143.0,
            -5969220.0,
            8336717.0,
            6186960.0,
            -17549108.0,
            -13970171.0,
        ];
        assert_eq!(&r.fixed[0][..10], &f1);
        assert_eq!(&r.fixed[1][..10], &f2);
        assert!((r.sqnorm[0] - 1506.435789).abs() < 1e-4, "{}", r.sqnorm[0]);
        assert!((r.sqnorm[1] - 1612.811795).abs() < 1e-4, "{}", r.sqnorm[1]);
    }

    /// Squared norm (a − z)ᵀ W (a − z) with W = Q⁻¹, for the brute-force check.
    fn sqnorm(a: &[f64], z: &[f64], w: &nalgebra::DMatrix<f64>, n: usize) -> f64 {
        let e = nalgebra::DVector::from_iterator(n, (0..n).map(|i| a[i] - z[i]));
        e.dot(&(w * &e))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// LAMBDA's two best equal a brute-force enumeration over a box.
        #[test]
        fn matches_brute_force(
            n in 1usize..=4,
            seed in proptest::collection::vec(-1.0f64..1.0, 4 * 4 + 4),
            scale in 0.05f64..2.0,
        ) {
            // Random SPD Q = G Gᵀ + 0.01 I (correlated), a in [−3, 3].
            let mut q = [0.0; 16];
            for i in 0..n {
                for j in 0..n {
                    let mut s = if i == j { 0.01 } else { 0.0 };
                    for k in 0..n {
                        s += seed[i * 4 + k] * seed[j * 4 + k];
                    }
                    q[i * n + j] = s * scale;
                }
            }
            let a: Vec<f64> = (0..n).map(|i| 3.0 * seed[16 + i]).collect();
            let r = lambda(&a, &q[..n * n], n, 2).unwrap();
            // Brute force over a box that certainly holds both best: ±R around a.
            let w = nalgebra::DMatrix::from_row_slice(n, n, &q[..n * n]).try_inverse().unwrap();
            let rad = 7i64;
            let mut best = [(f64::INFINITY, [0i64; 4]); 2];
            let total = (2 * rad + 1).pow(n as u32);
            for idx in 0..total {
                let mut z = [0i64; 4];
                let mut t = idx;
                for zi in z.iter_mut().take(n) {
                    *zi = (t % (2 * rad + 1)) - rad;
                    t /= 2 * rad + 1;
                }
                let zf: Vec<f64> = (0..n).map(|i| (a[i].round() as i64 + z[i]) as f64).collect();
                let s = sqnorm(&a, &zf, &w, n);
                let zz: [i64; 4] = core::array::from_fn(|i| if i < n { zf[i] as i64 } else { 0 });
                if s < best[0].0 { best[1] = best[0]; best[0] = (s, zz); }
                else if s < best[1].0 { best[1] = (s, zz); }
            }
            prop_assert!((r.sqnorm[0] - best[0].0).abs() < 1e-6 * (1.0 + best[0].0));
            prop_assert!((r.sqnorm[1] - best[1].0).abs() < 1e-6 * (1.0 + best[1].0));
            for i in 0..n {
                prop_assert_eq!(r.fixed[0][i] as i64, best[0].1[i]);
            }
        }
    }

    #[test]
    fn success_rate_behaves() {
        // Precise diagonal: P → 1; sloppy: small; correlated same as its decorrelation.
        let p = bootstrap_success_rate(&[0.001, 0.0, 0.0, 0.001], 2).unwrap();
        assert!(p > 0.999999);
        let p = bootstrap_success_rate(&[1.0, 0.0, 0.0, 1.0], 2).unwrap();
        let one = 2.0 * phi(0.5) - 1.0;
        assert!((p - one * one).abs() < 1e-12);
        // Monte Carlo check of the bound on a correlated 3-D problem.
        let q = [0.09, 0.08, 0.07, 0.08, 0.09, 0.08, 0.07, 0.08, 0.09];
        let p = bootstrap_success_rate(&q, 3).unwrap();
        let ch = nalgebra::Matrix3::from_row_slice(&q).cholesky().unwrap();
        let lq = ch.l();
        let mut ok = 0;
        let trials = 4000;
        let mut rng = crate::TestGauss(12345);
        let mut gauss = || rng.next();
        for _ in 0..trials {
            let w = nalgebra::Vector3::new(gauss(), gauss(), gauss());
            let a = lq * w; // true integers 0
            let r = lambda(a.as_slice(), &q, 3, 1).unwrap();
            if r.best().iter().all(|&v| v == 0.0) {
                ok += 1;
            }
        }
        let rate = ok as f64 / trials as f64;
        // ILS success ≥ bootstrapped (Teunissen 1999), allow MC noise.
        assert!(rate + 0.03 >= p, "ILS {rate} vs bootstrap {p}");
        assert!(p > 0.3 && p < 0.999, "{p}");
    }

    #[test]
    fn rejects_bad_input() {
        assert_eq!(
            lambda(&[0.5], &[-1.0], 1, 2).unwrap_err(),
            LambdaError::NotPositiveDefinite
        );
        assert_eq!(lambda(&[], &[], 0, 2).unwrap_err(), LambdaError::BadSize);
        assert_eq!(
            lambda(&[0.5], &[1.0], 1, 3).unwrap_err(),
            LambdaError::BadSize
        );
    }
}
