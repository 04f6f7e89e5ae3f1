//! CP-ATT: GPS carrier-phase multi-antenna attitude (seed 003, `SEEDS.md §3`).
//!
//! Frames: navigation ENU at the master antenna (x east, y north, z up);
//! body frame of the paper (its eq. 1: yaw ψ about z, pitch θ about x, roll φ
//! about y; `b_b = C_nb · b_n`). Baselines are slave − master.
//!
//! Per baseline a float Kalman filter (eq. 11–12): state
//! `X = [x (3), ẋ (3), λ∇ΔN (n−1)]` in metres, `F = [[I, ΔT I, 0],[0, I, 0],[0, 0, I]]`,
//! `Q = [[qΔT³/3 I, qΔT²/2 I, 0],[qΔT²/2 I, qΔT I, 0],[0, 0, 1e-10 I]]`,
//! `H = [ΔS, 0, I]`, `R = (2σ)² I` (or the exact DD covariance). The state has
//! a fixed maximum size ([`NS`]) with an active count, so an epoch allocates
//! nothing. When the satellite set or its elevation order changes, the
//! ambiguity states are mapped linearly to the new differences (the map is
//! integer and unimodular for kept satellites); a rising satellite gets a new
//! state with a wide prior, a setting one is dropped — the filter never restarts.
//!
//! Attitude: the paper's least squares `C_nb = R_b R_nᵀ (R_n R_nᵀ)⁻¹` (eq. 4)
//! and its angles (eq. 2); or Wahba/SVD with the known body geometry.
//! Measurement sign: the single difference is `Δφ = φ_master − φ_slave` [m],
//! so `Δφ − λΔN = sᵀ b` with `s` the ENU unit vector master → satellite.

#![allow(clippy::needless_range_loop)] // index loops mirror the matrix equations

use crate::gnss::dd::{dd_covariance, DdNoise, MAX_DD, MAX_SATS};
#[allow(unused_imports)]
use crate::prelude::*;
use crate::{Mat3, Vec3};
use nalgebra::{SMatrix, SVector};

/// Filter state size: baseline (3) + rate (3) + up to `MAX_DD` ambiguities.
pub const NS: usize = 6 + MAX_DD;
/// Largest number of baselines (slave antennas).
pub const MAX_BASELINES: usize = 4;

type StateVec = SVector<f64, NS>;
type StateMat = SMatrix<f64, NS, NS>;
type DdVec = SVector<f64, MAX_DD>;
type DdMat = SMatrix<f64, MAX_DD, MAX_DD>;

/// Configuration of the seed 003 float filter (defaults: the paper's values).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CpAttConfig {
    /// Spectral density q of the baseline acceleration noise (paper: 0.02).
    pub q: f64,
    /// Ambiguity process noise per epoch [m²] (paper: 1e-10).
    pub q_amb: f64,
    /// DD covariance model (paper: diagonal (2σ)²).
    pub dd_noise: DdNoise,
    /// A-priori σ of each baseline component at start [m].
    pub sigma_baseline0: f64,
    /// A-priori σ of the baseline rate at start [m/s].
    pub sigma_rate0: f64,
    /// Prior σ of a newly risen satellite's ambiguity beyond what the
    /// baseline predicts [m].
    pub sigma_new_amb: f64,
}

impl Default for CpAttConfig {
    fn default() -> Self {
        CpAttConfig {
            q: 0.02,
            q_amb: 1e-10,
            dd_noise: DdNoise::PaperDiagonal,
            sigma_baseline0: 1.0,
            sigma_rate0: 0.1,
            sigma_new_amb: 1.0,
        }
    }
}

/// One carrier-phase epoch for all baselines, satellites ordered by
/// decreasing elevation (the paper's DD order).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CpEpoch {
    /// GPS time [s].
    pub t: f64,
    /// Number of satellites used (≤ `MAX_SATS`).
    pub n_sats: usize,
    pub prn: [u8; MAX_SATS],
    /// ENU unit line of sight master → satellite.
    pub los_enu: [Vec3; MAX_SATS],
    /// Undifferenced phase σ per satellite [m] (for R).
    pub sigma: [f64; MAX_SATS],
    /// Number of baselines.
    pub n_baselines: usize,
    /// Single differences `φ_master − φ_slave` [m] per baseline and satellite.
    pub sd_phase: [[f64; MAX_SATS]; MAX_BASELINES],
}

