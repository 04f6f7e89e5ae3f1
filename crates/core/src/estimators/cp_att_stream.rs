//! CP-ATT (seed 003, `SEEDS.md §3`) as a streaming [`Estimator`] ("cp-att").
//!
//! Input: [`Event::CarrierPhase`] records, one per satellite per epoch, in
//! the epoch's satellite order (decreasing elevation, the DD order of
//! [`CpAttitude`]). They are assembled into a [`CpEpoch`] in a fixed buffer;
//! the epoch is processed when a record flagged `last_in_epoch` arrives, or
//! when any later event (any variant, `t` greater than the epoch's) arrives,
//! or on [`CpAttStream::flush`]. Records that cannot belong to the pending
//! epoch (earlier time, a PRN already in it, a baseline count that differs,
//! a full buffer, non-finite values) are rejected and counted
//! ([`CpAttStreamStats`]). Every other event variant is ignored.
//!
//! Output: per processed epoch with an attitude, a [`NavSolution`] whose
//! `rpy` is the ZYX roll/pitch/yaw of the IMU body frame (FRD) with respect
//! to NED and `std_rpy` their 1-σ from the solution's covariance. Position
//! and velocity are NaN: the carrier-phase records carry no position (only
//! lines of sight and single differences).
//!
//! Frames: CP-ATT works in ENU at the master antenna with the paper's body
//! ("antenna") frame a and angles (eq. 1–2: yaw about z, pitch about x,
//! roll about y, `b_a = C_na b_enu`). With `c_ba` the antenna → IMU body
//! (FRD) DCM from configuration and `T` the ENU ↔ NED swap
//! (`[[0,1,0],[1,0,0],[0,0,−1]]`, its own inverse),
//! `c_bn(FRD → NED) = T · C_naᵀ · c_baᵀ`. The default `c_ba` is that same
//! `T`: the paper's frame is x right, y forward, z up. Angles come from
//! `c_bn` by the paper's eq. 2 rewritten for ZYX (roll = atan2(C32, C33),
//! pitch = asin(−C31), yaw = atan2(C21, C11)), so with the default mounting
//! they are the paper's angles exactly: roll = φ, pitch = θ, yaw = −ψ
//! (the matrix products only permute and negate entries).
//! The rotation-error covariance maps to Euler-angle σ through
//! `δθ_n = M δ(φ, θ, ψ)`, `M = [c_z c_y e_x, c_z e_y, e_z]` (Groves 2nd ed.
//! §2.2.2 kinematics), cov = `M⁻¹ T P_enu T M⁻ᵀ`.

use super::cp_attitude::{
    AttEstimate, CpAttConfig, CpAttOutput, CpAttSolution, CpAttitude, CpEpoch, FixConfig,
    MAX_BASELINES,
};
use crate::gnss::dd::MAX_SATS;
#[allow(unused_imports)]
use crate::prelude::*;
use crate::types::{
    CarrierPhaseSat, Estimator, Event, HeadingFix, HeadingSource, NavSolution, MAX_CP_BASELINES,
};
use crate::{Mat3, Vec3};

/// ENU ↔ NED (and the paper's RFU antenna frame ↔ FRD): swap x and y, negate z.
pub const T_ENU_NED: Mat3 = Mat3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0);

/// Configuration of [`CpAttStream`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CpAttStreamConfig {
    /// The float filter (seed 003 defaults: the paper's).
    pub filter: CpAttConfig,
    /// Integer fixing and the attitude filter (`None`: float only).
    pub fix: Option<FixConfig>,
    /// The solution reported.
    pub output: CpAttOutput,
    /// Report the float eq. 4 solution at epochs where `output` has none
    /// (no fix yet).
    pub fallback_float: bool,
    /// Baselines slave − master in the antenna frame [m]; the first
    /// `n_baselines` are used (their order is the records' baseline order).
    pub b_a: [Vec3; MAX_BASELINES],
    pub n_baselines: usize,
    /// Antenna frame → IMU body FRD DCM (`v_b = c_ba v_a`); default
    /// [`T_ENU_NED`] (antenna frame x right, y forward, z up).
    pub c_ba: Mat3,
}

