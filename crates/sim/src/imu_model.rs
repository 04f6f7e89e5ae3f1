//! IMU error model (Groves 2nd ed. §4.4; IEEE Std 952 noise terms) and presets.
//!
//! Applied to the ideal increments of one interval `dt` (sensor frame):
//!
//! ```text
//! Δθ̃ = Q[(I + S + M) Δθ + (b₀ + b_GM + b_RW + G f) dt + N √dt w]
//! ```
//!
//! `b₀` turn-on bias (drawn once per run), `b_GM` first-order Gauss–Markov
//! bias instability (σ, τ; exact discretisation φ = e^{−dt/τ}), `b_RW` rate
//! random walk (density K), `N` angle/velocity random walk density,
//! `S` diagonal scale-factor error, `M` off-diagonal axis misalignment
//! (drawn once), `G` g-sensitivity (gyro only), `Q` quantisation of the
//! increment with the residual carried to the next sample (so quantisation
//! does not drift). The IMU may be mounted rotated w.r.t. the vehicle body:
//! the sensor measures `C_sb (·)_b` with `C_bs = dcm(mount_rpy)`.

use crate::rot;
use crate::SimError;
use navfuse_core::earth::STANDARD_GRAVITY as G0;
use navfuse_core::{ImuSample, Mat3, Vec3};
use rand::Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

const DEG: f64 = core::f64::consts::PI / 180.0;
const HOUR: f64 = 3600.0;

/// Gyro errors in datasheet units (the TOML edge).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct GyroSpec {
    /// Turn-on bias, 1σ per axis [deg/h].
    pub bias_deg_h: f64,
    /// Bias instability (Gauss–Markov steady-state σ) [deg/h].
    pub bias_instability_deg_h: f64,
    /// Gauss–Markov correlation time [s].
    pub bias_tau_s: f64,
    /// Angle random walk [deg/√h].
    pub arw_deg_sqrt_h: f64,
    /// Rate random walk [deg/h/√h].
    pub rrw_deg_h_sqrt_h: f64,
    /// Scale-factor error, 1σ [ppm].
    pub scale_ppm: f64,
    /// Axis misalignment, 1σ [mrad].
    pub misalign_mrad: f64,
    /// Angle-increment quantum [rad] (0: none).
    pub quantum_rad: f64,
    /// g-sensitivity [deg/h per g] (0: none).
    pub g_sensitivity_deg_h_g: f64,
}

/// Accelerometer errors in datasheet units (the TOML edge).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct AccelSpec {
    /// Turn-on bias, 1σ per axis [mg].
    pub bias_mg: f64,
    /// Bias instability (Gauss–Markov steady-state σ) [mg].
    pub bias_instability_mg: f64,
    /// Gauss–Markov correlation time [s].
    pub bias_tau_s: f64,
    /// Velocity random walk [m/s/√h].
    pub vrw_m_s_sqrt_h: f64,
    /// Acceleration (bias) random walk [mg/√h].
    pub rrw_mg_sqrt_h: f64,
    /// Scale-factor error, 1σ [ppm].
    pub scale_ppm: f64,
    /// Axis misalignment, 1σ [mrad].
    pub misalign_mrad: f64,
    /// Velocity-increment quantum [m/s] (0: none).
    pub quantum_m_s: f64,
}

/// A complete IMU error specification.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ImuSpec {
    /// Name shown in outputs.
    #[serde(default)]
    pub name: String,
    /// Where the numbers come from.
    #[serde(default)]
    pub source: String,
    /// `None`: accelerometer-only device (gyro increments written as 0).
    pub gyro: Option<GyroSpec>,
    #[serde(default)]
    pub accel: AccelSpec,
    /// IMU mounting rotation w.r.t. the vehicle body, roll/pitch/yaw [deg].
    #[serde(default)]
    pub mount_rpy_deg: [f64; 3],
}