impl Default for CpEpoch {
    fn default() -> Self {
        CpEpoch {
            t: 0.0,
            n_sats: 0,
            prn: [0; MAX_SATS],
            los_enu: [Vec3::zeros(); MAX_SATS],
            sigma: [0.0; MAX_SATS],
            n_baselines: 0,
            sd_phase: [[0.0; MAX_SATS]; MAX_BASELINES],
        }
    }
}

/// The float filter of one baseline (eq. 11–12).
#[derive(Clone, Debug)]
pub struct BaselineFilter {
    /// State: baseline ENU [m], rate [m/s], DD ambiguities λ∇ΔN [m].
    pub x: StateVec,
    /// Covariance.
    pub p: StateMat,
    /// PRNs of the current DD set, ordered as the ambiguity states.
    pub prn: [u8; MAX_SATS],
    /// Number of satellites (ambiguity states = `n_sats − 1`).
    pub n_sats: usize,
    t_last: f64,
    initialized: bool,
    /// Number of times the satellite set or order changed (state re-mapped).
    pub remaps: u32,
}

impl Default for BaselineFilter {
    fn default() -> Self {
        BaselineFilter {
            x: StateVec::zeros(),
            p: StateMat::zeros(),
            prn: [0; MAX_SATS],
            n_sats: 0,
            t_last: 0.0,
            initialized: false,
            remaps: 0,
        }
    }
}

impl BaselineFilter {
    /// Baseline estimate, ENU [m].
    pub fn baseline(&self) -> Vec3 {
        Vec3::new(self.x[0], self.x[1], self.x[2])
    }

    /// Number of active ambiguity states.
    pub fn n_amb(&self) -> usize {
        self.n_sats.saturating_sub(1)
    }

    /// Start from the first epoch: baseline ~ N(0, σ_b² I), ambiguities from
    /// the measurement `a = z − ΔS·0` with the covariance that prior implies
    /// (so the first epoch is used once, here).
    fn initialize(&mut self, ep: &CpEpoch, k: usize, cfg: &CpAttConfig) {
        let n = ep.n_sats;
        self.x = StateVec::zeros();
        self.p = StateMat::zeros();
        let pb = cfg.sigma_baseline0 * cfg.sigma_baseline0;
        for i in 0..3 {
            self.p[(i, i)] = pb;
            self.p[(3 + i, 3 + i)] = cfg.sigma_rate0 * cfg.sigma_rate0;
        }
        let r = dd_covariance(&ep.sigma[..n], cfg.dd_noise);
        for i in 0..n - 1 {
            let ds = ep.los_enu[i] - ep.los_enu[i + 1];
            self.x[6 + i] = ep.sd_phase[k][i] - ep.sd_phase[k][i + 1];
            for c in 0..3 {
                // a = z − ΔS b  ⇒  cov(a, b) = −ΔS P_bb
                self.p[(6 + i, c)] = -ds[c] * pb;
                self.p[(c, 6 + i)] = -ds[c] * pb;
            }
            for j in 0..n - 1 {
                let dsj = ep.los_enu[j] - ep.los_enu[j + 1];
                self.p[(6 + i, 6 + j)] = ds.dot(&dsj) * pb + r[(i, j)];
            }
        }
        self.prn = ep.prn;
        self.n_sats = n;
        self.t_last = ep.t;
        self.initialized = true;
    }

