//! World Magnetic Model 2025 (WMM2025): the main geomagnetic field at a
//! geodetic position and date, for magnetometer heading aiding.
//!
//! Coefficients: NOAA NCEI / BGS `WMM.COF`, epoch 2025.0, released
//! 2024-11-13, valid 2025.0–2030.0 (US-government work, public domain;
//! <https://www.ncei.noaa.gov/products/world-magnetic-model>). Rows
//! `(n, m, g, h, ġ, ḣ)` in nT and nT/yr, degree and order 12.
//!
//! Synthesis as in the WMM2025 technical report §1.2 (Chulliat et al.):
//! WGS-84 geodetic → geocentric spherical coordinates, Schmidt
//! semi-normalised associated Legendre functions, the field in the
//! geocentric frame (eq. 10–12), rotated to the geodetic NED frame (eq. 17).
//! Outside 2025.0–2030.0 the linear secular variation is extrapolated
//! (the error then grows by ~0.1°/yr in declination; the caller decides).

#[allow(unused_imports)]
use crate::prelude::*;
use crate::Vec3;

/// Epoch of the coefficients [decimal year].
pub const EPOCH: f64 = 2025.0;
/// End of the model's validity [decimal year].
pub const VALID_UNTIL: f64 = 2030.0;
/// Maximum degree.
const NMAX: usize = 12;
/// Triangular index size `(n, m) → n(n+1)/2 + m`.
const SIZE: usize = (NMAX + 1) * (NMAX + 2) / 2;
/// Geomagnetic reference radius [km] (WMM report).
const RE_KM: f64 = 6371.2;
/// WGS-84 semi-major axis [km] and first eccentricity squared.
const A_KM: f64 = 6378.137;
const E2: f64 = 0.006_694_379_990_141_316;

/// One-σ uncertainty of the WMM declination over the globe away from the
/// magnetic poles [rad]: 0.26° + 5625 nT/H° (WMM2025 report, error model,
/// `δD = sqrt(0.26² + (5625/H)²)` deg with H in nT — as recalled; the
/// caller adds it in quadrature, see [`declination_std`]).
pub fn declination_std(h_nt: f64) -> f64 {
    let k = 5625.0 / h_nt.max(1.0);
    (0.26f64 * 0.26 + k * k).sqrt().to_radians()
}

/// The main field at one place and time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Field {
    /// Field vector NED [T].
    pub b_n: Vec3,
    /// Declination (east of true north positive) [rad].
    pub declination: f64,
    /// Inclination (down positive) [rad].
    pub inclination: f64,
    /// Total intensity [T].
    pub total: f64,
}