/// One sensor triad's errors in SI.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TriadErrors {
    pub bias_sigma: f64,
    pub gm_sigma: f64,
    pub gm_tau: f64,
    /// White-noise density [unit·√s] (rad/√s or m/s/√s).
    pub white: f64,
    /// Rate random walk density [unit/s/√s].
    pub rrw: f64,
    pub scale_sigma: f64,
    pub misalign_sigma: f64,
    pub quantum: f64,
    /// g-sensitivity [rad/s per m/s²] (gyro only).
    pub g_sens: f64,
}

impl GyroSpec {
    pub fn to_si(&self) -> TriadErrors {
        TriadErrors {
            bias_sigma: self.bias_deg_h * DEG / HOUR,
            gm_sigma: self.bias_instability_deg_h * DEG / HOUR,
            gm_tau: self.bias_tau_s,
            white: self.arw_deg_sqrt_h * DEG / HOUR.sqrt(),
            rrw: self.rrw_deg_h_sqrt_h * DEG / HOUR / HOUR.sqrt(),
            scale_sigma: self.scale_ppm * 1e-6,
            misalign_sigma: self.misalign_mrad * 1e-3,
            quantum: self.quantum_rad,
            g_sens: self.g_sensitivity_deg_h_g * DEG / HOUR / G0,
        }
    }
}

impl AccelSpec {
    pub fn to_si(&self) -> TriadErrors {
        TriadErrors {
            bias_sigma: self.bias_mg * 1e-3 * G0,
            gm_sigma: self.bias_instability_mg * 1e-3 * G0,
            gm_tau: self.bias_tau_s,
            white: self.vrw_m_s_sqrt_h / HOUR.sqrt(),
            rrw: self.rrw_mg_sqrt_h * 1e-3 * G0 / HOUR.sqrt(),
            scale_sigma: self.scale_ppm * 1e-6,
            misalign_sigma: self.misalign_mrad * 1e-3,
            quantum: self.quantum_m_s,
            g_sens: 0.0,
        }
    }
}

impl ImuSpec {
    /// Check every number is finite and ≥ 0.
    pub fn validate(&self) -> Result<(), SimError> {
        let mut v: Vec<(&str, f64)> = Vec::new();
        if let Some(g) = &self.gyro {
            let s = g.to_si();
            v.extend([
                ("gyro.bias_deg_h", s.bias_sigma),
                ("gyro.bias_instability_deg_h", s.gm_sigma),
                ("gyro.bias_tau_s", s.gm_tau),
                ("gyro.arw_deg_sqrt_h", s.white),
                ("gyro.rrw_deg_h_sqrt_h", s.rrw),
                ("gyro.scale_ppm", s.scale_sigma),
                ("gyro.misalign_mrad", s.misalign_sigma),
                ("gyro.quantum_rad", s.quantum),
            ]);
            if s.gm_sigma > 0.0 && s.gm_tau <= 0.0 {
                return Err(SimError::Scenario(format!(
                    "imu '{}': gyro.bias_tau_s must be > 0 with a bias instability",
                    self.name
                )));
            }
        }
        let a = self.accel.to_si();
        v.extend([
            ("accel.bias_mg", a.bias_sigma),
            ("accel.bias_instability_mg", a.gm_sigma),
            ("accel.bias_tau_s", a.gm_tau),
            ("accel.vrw_m_s_sqrt_h", a.white),
            ("accel.scale_ppm", a.scale_sigma),
            ("accel.misalign_mrad", a.misalign_sigma),
            ("accel.quantum_m_s", a.quantum),
        ]);
        if a.gm_sigma > 0.0 && a.gm_tau <= 0.0 {
            return Err(SimError::Scenario(format!(
                "imu '{}': accel.bias_tau_s must be > 0 with a bias instability",
                self.name
            )));
        }
        for (n, x) in v {
            if !(x.is_finite() && x >= 0.0) {
                return Err(SimError::Scenario(format!(
                    "imu '{}': {n} = {x} must be finite and ≥ 0",
                    self.name
                )));
            }
        }
        Ok(())
    }
}