    /// Time update (eq. 11): `X⁻ = F X`, `P⁻ = F P Fᵀ + Q` over the active states.
    fn predict(&mut self, dt: f64, cfg: &CpAttConfig) {
        if dt <= 0.0 {
            return;
        }
        for i in 0..3 {
            self.x[i] += dt * self.x[3 + i];
        }
        // P ← F P Fᵀ with F = I + dt·E(0..3, 3..6), in place.
        for c in 0..NS {
            for i in 0..3 {
                self.p[(i, c)] += dt * self.p[(3 + i, c)];
            }
        }
        for r in 0..NS {
            for i in 0..3 {
                self.p[(r, i)] += dt * self.p[(r, 3 + i)];
            }
        }
        let q = cfg.q;
        for i in 0..3 {
            self.p[(i, i)] += q * dt * dt * dt / 3.0;
            self.p[(i, 3 + i)] += q * dt * dt / 2.0;
            self.p[(3 + i, i)] += q * dt * dt / 2.0;
            self.p[(3 + i, 3 + i)] += q * dt;
        }
        for i in 0..self.n_amb() {
            self.p[(6 + i, 6 + i)] += cfg.q_amb;
        }
    }

    /// Map the ambiguity states to the new satellite list of `ep` (rising,
    /// setting, reordered). Returns false when no satellite is kept (then the
    /// caller re-initialises).
    fn remap(&mut self, ep: &CpEpoch, k: usize, cfg: &CpAttConfig) -> bool {
        let n_new = ep.n_sats;
        if n_new == self.n_sats && ep.prn[..n_new] == self.prn[..n_new] {
            return true;
        }
        // Potential of each satellite, p(s) = SDamb(ref) − SDamb(s), ref = old[0],
        // as a row over the old state plus a constant and a fresh-noise flag.
        let old_pos = |prn: u8| self.prn[..self.n_sats].iter().position(|&p| p == prn);
        let Some(anchor) = (0..n_new).find(|&i| old_pos(ep.prn[i]).is_some()) else {
            return false;
        };
        // Measured SD-phase differences relative to the first new satellite.
        let mut rows = [SVector::<f64, NS>::zeros(); MAX_SATS];
        let mut cons = [0.0f64; MAX_SATS];
        let mut fresh = [false; MAX_SATS];
        let anchor_prn = ep.prn[anchor];
        let ja = old_pos(anchor_prn).unwrap_or(0);
        for (s, row) in rows.iter_mut().enumerate().take(n_new) {
            if let Some(j) = old_pos(ep.prn[s]) {
                for i in 0..j {
                    row[6 + i] = 1.0;
                }
            } else {
                // p(c) = p(a) + (SDamb(a) − SDamb(c)), with
                // SDamb(a) − SDamb(c) = (Δφ_a − Δφ_c) − (s_a − s_c)ᵀ b + w.
                for i in 0..ja {
                    row[6 + i] = 1.0;
                }
                let ds = ep.los_enu[anchor] - ep.los_enu[s];
                for c in 0..3 {
                    row[c] = -ds[c];
                }
                cons[s] = ep.sd_phase[k][anchor] - ep.sd_phase[k][s];
                fresh[s] = true;
            }
        }
        // New DD_i = p(new[i+1]) − p(new[i]).
        let mut a = StateMat::zeros();
        let mut x_new = StateVec::zeros();
        for i in 0..6 {
            a[(i, i)] = 1.0;
        }
        for i in 0..n_new - 1 {
            let r = rows[i + 1] - rows[i];
            for c in 0..NS {
                a[(6 + i, c)] = r[c];
            }
            x_new[6 + i] = cons[i + 1] - cons[i];
        }
        x_new += a * self.x;
        let mut p_new = a * self.p * a.transpose();
        let w = cfg.sigma_new_amb * cfg.sigma_new_amb;
        for i in 0..n_new - 1 {
            for j in 0..n_new - 1 {
                let coef = |d: usize, s: usize| -> f64 {
                    (if d + 1 == s { 1.0 } else { 0.0 }) - (if d == s { 1.0 } else { 0.0 })
                };
                let mut v = 0.0;
                for s in 0..n_new {
                    if fresh[s] {
                        v += coef(i, s) * coef(j, s) * w;
                    }
                }
                p_new[(6 + i, 6 + j)] += v;
            }
        }
        self.x = x_new;
        self.p = p_new;
        self.prn = ep.prn;
        self.n_sats = n_new;
        self.remaps += 1;
        true
    }

