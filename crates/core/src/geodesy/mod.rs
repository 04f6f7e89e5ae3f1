//! WGS84 geodesy: geodetic ↔ ECEF, ECEF ↔ NED/ENU, local tangent-plane
//! coordinates, Transverse Mercator (Krüger series, Karney 2011), UTM, and the
//! seed 002 small-area plane.
//!
//! Angles in radians, lengths in metres. The ellipsoid constants come from
//! [`crate::earth`] (`WGS84_A`, `WGS84_F`, `WGS84_E2`).
//!
//! | item | file | reference |
//! |---|---|---|
//! | [`geodetic_to_ecef`], [`ecef_to_geodetic`] | `ecef.rs` | Groves 2nd ed. §2.4; Vermeille (2011), J. Geodesy 85:105–117 |
//! | [`c_en`], [`c_e_enu`], NED/ENU offsets, [`LocalFrame`] | `local.rs` | Groves 2nd ed. §2.4 (C_e^n) |
//! | [`TransverseMercator`] | `tm.rs` | Karney (2011), J. Geodesy 85:475–485 |
//! | [`Utm`], [`utm_zone`] | `utm.rs` | NGA.SIG.0012 (UTM/UPS), DMA TM 8358.2 |
//! | [`SmallAreaPlane`] | `plane.rs` | `SEEDS.md §2` eq. 14–15 |

#[allow(unused_imports)]
use crate::prelude::*;

mod ecef;
mod local;
mod plane;
mod tm;
#[cfg(test)]
mod tm_fixture_tests;
mod utm;

pub use ecef::{ecef_to_geodetic, geodetic_to_ecef};
pub use local::{
    c_e_enu, c_en, ecef_from_enu, ecef_from_ned, enu_from_ecef, enu_from_geodetic,
    geodetic_from_enu, geodetic_from_ned, ned_from_ecef, ned_from_geodetic, LocalFrame,
};
pub use plane::{PlanePoint, SmallAreaPlane};
pub use tm::{TmPoint, TransverseMercator};
pub use utm::{
    utm_central_meridian, utm_projection, utm_zone, utm_zone_from_lon, Utm, UTM_FALSE_EASTING,
    UTM_FALSE_NORTHING_SOUTH, UTM_K0,
};

/// A geodetic position on WGS84: latitude, longitude [rad], ellipsoidal height [m].
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Geodetic {
    pub lat: f64,
    pub lon: f64,
    pub h: f64,
}

impl Geodetic {
    /// From latitude and longitude in degrees and height in metres (I/O edge helper).
    pub fn from_degrees(lat_deg: f64, lon_deg: f64, h: f64) -> Self {
        Geodetic {
            lat: lat_deg.to_radians(),
            lon: lon_deg.to_radians(),
            h,
        }
    }
}

/// Errors of the map projections (UTM zone and range checks, non-finite input).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GeodesyError {
    /// UTM zone outside 1..=60.
    InvalidZone(u8),
    /// Latitude outside the UTM range 80° S ..= 84° N [rad].
    LatitudeOutOfRange(f64),
    /// A NaN or infinite coordinate.
    NonFinite,
}

impl core::fmt::Display for GeodesyError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            GeodesyError::InvalidZone(z) => write!(f, "UTM zone {z} is outside 1..=60"),
            GeodesyError::LatitudeOutOfRange(lat) => write!(
                f,
                "latitude {:.6}° is outside the UTM range 80°S..84°N",
                lat.to_degrees()
            ),
            GeodesyError::NonFinite => write!(f, "coordinate is NaN or infinite"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for GeodesyError {}

/// Wrap an angle to (−π, π] [rad].
#[inline]
pub fn wrap_pi(a: f64) -> f64 {
    use core::f64::consts::{PI, TAU};
    let mut w = a % TAU; // in (−2π, 2π)
    if w > PI {
        w -= TAU;
    } else if w <= -PI {
        w += TAU;
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    #[test]
    fn wrap_pi_range() {
        assert_eq!(wrap_pi(0.0), 0.0);
        assert!((wrap_pi(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_pi(-3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_pi(PI + 0.1) - (-PI + 0.1)).abs() < 1e-12);
        assert!((wrap_pi(-PI - 0.1) - (PI - 0.1)).abs() < 1e-12);
        assert!((wrap_pi(7.0) - (7.0 - 2.0 * PI)).abs() < 1e-12);
    }

    #[test]
    fn error_messages_name_the_problem() {
        extern crate std;
        use std::string::ToString;
        assert!(GeodesyError::InvalidZone(61).to_string().contains("61"));
        assert!(GeodesyError::LatitudeOutOfRange(85f64.to_radians())
            .to_string()
            .contains("85.0"));
    }
}
