//! The one place the ESKF applies the aiding sensors of issue 17: odometer,
//! baseline heading, magnetometer (models in [`crate::measurements`]).
//! Each is off unless configured in [`AidingConfig`]; off, nothing here runs
//! and the filter's outputs are bit-identical to the filter without it.
//!
//! Timing: an aiding event is applied at the filter's current time (the
//! last IMU sample) when it lies within the sensor's tolerance of it
//! (odometer: `max_age_s`; heading and magnetometer: [`MAX_LAG_S`]);
//! older or newer ones are dropped and counted as bad. The events are
//! expected in time order with the IMU (as every reader merges them).

use super::{Eskf, UpdateKind, UpdateReject, IA_ODO, NA, NX};
use crate::measurements::heading::{self, HeadingConfig};
use crate::measurements::magnetometer::{self, MagConfig, MagReject};
use crate::measurements::odometer::{self, OdometerConfig};
use crate::measurements::wmm;
#[allow(unused_imports)]
use crate::prelude::*;
use crate::types::{HeadingFix, HeadingSource, MagSample, OdometerSample};
use crate::Vec3;
use nalgebra::{SMatrix, SVector};

/// Largest |event time − filter time| of a heading or magnetometer sample
/// applied at the filter time [s]: 20 ms is two 100 Hz IMU intervals, in
/// which a car turning at 30°/s (the simulator's limit) turns 0.6°; at
/// the usual 200 Hz IMU rate the applied sample is ≤ 2.5 ms off (0.08°).
pub const MAX_LAG_S: f64 = 0.02;

/// Which aiding sensors the filter uses (all `None`: none, the default).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AidingConfig {
    pub odometer: Option<OdometerConfig>,
    pub heading: Option<HeadingConfig>,
    pub mag: Option<MagConfig>,
}

/// Counters of the aiding updates (inside [`super::EskfStats`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AidingStats {
    pub odometer_used: u64,
    pub odometer_rejected_gate: u64,
    /// Odometer samples not applied: too far from the filter time, not
    /// finite, an unconfigured wheel, or before the first IMU sample.
    pub odometer_rejected_bad: u64,
    pub heading_used: u64,
    pub heading_rejected_gate: u64,
    pub heading_rejected_bad: u64,
    pub mag_used: u64,
    pub mag_rejected_gate: u64,
    /// Magnetometer samples whose magnitude or dip disagreed with the WMM.
    pub mag_disturbed: u64,
    pub mag_rejected_bad: u64,
}

/// Per-filter aiding bookkeeping.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct AidingState {
    /// Time of the last applied odometer update with NHC rows [s].
    pub last_odo_nhc: Option<f64>,
    pub last_mag: Option<f64>,
}

impl Eskf {
    /// Odometer update (forward speed at the wheel with the scale state,
    /// plus the NHC rows at the wheel when configured).
    pub(super) fn push_odometer(&mut self, o: &OdometerSample) {
        let Some(cfg) = self.cfg.aiding.odometer else {
            return;
        };
        let ok = self.started
            && o.t.is_finite()
            && o.speed_mps.is_finite()
            && o.dt.is_finite()
            && o.std_mps.is_finite()
            && o.wheel == 0
            && (o.t - self.t).abs() <= cfg.max_age_s;
        if !ok {
            self.stats.aiding.odometer_rejected_bad += 1;
            return;
        }
        let c_bn = self.nav.c_bn();
        let (v_b, h_v) =
            odometer::wheel_velocity(&c_bn, &self.nav.v_n, &self.w_ib_b, &cfg.lever_arm_b);
        let e = crate::ins::mech::EarthAt::new(self.nav.lat, self.nav.h);
        let a_fwd = (self.f_b + c_bn.transpose() * Vec3::new(0.0, 0.0, e.g)).x;
        let scale = self.aug.as_ref().map_or(0.0, |a| a.x[IA_ODO]);
        let std = if o.std_mps > 0.0 {
            o.std_mps
        } else {
            cfg.std_mps
        };
        let res = match cfg.nhc_std {
            Some(n) => {
                let r = odometer::rows::<3>(&v_b, &h_v, scale, o.speed_mps, std, n, a_fwd, o.dt);
                let res = self.odometer_rows(&r);
                if res.is_ok() {
                    self.aiding.last_odo_nhc = Some(self.t);
                }
                res
            }
            None => {
                let r = odometer::rows::<1>(&v_b, &h_v, scale, o.speed_mps, std, 0.0, a_fwd, o.dt);
                self.odometer_rows(&r)
            }
        };
        tally(
            res,
            &mut self.stats.aiding.odometer_used,
            &mut self.stats.aiding.odometer_rejected_gate,
        );
    }

    /// Apply odometer rows (1: speed; 3: speed + NHC) with the scale column.
    fn odometer_rows<const M: usize>(
        &mut self,
        r: &odometer::OdometerRows<M>,
    ) -> Result<f64, UpdateReject> {
        let mut h_a = SMatrix::<f64, M, NA>::zeros();
        h_a.set_column(IA_ODO, &r.h_scale);
        let rr = SMatrix::from_diagonal(&r.r_diag);
        self.update_aug(&r.h, &h_a, &rr, &r.dz, true, UpdateKind::Odometer)
    }

