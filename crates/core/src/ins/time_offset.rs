//! IMU–GNSS time offset τ with an uncertainty, from course changes (feature `alloc`).
//!
//! Convention: **true time = IMU stamp + τ**, so the IMU sample stamped `s`
//! measured the motion at GNSS time `s + τ`.
//!
//! Observable (the only one used): the GNSS course `ψ_k = atan2(v_E, v_N)` at
//! epoch `t_k` against the integrated IMU z-gyro (body FRD; z ≈ down for a
//! near-level vehicle, both positive turning right). Within a segment `S` of
//! contiguous epochs the measurement model is
//!
//! ```text
//! ψ_k = c_S + (1 + s)·Θ(t_k − τ) − b·(t_k − t₀) + l·ω(t_k − τ) / v_k + e_k
//! ```
//!
//! with `Θ(t) = ∫ω_z dt` the IMU heading integral, so a course change between
//! two epochs is `Δψ(ta, tb) = ∫_{ta−τ}^{tb−τ} ω_z dt` (+ nuisances);
//! `c_S` a per-segment constant (heading/course misalignment, eliminated
//! analytically, i.e. variable projection), `b` a constant gyro bias
//! (includes the Earth rate `Ω·sin φ`), `s` a gyro scale error (includes a
//! mounting tilt, `cos` of it), and `l` the along-track distance of the GNSS
//! antenna ahead of the vehicle's zero-sideslip point (rear axle): the antenna
//! velocity there is `v + ω × r`, its course leads the heading by
//! `atan(l·ω/v) ≈ l·ω/v`, which looks like a time shift of `l/v` and must be
//! fitted, not mistaken for τ (separable because `v` varies).
//! `e_k` has σ_ψ = σ_cross-track / speed. The speed-along-track observable
//! (Δv vs ∫f_x) is deliberately not used: road grade puts an unknown
//! `g·sin θ` into it.
//!
//! Course source: GNSS velocity (`GnssFix::v_n`, `std_v_n`) when most fixes
//! carry it, else chords between consecutive fixes (course of the chord at
//! its time midpoint, exact for a constant turn rate; σ from `std_ned` of
//! both ends, so neighbouring chords share noise — handled in σ_τ below).
//! Fixes are thinned to ≥ [`TimeOffsetConfig::min_spacing_s`].
//!
//! Fit: grid over τ ∈ ±`max_lag_s` of the profile χ²(τ) (the model is
//! linear in everything but τ), then Gauss–Newton on all parameters, weights
//! 1/σ_ψ². σ_τ is the larger of the classical `s²·(JᵀWJ)⁻¹` (s² the reduced
//! χ²) and a Newey–West sandwich over lags ≤ 5 within a segment (correlated
//! chord noise, time-correlated GNSS errors, gyro random walk); ∂ψ/∂τ = −(1+s)·ω(t_k − τ), the
//! IMU rate at the epoch (after removing its segment mean: a steady turn
//! carries no timing information).
//!
//! Gross errors: (1) a course sample whose velocity differs from *both*
//! neighbours by more than 1 g × Δt is dropped (no car does that; a GNSS
//! position jump or velocity glitch does); (2) after each fit, epochs with a
//! normalised residual beyond 5 robust σ (1.4826·MAD) are dropped and the
//! fit repeated (≤ 4 rounds).
//!
//! Decision: `significant` ⇔ |τ| > k·σ_τ (k = 3.29: 0.1 % two-sided false
//! alarm under N(0, σ_τ²)) and σ_τ ≤ `max_std_s` and τ not at the scan edge;
//! `apply = significant`.

use alloc::vec::Vec;
use nalgebra::{SMatrix, SVector};

#[allow(unused_imports)]
use crate::prelude::*;
use crate::{earth, GnssFix, ImuSample};

/// Parameters fitted besides the per-segment constants: τ, b, s, l.
const NP: usize = 4;
type Mat = SMatrix<f64, NP, NP>;
type Vecp = SVector<f64, NP>;

