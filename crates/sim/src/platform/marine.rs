//! Small craft (survey launch, RIB, workboat of 5–15 m) in a harbour or on
//! coastal water: a platform whose course is not its heading (current and
//! leeway crab it sideways), that is never still (it rolls, pitches and
//! heaves in the waves even when moored) and that turns slowly.
//!
//! Limits (as recalled from small-craft practice; nothing here is tuned to
//! a result): speed ≤ 8 m/s (≈ 15 kn, a displacement or semi-planing launch
//! at cruise), |a| ≤ 0.5 m/s² (hull drag and inertia: 0 → 8 m/s in ≥ 16 s),
//! rate of turn ≤ 6°/s (a small craft's hard-over turn at speed), crab angle
//! (heading − course) within ±10° (leeway in wind plus a 0.5–1 m/s tidal
//! current across a 5 m/s track ≈ 6–11°), changing at ≤ 0.5°/s.
//!
//! Waves (sea state 2–3 of the WMO code, 0.1–1.25 m significant height;
//! small-craft natural roll periods 3–8 s): roll 1–6° amplitude, period
//! 4–8 s; pitch 0.5–3°, 3–6 s; heave 0.1–0.5 m, 3–8 s; yaw 0.5–2° at the
//! roll period; random phases. Moored (the static start, in a harbour) the
//! amplitudes are a third of these: a moored boat is at rest on average but
//! never static, so no zero-velocity detector may call it still.
//!
//! Kinematics: the motion is sampled every [`STEP_S`] and each step is one
//! `RatesNed` segment with constant Euler rates and NED acceleration that
//! reach the sampled attitude and velocity exactly at its end (the IMU of a
//! piecewise-constant-acceleration path is exact; the 0.2 s sampling of a
//! ≥ 3 s wave is a polygon within 1 % of the sine).

use super::plan::{sign, uni, Plan};
use super::PlanInfo;
use crate::rot;
use navfuse_core::Vec3;
use rand::Rng;

const DEG: f64 = core::f64::consts::PI / 180.0;
const V_MAX: f64 = 8.0;
const A_MAX: f64 = 0.5;
const ROT_MAX: f64 = 6.0 * DEG;
const CRAB_MAX: f64 = 10.0 * DEG;
const CRAB_RATE: f64 = 0.5 * DEG;
/// Sampling of the wave motion [s].
pub(crate) const STEP_S: f64 = 0.2;
/// Wave amplitudes while moored, relative to under way.
const MOORED_WAVES: f64 = 1.0 / 3.0;

/// One sinusoid `a sin(ω t + φ)`.
#[derive(Clone, Copy)]
struct Wave {
    a: f64,
    w: f64,
    phi: f64,
}

impl Wave {
    fn draw<R: Rng>(r: &mut R, a: (f64, f64), period_s: (f64, f64)) -> Self {
        Wave {
            a: uni(r, a.0, a.1),
            w: 2.0 * core::f64::consts::PI / uni(r, period_s.0, period_s.1),
            phi: uni(r, 0.0, 2.0 * core::f64::consts::PI),
        }
    }
    fn at(&self, t: f64) -> f64 {
        self.a * (self.w * t + self.phi).sin()
    }
    fn rate(&self, t: f64) -> f64 {
        self.a * self.w * (self.w * t + self.phi).cos()
    }
}

struct Boat {
    speed: f64,
    course: f64,
    crab: f64,
    roll: Wave,
    pitch: Wave,
    heave: Wave,
    yaw: Wave,
    /// Wave scale now (moored → under way ramps over the first manoeuvre).
    sea: f64,
    /// Attitude (roll, pitch, unwrapped yaw) and NED velocity at `pl.t`,
    /// as the emitted segments left them.
    rpy: Vec3,
    v_n: Vec3,
}

