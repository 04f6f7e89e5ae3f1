//! Datasheet → error-state Kalman filter noise parameters (SI).
//!
//! A plain struct, independent of any estimator. Conversions (units as in
//! [`crate::imu_model`]):
//!
//! * ARW [°/√h] → [rad/√s]: × (π/180) / 60 (√h = 60 √s). VRW [m/s/√h] →
//!   [m/s/√s]: / 60. These are the white-noise PSD square roots: per interval
//!   dt the increment noise is σ = N √dt (IEEE Std 952 Annex C: the Allan
//!   deviation of white rate noise is N/√τ; Groves 2nd ed. §4.4.3).
//! * Bias instability: the simulator's model IS a first-order Gauss–Markov
//!   process b' = −b/τ_c + w with steady-state σ and correlation time τ_c, so
//!   σ and τ_c pass through; the driving noise PSD is q = 2σ²/τ_c
//!   (Groves 2nd ed. §14.2.6 / Maybeck). (If a datasheet quotes the Allan
//!   floor B instead, note that for white-flicker noise σ_A,min = B·√(2 ln2/π)
//!   ≈ 0.664 B — IEEE Std 952 — and a GM fit is a modelling choice.)
//! * Rate random walk K [°/h/√h] → [rad/s/√s]: × (π/180) / 3600 / 60.
//! * Turn-on bias σ → initial covariance of the bias states (its GM part is
//!   started in steady state by the simulator, so the total initial bias σ
//!   is √(σ_turn-on² + σ_GM²) — given as `bias_init_sigma`).
//! * Scale factor ppm → fraction ×1e−6; misalignment mrad → rad ×1e−3.
//!
//! Not represented (the filter would have to add them): quantisation (the
//! simulator carries the residual, so it does not accumulate; per-sample
//! σ = q/√12), gyro g-sensitivity, mounting rotation.

use crate::imu_model::{ImuSpec, TriadErrors};

/// Noise parameters of one sensor triad for an error-state KF (SI).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TriadNoise {
    /// White-noise density: ARW [rad/√s] (gyro) or VRW [m/s/√s] (accel).
    pub white: f64,
    /// Gauss–Markov bias: steady-state σ [rad/s or m/s²].
    pub bias_gm_sigma: f64,
    /// Gauss–Markov correlation time [s] (0: no GM bias).
    pub bias_gm_tau_s: f64,
    /// Driving-noise PSD of the GM bias, q = 2σ²/τ [(unit)²/s] (0 without GM).
    pub bias_gm_psd: f64,
    /// Bias random-walk density [unit/√s] (0: none).
    pub bias_rw: f64,
    /// Turn-on (run-to-run) bias σ [rad/s or m/s²].
    pub bias_turn_on_sigma: f64,
    /// Initial bias σ for the covariance: √(turn-on² + GM²).
    pub bias_init_sigma: f64,
    /// Scale-factor σ [fraction].
    pub scale_sigma: f64,
    /// Axis misalignment σ [rad].
    pub misalign_sigma: f64,
}

/// KF noise parameters of an IMU (`gyro` is `None` for accelerometer-only specs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FilterNoise {
    pub gyro: Option<TriadNoise>,
    pub accel: TriadNoise,
}

impl From<TriadErrors> for TriadNoise {
    fn from(e: TriadErrors) -> Self {
        let gm = e.gm_sigma > 0.0 && e.gm_tau > 0.0;
        TriadNoise {
            white: e.white,
            bias_gm_sigma: if gm { e.gm_sigma } else { 0.0 },
            bias_gm_tau_s: if gm { e.gm_tau } else { 0.0 },
            bias_gm_psd: if gm {
                2.0 * e.gm_sigma * e.gm_sigma / e.gm_tau
            } else {
                0.0
            },
            bias_rw: e.rrw,
            bias_turn_on_sigma: e.bias_sigma,
            bias_init_sigma: e.bias_sigma.hypot(if gm { e.gm_sigma } else { 0.0 }),
            scale_sigma: e.scale_sigma,
            misalign_sigma: e.misalign_sigma,
        }
    }
}

impl ImuSpec {
    /// The filter-side noise numbers of this spec (see the module doc for
    /// every conversion). Units SI; sensor frame.
    pub fn filter_noise(&self) -> FilterNoise {
        FilterNoise {
            gyro: self.gyro.as_ref().map(|g| g.to_si().into()),
            accel: self.accel.to_si().into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::imu_model::{imu_preset, ImuCorrupter, IMU_PRESETS};
    use navfuse_core::ImuSample;
    use rand::SeedableRng;
    use rand_chacha::ChaCha12Rng;

    #[test]
    fn adis16465_numbers_convert_by_hand() {
        let n = imu_preset("adis16465").unwrap().filter_noise();
        let g = n.gyro.unwrap();
        let d = core::f64::consts::PI / 180.0;
        // 0.15 °/√h = 0.15·(π/180)/60 rad/√s.
        assert!((g.white - 0.15 * d / 60.0).abs() < 1e-15);
        // 2 °/h GM σ, 500 s.
        assert!((g.bias_gm_sigma - 2.0 * d / 3600.0).abs() < 1e-15);
        assert_eq!(g.bias_gm_tau_s, 500.0);
        assert!((g.bias_gm_psd - 2.0 * g.bias_gm_sigma.powi(2) / 500.0).abs() < 1e-25);
        // 0.2 °/s as 3σ → 240 °/h.
        assert!((g.bias_turn_on_sigma - 240.0 * d / 3600.0).abs() < 1e-15);
        assert!((n.accel.white - 0.012 / 60.0).abs() < 1e-15);
        assert!((n.accel.scale_sigma - 1e-3).abs() < 1e-15);
        for p in IMU_PRESETS {
            let f = imu_preset(p).unwrap().filter_noise();
            assert!(f.accel.bias_init_sigma >= f.accel.bias_turn_on_sigma);
        }
    }

    #[test]
    fn white_density_matches_the_simulated_increment_noise() {
        // Only white noise left on: per-sample σ of Δθ must be ARW·√dt.
        let mut spec = imu_preset("phone").unwrap();
        let g = spec.gyro.as_mut().unwrap();
        (g.bias_deg_h, g.bias_instability_deg_h, g.scale_ppm) = (0.0, 0.0, 0.0);
        (g.misalign_mrad, g.quantum_rad, g.g_sensitivity_deg_h_g) = (0.0, 0.0, 0.0);
        let arw = spec.filter_noise().gyro.unwrap().white;
        let mut r = ChaCha12Rng::seed_from_u64(7);
        let mut c = ImuCorrupter::new(&spec, &mut r).unwrap();
        let ideal = ImuSample {
            dt: 0.01,
            ..Default::default()
        };
        let n = 30_000;
        let s2: f64 = (0..n)
            .map(|_| c.apply(&ideal, &mut r).dtheta_b.norm_squared())
            .sum();
        let sigma = (s2 / (3.0 * n as f64)).sqrt();
        assert!(
            (sigma / (arw * 0.1) - 1.0).abs() < 0.02,
            "{sigma} vs {}",
            arw * 0.1
        );
    }
}
