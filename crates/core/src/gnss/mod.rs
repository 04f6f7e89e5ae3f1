//! GNSS geometry: orbits from almanac/ephemeris, line of sight, double differences (`SEEDS.md §3`).
//!
//! - [`KeplerOrbit`]: GPS satellite position and clock from a YUMA almanac or
//!   a broadcast ephemeris by the IS-GPS-200 user algorithm (Table 20-IV),
//!   μ = 3.986005e14 m³/s², Ω̇e = 7.2921151467e-5 rad/s.
//! - [`sat_at_receive`]: position at transmission time, rotated into the ECEF
//!   frame of the reception time (earth rotation during signal travel,
//!   Groves §8.5.3).
//! - [`look`]: elevation/azimuth and the line-of-sight unit vector in local
//!   ENU (east-north-up) at the receiver, the frame of seed 003.
//! - [`visible_by_elevation`]: satellites above an elevation mask, ordered by
//!   decreasing elevation (the order of the paper's double differences).
//! - [`dd`]: the paper's double differences (eq. 8–10) and their covariance.
//! - [`raw`]: raw observations (pseudorange, phase, Doppler) as events.
//! - [`tropo`]: Saastamoinen zenith delays and Niell mapping functions.
//! - [`orbit_gnss`]: Galileo/BeiDou (incl. GEO)/QZSS broadcast orbits.
//! - [`glonass`]: GLONASS broadcast ephemeris (RK4 in PZ-90, ICD 5.1 A.3.1.2).
//! - [`iono`]: Klobuchar broadcast ionosphere (IS-GPS-200 Fig. 20-4).
//! - [`spp`]: single-point positioning (WLS, RAIM FDE, DOPs, Doppler velocity).
//! - [`slip`]: dual-frequency geometry-free and Melbourne–Wübbena cycle-slip tests.
//!
//! Time: GPS seconds since the GPS epoch (`week · 604800 + tow`).

#![allow(clippy::needless_range_loop)] // index loops mirror the matrix equations

pub use crate::geodesy::c_e_enu;
use crate::geodesy::ecef_to_geodetic;
#[allow(unused_imports)]
use crate::prelude::*;
use crate::{Mat3, Vec3};

pub mod dd;
pub mod glonass;
pub mod iono;
pub mod orbit_gnss;
pub mod raw;
pub mod slip;
pub mod spp;
pub mod tropo;

/// Earth gravitational constant for GPS, IS-GPS-200 [m³/s²].
pub const MU_GPS: f64 = 3.986005e14;
/// Earth rotation rate, IS-GPS-200 [rad/s].
pub const OMEGA_E_DOT: f64 = 7.2921151467e-5;
/// Speed of light [m/s].
pub const C_LIGHT: f64 = 299_792_458.0;
/// GPS L1 carrier wavelength [m] (c / 1575.42 MHz).
pub const LAMBDA_L1: f64 = C_LIGHT / 1575.42e6;
/// GPS L2 carrier wavelength [m] (c / 1227.60 MHz).
pub const LAMBDA_L2: f64 = C_LIGHT / 1227.60e6;
/// Seconds per GPS week.
pub const SECONDS_PER_WEEK: f64 = 604_800.0;
/// Relativistic clock correction constant F = −2√μ/c², IS-GPS-200 [s/√m].
const F_REL: f64 = -4.442807633e-10;

