//! Multirotor UAV: velocity planned in NED (`RatesNed` phases), yaw chosen
//! independently of the course (sideways and backwards flight), roll/pitch
//! from a thrust-direction model.
//!
//! Limits (small camera multirotor class, manufacturers' sheets as recalled:
//! DJI Mavic/Phantom top speeds 15–20 m/s, ascent 5–6 m/s, descent 3–4 m/s,
//! yaw up to 100–200°/s): horizontal speed ≤ 15 m/s, climb ≤ 4 m/s, descent
//! ≤ 3 m/s, horizontal acceleration ≤ 3 m/s², vertical ≤ 2 m/s², yaw rate
//! ≤ 60°/s, height 10–120 m above ground (120 m = 400 ft, the open-category
//! limit of EU 2019/947 and FAA Part 107).
//!
//! Attitude: the thrust acceleration `T = a_n − g_n + k|v|v` (k: quadratic
//! drag, chosen so steady flight at 15 m/s needs a 15° tilt) points along
//! body −z, yaw is free; roll and pitch move linearly (Euler rates) from one
//! such attitude to the next in 0.5 s ramps around each acceleration, so the
//! attitude matches the thrust model at phase ends and is a smooth blend in
//! between. The kinematics (and therefore truth and IMU) are exact anyway.

use super::plan::{sign, uni, Plan};
use super::PlanInfo;
use crate::rot;
use navfuse_core::earth::STANDARD_GRAVITY as G0;
use navfuse_core::Vec3;
use rand::Rng;

const DEG: f64 = core::f64::consts::PI / 180.0;
const V_H_MAX: f64 = 15.0;
const V_UP_MAX: f64 = 4.0;
const V_DOWN_MAX: f64 = 3.0;
const A_H_MAX: f64 = 3.0;
const A_V_MAX: f64 = 2.0;
const YAW_RATE_MAX: f64 = 60.0 * DEG;
const AGL_MIN: f64 = 10.0;
const AGL_MAX: f64 = 120.0;
/// Attitude ramp around accelerations [s] (multirotor attitude loops settle in ~0.2–0.5 s).
const RAMP_S: f64 = 0.5;

/// Drag coefficient k [1/m]: k·15² = g·tan 15°.
fn drag_k() -> f64 {
    G0 * (15.0 * DEG).tan() / (V_H_MAX * V_H_MAX)
}

/// Roll and pitch [rad] putting body −z along the thrust acceleration, at `yaw`.
fn tilt(a_n: &Vec3, v_n: &Vec3, yaw: f64) -> (f64, f64) {
    let t = a_n - Vec3::new(0.0, 0.0, G0) + v_n * (drag_k() * v_n.norm());
    let z_b = -t / t.norm();
    // Undo the yaw: z' = R_z(−ψ) z_b = (sθ cφ, −sφ, cθ cφ) for ZYX Euler angles.
    let (s, c) = yaw.sin_cos();
    let zx = c * z_b.x + s * z_b.y;
    let zy = -s * z_b.x + c * z_b.y;
    ((-zy).asin(), zx.atan2(z_b.z))
}

struct Uav {
    v: Vec3,
    yaw: f64,
    roll: f64,
    pitch: f64,
    /// Height above ground [m].
    agl: f64,
}

impl Uav {
    /// One NED phase reaching roll/pitch (r, p), yaw + dyaw and velocity + dv in ~d s.
    fn phase(&mut self, pl: &mut Plan, rp: (f64, f64), dyaw: f64, dv: Vec3, d: f64) {
        let d_rpy = Vec3::new(rp.0 - self.roll, rp.1 - self.pitch, dyaw);
        let t = pl.delta(d_rpy, dv, d, true);
        self.agl -= (self.v.z + 0.5 * dv.z) * t;
        self.v += dv;
        self.roll = rp.0;
        self.pitch = rp.1;
        self.yaw += dyaw;
    }

    /// Change velocity to `vt` with horizontal acceleration `a_h` (vertical
    /// ≤ A_V_MAX): ramp in, accelerate, ramp out.
    fn set_velocity(&mut self, pl: &mut Plan, vt: Vec3, a_h: f64) {
        let dv = vt - self.v;
        let dh = dv.xy().norm();
        let d = (dh / a_h).max(dv.z.abs() / A_V_MAX).max(RAMP_S);
        let a = dv / d;
        let z = Vec3::zeros();
        self.phase(pl, tilt(&a, &self.v, self.yaw), 0.0, z, RAMP_S);
        self.phase(pl, tilt(&a, &vt, self.yaw), 0.0, dv, d);
        self.phase(pl, tilt(&z, &vt, self.yaw), 0.0, z, RAMP_S);
    }

