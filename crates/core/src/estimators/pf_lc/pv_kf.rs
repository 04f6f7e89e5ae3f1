//! Position/velocity Kalman filter in the TM plane (`SEEDS.md §2` eq. 16–20).
//!
//! State `x = (p_N, p_E, v_N, v_E)` [m, m/s] in the local plane. Predict
//! with the navigation-frame acceleration `a^n` as input (eq. 16–17):
//! `p += vΔt + ½aΔt²`, `v += aΔt` — here from the velocity increment
//! `Δv^n = a^n Δt`. Process noise: white acceleration σ_a
//! (`Q = G Gᵀ σ_a² Δt`... in the exact discrete form for white acceleration,
//! Bar-Shalom et al. 2001 §6.2.2). Update with a GPS position (eq. 18–20),
//! Joseph form, NIS-gated; after `max_consecutive_rejects` rejected fixes the
//! filter restarts at the fix (counted).

#[allow(unused_imports)]
use crate::prelude::*;

use super::kf;
use nalgebra::{SMatrix, SVector};

type M4 = SMatrix<f64, 4, 4>;

/// Parameters of the position/velocity filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PvKfConfig {
    /// White acceleration noise density [m/s²/√Hz], covering the IMU
    /// acceleration errors (or the vehicle's manoeuvres without IMU).
    pub accel_psd_m_s2_sqrt_hz: f64,
    /// Same, while the attitude (yaw) is not yet known and `a^n = 0` is used.
    pub accel_psd_no_imu: f64,
    /// GPS position σ per horizontal axis [m].
    pub sigma_gps_m: f64,
    /// NIS gate on the 2-D position innovation (χ²₂; 13.8 ≈ 0.999).
    pub gate_nis: f64,
    /// Restart at the fix after this many consecutive gated fixes.
    pub max_consecutive_rejects: u32,
    /// Initial velocity σ [m/s].
    pub init_vel_sigma_m_s: f64,
}

impl Default for PvKfConfig {
    fn default() -> Self {
        PvKfConfig {
            accel_psd_m_s2_sqrt_hz: 0.5,
            accel_psd_no_imu: 2.0,
            sigma_gps_m: 5.0 / 1.1774,
            gate_nis: 13.8,
            max_consecutive_rejects: 8,
            init_vel_sigma_m_s: 10.0,
        }
    }
}

/// Counters of the position/velocity filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PvStats {
    pub updates: u64,
    pub gated: u64,
    pub restarts: u64,
}

/// The eq. 16–20 filter.
#[derive(Clone, Debug)]
pub struct PvKf {
    cfg: PvKfConfig,
    x: SVector<f64, 4>,
    p: M4,
    init: bool,
    rejects: u32,
    stats: PvStats,
}

impl PvKf {
    pub fn new(cfg: PvKfConfig) -> Self {
        PvKf {
            cfg,
            x: SVector::zeros(),
            p: M4::zeros(),
            init: false,
            rejects: 0,
            stats: PvStats::default(),
        }
    }
    pub fn config(&self) -> &PvKfConfig {
        &self.cfg
    }
    pub fn stats(&self) -> &PvStats {
        &self.stats
    }
    pub fn is_init(&self) -> bool {
        self.init
    }
    /// (north, east) [m].
    pub fn pos(&self) -> [f64; 2] {
        [self.x[0], self.x[1]]
    }
    /// (v_N, v_E) [m/s].
    pub fn vel(&self) -> [f64; 2] {
        [self.x[2], self.x[3]]
    }
    /// 1-σ of (north, east, v_N, v_E).
    pub fn std(&self) -> [f64; 4] {
        [0, 1, 2, 3].map(|i| self.p[(i, i)].max(0.0).sqrt())
    }

    /// Start at a fix with zero velocity.
    pub fn reset(&mut self, north: f64, east: f64) {
        self.x = SVector::from([north, east, 0.0, 0.0]);
        let (sp, sv) = (self.cfg.sigma_gps_m, self.cfg.init_vel_sigma_m_s);
        self.p = M4::from_diagonal(&SVector::from([sp * sp, sp * sp, sv * sv, sv * sv]));
        self.init = true;
        self.rejects = 0;
    }

