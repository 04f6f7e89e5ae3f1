//! Broadcast Kepler orbits of GPS, Galileo, BeiDou (MEO/IGSO and GEO) and
//! QZSS, with each system's constants and time scale.
//!
//! The orbit elements are those of [`KeplerOrbit`] (times `t_oe`, `t_oc` in
//! GPS seconds); what differs per system:
//! - GPS, QZSS: μ = 3.986005e14 m³/s², Ω̇e = 7.2921151467e-5 rad/s
//!   (IS-GPS-200 Table 20-IV; IS-QZSS-PNT §5.2.2.2.3);
//! - Galileo: μ = 3.986004418e14, Ω̇e = 7.2921151467e-5 (Galileo OS SIS ICD
//!   2.0 §5.1.1); GST is steered to GPS time (the GGTO, tens of ns, is
//!   neglected here);
//! - BeiDou: μ = 3.986004418e14, Ω̇e = 7.2921150e-5 (BDS-SIS-ICD-B1I 3.0
//!   §5.2.4.10); BDT = GPST − 14 s, so Ω_k uses t_oe as seconds of the BDT
//!   week; GEO satellites (C01–C05, C59–C63) are computed in an inertial-like
//!   frame then rotated by −5° about X and by Ω̇e·t_k about Z (Table 5-11).
//!
//! The relativistic clock term `F e √a sin E_k` uses F = −2√μ/c² of the
//! system's μ.

#[allow(unused_imports)]
use crate::prelude::*;

use super::{KeplerOrbit, C_LIGHT, SECONDS_PER_WEEK};
use crate::Vec3;

/// How a broadcast orbit is evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum OrbitKind {
    /// GPS (and QZSS) constants.
    #[default]
    Gps,
    Galileo,
    /// BeiDou MEO and IGSO.
    BeiDou,
    /// BeiDou geostationary (C01–C05, C59–C63).
    BeiDouGeo,
}

/// BDT − GPST [s] (BDT started 2006-01-01 00:00:00 UTC, 14 leap seconds
/// after GPST's start).
pub const BDT_MINUS_GPST: f64 = -14.0;

impl OrbitKind {
    /// (μ [m³/s²], Ω̇e [rad/s]) of the system.
    pub fn constants(self) -> (f64, f64) {
        match self {
            OrbitKind::Gps => (super::MU_GPS, super::OMEGA_E_DOT),
            OrbitKind::Galileo => (3.986004418e14, 7.2921151467e-5),
            OrbitKind::BeiDou | OrbitKind::BeiDouGeo => (3.986004418e14, 7.292115e-5),
        }
    }

    /// The system time scale minus GPS time [s].
    pub fn time_offset(self) -> f64 {
        match self {
            OrbitKind::BeiDou | OrbitKind::BeiDouGeo => BDT_MINUS_GPST,
            _ => 0.0,
        }
    }

    /// The kind of a BeiDou PRN (GEO for C01–C05 and C59–C63).
    pub fn beidou(prn: u8) -> OrbitKind {
        if (1..=5).contains(&prn) || (59..=63).contains(&prn) {
            OrbitKind::BeiDouGeo
        } else {
            OrbitKind::BeiDou
        }
    }
}

fn eccentric_anomaly(o: &KeplerOrbit, mu: f64, tk: f64) -> f64 {
    let a = o.sqrt_a * o.sqrt_a;
    let n0 = (mu / (a * a * a)).sqrt();
    let m = o.m0 + (n0 + o.delta_n) * tk;
    let mut ek = m;
    for _ in 0..30 {
        let d = (ek - o.e * ek.sin() - m) / (1.0 - o.e * ek.cos());
        ek -= d;
        if d.abs() < 1e-14 {
            break;
        }
    }
    ek
}

