//! Strapdown mechanization in NED on WGS84 from IMU increments
//! (`SEEDS.md §1` eq. 5–6; Groves 2nd ed. §5.4–5.5; Savage, *Strapdown
//! Analytics* ch. 7 for the two-sample coning/sculling corrections).
//!
//! One step integrates velocity, then position, then attitude over one IMU
//! interval `(t − dt, t]`, using the previous interval's increments for the
//! second-order coning (attitude) and sculling (velocity) corrections. The
//! earth and transport rates and gravity are evaluated at the extrapolated
//! mid-interval position (the velocity update) or the mid-interval position
//! (position and attitude updates), which makes the step second-order accurate.
//!
//! Frames and signs: body FRD; `q_bn` rotates body → NED (`v_n = C_bn v_b`);
//! the specific force of a level IMU at rest is (0, 0, −g).

use crate::earth;
#[allow(unused_imports)]
use crate::prelude::*;
use crate::{Mat3, Vec3};
use nalgebra::{Quaternion, UnitQuaternion};

/// Position, velocity and attitude of the IMU (the "nominal" state of the ESKF).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavState {
    /// Latitude [rad].
    pub lat: f64,
    /// Longitude [rad].
    pub lon: f64,
    /// Ellipsoidal height [m].
    pub h: f64,
    /// Velocity of the IMU w.r.t. the earth, NED [m/s].
    pub v_n: Vec3,
    /// Attitude body FRD → NED.
    pub q_bn: UnitQuaternion<f64>,
}

impl Default for NavState {
    fn default() -> Self {
        NavState {
            lat: 0.0,
            lon: 0.0,
            h: 0.0,
            v_n: Vec3::zeros(),
            q_bn: UnitQuaternion::identity(),
        }
    }
}

impl NavState {
    /// Body → NED direction cosine matrix `C_bn`.
    #[inline]
    pub fn c_bn(&self) -> Mat3 {
        self.q_bn.to_rotation_matrix().into_inner()
    }

    /// Roll, pitch, yaw (ZYX) [rad], yaw in (−π, π].
    #[inline]
    pub fn rpy(&self) -> Vec3 {
        let (r, p, y) = self.q_bn.euler_angles();
        Vec3::new(r, p, y)
    }
}

/// Attitude `q_bn` from roll, pitch, yaw (ZYX) [rad] (`SEEDS.md §1` eq. 3).
#[inline]
pub fn q_bn_from_rpy(rpy: &Vec3) -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(rpy.x, rpy.y, rpy.z)
}

/// Unit quaternion of a rotation vector [rad] (exponential map), with a
/// series form for small angles so it is exact to rounding near zero.
#[inline]
pub fn quat_from_rotvec(phi: &Vec3) -> UnitQuaternion<f64> {
    let a2 = phi.norm_squared();
    let (w, s) = if a2 < 1e-4 {
        // cos(a/2) and sin(a/2)/a to O(a⁶); the next terms are below 2e-17.
        (
            1.0 - a2 / 8.0 + a2 * a2 / 384.0,
            0.5 - a2 / 48.0 + a2 * a2 / 3840.0,
        )
    } else {
        let a = a2.sqrt();
        ((0.5 * a).cos(), (0.5 * a).sin() / a)
    };
    UnitQuaternion::new_unchecked(Quaternion::new(w, s * phi.x, s * phi.y, s * phi.z))
}

/// The earth model at one point with a single `sin_cos` (the same formulas
/// as [`earth::radii`], [`earth::gravity`], [`earth::omega_ie_n`],
/// [`earth::omega_en_n`], evaluated once per point for speed).
#[derive(Clone, Copy, Debug)]
pub struct EarthAt {
    pub sin_lat: f64,
    pub cos_lat: f64,
    /// R_M + h, R_N + h [m].
    pub rmh: f64,
    pub rnh: f64,
    /// R_M, R_N [m].
    pub rm: f64,
    pub rn: f64,
    /// Normal gravity [m/s²] (down).
    pub g: f64,
}

