//! Segment list builder on the internal time grid, cut at the run length.
//!
//! Every segment it emits has an explicit duration (rounded to the grid
//! step h, as the trajectory compiler does), so the planner's own state
//! (speed, attitude) matches the compiled trajectory and the last segment is
//! simply shortened to end exactly at `duration_s`.

use crate::trajectory::Segment;
use navfuse_core::Vec3;
use rand::Rng;

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

    /// Body-frame phase: Euler rates [rad/s], v̇_b [m/s²] for ~`d` s; returns the real duration.
    pub fn rates(&mut self, rpy_rate: Vec3, acc_b: Vec3, d: f64) -> f64 {
        let d = self.grid(d);
        if d > 0.0 {
            self.segs.push(Segment::Rates {
                rpy_rate_deg_s: arr(rpy_rate.map(f64::to_degrees)),
                accel_b: arr(acc_b),
                duration_s: d,
            });
            self.advance(d);
        }
        d
    }

    /// NED-frame phase: Euler rates [rad/s], a_n [m/s²] for ~`d` s; returns the real duration.
    pub fn rates_ned(&mut self, rpy_rate: Vec3, acc_n: Vec3, d: f64) -> f64 {
        let d = self.grid(d);
        if d > 0.0 {
            self.segs.push(Segment::RatesNed {
                rpy_rate_deg_s: arr(rpy_rate.map(f64::to_degrees)),
                accel_n: arr(acc_n),
                duration_s: d,
            });
            self.advance(d);
        }
        d
    }

    /// Reach the attitude change `d_rpy` [rad] and velocity change `d_v` in ~`d`
    /// s (body or NED frame); returns the real duration (the change is only
    /// complete if it equals the grid-rounded `d`, i.e. was not cut at the end).
    pub fn delta(&mut self, d_rpy: Vec3, d_v: Vec3, d: f64, ned: bool) -> f64 {
        let full = self.up(d) as f64 * self.h;
        let (w, a) = (d_rpy / full, d_v / full);
        if ned {
            self.rates_ned(w, a, full)
        } else {
            self.rates(w, a, full)
        }
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