/// Keplerian GPS orbit and clock: a broadcast ephemeris, or an almanac
/// (harmonic corrections, Δn and i̇ zero; `i0` the full inclination).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct KeplerOrbit {
    /// PRN number.
    pub prn: u8,
    /// Health word as broadcast (0 = healthy).
    pub health: u32,
    /// Reference time of ephemeris (or almanac t_oa), GPS seconds since the GPS epoch.
    pub t_oe: f64,
    /// Reference time of the clock terms, GPS seconds since the GPS epoch.
    pub t_oc: f64,
    /// √a [√m].
    pub sqrt_a: f64,
    /// Eccentricity.
    pub e: f64,
    /// Inclination at t_oe [rad].
    pub i0: f64,
    /// Rate of inclination [rad/s].
    pub idot: f64,
    /// Longitude of the ascending node at the weekly epoch, Ω0 [rad].
    pub omega0: f64,
    /// Rate of right ascension Ω̇ [rad/s].
    pub omega_dot: f64,
    /// Argument of perigee ω [rad].
    pub argp: f64,
    /// Mean anomaly at t_oe [rad].
    pub m0: f64,
    /// Mean motion correction Δn [rad/s].
    pub delta_n: f64,
    /// Harmonic corrections (argument of latitude [rad], radius [m], inclination [rad]).
    pub cuc: f64,
    pub cus: f64,
    pub crc: f64,
    pub crs: f64,
    pub cic: f64,
    pub cis: f64,
    /// Clock bias [s], drift [s/s], drift rate [s/s²].
    pub af0: f64,
    pub af1: f64,
    pub af2: f64,
    /// Group delay T_GD [s] (L1 single frequency users subtract it).
    pub tgd: f64,
}

impl KeplerOrbit {
    /// Eccentric anomaly at GPS time `t` (Kepler's equation by Newton iteration).
    fn eccentric_anomaly(&self, t: f64) -> (f64, f64) {
        let a = self.sqrt_a * self.sqrt_a;
        let n0 = (MU_GPS / (a * a * a)).sqrt();
        let tk = t - self.t_oe;
        let m = self.m0 + (n0 + self.delta_n) * tk;
        let mut ek = m;
        for _ in 0..30 {
            let d = (ek - self.e * ek.sin() - m) / (1.0 - self.e * ek.cos());
            ek -= d;
            if d.abs() < 1e-14 {
                break;
            }
        }
        (ek, tk)
    }

    /// Satellite position in ECEF at GPS time `t` [m] (IS-GPS-200 Table 20-IV),
    /// in the earth-fixed frame of the same instant `t`.
    pub fn position_ecef(&self, t: f64) -> Vec3 {
        let a = self.sqrt_a * self.sqrt_a;
        let (ek, tk) = self.eccentric_anomaly(t);
        let (se, ce) = (ek.sin(), ek.cos());
        let nu = ((1.0 - self.e * self.e).sqrt() * se).atan2(ce - self.e);
        let phi = nu + self.argp;
        let (s2, c2) = ((2.0 * phi).sin(), (2.0 * phi).cos());
        let u = phi + self.cus * s2 + self.cuc * c2;
        let r = a * (1.0 - self.e * ce) + self.crs * s2 + self.crc * c2;
        let i = self.i0 + self.idot * tk + self.cis * s2 + self.cic * c2;
        let (xp, yp) = (r * u.cos(), r * u.sin());
        // Ω_k = Ω0 + (Ω̇ − Ω̇e) t_k − Ω̇e t_oe (t_oe as seconds of its week).
        let toe_sow = self.t_oe - (self.t_oe / SECONDS_PER_WEEK).floor() * SECONDS_PER_WEEK;
        let om = self.omega0 + (self.omega_dot - OMEGA_E_DOT) * tk - OMEGA_E_DOT * toe_sow;
        let (so, co) = (om.sin(), om.cos());
        let (si, ci) = (i.sin(), i.cos());
        Vec3::new(xp * co - yp * ci * so, xp * so + yp * ci * co, yp * si)
    }

    /// Satellite clock offset at GPS time `t` [s], with the relativistic term
    /// (IS-GPS-200 §20.3.3.3.3.1), without T_GD.
    pub fn clock_offset(&self, t: f64) -> f64 {
        let dt = t - self.t_oc;
        let (ek, _) = self.eccentric_anomaly(t);
        self.af0 + self.af1 * dt + self.af2 * dt * dt + F_REL * self.e * self.sqrt_a * ek.sin()
    }
}