/// Settings of [`estimate`]; [`Default`] gives the physics-based defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeOffsetConfig {
    /// Scan range ±[s]. 0.5 s: logger/receiver latencies are tens to a few
    /// hundred ms; a larger offset means a wrong clock, not a latency.
    pub max_lag_s: f64,
    /// Grid step of the coarse scan [s]; refinement is continuous.
    pub grid_step_s: f64,
    /// Significance factor k: 3.29 = 0.1 % two-sided false-alarm rate.
    pub k_sigma: f64,
    /// Largest σ_τ worth applying [s]. 20 ms: at a 0.5 rad/s turn the heading
    /// error left by ±20 ms is 0.01 rad, the course noise of a 0.1 m/s
    /// velocity at 10 m/s — a less certain offset cannot improve the fusion.
    pub max_std_s: f64,
    /// Largest course σ that carries information [rad]. 0.1: the linear
    /// σ_ψ = σ_v/v holds (atan's second-order term σ²/2 = 0.005 rad ≪ σ);
    /// this replaces a fixed minimum speed (0.1 m/s velocity σ → 1 m/s).
    pub max_course_std_rad: f64,
    /// Minimum spacing of used fixes [s]. 0.9 s: GNSS errors are correlated
    /// over ~1 s, faster samples add little independent information.
    pub min_spacing_s: f64,
    /// A gap longer than this starts a new segment [s] (course/heading
    /// misalignment may change across a stop or a reverse).
    pub max_gap_s: f64,
    /// Longest segment [s]. 30 s: a consumer gyro's angle random walk
    /// (≤ 1 °/√h = 3·10⁻⁴ rad/√s) adds ≤ 1.6 mrad over it, below the course
    /// noise of RTK chords (~3 mrad), and its bias instability (~10 °/h) is
    /// constant over it; longer segments would make the residuals a random
    /// walk the σ_τ below does not model.
    pub max_segment_s: f64,
    /// Implied acceleration above which a course sample is a gross error
    /// [m/s²]: 1 g, beyond any road vehicle's braking or cornering.
    pub max_accel_mps2: f64,
    /// Residual rejection threshold in robust σ (1.4826·MAD). 5: below 1e-6
    /// false rejection for Gaussian noise.
    pub outlier_k: f64,
    /// Minimum number of used epochs. 30: the residual variance is then known
    /// to ±13 %, so the k-σ test keeps its stated false-alarm rate.
    pub min_pairs: usize,
    /// Fit the antenna lever `l` (see module doc). Leave on unless the
    /// antenna is known to sit at the rear axle.
    pub fit_lever: bool,
    /// Fit the gyro scale error `s`.
    pub fit_scale: bool,
}

impl Default for TimeOffsetConfig {
    fn default() -> Self {
        TimeOffsetConfig {
            max_lag_s: 0.5,
            grid_step_s: 0.01,
            k_sigma: 3.29,
            max_std_s: 0.02,
            max_course_std_rad: 0.1,
            min_spacing_s: 0.9,
            max_gap_s: 5.0,
            max_segment_s: 30.0,
            max_accel_mps2: 9.806_65,
            outlier_k: 5.0,
            min_pairs: 30,
            fit_lever: true,
            fit_scale: true,
        }
    }
}

/// Why [`TimeOffsetEstimate::apply`] is what it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeOffsetReason {
    /// |τ| > k·σ_τ with σ_τ small enough: apply it.
    Significant,
    /// |τ| ≤ k·σ_τ: consistent with zero.
    NotSignificant,
    /// σ_τ above `max_std_s` (straight road, noisy GNSS, few turns).
    TooUncertain,
    /// Best τ at the edge of the scan range: the real offset may lie outside.
    AtScanEdge,
    /// Fewer than `min_pairs` usable epochs (slow, stationary, no overlap).
    TooFewPairs,
}

impl TimeOffsetReason {
    /// The decision for an estimate `tau` ± `std` [s] from a scan over
    /// ±`max_lag_s` in `grid_step_s` steps: at the scan's edge, too
    /// uncertain (σ above `max_std_s` or NaN), significant (|τ| >
    /// `k_sigma`·σ) or not. Shared by every offset estimator.
    pub fn classify(
        tau: f64,
        std: f64,
        max_lag_s: f64,
        grid_step_s: f64,
        max_std_s: f64,
        k_sigma: f64,
    ) -> Self {
        if max_lag_s - tau.abs() < grid_step_s {
            TimeOffsetReason::AtScanEdge
        } else if std.is_nan() || std > max_std_s {
            TimeOffsetReason::TooUncertain
        } else if tau.abs() > k_sigma * std {
            TimeOffsetReason::Significant
        } else {
            TimeOffsetReason::NotSignificant
        }
    }
}

