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
//!
//! After the integer fix ("beyond" the paper): the fixed DD phases of all
//! baselines are mm-level ranges of the known rigid body, so the attitude is
//! estimated from all of them jointly with their exact covariance
//! (tridiagonal per baseline, correlated across baselines through the
//! master antenna; [`FixedDds`]) and carried across epochs by a rigid-body
//! multiplicative EKF ([`RigidAttFilter`], with an optional fixed-lag RTS
//! smoother [`AttSmoother`]). The earlier per-baseline LS + weighted Wahba
//! stays available (`CpAttSolution::rpy_wahba`).
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
    /// False-alarm probability of the cycle-slip NIS gate (0 = off; the
    /// paper has none).
    pub slip_gate: f64,
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
            slip_gate: 0.0,
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
    /// Number of ambiguities reset by the cycle-slip detector.
    pub slips_detected: u32,
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
            slips_detected: 0,
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

    /// Measurement model of the DDs of baseline `k` (eq. 11–12): `H`
    /// (LOS differences in ENU, +1 on the DD ambiguity in metres), the DDs
    /// `z` [m] and their covariance `R`; rows beyond `n − 1` are zero.
    #[allow(clippy::type_complexity)]
    fn dd_model(
        ep: &CpEpoch,
        k: usize,
        cfg: &CpAttConfig,
    ) -> (SMatrix<f64, MAX_DD, NS>, DdVec, DdMat) {
        let n = ep.n_sats;
        let r: DdMat = dd_covariance(&ep.sigma[..n], cfg.dd_noise);
        let mut h = SMatrix::<f64, MAX_DD, NS>::zeros();
        let mut z = DdVec::zeros();
        for i in 0..n - 1 {
            let ds = ep.los_enu[i] - ep.los_enu[i + 1];
            for c in 0..3 {
                h[(i, c)] = ds[c];
            }
            h[(i, 6 + i)] = 1.0;
            z[i] = ep.sd_phase[k][i] - ep.sd_phase[k][i + 1];
        }
        (h, z, r)
    }

    /// Measurement update (eq. 12) with the DDs of baseline `k` of `ep`,
    /// Joseph form. Returns the normalised innovation squared.
    fn correct(&mut self, ep: &CpEpoch, k: usize, cfg: &CpAttConfig) -> f64 {
        let (h, z, r) = Self::dd_model(ep, k, cfg);
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
        if cfg.slip_gate > 0.0 {
            self.detect_slips(ep, k, cfg);
        }
        self.correct(ep, k, cfg)
    }

    /// Normalised innovation squared of the DDs of baseline `k` against the
    /// current (predicted) state, without updating.
    fn nis(&self, ep: &CpEpoch, k: usize, cfg: &CpAttConfig) -> f64 {
        let (h, z, r) = Self::dd_model(ep, k, cfg);
        let innov = z - h * self.x;
        let s = h * self.p * h.transpose() + r;
        match s.cholesky() {
            Some(ch) => innov.dot(&ch.solve(&innov)),
            None => f64::NAN,
        }
    }

    /// Cycle-slip detection: when the predicted NIS exceeds the χ²(n−1)
    /// quantile of `cfg.slip_gate` (false-alarm probability, Wilson–Hilferty),
    /// the satellite whose ambiguity reset lowers the NIS most is treated as
    /// newly risen (fresh ambiguity), repeated up to 2 satellites per epoch.
    fn detect_slips(&mut self, ep: &CpEpoch, k: usize, cfg: &CpAttConfig) {
        let m = ep.n_sats - 1;
        if m < 4 {
            return;
        }
        for _ in 0..2 {
            let nis = self.nis(ep, k, cfg);
            let gate = chi2_quantile(m as f64, cfg.slip_gate);
            if nis.is_nan() || nis <= gate {
                return;
            }
            let mut best: Option<(usize, f64, Self)> = None;
            for s in 0..ep.n_sats {
                let mut trial = self.clone();
                trial.prn[s] = 0; // forget this satellite: re-mapped as new
                if !trial.remap(ep, k, cfg) {
                    continue;
                }
                let v = trial.nis(ep, k, cfg);
                if v.is_finite() && best.as_ref().map(|b| v < b.1).unwrap_or(true) {
                    best = Some((s, v, trial));
                }
            }
            let Some((_, _, trial)) = best else { return };
            let remaps = self.remaps;
            *self = trial;
            self.remaps = remaps;
            self.slips_detected += 1;
        }
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

/// Upper `1 − alpha` quantile of χ²(k) (Wilson–Hilferty approximation).
pub fn chi2_quantile(k: f64, alpha: f64) -> f64 {
    // Normal quantile by bisection on erf (no_std friendly).
    let (mut lo, mut hi) = (0.0f64, 10.0f64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        let tail = 0.5 * libm::erfc(mid / core::f64::consts::SQRT_2);
        if tail > alpha {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let z = 0.5 * (lo + hi);
    let a = 2.0 / (9.0 * k);
    k * (1.0 - a + z * a.sqrt()).powi(3)
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

/// How an epoch's baseline integers were found.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FixMethod {
    #[default]
    None,
    /// LAMBDA on the float filter's ambiguities, ratio test passed.
    LambdaFloat,
    /// Single-epoch length-constrained search (below), ratio test passed.
    ConstrainedSearch,
}

/// Integer fix of one baseline at one epoch.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct BaselineFix {
    pub method: FixMethod,
    /// DD integers [cycles] in the epoch's satellite order (`n_sats − 1`).
    pub n_dd: [i64; MAX_DD],
    pub m: usize,
    /// Fixed baseline, ENU [m].
    pub b_n: Vec3,
    /// Ratio test statistic (second best / best squared norm).
    pub ratio: f64,
}

/// Configuration of the integer ambiguity resolution ("beyond" the paper).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixConfig {
    /// Carrier wavelength [m].
    pub lambda: f64,
    /// Ratio test threshold.
    pub ratio_min: f64,
    /// Baseline length tolerance in the search and the integrity check [m].
    pub len_tol: f64,
    /// Inter-baseline angle tolerance of the integrity check [rad].
    pub angle_tol: f64,
    /// Try LAMBDA on the float filter first.
    pub use_float_lambda: bool,
    /// Single-epoch length-constrained search when LAMBDA does not pass.
    pub use_search: bool,
    /// Process noise q of the fixed-baseline filter [m²/s³]; 0 = no
    /// smoothing (each epoch's fixed baselines alone).
    pub q_fixed: f64,
    /// Fixed-baseline filters coast this many epochs without a fix, then reset.
    pub max_coast: u32,
    /// Rigid-body attitude filter on all fixed DDs ([`RigidAttFilter`]);
    /// `None`: the epoch's joint least-squares attitude alone.
    pub att_filter: Option<AttFilterConfig>,
}

impl Default for FixConfig {
    fn default() -> Self {
        FixConfig {
            lambda: 0.190293673,
            ratio_min: 3.0,
            len_tol: 0.03,
            angle_tol: 1.5f64.to_radians(),
            use_float_lambda: true,
            use_search: true,
            q_fixed: 0.0,
            max_coast: 6,
            att_filter: Some(AttFilterConfig::default()),
        }
    }
}

/// Weighted least-squares baseline from DDs with known integers:
/// `b = (ΔSᵀ W ΔS)⁻¹ ΔSᵀ W (z − λN)`, `W = R⁻¹`; returns (b, weighted SSR).
fn fixed_ls(ds: &[Vec3], z: &[f64], n: &[i64], lambda: f64, w: &DdMat) -> Option<(Vec3, f64)> {
    fixed_ls_info(ds, z, n, lambda, w).map(|(b, s, _)| (b, s))
}

/// [`fixed_ls`] also returning the information matrix `ΔSᵀ W ΔS`.
fn fixed_ls_info(
    ds: &[Vec3],
    z: &[f64],
    n: &[i64],
    lambda: f64,
    w: &DdMat,
) -> Option<(Vec3, f64, Mat3)> {
    let m = ds.len();
    let mut ata = Mat3::zeros();
    let mut atb = Vec3::zeros();
    let mut y = [0.0; MAX_DD];
    for i in 0..m {
        y[i] = z[i] - lambda * n[i] as f64;
    }
    for i in 0..m {
        for j in 0..m {
            let wij = w[(i, j)];
            if wij == 0.0 {
                continue;
            }
            ata += wij * ds[i] * ds[j].transpose();
            atb += wij * ds[i] * y[j];
        }
    }
    let b = ata.try_inverse()? * atb;
    let info = ata;
    let mut e = [0.0; MAX_DD];
    for i in 0..m {
        e[i] = y[i] - ds[i].dot(&b);
    }
    let mut ssr = 0.0;
    for i in 0..m {
        for j in 0..m {
            ssr += e[i] * w[(i, j)] * e[j];
        }
    }
    Some((b, ssr, info))
}

/// Weighted Wahba: the rotation `C_nb` minimising
/// `Σ (b_n,k − C_bn b_b,k)ᵀ W_k (b_n,k − C_bn b_b,k)` with full 3×3 weights
/// (Gauss–Newton on a small rotation from the SVD solution, 3 iterations).
pub fn wahba_weighted_nb(b_b: &[Vec3], b_n: &[Vec3], w: &[Mat3]) -> Option<Mat3> {
    let ones = [1.0; MAX_BASELINES];
    let mut c_bn = wahba_nb(b_b, b_n, &ones[..b_b.len().min(MAX_BASELINES)])?.transpose();
    for _ in 0..3 {
        let mut n = Mat3::zeros();
        let mut g = Vec3::zeros();
        for ((vb, vn), wk) in b_b.iter().zip(b_n).zip(w) {
            let u = c_bn * vb;
            let a = crate::attitude::skew(&u);
            let r = vn - u;
            n += a.transpose() * wk * a;
            g += a.transpose() * wk * r;
        }
        // e = r + [u×] δθ  ⇒  δθ = −N⁻¹ g.
        let d = -(n.try_inverse()? * g);
        c_bn = crate::attitude::dcm_from_rotvec(&d) * c_bn;
        if d.norm() < 1e-12 {
            break;
        }
    }
    Some(c_bn.transpose())
}

/// Constant-velocity Kalman filter of a fixed baseline (ENU): state
/// `[b, ḃ]`, measurement the epoch's fixed baseline with covariance
/// `(ΔSᵀ R⁻¹ ΔS)⁻¹`; process noise spectral density `q` (as eq. 11).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct FixedBaselineKf {
    pub x: SVector<f64, 6>,
    pub p: SMatrix<f64, 6, 6>,
    pub t: f64,
    pub active: bool,
}

