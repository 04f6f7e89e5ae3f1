//! Klobuchar broadcast ionosphere model for single-frequency GPS users
//! (IS-GPS-200, §20.3.3.5.2.5 and Figure 20-4; Klobuchar, *IEEE Trans.
//! AES* 23(3), 1987).
//!
//! The eight coefficients α0..α3, β0..β3 are broadcast in subframe 4 page 18
//! (RINEX 2 navigation header `ION ALPHA` / `ION BETA`, RINEX 3
//! `IONOSPHERIC CORR GPSA` / `GPSB`). The model is a half-cosine of local
//! time on a constant night-time floor of 5 ns, evaluated at the
//! ionospheric pierce point at 350 km, with the obliquity factor
//! `F = 1 + 16 (0.53 − E)³` (E in semicircles). Angles in the ICD algorithm
//! are in semicircles; the inputs here are radians.
//!
//! The model removes about half of the ionospheric range error (its design
//! goal, Klobuchar 1987), so the residual is taken as 50 % of the correction
//! (1σ) in [`crate::gnss::spp`] — the figure RTKLIB uses too (`ERR_BRDCI`).

#[allow(unused_imports)]
use crate::prelude::*;

use super::C_LIGHT;
use core::f64::consts::PI;

/// Broadcast Klobuchar coefficients: α [s, s/sc, s/sc², s/sc³] and
/// β [s, s/sc, s/sc², s/sc³] (sc = semicircle).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Klobuchar {
    pub alpha: [f64; 4],
    pub beta: [f64; 4],
}

impl Klobuchar {
    /// True when every coefficient is zero (no model broadcast).
    pub fn is_zero(&self) -> bool {
        self.alpha.iter().chain(self.beta.iter()).all(|&c| c == 0.0)
    }

    /// L1 slant ionospheric group delay [m] for a receiver at geodetic
    /// latitude `lat`, longitude `lon` [rad], a satellite at azimuth `az` and
    /// elevation `el` [rad], at GPS time of week `tow` [s]
    /// (IS-GPS-200 Figure 20-4, step by step). Zero for `el ≤ 0`. Other
    /// frequencies scale by (f_L1/f)².
    pub fn delay_l1(&self, lat: f64, lon: f64, az: f64, el: f64, tow: f64) -> f64 {
        if el <= 0.0 || !(lat.is_finite() && lon.is_finite() && tow.is_finite()) {
            return 0.0;
        }
        let e_sc = el / PI;
        // Earth-centred angle ψ [sc].
        let psi = 0.0137 / (e_sc + 0.11) - 0.022;
        // Sub-ionospheric latitude φ_i [sc], clamped to ±0.416.
        let phi_i = (lat / PI + psi * az.cos()).clamp(-0.416, 0.416);
        // Sub-ionospheric longitude λ_i [sc].
        let lam_i = lon / PI + psi * az.sin() / (phi_i * PI).cos();
        // Geomagnetic latitude φ_m [sc].
        let phi_m = phi_i + 0.064 * ((lam_i - 1.617) * PI).cos();
        // Local time [s], 0 ≤ t < 86400.
        let mut t = 4.32e4 * lam_i + tow;
        t -= (t / 86_400.0).floor() * 86_400.0;
        // Obliquity factor.
        let f = 1.0 + 16.0 * (0.53 - e_sc).powi(3);
        let a = &self.alpha;
        let b = &self.beta;
        let amp = (a[0] + phi_m * (a[1] + phi_m * (a[2] + phi_m * a[3]))).max(0.0);
        let per = (b[0] + phi_m * (b[1] + phi_m * (b[2] + phi_m * b[3]))).max(72_000.0);
        let x = 2.0 * PI * (t - 50_400.0) / per;
        let t_iono = if x.abs() < 1.57 {
            f * (5e-9 + amp * (1.0 - x * x / 2.0 + x * x * x * x / 24.0))
        } else {
            f * 5e-9
        };
        C_LIGHT * t_iono
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The coefficients of the GEONET 2005-04-02 navigation file header.
    fn geonet() -> Klobuchar {
        Klobuchar {
            alpha: [1.1180e-08, 1.4900e-08, -5.9600e-08, -5.9600e-08],
            beta: [8.8060e+04, 1.6380e+04, -1.9660e+05, -1.3110e+05],
        }
    }

    /// A hand computation of Figure 20-4 (each step done separately in a
    /// calculator, kept here): receiver 36.0° N, 139.0° E; satellite azimuth
    /// 210°, elevation 40°; GPS time of week 529 800 s.
    /// E = 0.222222 sc; ψ = 0.0137/0.332222 − 0.022 = 0.0192375 sc;
    /// φ_i = 0.2 + ψ cos 210° = 0.183340 sc;
    /// λ_i = 0.772222 + ψ sin 210°/cos(φ_i π) = 0.772222 − 0.0096187/0.838659 = 0.760753 sc;
    /// φ_m = φ_i + 0.064 cos((λ_i − 1.617)π) = 0.183340 + 0.064·cos(−2.689979) = 0.125756 sc;
    /// t = 43200·0.760753 + 529800 mod 86400 = 44264.5 s (local 12:18);
    /// F = 1 + 16 (0.307778)³ = 1.466479;
    /// AMP = 1.1180e-8 + φ_m(1.49e-8 + φ_m(−5.96e-8 − 5.96e-8 φ_m)) = 1.199268e-8 s;
    /// PER = 88060 + φ_m(16380 + φ_m(−196600 − 131100 φ_m)) = 86750.0 s;
    /// x = 2π (44264.5 − 50400)/86750.0 = −0.444384 rad (|x| < 1.57);
    /// T = F (5e-9 + AMP (1 − x²/2 + x⁴/24)) = 1.466479·(5e-9 + 1.199268e-8·0.902886)
    /// = 2.321147e-8 s → 6.9586 m.
    #[test]
    fn klobuchar_matches_a_hand_computed_case() {
        let k = geonet();
        let d = k.delay_l1(
            36f64.to_radians(),
            139f64.to_radians(),
            210f64.to_radians(),
            40f64.to_radians(),
            529_800.0,
        );
        assert!((d - 6.9586).abs() < 1e-3, "delay {d}");
    }

    /// At night (|x| ≥ 1.57) the delay is the 5 ns floor times the
    /// obliquity factor: at the zenith F = 1 + 16·0.03³.
    #[test]
    fn night_floor_and_obliquity() {
        let k = geonet();
        // 36° N 139° E at local ~01:00: tow such that local time ≈ 3600 s.
        let lam_sc: f64 = 139.0 / 180.0;
        let tow = (3600.0 - 43_200.0 * lam_sc).rem_euclid(86_400.0);
        let d = k.delay_l1(36f64.to_radians(), 139f64.to_radians(), 0.0, PI / 2.0, tow);
        let f = 1.0 + 16.0 * 0.03f64.powi(3);
        assert!((d - C_LIGHT * 5e-9 * f).abs() < 1e-9, "{d}");
        // Lower satellites see a longer slant path.
        let low = k.delay_l1(
            36f64.to_radians(),
            139f64.to_radians(),
            0.0,
            10f64.to_radians(),
            tow,
        );
        assert!(low > 2.5 * d && low < 3.5 * d, "{low} vs {d}");
        assert_eq!(k.delay_l1(0.6, 2.4, 0.0, -0.1, tow), 0.0);
    }
}