    /// Hold the velocity for ~d s, optionally turning the yaw by `dyaw` first.
    fn cruise(&mut self, pl: &mut Plan, d: f64, dyaw: f64, rate: f64) {
        let z = Vec3::zeros();
        let mut left = d;
        if dyaw != 0.0 {
            let ty = dyaw.abs() / rate;
            self.phase(pl, tilt(&z, &self.v, self.yaw + dyaw), dyaw, z, ty);
            left -= ty;
        }
        if left > 0.0 {
            self.phase(pl, (self.roll, self.pitch), 0.0, z, left);
        }
    }

    /// Climb or descend to `agl_t` at up to the vertical limits, horizontal velocity kept.
    fn change_height(&mut self, pl: &mut Plan, agl_t: f64, r: &mut impl Rng) {
        let dh = agl_t - self.agl;
        if dh.abs() < 1.0 {
            return;
        }
        let vmax = if dh > 0.0 { V_UP_MAX } else { V_DOWN_MAX };
        let a = uni(r, 0.5, 1.0) * A_V_MAX;
        // Triangular profile when the height change is too short for vmax.
        let vz = uni(r, 1.0, vmax).min((dh.abs() * a).sqrt());
        let t_acc = vz / a;
        let t_c = (dh.abs() - vz * t_acc) / vz;
        let vd = Vec3::new(0.0, 0.0, -dh.signum() * vz);
        let (vh, z) = (Vec3::new(self.v.x, self.v.y, 0.0), Vec3::zeros());
        let ac = vd / t_acc;
        self.phase(pl, tilt(&ac, &(vh + vd), self.yaw), 0.0, vd, t_acc);
        self.phase(pl, tilt(&z, &(vh + vd), self.yaw), 0.0, z, t_c);
        self.phase(pl, tilt(&-ac, &vh, self.yaw), 0.0, -vd, t_acc);
        self.phase(pl, tilt(&z, &vh, self.yaw), 0.0, z, RAMP_S);
    }
}

pub(crate) fn multirotor<R: Rng>(
    pl: &mut Plan,
    r: &mut R,
    static_start: bool,
) -> ([f64; 3], [f64; 3], PlanInfo) {
    let yaw0 = uni(r, -180.0, 180.0) * DEG;
    let mut u = Uav {
        v: Vec3::zeros(),
        yaw: yaw0,
        roll: 0.0,
        pitch: 0.0,
        agl: 0.0,
    };
    // A static start waits on the ground, then takes off.
    let no_hover_until = pl.start(r, static_start, true);
    if static_start {
        let h = uni(r, 20.0, 60.0);
        u.change_height(pl, h, r);
    } else {
        let course = uni(r, -180.0, 180.0) * DEG;
        let s = uni(r, 3.0, V_H_MAX);
        u.v = Vec3::new(course.cos(), course.sin(), 0.0) * s;
        u.agl = uni(r, 30.0, 80.0);
        (u.roll, u.pitch) = tilt(&Vec3::zeros(), &u.v, u.yaw);
    }
    let rpy0 = Vec3::new(u.roll, u.pitch, u.yaw);
    let v_b0 = rot::dcm_from_euler(&rpy0).transpose() * u.v;
    while !pl.done() {
        let x: f64 = r.gen();
        let a_h = uni(r, 0.3, 1.0) * A_H_MAX;
        if x < 0.35 {
            // New horizontal velocity; hovering allowed when not in the first minute of a moving start.
            let lo = if pl.t >= no_hover_until { 0.0 } else { 3.0 };
            let s = uni(r, lo, V_H_MAX);
            let c = uni(r, -180.0, 180.0) * DEG;
            u.set_velocity(pl, Vec3::new(c.cos(), c.sin(), 0.0) * s, a_h);
        } else if x < 0.75 {
            let dyaw = if r.gen_bool(0.7) {
                sign(r) * uni(r, 30.0, 180.0) * DEG
            } else {
                0.0
            };
            let rate = uni(r, 0.3, 1.0) * YAW_RATE_MAX;
            u.cruise(pl, uni(r, 3.0, 20.0), dyaw, rate);
        } else if x < 0.9 {
            let h = uni(r, AGL_MIN + 10.0, AGL_MAX - 10.0);
            u.change_height(pl, h, r);
        } else if pl.t >= no_hover_until {
            // Hover and spin.
            u.set_velocity(pl, Vec3::zeros(), a_h);
            let dyaw = sign(r) * uni(r, 45.0, 360.0) * DEG;
            u.cruise(pl, uni(r, 5.0, 20.0), dyaw, uni(r, 0.3, 1.0) * YAW_RATE_MAX);
        }
    }
    (
        [rpy0.x, rpy0.y, rpy0.z],
        [v_b0.x, v_b0.y, v_b0.z],
        PlanInfo::default(),
    )
}