impl FixedBaselineKf {
    /// Predict to `t` and update with `b_meas` of information `info` [1/m²].
    pub fn update(&mut self, t: f64, b_meas: &Vec3, info: &Mat3, q: f64) -> Option<()> {
        let r = info.try_inverse()?;
        if !self.active {
            self.x = SVector::<f64, 6>::zeros();
            self.p = SMatrix::<f64, 6, 6>::zeros();
            for i in 0..3 {
                self.x[i] = b_meas[i];
                self.p[(3 + i, 3 + i)] = 0.1 * 0.1;
                for j in 0..3 {
                    self.p[(i, j)] = r[(i, j)];
                }
            }
            self.t = t;
            self.active = true;
            return Some(());
        }
        self.predict(t, q);
        let mut h = SMatrix::<f64, 3, 6>::zeros();
        for i in 0..3 {
            h[(i, i)] = 1.0;
        }
        let innov = b_meas - h * self.x;
        let s = h * self.p * h.transpose() + r;
        let k = self.p * h.transpose() * s.try_inverse()?;
        self.x += k * innov;
        let ikh = SMatrix::<f64, 6, 6>::identity() - k * h;
        self.p = ikh * self.p * ikh.transpose() + k * r * k.transpose();
        Some(())
    }

    /// Time update to `t`.
    pub fn predict(&mut self, t: f64, q: f64) {
        let dt = t - self.t;
        if dt <= 0.0 || !self.active {
            return;
        }
        let mut f = SMatrix::<f64, 6, 6>::identity();
        for i in 0..3 {
            f[(i, 3 + i)] = dt;
        }
        self.x = f * self.x;
        self.p = f * self.p * f.transpose();
        for i in 0..3 {
            self.p[(i, i)] += q * dt * dt * dt / 3.0;
            self.p[(i, 3 + i)] += q * dt * dt / 2.0;
            self.p[(3 + i, i)] += q * dt * dt / 2.0;
            self.p[(3 + i, 3 + i)] += q * dt;
        }
        self.t = t;
    }

    pub fn baseline(&self) -> Vec3 {
        Vec3::new(self.x[0], self.x[1], self.x[2])
    }

    pub fn cov(&self) -> Mat3 {
        self.p.fixed_view::<3, 3>(0, 0).into_owned()
    }
}

/// Fixed double differences of all baselines of one epoch, ready for the
/// joint attitude estimate: `y_k,i = ∇Δφ_k,i − λ ∇ΔN_k,i` [m] with rows
/// `ΔS_i = s_i − s_{i+1}` (ENU) and the inverse `R⁻¹` of the exact
/// single-baseline DD covariance (`DdNoise::Exact`, undifferenced σ per
/// satellite, equal at every antenna).
///
/// Across baselines the DDs are correlated through the shared master
/// antenna: `cov(∇Δφ_k, ∇Δφ_l) = ½(1 + δ_kl) R`, i.e. `K ⊗ R` with
/// `K = ½(I + 11ᵀ)`, whose inverse is `K⁻¹ ⊗ R⁻¹`,
/// `K⁻¹ = 2 (I − 11ᵀ/(n_b + 1))`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixedDds {
    pub m: usize,
    pub nb: usize,
    pub ds: [Vec3; MAX_DD],
    pub y: [[f64; MAX_DD]; MAX_BASELINES],
    pub r_inv: DdMat,
}

impl FixedDds {
    /// Build from an epoch and the integers of `fixes` (epoch satellite order).
    pub fn new(ep: &CpEpoch, nb: usize, fixes: &[BaselineFix], lambda: f64) -> Option<Self> {
        let n = ep.n_sats;
        if n < 2 || nb == 0 || nb > MAX_BASELINES || fixes.len() < nb {
            return None;
        }
        let m = n - 1;
        let r = dd_covariance(&ep.sigma[..n], DdNoise::Exact);
        let r_full = r.cholesky()?.inverse();
        let mut r_inv = DdMat::zeros();
        for i in 0..m {
            for j in 0..m {
                r_inv[(i, j)] = r_full[(i, j)];
            }
        }
        let mut out = FixedDds {
            m,
            nb,
            ds: [Vec3::zeros(); MAX_DD],
            y: [[0.0; MAX_DD]; MAX_BASELINES],
            r_inv,
        };
        for i in 0..m {
            out.ds[i] = ep.los_enu[i] - ep.los_enu[i + 1];
        }
        for k in 0..nb {
            if fixes[k].m != m {
                return None;
            }
            for i in 0..m {
                out.y[k][i] =
                    ep.sd_phase[k][i] - ep.sd_phase[k][i + 1] - lambda * fixes[k].n_dd[i] as f64;
            }
        }
        Some(out)
    }

    /// `K⁻¹` entry for baselines `k`, `l` (see the type doc).
    fn k_inv(&self, k: usize, l: usize) -> f64 {
        2.0 * ((k == l) as u8 as f64 - 1.0 / (self.nb as f64 + 1.0))
    }

    /// Normal equations of the small rotation `δθ` (ENU) about `c_bn`
    /// (`b_n,k = exp([δθ×]) c_bn b_b,k`, so `∂(ΔS b_n,k)/∂δθ = −ΔS [u_k×]`):
    /// returns `(N, g, SSR)` with `N = Σ_kl K⁻¹_kl [u_k×]ᵀ G [u_l×]`,
    /// `G = ΔSᵀ R⁻¹ ΔS`, `g = −Σ_kl K⁻¹_kl [u_k×]ᵀ ΔSᵀ R⁻¹ e_l`, `e_l` the
    /// residuals at `c_bn`, and SSR the weighted residual square sum
    /// (χ²(n_b m − 3) at the optimum). The least-squares step is `N⁻¹ g`.
    pub fn normal(&self, c_bn: &Mat3, b_b: &[Vec3]) -> (Mat3, Vec3, f64) {
        let (m, nb) = (self.m, self.nb);
        let mut e = [[0.0; MAX_DD]; MAX_BASELINES]; // residuals e_k
        let mut t = [[0.0; MAX_DD]; MAX_BASELINES]; // R⁻¹ e_k
        let mut gk = [Vec3::zeros(); MAX_BASELINES]; // ΔSᵀ R⁻¹ e_k
        let mut ak = [Mat3::zeros(); MAX_BASELINES]; // [u_k×]
        for k in 0..nb {
            let u = c_bn * b_b[k];
            ak[k] = crate::attitude::skew(&u);
            for i in 0..m {
                e[k][i] = self.y[k][i] - self.ds[i].dot(&u);
            }
            for i in 0..m {
                let mut s = 0.0;
                for j in 0..m {
                    s += self.r_inv[(i, j)] * e[k][j];
                }
                t[k][i] = s;
                gk[k] += self.ds[i] * s;
            }
        }
        let mut g_mat = Mat3::zeros();
        for i in 0..m {
            for j in 0..m {
                let w = self.r_inv[(i, j)];
                if w != 0.0 {
                    g_mat += w * self.ds[i] * self.ds[j].transpose();
                }
            }
        }
        let mut n_mat = Mat3::zeros();
        let mut g = Vec3::zeros();
        let mut ssr = 0.0;
        for k in 0..nb {
            for l in 0..nb {
                let w = self.k_inv(k, l);
                n_mat += w * ak[k].transpose() * g_mat * ak[l];
                g -= w * ak[k].transpose() * gk[l];
                for i in 0..m {
                    ssr += w * e[k][i] * t[l][i];
                }
            }
        }
        (n_mat, g, ssr)
    }

