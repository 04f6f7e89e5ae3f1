//! Wheeled ground vehicles (car, robot): non-holonomic, body velocity along
//! body x only (`v_b = (v, 0, 0)`), random cruise / speed change / turn /
//! grade / stop manoeuvres inside the limits below.

use super::plan::{sign, uni, Plan};
use super::PlanInfo;
use navfuse_core::Vec3;
use rand::Rng;

const DEG: f64 = core::f64::consts::PI / 180.0;

/// Limits of a wheeled platform (each with its source in [`CAR`] / [`ROBOT`]).
pub(crate) struct GroundLimits {
    /// Cruise speed range [m/s].
    pub v: (f64, f64),
    /// Longitudinal acceleration / braking magnitude limit [m/s²].
    pub a_max: f64,
    /// Lateral (centripetal) acceleration limit in turns [m/s²].
    pub a_lat_max: f64,
    /// Yaw rate limit [rad/s].
    pub w_max: f64,
    /// Road grade limit (rise/run).
    pub grade_max: f64,
    /// Vertical-curve acceleration v·θ̇ limit [m/s²].
    pub a_vert_max: f64,
    /// Can turn on the spot (differential drive).
    pub turn_in_place: bool,
    /// Turn angle range [rad].
    pub turn: (f64, f64),
    /// Cruise and standstill duration ranges [s].
    pub cruise_s: (f64, f64),
    pub stop_s: (f64, f64),
}

/// Passenger car. Speeds 8–30 m/s (town to motorway, 29–108 km/h);
/// |a| ≤ 3 m/s² (normal driving stays below ~0.3 g, e.g. the accelerations
/// of urban drive cycles); lateral ≤ 4 m/s² (≈ 0.4 g, the usual comfort
/// bound of road curve design); grades ≤ 8 % (steep main roads; motorways
/// ≤ 4–6 %); vertical curves ≤ 0.5 m/s² (sag-curve comfort criteria
/// ≈ 0.3 m/s² in road design guides, AASHTO Green Book — as recalled);
/// yaw rate ≤ 30°/s (a ~5 m turning radius at walking pace).
pub(crate) const CAR: GroundLimits = GroundLimits {
    v: (8.0, 30.0),
    a_max: 3.0,
    a_lat_max: 4.0,
    w_max: 30.0 * DEG,
    grade_max: 0.08,
    a_vert_max: 0.5,
    turn_in_place: false,
    turn: (20.0 * DEG, 180.0 * DEG),
    cruise_s: (5.0, 40.0),
    stop_s: (5.0, 30.0),
};

/// Slow wheeled ground robot (differential drive): 0.3–1.5 m/s (TurtleBot-
/// to Husky/Jackal-class top speeds 0.7–2 m/s, manufacturers' sheets as
/// recalled); |a| ≤ 1 m/s²; yaw rate ≤ 60°/s, turning in place; lateral
/// ≤ 1.5 m/s² (1.5 m/s at 60°/s); ramps ≤ 8 % (1:12, the ADA ramp limit).
pub(crate) const ROBOT: GroundLimits = GroundLimits {
    v: (0.3, 1.5),
    a_max: 1.0,
    a_lat_max: 1.5,
    w_max: 60.0 * DEG,
    grade_max: 0.08,
    a_vert_max: 0.5,
    turn_in_place: true,
    turn: (20.0 * DEG, 180.0 * DEG),
    cruise_s: (2.0, 20.0),
    stop_s: (1.0, 10.0),
};

pub(crate) fn car<R: Rng>(
    pl: &mut Plan,
    r: &mut R,
    static_start: bool,
) -> ([f64; 3], [f64; 3], PlanInfo) {
    wheeled(pl, r, static_start, &CAR)
}

pub(crate) fn robot<R: Rng>(
    pl: &mut Plan,
    r: &mut R,
    static_start: bool,
) -> ([f64; 3], [f64; 3], PlanInfo) {
    wheeled(pl, r, static_start, &ROBOT)
}

fn wheeled<R: Rng>(
    pl: &mut Plan,
    r: &mut R,
    static_start: bool,
    l: &GroundLimits,
) -> ([f64; 3], [f64; 3], PlanInfo) {
    let yaw0 = uni(r, -180.0, 180.0) * DEG;
    let mut v = if static_start {
        0.0
    } else {
        uni(r, l.v.0, l.v.1)
    };
    let v0 = v;
    let mut pitch: f64 = 0.0;
    let x = Vec3::x();
    let z = Vec3::zeros();
    let no_stop_until = pl.start(r, static_start, false);
    // Speed changes at 30–100 % of the limit.
    let accel = |r: &mut R| uni(r, 0.3, 1.0) * l.a_max;
    while !pl.done() {
        if v < 1e-9 {
            if l.turn_in_place && r.gen_bool(0.5) {
                let ang = sign(r) * uni(r, 45.0 * DEG, 180.0 * DEG);
                let w = uni(r, 0.5, 1.0) * l.w_max;
                pl.delta(Vec3::new(0.0, 0.0, ang), z, ang.abs() / w, false);
            }
            let vt = uni(r, l.v.0, l.v.1);
            pl.delta(z, x * vt, vt / accel(r), false);
            v = vt;
            continue;
        }
        let u: f64 = r.gen();
        if u < 0.3 {
            pl.rates(z, z, uni(r, l.cruise_s.0, l.cruise_s.1), false);
        } else if u < 0.5 {
            let vt = uni(r, l.v.0, l.v.1);
            pl.delta(z, x * (vt - v), (vt - v).abs() / accel(r), false);
            v = vt;
        } else if u < 0.8 {
            let ang = sign(r) * uni(r, l.turn.0, l.turn.1);
            // Rate from the lateral-acceleration budget a = v·ω, capped.
            let w = (uni(r, 0.3, 1.0) * l.a_lat_max / v).min(l.w_max);
            pl.delta(Vec3::new(0.0, 0.0, ang), z, ang.abs() / w, false);
        } else if u < 0.9 {
            let target = if r.gen_bool(0.3) {
                0.0
            } else {
                uni(r, -l.grade_max, l.grade_max).atan()
            };
            let dth = target - pitch;
            // Vertical curve: v·θ̇ ≤ a_vert_max, at least 3 s.
            let d = (dth.abs() * v / l.a_vert_max).max(3.0);
            pl.delta(Vec3::new(0.0, dth, 0.0), z, d, false);
            pitch = target;
        } else if pl.t >= no_stop_until {
            pl.delta(z, -x * v, v / accel(r), false);
            v = 0.0;
            pl.rates(z, z, uni(r, l.stop_s.0, l.stop_s.1), false);
        }
    }
    ([0.0, 0.0, yaw0], [v0, 0.0, 0.0], PlanInfo::default())
}