/// Names of the IMU presets.
pub const IMU_PRESETS: &[&str] = &[
    "ideal",
    "adis16365",
    "3dm-gx3-35",
    "mma7260q",
    "adis16465",
    "phone",
    "tactical",
    "navigation",
];

/// Error terms to remove from an IMU specification, for diagnosis only:
/// which error that the filter does not model drives a result (the ESKF
/// estimates biases and diagonal scale factors, not axis misalignment or
/// g-sensitivity). The random draws of [`ImuCorrupter`] do not depend on
/// these σ, so a run with a term removed sees the same scene otherwise.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ImuIdeal {
    /// Gyro axis misalignment set to 0.
    pub gyro_misalignment: bool,
    /// Accelerometer axis misalignment set to 0.
    pub accel_misalignment: bool,
    /// Gyro g-sensitivity set to 0.
    pub g_sensitivity: bool,
}

impl ImuIdeal {
    /// `spec` with the selected terms removed.
    pub fn apply(&self, mut spec: ImuSpec) -> ImuSpec {
        if let Some(g) = spec.gyro.as_mut() {
            if self.gyro_misalignment {
                g.misalign_mrad = 0.0;
            }
            if self.g_sensitivity {
                g.g_sensitivity_deg_h_g = 0.0;
            }
        }
        if self.accel_misalignment {
            spec.accel.misalign_mrad = 0.0;
        }
        spec
    }
}

