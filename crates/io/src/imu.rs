//! Turning time-stamped IMU records into [`ImuSample`] intervals, shared by
//! the KF-GINS and CSV IMU readers.
//!
//! Each record closes the interval `(t_prev, t]`, `dt = t − t_prev`.
//! **The first record** has no predecessor: its `dt` is `1/nominal_rate` when
//! a nominal rate is given, else the first real interval `t₁ − t₀` (the
//! record is held back until the second one arrives). Records whose time is
//! equal to (`duplicate time`) or before (`time going backwards`) the last
//! accepted one are rejected and counted.
//!
//! Rate-form records are integrated over the interval:
//! - `Rectangle`: `Δθ = ω(t)·dt` (the rate at the end of the interval held
//!   over it);
//! - `Trapezoid`: `Δθ = ½(ω(t_prev) + ω(t))·dt` (second-order; the first
//!   record, having no predecessor, uses the rectangle rule).
//!
//! Same for `Δv` from specific force. Increment-form records are passed on.

use navfuse_core::types::{ImuSample, Vec3};

/// Form of the IMU values in a record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImuForm {
    /// Already increments: Δθ [rad], Δv [m/s] over the interval.
    Increment,
    /// Rates (ω [rad/s], f [m/s²]) at the stamp, integrated by the rectangle rule.
    RateRectangle,
    /// Rates integrated by the trapezoid rule (the default for rate data).
    RateTrapezoid,
}

/// One IMU record in SI units, body frame (mounting already applied).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RawImu {
    /// GPS seconds (`week·604800 + tow`).
    pub t: f64,
    /// GPS week and time of week of the stamp: `dt` is formed from these, as
    /// an f64 `t` near 1.4e9 s resolves only ~0.24 µs.
    pub week: u32,
    pub tow: f64,
    pub gyro: Vec3,
    pub acc: Vec3,
}

pub(crate) const REASON_DUP_TIME: &str = "duplicate time";
pub(crate) const REASON_BACKWARDS: &str = "time going backwards";
pub(crate) const REASON_LONE: &str = "single record, no interval (no nominal rate)";

#[derive(Debug)]
pub(crate) struct Assembler {
    form: ImuForm,
    nominal_dt: Option<f64>,
    prev: Option<RawImu>,
    first_pending: Option<RawImu>,
    queued: Option<ImuSample>,
}

impl Assembler {
    pub fn new(form: ImuForm, nominal_rate_hz: Option<f64>) -> Self {
        let nominal_dt = nominal_rate_hz
            .filter(|r| r.is_finite() && *r > 0.0)
            .map(|r| 1.0 / r);
        Assembler {
            form,
            nominal_dt,
            prev: None,
            first_pending: None,
            queued: None,
        }
    }

    fn make(&self, r: &RawImu, dt: f64, prev: Option<&RawImu>) -> ImuSample {
        let (dtheta_b, dvel_b) = match (self.form, prev) {
            (ImuForm::Increment, _) => (r.gyro, r.acc),
            (ImuForm::RateTrapezoid, Some(p)) => {
                ((p.gyro + r.gyro) * (0.5 * dt), (p.acc + r.acc) * (0.5 * dt))
            }
            (ImuForm::RateRectangle, _) | (ImuForm::RateTrapezoid, None) => {
                (r.gyro * dt, r.acc * dt)
            }
        };
        ImuSample {
            t: r.t,
            dt,
            dtheta_b,
            dvel_b,
        }
    }

    /// Feed one record: `Ok(Some)` a sample, `Ok(None)` held back (first
    /// record), `Err(reason)` rejected.
    pub fn push(&mut self, r: RawImu) -> Result<Option<ImuSample>, &'static str> {
        let Some(p) = self.prev else {
            self.prev = Some(r);
            return Ok(match self.nominal_dt {
                Some(dt) => Some(self.make(&r, dt, None)),
                None => {
                    self.first_pending = Some(r);
                    None
                }
            });
        };
        let dt = (f64::from(r.week) - f64::from(p.week)) * crate::time::SECONDS_PER_WEEK
            + (r.tow - p.tow);
        if dt == 0.0 {
            return Err(REASON_DUP_TIME);
        }
        if dt < 0.0 {
            return Err(REASON_BACKWARDS);
        }
        self.prev = Some(r);
        if let Some(f) = self.first_pending.take() {
            let s0 = self.make(&f, dt, None);
            self.queued = Some(self.make(&r, dt, Some(&f)));
            return Ok(Some(s0));
        }
        Ok(Some(self.make(&r, dt, Some(&p))))
    }

    /// A sample produced together with the previous one (after the first interval).
    pub fn take_queued(&mut self) -> Option<ImuSample> {
        self.queued.take()
    }

    /// At end of input: the reason to reject a record still held back.
    pub fn finish(&mut self) -> Option<&'static str> {
        self.first_pending.take().map(|_| REASON_LONE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn raw(t: f64, w: f64) -> RawImu {
        RawImu {
            t,
            week: 0,
            tow: t,
            gyro: Vec3::new(w, 0.0, 0.0),
            acc: Vec3::new(0.0, 0.0, -9.8),
        }
    }

    #[test]
    fn first_dt_from_next_interval_and_trapezoid() {
        let mut a = Assembler::new(ImuForm::RateTrapezoid, None);
        assert_eq!(a.push(raw(1.0, 1.0)), Ok(None));
        let s0 = a.push(raw(1.02, 3.0)).unwrap().unwrap();
        assert_eq!((s0.t, s0.dt), (1.0, 0.020000000000000018));
        assert!((s0.dtheta_b.x - 0.02).abs() < 1e-12);
        let s1 = a.take_queued().unwrap();
        assert!(
            (s1.dtheta_b.x - 0.04).abs() < 1e-12,
            "trapezoid (1+3)/2*0.02"
        );
        assert_eq!(a.push(raw(1.02, 0.0)), Err(REASON_DUP_TIME));
        assert_eq!(a.push(raw(1.01, 0.0)), Err(REASON_BACKWARDS));
        let s2 = a.push(raw(1.03, 3.0)).unwrap().unwrap();
        assert!((s2.dt - 0.01).abs() < 1e-12);
        assert_eq!(a.finish(), None);
    }

    #[test]
    fn nominal_rate_and_rectangle() {
        let mut a = Assembler::new(ImuForm::RateRectangle, Some(100.0));
        let s0 = a.push(raw(5.0, 2.0)).unwrap().unwrap();
        assert_eq!(s0.dt, 0.01);
        assert!((s0.dtheta_b.x - 0.02).abs() < 1e-15);
        assert!((s0.dvel_b.z + 0.098).abs() < 1e-12);
        let mut b = Assembler::new(ImuForm::Increment, None);
        assert_eq!(b.push(raw(5.0, 2.0)), Ok(None));
        assert_eq!(b.finish(), Some(REASON_LONE));
    }
}