impl TimeOffsetReason {
    /// One-line explanation for logs.
    pub fn describe(self) -> &'static str {
        match self {
            TimeOffsetReason::Significant => "significant: |tau| > k sigma",
            TimeOffsetReason::NotSignificant => "not significant: consistent with zero",
            TimeOffsetReason::TooUncertain => "too uncertain: sigma above the bound",
            TimeOffsetReason::AtScanEdge => "at the edge of the scan range",
            TimeOffsetReason::TooFewPairs => "too few usable GNSS course epochs",
        }
    }
}

/// Result of [`estimate`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeOffsetEstimate {
    /// τ [s] (true time = IMU stamp + τ); `None` without a fit.
    pub tau_s: Option<f64>,
    /// 1-σ of τ [s]; infinite without a fit or when τ is unobservable.
    pub std_s: f64,
    /// GNSS course epochs in the final fit.
    pub pairs_used: usize,
    /// Epochs dropped as gross errors (1 g test + residual test).
    pub outliers: usize,
    /// Fitted antenna lever ahead of the zero-sideslip point [m] (0 if not fitted).
    pub lever_m: f64,
    /// |τ| > k·σ_τ, σ_τ ≤ bound, not at the scan edge.
    pub significant: bool,
    /// Whether to apply τ (= `significant`).
    pub apply: bool,
    /// Why.
    pub reason: TimeOffsetReason,
}

/// One GNSS course epoch.
#[derive(Clone, Copy, Debug)]
struct Obs {
    t: f64,
    /// Course, later unwrapped onto the IMU heading integral [rad].
    psi: f64,
    sigma: f64,
    speed: f64,
    vn: f64,
    ve: f64,
    seg: usize,
}

/// IMU heading integral Θ(t) (z-gyro, IMU time) with O(log n) lookup.
struct Heading<'a> {
    imu: &'a [ImuSample],
    cum: Vec<f64>,
    /// The stamps are non-decreasing (no NaN): the sample search may start
    /// from the last one found ([`Heading::find`]).
    sorted: bool,
    hint: core::cell::Cell<usize>,
}

/// Half-width of the central difference for ω [s]: 0.05 s averages ≥ 10
/// samples of white gyro noise at 100 Hz yet is short against vehicle yaw
/// dynamics (≳ 0.5 s).
const RATE_HALF_S: f64 = 0.05;

impl<'a> Heading<'a> {
    fn new(imu: &'a [ImuSample]) -> Self {
        let mut cum = Vec::with_capacity(imu.len() + 1);
        let mut acc = 0.0;
        cum.push(acc);
        for s in imu {
            acc += s.dtheta_b.z;
            cum.push(acc);
        }
        let sorted = imu.windows(2).all(|w| w[0].t <= w[1].t) && imu.iter().all(|s| !s.t.is_nan());
        Heading {
            imu,
            cum,
            sorted,
            hint: core::cell::Cell::new(0),
        }
    }
    /// The first sample with `t_k ≥ t` (`imu.partition_point(|s| s.t < t)`):
    /// on sorted stamps by galloping from the last sample found (the fits
    /// ask for nearby, mostly increasing times: O(log distance) instead of
    /// a full binary search over the record, whose cache misses dominated
    /// `navfuse run`'s profile), the same index by construction; unsorted
    /// stamps take the plain search.
    fn find(&self, t: f64) -> usize {
        let imu = self.imu;
        let n = imu.len();
        if !self.sorted {
            return imu.partition_point(|s| s.t < t);
        }
        let below = |s: &ImuSample| s.t < t;
        // Start where a uniform rate from the last sample found puts t
        // (exact or next to it for a steady IMU); any start gives the
        // same index.
        let mut h = self.hint.get().min(n);
        if let Some(s) = imu.get(h) {
            let g = h as f64 + ((t - s.t) / s.dt).ceil();
            if g.is_finite() && s.dt > 0.0 {
                h = g.clamp(0.0, n as f64) as usize;
            }
        }
        let k = if h < n && below(&imu[h]) {
            // Answer in (h, n]: widen [lo, lo + step] until it holds it.
            let mut lo = h + 1;
            let mut step = 1;
            loop {
                let hi = lo + step;
                if hi >= n {
                    break lo + imu[lo..].partition_point(below);
                }
                if !below(&imu[hi]) {
                    break lo + imu[lo..=hi].partition_point(below);
                }
                lo = hi + 1;
                step *= 2;
            }
        } else {
            // Answer in [0, h].
            let mut hi = h;
            let mut step = 1;
            loop {
                if hi == 0 {
                    break 0;
                }
                let lo = hi.saturating_sub(step);
                if below(&imu[lo]) {
                    break lo + 1 + imu[lo + 1..hi].partition_point(below);
                }
                if lo == 0 {
                    break 0;
                }
                hi = lo;
                step *= 2;
            }
        };
        self.hint.set(k);
        k
    }
    /// Θ(t): sample k covers (t_k − dt_k, t_k]; `None` outside or in a gap.
    fn angle(&self, t: f64) -> Option<f64> {
        let k = self.find(t);
        let s = self.imu.get(k)?;
        let frac = (t - (s.t - s.dt)) / s.dt;
        if !(-1e-6..=1.0 + 1e-6).contains(&frac) {
            return None;
        }
        Some(self.cum[k] + frac.clamp(0.0, 1.0) * s.dtheta_b.z)
    }
    fn rate(&self, t: f64) -> Option<f64> {
        Some((self.angle(t + RATE_HALF_S)? - self.angle(t - RATE_HALF_S)?) / (2.0 * RATE_HALF_S))
    }
}

