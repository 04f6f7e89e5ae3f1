//! Roll and pitch when the run starts in motion (no static window): the
//! specific force the IMU measured over a window of GNSS epochs, rotated by
//! the gyro into the body frame at the window's end, against the same force
//! in NED from the GNSS velocity change, `f_n = Δv_n/Δt − g_n + (2ω_ie +
//! ω_en) × v_n` (Groves eq. 5.54). Given the yaw, the pair fixes roll and
//! pitch ([`navfuse_core::ins::align::tilt_given_yaw`]).
//!
//! Levelling an accelerating or turning vehicle from the accelerometer alone
//! tilts the solution by atan(a/g): 10–20° in a highway curve. The GNSS
//! velocity removes the motion term instead of assuming it away.
//!
//! **Window length** — two errors pull in opposite directions: the GNSS
//! velocity noise enters the acceleration as √2·σ_v/W, i.e. a tilt of
//! √2·σ_v/(W g), while an unknown gyro bias σ_bg rotates the averaged force
//! by σ_bg·W/2 on average. Their sum of squares is smallest at
//! W* = √(2√2·σ_v / (g·σ_bg)); the window is the GNSS epoch nearest W* back,
//! at least one epoch interval and not before the first IMU sample.
//!
//! **σ** of roll and pitch: the two terms above at the chosen W and the
//! accelerometer bias σ_ba/g (a bias shifts the force direction by that
//! much), summed in quadrature.

use navfuse_core::earth;
use navfuse_core::ins::align::tilt_given_yaw;
use navfuse_core::ins::mech::quat_from_rotvec;
use navfuse_core::types::{GnssFix, ImuSample};
use navfuse_core::{Mat3, Vec3};

/// Specific-force pair over a window ending at a GNSS epoch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForcePair {
    /// Mean specific force in the body frame at the window's end [m/s²].
    pub f_b: Vec3,
    /// The same in NED [m/s²].
    pub f_n: Vec3,
    /// 1-σ of the roll/pitch it gives [rad] (module documentation).
    pub tilt_std: f64,
    /// Window length [s].
    pub window_s: f64,
}

impl ForcePair {
    /// Roll and pitch [rad] for yaw `yaw` [rad].
    pub fn tilt(&self, yaw: f64) -> Option<(f64, f64)> {
        tilt_given_yaw(&self.f_b, &self.f_n, yaw)
    }
}

