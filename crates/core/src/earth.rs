//! WGS84 earth model: radii of curvature, normal gravity, earth and transport
//! rates (`SEEDS.md §1` eq. 5–6; Groves 2nd ed. §2.4, §2.4.7).
//!
//! Frame: local navigation frame NED. Latitude `lat` [rad], height `h` [m]
//! above the ellipsoid.

#[allow(unused_imports)]
use crate::prelude::*;
use crate::Vec3;

/// WGS84 semi-major axis a [m].
pub const WGS84_A: f64 = 6_378_137.0;
/// WGS84 flattening f.
pub const WGS84_F: f64 = 1.0 / 298.257_223_563;
/// WGS84 first eccentricity squared e² = f(2 − f).
pub const WGS84_E2: f64 = WGS84_F * (2.0 - WGS84_F);
/// WGS84 semi-minor axis b [m].
pub const WGS84_B: f64 = WGS84_A * (1.0 - WGS84_F);
/// WGS84 earth rotation rate Ω_ie [rad/s].
pub const OMEGA_IE: f64 = 7.292_115e-5;
/// WGS84 gravitational constant GM [m³/s²].
pub const WGS84_GM: f64 = 3.986_004_418e14;
/// Normal gravity at the equator γ_a [m/s²].
pub const GAMMA_EQUATOR: f64 = 9.780_325_335_9;
/// Somigliana constant k = (b γ_b − a γ_a)/(a γ_a).
pub const SOMIGLIANA_K: f64 = 0.001_931_852_652_41;
/// Standard gravity for unit conversion (1 g) [m/s²].
pub const STANDARD_GRAVITY: f64 = 9.806_65;

/// Meridian radius of curvature R_M (north–south) [m] (`SEEDS.md §1` eq. 6).
#[inline]
pub fn radius_meridian(lat: f64) -> f64 {
    let s = lat.sin();
    let w2 = 1.0 - WGS84_E2 * s * s;
    WGS84_A * (1.0 - WGS84_E2) / (w2 * w2.sqrt())
}

/// Prime-vertical (transverse) radius of curvature R_N (east–west) [m] (`SEEDS.md §1` eq. 6).
#[inline]
pub fn radius_prime_vertical(lat: f64) -> f64 {
    let s = lat.sin();
    WGS84_A / (1.0 - WGS84_E2 * s * s).sqrt()
}

/// Both radii (R_M, R_N) with one `sin` [m].
#[inline]
pub fn radii(lat: f64) -> (f64, f64) {
    let s = lat.sin();
    let w2 = 1.0 - WGS84_E2 * s * s;
    let w = w2.sqrt();
    (WGS84_A * (1.0 - WGS84_E2) / (w2 * w), WGS84_A / w)
}

/// Normal gravity magnitude on the ellipsoid, Somigliana's formula [m/s²].
#[inline]
pub fn gravity_somigliana(lat: f64) -> f64 {
    let s2 = lat.sin().powi(2);
    GAMMA_EQUATOR * (1.0 + SOMIGLIANA_K * s2) / (1.0 - WGS84_E2 * s2).sqrt()
}

/// Normal gravity magnitude at height `h` [m/s²]: Somigliana with the
/// second-order free-air correction (NIMA TR8350.2 eq. 4-3; Groves eq. 2.134).
#[inline]
pub fn gravity(lat: f64, h: f64) -> f64 {
    let g0 = gravity_somigliana(lat);
    let s2 = lat.sin().powi(2);
    let m = OMEGA_IE * OMEGA_IE * WGS84_A * WGS84_A * WGS84_B / WGS84_GM;
    g0 * (1.0 - 2.0 / WGS84_A * (1.0 + WGS84_F + m - 2.0 * WGS84_F * s2) * h
        + 3.0 / (WGS84_A * WGS84_A) * h * h)
}

/// Normal gravity vector g^n in NED, pointing down [m/s²].
#[inline]
pub fn gravity_n(lat: f64, h: f64) -> Vec3 {
    Vec3::new(0.0, 0.0, gravity(lat, h))
}

/// Earth rotation rate ω_ie^n resolved in NED [rad/s] (`SEEDS.md §1` eq. 5).
#[inline]
pub fn omega_ie_n(lat: f64) -> Vec3 {
    Vec3::new(OMEGA_IE * lat.cos(), 0.0, -OMEGA_IE * lat.sin())
}

/// Transport rate ω_en^n in NED for velocity `v_n` at `lat`, `h` [rad/s]
/// (`SEEDS.md §1` eq. 5: (l̇ cos L, −L̇, −l̇ sin L)).
#[inline]
pub fn omega_en_n(lat: f64, h: f64, v_n: &Vec3) -> Vec3 {
    let (rm, rn) = radii(lat);
    Vec3::new(
        v_n.y / (rn + h),
        -v_n.x / (rm + h),
        -v_n.y * lat.tan() / (rn + h),
    )
}

/// Geodetic rates (L̇, l̇, ḣ) from NED velocity [rad/s, rad/s, m/s] (`SEEDS.md §1` eq. 5).
#[inline]
pub fn geodetic_rates(lat: f64, h: f64, v_n: &Vec3) -> Vec3 {
    let (rm, rn) = radii(lat);
    Vec3::new(v_n.x / (rm + h), v_n.y / ((rn + h) * lat.cos()), -v_n.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radii_at_equator_and_pole() {
        assert!((radius_prime_vertical(0.0) - WGS84_A).abs() < 1e-6);
        assert!((radius_meridian(0.0) - WGS84_A * (1.0 - WGS84_E2)).abs() < 1e-6);
        let pole = core::f64::consts::FRAC_PI_2;
        // At the pole both radii equal a²/b.
        let rp = WGS84_A * WGS84_A / WGS84_B;
        assert!((radius_meridian(pole) - rp).abs() < 1e-6);
        assert!((radius_prime_vertical(pole) - rp).abs() < 1e-6);
        let (rm, rn) = radii(0.7);
        assert_eq!(rm, radius_meridian(0.7));
        assert_eq!(rn, radius_prime_vertical(0.7));
    }

    #[test]
    fn normal_gravity_reference_values() {
        // WGS84 normal gravity: equator 9.7803253359, pole 9.8321849378 m/s².
        assert!((gravity(0.0, 0.0) - 9.780_325_335_9).abs() < 1e-9);
        let pole = core::f64::consts::FRAC_PI_2;
        assert!((gravity(pole, 0.0) - 9.832_184_937_8).abs() < 1e-8);
        // Free-air gradient ≈ −3.086e-6 s⁻² at mid latitude.
        let dg = gravity(0.7, 1000.0) - gravity(0.7, 0.0);
        assert!((dg + 3.086e-3).abs() < 1e-5, "dg = {dg}");
    }

    #[test]
    fn rates() {
        let w = omega_ie_n(0.0);
        assert!((w.x - OMEGA_IE).abs() < 1e-18 && w.z.abs() < 1e-18);
        // Driving north at 10 m/s: transport rate is about −v/R around east.
        let r = omega_en_n(0.5, 0.0, &Vec3::new(10.0, 0.0, 0.0));
        assert!((r.y + 10.0 / radius_meridian(0.5)).abs() < 1e-15);
        let d = geodetic_rates(0.5, 100.0, &Vec3::new(0.0, 10.0, -1.0));
        assert!((d.z - 1.0).abs() < 1e-15 && d.x == 0.0 && d.y > 0.0);
    }
}