/// Satellite position, ECEF of the same instant, at GPS time `t` [m].
pub fn position_ecef(o: &KeplerOrbit, kind: OrbitKind, t: f64) -> Vec3 {
    if kind == OrbitKind::Gps {
        return o.position_ecef(t);
    }
    let (mu, we) = kind.constants();
    let a = o.sqrt_a * o.sqrt_a;
    let tk = t - o.t_oe;
    let ek = eccentric_anomaly(o, mu, tk);
    let (se, ce) = (ek.sin(), ek.cos());
    let nu = ((1.0 - o.e * o.e).sqrt() * se).atan2(ce - o.e);
    let phi = nu + o.argp;
    let (s2, c2) = ((2.0 * phi).sin(), (2.0 * phi).cos());
    let u = phi + o.cus * s2 + o.cuc * c2;
    let r = a * (1.0 - o.e * ce) + o.crs * s2 + o.crc * c2;
    let i = o.i0 + o.idot * tk + o.cis * s2 + o.cic * c2;
    let (xp, yp) = (r * u.cos(), r * u.sin());
    // t_oe as seconds of the system's own week.
    let toe_sys = o.t_oe + kind.time_offset();
    let toe_sow = toe_sys - (toe_sys / SECONDS_PER_WEEK).floor() * SECONDS_PER_WEEK;
    let (si, ci) = (i.sin(), i.cos());
    if kind == OrbitKind::BeiDouGeo {
        // BDS-SIS-ICD-B1I 3.0 Table 5-11.
        let om = o.omega0 + o.omega_dot * tk - we * toe_sow;
        let (so, co) = (om.sin(), om.cos());
        let xg = xp * co - yp * ci * so;
        let yg = xp * so + yp * ci * co;
        let zg = yp * si;
        let (sf, cf) = ((-5f64).to_radians().sin(), (-5f64).to_radians().cos());
        // R_X(−5°)
        let x1 = xg;
        let y1 = cf * yg + sf * zg;
        let z1 = -sf * yg + cf * zg;
        // R_Z(Ω̇e t_k)
        let (sz, cz) = ((we * tk).sin(), (we * tk).cos());
        return Vec3::new(cz * x1 + sz * y1, -sz * x1 + cz * y1, z1);
    }
    let om = o.omega0 + (o.omega_dot - we) * tk - we * toe_sow;
    let (so, co) = (om.sin(), om.cos());
    Vec3::new(xp * co - yp * ci * so, xp * so + yp * ci * co, yp * si)
}