impl EarthAt {
    #[inline]
    pub fn new(lat: f64, h: f64) -> Self {
        let (sl, cl) = lat.sin_cos();
        let s2 = sl * sl;
        let w2 = 1.0 - earth::WGS84_E2 * s2;
        let w = w2.sqrt();
        let rm = earth::WGS84_A * (1.0 - earth::WGS84_E2) / (w2 * w);
        let rn = earth::WGS84_A / w;
        let g0 = earth::GAMMA_EQUATOR * (1.0 + earth::SOMIGLIANA_K * s2) / w;
        let a = earth::WGS84_A;
        let m = earth::OMEGA_IE * earth::OMEGA_IE * a * a * earth::WGS84_B / earth::WGS84_GM;
        let g = g0
            * (1.0 - 2.0 / a * (1.0 + earth::WGS84_F + m - 2.0 * earth::WGS84_F * s2) * h
                + 3.0 / (a * a) * h * h);
        EarthAt {
            sin_lat: sl,
            cos_lat: cl,
            rmh: rm + h,
            rnh: rn + h,
            rm,
            rn,
            g,
        }
    }
    /// ω_ie^n [rad/s].
    #[inline]
    pub fn w_ie(&self) -> Vec3 {
        Vec3::new(
            earth::OMEGA_IE * self.cos_lat,
            0.0,
            -earth::OMEGA_IE * self.sin_lat,
        )
    }
    /// ω_en^n for `v_n` [rad/s].
    #[inline]
    pub fn w_en(&self, v_n: &Vec3) -> Vec3 {
        Vec3::new(
            v_n.y / self.rnh,
            -v_n.x / self.rmh,
            -v_n.y * self.sin_lat / (self.cos_lat * self.rnh),
        )
    }
    /// (ΔL, Δl, Δh) for `v_n` held over `dt`.
    #[inline]
    pub fn step(&self, v_n: &Vec3, dt: f64) -> Vec3 {
        Vec3::new(
            v_n.x / self.rmh * dt,
            v_n.y / (self.rnh * self.cos_lat) * dt,
            -v_n.z * dt,
        )
    }
}

/// Geodetic position increment (ΔL, Δl, Δh) for velocity `v_n` held over `dt`
/// at (`lat`, `h`) (`SEEDS.md §1` eq. 5).
#[inline]
fn geodetic_step(e: &EarthAt, v_n: &Vec3, dt: f64) -> Vec3 {
    e.step(v_n, dt)
}

/// Velocity increment from the specific-force and gravity/Coriolis terms over
/// one interval, with all rates evaluated at `e` and velocity `v_mid`.
#[inline]
fn velocity_increment(c_bn: &Mat3, dv_fb: &Vec3, e: &EarthAt, v_mid: &Vec3, dt: f64) -> Vec3 {
    let w_ie = e.w_ie();
    let w_en = e.w_en(v_mid);
    let zeta = (w_ie + w_en) * dt;
    // Rotation of the navigation frame over the interval, to first order,
    // applied at mid-interval: (I − ½[ζ×]) C_bn Δv_f^b (Savage eq. 7.2.2.2).
    let dv_f = c_bn * dv_fb;
    let dv_fn = dv_f - 0.5 * zeta.cross(&dv_f);
    let g_n = Vec3::new(0.0, 0.0, e.g);
    let dv_gn = (g_n - (2.0 * w_ie + w_en).cross(v_mid)) * dt;
    dv_fn + dv_gn
}

/// One mechanization step: `pre` at the start of the interval → state at its end.
///
/// `dtheta_pre`, `dvel_pre` are the previous interval's (already compensated)
/// increments, `dtheta`, `dvel` this interval's, `dt` its length [s].
/// Velocity (`SEEDS.md §1` eq. 5): Δv^b with the sculling term
/// ½Δθ×Δv + (Δθ₋₁×Δv + Δv₋₁×Δθ)/12; position with the mid-interval
/// velocity; attitude `q_bn ← q_nn(−(ω_ie+ω_en)dt) ⊗ q_bn ⊗ q(Δθ + Δθ₋₁×Δθ/12)`
/// (two-sample coning).
pub fn mechanize(
    pre: &NavState,
    dtheta_pre: &Vec3,
    dvel_pre: &Vec3,
    dtheta: &Vec3,
    dvel: &Vec3,
    dt: f64,
) -> NavState {
    let c_bn = pre.c_bn();
    let e0 = EarthAt::new(pre.lat, pre.h);
    mechanize_with(pre, &c_bn, &e0, dtheta_pre, dvel_pre, dtheta, dvel, dt)
}