impl CpAttStreamConfig {
    /// The paper's setup: three orthogonal 1 m baselines along the antenna
    /// axes, the float filter with its defaults, fixing with
    /// [`FixConfig::default`], the fixed solution with the float fallback.
    pub fn new(b_a: &[Vec3]) -> Self {
        let mut bb = [Vec3::zeros(); MAX_BASELINES];
        let n = b_a.len().min(MAX_BASELINES);
        bb[..n].copy_from_slice(&b_a[..n]);
        CpAttStreamConfig {
            filter: CpAttConfig::default(),
            fix: Some(FixConfig::default()),
            output: CpAttOutput::Fixed,
            fallback_float: true,
            b_a: bb,
            n_baselines: n,
            c_ba: T_ENU_NED,
        }
    }
}

/// Why a [`CpAttStreamConfig`] is refused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CpAttStreamError {
    /// Fewer than 2 or more than `MAX_BASELINES` baselines.
    Baselines(usize),
    /// This baseline (0-based) is shorter than 1 mm or not finite.
    BadBaseline(usize),
    /// `c_ba` is not orthonormal with determinant +1.
    NotRotation,
}

impl core::fmt::Display for CpAttStreamError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Baselines(n) => write!(
                f,
                "cp-att needs 2 to {MAX_BASELINES} baselines (3 for the float solution), got {n}"
            ),
            Self::BadBaseline(k) => write!(f, "cp-att baseline {} is zero or not finite", k + 1),
            Self::NotRotation => write!(
                f,
                "cp-att antenna-to-body matrix is not a rotation (orthonormal, det +1)"
            ),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for CpAttStreamError {}

/// Counters of a [`CpAttStream`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct CpAttStreamStats {
    /// Records accepted into an epoch.
    pub records: u64,
    /// Epochs processed.
    pub epochs: u64,
    /// Solutions returned.
    pub solutions: u64,
    /// Records rejected: earlier than the pending epoch.
    pub rejected_out_of_order: u64,
    /// Records rejected: PRN already in the pending epoch.
    pub rejected_duplicate: u64,
    /// Records rejected: baseline count differs from the pending epoch's
    /// or exceeds the configuration's, buffer full, or non-finite values.
    pub rejected_invalid: u64,
    /// Events of other variants ignored.
    pub ignored: u64,
}

/// CP-ATT as a streaming estimator ("cp-att"); see the module doc.
#[derive(Clone, Debug)]
pub struct CpAttStream {
    cfg: CpAttStreamConfig,
    att: CpAttitude,
    epoch: CpEpoch,
    pending: bool,
    last: CpAttSolution,
    stats: CpAttStreamStats,
}

impl CpAttStream {
    /// A new estimator; checks the baselines and that `c_ba` is a rotation.
    pub fn new(cfg: CpAttStreamConfig) -> Result<Self, CpAttStreamError> {
        let n = cfg.n_baselines;
        if !(2..=MAX_BASELINES.min(MAX_CP_BASELINES)).contains(&n) {
            return Err(CpAttStreamError::Baselines(n));
        }
        for (k, b) in cfg.b_a[..n].iter().enumerate() {
            if !b.iter().all(|x| x.is_finite()) || b.norm() < 1e-3 {
                return Err(CpAttStreamError::BadBaseline(k));
            }
        }
        let c = cfg.c_ba;
        let orth = (c.transpose() * c - Mat3::identity()).abs().max();
        if !(orth < 1e-6 && (c.determinant() - 1.0).abs() < 1e-6) {
            return Err(CpAttStreamError::NotRotation);
        }
        let mut att = CpAttitude::new(cfg.filter, &cfg.b_a[..n]);
        if let Some(f) = cfg.fix {
            att = att.with_fixing(f);
        }
        Ok(CpAttStream {
            cfg,
            att,
            epoch: CpEpoch::default(),
            pending: false,
            last: CpAttSolution::default(),
            stats: CpAttStreamStats::default(),
        })
    }

    /// The last processed epoch's full solution (every method, the paper's angles).
    pub fn last(&self) -> &CpAttSolution {
        &self.last
    }