/// IMU preset by name (see [`IMU_PRESETS`]); each documents its source.
pub fn imu_preset(name: &str) -> Result<ImuSpec, SimError> {
    let s = match name {
        "ideal" => ImuSpec {
            name: "ideal".into(),
            source: "no errors".into(),
            gyro: Some(GyroSpec::default()),
            ..Default::default()
        },
        // Seed 002 Table 1 gives bias ±3°/s and noise 0.8°/s rms (gyro), bias ±50 mg
        // and noise 9 mg rms (accel), without a bandwidth. We take the ± range as
        // 3σ and the rms as per-sample noise at 100 Hz: density = rms·√(0.01 s),
        // i.e. 0.8°/s·0.1√s = 0.08°/√s = 4.8°/√h and 9 mg·0.1√s → 0.0088 m/s/√s
        // = 0.53 m/s/√h. No bias instability is given in the seed.
        "adis16365" => ImuSpec {
            name: "ADIS16365".into(),
            source:
                "seed 002 Table 1 (±3°/s, 0.8°/s rms; ±50 mg, 9 mg rms); ± as 3σ, rms at 100 Hz"
                    .into(),
            gyro: Some(GyroSpec {
                bias_deg_h: 3600.0,
                arw_deg_sqrt_h: 0.8 * 0.1 * 60.0,
                ..Default::default()
            }),
            accel: AccelSpec {
                bias_mg: 50.0 / 3.0,
                vrw_m_s_sqrt_h: 9e-3 * G0 * 0.1 * 60.0,
                ..Default::default()
            },
            ..Default::default()
        },
        // Seed 001's MicroStrain 3DM-GX3-35: values as recalled from the
        // 3DM-GX3 family datasheet (not verified here): gyro bias stability
        // ±0.2°/s turn-on, in-run 18°/h, noise density 0.03°/s/√Hz (1.8°/√h);
        // accel ±5 mg turn-on, in-run 0.04 mg, 80 µg/√Hz (0.047 m/s/√h).
        "3dm-gx3-35" => ImuSpec {
            name: "3DM-GX3-35".into(),
            source: "MicroStrain 3DM-GX3 datasheet values as recalled (unverified)".into(),
            gyro: Some(GyroSpec {
                bias_deg_h: 0.2 / 3.0 * 3600.0,
                bias_instability_deg_h: 18.0,
                bias_tau_s: 300.0,
                arw_deg_sqrt_h: 0.03 * 60.0,
                scale_ppm: 500.0,
                misalign_mrad: 1.0,
                ..Default::default()
            }),
            accel: AccelSpec {
                bias_mg: 5.0 / 3.0,
                bias_instability_mg: 0.04,
                bias_tau_s: 300.0,
                vrw_m_s_sqrt_h: 80e-6 * G0 * 60.0,
                scale_ppm: 500.0,
                misalign_mrad: 1.0,
                ..Default::default()
            },
            ..Default::default()
        },
        // Seed 004 simulation: accelerometer only, noise variance 0.01 G² at
        // 10 Hz → σ = 0.1 g per sample → density 0.1 g·√0.1 s = 0.310 m/s/√s.
        "mma7260q" => ImuSpec {
            name: "MMA7260Q".into(),
            source: "seed 004 Table 3 simulation: accel noise variance 0.01 G² at 10 Hz, no gyro"
                .into(),
            gyro: None,
            accel: AccelSpec {
                vrw_m_s_sqrt_h: 0.1 * G0 * 0.1f64.sqrt() * 60.0,
                ..Default::default()
            },
            ..Default::default()
        },
        // ADIS16465-1 datasheet values as recalled (unverified): gyro in-run
        // 2°/h, ARW 0.15°/√h, initial bias ±0.2°/s; accel in-run 3.6 µg,
        // VRW 0.012 m/s/√h, initial bias ±25 mg (± bounds taken as 3σ).
        "adis16465" => ImuSpec {
            name: "ADIS16465".into(),
            source: "ADIS16465-1 datasheet values as recalled (unverified)".into(),
            gyro: Some(GyroSpec {
                bias_deg_h: 0.2 / 3.0 * 3600.0,
                bias_instability_deg_h: 2.0,
                bias_tau_s: 500.0,
                arw_deg_sqrt_h: 0.15,
                scale_ppm: 1000.0,
                misalign_mrad: 0.5,
                ..Default::default()
            }),
            accel: AccelSpec {
                bias_mg: 25.0 / 3.0,
                bias_instability_mg: 3.6e-3,
                bias_tau_s: 500.0,
                vrw_m_s_sqrt_h: 0.012,
                scale_ppm: 1000.0,
                misalign_mrad: 0.5,
                ..Default::default()
            },
            ..Default::default()
        },
        // Consumer (phone) MEMS, representative of the BMI/LSM6 class
        // (Groves §4.4.6 consumer grade): gyro turn-on 0.5°/s, in-run ~20°/h,
        // noise 0.007°/s/√Hz (0.42°/√h); accel 20 mg, 0.1 mg, 150 µg/√Hz.
        "phone" => ImuSpec {
            name: "phone-grade MEMS".into(),
            source: "representative consumer MEMS (Groves 2nd ed. §4.4 consumer grade)".into(),
            gyro: Some(GyroSpec {
                bias_deg_h: 0.5 * 3600.0,
                bias_instability_deg_h: 20.0,
                bias_tau_s: 100.0,
                arw_deg_sqrt_h: 0.42,
                scale_ppm: 5000.0,
                misalign_mrad: 5.0,
                quantum_rad: 1e-6,
                g_sensitivity_deg_h_g: 36.0,
                ..Default::default()
            }),
            accel: AccelSpec {
                bias_mg: 20.0,
                bias_instability_mg: 0.1,
                bias_tau_s: 100.0,
                vrw_m_s_sqrt_h: 150e-6 * G0 * 60.0,
                scale_ppm: 5000.0,
                misalign_mrad: 5.0,
                quantum_m_s: 1e-5,
                ..Default::default()
            },
            ..Default::default()
        },
        // Tactical grade (Groves 2nd ed. §4.4: gyro bias 1–10°/h, ARW
        // 0.05–0.5°/√h; accel bias 0.1–1 mg): mid values.
        "tactical" => ImuSpec {
            name: "tactical grade".into(),
            source: "Groves 2nd ed. §4.4 tactical-grade ranges (representative)".into(),
            gyro: Some(GyroSpec {
                bias_deg_h: 3.0,
                bias_instability_deg_h: 0.5,
                bias_tau_s: 1000.0,
                arw_deg_sqrt_h: 0.1,
                scale_ppm: 300.0,
                misalign_mrad: 0.1,
                ..Default::default()
            }),
            accel: AccelSpec {
                bias_mg: 0.5,
                bias_instability_mg: 0.05,
                bias_tau_s: 1000.0,
                vrw_m_s_sqrt_h: 0.05,
                scale_ppm: 300.0,
                misalign_mrad: 0.1,
                ..Default::default()
            },
            ..Default::default()
        },
        // Navigation grade (Groves 2nd ed. §4.4: gyro bias ≤ 0.01°/h, ARW
        // ~0.002°/√h; accel bias 30–100 µg).
        "navigation" => ImuSpec {
            name: "navigation grade".into(),
            source: "Groves 2nd ed. §4.4 navigation-grade values (representative)".into(),
            gyro: Some(GyroSpec {
                bias_deg_h: 0.01,
                bias_instability_deg_h: 0.003,
                bias_tau_s: 3600.0,
                arw_deg_sqrt_h: 0.002,
                scale_ppm: 10.0,
                misalign_mrad: 0.02,
                ..Default::default()
            }),
            accel: AccelSpec {
                bias_mg: 0.05,
                bias_instability_mg: 0.01,
                bias_tau_s: 3600.0,
                vrw_m_s_sqrt_h: 0.003,
                scale_ppm: 20.0,
                misalign_mrad: 0.02,
                ..Default::default()
            },
            ..Default::default()
        },
        _ => {
            return Err(SimError::Scenario(format!(
                "unknown IMU preset '{name}' (known: {})",
                IMU_PRESETS.join(", ")
            )))
        }
    };
    Ok(s)
}

