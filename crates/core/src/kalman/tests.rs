use super::*;
use nalgebra::{DMatrix, DVector, Matrix2};

fn vv<const N: usize>(a: [f64; N]) -> SVector<f64, N> {
    SVector::from(a)
}

fn m1(v: f64) -> SMatrix<f64, 1, 1> {
    SMatrix::from_element(v)
}

/// Small deterministic generator (xorshift64*) so tests need no RNG crate.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let v = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d);
        (v >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
    fn mat<const R: usize, const C: usize>(&mut self) -> SMatrix<f64, R, C> {
        SMatrix::from_fn(|_, _| self.next())
    }
    fn spd<const N: usize>(&mut self) -> SMatrix<f64, N, N> {
        let a: SMatrix<f64, N, N> = self.mat();
        a * a.transpose() + SMatrix::identity() * 0.1
    }
}

/// INS-like 15-state transition F = I + F_c dt (pos, vel, att, b_a, b_g; NED),
/// psi-angle error-model block structure (Groves ch. 14; Titterton & Weston ch. 12).
fn ins_f(rng: &mut Rng) -> SMatrix<f64, 15, 15> {
    let dt = 0.01;
    let mut fc = SMatrix::<f64, 15, 15>::zeros();
    let c_bn = crate::attitude::dcm_from_euler(&crate::Vec3::new(0.1, -0.05, 1.2));
    let f_n = crate::Vec3::new(0.3, -0.2, -9.8);
    let w_in = crate::Vec3::new(5e-5, 1e-6, -4e-5);
    for i in 0..3 {
        fc[(i, 3 + i)] = 1.0;
    }
    fc.fixed_view_mut::<3, 3>(3, 6)
        .copy_from(&crate::attitude::skew(&f_n));
    fc.fixed_view_mut::<3, 3>(3, 3)
        .copy_from(&(-crate::attitude::skew(&(w_in * 2.0))));
    fc.fixed_view_mut::<3, 3>(3, 9).copy_from(&c_bn);
    fc.fixed_view_mut::<3, 3>(6, 6)
        .copy_from(&(-crate::attitude::skew(&w_in)));
    fc.fixed_view_mut::<3, 3>(6, 12).copy_from(&(-c_bn));
    for i in 9..15 {
        fc[(i, i)] = -1.0 / (3600.0 + 100.0 * rng.next());
    }
    SMatrix::identity() + fc * dt
}

fn max_abs<const R: usize, const C: usize>(m: &SMatrix<f64, R, C>) -> f64 {
    m.abs().max()
}

#[test]
fn predict_matches_formula_and_is_symmetric() {
    let mut rng = Rng(7);
    let f: SMatrix<f64, 5, 5> = rng.mat();
    let q = rng.spd::<5>();
    let p0 = rng.spd::<5>();
    let mut p = p0;
    predict(&mut p, &f, &q);
    let expect = f * p0 * f.transpose() + q;
    assert!(max_abs(&(p - expect)) < 1e-13);
    assert_eq!(p, p.transpose());
    // Scalar: P = 2² · 3 + 0.5.
    let mut p1 = m1(3.0);
    predict(&mut p1, &m1(2.0), &m1(0.5));
    assert_eq!(p1[(0, 0)], 12.5);
}

#[test]
fn predict_sparse_equals_plain() {
    let mut rng = Rng(11);
    for trial in 0..20 {
        let f = if trial % 2 == 0 {
            ins_f(&mut rng)
        } else {
            rng.mat()
        };
        let q = rng.spd::<15>() * 1e-4;
        let p0 = rng.spd::<15>();
        let (mut a, mut b) = (p0, p0);
        predict(&mut a, &f, &q);
        predict_sparse(&mut b, &f, &q);
        let scale = max_abs(&a);
        assert!(max_abs(&(a - b)) < 1e-14 * scale, "trial {trial}");
        assert_eq!(b, b.transpose());
    }
    // Entries of F that are exactly zero in a whole row/column.
    let mut f = SMatrix::<f64, 4, 4>::zeros();
    f[(0, 3)] = 2.0;
    f[(2, 2)] = -1.0;
    let p0 = rng.spd::<4>();
    let q = SMatrix::<f64, 4, 4>::identity();
    let (mut a, mut b) = (p0, p0);
    predict(&mut a, &f, &q);
    predict_sparse(&mut b, &f, &q);
    assert!(max_abs(&(a - b)) < 1e-14);
}