    /// Measurement update (eq. 12) with the DDs of baseline `k` of `ep`,
    /// Joseph form. Returns the normalised innovation squared.
    fn correct(&mut self, ep: &CpEpoch, k: usize, cfg: &CpAttConfig) -> f64 {
        let n = ep.n_sats;
        let m = n - 1;
        let r: DdMat = dd_covariance(&ep.sigma[..n], cfg.dd_noise);
        let mut h = SMatrix::<f64, MAX_DD, NS>::zeros();
        let mut z = DdVec::zeros();
        for i in 0..m {
            let ds = ep.los_enu[i] - ep.los_enu[i + 1];
            for c in 0..3 {
                h[(i, c)] = ds[c];
            }
            h[(i, 6 + i)] = 1.0;
            z[i] = ep.sd_phase[k][i] - ep.sd_phase[k][i + 1];
        }
        let innov = z - h * self.x;
        let ph = self.p * h.transpose();
        let s = h * ph + r;
        let Some(chol) = s.cholesky() else {
            return f64::NAN;
        };
        let k_gain = chol.solve(&ph.transpose()).transpose();
        let nis = innov.dot(&chol.solve(&innov));
        self.x += k_gain * innov;
        let ikh = StateMat::identity() - k_gain * h;
        self.p = ikh * self.p * ikh.transpose() + k_gain * r * k_gain.transpose();
        nis
    }

    /// Process one epoch for baseline `k`: initialise, or predict, re-map and correct.
    pub fn update(&mut self, ep: &CpEpoch, k: usize, cfg: &CpAttConfig) -> f64 {
        if ep.n_sats < 2 {
            return f64::NAN;
        }
        if !self.initialized {
            self.initialize(ep, k, cfg);
            return 0.0;
        }
        self.predict(ep.t - self.t_last, cfg);
        self.t_last = ep.t;
        if !self.remap(ep, k, cfg) {
            self.initialize(ep, k, cfg);
            return 0.0;
        }
        self.correct(ep, k, cfg)
    }

    /// Float DD ambiguities [m] and their covariance block, active part only.
    pub fn ambiguities(&self) -> (DdVec, DdMat, usize) {
        let m = self.n_amb();
        let mut a = DdVec::zeros();
        let mut q = DdMat::zeros();
        for i in 0..m {
            a[i] = self.x[6 + i];
            for j in 0..m {
                q[(i, j)] = self.p[(6 + i, 6 + j)];
            }
        }
        (a, q, m)
    }
}

/// The paper's DCM `C_nb = C(φ) C(θ) C(ψ)` (eq. 1; ψ about z, θ about x,
/// φ about y), `b_b = C_nb b_n`, n = ENU.
pub fn paper_dcm_nb(roll: f64, pitch: f64, yaw: f64) -> Mat3 {
    let (sp, cp) = (roll.sin(), roll.cos());
    let (st, ct) = (pitch.sin(), pitch.cos());
    let (sy, cy) = (yaw.sin(), yaw.cos());
    let c_psi = Mat3::new(cy, sy, 0.0, -sy, cy, 0.0, 0.0, 0.0, 1.0);
    let c_theta = Mat3::new(1.0, 0.0, 0.0, 0.0, ct, st, 0.0, -st, ct);
    let c_phi = Mat3::new(cp, 0.0, -sp, 0.0, 1.0, 0.0, sp, 0.0, cp);
    c_phi * c_theta * c_psi
}

/// The paper's angles (eq. 2): φ = −atan(C13/C33), θ = asin(C23),
/// ψ = −atan(C21/C22), as four-quadrant arctangents. Returns (roll, pitch, yaw) [rad].
pub fn paper_euler(c_nb: &Mat3) -> Vec3 {
    let roll = (-c_nb[(0, 2)]).atan2(c_nb[(2, 2)]);
    let pitch = c_nb[(1, 2)].clamp(-1.0, 1.0).asin();
    let yaw = (-c_nb[(1, 0)]).atan2(c_nb[(1, 1)]);
    Vec3::new(roll, pitch, yaw)
}