    /// Joint least-squares attitude from all fixed DDs (Gauss–Newton from
    /// `c_bn0`, ≤ 5 iterations). Returns `(c_bn, N)` (N: information [1/rad²]).
    pub fn solve(&self, c_bn0: &Mat3, b_b: &[Vec3]) -> Option<(Mat3, Mat3)> {
        let mut c = *c_bn0;
        let mut n_mat = Mat3::identity();
        for _ in 0..5 {
            let (n, g, _) = self.normal(&c, b_b);
            let d = n.cholesky()?.solve(&g);
            c = crate::attitude::dcm_from_rotvec(&d) * c;
            n_mat = n;
            if d.norm() < 1e-12 {
                break;
            }
        }
        Some((c, n_mat))
    }
}

/// Configuration of the rigid-body attitude filter on fixed DDs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AttFilterConfig {
    /// Kinematic order: the highest derivative of the ENU angular rate held
    /// in the state plus one — 2: rate + acceleration, white jerk
    /// (Wiener-process acceleration); 3: rate + acceleration + jerk, white
    /// snap. 1 ≤ order ≤ [`MAX_ATT_ORDER`].
    pub order: usize,
    /// Spectral density of the white noise driving derivative `order` of
    /// the rate, per ENU axis (east, north, up) [rad²/s^(2·order+1)].
    pub q: Vec3,
    /// A-priori σ at initialisation of the rate and its derivatives
    /// (entry k: k-th derivative of the rate) [rad/s^(k+1)].
    pub sigma0: [f64; MAX_ATT_ORDER],
    /// False-alarm probability of the χ²(3) innovation gate (0 = off).
    pub gate: f64,
    /// Lag of the fixed-lag RTS smoother in fixed epochs (0 = off, at most
    /// [`MAX_SMOOTH_LAG`]): the attitude of the fix `lag` fixes back,
    /// re-estimated with the later fixes.
    pub smoother_lag: usize,
}

/// Largest kinematic order of [`AttFilterConfig`].
pub const MAX_ATT_ORDER: usize = 3;

impl AttFilterConfig {
    /// Parameters from bounds on the attitude dynamics: `bounds[k]` =
    /// (max horizontal norm, max |vertical|) of the k-th time derivative of
    /// the ENU angular rate, k = 0..=order; epoch interval `dt` [s].
    /// Bar-Shalom's rule for white-noise kinematic models (Bar-Shalom, Li &
    /// Kirubarajan 2001 §6.3.3): the change of the highest state derivative
    /// over an interval, `√(q dt)`, is of the order of the bound of the next
    /// derivative times `dt` ⇒ `q = bound² dt`; initial σ = the bounds.
    pub fn from_bounds(bounds: &[[f64; 2]], order: usize, dt: f64) -> Self {
        let order = order
            .clamp(1, MAX_ATT_ORDER)
            .min(bounds.len().saturating_sub(1));
        let mut sigma0 = [0.0; MAX_ATT_ORDER];
        for (k, s) in sigma0.iter_mut().enumerate().take(order) {
            *s = bounds[k][0].hypot(bounds[k][1]);
        }
        let [h, v] = bounds[order];
        AttFilterConfig {
            order,
            q: Vec3::new(h * h * dt, h * h * dt, v * v * dt),
            sigma0,
            gate: 1e-6,
            smoother_lag: 0,
        }
    }
}

impl Default for AttFilterConfig {
    /// The paper's scene (`SEEDS.md §3`), order 2: angles `A sin(0.02 t + …)`,
    /// A = (10°, 10°, 30°) (roll, pitch, yaw), epochs of 10 s; the bounds of
    /// the k-th rate derivative taken as `0.02^(k+1)` times |A| (norm),
    /// |(10°, 10°)| (horizontal) and 30° (vertical). The experiment and
    /// `navfuse attitude` use `Motion::dynamics_bounds` instead.
    fn default() -> Self {
        let (a_h, a_v) = ((2.0f64).sqrt() * 10f64.to_radians(), 30f64.to_radians());
        let b: [[f64; 2]; 4] = core::array::from_fn(|k| {
            let w = 0.02f64.powi(k as i32 + 1);
            [w * a_h, w * a_v]
        });
        Self::from_bounds(&b, 2, 10.0)
    }
}

/// Error-state size of [`RigidAttFilter`]: attitude + rate derivatives.
const NA: usize = 3 + 3 * MAX_ATT_ORDER;
type MatA = SMatrix<f64, NA, NA>;
type VecA = SVector<f64, NA>;
/// Rate and its derivatives (ENU), `[ω, ω̇, ω̈]`.
type Kin = [Vec3; MAX_ATT_ORDER];

/// Largest lag of the attitude smoother [fixed epochs].
pub const MAX_SMOOTH_LAG: usize = 6;

/// One step of the attitude filter kept for smoothing: the filtered state
/// and the prediction (with its transition) that led to it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct SmoothStep {
    t: f64,
    c_f: Mat3,
    k_f: Kin,
    p_f: MatA,
    c_p: Mat3,
    k_p: Kin,
    p_p: MatA,
    f: MatA,
}

/// Fixed-lag Rauch–Tung–Striebel smoother for [`RigidAttFilter`] (RTS
/// 1965; Bar-Shalom et al. 2001 §8.6) on the error state: with
/// `G_k = P_k|k F_k+1ᵀ P_k+1|k⁻¹` and `d = x_k+1|s ⊟ x_k+1|k`
/// (attitude part `rotvec(C_s C_pᵀ)`), `x_k|s = x_k|k ⊞ G_k d`.
/// A ring of the last `lag + 1` steps; allocation-free.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AttSmoother {
    ring: [SmoothStep; MAX_SMOOTH_LAG + 1],
    len: usize,
    head: usize,
}

impl Default for AttSmoother {
    fn default() -> Self {
        let z = SmoothStep {
            t: 0.0,
            c_f: Mat3::identity(),
            k_f: [Vec3::zeros(); MAX_ATT_ORDER],
            p_f: MatA::zeros(),
            c_p: Mat3::identity(),
            k_p: [Vec3::zeros(); MAX_ATT_ORDER],
            p_p: MatA::zeros(),
            f: MatA::identity(),
        };
        AttSmoother {
            ring: [z; MAX_SMOOTH_LAG + 1],
            len: 0,
            head: 0,
        }
    }
}

impl AttSmoother {
    /// Forget the history (filter re-initialised).
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Record the filter after this epoch's time and measurement update
    /// (`predicted`: whether a time update led here; false right after
    /// initialisation) and return `(t, c_bn)` of the epoch `lag` steps
    /// back, smoothed, once `lag + 1` steps are held.
    pub fn push(&mut self, f: &RigidAttFilter, predicted: bool, lag: usize) -> Option<(f64, Mat3)> {
        let lag = lag.min(MAX_SMOOTH_LAG);
        if !predicted {
            self.len = 0;
        }
        let cap = MAX_SMOOTH_LAG + 1;
        self.head = (self.head + 1) % cap;
        self.ring[self.head] = SmoothStep {
            t: f.t,
            c_f: f.c_bn,
            k_f: f.kin,
            p_f: f.p,
            c_p: f.pred.0,
            k_p: f.pred.1,
            p_p: f.pred.2,
            f: f.f_last,
        };
        self.len = (self.len + 1).min(cap);
        if lag == 0 || self.len < lag + 1 {
            return None;
        }
        let nd = 3 + 3 * f.order;
        let idx = |back: usize| (self.head + cap - back) % cap;
        let newest = &self.ring[self.head];
        let (mut c_s, mut k_s) = (newest.c_f, newest.k_f);
        for back in 1..=lag {
            let next = &self.ring[idx(back - 1)];
            let cur = &self.ring[idx(back)];
            // Only the active block (inactive states have zero covariance).
            let mut pp = MatA::identity();
            for i in 0..nd {
                for j in 0..nd {
                    pp[(i, j)] = next.p_p[(i, j)];
                }
            }
            let p_inv = pp.cholesky()?.inverse();
            let g = cur.p_f * next.f.transpose() * p_inv;
            let dth = crate::attitude::rotvec_from_dcm(&(c_s * next.c_p.transpose()));
            let mut d = VecA::zeros();
            for i in 0..3 {
                d[i] = dth[i];
                for k in 0..f.order {
                    d[3 + 3 * k + i] = k_s[k][i] - next.k_p[k][i];
                }
            }
            let dx = g * d;
            c_s = crate::attitude::dcm_from_rotvec(&Vec3::new(dx[0], dx[1], dx[2])) * cur.c_f;
            for k in 0..MAX_ATT_ORDER {
                k_s[k] = cur.k_f[k] + Vec3::new(dx[3 + 3 * k], dx[4 + 3 * k], dx[5 + 3 * k]);
            }
        }
        Some((self.ring[idx(lag)].t, c_s))
    }
}