/// Satellite clock offset at GPS time `t` [s] with the relativistic term,
/// without group delays.
pub fn clock_offset(o: &KeplerOrbit, kind: OrbitKind, t: f64) -> f64 {
    if kind == OrbitKind::Gps {
        return o.clock_offset(t);
    }
    let (mu, _) = kind.constants();
    let f_rel = -2.0 * mu.sqrt() / (C_LIGHT * C_LIGHT);
    let dt = t - o.t_oc;
    let ek = eccentric_anomaly(o, mu, t - o.t_oe);
    o.af0 + o.af1 * dt + o.af2 * dt * dt + f_rel * o.e * o.sqrt_a * ek.sin()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geodesy::ecef_to_geodetic;

    /// A BeiDou GEO broadcast set as the ICD defines it: elements in a
    /// frame tilted by 5°, so a truly geostationary satellite is broadcast
    /// with i0 ≈ 5° and its node along −X (Ω_k ≈ π). Evaluated with the GEO
    /// algorithm it stays within tens of km of one ECEF point over a day at
    /// ~35 786 km height; evaluated as a MEO (no tilt) the same elements
    /// swing ±5° (≈ ±3,700 km) north–south. The GEO and MEO results are
    /// related by R_Z(Ω̇e t_k) R_X(−5°) R_Z(−Ω̇e t_k) (Table 5-11).
    #[test]
    fn beidou_geo_stays_put_over_a_day() {
        let t0 = 1316.0 * SECONDS_PER_WEEK + 518_400.0;
        let (mu, we) = OrbitKind::BeiDouGeo.constants();
        let toe_sow = (t0 - 14.0) % SECONDS_PER_WEEK;
        let o = KeplerOrbit {
            prn: 1,
            sqrt_a: (mu / (we * we)).powf(1.0 / 6.0),
            e: 4.0e-4,
            i0: 5f64.to_radians(),
            omega0: core::f64::consts::PI + we * toe_sow,
            argp: 0.5,
            m0: 0.2,
            t_oe: t0,
            t_oc: t0,
            ..Default::default()
        };
        let p0 = position_ecef(&o, OrbitKind::BeiDouGeo, t0);
        let h = ecef_to_geodetic(&p0).h;
        assert!((h - 35_786e3).abs() < 50e3, "height {h}");
        let (mut geo, mut meo) = (0.0f64, 0.0f64);
        let m0 = position_ecef(&o, OrbitKind::BeiDou, t0);
        for k in -12..=12 {
            let t = t0 + k as f64 * 3600.0;
            let p = position_ecef(&o, OrbitKind::BeiDouGeo, t);
            let q = position_ecef(&o, OrbitKind::BeiDou, t);
            geo = geo.max((p - p0).norm());
            meo = meo.max((q - m0).norm());
            // The ICD's relation between the two evaluations.
            let th = we * (t - t0);
            let rz = |a: f64, v: Vec3| {
                Vec3::new(
                    a.cos() * v.x + a.sin() * v.y,
                    -a.sin() * v.x + a.cos() * v.y,
                    v.z,
                )
            };
            let f = (-5f64).to_radians();
            let rx = |v: Vec3| {
                Vec3::new(
                    v.x,
                    f.cos() * v.y + f.sin() * v.z,
                    -f.sin() * v.y + f.cos() * v.z,
                )
            };
            let expect = rz(th, rx(rz(-th, q)));
            assert!((expect - p).norm() < 1e-3, "{}", (expect - p).norm());
        }
        assert!(geo < 100e3, "GEO moved {geo} m in a day");
        assert!(meo > 5_000e3, "MEO-evaluated GEO moved only {meo} m");
    }

    /// Galileo and BeiDou MEO orbits with the GPS algorithm differ only by
    /// μ, Ω̇e and (BeiDou) the 14 s week offset: with GPS constants
    /// substituted the results coincide; with their own they move by the
    /// expected amounts.
    #[test]
    fn galileo_and_beidou_meo_constants() {
        let t0 = 1316.0 * SECONDS_PER_WEEK + 518_400.0;
        let o = KeplerOrbit {
            prn: 11,
            sqrt_a: 5440.6,
            e: 2.0e-4,
            i0: 0.97,
            omega0: 1.2,
            omega_dot: -5.5e-9,
            argp: 0.3,
            m0: 1.1,
            t_oe: t0,
            t_oc: t0,
            af0: 1e-4,
            ..Default::default()
        };
        let t = t0 + 1800.0;
        let gps = position_ecef(&o, OrbitKind::Gps, t);
        let gal = position_ecef(&o, OrbitKind::Galileo, t);
        // Δμ/μ = 2e-8 changes the mean motion by 1e-8 → ~0.5 m along track
        // after 30 min at 3.6 km/s... within a few metres.
        let d = (gps - gal).norm();
        assert!(d > 0.01 && d < 5.0, "GPS vs Galileo constants {d} m");
        // BeiDou: t_oe in the BDT week is 14 s earlier, so the node is
        // Ω̇e·14 s further east: the Galileo result rotated about Z, plus
        // the two Ω̇e's difference (1.5e-12 rad/s) over t_oe + t_k.
        let bds = position_ecef(&o, OrbitKind::BeiDou, t);
        let (wb, wg) = (
            OrbitKind::BeiDou.constants().1,
            OrbitKind::Galileo.constants().1,
        );
        let th = wb * 14.0 - (wb - wg) * (t - t0 + t0 % SECONDS_PER_WEEK);
        let rot = Vec3::new(
            th.cos() * gal.x - th.sin() * gal.y,
            th.sin() * gal.x + th.cos() * gal.y,
            gal.z,
        );
        assert!(
            (bds - rot).norm() < 0.2,
            "BDT week offset {}",
            (bds - rot).norm()
        );
        assert!((bds - gal).norm() > 1e3);
        // Relativistic clock term within the expected size (|F e √a| ≤ 1e-9 s here).
        let c = clock_offset(&o, OrbitKind::Galileo, t);
        assert!((c - 1e-4).abs() < 1e-9);
        assert_eq!(OrbitKind::beidou(3), OrbitKind::BeiDouGeo);
        assert_eq!(OrbitKind::beidou(60), OrbitKind::BeiDouGeo);
        assert_eq!(OrbitKind::beidou(19), OrbitKind::BeiDou);
    }
}