    /// Predict over `dt` with the NED velocity increment `dv_ne = a^n Δt`
    /// (None: no IMU yet — a constant-velocity step with the larger noise).
    pub fn predict(&mut self, dt: f64, dv_ne: Option<[f64; 2]>) {
        if !self.init || dt.is_nan() || dt <= 0.0 {
            return;
        }
        let (dvn, dve, q_psd) = match dv_ne {
            Some([a, b]) => (a, b, self.cfg.accel_psd_m_s2_sqrt_hz),
            None => (0.0, 0.0, self.cfg.accel_psd_no_imu),
        };
        // Eq. 17: p += vΔt + ½ Δv Δt, v += Δv.
        self.x[0] += self.x[2] * dt + 0.5 * dvn * dt;
        self.x[1] += self.x[3] * dt + 0.5 * dve * dt;
        self.x[2] += dvn;
        self.x[3] += dve;
        let mut f = M4::identity();
        f[(0, 2)] = dt;
        f[(1, 3)] = dt;
        let q = q_psd * q_psd;
        let (q11, q12, q22) = (q * dt * dt * dt / 3.0, q * dt * dt / 2.0, q * dt);
        let mut qm = M4::zeros();
        for i in 0..2 {
            qm[(i, i)] = q11;
            qm[(i, i + 2)] = q12;
            qm[(i + 2, i)] = q12;
            qm[(i + 2, i + 2)] = q22;
        }
        kf::predict(&mut self.p, &f, &qm);
    }

    /// Position update (eq. 18–20). Returns whether it was applied.
    pub fn update(&mut self, north: f64, east: f64) -> bool {
        if !self.init {
            self.reset(north, east);
            return true;
        }
        let mut h = SMatrix::<f64, 2, 4>::zeros();
        h[(0, 0)] = 1.0;
        h[(1, 1)] = 1.0;
        let r = SMatrix::<f64, 2, 2>::identity() * self.cfg.sigma_gps_m.powi(2);
        let nu = SVector::<f64, 2>::new(north - self.x[0], east - self.x[1]);
        let u = kf::update(&mut self.x, &mut self.p, &h, &r, &nu, self.cfg.gate_nis);
        if u.accepted {
            self.stats.updates += 1;
            self.rejects = 0;
            true
        } else {
            self.stats.gated += 1;
            self.rejects += 1;
            if self.rejects >= self.cfg.max_consecutive_rejects {
                // Keep the velocity, restart the position at the fix.
                let v = self.vel();
                self.reset(north, east);
                self.x[2] = v[0];
                self.x[3] = v[1];
                self.stats.restarts += 1;
            }
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimators::pf_lc::rng::SplitMix64;

    #[test]
    fn exact_acceleration_input_gives_exact_kinematics() {
        let mut k = PvKf::new(PvKfConfig::default());
        k.reset(0.0, 0.0);
        for _ in 0..100 {
            k.predict(0.01, Some([0.02, -0.01])); // a = (2, −1) m/s²
        }
        let (p, v) = (k.pos(), k.vel());
        assert!(
            (p[0] - 1.0).abs() < 1e-9 && (p[1] + 0.5).abs() < 1e-9,
            "{p:?}"
        );
        assert!((v[0] - 2.0).abs() < 1e-12 && (v[1] + 1.0).abs() < 1e-12);
    }

    #[test]
    fn fusion_beats_raw_fixes_and_gates_outlier() {
        let mut rng = SplitMix64::new(3);
        let mut k = PvKf::new(PvKfConfig {
            sigma_gps_m: 3.0,
            ..Default::default()
        });
        let (mut er, mut ek, mut n) = (0.0, 0.0, 0);
        for j in 0..400 {
            // Straight at 5 m/s north; 25 IMU steps per 4 Hz fix, exact a^n = 0.
            for _ in 0..25 {
                k.predict(0.01, Some([0.0, 0.0]));
            }
            let t = (j + 1) as f64 * 0.25;
            let (zn, ze) = (5.0 * t + 3.0 * rng.normal(), 3.0 * rng.normal());
            k.update(zn, ze);
            if j > 40 {
                er += ((zn - 5.0 * t).powi(2) + ze * ze).sqrt();
                ek += ((k.pos()[0] - 5.0 * t).powi(2) + k.pos()[1].powi(2)).sqrt();
                n += 1;
            }
        }
        assert!(ek < 0.4 * er, "raw {} kf {}", er / n as f64, ek / n as f64);
        assert!(!k.update(k.pos()[0] + 500.0, 0.0));
        assert_eq!(k.stats().gated, 1);
    }
}