/// The paper's least-squares DCM (eq. 4): `C_nb = R_b R_nᵀ (R_n R_nᵀ)⁻¹` from
/// three body baselines `b_b` and their navigation-frame estimates `b_n`
/// (`attitude::dcm_from_baselines_ls`). Not orthonormal in general. `None`
/// when singular or not three baselines.
pub fn ls_dcm(b_b: &[Vec3], b_n: &[Vec3]) -> Option<Mat3> {
    if b_b.len() != 3 || b_n.len() != 3 {
        return None;
    }
    let r_b = Mat3::from_columns(b_b);
    let r_n = Mat3::from_columns(b_n);
    crate::attitude::dcm_from_baselines_ls::<3>(&r_b, &r_n)
}

/// Wahba's problem by SVD (`attitude::wahba_svd`, Markley 1988) in the
/// paper's direction: the rotation `C_nb` minimising `Σ wᵢ |b_b,i − C_nb b_n,i|²`.
pub fn wahba_nb(b_b: &[Vec3], b_n: &[Vec3], w: &[f64]) -> Option<Mat3> {
    crate::attitude::wahba_svd(b_b, b_n, w).map(|c_bn| c_bn.transpose())
}

/// Attitude output of one epoch.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct CpAttSolution {
    pub t: f64,
    /// Paper's (roll, pitch, yaw) [rad] from the float baselines by eq. 4 and eq. 2.
    pub rpy_float: Vec3,
    /// Float baselines, ENU [m].
    pub b_n_float: [Vec3; MAX_BASELINES],
    pub n_sats: usize,
}

/// The seed 003 estimator: one float filter per baseline and the paper's
/// least-squares attitude.
#[derive(Clone, Debug)]
pub struct CpAttitude {
    pub cfg: CpAttConfig,
    /// Body-frame baselines (slave − master) [m].
    pub b_b: [Vec3; MAX_BASELINES],
    pub n_baselines: usize,
    pub filters: [BaselineFilter; MAX_BASELINES],
}

impl CpAttitude {
    /// A new estimator for the body baselines `b_b` (≤ `MAX_BASELINES`).
    pub fn new(cfg: CpAttConfig, b_b: &[Vec3]) -> Self {
        let mut bb = [Vec3::zeros(); MAX_BASELINES];
        let n = b_b.len().min(MAX_BASELINES);
        bb[..n].copy_from_slice(&b_b[..n]);
        CpAttitude {
            cfg,
            b_b: bb,
            n_baselines: n,
            filters: core::array::from_fn(|_| BaselineFilter::default()),
        }
    }

