//! IMU–GNSS time offset τ from GNSS velocities against an INS velocity
//! trajectory (feature `alloc`); unlike [`super::time_offset`] it does not
//! assume that the course follows the heading, so it serves any platform
//! (multirotors fly sideways, pedestrians carry the device at any yaw).
//!
//! Convention: **true time = IMU stamp + τ**: the INS state computed from the
//! IMU sample stamped `s` describes the motion at GNSS time `s + τ`.
//!
//! Input: the INS nav-frame acceleration `a_n` (NED, gravity and Coriolis
//! included, i.e. `v̇_n`) at every IMU sample — in practice the velocity
//! increments of a first filter pass between its GNSS updates, so attitude,
//! biases and the lever arm come from the filter — and the GNSS velocities.
//! Within a segment `S` of contiguous fixes, per NED axis,
//!
//! ```text
//! v_gnss(t_k) = c_S + V(t_k − τ) + b_S·(t_k − t_S) + C_bn(t_k − τ)·[ω(t_k − τ)]×·l + e_k
//! ```
//!
//! with `V(t) = ∫ a_n dt` (IMU time), `c_S`, `b_S` per-segment constants and
//! drifts (the filter's velocity and tilt/bias errors, slowly varying over a
//! segment ≤ 30 s), and `l` [m, body FRD] a lever arm whose velocity
//! `C_bn(ω × l)` the receiver may or may not include (fitted, global: a
//! receiver reports the antenna's velocity, a simulator may not; either way
//! `ω × l` correlates with the centripetal acceleration and would otherwise
//! read as a time shift of `l/v`). `e_k` has the receiver's velocity σ.
//! Everything but τ enters linearly, so τ is found by a grid search of the
//! profile χ²(τ) (variable projection, Golub & Pereyra 1973) and refined by
//! Newton steps on it. The τ information is `∂v/∂τ = −a_n(t_k − τ)` after
//! projecting out the nuisances: it comes from changes of acceleration
//! (braking, turn entry/exit, climbs), which every platform has.
//!
//! σ_τ is the larger of the classical `s²/I` (`s²` the reduced χ², `I` the
//! projected information) and a Newey–West sandwich over lags ≤ 5 epochs
//! within a segment (filter errors and time-correlated GNSS errors make the
//! residuals autocorrelated: the effective sample size is smaller than the
//! number of epochs). Gross errors: epochs with a residual beyond 5 robust σ
//! (1.4826·MAD) are dropped and the fit repeated (≤ 4 rounds).
//!
//! Linearisation: the INS trajectory comes from a pass run with some
//! offset; the estimate is the *residual* offset of that pass. A pass run
//! far from the truth has a distorted trajectory (the filter bent its
//! attitude and biases to absorb the timing error), so the caller iterates:
//! re-run with the IMU shifted by the estimate until the residual is
//! negligible (see navfuse-pipeline's `offset_passes`).

use alloc::vec::Vec;
use nalgebra::Matrix3;

#[allow(unused_imports)]
use crate::prelude::*;
use crate::{GnssFix, Vec3};

use super::time_offset::TimeOffsetReason;

/// One IMU-rate sample of the INS trajectory (IMU time).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InsSample {
    /// IMU stamp at the end of the interval [s] (after any offset applied).
    pub t: f64,
    /// Nav-frame acceleration `v̇_n` over the interval ending at `t` [m/s², NED].
    pub a_n: Vec3,
    /// `C_bn·[ω_ib]×` at `t`: the lever-arm velocity is this times `l_b`
    /// [1/s] (body FRD → NED).
    pub lever_map: Matrix3<f64>,
}