fn wrap(a: f64) -> f64 {
    let tau = core::f64::consts::TAU;
    a - tau * (a / tau).round()
}

/// Cross-track σ of a NED (north, east) σ pair for course ψ.
fn cross_track(sn: f64, se: f64, psi: f64) -> f64 {
    ((sn * psi.sin()).powi(2) + (se * psi.cos()).powi(2)).sqrt()
}

/// Noise floors for missing/zero σ (0 = unknown in several formats):
/// carrier-phase position noise ~5 mm, Doppler velocity noise ~1 cm/s. The
/// overall scale is re-estimated from the residuals anyway.
const FLOOR_POS_M: f64 = 0.005;
const FLOOR_VEL_MPS: f64 = 0.01;

fn floor(s: f64, f: f64) -> f64 {
    if s.is_finite() && s > f {
        s
    } else {
        f
    }
}

/// Course candidates (before the σ test) from velocities or chords.
fn candidates(gnss: &[GnssFix], cfg: &TimeOffsetConfig) -> Vec<Obs> {
    let mut fixes: Vec<&GnssFix> = Vec::with_capacity(gnss.len());
    for g in gnss {
        let ok = g.t.is_finite() && g.lat.is_finite() && g.lon.is_finite() && g.h.is_finite();
        if ok && fixes.last().is_none_or(|l| g.t - l.t >= cfg.min_spacing_s) {
            fixes.push(g);
        }
    }
    let with_vel = fixes
        .iter()
        .filter(|g| g.v_n.is_some_and(|v| v.x.is_finite() && v.y.is_finite()))
        .count();
    let mut out = Vec::with_capacity(fixes.len());
    let mk = |t: f64, vn: f64, ve: f64, sct: &dyn Fn(f64) -> f64| {
        let psi = ve.atan2(vn);
        let speed = vn.hypot(ve);
        let sigma = if speed > 0.0 {
            sct(psi) / speed
        } else {
            f64::INFINITY
        };
        Obs {
            t,
            psi,
            sigma,
            speed,
            vn,
            ve,
            seg: 0,
        }
    };
    if 2 * with_vel >= fixes.len() && with_vel > 0 {
        for g in &fixes {
            let Some(v) = g.v_n.filter(|v| v.x.is_finite() && v.y.is_finite()) else {
                continue;
            };
            let s = g.std_v_n.unwrap_or_default();
            let (sn, se) = (floor(s.x, FLOOR_VEL_MPS), floor(s.y, FLOOR_VEL_MPS));
            out.push(mk(g.t, v.x, v.y, &|psi| cross_track(sn, se, psi)));
        }
    } else {
        for w in fixes.windows(2) {
            let (a, b) = (w[0], w[1]);
            let dt = b.t - a.t;
            let lat = 0.5 * (a.lat + b.lat);
            let h = 0.5 * (a.h + b.h);
            let (rm, rn) = earth::radii(lat);
            let dn = (b.lat - a.lat) * (rm + h);
            let de = wrap(b.lon - a.lon) * (rn + h) * lat.cos();
            let sd = |g: &GnssFix, psi: f64| {
                cross_track(
                    floor(g.std_ned.x, FLOOR_POS_M),
                    floor(g.std_ned.y, FLOOR_POS_M),
                    psi,
                )
            };
            let sct = |psi: f64| sd(a, psi).hypot(sd(b, psi)) / dt;
            out.push(mk(0.5 * (a.t + b.t), dn / dt, de / dt, &sct));
        }
    }
    out
}

