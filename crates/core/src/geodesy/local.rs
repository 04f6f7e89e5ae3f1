//! ECEF ↔ local-level frames (NED, ENU) and exact local tangent-plane
//! coordinates (offsets from an origin, through ECEF).
//!
//! Rotations: Groves 2nd ed. §2.4 (`C_e^n`, NED) and its row permutation
//! for ENU. Naming as everywhere in navfuse: `c_xy` maps frame x to frame y,
//! `v_y = c_xy · v_x`.

#[allow(unused_imports)]
use crate::prelude::*;

use super::{ecef_to_geodetic, geodetic_to_ecef, Geodetic};
use crate::{Mat3, Vec3};

/// DCM from ECEF to NED at (lat, lon): `v_n = c_en · v_e` (Groves 2nd ed. §2.4).
///
/// Rows are the north, east and down unit vectors resolved in ECEF.
pub fn c_en(lat: f64, lon: f64) -> Mat3 {
    let (sl, cl) = lat.sin_cos();
    let (so, co) = lon.sin_cos();
    Mat3::new(
        -sl * co,
        -sl * so,
        cl, //
        -so,
        co,
        0.0, //
        -cl * co,
        -cl * so,
        -sl,
    )
}

/// DCM from ECEF to ENU at (lat, lon): `v_enu = c_e_enu · v_e`.
///
/// Rows are the east, north and up unit vectors resolved in ECEF. Used only
/// where a paper works in ENU (seed 003); everything else is NED.
pub fn c_e_enu(lat: f64, lon: f64) -> Mat3 {
    let (sl, cl) = lat.sin_cos();
    let (so, co) = lon.sin_cos();
    Mat3::new(
        -so,
        co,
        0.0, //
        -sl * co,
        -sl * so,
        cl, //
        cl * co,
        cl * so,
        sl,
    )
}

/// NED offset [m] of the ECEF point `r_e` from `origin` (exact).
pub fn ned_from_ecef(origin: &Geodetic, r_e: &Vec3) -> Vec3 {
    c_en(origin.lat, origin.lon) * (r_e - geodetic_to_ecef(origin))
}

/// ECEF point [m] at NED offset `d_n` from `origin` (exact).
pub fn ecef_from_ned(origin: &Geodetic, d_n: &Vec3) -> Vec3 {
    geodetic_to_ecef(origin) + c_en(origin.lat, origin.lon).transpose() * d_n
}

/// ENU offset [m] of the ECEF point `r_e` from `origin` (exact).
pub fn enu_from_ecef(origin: &Geodetic, r_e: &Vec3) -> Vec3 {
    c_e_enu(origin.lat, origin.lon) * (r_e - geodetic_to_ecef(origin))
}

/// ECEF point [m] at ENU offset `d_enu` from `origin` (exact).
pub fn ecef_from_enu(origin: &Geodetic, d_enu: &Vec3) -> Vec3 {
    geodetic_to_ecef(origin) + c_e_enu(origin.lat, origin.lon).transpose() * d_enu
}

/// NED offset [m] of `p` from the origin `origin` (exact, through ECEF).
pub fn ned_from_geodetic(origin: &Geodetic, p: &Geodetic) -> Vec3 {
    ned_from_ecef(origin, &geodetic_to_ecef(p))
}

/// Geodetic position at NED offset `d_n` [m] from `origin` (exact, through ECEF).
pub fn geodetic_from_ned(origin: &Geodetic, d_n: &Vec3) -> Geodetic {
    ecef_to_geodetic(&ecef_from_ned(origin, d_n))
}

/// ENU offset [m] of `p` from `origin` (exact, through ECEF).
pub fn enu_from_geodetic(origin: &Geodetic, p: &Geodetic) -> Vec3 {
    enu_from_ecef(origin, &geodetic_to_ecef(p))
}

