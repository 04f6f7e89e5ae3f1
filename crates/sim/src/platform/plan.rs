//! Segment list builder on the internal time grid, cut at the run length.
//!
//! Every segment it emits has an explicit duration (rounded to the grid
//! step h, as the trajectory compiler does), so the planner's own state
//! (speed, attitude) matches the compiled trajectory and the last segment is
//! simply shortened to end exactly at `duration_s`.

use crate::trajectory::Segment;
use navfuse_core::Vec3;
use rand::Rng;

/// With a moving start, no stop / pause / hover within this time [s] (the
/// brief: a moving start has no zero-velocity window to align in).
pub(crate) const MOVING_START_NO_STOP_S: f64 = 60.0;

pub(crate) struct Plan {
    pub segs: Vec<Segment>,
    /// Planned time so far [s] (`steps·h`).
    pub t: f64,
    steps: u64,
    end_steps: u64,
    h: f64,
}

fn arr(v: Vec3) -> [f64; 3] {
    [v.x, v.y, v.z]
}

impl Plan {
    pub fn new(h: f64, end: f64) -> Self {
        Plan {
            segs: Vec::new(),
            t: 0.0,
            steps: 0,
            end_steps: (end / h).round() as u64,
            h,
        }
    }

    /// Time left [s].
    pub fn left(&self) -> f64 {
        self.end_steps.saturating_sub(self.steps) as f64 * self.h
    }

    pub fn done(&self) -> bool {
        self.steps >= self.end_steps
    }

    /// Steps of `d` rounded up (≥ 1): rates Δ/d then never exceed the asked ones.
    fn up(&self, d: f64) -> u64 {
        ((d / self.h - 1e-6).ceil() as u64).max(1)
    }

    /// `d` on the grid (rounded up, ≥ one step), cut to the time left.
    pub fn grid(&self, d: f64) -> f64 {
        self.up(d).min(self.end_steps.saturating_sub(self.steps)) as f64 * self.h
    }

    fn advance(&mut self, d: f64) {
        self.steps += (d / self.h).round() as u64;
        self.t = self.steps as f64 * self.h;
    }

    /// Phase of ~`d` s with Euler rates [rad/s] and an acceleration [m/s²]:
    /// v̇_b (body) or, with `ned`, a_n. Returns the real duration.
    pub fn rates(&mut self, rpy_rate: Vec3, acc: Vec3, d: f64, ned: bool) -> f64 {
        let d = self.grid(d);
        if d > 0.0 {
            let (rpy_rate_deg_s, accel, duration_s) =
                (arr(rpy_rate.map(f64::to_degrees)), arr(acc), d);
            self.segs.push(if ned {
                Segment::RatesNed {
                    rpy_rate_deg_s,
                    accel_n: accel,
                    duration_s,
                }
            } else {
                Segment::Rates {
                    rpy_rate_deg_s,
                    accel_b: accel,
                    duration_s,
                }
            });
            self.advance(d);
        }
        d
    }

    /// The start: with `static_start`, a 10–20 s hold at rest (the brief's
    /// "≥ 10 s"). Returns the time before which no stop may be planned
    /// ([`MOVING_START_NO_STOP_S`] for a moving start).
    pub fn start<R: Rng>(&mut self, r: &mut R, static_start: bool, ned: bool) -> f64 {
        if static_start {
            let z = Vec3::zeros();
            self.rates(z, z, uni(r, 10.0, 20.0), ned);
            0.0
        } else {
            MOVING_START_NO_STOP_S
        }
    }

    /// Reach the attitude change `d_rpy` [rad] and velocity change `d_v` in ~`d`
    /// s (body or NED frame); returns the real duration (the change is only
    /// complete if it equals the grid-rounded `d`, i.e. was not cut at the end).
    pub fn delta(&mut self, d_rpy: Vec3, d_v: Vec3, d: f64, ned: bool) -> f64 {
        let full = self.up(d) as f64 * self.h;
        self.rates(d_rpy / full, d_v / full, full, ned)
    }

    /// Push a prepared segment that the compiler rounds to `steps` internal
    /// steps (it cannot be cut, so it is dropped when it does not fit).
    pub fn push_if_fits(&mut self, seg: Segment, steps: u64) -> bool {
        if self.steps + steps > self.end_steps {
            return false;
        }
        self.segs.push(seg);
        self.steps += steps;
        self.t = self.steps as f64 * self.h;
        true
    }

    /// Internal step [s].
    pub fn h(&self) -> f64 {
        self.h
    }
}

/// Uniform draw in [a, b].
pub(crate) fn uni<R: Rng>(r: &mut R, a: f64, b: f64) -> f64 {
    a + (b - a) * r.gen::<f64>()
}

/// ±1 with equal probability.
pub(crate) fn sign<R: Rng>(r: &mut R) -> f64 {
    if r.gen::<bool>() {
        1.0
    } else {
        -1.0
    }
}