/// Settings of [`estimate_from_velocity`]; [`Default`] gives the documented defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VelOffsetConfig {
    /// Scan range ±[s]. 0.5 s: logger/receiver latencies are tens to a few
    /// hundred ms; more means a wrong clock, not a latency.
    pub max_lag_s: f64,
    /// Coarse grid step [s]; refinement is continuous.
    pub grid_step_s: f64,
    /// Significance factor k: 3.29 = 0.1 % two-sided false-alarm rate.
    pub k_sigma: f64,
    /// Largest σ_τ worth applying [s] (20 ms, as [`super::time_offset::TimeOffsetConfig::max_std_s`]).
    pub max_std_s: f64,
    /// Minimum spacing of used fixes [s]. 0.9 s: GNSS errors are correlated
    /// over ~1 s, faster fixes add little independent information.
    pub min_spacing_s: f64,
    /// A gap longer than this starts a new segment [s].
    pub max_gap_s: f64,
    /// Longest segment [s]. 30 s: a filter's tilt error (≲ 1 mrad → 1 cm/s²)
    /// and bias error are constant over it, so the per-segment drift `b_S`
    /// absorbs them; longer segments would leave a curvature in the residuals.
    pub max_segment_s: f64,
    /// Residual rejection threshold in robust σ. 5: < 1e-6 false rejections
    /// for Gaussian noise.
    pub outlier_k: f64,
    /// Minimum number of used epochs. 30: the residual variance is then known
    /// to ±13 %, so the k-σ test keeps its stated false-alarm rate.
    pub min_pairs: usize,
    /// Fit the lever arm `l` (see module doc).
    pub fit_lever: bool,
    /// Prior σ of each lever component [m] (zero mean), a Gaussian
    /// regularisation of the fit. 1 m: an antenna sits within ~2 m (2σ) of
    /// the IMU on a car roof, a robot, a person or a multirotor. Without it
    /// the lever is free where the motion barely excites it — on a car the
    /// along-track component gives a lateral velocity `ω·l_x`, the same as
    /// the time shift `τ·ω·v` at constant speed, and the vertical one is
    /// seen only through roll/pitch rates — and on short records it fitted
    /// levers of 3–60 m that carried τ to ±0.5 s (`experiment align`, car
    /// starts at τ = 0). With the prior, τ and σ_τ include that
    /// confounding as far as the physics allows, not further.
    pub lever_prior_m: f64,
}

impl Default for VelOffsetConfig {
    fn default() -> Self {
        VelOffsetConfig {
            max_lag_s: 0.5,
            grid_step_s: 0.005,
            k_sigma: 3.29,
            max_std_s: 0.02,
            min_spacing_s: 0.9,
            max_gap_s: 5.0,
            max_segment_s: 30.0,
            outlier_k: 5.0,
            min_pairs: 30,
            fit_lever: true,
            lever_prior_m: 1.0,
        }
    }
}

/// Result of [`estimate_from_velocity`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VelOffsetEstimate {
    /// Residual τ [s] of the INS trajectory given (true time = stamp + τ);
    /// `None` without a fit.
    pub tau_s: Option<f64>,
    /// 1-σ of τ [s]: the larger of the residual σ (`std_fit_s`) and the
    /// split-half σ (see `split_half_std`); infinite without a fit or when
    /// the record is too short to be split.
    pub std_s: f64,
    /// The residual σ alone (classical / Newey–West) [s]: the step size of
    /// an iteration, not a test (a pass far from the truth is itself a
    /// misfit the halves disagree on).
    pub std_fit_s: f64,
    /// GNSS epochs in the final fit.
    pub pairs_used: usize,
    /// Epochs dropped as gross errors.
    pub outliers: usize,
    /// Fitted lever arm [m, body FRD] (zero when not fitted).
    pub lever_b: Vec3,
    /// Why it is (not) significant.
    pub reason: TimeOffsetReason,
}

impl VelOffsetEstimate {
    /// |τ| > k·σ, σ ≤ bound, not at the scan edge.
    pub fn significant(&self) -> bool {
        self.reason == TimeOffsetReason::Significant
    }

    /// [`Self::significant`] against the residual σ alone (`std_fit_s`):
    /// whether an iteration should move, not whether to apply.
    pub fn significant_fit(&self, cfg: &VelOffsetConfig) -> bool {
        self.tau_s.is_some_and(|tau| {
            TimeOffsetReason::classify(
                tau,
                self.std_fit_s,
                cfg.max_lag_s,
                cfg.grid_step_s,
                cfg.max_std_s,
                cfg.k_sigma,
            ) == TimeOffsetReason::Significant
        })
    }
}