/// Rigid-body attitude filter on fixed carrier phases (multiplicative EKF,
/// Markley & Crassidis 2014 §6.2 style): nominal `c_bn` (`b_n = c_bn b_b`)
/// and the ENU angular rate with its first `order − 1` derivatives; error
/// state `[δθ, δω, δω̇, …]` with `c_bn,true = exp([δθ×]) c_bn`; the
/// derivative `order` of the rate is white noise of density `q` per axis
/// (Bar-Shalom's kinematic models: order 2 = Wiener-process acceleration).
/// The measurement is every fixed DD of every baseline with the exact
/// correlated covariance (`FixedDds`); as the DDs enter only through `δθ`,
/// the stacked update equals the update with the joint least-squares
/// rotation and covariance `N⁻¹` (sufficient statistic;
/// [`RigidAttFilter::update_ls`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidAttFilter {
    pub c_bn: Mat3,
    /// `[ω_n, ω̇_n, ω̈_n]` (entries at or above `order` stay zero).
    pub kin: Kin,
    pub p: MatA,
    pub t: f64,
    pub order: usize,
    pub active: bool,
    /// Updates rejected by the innovation gate (total) and in a row.
    pub rejected: u32,
    pub rejected_run: u32,
    /// NIS of the last update (χ²(3) when consistent).
    pub nis: f64,
    /// Transition matrix of the last time update and the predicted state
    /// (attitude, rate derivatives, covariance) it produced, for the smoother.
    f_last: MatA,
    pred: (Mat3, Kin, MatA),
}

impl Default for RigidAttFilter {
    fn default() -> Self {
        RigidAttFilter {
            c_bn: Mat3::identity(),
            kin: [Vec3::zeros(); MAX_ATT_ORDER],
            p: MatA::zeros(),
            t: 0.0,
            order: 2,
            active: false,
            rejected: 0,
            rejected_run: 0,
            nis: f64::NAN,
            f_last: MatA::identity(),
            pred: (
                Mat3::identity(),
                [Vec3::zeros(); MAX_ATT_ORDER],
                MatA::zeros(),
            ),
        }
    }
}

/// `dt^n / n!`.
fn taylor(dt: f64, n: usize) -> f64 {
    let mut v = 1.0;
    for i in 1..=n {
        v *= dt / i as f64;
    }
    v
}

impl RigidAttFilter {
    /// Start at `t` from an attitude with information `n_info` [1/rad²].
    pub fn init(&mut self, t: f64, c_bn: &Mat3, n_info: &Mat3, cfg: &AttFilterConfig) -> bool {
        let Some(cov) = n_info.try_inverse() else {
            return false;
        };
        self.order = cfg.order.clamp(1, MAX_ATT_ORDER);
        self.c_bn = *c_bn;
        self.kin = [Vec3::zeros(); MAX_ATT_ORDER];
        self.p = MatA::zeros();
        for i in 0..3 {
            for j in 0..3 {
                self.p[(i, j)] = cov[(i, j)];
            }
            for k in 0..self.order {
                self.p[(3 + 3 * k + i, 3 + 3 * k + i)] = cfg.sigma0[k] * cfg.sigma0[k];
            }
        }
        self.t = t;
        self.active = true;
        self.rejected_run = 0;
        true
    }

    /// Time update to `t`: rotate by `φ = Σ_k ω⁽ᵏ⁾ dt^(k+1)/(k+1)!`,
    /// `ω⁽ᵏ⁾ += Σ_{l>k} ω⁽ˡ⁾ dt^(l−k)/(l−k)!`;
    /// `F` = the integrator chain with `R(φ)` in the attitude block;
    /// `Q_ab = q dt^(2n−a−b+1) / ((n−a)! (n−b)! (2n−a−b+1))` over the chain
    /// positions a, b = 0 (attitude) … n−1, n = order (Wiener-process models).
    pub fn predict(&mut self, t: f64, cfg: &AttFilterConfig) {
        let dt = t - self.t;
        if !self.active || dt <= 0.0 {
            return;
        }
        let n = self.order;
        let mut phi = Vec3::zeros();
        for k in 0..n {
            phi += self.kin[k] * taylor(dt, k + 1);
        }
        let rot = crate::attitude::dcm_from_rotvec(&phi);
        self.c_bn = rot * self.c_bn;
        let old = self.kin;
        for k in 0..n {
            for l in k + 1..n {
                self.kin[k] += old[l] * taylor(dt, l - k);
            }
        }
        let mut f = MatA::identity();
        for i in 0..3 {
            for j in 0..3 {
                f[(i, j)] = rot[(i, j)];
            }
            // Chain positions 0 (attitude) … n (unused beyond n).
            for a in 0..=n {
                for b in a + 1..=n {
                    f[(3 * a + i, 3 * b + i)] = taylor(dt, b - a);
                }
            }
        }
        self.p = f * self.p * f.transpose();
        for a in 0..=n {
            for b in 0..=n {
                let (ra, rb) = (n - a, n - b);
                let e = ra + rb + 1;
                let coef = taylor(dt, ra) * taylor(dt, rb) * dt / e as f64;
                for i in 0..3 {
                    self.p[(3 * a + i, 3 * b + i)] += cfg.q[i] * coef;
                }
            }
        }
        self.t = t;
        self.f_last = f;
        self.pred = (self.c_bn, self.kin, self.p);
    }

    /// Measurement update with the fixed DDs of one epoch: solves the joint
    /// LS from the predicted attitude and calls [`Self::update_ls`].
    pub fn update(&mut self, dds: &FixedDds, b_b: &[Vec3], cfg: &AttFilterConfig) -> bool {
        match dds.solve(&self.c_bn, b_b) {
            Some((c_ls, n_info)) => self.update_ls(&c_ls, &n_info, cfg),
            None => false,
        }
    }

    /// Measurement update with the epoch's joint LS attitude `c_ls` and its
    /// information `n_info` (`FixedDds::solve`). The DDs enter only through
    /// `δθ`, so the stacked DD update linearised at the LS solution equals
    /// the update with the pseudo-measurement `z = rotvec(c_ls ĉ_bnᵀ)`,
    /// `R = N⁻¹`, `H = [I 0 …]` (sufficient statistic); linearising at the
    /// LS solution, not at the prediction, keeps it exact when the
    /// prediction is poor. Returns false when the χ²(3) gate rejects it
    /// (state unchanged) or `N` is singular.
    pub fn update_ls(&mut self, c_ls: &Mat3, n_info: &Mat3, cfg: &AttFilterConfig) -> bool {
        let Some(r_meas) = n_info.cholesky().map(|ch| ch.inverse()) else {
            return false;
        };
        let z = crate::attitude::rotvec_from_dcm(&(c_ls * self.c_bn.transpose()));
        let p_tt = self.p.fixed_view::<3, 3>(0, 0).into_owned();
        let Some(s_ch) = (p_tt + r_meas).cholesky() else {
            return false;
        };
        self.nis = z.dot(&s_ch.solve(&z));
        if cfg.gate > 0.0 && self.nis > chi2_quantile(3.0, cfg.gate) {
            self.rejected += 1;
            self.rejected_run += 1;
            return false;
        }
        let p_xt = self.p.fixed_view::<NA, 3>(0, 0).into_owned();
        let gain = p_xt * s_ch.inverse();
        let dx = gain * z;
        self.c_bn = crate::attitude::dcm_from_rotvec(&Vec3::new(dx[0], dx[1], dx[2])) * self.c_bn;
        for k in 0..self.order {
            self.kin[k] += Vec3::new(dx[3 + 3 * k], dx[4 + 3 * k], dx[5 + 3 * k]);
        }
        // Joseph form with H = [I 0 …].
        let mut ikh = MatA::identity();
        for i in 0..NA {
            for j in 0..3 {
                ikh[(i, j)] -= gain[(i, j)];
            }
        }
        self.p = ikh * self.p * ikh.transpose() + gain * r_meas * gain.transpose();
        self.rejected_run = 0;
        true
    }