/// Geodetic position at ENU offset `d_enu` [m] from `origin` (exact, through ECEF).
pub fn geodetic_from_enu(origin: &Geodetic, d_enu: &Vec3) -> Geodetic {
    ecef_to_geodetic(&ecef_from_enu(origin, d_enu))
}

/// A local tangent plane at a fixed origin, with the origin's ECEF position
/// and `c_en` cached, for converting many points (allocation-free, no trig per
/// point in the forward direction). Exact: the same results as
/// [`ned_from_geodetic`] / [`geodetic_from_ned`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalFrame {
    /// Origin of the frame.
    pub origin: Geodetic,
    /// Origin in ECEF [m].
    pub r0_e: Vec3,
    /// ECEF → NED at the origin.
    pub c_en: Mat3,
}

impl LocalFrame {
    /// Frame at `origin`.
    pub fn new(origin: Geodetic) -> Self {
        LocalFrame {
            origin,
            r0_e: geodetic_to_ecef(&origin),
            c_en: c_en(origin.lat, origin.lon),
        }
    }

    /// NED offset [m] of an ECEF point.
    pub fn ned_from_ecef(&self, r_e: &Vec3) -> Vec3 {
        self.c_en * (r_e - self.r0_e)
    }

    /// ECEF point at NED offset `d_n` [m].
    pub fn ecef_from_ned(&self, d_n: &Vec3) -> Vec3 {
        self.r0_e + self.c_en.transpose() * d_n
    }

    /// NED offset [m] of a geodetic point.
    pub fn ned(&self, p: &Geodetic) -> Vec3 {
        self.ned_from_ecef(&geodetic_to_ecef(p))
    }

    /// Geodetic point at NED offset `d_n` [m].
    pub fn geodetic_from_ned(&self, d_n: &Vec3) -> Geodetic {
        ecef_to_geodetic(&self.ecef_from_ned(d_n))
    }

    /// ENU offset [m] of a geodetic point (NED with north/east swapped, up = −down).
    pub fn enu(&self, p: &Geodetic) -> Vec3 {
        let d = self.ned(p);
        Vec3::new(d.y, d.x, -d.z)
    }

    /// Geodetic point at ENU offset `d_enu` [m].
    pub fn geodetic_from_enu(&self, d_enu: &Vec3) -> Geodetic {
        self.geodetic_from_ned(&Vec3::new(d_enu.y, d_enu.x, -d_enu.z))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::FRAC_PI_2;
    use proptest::prelude::*;

    fn mat_close(a: &Mat3, b: &Mat3, tol: f64) -> bool {
        (a - b).abs().max() < tol
    }

    #[test]
    fn rotations_are_orthonormal_and_right_handed() {
        for &(lat, lon) in &[(0.0, 0.0), (0.7, -2.0), (FRAC_PI_2, 1.0), (-1.2, 3.0)] {
            let c = c_en(lat, lon);
            assert!(mat_close(&(c * c.transpose()), &Mat3::identity(), 1e-15));
            assert!((c.determinant() - 1.0).abs() < 1e-15);
            let u = c_e_enu(lat, lon);
            assert!(mat_close(&(u * u.transpose()), &Mat3::identity(), 1e-15));
            assert!((u.determinant() - 1.0).abs() < 1e-15);
            // ENU rows = (E, N, −D) rows of NED.
            assert_eq!(u.row(0), c.row(1));
            assert_eq!(u.row(1), c.row(0));
            assert_eq!(u.row(2), -c.row(2));
        }
        // At (0, 0): north = +z_e, east = +y_e, down = −x_e.
        let c = c_en(0.0, 0.0);
        let want = Mat3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0);
        assert!(mat_close(&c, &want, 1e-16));
    }

    #[test]
    fn down_is_the_ellipsoid_normal() {
        // Moving up along the normal changes only the down component.
        let o = Geodetic::from_degrees(48.1, 11.6, 500.0);
        let up = Geodetic { h: 1500.0, ..o };
        let d = ned_from_geodetic(&o, &up);
        assert!(d.x.abs() < 1e-8 && d.y.abs() < 1e-8, "{d:?}");
        assert!((d.z + 1000.0).abs() < 1e-8);
    }

