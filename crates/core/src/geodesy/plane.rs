//! The seed 002 small-area plane (`SEEDS.md §2` eq. 14–15):
//!
//! N = (R_M + h)(L − L0),  E = (R_N + h) cos L (l − l0)
//!
//! with L, l the latitude and longitude of the point, h its ellipsoidal height,
//! (L0, l0) the origin. This is the paper's approximation: an equirectangular
//! map with the radii of curvature R_M, R_N (`earth::radii`) evaluated at the
//! **origin latitude L0** (the paper does not say where; at L0 the map is a
//! fixed-scale projection with an exact closed-form inverse). It is neither
//! conformal nor a tangent plane: against the exact local NED offset it is off
//! by roughly d² tan L / (2R) (≈ 0.2 m at d = 2 km, L = 30°) and worse with
//! distance and latitude. Use [`super::TransverseMercator`] (Krüger series)
//! or the exact [`super::LocalFrame`] when accuracy matters; this one exists so
//! seed 002 can be reproduced as published. Not for use near the poles
//! (cos L → 0).

#[allow(unused_imports)]
use crate::prelude::*;

use super::{wrap_pi, Geodetic};
use crate::earth::radii;

/// A point of the small-area plane: north and east of the origin [m].
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct PlanePoint {
    /// N [m], `SEEDS.md §2` eq. 14.
    pub north: f64,
    /// E [m], `SEEDS.md §2` eq. 15.
    pub east: f64,
}

/// The seed 002 small-area plane at a fixed origin (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmallAreaPlane {
    /// Origin (L0, l0); its height is not used.
    pub origin: Geodetic,
    /// R_M at L0 [m].
    r_m0: f64,
    /// R_N at L0 [m].
    r_n0: f64,
}

impl SmallAreaPlane {
    /// Plane with origin (L0, l0) = (`origin.lat`, `origin.lon`).
    pub fn new(origin: Geodetic) -> Self {
        let (r_m0, r_n0) = radii(origin.lat);
        SmallAreaPlane { origin, r_m0, r_n0 }
    }

    /// Geodetic → plane (`SEEDS.md §2` eq. 14–15). The height passes through
    /// unchanged (keep `p.h` alongside).
    pub fn forward(&self, p: &Geodetic) -> PlanePoint {
        PlanePoint {
            north: (self.r_m0 + p.h) * (p.lat - self.origin.lat),
            east: (self.r_n0 + p.h) * p.lat.cos() * wrap_pi(p.lon - self.origin.lon),
        }
    }

    /// Plane → geodetic: the exact inverse of [`Self::forward`] for the
    /// height `h` the point was projected with. Longitude wrapped to (−π, π].
    pub fn inverse(&self, q: &PlanePoint, h: f64) -> Geodetic {
        let lat = self.origin.lat + q.north / (self.r_m0 + h);
        let lon = wrap_pi(self.origin.lon + q.east / ((self.r_n0 + h) * lat.cos()));
        Geodetic { lat, lon, h }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geodesy::ned_from_geodetic;
    use proptest::prelude::*;

    #[test]
    fn eq_14_15_by_hand() {
        // Origin 30.5° N 114.35° E (Wuhan), one arc-second north and east, h = 20 m.
        let o = Geodetic::from_degrees(30.5, 114.35, 0.0);
        let pl = SmallAreaPlane::new(o);
        let arcsec = (1.0f64 / 3600.0).to_radians();
        let p = Geodetic {
            lat: o.lat + arcsec,
            lon: o.lon + arcsec,
            h: 20.0,
        };
        let q = pl.forward(&p);
        let (rm, rn) = radii(o.lat);
        assert!((q.north - (rm + 20.0) * arcsec).abs() < 1e-9);
        assert!((q.east - (rn + 20.0) * p.lat.cos() * arcsec).abs() < 1e-9);
        // ≈ 30.8 m per arc-second north, ≈ 26.7 m east at 30.5° N.
        assert!(
            (q.north - 30.8).abs() < 0.05 && (q.east - 26.7).abs() < 0.05,
            "{q:?}"
        );
        // The origin maps to (0, 0).
        assert_eq!(pl.forward(&o), PlanePoint::default());
    }

    #[test]
    fn close_to_the_exact_local_frame_for_small_areas() {
        // Against the exact NED offset the error stays within the expected
        // curvature term d² tan L / (2R) plus a margin, out to 10 km.
        for &lat0 in &[0.0f64, 30.5, 60.0, -45.0] {
            let o = Geodetic::from_degrees(lat0, 114.35, 30.0);
            let pl = SmallAreaPlane::new(o);
            for &(dn, de) in &[
                (2000.0, 0.0),
                (0.0, 2000.0),
                (1500.0, -1500.0),
                (-10_000.0, 7000.0),
            ] {
                let p = pl.inverse(
                    &PlanePoint {
                        north: dn,
                        east: de,
                    },
                    o.h,
                );
                let d = ned_from_geodetic(&o, &p);
                let dist: f64 = (dn * dn + de * de).sqrt();
                let bound = dist * dist * (1.0 + lat0.to_radians().tan().abs()) / 6.3e6 + 1e-3;
                let err = (d.x - dn).hypot(d.y - de);
                assert!(
                    err < bound,
                    "lat0 {lat0}, ({dn}, {de}): {err} m > {bound} m"
                );
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        #[test]
        fn roundtrip_plane(
            lat0 in -85.0f64..85.0,
            lon0 in -180.0f64..180.0,
            dlat in -0.5f64..0.5,
            dlon in -0.5f64..0.5,
            h in -1000.0f64..10_000.0,
        ) {
            let o = Geodetic::from_degrees(lat0, lon0, 0.0);
            let pl = SmallAreaPlane::new(o);
            let p = Geodetic::from_degrees(lat0 + dlat, lon0 + dlon, h);
            let q = pl.forward(&p);
            let p2 = pl.inverse(&q, h);
            let (rm, rn) = radii(p.lat);
            let err = ((p2.lat - p.lat) * rm).hypot(wrap_pi(p2.lon - p.lon) * rn * p.lat.cos());
            prop_assert!(err < 1e-8, "plane round trip {} m", err);
            prop_assert_eq!(p2.h, h);
            // And plane → geodetic → plane.
            let q2 = pl.forward(&pl.inverse(&PlanePoint { north: q.north + 10.0, east: q.east - 20.0 }, h));
            prop_assert!((q2.north - q.north - 10.0).abs() < 1e-8 && (q2.east - q.east + 20.0).abs() < 1e-8);
        }
    }
}