    /// Attitude `c_nb` (paper's direction, `b_b = c_nb b_n`).
    pub fn c_nb(&self) -> Mat3 {
        self.c_bn.transpose()
    }

    /// Covariance of the ENU rotation error `δθ` [rad²].
    pub fn cov_att(&self) -> Mat3 {
        self.p.fixed_view::<3, 3>(0, 0).into_owned()
    }
}

/// Single-epoch ambiguity search constrained by the known baseline length
/// (a least-squares ambiguity search in the spirit of Hatch 1990): the
/// integers of the three best-conditioned DDs are enumerated over the range
/// the length allows, each triple gives a baseline that must have the right
/// length, the other DDs are rounded from it, and the candidates are ranked
/// by the weighted residual. Returns the best with its ratio (second best /
/// best), `None` with fewer than 4 DDs or no candidate.
pub fn constrained_search(
    ds: &[Vec3],
    z: &[f64],
    r: &DdMat,
    length: f64,
    cfg: &FixConfig,
) -> Option<BaselineFix> {
    let m = ds.len();
    if !(4..=MAX_DD).contains(&m) {
        return None;
    }
    let mut w = DdMat::zeros();
    {
        let mut rr = DdMat::identity();
        for i in 0..m {
            for j in 0..m {
                rr[(i, j)] = r[(i, j)];
            }
        }
        let inv = rr.try_inverse()?;
        for i in 0..m {
            for j in 0..m {
                w[(i, j)] = inv[(i, j)];
            }
        }
    }
    // Best-conditioned triple (largest |det| of unit-normalised rows).
    let mut best_t = (0, 1, 2);
    let mut best_det = -1.0;
    for i in 0..m {
        for j in i + 1..m {
            for k in j + 1..m {
                let a = Mat3::from_rows(&[ds[i].transpose(), ds[j].transpose(), ds[k].transpose()]);
                let d = a.determinant().abs() / (ds[i].norm() * ds[j].norm() * ds[k].norm());
                if d > best_det {
                    best_det = d;
                    best_t = (i, j, k);
                }
            }
        }
    }
    let (i0, i1, i2) = best_t;
    let a = Mat3::from_rows(&[ds[i0].transpose(), ds[i1].transpose(), ds[i2].transpose()]);
    let a_inv = a.try_inverse()?;
    let lam = cfg.lambda;
    let range = |i: usize| -> (i64, i64) {
        let reach = ds[i].norm() * (length + cfg.len_tol);
        (
            ((z[i] - reach) / lam).floor() as i64 - 1,
            ((z[i] + reach) / lam).ceil() as i64 + 1,
        )
    };
    let (r0, r1, r2) = (range(i0), range(i1), range(i2));
    let mut best: [(f64, [i64; MAX_DD], Vec3); 2] =
        [(f64::INFINITY, [0; MAX_DD], Vec3::zeros()); 2];
    for n0 in r0.0..=r0.1 {
        for n1 in r1.0..=r1.1 {
            for n2 in r2.0..=r2.1 {
                let y = Vec3::new(
                    z[i0] - lam * n0 as f64,
                    z[i1] - lam * n1 as f64,
                    z[i2] - lam * n2 as f64,
                );
                let b = a_inv * y;
                if (b.norm() - length).abs() > cfg.len_tol {
                    continue;
                }
                let mut n = [0i64; MAX_DD];
                for i in 0..m {
                    n[i] = ((z[i] - ds[i].dot(&b)) / lam).round() as i64;
                }
                let Some((bf, ssr)) = fixed_ls(&ds[..m], &z[..m], &n[..m], lam, &w) else {
                    continue;
                };
                if (bf.norm() - length).abs() > cfg.len_tol {
                    continue;
                }
                if (best[0].0.is_finite() && best[0].1[..m] == n[..m])
                    || (best[1].0.is_finite() && best[1].1[..m] == n[..m])
                {
                    continue;
                }
                if ssr < best[0].0 {
                    best[1] = best[0];
                    best[0] = (ssr, n, bf);
                } else if ssr < best[1].0 {
                    best[1] = (ssr, n, bf);
                }
            }
        }
    }
    if !best[0].0.is_finite() {
        return None;
    }
    Some(BaselineFix {
        method: FixMethod::ConstrainedSearch,
        n_dd: best[0].1,
        m,
        b_n: best[0].2,
        ratio: if best[0].0 > 0.0 {
            best[1].0 / best[0].0
        } else {
            f64::INFINITY
        },
    })
}

/// LAMBDA on the float filter of one baseline; the fixed baseline is the
/// conditional `b̌ = b̂ − P_ba P_aa⁻¹ (â − λ ž)` (Teunissen 1995).
pub fn lambda_on_float(f: &BaselineFilter, cfg: &FixConfig) -> Option<BaselineFix> {
    let (a, q, m) = f.ambiguities();
    if !(1..=MAX_DD).contains(&m) {
        return None;
    }
    let lam = cfg.lambda;
    let mut ac = [0.0; MAX_DD];
    let mut qc = [0.0; MAX_DD * MAX_DD];
    for i in 0..m {
        ac[i] = a[i] / lam;
        for j in 0..m {
            qc[i * m + j] = q[(i, j)] / (lam * lam);
        }
    }
    let res = crate::lambda::lambda(&ac[..m], &qc[..m * m], m, 2).ok()?;
    let mut n = [0i64; MAX_DD];
    let mut da = DdVec::zeros();
    let mut qa = DdMat::identity();
    for i in 0..m {
        n[i] = res.fixed[0][i] as i64;
        da[i] = a[i] - lam * res.fixed[0][i];
        for j in 0..m {
            qa[(i, j)] = q[(i, j)];
        }
    }
    let sol = qa.cholesky()?.solve(&da);
    let mut b = f.baseline();
    for c in 0..3 {
        for i in 0..m {
            b[c] -= f.p[(c, 6 + i)] * sol[i];
        }
    }
    Some(BaselineFix {
        method: FixMethod::LambdaFloat,
        n_dd: n,
        m,
        b_n: b,
        ratio: res.ratio(),
    })
}

/// Which of an epoch's attitude solutions (the `rpy_*` of [`CpAttSolution`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CpAttOutput {
    /// Float baselines, the paper's eq. 4 + eq. 2 (`rpy_float`).
    Float = 0,
    /// Float baselines, equal-weight Wahba (`rpy_float_wahba`).
    FloatWahba = 1,
    /// The fixed solution (`rpy_fixed`: the attitude filter, else the joint LS).
    #[default]
    Fixed = 2,
    /// Per-epoch per-baseline fixed LS + weighted Wahba (`rpy_wahba`).
    FixedWahba = 3,
    /// Per-epoch joint LS on all fixed DDs (`rpy_joint`).
    FixedJoint = 4,
}

/// Number of [`CpAttOutput`] variants.
pub const CP_ATT_OUTPUTS: usize = 5;

/// One attitude solution as a matrix: `c_nb` in the paper's direction
/// (`b_b = c_nb b_n`, n = ENU; not orthonormal for eq. 4) and the
/// covariance of its ENU rotation error `δθ` [rad²]
/// (`c_bn,true = exp([δθ×]) c_bn`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AttEstimate {
    pub c_nb: Mat3,
    pub cov_n: Mat3,
}

/// Covariance of the nav-frame rotation error of a Wahba fit to the
/// baselines `b_n` with errors of covariance `cov_b` (`δb_k = δθ × b_n,k`,
/// `S_k = −[b_n,k×]`): `A⁻¹ (Σ S_kᵀ P_k S_k) A⁻¹`, `A = Σ S_kᵀ S_k` (the
/// equal-weight fit; first order, also used for eq. 4).
fn wahba_sandwich_cov(b_n: &[Vec3], cov_b: &[Mat3]) -> Option<Mat3> {
    let (mut a, mut m) = (Mat3::zeros(), Mat3::zeros());
    for (b, p) in b_n.iter().zip(cov_b) {
        let s = -crate::attitude::skew(b);
        a += s.transpose() * s;
        m += s.transpose() * p * s;
    }
    let ai = a.try_inverse()?;
    Some(ai * m * ai)
}

/// Covariance of the nav-frame rotation error of a Wahba fit weighted by
/// the baseline information matrices `w`: `(Σ S_kᵀ W_k S_k)⁻¹`.
fn wahba_info_cov(b_n: &[Vec3], w: &[Mat3]) -> Option<Mat3> {
    let mut a = Mat3::zeros();
    for (b, wk) in b_n.iter().zip(w) {
        let s = crate::attitude::skew(b);
        a += s.transpose() * wk * s;
    }
    a.try_inverse()
}