#[test]
fn scalar_update_known_values() {
    let mut x = vv([0.0]);
    let mut p = m1(4.0);
    let info = update_joseph(&mut x, &mut p, &m1(1.0), &m1(1.0), &vv([2.0]), None);
    // S = 5, K = 0.8, x = 1.6, P = 0.2²·4 + 0.8²·1 = 0.8, NIS = 4/5.
    assert!(info.accepted);
    assert!((info.nis - 0.8).abs() < 1e-15);
    assert!((x[0] - 1.6).abs() < 1e-15);
    assert!((p[(0, 0)] - 0.8).abs() < 1e-15);
}

#[test]
fn joseph_matches_reference_forms() {
    let mut rng = Rng(3);
    for _ in 0..20 {
        let p0 = rng.spd::<15>();
        let x0: SVector<f64, 15> = rng.mat();
        let h: SMatrix<f64, 6, 15> = rng.mat();
        let r = rng.spd::<6>();
        let nu: SVector<f64, 6> = rng.mat();
        let (mut x, mut p) = (x0, p0);
        let info = update_joseph(&mut x, &mut p, &h, &r, &nu, None);
        assert!(info.accepted);
        // Reference with explicit inverses.
        let s = h * p0 * h.transpose() + r;
        let s_inv = s.try_inverse().unwrap();
        let k = p0 * h.transpose() * s_inv;
        let a = SMatrix::<f64, 15, 15>::identity() - k * h;
        let joseph = a * p0 * a.transpose() + k * r * k.transpose();
        let standard = p0 - k * s * k.transpose();
        let scale = max_abs(&p0);
        assert!(max_abs(&(p - joseph)) < 1e-11 * scale);
        assert!(max_abs(&(p - standard)) < 1e-11 * scale);
        assert!(max_abs(&(x - (x0 + k * nu))) < 1e-11);
        assert!((info.nis - (nu.transpose() * s_inv * nu)[(0, 0)]).abs() < 1e-10 * info.nis);
        assert_eq!(p, p.transpose());
    }
}

#[test]
fn gate_rejects_and_leaves_state_untouched() {
    let mut x = vv([1.0, 2.0]);
    let mut p = SMatrix::<f64, 2, 2>::identity();
    let h = SMatrix::<f64, 1, 2>::new(1.0, 0.0);
    let r = m1(1.0);
    let g = chi2_quantile(1, 0.99);
    // ν = 10 → NIS = 100/2 = 50 > 6.63.
    let info = update_joseph(&mut x, &mut p, &h, &r, &vv([10.0]), Some(g));
    assert!(!info.accepted && info.gated() && !info.singular());
    assert!((info.nis - 50.0).abs() < 1e-12);
    assert_eq!(x, vv([1.0, 2.0]));
    assert_eq!(p, SMatrix::<f64, 2, 2>::identity());
    // ν = 1 → NIS = 0.5 passes the same gate.
    let info = update_joseph(&mut x, &mut p, &h, &r, &vv([1.0]), Some(g));
    assert!(info.accepted);
    assert!((x[0] - 1.5).abs() < 1e-15);
}

