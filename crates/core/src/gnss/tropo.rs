//! Tropospheric delay: Saastamoinen zenith delays of a standard atmosphere
//! and the Niell (1996) mapping functions.
//!
//! - Standard atmosphere at ellipsoidal height `h` [m] (as used with the
//!   Saastamoinen model, e.g. by RTKLIB): `P = 1013.25 (1 − 2.2557e-5 h)^5.2568`
//!   hPa, `T = 288.16 − 6.5e-3 h` K, water-vapour pressure
//!   `e = 6.108 rh exp((17.15 T − 4684)/(T − 38.45))` hPa.
//! - Saastamoinen (1972) zenith delays [m]:
//!   `ZHD = 0.0022768 P / (1 − 0.00266 cos 2φ − 0.00028 h_km)`,
//!   `ZWD = 0.002277 (1255/T + 0.05) e`.
//! - Niell, *J. Geophys. Res.* 101(B2), 1996: hydrostatic and wet mapping
//!   functions, Marini continued fraction
//!   `m(ε) = (1 + a/(1 + b/(1 + c))) / (sin ε + a/(sin ε + b/(sin ε + c)))`,
//!   coefficients interpolated in |latitude| (Table 3), seasonal term with
//!   phase DOY 28 (half a year later in the south), hydrostatic height
//!   correction `(1/sin ε − m(ε; a_ht, b_ht, c_ht)) h_km`.
//!
//! Slant delay `ZHD·m_h(ε) + ZWD·m_w(ε)` [m], added to the modelled range of
//! code and phase alike. In a double difference over a short baseline it
//! does not cancel: the sites differ in height (ZHD changes ≈ 0.3 mm/m) and
//! see each satellite at elevations differing by about baseline/R_earth
//! (≈ 0.03° at 3.3 km, worth ~1 cm of slant delay at 15° elevation).

#[allow(unused_imports)]
use crate::prelude::*;

/// Zenith hydrostatic and wet delays [m] of the Saastamoinen model in a
/// standard atmosphere at geodetic latitude `lat` [rad], ellipsoidal height
/// `h` [m] (clamped to 0…10 km) and relative humidity `rh` (0…1).
pub fn saastamoinen_zenith(lat: f64, h: f64, rh: f64) -> (f64, f64) {
    let h = h.clamp(0.0, 10_000.0);
    let p = 1013.25 * (1.0 - 2.2557e-5 * h).powf(5.2568);
    let t = 15.0 - 6.5e-3 * h + 273.16;
    let e = 6.108 * rh.clamp(0.0, 1.0) * ((17.15 * t - 4684.0) / (t - 38.45)).exp();
    let zhd = 0.0022768 * p / (1.0 - 0.00266 * (2.0 * lat).cos() - 0.00028 * h / 1e3);
    let zwd = 0.002277 * (1255.0 / t + 0.05) * e;
    (zhd, zwd)
}

/// Marini continued fraction normalised to 1 at the zenith.
fn marini(sin_el: f64, a: f64, b: f64, c: f64) -> f64 {
    (1.0 + a / (1.0 + b / (1.0 + c))) / (sin_el + a / (sin_el + b / (sin_el + c)))
}

/// Linear interpolation of a Niell table row in |latitude| [deg] over the
/// nodes 15, 30, 45, 60, 75° (constant beyond the ends).
fn interp_lat(row: &[f64; 5], lat_deg_abs: f64) -> f64 {
    if lat_deg_abs <= 15.0 {
        return row[0];
    }
    if lat_deg_abs >= 75.0 {
        return row[4];
    }
    let x = (lat_deg_abs - 15.0) / 15.0;
    let i = (x as usize).min(3);
    let f = x - i as f64;
    row[i] + f * (row[i + 1] - row[i])
}