/// Velocity noise floor for a missing/zero σ [m/s]: Doppler velocity ~1 cm/s.
/// The overall scale is re-estimated from the residuals anyway.
const FLOOR_VEL_MPS: f64 = 0.01;

/// One GNSS velocity epoch.
#[derive(Clone, Copy, Debug)]
struct Obs {
    t: f64,
    v: Vec3,
    /// 1/σ per axis.
    w: Vec3,
    seg: usize,
}

/// The INS trajectory with O(log n) interpolation of `V(t)` and the lever map.
struct Track<'a> {
    ins: &'a [InsSample],
    /// `V` at each sample's stamp (cumulative `a_n·dt`).
    cum: Vec<Vec3>,
}

impl<'a> Track<'a> {
    fn new(ins: &'a [InsSample]) -> Self {
        let mut cum = Vec::with_capacity(ins.len());
        let mut acc = Vec3::zeros();
        for (i, s) in ins.iter().enumerate() {
            if i > 0 {
                acc += s.a_n * (s.t - ins[i - 1].t);
            }
            cum.push(acc);
        }
        Track { ins, cum }
    }
    /// `V(t)` and the lever map at `t` (linear between samples); `None`
    /// outside the track or across a gap longer than 0.1 s.
    fn at(&self, t: f64) -> Option<(Vec3, Matrix3<f64>)> {
        let k = self.ins.partition_point(|s| s.t < t);
        let (a, b) = (self.ins.get(k.checked_sub(1)?)?, self.ins.get(k)?);
        let dt = b.t - a.t;
        if !(dt > 0.0 && dt <= 0.1) {
            return None;
        }
        let w = (t - a.t) / dt;
        Some((
            self.cum[k - 1] * (1.0 - w) + self.cum[k] * w,
            a.lever_map * (1.0 - w) + b.lever_map * w,
        ))
    }
}

/// Profile χ² at τ with the normalised residuals (3 per epoch) and the lever.
struct Profile {
    chi2: f64,
    res: Vec<[f64; 3]>,
    lever: Vec3,
}

/// Weighted projection of `x` (one axis of one segment) off `[1, t − t_S]`.
fn project(ts: &[f64], w2: &[f64], x: &mut [f64]) {
    let (mut s0, mut s1, mut s2, mut y0, mut y1) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for ((t, w), v) in ts.iter().zip(w2).zip(x.iter()) {
        s0 += w;
        s1 += w * t;
        s2 += w * t * t;
        y0 += w * v;
        y1 += w * t * v;
    }
    let det = s0 * s2 - s1 * s1;
    let (c, b) = if det.abs() > 1e-12 * s0 * s2.max(1e-300) {
        ((s2 * y0 - s1 * y1) / det, (s0 * y1 - s1 * y0) / det)
    } else {
        (y0 / s0, 0.0)
    };
    for (t, v) in ts.iter().zip(x.iter_mut()) {
        *v -= c + b * t;
    }
}