/// Drops samples whose velocity jump to *both* neighbours implies > max_accel.
fn reject_gross(c: &[Obs], cfg: &TimeOffsetConfig) -> (Vec<Obs>, usize) {
    let bad_link = |a: &Obs, b: &Obs| {
        let dt = b.t - a.t;
        dt <= cfg.max_gap_s && (b.vn - a.vn).hypot(b.ve - a.ve) > cfg.max_accel_mps2 * dt
    };
    let linked = |a: &Obs, b: &Obs| b.t - a.t <= cfg.max_gap_s;
    let mut kept = Vec::with_capacity(c.len());
    for i in 0..c.len() {
        let prev = i.checked_sub(1).map(|j| &c[j]).filter(|p| linked(p, &c[i]));
        let next = c.get(i + 1).filter(|n| linked(&c[i], n));
        let bad = match (prev, next) {
            (Some(p), Some(n)) => bad_link(p, &c[i]) && bad_link(&c[i], n),
            (Some(p), None) => bad_link(p, &c[i]),
            (None, Some(n)) => bad_link(&c[i], n),
            (None, None) => false,
        };
        if !bad {
            kept.push(c[i]);
        }
    }
    let n = c.len() - kept.len();
    (kept, n)
}

/// Numbers (from 1) the segments of time-ordered epochs `(t, &mut seg)`:
/// a new segment after a gap over `max_gap_s` or once the current one spans
/// `max_segment_s`. Shared by both offset estimators.
pub(crate) fn assign_segments<'a>(
    epochs: impl Iterator<Item = (f64, &'a mut usize)>,
    max_gap_s: f64,
    max_segment_s: f64,
) {
    let (mut seg, mut start, mut last) = (0, f64::NEG_INFINITY, f64::NEG_INFINITY);
    for (t, s) in epochs {
        if t - last > max_gap_s || t - start > max_segment_s {
            seg += 1;
            start = t;
        }
        last = t;
        *s = seg;
    }
}

/// Assigns segments, drops short ones, unwraps ψ onto Θ(t) per segment.
fn segment(obs: &mut Vec<Obs>, head: &Heading, cfg: &TimeOffsetConfig) {
    assign_segments(
        obs.iter_mut().map(|o| (o.t, &mut o.seg)),
        cfg.max_gap_s,
        cfg.max_segment_s,
    );
    // Segments with < 3 epochs give ≤ 1 dof after their constant: drop.
    let mut i = 0;
    let mut out = Vec::with_capacity(obs.len());
    while i < obs.len() {
        let j = i + obs[i..].iter().take_while(|o| o.seg == obs[i].seg).count();
        if j - i >= 3 {
            let th: Vec<f64> = obs[i..j]
                .iter()
                .map(|o| head.angle(o.t).unwrap_or(0.0))
                .collect();
            let (mut sx, mut cx) = (0.0, 0.0);
            for (o, t) in obs[i..j].iter().zip(&th) {
                sx += (o.psi - t).sin();
                cx += (o.psi - t).cos();
            }
            let c0 = sx.atan2(cx);
            for (o, t) in obs[i..j].iter().zip(&th) {
                let mut o = *o;
                o.psi = t + c0 + wrap(o.psi - t - c0);
                out.push(o);
            }
        }
        i = j;
    }
    *obs = out;
}

/// Normal equations and residuals at parameters `p` (τ, b, s, l).
struct Lin {
    n: Mat,
    g: Vecp,
    chi2: f64,
    /// Per epoch: weighted, segment-demeaned Jacobian row × residual, and r/σ.
    score: Vec<(Vecp, f64)>,
    segs: usize,
}