    /// The wrapped batch estimator (filters, counters).
    pub fn inner(&self) -> &CpAttitude {
        &self.att
    }

    pub fn stats(&self) -> &CpAttStreamStats {
        &self.stats
    }

    /// Process the pending epoch, if any (end of stream).
    pub fn flush(&mut self) -> Option<NavSolution> {
        if !self.pending {
            return None;
        }
        self.pending = false;
        self.stats.epochs += 1;
        self.last = self.att.update(&self.epoch);
        let est = self.last.estimate(self.cfg.output).or_else(|| {
            if self.cfg.fallback_float {
                self.last.estimate(CpAttOutput::Float)
            } else {
                None
            }
        })?;
        let (rpy, std_rpy) = body_rpy_ned(&est, &self.cfg.c_ba);
        if !rpy.iter().all(|x| x.is_finite()) {
            return None;
        }
        self.stats.solutions += 1;
        let nan = f64::NAN;
        Some(NavSolution {
            t: self.epoch.t,
            lat: nan,
            lon: nan,
            h: nan,
            v_n: Vec3::repeat(nan),
            rpy,
            std_pos_ned: Vec3::repeat(nan),
            std_v_n: Vec3::repeat(nan),
            std_rpy,
        })
    }

    fn accept(&mut self, r: &CarrierPhaseSat) -> Option<NavSolution> {
        let nb = r.n_baselines as usize;
        let finite = r.t.is_finite()
            && r.los_enu.iter().all(|x| x.is_finite())
            && r.sigma_m.is_finite()
            && r.sigma_m > 0.0
            && r.sd_phase_m[..nb.min(MAX_CP_BASELINES)]
                .iter()
                .all(|x| x.is_finite());
        if !finite || nb < self.cfg.n_baselines || nb > MAX_CP_BASELINES {
            self.stats.rejected_invalid += 1;
            return None;
        }
        let mut out = None;
        if self.pending {
            if r.t < self.epoch.t {
                self.stats.rejected_out_of_order += 1;
                return None;
            }
            if r.t > self.epoch.t {
                out = self.flush();
            }
        }
        if !self.pending {
            self.epoch = CpEpoch {
                t: r.t,
                n_baselines: nb,
                ..CpEpoch::default()
            };
            self.pending = true;
        }
        let ep = &mut self.epoch;
        let n = ep.n_sats;
        if ep.prn[..n].contains(&r.prn) {
            self.stats.rejected_duplicate += 1;
        } else if n >= MAX_SATS || nb != ep.n_baselines {
            self.stats.rejected_invalid += 1;
        } else {
            ep.prn[n] = r.prn;
            ep.los_enu[n] = r.los_enu;
            ep.sigma[n] = r.sigma_m;
            for k in 0..nb {
                ep.sd_phase[k][n] = r.sd_phase_m[k];
            }
            ep.n_sats = n + 1;
            self.stats.records += 1;
        }
        if r.last_in_epoch && out.is_none() {
            out = self.flush();
        }
        out
    }
}

impl Estimator for CpAttStream {
    fn name(&self) -> &'static str {
        "cp-att"
    }

    fn push(&mut self, ev: &Event) -> Option<NavSolution> {
        match ev {
            Event::CarrierPhase(r) => self.accept(r),
            other => {
                self.stats.ignored += 1;
                if self.pending && other.t() > self.epoch.t {
                    self.flush()
                } else {
                    None
                }
            }
        }
    }
}

/// The per-satellite records of a whole epoch, in its satellite order, the
/// last one flagged (the inverse of [`CpAttStream`]'s assembly).
pub fn epoch_records(ep: &CpEpoch) -> impl Iterator<Item = CarrierPhaseSat> + '_ {
    let nb = ep.n_baselines.min(MAX_CP_BASELINES);
    (0..ep.n_sats).map(move |i| {
        let mut sd = [0.0; MAX_CP_BASELINES];
        for (k, v) in sd[..nb].iter_mut().enumerate() {
            *v = ep.sd_phase[k][i];
        }
        CarrierPhaseSat {
            t: ep.t,
            prn: ep.prn[i],
            n_baselines: nb as u8,
            last_in_epoch: i + 1 == ep.n_sats,
            los_enu: ep.los_enu[i],
            sigma_m: ep.sigma[i],
            sd_phase_m: sd,
        }
    })
}