    /// Apply heading rows `(dz, H, R diagonal)` (1: heading; 2: + pitch).
    fn heading_rows<const M: usize>(
        &mut self,
        (dz, h, r): (SVector<f64, M>, SMatrix<f64, M, NX>, SVector<f64, M>),
    ) -> Result<f64, UpdateReject> {
        let rr = SMatrix::from_diagonal(&r);
        self.update(&h, &rr, &dz, true, UpdateKind::Heading)
    }

    /// Whether the odometer's NHC rows were applied recently, so the plain
    /// NHC at the IMU is skipped (the same constraint, at the wrong point).
    pub(super) fn odometer_nhc_recent(&self) -> bool {
        match (self.cfg.nhc, self.aiding.last_odo_nhc) {
            (Some(n), Some(t)) => self.t - t <= n.interval.max(1.0),
            _ => false,
        }
    }

    /// Baseline heading (and pitch) update; a magnetometer-sourced fix is
    /// the heading of body +x (no mounting).
    pub(super) fn push_heading(&mut self, f: &HeadingFix) {
        let Some(cfg) = self.cfg.aiding.heading else {
            return;
        };
        let ok = self.started
            && f.t.is_finite()
            && f.heading_rad.is_finite()
            && f.std_heading_rad.is_finite()
            && f.std_heading_rad > 0.0
            && (f.t - self.t).abs() <= MAX_LAG_S;
        if !ok {
            self.stats.aiding.heading_rejected_bad += 1;
            return;
        }
        let u_b = match f.source {
            HeadingSource::Magnetometer => Vec3::x(),
            _ => heading::baseline_b(cfg.mount_yaw_rad, cfg.mount_pitch_rad),
        };
        let c_bn = self.nav.c_bn();
        let with_pitch = cfg.use_pitch
            && f.pitch_rad.is_finite()
            && f.std_pitch_rad.is_finite()
            && f.std_pitch_rad > 0.0;
        let res = if with_pitch {
            let rows = heading::rows::<2>(&c_bn, &u_b, f, cfg.std_floor_rad);
            self.heading_rows(rows)
        } else {
            let rows = heading::rows::<1>(&c_bn, &u_b, f, cfg.std_floor_rad);
            self.heading_rows(rows)
        };
        tally(
            res,
            &mut self.stats.aiding.heading_used,
            &mut self.stats.aiding.heading_rejected_gate,
        );
    }

    /// Magnetometer heading update with the WMM declination at the filter's
    /// position and the disturbance gate ([`magnetometer`]).
    pub(super) fn push_mag(&mut self, m: &MagSample) {
        let Some(cfg) = self.cfg.aiding.mag else {
            return;
        };
        let ok = self.started
            && m.t.is_finite()
            && m.m_b.iter().all(|v| v.is_finite())
            && (m.t - self.t).abs() <= MAX_LAG_S;
        if !ok {
            self.stats.aiding.mag_rejected_bad += 1;
            return;
        }
        // Half an IMU interval of slack: a 10 Hz stream on a 100 Hz filter
        // must not lose every other sample to rounding.
        if self
            .aiding
            .last_mag
            .is_some_and(|t| self.t - t < cfg.interval_s - 0.5 * self.last_dt)
        {
            return;
        }
        let Some(w) = wmm::field(self.nav.lat, self.nav.lon, self.nav.h, cfg.decimal_year) else {
            self.stats.aiding.mag_rejected_bad += 1;
            return;
        };
        let p = self.cfg.gate_probability.unwrap_or(MAG_GATE_PROBABILITY);
        let k = crate::kalman::chi2_quantile(1, p).sqrt();
        let decl_std = wmm::declination_std(w.b_n.xy().norm() * 1e9);
        match magnetometer::heading_row(&self.nav.c_bn(), &m.m_b, &w, &cfg, decl_std, k) {
            Ok((dz, h, r)) => {
                self.aiding.last_mag = Some(self.t);
                let res = self.update(
                    &h,
                    &SMatrix::<f64, 1, 1>::new(r),
                    &SVector::<f64, 1>::new(dz),
                    true,
                    UpdateKind::Mag,
                );
                tally(
                    res,
                    &mut self.stats.aiding.mag_used,
                    &mut self.stats.aiding.mag_rejected_gate,
                );
            }
            Err(MagReject::Disturbed) => self.stats.aiding.mag_disturbed += 1,
            Err(MagReject::NoHorizontal) => self.stats.aiding.mag_rejected_bad += 1,
        }
    }
}

/// Count an update's outcome (singular ones are counted by the filter).
fn tally(res: Result<f64, UpdateReject>, used: &mut u64, gated: &mut u64) {
    match res {
        Ok(_) => *used += 1,
        Err(UpdateReject::Gate) => *gated += 1,
        Err(UpdateReject::Singular) => {}
    }
}

/// Disturbance-gate probability when the filter has no χ² gate: a 1-in-10⁴
/// false rejection of an undisturbed sample (k ≈ 3.9 σ), as the profiles' gate.
const MAG_GATE_PROBABILITY: f64 = 0.9999;

// Keep the dimension in sight: the scale state lives in the augmented block.
const _: () = assert!(IA_ODO < NA && NX == 21);