fn profile(obs: &[Obs], track: &Track, tau: f64, cfg: &VelOffsetConfig) -> Option<Profile> {
    let fit_lever = cfg.fit_lever;
    let n = obs.len();
    // Residual r and lever regressors G (3 columns) per epoch and axis.
    let mut r = Vec::with_capacity(n);
    let mut g = Vec::with_capacity(n);
    for o in obs {
        let (v, m) = track.at(o.t - tau)?;
        r.push(o.v - v);
        g.push(m);
    }
    let mut ts = Vec::new();
    let mut w2 = Vec::new();
    let mut col = Vec::new();
    let mut i = 0;
    while i < n {
        let j = i + obs[i..].iter().take_while(|o| o.seg == obs[i].seg).count();
        for ax in 0..3 {
            ts.clear();
            w2.clear();
            ts.extend(obs[i..j].iter().map(|o| o.t - obs[i].t));
            w2.extend(obs[i..j].iter().map(|o| o.w[ax] * o.w[ax]));
            col.clear();
            col.extend(r[i..j].iter().map(|x| x[ax]));
            project(&ts, &w2, &mut col);
            for (x, c) in r[i..j].iter_mut().zip(&col) {
                x[ax] = *c;
            }
            for k in 0..3 {
                col.clear();
                col.extend(g[i..j].iter().map(|m| m[(ax, k)]));
                project(&ts, &w2, &mut col);
                for (m, c) in g[i..j].iter_mut().zip(&col) {
                    m[(ax, k)] = *c;
                }
            }
        }
        i = j;
    }
    let mut lever = Vec3::zeros();
    if fit_lever {
        let (mut nm, mut rhs) = (Matrix3::zeros(), Vec3::zeros());
        for ((o, x), m) in obs.iter().zip(&r).zip(&g) {
            let wm = Matrix3::from_diagonal(&o.w.component_mul(&o.w));
            nm += m.transpose() * wm * m;
            rhs += m.transpose() * wm * x;
        }
        // The prior (see `lever_prior_m`); a lever the motion does not
        // excite stays at its prior mean, zero.
        let scale = nm.trace().max(1e-300);
        nm += Matrix3::identity() * (1e-9 * scale + lever_info(cfg));
        lever = nm.cholesky()?.solve(&rhs);
    }
    let mut chi2 = lever.norm_squared() * lever_info(cfg);
    let res = obs
        .iter()
        .zip(&r)
        .zip(&g)
        .map(|((o, x), m)| {
            let e = (x - m * lever).component_mul(&o.w);
            chi2 += e.norm_squared();
            [e.x, e.y, e.z]
        })
        .collect();
    Some(Profile { chi2, res, lever })
}

/// Information of the lever prior per component [1/m²] (0 without one).
fn lever_info(cfg: &VelOffsetConfig) -> f64 {
    if cfg.lever_prior_m.is_finite() && cfg.lever_prior_m > 0.0 {
        1.0 / (cfg.lever_prior_m * cfg.lever_prior_m)
    } else {
        0.0
    }
}

/// Assigns segments (gap / length limits) and drops segments of < 4 epochs
/// (their constant and drift leave ≤ 1 dof per axis).
fn segment(obs: &mut Vec<Obs>, cfg: &VelOffsetConfig) {
    super::time_offset::assign_segments(
        obs.iter_mut().map(|o| (o.t, &mut o.seg)),
        cfg.max_gap_s,
        cfg.max_segment_s,
    );
    let mut keep = Vec::with_capacity(obs.len());
    let mut i = 0;
    while i < obs.len() {
        let j = i + obs[i..].iter().take_while(|o| o.seg == obs[i].seg).count();
        if j - i >= 4 {
            keep.extend_from_slice(&obs[i..j]);
        }
        i = j;
    }
    *obs = keep;
}

/// Newey–West lags [epochs]: ~5 s of filter/GNSS error correlation.
const HAC_LAGS: usize = 5;

/// Grid scan, then Newton refinement on the profile χ²; τ and the profile.
fn fit(obs: &[Obs], track: &Track, cfg: &VelOffsetConfig) -> Option<(f64, Profile)> {
    let steps = (cfg.max_lag_s / cfg.grid_step_s).round() as i64;
    let mut best: Option<(f64, f64)> = None;
    for i in -steps..=steps {
        let tau = i as f64 * cfg.grid_step_s;
        let c = profile(obs, track, tau, cfg)?.chi2;
        if best.is_none_or(|(_, b)| c < b) {
            best = Some((tau, c));
        }
    }
    let (mut tau, _) = best?;
    let h = 0.2 * cfg.grid_step_s;
    for _ in 0..10 {
        let c0 = profile(obs, track, tau, cfg)?.chi2;
        let cm = profile(obs, track, tau - h, cfg)?.chi2;
        let cp = profile(obs, track, tau + h, cfg)?.chi2;
        let curv = cp - 2.0 * c0 + cm;
        if curv <= 0.0 {
            break;
        }
        let d = (-h * (cp - cm) / (2.0 * curv)).clamp(-cfg.grid_step_s, cfg.grid_step_s);
        tau = (tau + d).clamp(-cfg.max_lag_s, cfg.max_lag_s);
        if d.abs() < 1e-6 {
            break;
        }
    }
    Some((tau, profile(obs, track, tau, cfg)?))
}