fn linearise(obs: &[Obs], head: &Heading, p: &Vecp, active: &[bool; NP], t0: f64) -> Lin {
    let mut n = Mat::zeros();
    let mut g = Vecp::zeros();
    let mut chi2 = 0.0;
    let mut score = Vec::with_capacity(obs.len());
    let mut segs = 0;
    let mut rows: Vec<(Vecp, f64, f64)> = Vec::new();
    let mut i = 0;
    while i < obs.len() {
        let j = i + obs[i..].iter().take_while(|o| o.seg == obs[i].seg).count();
        segs += 1;
        rows.clear();
        let (mut sw, mut sj, mut sr) = (0.0, Vecp::zeros(), 0.0);
        for o in &obs[i..j] {
            let tt = o.t - p[0];
            // Observations were pre-screened for IMU coverage over ±max_lag.
            let th = head.angle(tt).unwrap_or(0.0);
            let w_rate = head.rate(tt).unwrap_or(0.0);
            let m = (1.0 + p[2]) * th - p[1] * (o.t - t0) + p[3] * w_rate / o.speed;
            let mut jr = Vecp::new(-(1.0 + p[2]) * w_rate, -(o.t - t0), th, w_rate / o.speed);
            for (k, a) in active.iter().enumerate() {
                if !a {
                    jr[k] = 0.0;
                }
            }
            let w = 1.0 / (o.sigma * o.sigma);
            let r = o.psi - m;
            sw += w;
            sj += jr * w;
            sr += r * w;
            rows.push((jr, r, w));
        }
        let (mj, mr) = (sj / sw, sr / sw);
        for (o, &(jr, r, w)) in obs[i..j].iter().zip(&rows) {
            let (jd, rd) = (jr - mj, r - mr);
            n += jd * jd.transpose() * w;
            g += jd * (w * rd);
            chi2 += w * rd * rd;
            score.push((jd * (w * rd), rd / o.sigma));
        }
        i = j;
    }
    for (k, a) in active.iter().enumerate() {
        if !a {
            n[(k, k)] = 1.0;
        }
    }
    Lin {
        n,
        g,
        chi2,
        score,
        segs,
    }
}

/// Profile fit at fixed τ (linear in b, s, l) then Gauss–Newton on all.
fn fit(obs: &[Obs], head: &Heading, cfg: &TimeOffsetConfig, t0: f64) -> Option<(Vecp, Lin)> {
    let mut act = [false, true, cfg.fit_scale, cfg.fit_lever];
    let steps = (cfg.max_lag_s / cfg.grid_step_s).round() as i64;
    let mut best: Option<(f64, Vecp)> = None;
    for i in -steps..=steps {
        let mut p = Vecp::zeros();
        p[0] = i as f64 * cfg.grid_step_s;
        let l = linearise(obs, head, &p, &act, t0);
        let d = l.n.cholesky()?.solve(&l.g);
        let p = p + d;
        let chi2 = linearise(obs, head, &p, &act, t0).chi2;
        if best.is_none_or(|(c, _)| chi2 < c) {
            best = Some((chi2, p));
        }
    }
    let (_, mut p) = best?;
    act[0] = true;
    for _ in 0..20 {
        let l = linearise(obs, head, &p, &act, t0);
        let d =
            l.n.cholesky()
                .map(|c| c.solve(&l.g))
                .unwrap_or_else(Vecp::zeros);
        // Keep the step inside the scanned range (the grid found the basin).
        let d0 = d[0].clamp(-cfg.grid_step_s, cfg.grid_step_s);
        p += d;
        p[0] += d0 - d[0];
        p[0] = p[0].clamp(-cfg.max_lag_s, cfg.max_lag_s);
        if d0.abs() < 1e-7 {
            break;
        }
    }
    let l = linearise(obs, head, &p, &act, t0);
    Some((p, l))
}

/// Newey–West lags [epochs]: covers the shared chord endpoints (lag 1),
/// ~1 s correlated GNSS errors and the gyro random walk inside a segment.
const HAC_LAGS: usize = 5;

/// σ_τ: max of classical s²·N⁻¹ and a Newey–West sandwich (lags ≤ HAC_LAGS).
fn std_tau(obs: &[Obs], lin: &Lin, active: usize) -> f64 {
    let Some(ninv) = lin.n.try_inverse() else {
        return f64::INFINITY;
    };
    let dof = obs.len() as f64 - lin.segs as f64 - active as f64;
    if dof < 1.0 {
        return f64::INFINITY;
    }
    let s2 = lin.chi2 / dof;
    let classical = s2 * ninv[(0, 0)];
    let mut m = Mat::zeros();
    for k in 0..obs.len() {
        let u = lin.score[k].0;
        m += u * u.transpose();
        for lag in 1..=HAC_LAGS {
            if k + lag < obs.len() && obs[k + lag].seg == obs[k].seg {
                let wl = 1.0 - lag as f64 / (HAC_LAGS as f64 + 1.0);
                let c = u * lin.score[k + lag].0.transpose();
                m += (c + c.transpose()) * wl;
            }
        }
    }
    let sandwich = (ninv * m * ninv)[(0, 0)] * obs.len() as f64 / dof;
    classical.max(sandwich).sqrt()
}