    /// Feed one epoch; returns the float attitude (NaN when fewer than 3 baselines).
    pub fn update(&mut self, ep: &CpEpoch) -> CpAttSolution {
        let nb = self.n_baselines.min(ep.n_baselines);
        let mut sol = CpAttSolution {
            t: ep.t,
            n_sats: ep.n_sats,
            rpy_float: Vec3::repeat(f64::NAN),
            ..Default::default()
        };
        for k in 0..nb {
            self.filters[k].update(ep, k, &self.cfg);
            sol.b_n_float[k] = self.filters[k].baseline();
        }
        if nb >= 3 {
            if let Some(c) = ls_dcm(&self.b_b[..nb], &sol.b_n_float[..nb]) {
                sol.rpy_float = paper_euler(&c);
            }
        }
        sol
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_dcm_matches_its_closed_form_and_eq2_inverts_it() {
        let (r, p, y) = (0.3, -0.2, 1.1);
        let c = paper_dcm_nb(r, p, y);
        let (sp, cp, st, ct, sy, cy) = (r.sin(), r.cos(), p.sin(), p.cos(), y.sin(), y.cos());
        // Rows 2 and 3 of the paper's C_{n→B}; row 2 typo-corrected (cθ sψ, cθ cψ).
        assert!((c[(1, 0)] + ct * sy).abs() < 1e-12);
        assert!((c[(1, 1)] - ct * cy).abs() < 1e-12);
        assert!((c[(1, 2)] - st).abs() < 1e-12);
        assert!((c[(0, 2)] + sp * ct).abs() < 1e-12);
        assert!((c[(2, 2)] - cp * ct).abs() < 1e-12);
        assert!((c[(0, 0)] - (cp * cy - sp * st * sy)).abs() < 1e-12);
        let e = paper_euler(&c);
        assert!((e - Vec3::new(r, p, y)).norm() < 1e-12);
    }

    #[test]
    fn ls_and_wahba_recover_exact_rotation() {
        let c = paper_dcm_nb(0.1, 0.2, -2.0);
        let b_b = [Vec3::x(), Vec3::y(), Vec3::new(0.0, 0.0, 1.0)];
        let b_n: [Vec3; 3] = core::array::from_fn(|i| c.transpose() * b_b[i]);
        let l = ls_dcm(&b_b, &b_n).unwrap();
        assert!((l - c).norm() < 1e-12);
        let w = wahba_nb(&b_b, &b_n, &[1.0; 3]).unwrap();
        assert!((w - c).norm() < 1e-12);
        // Two baselines still determine a rotation for Wahba, not for eq. 4.
        assert!(wahba_nb(&b_b[..2], &b_n[..2], &[1.0; 2]).is_some());
        assert!(ls_dcm(&b_b[..2], &b_n[..2]).is_none());
    }

    /// A static baseline under a fixed sky: the float filter converges to the
    /// truth, and survives a satellite setting and one rising.
    #[test]
    fn float_filter_converges_and_survives_set_changes() {
        let b_true = Vec3::new(0.6, -0.7, 0.2);
        // Satellites moving independently across the sky (non-rigid geometry change).
        let sky = |s: usize, e: usize| -> Vec3 {
            let el = 1.3 - 0.15 * s as f64 + 0.0015 * (s as f64 - 3.5) * e as f64;
            let az = 0.9 * s as f64 + 0.003 * (s % 3) as f64 * e as f64;
            Vec3::new(el.cos() * az.sin(), el.cos() * az.cos(), el.sin())
        };
        let amb: [f64; 8] = core::array::from_fn(|i| LAMBDA * ((i as f64 * 7.3) % 11.0 - 5.0));
        const LAMBDA: f64 = 0.190293673;
        let cfg = CpAttConfig {
            q: 1e-8,
            ..Default::default()
        };
        let mut f = BaselineFilter::default();
        for e in 0..200 {
            // Sats 0..6 at first; sat 3 sets at epoch 80; sat 7 rises at 120.
            let mut ep = CpEpoch {
                t: 10.0 * e as f64,
                n_baselines: 1,
                ..Default::default()
            };
            let mut n = 0;
            for s in 0..8 {
                let on = match s {
                    3 => e < 80,
                    7 => e >= 120,
                    _ => true,
                };
                if !on {
                    continue;
                }
                let l = sky(s, e);
                ep.prn[n] = s as u8 + 1;
                ep.los_enu[n] = l;
                ep.sigma[n] = 0.002;
                ep.sd_phase[0][n] = l.dot(&b_true) + amb[s];
                n += 1;
            }
            ep.n_sats = n;
            f.update(&ep, 0, &cfg);
            let (a, _, m) = f.ambiguities();
            if e > 150 {
                assert!(
                    (f.baseline() - b_true).norm() < 2e-3,
                    "{e}: {}",
                    f.baseline()
                );
                for i in 0..m {
                    let si = (f.prn[i] - 1) as usize;
                    let sj = (f.prn[i + 1] - 1) as usize;
                    assert!((a[i] - (amb[si] - amb[sj])).abs() < 2e-3);
                }
            }
        }
        assert_eq!(f.n_sats, 7);
        assert!(f.remaps >= 2);
    }
}