/// σ_τ: max of the classical `s²/I` and a Newey–West sandwich, with the
/// projected Jacobian taken numerically from the profile residuals.
fn std_tau(obs: &[Obs], track: &Track, tau: f64, p: &Profile, cfg: &VelOffsetConfig) -> f64 {
    let h = 1e-3;
    let (Some(pp), Some(pm)) = (
        profile(obs, track, tau + h, cfg),
        profile(obs, track, tau - h, cfg),
    ) else {
        return f64::INFINITY;
    };
    let nseg = {
        let mut n = 0usize;
        let mut last = usize::MAX;
        for o in obs {
            if o.seg != last {
                n += 1;
                last = o.seg;
            }
        }
        n as f64
    };
    let lever_p = if cfg.fit_lever { 3.0 } else { 0.0 };
    let dof = 3.0 * obs.len() as f64 - 6.0 * nseg - lever_p - 1.0;
    if dof < 1.0 {
        return f64::INFINITY;
    }
    let mut info = 0.0;
    let mut u = Vec::with_capacity(obs.len());
    for k in 0..obs.len() {
        let mut uk = 0.0;
        for ax in 0..3 {
            let j = (pp.res[k][ax] - pm.res[k][ax]) / (2.0 * h);
            info += j * j;
            uk += j * p.res[k][ax];
        }
        u.push(uk);
    }
    // The prior's pseudo-residuals `l/σ_l` move with τ too.
    if cfg.fit_lever {
        info += ((pp.lever - pm.lever) / (2.0 * h)).norm_squared() * lever_info(cfg);
    }
    if info <= 0.0 {
        return f64::INFINITY;
    }
    let s2 = p.chi2 / dof;
    let classical = s2 / info;
    let mut m = 0.0;
    for k in 0..u.len() {
        m += u[k] * u[k];
        for lag in 1..=HAC_LAGS {
            if k + lag < u.len() && obs[k + lag].seg == obs[k].seg {
                m += 2.0 * (1.0 - lag as f64 / (HAC_LAGS as f64 + 1.0)) * u[k] * u[k + lag];
            }
        }
    }
    let sandwich = m / (info * info) * (3.0 * obs.len() as f64) / dof;
    classical.max(sandwich).sqrt()
}

/// The model check of σ_τ: τ fitted on each half of the epochs (by time)
/// separately; returns `|τ₁ − τ₂| / 2`, infinite when a half has fewer than
/// `min_pairs` epochs. If the model holds, each half carries half the
/// information, so `E[(τ₁ − τ₂)²] ≈ 4 σ²` and `|τ₁ − τ₂|/2` is a (1-dof)
/// estimate of σ itself; a misfit that changes along the record — a filter
/// still converging from an in-motion start, an attitude or lever error the
/// motion excites differently — makes it larger, which the residual-based
/// σ cannot see. The caller takes the larger of the two. A record too short
/// to be split cannot be checked, so no offset is applied from it (at 1 Hz:
/// under a minute of usable epochs).
fn split_half_std(obs: &[Obs], track: &Track, cfg: &VelOffsetConfig) -> f64 {
    let mid = obs.len() / 2;
    let mut taus = [0.0; 2];
    for (k, half) in [&obs[..mid], &obs[mid..]].into_iter().enumerate() {
        let mut h = half.to_vec();
        segment(&mut h, cfg);
        if h.len() < cfg.min_pairs {
            return f64::INFINITY;
        }
        match fit(&h, track, cfg) {
            Some((t, _)) => taus[k] = t,
            None => return f64::INFINITY,
        }
    }
    0.5 * (taus[0] - taus[1]).abs()
}