/// Draws of the per-run constant errors of one triad.
#[derive(Clone, Copy, Debug, Default)]
pub struct TriadDraw {
    pub bias: Vec3,
    /// (I + S + M): scale factor on the diagonal, misalignment off it.
    pub gain: Mat3,
}

/// Error-model state for one run (constant draws + random processes).
pub struct ImuCorrupter {
    gyro: Option<TriadErrors>,
    accel: TriadErrors,
    pub gyro_draw: TriadDraw,
    pub accel_draw: TriadDraw,
    c_sb: Mat3,
    gm_g: Vec3,
    gm_a: Vec3,
    rw_g: Vec3,
    rw_a: Vec3,
    res_g: Vec3,
    res_a: Vec3,
}

fn normal3<R: Rng>(r: &mut R) -> Vec3 {
    Vec3::new(
        r.sample(StandardNormal),
        r.sample(StandardNormal),
        r.sample(StandardNormal),
    )
}

fn draw<R: Rng>(e: &TriadErrors, r: &mut R) -> TriadDraw {
    let bias = normal3(r) * e.bias_sigma;
    let s = normal3(r) * e.scale_sigma;
    let m = [normal3(r), normal3(r)];
    let mut gain = Mat3::identity();
    for i in 0..3 {
        gain[(i, i)] += s[i];
    }
    let off = [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)];
    for (k, (i, j)) in off.iter().enumerate() {
        gain[(*i, *j)] += m[k / 3][k % 3] * e.misalign_sigma;
    }
    TriadDraw { bias, gain }
}

fn quantise(x: &Vec3, res: &mut Vec3, q: f64) -> Vec3 {
    if q <= 0.0 {
        return *x;
    }
    let y = x + *res;
    let out = y.map(|v| (v / q).round() * q);
    *res = y - out;
    out
}