#[test]
fn non_pd_innovation_covariance_is_rejected() {
    let mut x = vv([1.0, 2.0]);
    let mut p = SMatrix::<f64, 2, 2>::zeros();
    let h = SMatrix::<f64, 2, 2>::identity();
    for r in [
        SMatrix::<f64, 2, 2>::zeros(),
        -SMatrix::<f64, 2, 2>::identity(),
    ] {
        let info = update_joseph(&mut x, &mut p, &h, &r, &vv([1.0, 1.0]), None);
        assert!(!info.accepted && info.singular() && !info.gated());
        assert_eq!(x, vv([1.0, 2.0]));
        assert_eq!(p, SMatrix::<f64, 2, 2>::zeros());
    }
    // NaN innovation: rejected, state untouched.
    let mut p = SMatrix::<f64, 2, 2>::identity();
    let info = update_joseph(
        &mut x,
        &mut p,
        &h,
        &SMatrix::identity(),
        &vv([f64::NAN, 0.0]),
        None,
    );
    assert!(!info.accepted && info.gated());
    assert_eq!(x, vv([1.0, 2.0]));
    assert_eq!(p, SMatrix::<f64, 2, 2>::identity());
}

#[test]
fn chi2_quantile_table_values() {
    // Standard χ² table (upper critical values, 3 decimals).
    let table: &[(usize, f64, f64)] = &[
        (1, 0.90, 2.706),
        (1, 0.95, 3.841),
        (1, 0.99, 6.635),
        (1, 0.999, 10.828),
        (2, 0.99, 9.210),
        (3, 0.90, 6.251),
        (3, 0.95, 7.815),
        (3, 0.99, 11.345),
        (3, 0.999, 16.266),
        (5, 0.90, 9.236),
        (5, 0.95, 11.070),
        (5, 0.99, 15.086),
        (5, 0.999, 20.515),
        (6, 0.999, 22.458),
        (7, 0.95, 14.067),
        (9, 0.99, 21.666),
        (10, 0.95, 18.307),
        (15, 0.99, 30.578),
        (20, 0.999, 45.315),
        (25, 0.95, 37.652),
        (29, 0.999, 58.301),
        (30, 0.90, 40.256),
        (30, 0.99, 50.892),
        (30, 0.999, 59.703),
    ];
    for &(k, p, v) in table {
        let q = chi2_quantile(k, p);
        assert!((q - v).abs() <= 6e-4, "chi2({k}, {p}) = {q}, table {v}");
    }
    // χ²₁ at 1 − 1e-5: z² with z = 4.41717 (normal 0.999995 quantile).
    let q = chi2_quantile(1, 0.99999);
    assert!((q - 4.41717_f64.powi(2)).abs() < 1e-3, "{q}");
}

#[test]
fn chi2_even_dof_closed_form() {
    // For k = 2m: Q(x) = e^{−x/2} Σ_{j<m} (x/2)^j / j!  (independent of the gamma code).
    let ps = [0.9, 0.95, 0.99, 0.995, 0.999, 0.9999, 0.99999];
    for m in 1..=15 {
        for &p in &ps {
            let x = chi2_quantile(2 * m, p);
            let h = 0.5 * x;
            let mut term = 1.0;
            let mut sum = 1.0;
            for j in 1..m {
                term *= h / j as f64;
                sum += term;
            }
            let q = (-h).exp() * sum;
            assert!(
                ((q - (1.0 - p)) / (1.0 - p)).abs() < 1e-9,
                "k={} p={p}",
                2 * m
            );
        }
    }
    assert!((chi2_quantile(2, 0.99) + 2.0 * 0.01f64.ln()).abs() < 1e-10);
}

#[test]
fn chi2_cdf_inverts_quantile_and_edges() {
    for k in 1..=30 {
        for &p in &[0.001, 0.3, 0.5, 0.9, 0.99, 0.99999] {
            let x = chi2_quantile(k, p);
            assert!(
                (chi2_cdf(k, x) - p).abs() < 1e-10 * p.max(1e-3),
                "k={k} p={p}"
            );
            assert!(
                (chi2_sf(k, x) - (1.0 - p)).abs() < 1e-9 * (1.0 - p),
                "k={k} p={p}"
            );
        }
        // Monotone in p.
        assert!(chi2_quantile(k, 0.999) > chi2_quantile(k, 0.99));
    }
    assert_eq!(chi2_quantile(3, 0.0), 0.0);
    assert_eq!(chi2_quantile(3, 1.0), f64::INFINITY);
    assert_eq!(chi2_quantile(0, 0.5), 0.0);
    assert!(chi2_quantile(3, f64::NAN).is_nan());
    assert_eq!(chi2_cdf(4, 0.0), 0.0);
    assert_eq!(chi2_cdf(4, f64::INFINITY), 1.0);
}