/// Robust screen on the largest normalised residual of each epoch; returns
/// the number dropped.
fn screen(obs: &mut Vec<Obs>, p: &Profile, k: f64) -> usize {
    let z: Vec<f64> = p.res.iter().flat_map(|r| r.iter().copied()).collect();
    let (med, lim) = super::time_offset::robust_band(z, k);
    let before = obs.len();
    let mut idx = 0;
    obs.retain(|_| {
        let keep = p.res[idx].iter().all(|e| (e - med).abs() <= lim);
        idx += 1;
        keep
    });
    before - obs.len()
}

/// Estimates the residual IMU–GNSS time offset τ of an INS trajectory
/// (`ins`, IMU time, NED; true time = stamp + τ) from the GNSS velocities
/// (`gnss`, NED, GPS time; fixes without velocity are skipped), with its
/// 1-σ and a significance decision; see the module doc for the model.
/// Both inputs sorted by time. Allocates O(n); call once per pass.
pub fn estimate_from_velocity(
    ins: &[InsSample],
    gnss: &[GnssFix],
    cfg: &VelOffsetConfig,
) -> VelOffsetEstimate {
    let none = |pairs_used, outliers| VelOffsetEstimate {
        tau_s: None,
        std_s: f64::INFINITY,
        std_fit_s: f64::INFINITY,
        pairs_used,
        outliers,
        lever_b: Vec3::zeros(),
        reason: TimeOffsetReason::TooFewPairs,
    };
    let track = Track::new(ins);
    // Epochs whose INS window covers every τ of the scan.
    let margin = cfg.max_lag_s + 1e-3;
    let mut obs: Vec<Obs> = Vec::with_capacity(gnss.len());
    for g in gnss {
        let Some(v) = g.v_n.filter(|v| v.iter().all(|x| x.is_finite())) else {
            continue;
        };
        if obs.last().is_some_and(|l| g.t - l.t < cfg.min_spacing_s) {
            continue;
        }
        if track.at(g.t - margin).is_none() || track.at(g.t + margin).is_none() {
            continue;
        }
        let s = g.std_v_n.unwrap_or_default();
        let f = |x: f64| {
            1.0 / if x.is_finite() && x > FLOOR_VEL_MPS {
                x
            } else {
                FLOOR_VEL_MPS
            }
        };
        obs.push(Obs {
            t: g.t,
            v,
            w: Vec3::new(f(s.x), f(s.y), f(s.z)),
            seg: 0,
        });
    }
    segment(&mut obs, cfg);
    let mut outliers = 0;
    const ROUNDS: usize = 4;
    let mut result = None;
    for round in 0..=ROUNDS {
        if obs.len() < cfg.min_pairs {
            return none(obs.len(), outliers);
        }
        let Some((tau, p)) = fit(&obs, &track, cfg) else {
            return none(obs.len(), outliers);
        };
        let dropped = if round == ROUNDS {
            0
        } else {
            screen(&mut obs, &p, cfg.outlier_k)
        };
        if dropped == 0 {
            let std = std_tau(&obs, &track, tau, &p, cfg);
            result = Some((tau, std, p.lever));
            break;
        }
        outliers += dropped;
        segment(&mut obs, cfg);
    }
    let Some((tau, std, lever_b)) = result else {
        return none(obs.len(), outliers);
    };
    let std_fit_s = std;
    let std = std.max(split_half_std(&obs, &track, cfg));
    let reason = TimeOffsetReason::classify(
        tau,
        std,
        cfg.max_lag_s,
        cfg.grid_step_s,
        cfg.max_std_s,
        cfg.k_sigma,
    );
    VelOffsetEstimate {
        tau_s: Some(tau),
        std_s: std,
        std_fit_s,
        pairs_used: obs.len(),
        outliers,
        lever_b,
        reason,
    }
}

#[cfg(test)]
#[path = "time_offset_vel_tests.rs"]
mod tests;
