//! GNSS position/velocity error model and presets.
//!
//! Per NED axis: position error = white (σ_w) + first-order Gauss–Markov
//! (σ_gm, τ; exact discretisation) + occasional multipath jumps (a horizontal
//! offset N(0, σ_jump) held for `jump_duration_s`, started with probability
//! `jump_prob` per epoch). Horizontal accuracy may be given as CEP: for a
//! circular normal error CEP = σ·√(2 ln 2) ≈ 1.1774 σ (Groves 2nd ed. §B.5);
//! the total per-axis σ is split between white and GM by `gm_fraction`
//! (share of variance). Vertical σ = `vertical_ratio` × horizontal.
//! Velocity noise is white NED. The reported 1-σ (`std_ned`) is the model's
//! white+GM σ — jumps are not in it, as a real receiver would not know.

use crate::SimError;
use serde::{Deserialize, Serialize};

/// CEP → per-axis σ for a circular normal distribution.
pub const CEP_TO_SIGMA: f64 = 1.0 / 1.177_410_022_515_474_5;

/// GNSS receiver error specification (TOML edge, metres and seconds).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GnssSpec {
    #[serde(default)]
    pub name: String,
    #[serde(default)]
    pub source: String,
    /// Output rate [Hz].
    pub rate_hz: f64,
    /// Horizontal CEP [m] (50 % circle); alternative to `sigma_h_m`.
    pub cep_m: Option<f64>,
    /// Horizontal per-axis σ [m]; alternative to `cep_m`.
    pub sigma_h_m: Option<f64>,
    /// Vertical σ as a multiple of the horizontal per-axis σ.
    #[serde(default = "default_vratio")]
    pub vertical_ratio: f64,
    /// Share of the position variance that is Gauss–Markov (time-correlated).
    #[serde(default)]
    pub gm_fraction: f64,
    /// Gauss–Markov correlation time [s].
    #[serde(default = "default_gm_tau")]
    pub gm_tau_s: f64,
    /// Velocity noise σ per NED axis [m/s] (0: no velocity output).
    #[serde(default)]
    pub vel_sigma_m_s: f64,
    /// Probability per epoch of a multipath jump starting.
    #[serde(default)]
    pub jump_prob: f64,
    /// Horizontal σ of a jump [m].
    #[serde(default)]
    pub jump_sigma_m: f64,
    /// How long a jump lasts [s].
    #[serde(default = "default_jump_dur")]
    pub jump_duration_s: f64,
    /// Fix latency: the fix tagged t is the position at t − latency [s].
    #[serde(default)]
    pub latency_s: f64,
}

fn default_vratio() -> f64 {
    1.5
}
fn default_gm_tau() -> f64 {
    60.0
}
fn default_jump_dur() -> f64 {
    3.0
}

/// SI per-axis error parameters derived from a [`GnssSpec`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssErrors {
    pub white_ned: [f64; 3],
    pub gm_ned: [f64; 3],
    pub gm_tau: f64,
    pub vel_sigma: f64,
}

impl GnssSpec {
    /// Validate and convert to per-axis σ.
    pub fn errors(&self) -> Result<GnssErrors, SimError> {
        let bad = |m: String| Err(SimError::Scenario(format!("gnss '{}': {m}", self.name)));
        let sh = match (self.cep_m, self.sigma_h_m) {
            (Some(c), None) => c * CEP_TO_SIGMA,
            (None, Some(s)) => s,
            _ => return bad("give exactly one of cep_m, sigma_h_m".into()),
        };
        if !(self.rate_hz > 0.0 && self.rate_hz.is_finite()) {
            return bad(format!("rate_hz = {} must be > 0", self.rate_hz));
        }
        for (n, v) in [
            ("horizontal σ", sh),
            ("vertical_ratio", self.vertical_ratio),
            ("vel_sigma_m_s", self.vel_sigma_m_s),
            ("jump_sigma_m", self.jump_sigma_m),
            ("jump_duration_s", self.jump_duration_s),
            ("latency_s", self.latency_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!("{n} = {v} must be finite and ≥ 0"));
            }
        }
        if !(0.0..=1.0).contains(&self.gm_fraction) || !(0.0..=1.0).contains(&self.jump_prob) {
            return bad("gm_fraction and jump_prob must be in [0, 1]".into());
        }
        if self.gm_fraction > 0.0 && self.gm_tau_s.is_nan() || self.gm_tau_s <= 0.0 {
            return bad("gm_tau_s must be > 0".into());
        }
        let sv = sh * self.vertical_ratio;
        let (fw, fg) = ((1.0 - self.gm_fraction).sqrt(), self.gm_fraction.sqrt());
        Ok(GnssErrors {
            white_ned: [sh * fw, sh * fw, sv * fw],
            gm_ned: [sh * fg, sh * fg, sv * fg],
            gm_tau: self.gm_tau_s,
            vel_sigma: self.vel_sigma_m_s,
        })
    }
}