// ---------------------------------------------------------------------------
// RTS smoother against an independent batch least-squares solution.

/// Constant-velocity model with white-noise acceleration (discrete white-noise acceleration).
fn cv_model(dt: f64, q: f64) -> (Matrix2<f64>, Matrix2<f64>) {
    let f = Matrix2::new(1.0, dt, 0.0, 1.0);
    let qd = Matrix2::new(
        q * dt.powi(3) / 3.0,
        q * dt * dt / 2.0,
        q * dt * dt / 2.0,
        q * dt,
    );
    (f, qd)
}

#[test]
fn rts_matches_batch_least_squares() {
    let (f, qd) = cv_model(0.5, 0.3);
    let h = SMatrix::<f64, 1, 2>::new(1.0, 0.0);
    let r = m1(0.8);
    let m0 = vv([1.0, -0.5]);
    let p0 = Matrix2::new(4.0, 0.5, 0.5, 2.0);
    let k_steps = 40;
    let mut rng = Rng(99);
    // Measurements (some epochs without).
    let z: Vec<Option<f64>> = (0..k_steps)
        .map(|k| {
            if k % 7 == 3 {
                None
            } else {
                Some(1.0 + 0.4 * k as f64 + 0.9 * rng.next())
            }
        })
        .collect();

    // Forward filter + store.
    let mut store = RtsStore::<2>::with_capacity(k_steps);
    let (mut x, mut p) = (m0, p0);
    let mut filtered = Vec::new();
    for (k, zk) in z.iter().enumerate() {
        if k > 0 {
            x = f * x;
            predict(&mut p, &f, &qd);
        }
        let (xp, pp) = (x, p);
        if let Some(zk) = zk {
            let nu = SVector::<f64, 1>::new(zk - (h * x)[0]);
            assert!(update_joseph(&mut x, &mut p, &h, &r, &nu, None).accepted);
        }
        store.push(k as f64, &f, &xp, &pp, &x, &p);
        filtered.push(p);
    }
    let smoothed = store.smooth().unwrap();
    assert_eq!(smoothed.len(), k_steps);

    // Batch: minimise |x0 − m0|²_{P0⁻¹} + Σ|x_{k+1} − F x_k|²_{Q⁻¹} + Σ|z_k − H x_k|²_{R⁻¹}.
    let n = 2 * k_steps;
    let mut lam = DMatrix::<f64>::zeros(n, n);
    let mut eta = DVector::<f64>::zeros(n);
    let p0i = p0.try_inverse().unwrap();
    let qi = qd.try_inverse().unwrap();
    let ri = 1.0 / r[(0, 0)];
    {
        let mut b = lam.fixed_view_mut::<2, 2>(0, 0);
        b += p0i;
    }
    {
        let mut e = eta.fixed_rows_mut::<2>(0);
        e += p0i * m0;
    }
    for k in 0..k_steps {
        if let Some(zk) = z[k] {
            lam[(2 * k, 2 * k)] += ri;
            eta[2 * k] += ri * zk;
        }
        if k + 1 < k_steps {
            // Residual x_{k+1} − F x_k: blocks [−F, I].
            let a = -f;
            let (i, j) = (2 * k, 2 * k + 2);
            let aa = a.transpose() * qi * a;
            let ab = a.transpose() * qi;
            let bb = qi;
            for (ro, co, blk) in [(i, i, aa), (i, j, ab), (j, i, ab.transpose()), (j, j, bb)] {
                let mut v = lam.fixed_view_mut::<2, 2>(ro, co);
                v += blk;
            }
        }
    }
    let cov = lam.clone().try_inverse().unwrap();
    let xb = &cov * &eta;

    for k in 0..k_steps {
        let s = &smoothed[k];
        assert_eq!(s.t, k as f64);
        let dx = (s.x - vv([xb[2 * k], xb[2 * k + 1]])).norm();
        assert!(dx < 1e-9, "step {k}: state differs by {dx}");
        let pb = cov.fixed_view::<2, 2>(2 * k, 2 * k).into_owned();
        assert!(max_abs(&(s.p - pb)) < 1e-9, "step {k}: covariance differs");
        // Smoothing never increases uncertainty: P_f − P_s ⪰ 0.
        let diff = filtered[k] - s.p;
        let ev = diff.symmetric_eigenvalues();
        assert!(ev.min() > -1e-12, "step {k}: {ev}");
    }
    // Strictly better than filtering away from the last epoch.
    assert!(smoothed[0].p[(0, 0)] < filtered[0][(0, 0)] * 0.9);
    assert_eq!(smoothed[k_steps - 1].p, filtered[k_steps - 1]);
}