impl ImuCorrupter {
    /// Draw the per-run constants from `rng_const` (turn-on bias, scale, misalignment)
    /// and start the Gauss–Markov biases in their steady state.
    pub fn new<R: Rng>(spec: &ImuSpec, rng_const: &mut R) -> Result<Self, SimError> {
        spec.validate()?;
        let gyro = spec.gyro.as_ref().map(|g| g.to_si());
        let accel = spec.accel.to_si();
        let gyro_draw = gyro
            .as_ref()
            .map(|g| draw(g, rng_const))
            .unwrap_or(TriadDraw {
                bias: Vec3::zeros(),
                gain: Mat3::identity(),
            });
        let accel_draw = draw(&accel, rng_const);
        let gm_g = normal3(rng_const) * gyro.map_or(0.0, |g| g.gm_sigma);
        let gm_a = normal3(rng_const) * accel.gm_sigma;
        let m = spec.mount_rpy_deg;
        let c_bs = rot::dcm_from_euler(&(Vec3::from(m) * DEG));
        Ok(ImuCorrupter {
            gyro,
            accel,
            gyro_draw,
            accel_draw,
            c_sb: c_bs.transpose(),
            gm_g,
            gm_a,
            rw_g: Vec3::zeros(),
            rw_a: Vec3::zeros(),
            res_g: Vec3::zeros(),
            res_a: Vec3::zeros(),
        })
    }

    /// Total current bias of (gyro [rad/s], accel [m/s²]) (turn-on + GM + RW), for reports.
    pub fn current_bias(&self) -> (Vec3, Vec3) {
        (
            self.gyro_draw.bias + self.gm_g + self.rw_g,
            self.accel_draw.bias + self.gm_a + self.rw_a,
        )
    }