    #[test]
    fn small_offsets_match_the_radii() {
        // 1e-6 rad north ≈ (R_M + h)·1e-6 m north; 1e-6 rad east ≈ (R_N + h) cos φ·1e-6 m.
        let o = Geodetic::from_degrees(30.5, 114.35, 25.0);
        let (rm, rn) = crate::earth::radii(o.lat);
        let dn = ned_from_geodetic(
            &o,
            &Geodetic {
                lat: o.lat + 1e-6,
                ..o
            },
        );
        assert!((dn.x - (rm + o.h) * 1e-6).abs() < 1e-5, "{dn:?}");
        let de = ned_from_geodetic(
            &o,
            &Geodetic {
                lon: o.lon + 1e-6,
                ..o
            },
        );
        assert!(
            (de.y - (rn + o.h) * o.lat.cos() * 1e-6).abs() < 1e-5,
            "{de:?}"
        );
        // Earth curvature: 10 km east drops ≈ d²/(2R) below the tangent plane.
        let p = geodetic_from_ned(&o, &Vec3::new(0.0, 10_000.0, 0.0));
        assert!(
            (p.h - o.h - 10_000f64.powi(2) / (2.0 * rn)).abs() < 0.1,
            "{p:?}"
        );
    }

    #[test]
    fn local_frame_matches_free_functions() {
        let o = Geodetic::from_degrees(-33.9, 151.2, 40.0);
        let f = LocalFrame::new(o);
        let p = Geodetic::from_degrees(-33.95, 151.3, 120.0);
        let d = ned_from_geodetic(&o, &p);
        assert!((f.ned(&p) - d).norm() < 1e-9);
        let e = enu_from_geodetic(&o, &p);
        assert!((f.enu(&p) - e).norm() < 1e-9);
        assert!((e - Vec3::new(d.y, d.x, -d.z)).norm() < 1e-9);
        let back = f.geodetic_from_enu(&e);
        assert!((geodetic_to_ecef(&back) - geodetic_to_ecef(&p)).norm() < 1e-8);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        #[test]
        fn roundtrip_ned_enu_offsets(
            lat0 in -90.0f64..=90.0,
            lon0 in -180.0f64..180.0,
            h0 in -1000.0f64..=10_000.0,
            dn in -50_000.0f64..50_000.0,
            de in -50_000.0f64..50_000.0,
            dd in -20_000.0f64..1000.0,
        ) {
            let o = Geodetic::from_degrees(lat0, lon0, h0);
            let d_n = Vec3::new(dn, de, dd);
            // offset → geodetic → offset
            let p = geodetic_from_ned(&o, &d_n);
            let d2 = ned_from_geodetic(&o, &p);
            prop_assert!((d2 - d_n).norm() < 1e-6, "NED |Δ| = {}", (d2 - d_n).norm());
            let d_enu = Vec3::new(de, dn, -dd);
            let p2 = geodetic_from_enu(&o, &d_enu);
            let e2 = enu_from_geodetic(&o, &p2);
            prop_assert!((e2 - d_enu).norm() < 1e-6, "ENU |Δ| = {}", (e2 - d_enu).norm());
            // Same point either way.
            prop_assert!((geodetic_to_ecef(&p) - geodetic_to_ecef(&p2)).norm() < 1e-6);
            // geodetic → offset → geodetic
            let q = Geodetic { lat: (o.lat + dn * 1e-7).clamp(-FRAC_PI_2, FRAC_PI_2), lon: o.lon + de * 1e-7, h: h0 + dd.abs() };
            let q2 = geodetic_from_ned(&o, &ned_from_geodetic(&o, &q));
            prop_assert!((geodetic_to_ecef(&q2) - geodetic_to_ecef(&q)).norm() < 1e-6);
            prop_assert!((q2.h - q.h).abs() < 1e-6);
        }
    }
}