/// The paper's (roll φ, pitch θ, yaw ψ) from [`body_rpy_ned`]'s angles
/// under the default mounting (`c_ba` = [`T_ENU_NED`]): `(roll, pitch,
/// −yaw)`, exact (module doc).
pub fn paper_rpy_from_ned_default(rpy: &Vec3) -> Vec3 {
    Vec3::new(rpy.x, rpy.y, -rpy.z)
}

/// ZYX roll/pitch/yaw of the IMU body (FRD) w.r.t. NED [rad] and their 1-σ
/// from a CP-ATT estimate and the antenna → body DCM `c_ba` (module doc).
pub fn body_rpy_ned(est: &AttEstimate, c_ba: &Mat3) -> (Vec3, Vec3) {
    let c = T_ENU_NED * est.c_nb.transpose() * c_ba.transpose();
    let roll = c[(2, 1)].atan2(c[(2, 2)]);
    let pitch = (-c[(2, 0)]).clamp(-1.0, 1.0).asin();
    let yaw = c[(1, 0)].atan2(c[(0, 0)]);
    let rpy = Vec3::new(roll, pitch, yaw);
    let cov_ned = T_ENU_NED * est.cov_n * T_ENU_NED;
    let std = match euler_rate_matrix(&rpy).try_inverse() {
        Some(mi) => (mi * cov_ned * mi.transpose()).diagonal().map(|v| {
            if v >= 0.0 {
                v.sqrt()
            } else {
                f64::NAN
            }
        }),
        None => Vec3::repeat(f64::NAN),
    };
    (rpy, std)
}

/// `M` with `δθ_n = M δ(roll, pitch, yaw)` for ZYX angles (columns: the
/// roll axis `c_z(ψ) c_y(θ) e_x`, the pitch axis `c_z(ψ) e_y`, `e_z`).
fn euler_rate_matrix(rpy: &Vec3) -> Mat3 {
    let (sp, cp) = rpy.y.sin_cos();
    let (sy, cy) = rpy.z.sin_cos();
    Mat3::new(cp * cy, -sy, 0.0, cp * sy, cy, 0.0, -sp, 0.0, 1.0)
}

/// Largest |pitch| of a heading aid [rad] (80°: beyond it a 1 mrad
/// attitude error is ≥ 5.8 mrad of heading, 1/cos 80°).
pub const MAX_HEADING_PITCH_RAD: f64 = 80.0 * core::f64::consts::PI / 180.0;

/// The heading aid of a CP-ATT solution (issue 17): heading and pitch of
/// the IMU body x axis (FRD forward) in NED, i.e. yaw and pitch of `sol`,
/// with their σ; `baseline_m` NaN (the geometry is the configuration's).
/// `None` when the yaw or its σ is not finite, or the pitch is beyond
/// ±[`MAX_HEADING_PITCH_RAD`] (the x axis' heading is ill-defined near the
/// vertical; an unconverged float solution lands there).
pub fn heading_fix(sol: &NavSolution) -> Option<HeadingFix> {
    let ok = sol.rpy.z.is_finite()
        && sol.std_rpy.z.is_finite()
        && sol.std_rpy.z > 0.0
        && sol.rpy.y.abs() <= MAX_HEADING_PITCH_RAD;
    ok.then(|| HeadingFix {
        t: sol.t,
        heading_rad: sol.rpy.z,
        pitch_rad: sol.rpy.y,
        std_heading_rad: sol.std_rpy.z,
        std_pitch_rad: if sol.std_rpy.y.is_finite() {
            sol.std_rpy.y
        } else {
            f64::NAN
        },
        baseline_m: f64::NAN,
        source: HeadingSource::CpAtt,
    })
}

#[cfg(test)]
#[path = "cp_att_stream_tests.rs"]
mod tests;