/// A satellite as seen at reception: position at transmission rotated into
/// the ECEF frame of reception, geometric range and transmission time.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct SatAtReceive {
    /// Satellite position, ECEF frame at reception time [m].
    pub pos_e: Vec3,
    /// Geometric range receiver–satellite [m].
    pub range: f64,
    /// Transmission time, GPS seconds [s].
    pub t_tx: f64,
}

/// Satellite position at transmission for a signal received at `t_rx` by a
/// receiver at `rx_e` (ECEF) — light-time iteration with earth rotation
/// during signal travel (Sagnac; Groves eq. 8.36).
pub fn sat_at_receive(orbit: &KeplerOrbit, rx_e: &Vec3, t_rx: f64) -> SatAtReceive {
    let mut tau = 0.075;
    let mut out = SatAtReceive::default();
    for _ in 0..6 {
        let t_tx = t_rx - tau;
        let p = orbit.position_ecef(t_tx);
        let th = OMEGA_E_DOT * tau;
        let (s, c) = (th.sin(), th.cos());
        let p_rot = Vec3::new(c * p.x + s * p.y, -s * p.x + c * p.y, p.z);
        let range = (p_rot - rx_e).norm();
        out = SatAtReceive {
            pos_e: p_rot,
            range,
            t_tx,
        };
        let new_tau = range / C_LIGHT;
        if (new_tau - tau).abs() < 1e-12 {
            break;
        }
        tau = new_tau;
    }
    out
}

/// How a satellite looks from a receiver.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Look {
    /// PRN.
    pub prn: u8,
    /// Elevation [rad].
    pub el: f64,
    /// Azimuth from north, clockwise (towards east) [rad], in [0, 2π).
    pub az: f64,
    /// Unit line of sight receiver → satellite, local ENU.
    pub los_enu: Vec3,
    /// Geometric range [m] and satellite ECEF position at reception frame.
    pub range: f64,
    pub sat_e: Vec3,
}

/// Elevation, azimuth and ENU line of sight of `orbit` from the receiver at
/// `rx_e` (ECEF) with ECEF→ENU rotation `c_e_enu` at time `t_rx`.
pub fn look(orbit: &KeplerOrbit, rx_e: &Vec3, c_e_enu: &Mat3, t_rx: f64) -> Look {
    let s = sat_at_receive(orbit, rx_e, t_rx);
    let los_enu = c_e_enu * ((s.pos_e - rx_e) / s.range);
    let el = los_enu.z.clamp(-1.0, 1.0).asin();
    let mut az = los_enu.x.atan2(los_enu.y);
    if az < 0.0 {
        az += 2.0 * core::f64::consts::PI;
    }
    Look {
        prn: orbit.prn,
        el,
        az,
        los_enu,
        range: s.range,
        sat_e: s.pos_e,
    }
}

/// Healthy satellites of `orbits` above `mask` [rad] at `t_rx`, written to
/// `out` in order of decreasing elevation; returns how many (≤ `out.len()`:
/// the highest ones are kept when more are visible).
pub fn visible_by_elevation(
    orbits: &[KeplerOrbit],
    rx_e: &Vec3,
    t_rx: f64,
    mask: f64,
    out: &mut [Look],
) -> usize {
    let g = ecef_to_geodetic(rx_e);
    let c = c_e_enu(g.lat, g.lon);
    let mut n = 0usize;
    for o in orbits.iter().filter(|o| o.health == 0) {
        let l = look(o, rx_e, &c, t_rx);
        if l.el < mask {
            continue;
        }
        // Insertion into the descending list, dropping the lowest when full.
        let mut k = n;
        while k > 0 && out[k - 1].el < l.el {
            k -= 1;
        }
        if k >= out.len() {
            continue;
        }
        let last = if n < out.len() { n } else { out.len() - 1 };
        let mut j = last;
        while j > k {
            out[j] = out[j - 1];
            j -= 1;
        }
        out[k] = l;
        if n < out.len() {
            n += 1;
        }
    }
    n
}

