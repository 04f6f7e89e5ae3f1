//! WGS84 geodesy (CONTRACT STUB — being filled in): geodetic ↔ ECEF,
//! ECEF ↔ NED/ENU, local tangent-plane coordinates, Transverse Mercator
//! (Krüger series, Karney 2011), UTM, and the seed 002 small-area plane.
//!
//! Angles in radians, lengths in metres.

#[allow(unused_imports)]
use crate::prelude::*;
use crate::{Mat3, Vec3};

/// A geodetic position on WGS84: latitude, longitude [rad], ellipsoidal height [m].
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Geodetic {
    pub lat: f64,
    pub lon: f64,
    pub h: f64,
}

/// Geodetic → ECEF [m].
pub fn geodetic_to_ecef(p: &Geodetic) -> Vec3 {
    let _ = p;
    unimplemented!()
}

/// ECEF [m] → geodetic (closed form or iterated to < 1e-6 m).
pub fn ecef_to_geodetic(r_e: &Vec3) -> Geodetic {
    let _ = r_e;
    unimplemented!()
}

/// DCM from ECEF to NED at (lat, lon): `v_n = c_en · v_e`.
pub fn c_en(lat: f64, lon: f64) -> Mat3 {
    let _ = (lat, lon);
    unimplemented!()
}

/// NED offset [m] of `p` from the origin `origin` (exact, through ECEF).
pub fn ned_from_geodetic(origin: &Geodetic, p: &Geodetic) -> Vec3 {
    let _ = (origin, p);
    unimplemented!()
}

/// Geodetic position at NED offset `d_n` [m] from `origin` (exact, through ECEF).
pub fn geodetic_from_ned(origin: &Geodetic, d_n: &Vec3) -> Geodetic {
    let _ = (origin, d_n);
    unimplemented!()
}