/// Names of the GNSS presets.
pub const GNSS_PRESETS: &[&str] = &[
    "ideal-1hz",
    "lowcost-4hz",
    "propak-20hz",
    "consumer-1hz",
    "rtk-1hz",
];

/// GNSS preset by name (see [`GNSS_PRESETS`]).
pub fn gnss_preset(name: &str) -> Result<GnssSpec, SimError> {
    let base = GnssSpec {
        name: name.into(),
        source: String::new(),
        rate_hz: 1.0,
        cep_m: None,
        sigma_h_m: None,
        vertical_ratio: 1.5,
        gm_fraction: 0.0,
        gm_tau_s: 60.0,
        vel_sigma_m_s: 0.0,
        jump_prob: 0.0,
        jump_sigma_m: 0.0,
        jump_duration_s: 3.0,
        latency_s: 0.0,
    };
    let s = match name {
        // Seed 004 Table 3 simulation: "GPS noise-free, 1 Hz".
        "ideal-1hz" => GnssSpec {
            source: "noise-free 1 Hz (seed 004 simulation)".into(),
            sigma_h_m: Some(0.0),
            ..base
        },
        // Seed 002: low-cost receiver, 5 m CEP, 4 Hz. Mostly time-correlated
        // (atmosphere/orbit errors), plus occasional multipath jumps.
        "lowcost-4hz" => GnssSpec {
            source: "seed 002 low-cost GPS: 5 m CEP, 4 Hz; GM share and jumps are our choice"
                .into(),
            rate_hz: 4.0,
            cep_m: Some(5.0),
            gm_fraction: 0.8,
            gm_tau_s: 60.0,
            vel_sigma_m_s: 0.2,
            jump_prob: 0.002,
            jump_sigma_m: 8.0,
            ..base
        },
        // Seed 002 reference: NovAtel ProPak-G2, 1.5 m CEP, 20 Hz.
        "propak-20hz" => GnssSpec {
            source: "seed 002 reference NovAtel ProPak-G2: 1.5 m CEP, 20 Hz".into(),
            rate_hz: 20.0,
            cep_m: Some(1.5),
            gm_fraction: 0.8,
            gm_tau_s: 100.0,
            vel_sigma_m_s: 0.05,
            ..base
        },
        // Consumer receiver, 1 Hz, 2.5 m CEP (typical open-sky datasheet figure).
        "consumer-1hz" => GnssSpec {
            source: "typical consumer receiver: 2.5 m CEP, 1 Hz, 0.1 m/s velocity".into(),
            cep_m: Some(2.5),
            gm_fraction: 0.7,
            gm_tau_s: 60.0,
            vel_sigma_m_s: 0.1,
            jump_prob: 0.002,
            jump_sigma_m: 5.0,
            ..base
        },
        // RTK fixed: 2 cm horizontal σ, 3 cm vertical.
        "rtk-1hz" => GnssSpec {
            source: "RTK fixed: 2 cm horizontal σ, 1 Hz".into(),
            sigma_h_m: Some(0.02),
            gm_fraction: 0.5,
            gm_tau_s: 30.0,
            vel_sigma_m_s: 0.02,
            ..base
        },
        _ => {
            return Err(SimError::Scenario(format!(
                "unknown GNSS preset '{name}' (known: {})",
                GNSS_PRESETS.join(", ")
            )))
        }
    };
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_valid_and_cep_converts() {
        for p in GNSS_PRESETS {
            gnss_preset(p).unwrap().errors().unwrap();
        }
        let e = gnss_preset("lowcost-4hz").unwrap().errors().unwrap();
        let sh = (e.white_ned[0].powi(2) + e.gm_ned[0].powi(2)).sqrt();
        assert!((sh * 1.1774 - 5.0).abs() < 1e-3);
        assert!(gnss_preset("x").is_err());
    }
}
