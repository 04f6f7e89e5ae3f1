//! Pedestrian with a hand-held / body-worn device: `Walk` segments (step
//! bounce and sway, see `trajectory::walk`), tight turns and pauses.
//!
//! Limits (per run draws): speed 1.0–1.5 m/s (comfortable walking speeds of
//! adults, ≈ 1.2–1.4 m/s on average, e.g. Bohannon 1997 — as recalled);
//! cadence 1.8–2.0 steps/s; step accelerations forward 1–2, lateral
//! 0.3–0.8, vertical 1–3 m/s² (amplitude); sway 1–3° per axis; tight turns
//! of 45–135° in 1–3 strides (≈ 1–3 s, up to ~135°/s) or 180° in 2–3; pauses of
//! 2–10 s. The device yaw differs from the walking course by a constant
//! offset in ±30° (phone held askew, body-worn off-centre): the body velocity
//! is NOT along body x.

use super::plan::{sign, uni, Plan};
use super::PlanInfo;
use crate::trajectory::{walk_strides, Segment};
use navfuse_core::Vec3;
use rand::Rng;

const DEG: f64 = core::f64::consts::PI / 180.0;

struct Walker {
    cadence: f64,
    step_accel: [f64; 3],
    sway: [f64; 3],
    offset_deg: f64,
}

impl Walker {
    /// Push `strides` strides ending at `speed` with a heading change `turn` [rad].
    fn walk(&self, pl: &mut Plan, strides: u64, speed: Option<f64>, turn: f64) -> bool {
        let d = 2.0 * strides as f64 / self.cadence;
        debug_assert_eq!(walk_strides(d, self.cadence), strides);
        let steps = (d / pl.h()).round().max(1.0) as u64;
        pl.push_if_fits(
            Segment::Walk {
                duration_s: d,
                speed_mps: speed,
                turn_deg: turn / DEG,
                cadence_hz: self.cadence,
                step_accel_mps2: self.step_accel,
                sway_deg: self.sway,
                yaw_offset_deg: Some(self.offset_deg),
            },
            steps,
        )
    }
}

pub(crate) fn pedestrian<R: Rng>(
    pl: &mut Plan,
    r: &mut R,
    static_start: bool,
) -> ([f64; 3], [f64; 3], PlanInfo) {
    let yaw0 = uni(r, -180.0, 180.0) * DEG;
    let offset = uni(r, -30.0, 30.0) * DEG;
    let w = Walker {
        cadence: uni(r, 1.8, 2.0),
        step_accel: [uni(r, 1.0, 2.0), uni(r, 0.3, 0.8), uni(r, 1.0, 3.0)],
        sway: [uni(r, 1.0, 3.0), uni(r, 1.0, 3.0), uni(r, 1.0, 3.0)],
        offset_deg: offset / DEG,
    };
    // Walking direction in the body frame: course = yaw − offset.
    let dir_b = Vec3::new(offset.cos(), -offset.sin(), 0.0);
    let speed = |r: &mut R| uni(r, 1.0, 1.5);
    let mut v = if static_start { 0.0 } else { speed(r) };
    let v_b0 = dir_b * v;
    let z = Vec3::zeros();
    let no_stop_until = pl.start(r, static_start, false);
    while !pl.done() {
        // Whole strides may not fill the end exactly: the last few seconds
        // continue at constant velocity (without the step motion).
        let fits = if v < 1e-9 {
            let s = speed(r);
            v = s;
            w.walk(pl, 1, Some(s), 0.0)
        } else {
            let u: f64 = r.gen();
            if u < 0.45 {
                let n = r.gen_range(3..=15);
                let s = if r.gen_bool(0.5) {
                    Some(speed(r))
                } else {
                    None
                };
                let ok = w.walk(pl, n, s, 0.0);
                if ok {
                    v = s.unwrap_or(v);
                }
                ok
            } else if u < 0.85 {
                // 45–135° in 1–3 strides (≤ ~135°/s), or about-turns in 2–3.
                let (ang, n) = if r.gen_bool(0.15) {
                    (180.0 * DEG, r.gen_range(2..=3))
                } else {
                    (uni(r, 45.0, 135.0) * DEG, r.gen_range(1..=3))
                };
                w.walk(pl, n, None, sign(r) * ang)
            } else if pl.t >= no_stop_until {
                let ok = w.walk(pl, 1, Some(0.0), 0.0);
                if ok {
                    v = 0.0;
                    pl.rates(z, z, uni(r, 2.0, 10.0), false);
                }
                ok
            } else {
                true
            }
        };
        if !fits {
            pl.rates(z, z, pl.left(), false);
        }
    }
    (
        [0.0, 0.0, yaw0],
        [v_b0.x, v_b0.y, v_b0.z],
        PlanInfo {
            yaw_offset: Some(offset),
        },
    )
}
