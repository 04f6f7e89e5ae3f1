//! Universal Transverse Mercator on WGS84, built on [`TransverseMercator`].
//!
//! Zones of 6° numbered 1..=60 eastwards from 180° W, central meridian
//! (6·zone − 183)°, k0 = 0.9996, false easting 500 km, false northing 0 in the
//! northern and 10 000 km in the southern hemisphere; defined from 80° S to
//! 84° N, with the Norway (32V) and Svalbard (31X–37X) zone exceptions
//! (NGA.SIG.0012_2.0.0_UTMUPS; DMA TM 8358.2).

#[allow(unused_imports)]
use crate::prelude::*;

use super::{wrap_pi, GeodesyError, TransverseMercator};

/// UTM central scale factor.
pub const UTM_K0: f64 = 0.9996;
/// UTM false easting [m].
pub const UTM_FALSE_EASTING: f64 = 500_000.0;
/// UTM false northing in the southern hemisphere [m].
pub const UTM_FALSE_NORTHING_SOUTH: f64 = 10_000_000.0;

/// A UTM coordinate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Utm {
    /// Zone 1..=60.
    pub zone: u8,
    /// `true` for the northern hemisphere (false northing 0), `false` for the
    /// southern (false northing 10 000 km).
    pub north: bool,
    /// Easting [m].
    pub easting: f64,
    /// Northing [m].
    pub northing: f64,
}

/// Standard zone number 1..=60 from the longitude [rad], without exceptions.
/// 180° E belongs to zone 1 (the same meridian as 180° W); a zone boundary
/// belongs to the zone to its east.
pub fn utm_zone_from_lon(lon: f64) -> u8 {
    let deg = wrap_pi(lon).to_degrees(); // (−180, 180]
    let z = ((deg + 180.0) / 6.0).floor() as i64; // 0..=60
    (z.rem_euclid(60) + 1) as u8
}

/// Zone number at (lat, lon) [rad], with the Norway (32V: 56°–64° N,
/// 3°–12° E) and Svalbard (72°–84° N: 31X 0°–9°, 33X 9°–21°, 35X 21°–33°,
/// 37X 33°–42° E) exceptions.
pub fn utm_zone(lat: f64, lon: f64) -> u8 {
    let zone = utm_zone_from_lon(lon);
    let lat_d = lat.to_degrees();
    let lon_d = wrap_pi(lon).to_degrees();
    if (56.0..64.0).contains(&lat_d) && (3.0..12.0).contains(&lon_d) {
        return 32;
    }
    if (72.0..=84.0).contains(&lat_d) && (0.0..42.0).contains(&lon_d) {
        return if lon_d < 9.0 {
            31
        } else if lon_d < 21.0 {
            33
        } else if lon_d < 33.0 {
            35
        } else {
            37
        };
    }
    zone
}

/// Central meridian of a zone [rad]: (6·zone − 183)°.
pub fn utm_central_meridian(zone: u8) -> f64 {
    (6.0 * f64::from(zone) - 183.0).to_radians()
}

/// The Transverse Mercator projection of a UTM zone.
pub fn utm_projection(zone: u8, north: bool) -> Result<TransverseMercator, GeodesyError> {
    if !(1..=60).contains(&zone) {
        return Err(GeodesyError::InvalidZone(zone));
    }
    let fnorth = if north { 0.0 } else { UTM_FALSE_NORTHING_SOUTH };
    Ok(TransverseMercator::new(
        utm_central_meridian(zone),
        UTM_K0,
        UTM_FALSE_EASTING,
        fnorth,
    ))
}

impl Utm {
    /// UTM coordinate of (lat, lon) [rad] in its own zone ([`utm_zone`],
    /// with exceptions) and hemisphere (lat ≥ 0 is north).
    pub fn from_geodetic(lat: f64, lon: f64) -> Result<Utm, GeodesyError> {
        Self::check_lat(lat, lon)?;
        Self::from_geodetic_in_zone(lat, lon, utm_zone(lat, lon), lat >= 0.0)
    }

    /// UTM coordinate of (lat, lon) [rad] forced into `zone` and hemisphere
    /// (e.g. to keep a whole track in one zone). Any longitude is accepted;
    /// accuracy degrades far (≳ 30°) from the zone's central meridian.
    pub fn from_geodetic_in_zone(
        lat: f64,
        lon: f64,
        zone: u8,
        north: bool,
    ) -> Result<Utm, GeodesyError> {
        Self::check_lat(lat, lon)?;
        let p = utm_projection(zone, north)?.forward(lat, lon);
        Ok(Utm {
            zone,
            north,
            easting: p.easting,
            northing: p.northing,
        })
    }

    /// Back to (lat, lon) [rad].
    pub fn to_geodetic(&self) -> Result<(f64, f64), GeodesyError> {
        if !self.easting.is_finite() || !self.northing.is_finite() {
            return Err(GeodesyError::NonFinite);
        }
        let (lat, lon, _, _) =
            utm_projection(self.zone, self.north)?.inverse(self.easting, self.northing);
        Ok((lat, lon))
    }