/// Attitude output of one epoch.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct CpAttSolution {
    pub t: f64,
    /// Paper's (roll, pitch, yaw) [rad] from the float baselines by eq. 4 and eq. 2.
    pub rpy_float: Vec3,
    /// The same float baselines through equal-weight Wahba (orthonormal).
    /// With eq. 4 and orthonormal body baselines `C_nb = R_n⁻¹`, whose rows
    /// are cross products of the *other two* baselines: to first order yaw
    /// sees only the north error of b_x, pitch the north error of b_z and
    /// roll the east error of b_z (one horizontal component each), whereas
    /// Wahba averages two baselines per angle (yaw: both horizontal, pitch
    /// and roll: one horizontal, one vertical).
    pub rpy_float_wahba: Vec3,
    /// Float baselines, ENU [m].
    pub b_n_float: [Vec3; MAX_BASELINES],
    pub n_sats: usize,
    /// Fixed solution when every baseline passed the ratio test and the
    /// integrity checks: the rigid-body attitude filter on all fixed DDs
    /// (or, without it, `rpy_joint`).
    pub rpy_fixed: Option<Vec3>,
    /// Same epochs: per-baseline fixed LS baselines + weighted Wahba (epoch by epoch).
    pub rpy_wahba: Option<Vec3>,
    /// Same epochs: joint LS attitude from all fixed DDs, exact covariance (epoch by epoch).
    pub rpy_joint: Option<Vec3>,
    /// Weighted SSR of the joint LS (χ²(n_b(n−1) − 3) when the model holds).
    pub joint_ssr: f64,
    /// NIS of the attitude filter's update (χ²(3) when consistent; NaN: none).
    pub att_nis: f64,
    /// Fixed-lag smoothed attitude of an earlier fixed epoch: (its time,
    /// paper's (roll, pitch, yaw)), `AttFilterConfig::smoother_lag` fixes back.
    pub smoothed: Option<(f64, Vec3)>,
    pub fixes: [BaselineFix; MAX_BASELINES],
    /// Why the fix was rejected (0 none, 1 ratio/no candidate, 2 length, 3 angle).
    pub reject: u8,
    /// The matrix and covariance behind each `rpy_*`, indexed by
    /// [`CpAttOutput`] (`None` where that `rpy_*` is NaN/`None`; the
    /// covariance is NaN where it cannot be formed).
    pub att: [Option<AttEstimate>; CP_ATT_OUTPUTS],
}

impl CpAttSolution {
    /// The estimate of `which` at this epoch.
    pub fn estimate(&self, which: CpAttOutput) -> Option<AttEstimate> {
        self.att[which as usize]
    }

    fn set(&mut self, which: CpAttOutput, c_nb: Mat3, cov_n: Option<Mat3>) {
        self.att[which as usize] = Some(AttEstimate {
            c_nb,
            cov_n: cov_n.unwrap_or(Mat3::repeat(f64::NAN)),
        });
    }
}

/// The seed 003 estimator: one float filter per baseline and the paper's
/// least-squares attitude; optionally integer fixing + Wahba.
#[derive(Clone, Debug)]
pub struct CpAttitude {
    pub cfg: CpAttConfig,
    pub fix: Option<FixConfig>,
    /// Body-frame baselines (slave − master) [m].
    pub b_b: [Vec3; MAX_BASELINES],
    pub n_baselines: usize,
    pub filters: [BaselineFilter; MAX_BASELINES],
    pub fixed_kf: [FixedBaselineKf; MAX_BASELINES],
    /// Rigid-body attitude filter on the fixed DDs.
    pub att: RigidAttFilter,
    /// Its fixed-lag smoother.
    pub smoother: AttSmoother,
    coast: u32,
}

impl CpAttitude {
    /// A new estimator for the body baselines `b_b` (≤ `MAX_BASELINES`).
    pub fn new(cfg: CpAttConfig, b_b: &[Vec3]) -> Self {
        let mut bb = [Vec3::zeros(); MAX_BASELINES];
        let n = b_b.len().min(MAX_BASELINES);
        bb[..n].copy_from_slice(&b_b[..n]);
        CpAttitude {
            cfg,
            fix: None,
            b_b: bb,
            n_baselines: n,
            filters: core::array::from_fn(|_| BaselineFilter::default()),
            fixed_kf: [FixedBaselineKf::default(); MAX_BASELINES],
            att: RigidAttFilter::default(),
            smoother: AttSmoother::default(),
            coast: 0,
        }
    }

    /// Enable integer fixing.
    pub fn with_fixing(mut self, fix: FixConfig) -> Self {
        self.fix = Some(fix);
        self
    }

    /// Feed one epoch; returns the float attitude (NaN when fewer than 3
    /// baselines) and, with fixing enabled, the fixed one.
    pub fn update(&mut self, ep: &CpEpoch) -> CpAttSolution {
        let nb = self.n_baselines.min(ep.n_baselines);
        let mut sol = CpAttSolution {
            t: ep.t,
            n_sats: ep.n_sats,
            rpy_float: Vec3::repeat(f64::NAN),
            rpy_float_wahba: Vec3::repeat(f64::NAN),
            att_nis: f64::NAN,
            ..Default::default()
        };
        for k in 0..nb {
            self.filters[k].update(ep, k, &self.cfg);
            sol.b_n_float[k] = self.filters[k].baseline();
        }
        if nb >= 3 {
            let mut cov_b = [Mat3::zeros(); MAX_BASELINES];
            for k in 0..nb {
                cov_b[k] = self.filters[k].p.fixed_view::<3, 3>(0, 0).into_owned();
            }
            let cov = wahba_sandwich_cov(&sol.b_n_float[..nb], &cov_b[..nb]);
            if let Some(c) = ls_dcm(&self.b_b[..nb], &sol.b_n_float[..nb]) {
                sol.rpy_float = paper_euler(&c);
                sol.set(CpAttOutput::Float, c, cov);
            }
            let ones = [1.0; MAX_BASELINES];
            if let Some(c) = wahba_nb(&self.b_b[..nb], &sol.b_n_float[..nb], &ones[..nb]) {
                sol.rpy_float_wahba = paper_euler(&c);
                sol.set(CpAttOutput::FloatWahba, c, cov);
            }
        }
        if let Some(fc) = self.fix {
            self.fix_epoch(ep, nb, &fc, &mut sol);
        }
        sol
    }

    fn fix_epoch(&mut self, ep: &CpEpoch, nb: usize, fc: &FixConfig, sol: &mut CpAttSolution) {
        let n = ep.n_sats;
        if n < 5 || nb < 2 {
            sol.reject = 1;
            return;
        }
        let m = n - 1;
        let mut ds = [Vec3::zeros(); MAX_DD];
        for i in 0..m {
            ds[i] = ep.los_enu[i] - ep.los_enu[i + 1];
        }
        let r = dd_covariance(&ep.sigma[..n], self.cfg.dd_noise);
        let mut b_fix = [Vec3::zeros(); MAX_BASELINES];
        let mut z_all = [[0.0; MAX_DD]; MAX_BASELINES];
        for k in 0..nb {
            for i in 0..m {
                z_all[k][i] = ep.sd_phase[k][i] - ep.sd_phase[k][i + 1];
            }
        }
        let mut w = DdMat::zeros();
        if let Some(inv) = r.try_inverse() {
            for i in 0..m {
                for j in 0..m {
                    w[(i, j)] = inv[(i, j)];
                }
            }
        }
        let ok = self.fix_baselines(ep, nb, fc, sol, &ds[..m], &z_all, &r, &mut b_fix);
        if !ok {
            self.coast += 1;
            if self.coast > fc.max_coast {
                for f in self.fixed_kf.iter_mut() {
                    f.active = false;
                }
                self.att.active = false;
            }
            return;
        }
        self.coast = 0;
        // Fixed baselines re-estimated with all DDs (weights W), information per baseline.
        let mut info = [Mat3::identity(); MAX_BASELINES];
        for k in 0..nb {
            let f = &sol.fixes[k];
            if let Some((b, _, inf)) =
                fixed_ls_info(&ds[..m], &z_all[k][..m], &f.n_dd[..m], fc.lambda, &w)
            {
                b_fix[k] = b;
                info[k] = inf;
            }
        }
        let mut b_use = b_fix;
        let mut w_use = info;
        if fc.q_fixed > 0.0 {
            for k in 0..nb {
                if self.fixed_kf[k]
                    .update(ep.t, &b_fix[k], &info[k], fc.q_fixed)
                    .is_some()
                {
                    b_use[k] = self.fixed_kf[k].baseline();
                    w_use[k] = self.fixed_kf[k].cov().try_inverse().unwrap_or(info[k]);
                }
            }
        }
        let Some(c_w) = wahba_weighted_nb(&self.b_b[..nb], &b_use[..nb], &w_use[..nb]) else {
            return;
        };
        sol.rpy_wahba = Some(paper_euler(&c_w));
        let cov_w = wahba_info_cov(&b_use[..nb], &w_use[..nb]);
        sol.set(CpAttOutput::FixedWahba, c_w, cov_w);
        // Joint LS on all fixed DDs of all baselines, exact correlated covariance.
        let Some(dds) = FixedDds::new(ep, nb, &sol.fixes[..nb], fc.lambda) else {
            sol.rpy_fixed = sol.rpy_wahba;
            sol.set(CpAttOutput::Fixed, c_w, cov_w);
            return;
        };
        let b_b = &self.b_b[..nb];
        let Some((c_j, n_j)) = dds.solve(&c_w.transpose(), b_b) else {
            sol.rpy_fixed = sol.rpy_wahba;
            sol.set(CpAttOutput::Fixed, c_w, cov_w);
            return;
        };
        sol.joint_ssr = dds.normal(&c_j, b_b).2;
        sol.rpy_joint = Some(paper_euler(&c_j.transpose()));
        sol.rpy_fixed = sol.rpy_joint;
        let cov_j = n_j.try_inverse();
        sol.set(CpAttOutput::FixedJoint, c_j.transpose(), cov_j);
        sol.set(CpAttOutput::Fixed, c_j.transpose(), cov_j);
        let Some(ac) = fc.att_filter else { return };
        let mut predicted = false;
        if self.att.active {
            self.att.predict(ep.t, &ac);
            let ok = self.att.update_ls(&c_j, &n_j, &ac);
            sol.att_nis = self.att.nis;
            if ok {
                sol.rpy_fixed = Some(paper_euler(&self.att.c_nb()));
                sol.set(
                    CpAttOutput::Fixed,
                    self.att.c_nb(),
                    Some(self.att.cov_att()),
                );
            }
            // Gate rejected: keep the epoch's joint LS and the filter's
            // prediction; restart after 3 rejections in a row.
            predicted = ok || self.att.rejected_run < 3;
        }
        if !predicted {
            if !self.att.init(ep.t, &c_j, &n_j, &ac) {
                return;
            }
            sol.rpy_fixed = Some(paper_euler(&self.att.c_nb()));
            sol.set(
                CpAttOutput::Fixed,
                self.att.c_nb(),
                Some(self.att.cov_att()),
            );
        }
        if let Some((t, c_bn)) = self.smoother.push(&self.att, predicted, ac.smoother_lag) {
            sol.smoothed = Some((t, paper_euler(&c_bn.transpose())));
        }
    }