#[test]
fn rts_scalar_random_walk_and_errors() {
    // Scalar random walk, measured every step: a smoothed interior point uses
    // both sides; with equal Q, R the steady-state interior variance is known.
    let f = m1(1.0);
    let q = m1(1.0);
    let r = m1(1.0);
    let h = m1(1.0);
    let mut store = RtsStore::<1>::new();
    assert!(store.smooth().unwrap().is_empty());
    let (mut x, mut p) = (vv([0.0]), m1(100.0));
    for k in 0..200 {
        if k > 0 {
            predict(&mut p, &f, &q);
        }
        let (xp, pp) = (x, p);
        let nu = SVector::<f64, 1>::new(((k * 37) % 11) as f64 - 5.0 - x[0]);
        update_joseph(&mut x, &mut p, &h, &r, &nu, None);
        store.push(k as f64, &f, &xp, &pp, &x, &p);
    }
    let s = store.smooth().unwrap();
    // Steady-state filtered variance for q = r = 1: P⁺ = (√5 − 1)/2; the
    // smoothed interior variance is 1/√5 (two-sided information).
    let pf = p[(0, 0)];
    assert!((pf - (5f64.sqrt() - 1.0) / 2.0).abs() < 1e-12);
    assert!(
        (s[100].p[(0, 0)] - 1.0 / 5f64.sqrt()).abs() < 1e-12,
        "{}",
        s[100].p[(0, 0)]
    );

    // A singular predicted covariance is reported with its index.
    let mut bad = RtsStore::<1>::new();
    let z = SMatrix::<f64, 1, 1>::zeros();
    let x0 = SVector::<f64, 1>::zeros();
    bad.push_initial(0.0, &x0, &m1(1.0));
    bad.push(1.0, &f, &x0, &z, &x0, &z);
    bad.push(2.0, &f, &x0, &m1(1.0), &x0, &m1(1.0));
    assert_eq!(bad.smooth(), Err(RtsError::SingularPrediction { step: 1 }));
}

#[test]
fn joseph_keeps_covariance_psd_under_precise_measurements() {
    // Large prior, near-perfect measurements of combinations of states: the
    // conventional (I − K H) P form is prone to losing symmetry/definiteness
    // here; the Joseph form must keep P symmetric and PSD.
    let mut rng = Rng(21);
    let mut x = SVector::<f64, 6>::zeros();
    let mut p = rng.spd::<6>() * 1e6;
    for step in 0..50 {
        let h: SMatrix<f64, 2, 6> = rng.mat();
        let r = SMatrix::<f64, 2, 2>::identity() * 1e-10;
        let nu: SVector<f64, 2> = rng.mat();
        let info = update_joseph(&mut x, &mut p, &h, &r, &nu, None);
        assert!(info.accepted, "step {step}");
        assert_eq!(p, p.transpose());
        let ev = p.symmetric_eigenvalues();
        assert!(ev.min() > -1e-9 * ev.max().max(1.0), "step {step}: {ev}");
        predict(&mut p, &SMatrix::identity(), &(SMatrix::identity() * 1e-8));
    }
}