impl Boat {
    fn attitude(&self, t: f64) -> Vec3 {
        let s = self.sea;
        Vec3::new(
            s * self.roll.at(t),
            s * self.pitch.at(t),
            self.course + self.crab + s * self.yaw.at(t),
        )
    }
    /// NED velocity: the track plus the heave (down = − up-heave rate).
    fn velocity(&self, t: f64) -> Vec3 {
        let (s, c) = self.course.sin_cos();
        Vec3::new(
            self.speed * c,
            self.speed * s,
            -self.sea * self.heave.rate(t),
        )
    }
    /// One step of ≤ [`STEP_S`] towards the state set on `self` for its end.
    fn step(&mut self, pl: &mut Plan) -> f64 {
        let d = pl.grid(STEP_S);
        if d <= 0.0 {
            return 0.0;
        }
        let t1 = pl.t + d;
        let rpy1 = self.attitude(t1);
        let v1 = self.velocity(t1);
        let d = pl.rates((rpy1 - self.rpy) / d, (v1 - self.v_n) / d, d, true);
        self.rpy = rpy1;
        self.v_n = v1;
        d
    }
    /// Move speed, course and crab towards their targets at the given rates
    /// for ~`dur` s (at least until the targets are reached).
    fn manoeuvre(&mut self, pl: &mut Plan, to: (f64, f64, f64), rates: (f64, f64), dur: f64) {
        let (v_t, c_t, crab_t) = to;
        let (a, rot) = rates;
        let mut t = 0.0;
        while !pl.done() {
            let reached = self.speed == v_t && self.course == c_t && self.crab == crab_t;
            if reached && t >= dur {
                break;
            }
            let h = pl.grid(STEP_S);
            self.speed = approach(self.speed, v_t, a * h);
            self.course = approach(self.course, c_t, rot * h);
            self.crab = approach(self.crab, crab_t, CRAB_RATE * h);
            // Waves build up to the open-water scale over ~30 s under way.
            if self.speed > 0.5 {
                self.sea = approach(self.sea, 1.0, 0.02 * h);
            }
            t += self.step(pl);
        }
    }
}

/// `x` moved towards `target` by at most `max` (exactly `target` once within).
fn approach(x: f64, target: f64, max: f64) -> f64 {
    if (target - x).abs() <= max {
        target
    } else {
        x + max.copysign(target - x)
    }
}

pub(crate) fn small_craft<R: Rng>(
    pl: &mut Plan,
    r: &mut R,
    static_start: bool,
) -> ([f64; 3], [f64; 3], PlanInfo) {
    let mut b = Boat {
        speed: 0.0,
        course: uni(r, -180.0, 180.0) * DEG,
        crab: uni(r, -1.0, 1.0) * CRAB_MAX,
        roll: Wave::draw(r, (1.0 * DEG, 6.0 * DEG), (4.0, 8.0)),
        pitch: Wave::draw(r, (0.5 * DEG, 3.0 * DEG), (3.0, 6.0)),
        heave: Wave::draw(r, (0.1, 0.5), (3.0, 8.0)),
        yaw: Wave::draw(r, (0.5 * DEG, 2.0 * DEG), (4.0, 8.0)),
        sea: if static_start { MOORED_WAVES } else { 1.0 },
        rpy: Vec3::zeros(),
        v_n: Vec3::zeros(),
    };
    if !static_start {
        b.speed = uni(r, 2.0, V_MAX);
    }
    b.rpy = b.attitude(0.0);
    b.v_n = b.velocity(0.0);
    let rpy0 = b.rpy;
    let v_b0 = rot::dcm_from_euler(&rpy0).transpose() * b.v_n;
    // Moored: 10–20 s alongside (waves, no way on), as the other platforms'
    // static start.
    let no_stop_until = if static_start {
        let hold = uni(r, 10.0, 20.0);
        let to = (0.0, b.course, b.crab);
        b.manoeuvre(pl, to, (A_MAX, ROT_MAX), hold);
        0.0
    } else {
        super::plan::MOVING_START_NO_STOP_S
    };
    while !pl.done() {
        let x: f64 = r.gen();
        let a = uni(r, 0.2, 1.0) * A_MAX;
        let rot = uni(r, 0.3, 1.0) * ROT_MAX;
        let crab = uni(r, -1.0, 1.0) * CRAB_MAX;
        let cruise = uni(r, 5.0, 30.0);
        if x < 0.35 {
            let lo = if pl.t >= no_stop_until { 0.5 } else { 2.0 };
            let to = (uni(r, lo, V_MAX), b.course, crab);
            b.manoeuvre(pl, to, (a, rot), cruise);
        } else if x < 0.8 {
            let turn = sign(r) * uni(r, 20.0, 180.0) * DEG;
            let to = (b.speed.max(1.0), b.course + turn, crab);
            b.manoeuvre(pl, to, (a, rot), cruise);
        } else if pl.t >= no_stop_until {
            // Hold station (drifting with no way on), then get under way.
            let to = (0.0, b.course, crab);
            b.manoeuvre(pl, to, (a, rot), uni(r, 10.0, 30.0));
        }
    }
    (
        [rpy0.x, rpy0.y, rpy0.z],
        [v_b0.x, v_b0.y, v_b0.z],
        PlanInfo::default(),
    )
}