/// Rising or setting: the sign of the elevation rate at `t` (central difference over ±`dt`).
pub fn elevation_rate(orbit: &KeplerOrbit, rx_e: &Vec3, c_e_enu: &Mat3, t: f64, dt: f64) -> f64 {
    let a = look(orbit, rx_e, c_e_enu, t - dt).el;
    let b = look(orbit, rx_e, c_e_enu, t + dt).el;
    (b - a) / (2.0 * dt)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geodesy::{geodetic_to_ecef, Geodetic};

    /// A GPS-like circular orbit.
    fn orbit() -> KeplerOrbit {
        KeplerOrbit {
            prn: 1,
            sqrt_a: 5153.6,
            e: 0.01,
            i0: 0.96,
            omega0: 1.0,
            omega_dot: -8e-9,
            argp: 0.5,
            m0: 0.3,
            t_oe: 2035.0 * SECONDS_PER_WEEK + 319_488.0,
            ..Default::default()
        }
    }

    #[test]
    fn orbit_radius_and_period() {
        let o = orbit();
        let a = o.sqrt_a * o.sqrt_a;
        let p = o.position_ecef(o.t_oe);
        assert!(p.norm() > a * (1.0 - o.e) - 1.0 && p.norm() < a * (1.0 + o.e) + 1.0);
        // After one sidereal-ish orbital period the inertial position repeats;
        // ECEF differs by the earth rotation over the period only.
        let period = 2.0 * core::f64::consts::PI * (a * a * a / MU_GPS).sqrt();
        let q = o.position_ecef(o.t_oe + period);
        let th = -(o.omega_dot - OMEGA_E_DOT) * period;
        let (s, c) = (th.sin(), th.cos());
        let q_back = Vec3::new(c * q.x - s * q.y, s * q.x + c * q.y, q.z);
        assert!((q_back - p).norm() < 1e-3, "{}", (q_back - p).norm());
    }

    #[test]
    fn light_time_consistent() {
        let o = orbit();
        let rx = geodetic_to_ecef(&Geodetic {
            lat: 0.6,
            lon: 2.2,
            h: 50.0,
        });
        let t = o.t_oe + 1000.0;
        let s = sat_at_receive(&o, &rx, t);
        // Absolute GPS seconds near 1.2e9 carry ~2e-7 s of rounding.
        assert!((s.range / C_LIGHT - (t - s.t_tx)).abs() < 1e-6);
        assert!(s.range > 1.9e7 && s.range < 2.6e7 + 6.4e6);
    }

    #[test]
    fn visible_sorted_and_masked() {
        let mut orbits = [orbit(); 8];
        for (k, o) in orbits.iter_mut().enumerate() {
            o.prn = k as u8 + 1;
            o.m0 = k as f64 * 0.8;
            o.omega0 = k as f64 * 0.7;
        }
        let rx = geodetic_to_ecef(&Geodetic {
            lat: 0.6,
            lon: 2.2,
            h: 50.0,
        });
        let mut out = [Look::default(); 8];
        let n = visible_by_elevation(&orbits, &rx, orbits[0].t_oe, 0.1, &mut out);
        for w in out[..n].windows(2) {
            assert!(w[0].el >= w[1].el);
        }
        for l in &out[..n] {
            assert!(l.el >= 0.1);
            assert!((l.los_enu.norm() - 1.0).abs() < 1e-12);
            assert!((l.los_enu.z - l.el.sin()).abs() < 1e-12);
        }
        // Capacity smaller than the visible count keeps the highest ones.
        let mut small = [Look::default(); 2];
        let m = visible_by_elevation(&orbits, &rx, orbits[0].t_oe, 0.1, &mut small);
        assert_eq!(m, n.min(2));
        if m == 2 {
            assert_eq!(small[0].prn, out[0].prn);
            assert_eq!(small[1].prn, out[1].prn);
        }
    }
}