/// `(n, m, g, h, ġ, ḣ)`: WMM2025 `WMM.COF`, verbatim values.
#[rustfmt::skip]
const COF: [(usize, usize, f64, f64, f64, f64); 90] = [
    (1, 0, -29351.8, 0.0, 12.0, 0.0),
    (1, 1, -1410.8, 4545.4, 9.7, -21.5),
    (2, 0, -2556.6, 0.0, -11.6, 0.0),
    (2, 1, 2951.1, -3133.6, -5.2, -27.7),
    (2, 2, 1649.3, -815.1, -8.0, -12.1),
    (3, 0, 1361.0, 0.0, -1.3, 0.0),
    (3, 1, -2404.1, -56.6, -4.2, 4.0),
    (3, 2, 1243.8, 237.5, 0.4, -0.3),
    (3, 3, 453.6, -549.5, -15.6, -4.1),
    (4, 0, 895.0, 0.0, -1.6, 0.0),
    (4, 1, 799.5, 278.6, -2.4, -1.1),
    (4, 2, 55.7, -133.9, -6.0, 4.1),
    (4, 3, -281.1, 212.0, 5.6, 1.6),
    (4, 4, 12.1, -375.6, -7.0, -4.4),
    (5, 0, -233.2, 0.0, 0.6, 0.0),
    (5, 1, 368.9, 45.4, 1.4, -0.5),
    (5, 2, 187.2, 220.2, 0.0, 2.2),
    (5, 3, -138.7, -122.9, 0.6, 0.4),
    (5, 4, -142.0, 43.0, 2.2, 1.7),
    (5, 5, 20.9, 106.1, 0.9, 1.9),
    (6, 0, 64.4, 0.0, -0.2, 0.0),
    (6, 1, 63.8, -18.4, -0.4, 0.3),
    (6, 2, 76.9, 16.8, 0.9, -1.6),
    (6, 3, -115.7, 48.8, 1.2, -0.4),
    (6, 4, -40.9, -59.8, -0.9, 0.9),
    (6, 5, 14.9, 10.9, 0.3, 0.7),
    (6, 6, -60.7, 72.7, 0.9, 0.9),
    (7, 0, 79.5, 0.0, -0.0, 0.0),
    (7, 1, -77.0, -48.9, -0.1, 0.6),
    (7, 2, -8.8, -14.4, -0.1, 0.5),
    (7, 3, 59.3, -1.0, 0.5, -0.8),
    (7, 4, 15.8, 23.4, -0.1, 0.0),
    (7, 5, 2.5, -7.4, -0.8, -1.0),
    (7, 6, -11.1, -25.1, -0.8, 0.6),
    (7, 7, 14.2, -2.3, 0.8, -0.2),
    (8, 0, 23.2, 0.0, -0.1, 0.0),
    (8, 1, 10.8, 7.1, 0.2, -0.2),
    (8, 2, -17.5, -12.6, 0.0, 0.5),
    (8, 3, 2.0, 11.4, 0.5, -0.4),
    (8, 4, -21.7, -9.7, -0.1, 0.4),
    (8, 5, 16.9, 12.7, 0.3, -0.5),
    (8, 6, 15.0, 0.7, 0.2, -0.6),
    (8, 7, -16.8, -5.2, -0.0, 0.3),
    (8, 8, 0.9, 3.9, 0.2, 0.2),
    (9, 0, 4.6, 0.0, -0.0, 0.0),
    (9, 1, 7.8, -24.8, -0.1, -0.3),
    (9, 2, 3.0, 12.2, 0.1, 0.3),
    (9, 3, -0.2, 8.3, 0.3, -0.3),
    (9, 4, -2.5, -3.3, -0.3, 0.3),
    (9, 5, -13.1, -5.2, 0.0, 0.2),
    (9, 6, 2.4, 7.2, 0.3, -0.1),
    (9, 7, 8.6, -0.6, -0.1, -0.2),
    (9, 8, -8.7, 0.8, 0.1, 0.4),
    (9, 9, -12.9, 10.0, -0.1, 0.1),
    (10, 0, -1.3, 0.0, 0.1, 0.0),
    (10, 1, -6.4, 3.3, 0.0, 0.0),
    (10, 2, 0.2, 0.0, 0.1, -0.0),
    (10, 3, 2.0, 2.4, 0.1, -0.2),
    (10, 4, -1.0, 5.3, -0.0, 0.1),
    (10, 5, -0.6, -9.1, -0.3, -0.1),
    (10, 6, -0.9, 0.4, 0.0, 0.1),
    (10, 7, 1.5, -4.2, -0.1, 0.0),
    (10, 8, 0.9, -3.8, -0.1, -0.1),
    (10, 9, -2.7, 0.9, -0.0, 0.2),
    (10, 10, -3.9, -9.1, -0.0, -0.0),
    (11, 0, 2.9, 0.0, 0.0, 0.0),
    (11, 1, -1.5, 0.0, -0.0, -0.0),
    (11, 2, -2.5, 2.9, 0.0, 0.1),
    (11, 3, 2.4, -0.6, 0.0, -0.0),
    (11, 4, -0.6, 0.2, 0.0, 0.1),
    (11, 5, -0.1, 0.5, -0.1, -0.0),
    (11, 6, -0.6, -0.3, 0.0, -0.0),
    (11, 7, -0.1, -1.2, -0.0, 0.1),
    (11, 8, 1.1, -1.7, -0.1, -0.0),
    (11, 9, -1.0, -2.9, -0.1, 0.0),
    (11, 10, -0.2, -1.8, -0.1, 0.0),
    (11, 11, 2.6, -2.3, -0.1, 0.0),
    (12, 0, -2.0, 0.0, 0.0, 0.0),
    (12, 1, -0.2, -1.3, 0.0, -0.0),
    (12, 2, 0.3, 0.7, -0.0, 0.0),
    (12, 3, 1.2, 1.0, -0.0, -0.1),
    (12, 4, -1.3, -1.4, -0.0, 0.1),
    (12, 5, 0.6, -0.0, -0.0, -0.0),
    (12, 6, 0.6, 0.6, 0.1, -0.0),
    (12, 7, 0.5, -0.1, -0.0, -0.0),
    (12, 8, -0.1, 0.8, 0.0, 0.0),
    (12, 9, -0.4, 0.1, 0.0, -0.0),
    (12, 10, -0.2, -1.0, -0.1, -0.0),
    (12, 11, -1.3, 0.1, -0.0, 0.0),
    (12, 12, -0.7, 0.2, -0.1, -0.1),
];