    /// Corrupt one ideal interval (body-frame increments) with noise drawn from `rng`.
    pub fn apply<R: Rng>(&mut self, ideal: &ImuSample, rng: &mut R) -> ImuSample {
        let dt = ideal.dt;
        let th_s = self.c_sb * ideal.dtheta_b;
        let dv_s = self.c_sb * ideal.dvel_b;
        let f_s = dv_s / dt;
        let step_process = |gm: &mut Vec3, rw: &mut Vec3, e: &TriadErrors, r: &mut R| {
            if e.gm_sigma > 0.0 {
                let phi = (-dt / e.gm_tau).exp();
                *gm = *gm * phi + normal3(r) * (e.gm_sigma * (1.0 - phi * phi).sqrt());
            }
            if e.rrw > 0.0 {
                *rw += normal3(r) * (e.rrw * dt.sqrt());
            }
        };
        let dtheta = match self.gyro {
            Some(g) => {
                let b0 = self.gm_g + self.rw_g;
                step_process(&mut self.gm_g, &mut self.rw_g, &g, rng);
                // Mean of the bias processes over the interval (trapezoid).
                let b = self.gyro_draw.bias + 0.5 * (b0 + self.gm_g + self.rw_g) + f_s * g.g_sens;
                let x = self.gyro_draw.gain * th_s + b * dt + normal3(rng) * (g.white * dt.sqrt());
                quantise(&x, &mut self.res_g, g.quantum)
            }
            None => Vec3::zeros(),
        };
        let a = self.accel;
        let b0 = self.gm_a + self.rw_a;
        step_process(&mut self.gm_a, &mut self.rw_a, &a, rng);
        let b = self.accel_draw.bias + 0.5 * (b0 + self.gm_a + self.rw_a);
        let x = self.accel_draw.gain * dv_s + b * dt + normal3(rng) * (a.white * dt.sqrt());
        let dvel = quantise(&x, &mut self.res_a, a.quantum);
        ImuSample {
            t: ideal.t,
            dt,
            dtheta_b: dtheta,
            dvel_b: dvel,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha12Rng;

    /// `ImuIdeal` removes only the named terms, and the corrupter's random
    /// draws do not depend on them: at zero rotation rate a gyro
    /// misalignment has nothing to act on, so the outputs are bit-identical;
    /// at a 1 rad/s yaw rate they differ on the x/y gyro axes only through
    /// the misalignment.
    #[test]
    fn ideal_terms_leave_the_random_draws_unchanged() {
        let spec = imu_preset("phone").unwrap();
        let off = ImuIdeal {
            gyro_misalignment: true,
            ..Default::default()
        }
        .apply(spec.clone());
        let (g, g0) = (spec.gyro.as_ref().unwrap(), off.gyro.as_ref().unwrap());
        assert_eq!(g0.misalign_mrad, 0.0);
        assert_eq!(g0.g_sensitivity_deg_h_g, g.g_sensitivity_deg_h_g);
        assert_eq!(off.accel, spec.accel);
        let outputs = |s: &ImuSpec, yaw_rate: f64| {
            let mut r = ChaCha12Rng::seed_from_u64(3);
            let mut c = ImuCorrupter::new(s, &mut r).unwrap();
            let x = ImuSample {
                dt: 0.01,
                dtheta_b: Vec3::new(0.0, 0.0, yaw_rate * 0.01),
                dvel_b: Vec3::new(0.0, 0.0, -9.8 * 0.01),
                ..Default::default()
            };
            (0..100).map(|_| c.apply(&x, &mut r)).collect::<Vec<_>>()
        };
        assert_eq!(outputs(&spec, 0.0), outputs(&off, 0.0));
        let (a, b) = (outputs(&spec, 1.0), outputs(&off, 1.0));
        let dx = (a[99].dtheta_b - b[99].dtheta_b).abs();
        // 5 mrad σ misalignment × 0.01 rad per sample ≈ 5e-5 rad.
        assert!(dx.x > 1e-7 || dx.y > 1e-7, "{dx:?}");
        assert_eq!(a[99].dvel_b, b[99].dvel_b);
    }

    #[test]
    fn every_preset_is_valid_and_documented() {
        for p in IMU_PRESETS {
            let s = imu_preset(p).unwrap();
            s.validate().unwrap();
            assert!(!s.source.is_empty() && !s.name.is_empty(), "{p}");
        }
        assert!(imu_preset("nope").is_err());
        assert!(imu_preset("mma7260q").unwrap().gyro.is_none());
    }

    #[test]
    fn white_noise_has_the_stated_density() {
        // Per-sample σ of Δv must be VRW·√dt.
        let spec = ImuSpec {
            gyro: Some(GyroSpec {
                arw_deg_sqrt_h: 6.0,
                ..Default::default()
            }),
            accel: AccelSpec {
                vrw_m_s_sqrt_h: 0.6,
                ..Default::default()
            },
            ..Default::default()
        };
        let mut r = ChaCha12Rng::seed_from_u64(1);
        let mut c = ImuCorrupter::new(&spec, &mut r).unwrap();
        let ideal = ImuSample {
            t: 0.0,
            dt: 0.01,
            ..Default::default()
        };
        let n = 40_000;
        let (mut sg, mut sa) = (0.0, 0.0);
        for _ in 0..n {
            let m = c.apply(&ideal, &mut r);
            sg += m.dtheta_b.norm_squared();
            sa += m.dvel_b.norm_squared();
        }
        let sg = (sg / (3.0 * n as f64)).sqrt();
        let sa = (sa / (3.0 * n as f64)).sqrt();
        let eg = 6.0 * DEG / 60.0 * 0.1;
        let ea = 0.6 / 60.0 * 0.1;
        assert!((sg / eg - 1.0).abs() < 0.02, "{sg} vs {eg}");
        assert!((sa / ea - 1.0).abs() < 0.02, "{sa} vs {ea}");
    }

    #[test]
    fn quantisation_does_not_drift() {
        let mut res = Vec3::zeros();
        let mut sum = 0.0;
        for _ in 0..1000 {
            sum += quantise(&Vec3::repeat(0.3e-3), &mut res, 1e-3).x;
        }
        assert!((sum - 0.3).abs() <= 1e-3 + 1e-12);
    }
}