/// [`mechanize`] with `C_bn` and the earth model at `pre` already evaluated.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn mechanize_with(
    pre: &NavState,
    c_bn: &Mat3,
    e0: &EarthAt,
    dtheta_pre: &Vec3,
    dvel_pre: &Vec3,
    dtheta: &Vec3,
    dvel: &Vec3,
    dt: f64,
) -> NavState {
    // --- velocity -------------------------------------------------------
    let dv_fb =
        dvel + 0.5 * dtheta.cross(dvel) + (dtheta_pre.cross(dvel) + dvel_pre.cross(dtheta)) / 12.0;
    // First pass with the rates at the start, to extrapolate the mid-interval
    // velocity and position; second pass with the rates there.
    let dv0 = velocity_increment(c_bn, &dv_fb, e0, &pre.v_n, dt);
    let v_mid = pre.v_n + 0.5 * dv0;
    let d_mid = geodetic_step(e0, &v_mid, 0.5 * dt);
    let e_mid = EarthAt::new(pre.lat + d_mid.x, pre.h + d_mid.z);
    let dv = velocity_increment(c_bn, &dv_fb, &e_mid, &v_mid, dt);
    let v_cur = pre.v_n + dv;

    // --- position -------------------------------------------------------
    let v_mid = 0.5 * (pre.v_n + v_cur);
    let d_half = geodetic_step(e0, &v_mid, 0.5 * dt);
    let e_mid = EarthAt::new(pre.lat + d_half.x, pre.h + d_half.z);
    let d = geodetic_step(&e_mid, &v_mid, dt);

    // --- attitude -------------------------------------------------------
    let w_in = e_mid.w_ie() + e_mid.w_en(&v_mid);
    let q_nn = quat_from_rotvec(&(-w_in * dt));
    let q_bb = quat_from_rotvec(&(dtheta + dtheta_pre.cross(dtheta) / 12.0));
    let mut q_bn = q_nn * pre.q_bn * q_bb;
    q_bn.renormalize_fast();

    NavState {
        lat: pre.lat + d.x,
        lon: pre.lon + d.y,
        h: pre.h + d.z,
        v_n: v_cur,
        q_bn,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Increments a perfect IMU at rest reads, for a level body with yaw `yaw`.
    fn static_increments(lat: f64, h: f64, yaw: f64, dt: f64) -> (Vec3, Vec3) {
        let q = q_bn_from_rpy(&Vec3::new(0.0, 0.0, yaw));
        let c_nb = q.to_rotation_matrix().into_inner().transpose();
        let w_ib_b = c_nb * earth::omega_ie_n(lat);
        // f = a − g, a = 0 in the earth frame except the centripetal part, which
        // normal gravity already contains (it is the gravity *of the rotating earth*).
        let f_b = c_nb * (-earth::gravity_n(lat, h));
        (w_ib_b * dt, f_b * dt)
    }

    #[test]
    fn stationary_stays_put_for_an_hour() {
        let lat = 0.7;
        let h = 1600.0;
        let dt = 0.01;
        let (dth, dv) = static_increments(lat, h, 0.3, dt);
        let mut s = NavState {
            lat,
            lon: -1.8,
            h,
            v_n: Vec3::zeros(),
            q_bn: q_bn_from_rpy(&Vec3::new(0.0, 0.0, 0.3)),
        };
        for _ in 0..360_000 {
            s = mechanize(&s, &dth, &dv, &dth, &dv, dt);
        }
        let (rm, rn) = earth::radii(lat);
        let dn = (s.lat - lat) * rm;
        let de = (s.lon + 1.8) * rn * lat.cos();
        // Only rounding drives the (unstable) vertical channel; stay within mm/cm.
        assert!(dn.abs() < 0.05 && de.abs() < 0.05, "dn {dn} de {de}");
        assert!((s.h - h).abs() < 0.5, "dh {}", s.h - h);
        assert!(s.v_n.norm() < 1e-3, "v {}", s.v_n);
        let rpy = s.rpy();
        assert!(
            (rpy.z - 0.3).abs() < 1e-7 && rpy.x.abs() < 1e-7,
            "rpy {rpy}"
        );
    }

    #[test]
    fn constant_acceleration_north_on_a_non_rotating_frame_is_integrated() {
        // Accelerate north at 1 m/s² for 10 s; compare with ½at² (the earth
        // terms change this by well under a centimetre over 50 m).
        let lat = 0.5;
        let dt = 0.01;
        let g = earth::gravity(lat, 0.0);
        let mut s = NavState {
            lat,
            ..Default::default()
        };
        let c_nb = s.c_bn().transpose();
        let dth = c_nb * earth::omega_ie_n(lat) * dt;
        let dv = Vec3::new(1.0, 0.0, -g) * dt;
        for _ in 0..1000 {
            s = mechanize(&s, &dth, &dv, &dth, &dv, dt);
        }
        let north = (s.lat - lat) * earth::radius_meridian(lat);
        assert!((north - 50.0).abs() < 0.05, "north {north}");
        assert!((s.v_n.x - 10.0).abs() < 1e-3, "vn {}", s.v_n.x);
        assert!(s.v_n.y.abs() < 0.01, "ve {}", s.v_n.y);
    }

    #[test]
    fn coning_is_captured_with_the_two_sample_correction() {
        // Classical coning motion: ω = (−Ωa sin... ) — use the closed form of
        // Savage: a body coning at rate Ω with half-angle a. Compare the
        // two-sample attitude after 1 s against the exact attitude; without
        // the correction the error is a multiple larger.
        let a: f64 = 0.05;
        let big_w = 2.0 * core::f64::consts::PI * 5.0; // 5 Hz coning
        let dt = 0.01;
        // Exact attitude q(t) = q_z(Ωt) ⊗ q_x(a) ⊗ q_z(−Ωt): body rate
        // ω(t) has a constant z component and a rotating xy component.
        let exact = |t: f64| {
            UnitQuaternion::from_euler_angles(0.0, 0.0, big_w * t)
                * UnitQuaternion::from_euler_angles(a, 0.0, 0.0)
                * UnitQuaternion::from_euler_angles(0.0, 0.0, -big_w * t)
        };
        // Increment over (t0, t1] by integrating ω_b numerically (fine steps).
        let rate = |t: f64| {
            let h = 1e-6;
            let dq = exact(t).inverse() * exact(t + h);
            dq.scaled_axis() / h
        };
        let incr = |t0: f64, t1: f64| {
            let n = 200;
            let mut s = Vec3::zeros();
            for i in 0..n {
                let t = t0 + (i as f64 + 0.5) * (t1 - t0) / n as f64;
                s += rate(t) * (t1 - t0) / n as f64;
            }
            s
        };
        let mut q_c = exact(0.0);
        let mut q_n = exact(0.0);
        let mut prev = incr(-dt, 0.0);
        for k in 0..100 {
            let t0 = k as f64 * dt;
            let d = incr(t0, t0 + dt);
            q_c *= quat_from_rotvec(&(d + prev.cross(&d) / 12.0));
            q_n *= quat_from_rotvec(&d);
            prev = d;
        }
        let e_c = (exact(1.0).inverse() * q_c).angle();
        let e_n = (exact(1.0).inverse() * q_n).angle();
        assert!(e_c < 0.2 * e_n, "corrected {e_c} uncorrected {e_n}");
    }

    #[test]
    fn quat_from_rotvec_matches_nalgebra() {
        for v in [
            Vec3::new(0.1, -0.2, 0.3),
            Vec3::new(1e-5, 2e-6, -3e-5),
            Vec3::zeros(),
        ] {
            let a = quat_from_rotvec(&v);
            let b = UnitQuaternion::from_scaled_axis(v);
            assert!(a.angle_to(&b) < 1e-12);
        }
    }
}