    /// Fix every baseline (LAMBDA on the float filter, else the constrained
    /// search), then check lengths and inter-baseline angles.
    #[allow(clippy::too_many_arguments)]
    fn fix_baselines(
        &self,
        ep: &CpEpoch,
        nb: usize,
        fc: &FixConfig,
        sol: &mut CpAttSolution,
        ds: &[Vec3],
        z_all: &[[f64; MAX_DD]; MAX_BASELINES],
        r: &DdMat,
        b_fix: &mut [Vec3; MAX_BASELINES],
    ) -> bool {
        let n = ep.n_sats;
        let m = ds.len();
        for k in 0..nb {
            let len = self.b_b[k].norm();
            let mut fx = None;
            if fc.use_float_lambda && self.filters[k].n_sats == n {
                if let Some(f) = lambda_on_float(&self.filters[k], fc) {
                    let _ = n;
                    if f.ratio >= fc.ratio_min && (f.b_n.norm() - len).abs() <= fc.len_tol {
                        fx = Some(f);
                    }
                }
            }
            if fx.is_none() && fc.use_search {
                if let Some(f) = constrained_search(ds, &z_all[k][..m], r, len, fc) {
                    if f.ratio >= fc.ratio_min {
                        fx = Some(f);
                    }
                }
            }
            let Some(f) = fx else {
                sol.reject = 1;
                return false;
            };
            if (f.b_n.norm() - len).abs() > fc.len_tol {
                sol.reject = 2;
                return false;
            }
            sol.fixes[k] = f;
            b_fix[k] = f.b_n;
        }
        // Integrity: inter-baseline angles against the body geometry.
        for i in 0..nb {
            for j in i + 1..nb {
                let ang =
                    |a: &Vec3, b: &Vec3| (a.dot(b) / (a.norm() * b.norm())).clamp(-1.0, 1.0).acos();
                if (ang(&b_fix[i], &b_fix[j]) - ang(&self.b_b[i], &self.b_b[j])).abs()
                    > fc.angle_tol
                {
                    sol.reject = 3;
                    return false;
                }
            }
        }
        true
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
    fn chi2_quantiles() {
        // χ²(10) upper 1 % ≈ 23.21, χ²(4) upper 0.1 % ≈ 18.47.
        assert!((chi2_quantile(10.0, 0.01) - 23.21).abs() < 0.2);
        assert!((chi2_quantile(4.0, 0.001) - 18.47).abs() < 0.5);
    }

    /// The constrained search finds the true integers in one noise-free epoch,
    /// and the integrity/length rules reject a wrong body length.
    #[test]
    fn constrained_search_single_epoch() {
        const LAM: f64 = 0.190293673;
        let b = Vec3::new(0.3, -0.8, 0.52).normalize();
        let mut ds = [Vec3::zeros(); 8];
        let mut z = [0.0; 8];
        let mut n_true = [0i64; 8];
        let mut prev = Vec3::z();
        for i in 0..9 {
            let el = 1.4 - 0.14 * i as f64;
            let az = 1.9 * i as f64;
            let s = Vec3::new(el.cos() * az.sin(), el.cos() * az.cos(), el.sin());
            if i > 0 {
                ds[i - 1] = prev - s;
                n_true[i - 1] = (i as i64 * 37) % 11 - 5;
                z[i - 1] = ds[i - 1].dot(&b) + LAM * n_true[i - 1] as f64;
            }
            prev = s;
        }
        let r = dd_covariance(&[0.002; 9], DdNoise::PaperDiagonal);
        let cfg = FixConfig::default();
        let f = constrained_search(&ds, &z, &r, 1.0, &cfg).unwrap();
        assert_eq!(&f.n_dd[..8], &n_true);
        assert!((f.b_n - b).norm() < 1e-9);
        assert!(f.ratio > 100.0, "{}", f.ratio);
        // With a body length 20 cm off no candidate has the true integers.
        if let Some(g) = constrained_search(&ds, &z, &r, 1.2, &cfg) {
            assert_ne!(&g.n_dd[..8], &n_true);
        }
    }

    /// Why the float yaw of eq. 4 is no better than its pitch/roll (level,
    /// yaw 0, body x/y/z = E/N/U): eq. 4 yaw moves with the north error of
    /// b_x only and ignores the east error of b_y; Wahba takes half of each.
    #[test]
    fn eq4_yaw_sees_one_horizontal_error_wahba_two() {
        let b_b = [Vec3::x(), Vec3::y(), Vec3::z()];
        let eps = 1e-4;
        let yaw = |b_n: &[Vec3; 3]| {
            let ls = paper_euler(&ls_dcm(&b_b, b_n).unwrap()).z;
            let wa = paper_euler(&wahba_nb(&b_b, b_n, &[1.0; 3]).unwrap()).z;
            (ls, wa)
        };
        let (ls_x, wa_x) = yaw(&[Vec3::new(1.0, eps, 0.0), Vec3::y(), Vec3::z()]);
        let (ls_y, wa_y) = yaw(&[Vec3::x(), Vec3::new(-eps, 1.0, 0.0), Vec3::z()]);
        assert!((ls_x.abs() - eps).abs() < 1e-8, "{ls_x}");
        assert!(ls_y.abs() < 1e-8, "{ls_y}");
        assert!((wa_x.abs() - eps / 2.0).abs() < 1e-8, "{wa_x}");
        assert!((wa_y.abs() - eps / 2.0).abs() < 1e-8, "{wa_y}");
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

#[cfg(test)]
mod att_filter_tests {
    use super::*;

    /// xorshift64* + Box–Muller: a deterministic N(0, 1) stream for tests.
    struct Gauss(u64);
    impl Gauss {
        fn uniform(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            ((self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        }
        fn next(&mut self) -> f64 {
            let (u, v) = (self.uniform(), self.uniform());
            (-2.0 * u.ln()).sqrt() * (2.0 * core::f64::consts::PI * v).cos()
        }
    }

    const LAM: f64 = 0.190293673;

    /// Nine satellites drifting over the sky; epoch `e` of 10 s.
    fn sky(s: usize, e: usize) -> Vec3 {
        let el = 1.35 - 0.14 * s as f64 + 0.0001 * (s as f64 - 4.0) * e as f64;
        let az = 0.7 * s as f64 + 0.0007 * e as f64;
        Vec3::new(el.cos() * az.sin(), el.cos() * az.cos(), el.sin())
    }

    /// The paper's sinusoid (10°, 10°, 30°, ω = 0.02 rad/s).
    fn truth(t: f64) -> Mat3 {
        use core::f64::consts::PI;
        let a = [10f64.to_radians(), 10f64.to_radians(), 30f64.to_radians()];
        paper_dcm_nb(
            a[0] * (0.02 * t).sin(),
            a[1] * (0.02 * t + 2.0 * PI / 3.0).sin(),
            a[2] * (0.02 * t + 4.0 * PI / 3.0).sin(),
        )
        .transpose()
    }

    /// One epoch of fixed DDs with undifferenced noise σ (master noise shared
    /// by the three baselines, as in a real receiver set-up).
    fn epoch(e: usize, sigma: f64, g: &mut Gauss, b_b: &[Vec3; 3]) -> (CpEpoch, [BaselineFix; 3]) {
        let t = 10.0 * e as f64;
        let c_bn = truth(t);
        let n = 9;
        let mut ep = CpEpoch {
            t,
            n_sats: n,
            n_baselines: 3,
            ..Default::default()
        };
        let mut fixes = [BaselineFix::default(); 3];
        for s in 0..n {
            ep.prn[s] = s as u8 + 1;
            ep.los_enu[s] = sky(s, e);
            ep.sigma[s] = sigma;
            let master = sigma * g.next();
            for k in 0..3 {
                let amb = ((s * 7 + k * 3) % 13) as f64 - 6.0;
                ep.sd_phase[k][s] =
                    ep.los_enu[s].dot(&(c_bn * b_b[k])) + LAM * amb + master - sigma * g.next();
            }
        }
        for (k, f) in fixes.iter_mut().enumerate() {
            f.m = n - 1;
            for i in 0..n - 1 {
                let a = |s: usize| ((s * 7 + k * 3) % 13) as i64 - 6;
                f.n_dd[i] = a(i) - a(i + 1);
            }
        }
        (ep, fixes)
    }

    fn ang_err(a: &Mat3, b: &Mat3) -> Vec3 {
        crate::attitude::rotvec_from_dcm(&(a * b.transpose()))
    }

    /// Noise-free: the joint LS is exact, and the filter's one-step
    /// prediction (orders 2 and 3) stays within the error of extrapolating a
    /// quadratic fitted to past attitudes, `j_max dt³` (Lagrange remainder
    /// `j/6 · dt·2dt·3dt`), 4.6e-3 rad — against ~0.2 rad for a wrong
    /// rotation sense; order 3 extrapolates the smooth motion better.
    #[test]
    fn joint_ls_exact_and_prediction_within_jerk_bound() {
        let b_b = [Vec3::x(), Vec3::y(), Vec3::z()];
        let mut worst = [0.0f64; 2];
        for (o, order) in [2usize, 3].into_iter().enumerate() {
            let mut g = Gauss(1);
            let d = AttFilterConfig::default();
            // Order 3: white snap bounded by 0.02⁴·|A| per the same rule.
            let cfg = if order == 2 {
                d
            } else {
                let (a_h, a_v) = (2f64.sqrt() * 10f64.to_radians(), 30f64.to_radians());
                let b: [[f64; 2]; 4] = core::array::from_fn(|k| {
                    let w = 0.02f64.powi(k as i32 + 1);
                    [w * a_h, w * a_v]
                });
                AttFilterConfig::from_bounds(&b, 3, 10.0)
            };
            let mut f = RigidAttFilter::default();
            for e in 0..120 {
                let (ep, fixes) = epoch(e, 0.0, &mut g, &b_b);
                // Zero noise: give R a tiny σ so it stays invertible.
                let mut ep = ep;
                ep.sigma = [1e-6; MAX_SATS];
                let dds = FixedDds::new(&ep, 3, &fixes, LAM).unwrap();
                let c0 =
                    crate::attitude::dcm_from_rotvec(&Vec3::new(0.02, -0.03, 0.05)) * truth(ep.t);
                let (c, n_info) = dds.solve(&c0, &b_b).unwrap();
                assert!(ang_err(&c, &truth(ep.t)).norm() < 1e-9);
                if !f.active {
                    assert!(f.init(ep.t, &c, &n_info, &cfg));
                    continue;
                }
                f.predict(ep.t, &cfg);
                if e > 30 {
                    let pred = ang_err(&f.c_bn, &truth(ep.t)).norm();
                    // |j| = 0.02³·0.579 rad/s³ ⇒ j dt³ = 4.6e-3 rad.
                    assert!(pred < 4.6e-3, "order {order}, epoch {e}: prediction {pred}");
                    worst[o] = worst[o].max(pred);
                }
                assert!(f.update(&dds, &b_b, &cfg));
                let post = ang_err(&f.c_bn, &truth(ep.t)).norm();
                assert!(post < 1e-6, "epoch {e}: updated error {post}");
            }
        }
        // The smooth motion is better extrapolated by the higher-order model.
        assert!(worst[1] < 0.7 * worst[0], "{worst:?}");
    }

    /// With 2 mm noise the filter converges to the truth and beats the
    /// per-epoch joint LS, which beats per-baseline LS + Wahba; the filter's
    /// NIS averages near its 3 degrees of freedom (3 ± 1); the fixed-lag
    /// smoother (lag 1 and 3) beats the filter on the same epochs.
    #[test]
    fn filter_beats_epoch_solutions_on_noisy_scene() {
        let b_b = [Vec3::x(), Vec3::y(), Vec3::z()];
        let mut g = Gauss(0x5eed_0003);
        let cfg = AttFilterConfig::default();
        let fc = FixConfig::default();
        let mut f = RigidAttFilter::default();
        let mut sm = [AttSmoother::default(); 2];
        let lags = [1, 3];
        let mut se_s = [0.0; 2];
        let mut n_s = [0; 2];
        let (mut se_f, mut se_j, mut se_w, mut nis, mut n) = (0.0, 0.0, 0.0, 0.0, 0);
        for e in 0..400 {
            let (ep, fixes) = epoch(e, 0.002, &mut g, &b_b);
            let dds = FixedDds::new(&ep, 3, &fixes, LAM).unwrap();
            // Per-baseline LS (exact single-baseline weights) + Wahba.
            let mut b_n = [Vec3::zeros(); 3];
            let mut info = [Mat3::zeros(); 3];
            let mut z = [0.0; MAX_DD];
            for k in 0..3 {
                for i in 0..8 {
                    z[i] = ep.sd_phase[k][i] - ep.sd_phase[k][i + 1];
                }
                let (b, _, inf) = fixed_ls_info(
                    &dds.ds[..8],
                    &z[..8],
                    &fixes[k].n_dd[..8],
                    fc.lambda,
                    &dds.r_inv,
                )
                .unwrap();
                b_n[k] = b;
                info[k] = inf;
            }
            let c_w = wahba_weighted_nb(&b_b, &b_n, &info)
                .unwrap_or_else(|| panic!("{e} {b_n:?} {info:?}"))
                .transpose();
            let (c_j, n_info) = dds.solve(&c_w, &b_b).unwrap();
            let predicted = f.active;
            if !f.active {
                f.init(ep.t, &c_j, &n_info, &cfg);
            } else {
                f.predict(ep.t, &cfg);
                assert!(f.update(&dds, &b_b, &cfg));
            }
            for j in 0..2 {
                if let Some((ts, cs)) = sm[j].push(&f, predicted, lags[j]) {
                    if ts >= 500.0 {
                        se_s[j] += ang_err(&cs, &truth(ts)).norm_squared();
                        n_s[j] += 1;
                    }
                }
            }
            if e >= 50 {
                let t = truth(ep.t);
                se_f += ang_err(&f.c_bn, &t).norm_squared();
                se_j += ang_err(&c_j, &t).norm_squared();
                se_w += ang_err(&c_w, &t).norm_squared();
                nis += f.nis;
                n += 1;
            }
        }
        let rms = |s: f64| (s / n as f64).sqrt().to_degrees();
        let (rf, rj, rw) = (rms(se_f), rms(se_j), rms(se_w));
        for j in 0..2 {
            let rs = (se_s[j] / n_s[j] as f64).sqrt().to_degrees();
            assert_eq!(n_s[j], n - lags[j]);
            assert!(
                rs < 0.9 * rf,
                "lag {}: smoothed {rs}°, filter {rf}°",
                lags[j]
            );
        }
        assert!(rf < rj && rj < rw, "filter {rf}°, joint {rj}°, Wahba {rw}°");
        assert!(rf < 0.2, "filter {rf}°");
        let mean_nis = nis / n as f64;
        assert!((2.0..4.0).contains(&mean_nis), "mean NIS {mean_nis}");
    }
}