/// The pair ending at fix `j`. `vel(i)` gives the GNSS velocity (NED) and
/// its per-axis σ at fix `i`; `bg_b` is the gyro bias prior [rad/s] with
/// σ `bg_std` [rad/s] (largest axis), `ba_std` the accelerometer bias σ
/// [m/s²]. `None` without two GNSS velocities over IMU data.
pub fn force_pair(
    imu: &[ImuSample],
    gnss: &[GnssFix],
    j: usize,
    vel: &dyn Fn(usize) -> Option<(Vec3, Vec3)>,
    bg_b: &Vec3,
    bg_std: f64,
    ba_std: f64,
) -> Option<ForcePair> {
    let gj = gnss.get(j)?;
    let (vj, sj) = vel(j)?;
    let t_imu0 = imu.first().map(|s| s.t - s.dt)?;
    let g0 = earth::gravity(gj.lat, gj.h);
    let sv = sj.x.max(sj.y);
    // W* of the module documentation (σ_bg floored at the earth rate: the
    // part of a rate no alignment in motion separates from the bias).
    let w_opt = (2.0 * 2f64.sqrt() * sv / (g0 * bg_std.max(7.3e-5))).sqrt();
    let (i, (vi, si)) = (0..j)
        .rev()
        .take_while(|&i| gnss[i].t >= t_imu0)
        .filter(|&i| gj.t - gnss[i].t > 1e-3)
        .filter_map(|i| vel(i).map(|v| (i, v)))
        .min_by(|a, b| {
            let da = (gj.t - gnss[a.0].t - w_opt).abs();
            let db = (gj.t - gnss[b.0].t - w_opt).abs();
            da.total_cmp(&db)
        })?;
    let gi = &gnss[i];
    // Body side: Σ C_{b_i b_k} Δv_k, then into the frame at t_j.
    let (mut c, mut acc, mut span) = (Mat3::identity(), Vec3::zeros(), 0.0);
    let k0 = imu.partition_point(|s| s.t <= gi.t);
    for s in imu[k0..].iter().take_while(|s| s.t <= gj.t) {
        acc += c * s.dvel_b;
        c *= quat_from_rotvec(&(s.dtheta_b - bg_b * s.dt))
            .to_rotation_matrix()
            .into_inner();
        span += s.dt;
    }
    if span < 0.5 * (gj.t - gi.t) {
        return None;
    }
    let f_b = c.transpose() * acc / span;
    // Nav side (Groves eq. 5.54), at the window's middle.
    let dt = gj.t - gi.t;
    let v_mid = 0.5 * (vi + vj);
    let w = 2.0 * earth::omega_ie_n(gj.lat) + earth::omega_en_n(gj.lat, gj.h, &v_mid);
    let f_n = (vj - vi) / dt - earth::gravity_n(gj.lat, gj.h) + w.cross(&v_mid);
    let sv_pair = (sv * sv + si.x.max(si.y).powi(2)).sqrt();
    let tilt_std =
        ((sv_pair / (dt * g0)).powi(2) + (bg_std * dt / 2.0).powi(2) + (ba_std / g0).powi(2))
            .sqrt();
    (f_b.iter().chain(f_n.iter()).all(|x| x.is_finite())).then_some(ForcePair {
        f_b,
        f_n,
        tilt_std,
        window_s: dt,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use navfuse_core::ins::mech::q_bn_from_rpy;

    /// A vehicle in a steady 0.3 g turn at 25 m/s, rolled 2° and pitched −1°
    /// (a sensor mounted off level): levelling from the accelerometer is
    /// 17° off in roll; the pair gives roll and pitch to 0.05°.
    #[test]
    fn turning_vehicle_tilt_from_the_pair() {
        let (lat, h) = (0.5, 100.0);
        let (speed, a_c) = (25.0, 0.3 * 9.8);
        let rate = a_c / speed; // yaw rate [rad/s]
        let (roll, pitch) = (2f64.to_radians(), -1f64.to_radians());
        let dt = 0.01;
        let g_n = earth::gravity_n(lat, h);
        let mut imu = Vec::new();
        let yaw_at = |t: f64| 0.4 + rate * t;
        let v_at = |t: f64| Vec3::new(yaw_at(t).cos(), yaw_at(t).sin(), 0.0) * speed;
        for k in 1..=400 {
            let t = k as f64 * dt;
            let tm = t - dt / 2.0;
            let c_bn = q_bn_from_rpy(&Vec3::new(roll, pitch, yaw_at(tm)))
                .to_rotation_matrix()
                .into_inner();
            // a_n = centripetal; earth-rate terms neglected on both sides.
            let a_n = Vec3::new(-yaw_at(tm).sin(), yaw_at(tm).cos(), 0.0) * a_c;
            let f_b = c_bn.transpose() * (a_n - g_n);
            // Body rate of a pure yaw rotation of the tilted body.
            let w_b = c_bn.transpose() * Vec3::new(0.0, 0.0, rate);
            imu.push(ImuSample {
                t,
                dt,
                dtheta_b: w_b * dt,
                dvel_b: f_b * dt,
            });
        }
        let gnss: Vec<GnssFix> = (1..=4)
            .map(|s| GnssFix {
                t: s as f64,
                lat,
                h,
                std_ned: Vec3::repeat(0.02),
                v_n: Some(v_at(s as f64)),
                std_v_n: Some(Vec3::repeat(0.05)),
                ..Default::default()
            })
            .collect();
        let vel = |i: usize| Some((gnss[i].v_n.unwrap(), gnss[i].std_v_n.unwrap()));
        let pair = force_pair(&imu, &gnss, 3, &vel, &Vec3::zeros(), 1e-3, 0.01).unwrap();
        let (r, p) = pair.tilt(yaw_at(4.0)).unwrap();
        assert!(
            (r - roll).abs().to_degrees() < 0.05,
            "roll {}",
            r.to_degrees()
        );
        assert!(
            (p - pitch).abs().to_degrees() < 0.05,
            "pitch {}",
            p.to_degrees()
        );
        let lev = navfuse_core::ins::align::level(&(imu[399].dvel_b / dt));
        assert!(
            (lev.0 - roll).abs().to_degrees() > 10.0,
            "levelling {}",
            lev.0
        );
        assert!(pair.tilt_std.to_degrees() < 0.2 && pair.tilt_std > 0.0);
    }
}