/// Median and k·1.4826·MAD of `z` (a robust σ band; `z` non-empty).
pub(crate) fn robust_band(mut z: Vec<f64>, k: f64) -> (f64, f64) {
    z.sort_by(f64::total_cmp);
    let med = z[z.len() / 2];
    let mut dev: Vec<f64> = z.iter().map(|e| (e - med).abs()).collect();
    dev.sort_by(f64::total_cmp);
    (med, k * 1.4826 * dev[dev.len() / 2])
}

/// Robust residual screen: keeps |z − med| ≤ k·1.4826·MAD; returns dropped count.
fn screen(obs: &mut Vec<Obs>, lin: &Lin, k: f64) -> usize {
    let (med, lim) = robust_band(lin.score.iter().map(|s| s.1).collect(), k);
    let before = obs.len();
    let mut idx = 0;
    obs.retain(|_| {
        let keep = (lin.score[idx].1 - med).abs() <= lim;
        idx += 1;
        keep
    });
    before - obs.len()
}

/// Estimates the IMU–GNSS time offset τ (true time = IMU stamp + τ) with its
/// 1-σ and a decision whether applying it is safe; see the module doc for
/// the model (course vs integrated body-z gyro, FRD/NED), the gross-error
/// rejection and the significance test. `imu` and `gnss` must be sorted by
/// time; non-finite fixes are skipped. Allocates O(n); call once per file.
pub fn estimate(imu: &[ImuSample], gnss: &[GnssFix], cfg: &TimeOffsetConfig) -> TimeOffsetEstimate {
    let none = |pairs_used, outliers| TimeOffsetEstimate {
        tau_s: None,
        std_s: f64::INFINITY,
        pairs_used,
        outliers,
        lever_m: 0.0,
        significant: false,
        apply: false,
        reason: TimeOffsetReason::TooFewPairs,
    };
    let head = Heading::new(imu);
    let (cand, mut outliers) = reject_gross(&candidates(gnss, cfg), cfg);
    // Keep informative epochs whose IMU window covers every τ in the scan.
    let margin = cfg.max_lag_s + RATE_HALF_S + 1e-3;
    let mut obs: Vec<Obs> = cand
        .into_iter()
        .filter(|o| o.sigma <= cfg.max_course_std_rad)
        .filter(|o| head.angle(o.t - margin).is_some() && head.angle(o.t + margin).is_some())
        .collect();
    segment(&mut obs, &head, cfg);
    let active = 2 + usize::from(cfg.fit_scale) + usize::from(cfg.fit_lever);
    let t0 = obs.first().map_or(0.0, |o| o.t);
    let mut result = None;
    const ROUNDS: usize = 4;
    for round in 0..=ROUNDS {
        if obs.len() < cfg.min_pairs.max(active + 2) {
            return none(obs.len(), outliers);
        }
        let Some((p, lin)) = fit(&obs, &head, cfg, t0) else {
            return none(obs.len(), outliers);
        };
        // After ROUNDS screenings the fit stands (precise data keeps a
        // heavy-tailed residual: screening it further would only thin it).
        if round == ROUNDS {
            result = Some((p, std_tau(&obs, &lin, active)));
            break;
        }
        let dropped = screen(&mut obs, &lin, cfg.outlier_k);
        outliers += dropped;
        if dropped == 0 {
            result = Some((p, std_tau(&obs, &lin, active)));
            break;
        }
        // Segments may have shrunk below 3 epochs: re-segment (keeps unwrap).
        segment(&mut obs, &head, cfg);
    }
    let Some((p, std)) = result else {
        return none(obs.len(), outliers);
    };
    let tau = p[0];
    let reason = TimeOffsetReason::classify(
        tau,
        std,
        cfg.max_lag_s,
        cfg.grid_step_s,
        cfg.max_std_s,
        cfg.k_sigma,
    );
    let significant = reason == TimeOffsetReason::Significant;
    TimeOffsetEstimate {
        tau_s: Some(tau),
        std_s: std,
        pairs_used: obs.len(),
        outliers,
        lever_m: p[3],
        significant,
        apply: significant,
        reason,
    }
}

#[cfg(test)]
#[path = "time_offset_tests.rs"]
pub(crate) mod tests;