    fn check_lat(lat: f64, lon: f64) -> Result<(), GeodesyError> {
        if !lat.is_finite() || !lon.is_finite() {
            return Err(GeodesyError::NonFinite);
        }
        if !(-80f64.to_radians()..=84f64.to_radians()).contains(&lat) {
            return Err(GeodesyError::LatitudeOutOfRange(lat));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d(x: f64) -> f64 {
        x.to_radians()
    }

    #[test]
    fn zone_numbers() {
        assert_eq!(utm_zone_from_lon(d(-180.0)), 1);
        assert_eq!(utm_zone_from_lon(d(180.0)), 1);
        assert_eq!(utm_zone_from_lon(d(-174.0)), 2);
        assert_eq!(utm_zone_from_lon(d(-174.000_001)), 1);
        assert_eq!(utm_zone_from_lon(d(0.0)), 31);
        assert_eq!(utm_zone_from_lon(d(-0.1)), 30);
        assert_eq!(utm_zone_from_lon(d(114.35)), 50);
        assert_eq!(utm_zone_from_lon(d(179.9)), 60);
        assert_eq!(utm_zone_from_lon(d(-75.0)), 18);
        assert_eq!(utm_zone_from_lon(d(360.0 + 3.0)), 31);
        for z in 1..=60u8 {
            // The central meridian lies in its own zone.
            assert_eq!(utm_zone_from_lon(utm_central_meridian(z)), z);
        }
    }

    #[test]
    fn norway_and_svalbard() {
        assert_eq!(utm_zone(d(60.0), d(5.0)), 32); // Bergen, 31V → 32V
        assert_eq!(utm_zone(d(60.0), d(2.9)), 31);
        assert_eq!(utm_zone(d(64.0), d(5.0)), 31); // north of 64° N: standard
        assert_eq!(utm_zone(d(55.9), d(5.0)), 31);
        assert_eq!(utm_zone(d(78.0), d(15.6)), 33); // Longyearbyen
        assert_eq!(utm_zone(d(78.0), d(8.9)), 31);
        assert_eq!(utm_zone(d(78.0), d(9.0)), 33);
        assert_eq!(utm_zone(d(80.0), d(25.0)), 35);
        assert_eq!(utm_zone(d(80.0), d(40.0)), 37);
        assert_eq!(utm_zone(d(80.0), d(42.0)), 38);
        assert_eq!(utm_zone(d(71.9), d(25.0)), 35); // standard 35W
        assert_eq!(utm_zone(d(71.9), d(20.0)), 34);
    }

    #[test]
    fn hemispheres_and_round_trip() {
        // Equator on the CM of zone 31: (500 000, 0) north, (500 000, 10 000 000) south.
        let n = Utm::from_geodetic(0.0, d(3.0)).unwrap();
        assert_eq!((n.zone, n.north), (31, true));
        assert!((n.easting - 500_000.0).abs() < 1e-9 && n.northing.abs() < 1e-9);
        let s = Utm::from_geodetic_in_zone(0.0, d(3.0), 31, false).unwrap();
        assert!((s.northing - 10_000_000.0).abs() < 1e-9);
        let s = Utm::from_geodetic(d(-33.9), d(151.2)).unwrap();
        assert_eq!((s.zone, s.north), (56, false));
        assert!(s.northing > 6.0e6 && s.northing < 10.0e6);
        let (lat, lon) = s.to_geodetic().unwrap();
        assert!((lat - d(-33.9)).abs() < 1e-14 && (lon - d(151.2)).abs() < 1e-14);
        // Zone 60 / zone 1 across the antimeridian.
        let u = Utm::from_geodetic(d(-40.0), d(-179.5)).unwrap();
        assert_eq!(u.zone, 1);
        let (_, lon) = u.to_geodetic().unwrap();
        assert!((lon - d(-179.5)).abs() < 1e-14);
        let u = Utm::from_geodetic_in_zone(d(-40.0), d(-179.5), 60, false).unwrap();
        assert!(u.easting > 500_000.0);
        let (_, lon) = u.to_geodetic().unwrap();
        assert!((lon - d(-179.5)).abs() < 1e-14);
    }

    #[test]
    fn errors() {
        assert_eq!(
            Utm::from_geodetic(d(85.0), 0.0),
            Err(GeodesyError::LatitudeOutOfRange(d(85.0)))
        );
        assert!(matches!(
            Utm::from_geodetic(d(-80.1), 0.0),
            Err(GeodesyError::LatitudeOutOfRange(_))
        ));
        assert_eq!(
            Utm::from_geodetic(f64::NAN, 0.0),
            Err(GeodesyError::NonFinite)
        );
        assert_eq!(
            Utm::from_geodetic_in_zone(0.0, 0.0, 0, true),
            Err(GeodesyError::InvalidZone(0))
        );
        let bad = Utm {
            zone: 61,
            north: true,
            easting: 500_000.0,
            northing: 0.0,
        };
        assert_eq!(bad.to_geodetic(), Err(GeodesyError::InvalidZone(61)));
        let nan = Utm {
            easting: f64::INFINITY,
            ..bad
        };
        assert_eq!(nan.to_geodetic(), Err(GeodesyError::NonFinite));
    }
}