/// Main field at geodetic latitude `lat`, longitude `lon` [rad], height
/// above the WGS-84 ellipsoid `h` [m], decimal year `year` (e.g. 2026.9).
/// Returns `None` for non-finite input.
pub fn field(lat: f64, lon: f64, h: f64, year: f64) -> Option<Field> {
    if !(lat.is_finite() && lon.is_finite() && h.is_finite() && year.is_finite()) {
        return None;
    }
    // Keep off the pole: 1/cos φ′ in the east component (the WMM's special
    // summation gives the same limit; 1e-8 rad ≈ 6 cm).
    let half_pi = core::f64::consts::FRAC_PI_2 - 1e-8;
    let lat = lat.clamp(-half_pi, half_pi);
    let h_km = h / 1000.0;
    let (sl, cl) = (lat.sin(), lat.cos());
    let rc = A_KM / (1.0 - E2 * sl * sl).sqrt();
    let xp = (rc + h_km) * cl;
    let zp = (rc * (1.0 - E2) + h_km) * sl;
    let r = xp.hypot(zp);
    let phi = zp.atan2(xp);
    let (sp, cp) = (zp / r, xp / r);

    // Schmidt semi-normalised P_n^m(sin φ′) and dP/dφ′ (Gauss recursion,
    // then the Schmidt factors).
    let mut p = [0.0f64; SIZE];
    let mut dp = [0.0f64; SIZE];
    p[0] = 1.0;
    let idx = |n: usize, m: usize| n * (n + 1) / 2 + m;
    for n in 1..=NMAX {
        for m in 0..=n {
            let i = idx(n, m);
            if m == n {
                let j = idx(n - 1, m - 1);
                p[i] = cp * p[j];
                dp[i] = cp * dp[j] + sp * p[j];
            } else if m + 1 == n || n == 1 {
                let j = idx(n - 1, m);
                p[i] = sp * p[j];
                dp[i] = sp * dp[j] - cp * p[j];
            } else {
                let (j, k) = (idx(n - 1, m), idx(n - 2, m));
                let kk =
                    (((n - 1) * (n - 1) - m * m) as f64) / (((2 * n - 1) * (2 * n - 3)) as f64);
                p[i] = sp * p[j] - kk * p[k];
                dp[i] = sp * dp[j] - cp * p[j] - kk * dp[k];
            }
        }
    }
    let mut schmidt = [0.0f64; SIZE];
    schmidt[0] = 1.0;
    for n in 1..=NMAX {
        let i0 = idx(n, 0);
        schmidt[i0] = schmidt[idx(n - 1, 0)] * (2 * n - 1) as f64 / n as f64;
        for m in 1..=n {
            let two = if m == 1 { 2.0 } else { 1.0 };
            schmidt[i0 + m] =
                schmidt[i0 + m - 1] * (((n - m + 1) as f64 * two) / (n + m) as f64).sqrt();
        }
    }
    for i in 0..SIZE {
        p[i] *= schmidt[i];
        // The recursion differentiates by colatitude; by latitude the sign flips.
        dp[i] = -dp[i] * schmidt[i];
    }

    let dt = year - EPOCH;
    let ratio = RE_KM / r;
    let (mut bx, mut by, mut bz) = (0.0, 0.0, 0.0);
    for &(n, m, g0, h0, gd, hd) in COF.iter() {
        let i = idx(n, m);
        let rp = ratio.powi(n as i32 + 2);
        let g = g0 + dt * gd;
        let hh = h0 + dt * hd;
        let (sm, cm) = ((m as f64) * lon).sin_cos();
        let gc = g * cm + hh * sm;
        bx -= rp * gc * dp[i];
        by += rp * m as f64 * (g * sm - hh * cm) * p[i];
        bz -= rp * (n as f64 + 1.0) * gc * p[i];
    }
    by /= cp;
    // Geocentric → geodetic NED.
    let psi = phi - lat;
    let (s, c) = psi.sin_cos();
    let x = bx * c - bz * s;
    let z = bx * s + bz * c;
    let b_n = Vec3::new(x, by, z) * 1e-9;
    let hz = x.hypot(by);
    Some(Field {
        b_n,
        declination: by.atan2(x),
        inclination: z.atan2(hz),
        total: b_n.norm(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// WMM2025 declination test values (decimal year, height [km], lat, lon
    /// [deg], D [deg]) of NOAA's `WMM2025_TestValues.txt` / the WMM2025
    /// report's Table 6, given there to 0.01°.
    const VALUES: [(f64, f64, f64, f64, f64); 13] = [
        (2025.0, 0.0, 80.0, 0.0, 1.28),
        (2025.0, 0.0, 0.0, 120.0, -0.16),
        (2025.0, 0.0, -80.0, 240.0, 68.78),
        (2025.0, 100.0, 80.0, 0.0, 0.85),
        (2025.0, 100.0, 0.0, 120.0, -0.15),
        (2025.0, 100.0, -80.0, 240.0, 68.21),
        (2027.5, 100.0, 80.0, 0.0, 2.16),
        (2027.5, 100.0, 0.0, 120.0, -0.23),
        (2027.5, 100.0, -80.0, 240.0, 67.93),
        (2025.0, 28.0, 89.0, -121.0, -99.77),
        (2025.0, 48.0, 80.0, -96.0, -29.91),
        (2025.0, 18.0, 0.0, 21.0, 1.29),
        (2025.5, 6.0, -36.0, -137.0, 20.28),
    ];

    #[test]
    fn declination_matches_the_published_test_values() {
        for (y, h_km, lat, lon, d) in VALUES {
            let f = field(lat.to_radians(), lon.to_radians(), h_km * 1000.0, y).unwrap();
            let got = f.declination.to_degrees();
            // Published to 0.01°: half a unit of rounding plus float slack.
            assert!(
                (got - d).abs() <= 0.006,
                "{y} {h_km} {lat} {lon}: {got} vs {d}"
            );
        }
    }

    #[test]
    fn field_is_plausible_at_mid_latitude() {
        // Wuhan-like position: total intensity 25–65 µT everywhere on Earth,
        // dipping down in the northern hemisphere.
        let f = field(30.5f64.to_radians(), 114.4f64.to_radians(), 25.0, 2026.9).unwrap();
        assert!(f.total > 25e-6 && f.total < 65e-6, "{}", f.total);
        assert!(f.inclination > 0.0);
        assert!((f.b_n.norm() - f.total).abs() < 1e-15);
        assert!(field(f64::NAN, 0.0, 0.0, 2025.0).is_none());
    }
}