// Niell (1996) Table 3: hydrostatic average and amplitude a, b, c; wet a, b, c.
const H_AVG: [[f64; 5]; 3] = [
    [
        1.2769934e-3,
        1.2683230e-3,
        1.2465397e-3,
        1.2196049e-3,
        1.2045996e-3,
    ],
    [
        2.9153695e-3,
        2.9152299e-3,
        2.9288445e-3,
        2.9022565e-3,
        2.9024912e-3,
    ],
    [
        62.610505e-3,
        62.837393e-3,
        63.721774e-3,
        63.824265e-3,
        64.258455e-3,
    ],
];
const H_AMP: [[f64; 5]; 3] = [
    [0.0, 1.2709626e-5, 2.6523662e-5, 3.4000452e-5, 4.1202191e-5],
    [0.0, 2.1414979e-5, 3.0160779e-5, 7.2562722e-5, 11.723375e-5],
    [0.0, 9.0128400e-5, 4.3497037e-5, 84.795348e-5, 170.37206e-5],
];
const H_HT: [f64; 3] = [2.53e-5, 5.49e-3, 1.14e-3];
const W: [[f64; 5]; 3] = [
    [
        5.8021897e-4,
        5.6794847e-4,
        5.8118019e-4,
        5.9727542e-4,
        6.1641693e-4,
    ],
    [
        1.4275268e-3,
        1.5138625e-3,
        1.4572752e-3,
        1.5007428e-3,
        1.7599082e-3,
    ],
    [
        4.3472961e-2,
        4.6729510e-2,
        4.3908931e-2,
        4.4626982e-2,
        5.4736038e-2,
    ],
];

/// Niell (1996) hydrostatic and wet mapping functions `(m_h, m_w)` at
/// elevation `el` [rad] (floored at 1°), geodetic latitude `lat` [rad],
/// ellipsoidal height `h` [m] and day of year `doy` (1…366, fractional ok).
pub fn niell_mapping(el: f64, lat: f64, h: f64, doy: f64) -> (f64, f64) {
    let s = el.max(1f64.to_radians()).sin();
    let lat_abs = lat.abs().to_degrees();
    let phase = if lat < 0.0 { 182.625 } else { 0.0 };
    let cos_season = (2.0 * core::f64::consts::PI * (doy - 28.0 + phase) / 365.25).cos();
    let coef =
        |k: usize| interp_lat(&H_AVG[k], lat_abs) - interp_lat(&H_AMP[k], lat_abs) * cos_season;
    let mh0 = marini(s, coef(0), coef(1), coef(2));
    let dm = (1.0 / s - marini(s, H_HT[0], H_HT[1], H_HT[2])) * h / 1e3;
    let w = |k: usize| interp_lat(&W[k], lat_abs);
    let mw = marini(s, w(0), w(1), w(2));
    (mh0 + dm, mw)
}

/// Slant tropospheric delay [m]: Saastamoinen zenith delays (standard
/// atmosphere, relative humidity `rh`; `rh = 0` gives the hydrostatic part
/// alone) mapped with the Niell functions. Arguments as in
/// [`saastamoinen_zenith`] and [`niell_mapping`].
pub fn slant_delay(el: f64, lat: f64, h: f64, doy: f64, rh: f64) -> f64 {
    let (zhd, zwd) = saastamoinen_zenith(lat, h, rh);
    let (mh, mw) = niell_mapping(el, lat, h, doy);
    zhd * mh + zwd * mw
}

/// Day of year (1 = 1 January, fractional) of GPS time `t` [s since
/// 1980-01-06 00:00], ignoring leap seconds (irrelevant for the seasonal
/// term of the mapping function).
pub fn day_of_year(t: f64) -> f64 {
    // Days since 1970-01-01; 1980-01-06 is day 3657.
    let days = t / 86_400.0 + 3657.0;
    let d = days.floor() as i64;
    let frac = days - d as f64;
    // Civil date from days since the Unix epoch (proleptic Gregorian).
    let z = d + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy_mar = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy_mar + 2) / 153;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = if month <= 2 { y + 1 } else { y };
    // Days from 1 January of `year` to day `d`.
    let jan1 = days_from_civil(year, 1, 1);
    (d - jan1) as f64 + 1.0 + frac
}

fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = if m > 2 { m - 3 } else { m + 9 };
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zenith_delays_of_the_standard_atmosphere() {
        // Sea level, 45°: ZHD ≈ 2.31 m (P = 1013.25 hPa), dry air has no ZWD.
        let (zhd, zwd) = saastamoinen_zenith(45f64.to_radians(), 0.0, 0.0);
        assert!((zhd - 2.3069).abs() < 1e-3, "{zhd}");
        assert_eq!(zwd, 0.0);
        // ZHD falls by roughly 0.27 mm per metre of height near sea level.
        let (z100, _) = saastamoinen_zenith(45f64.to_radians(), 100.0, 0.0);
        let slope = (zhd - z100) / 100.0;
        assert!(slope > 2.4e-4 && slope < 3.0e-4, "{slope}");
        // Humid air adds a wet delay of ~0.1–0.2 m.
        let (_, w) = saastamoinen_zenith(45f64.to_radians(), 0.0, 0.7);
        assert!(w > 0.08 && w < 0.25, "{w}");
    }

    #[test]
    fn mapping_functions_behave_like_cosecant() {
        let lat = 35f64.to_radians();
        let (mh, mw) = niell_mapping(core::f64::consts::FRAC_PI_2, lat, 0.0, 92.0);
        assert!((mh - 1.0).abs() < 1e-9 && (mw - 1.0).abs() < 1e-9);
        // Near 1/sin ε at moderate elevations, a little below it at low ones.
        for deg in [15.0f64, 30.0, 60.0] {
            let el = deg.to_radians();
            let (mh, mw) = niell_mapping(el, lat, 0.0, 92.0);
            let csc = 1.0 / el.sin();
            assert!(mh < csc && mh > 0.97 * csc, "{deg}: {mh} {csc}");
            assert!(mw < csc * 1.01 && mw > 0.97 * csc, "{deg}: {mw} {csc}");
        }
        // Known value: hydrostatic NMF at 5° is close to 10.15 (mid latitudes).
        let (m5, _) = niell_mapping(5f64.to_radians(), 45f64.to_radians(), 0.0, 28.0);
        assert!((m5 - 10.15).abs() < 0.1, "{m5}");
        // Monotone in elevation.
        let mut prev = f64::INFINITY;
        for k in 1..90 {
            let (m, _) = niell_mapping((k as f64).to_radians(), lat, 100.0, 92.0);
            assert!(m < prev);
            prev = m;
        }
    }

    #[test]
    fn latitude_interpolation_hits_the_nodes() {
        let row = [1.0, 2.0, 4.0, 8.0, 16.0];
        assert_eq!(interp_lat(&row, 10.0), 1.0);
        assert_eq!(interp_lat(&row, 30.0), 2.0);
        assert_eq!(interp_lat(&row, 37.5), 3.0);
        assert_eq!(interp_lat(&row, 75.0), 16.0);
        assert_eq!(interp_lat(&row, 89.0), 16.0);
    }

    #[test]
    fn day_of_year_of_known_dates() {
        let gps = |days_since_1980_01_06: f64| days_since_1980_01_06 * 86_400.0;
        // 1980-01-06 is day 6.
        assert!((day_of_year(gps(0.0)) - 6.0).abs() < 1e-9);
        // 2005-04-02 00:00 GPS (GPS week 1316, Saturday): day 92.
        let t = 1316.0 * 604_800.0 + 6.0 * 86_400.0;
        assert!((day_of_year(t) - 92.0).abs() < 1e-9, "{}", day_of_year(t));
        // Noon adds half a day; 2004 is a leap year: 2004-12-31 is day 366.
        assert!((day_of_year(t + 43_200.0) - 92.5).abs() < 1e-9);
        let dec31 = t - 92.0 * 86_400.0;
        assert!((day_of_year(dec31) - 366.0).abs() < 1e-9);
    }

    #[test]
    fn slant_delay_difference_of_two_nearby_sites() {
        // Sites 3.3 km apart see a 15° satellite at elevations ~0.03° apart:
        // the slant delays then differ by about a centimetre.
        let lat = 35f64.to_radians();
        let el = 15f64.to_radians();
        let d_el = (3300.0f64 / 6.371e6).min(1.0);
        let a = slant_delay(el, lat, 50.0, 92.0, 0.0);
        let b = slant_delay(el + d_el, lat, 50.0, 92.0, 0.0);
        let diff = a - b;
        assert!(diff > 0.008 && diff < 0.03, "{diff}");
    }
}
