//! Bounded innovation-based adaptive measurement noise for pseudo-measurements
//! (land-vehicle constraints: NHC, ZUPT, ZARU) and a GNSS quality σ hook.
//!
//! **Method** (innovation-based adaptive estimation, IAE): Mehra 1972, "Approaches
//! to adaptive filtering", IEEE TAC 17(5); Mohamed & Schwarz 1999, "Adaptive
//! Kalman filtering for INS/GPS", J. Geodesy 73(4) (the windowed innovation
//! covariance and `R̂ = Ĉ_ν − H P⁻ Hᵀ`); with the fading memory of Sage & Husa
//! 1969, "Adaptive filtering with unknown prior statistics", JACC. For a correctly tuned filter the innovation
//! `ν = z − H x⁻` has covariance `C_ν = H P⁻ Hᵀ + R`, so
//! `R̂ = Ĉ_ν − H P⁻ Hᵀ`. Per axis `j` (diagonal R) this is kept as an
//! exponentially weighted mean
//!
//! `m_j ← (1 − α_k) m_j + α_k (ν_j² − (H P⁻ Hᵀ)_jj)`,  `α_k = max(1/(k+1), 1/N)`,
//!
//! where `k` counts the innovations used and `N` is [`AdaptiveNoise::window`]
//! (the configured σ counts as one prior sample, then a running mean until `k = N`,
//! then fading memory of effective length ≈ N). The R applied is
//! `clamp(m_j, σ_min², σ_max²)`; the mean itself is left unclamped so that the
//! clamp does not bias it. The R of an update includes its own innovation
//! (Mohamed & Schwarz's window ends at the current epoch; Sage–Husa likewise):
//! a σ started far too small is corrected at the first innovation instead of
//! locking the states onto it (with the previous-epoch estimate, a ZARU started
//! at 0.1× learned 1.48× the true σ on the z gyro in the parked test).
//!
//! **Outliers**: an innovation is used only if it passes a χ² gate computed
//! with R at its ceiling, `Σ_j ν_j² / ((H P⁻ Hᵀ)_jj + σ_max²) ≤ χ²_M(p)`: it is
//! consistent with the largest noise the caller declares plausible. Otherwise
//! it is counted and not used, so an outlier cannot inflate R, and R never
//! leaves `[σ_min², σ_max²]`. The gate uses the ceiling, not the current R, so
//! a filter started with a σ far too small still learns (its innovations fail
//! the filter's own gate but not this one).
//!
//! **Precision of the window**: for white Gaussian innovations the variance of
//! the exponentially weighted mean is ≈ `2σ⁴ α/(2 − α) ≈ σ⁴/N`, i.e. σ̂ has a
//! relative 1-σ scatter of ≈ `1/(2√N)`: `N = 100` gives ≈ 5 %, and the
//! estimate follows a change of the noise within a few `N` updates (10 s for
//! NHC at 10 Hz).

use crate::kalman;
#[allow(unused_imports)]
use crate::prelude::*;
use nalgebra::SVector;

/// Bounds and memory of one adaptive noise estimate. Every field is the
/// caller's; the presets document where their numbers come from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveNoise {
    /// Effective number of innovations in the estimate, `N ≥ 1` (see the module doc).
    pub window: f64,
    /// Floor of the adapted 1-σ [measurement units: m/s or rad/s].
    pub min_std: f64,
    /// Ceiling of the adapted 1-σ [same units]; also the R of the outlier gate.
    pub max_std: f64,
    /// χ² gate probability of the innovations used for adaptation (e.g. 0.9999:
    /// one good innovation in 10⁴ wrongly discarded).
    pub gate_probability: f64,
}

impl AdaptiveNoise {
    /// Non-holonomic constraint of a wheeled ground vehicle, body lateral and
    /// vertical velocity [m/s].
    /// - Floor 0.02 m/s: a rigidly mounted IMU on a sprung body vibrates with
    ///   amplitudes of ≳ 1 mm at the 3–15 Hz body/wheel-hop modes, i.e. a
    ///   velocity of 2π·3 Hz·1 mm ≈ 0.02 m/s at least (Gillespie, *Fundamentals
    ///   of Vehicle Dynamics*, ch. 5); a smaller σ would make the constraint
    ///   claim more than the vehicle holds.
    /// - Ceiling 2 m/s: a car's sideslip angle stays within ≈ 5° up to the
    ///   friction limit (Gillespie ch. 6; Rajamani, *Vehicle Dynamics and
    ///   Control*, §8), ≈ 1.7 m/s at 20 m/s; heave velocity of the suspension
    ///   (±0.1 m travel at 1–2 Hz) is of the same order. Beyond it the motion
    ///   is not a ground vehicle's and the innovation is an outlier.
    /// - Window 100 innovations: σ̂ to ≈ 5 % (module doc); 10 s at 10 Hz.
    pub const fn nhc_ground_vehicle() -> Self {
        AdaptiveNoise {
            window: 100.0,
            min_std: 0.02,
            max_std: 2.0,
            gate_probability: 0.9999,
        }
    }

    /// Zero-velocity update at a detected standstill, NED velocity [m/s].
    /// - Floor 1 mm/s: engine-idle vibration of ≈ 10 µm at 15–30 Hz is
    ///   ≈ 1–2 mm/s; the constraint is never better than that.
    /// - Ceiling 0.1 m/s: a larger true speed is creeping, not standstill; the
    ///   usual detector speed limits are of this order or below its accuracy.
    /// - Window 50 innovations: ≈ 7 % on σ̂; 5 s of standstill at 10 Hz.
    pub const fn zupt() -> Self {
        AdaptiveNoise {
            window: 50.0,
            min_std: 1e-3,
            max_std: 0.1,
            gate_probability: 0.9999,
        }
    }

    /// Zero angular rate update, body rate [rad/s].
    /// - Floor 1e-5 rad/s (2 °/h): below a MEMS gyro's bias stability the
    ///   window mean cannot resolve the bias.
    /// - Ceiling 0.01 rad/s (0.6 °/s): engine-idle rocking of a parked car is
    ///   1–1.5 °/s rms instantaneously, ≲ 0.5 °/s as a window mean.
    /// - Window 20 innovations (one ZARU per detector window): ≈ 11 % on σ̂.
    pub const fn zaru() -> Self {
        AdaptiveNoise {
            window: 20.0,
            min_std: 1e-5,
            max_std: 0.01,
            gate_probability: 0.9999,
        }
    }

    fn is_valid(&self) -> bool {
        self.window.is_finite()
            && self.window >= 1.0
            && self.min_std.is_finite()
            && self.min_std > 0.0
            && self.max_std.is_finite()
            && self.max_std >= self.min_std
            && self.gate_probability > 0.0
            && self.gate_probability < 1.0
    }
}

/// Which constraint updates adapt their noise. `Default`: none (the fixed σ
/// of [`super::eskf::NhcConfig`] / [`super::eskf::ZuptConfig`] is used).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AdaptiveConstraints {
    /// NHC (body y, z velocity), started from `NhcConfig::std`.
    pub nhc: Option<AdaptiveNoise>,
    /// ZUPT (NED velocity), started from `ZuptConfig::vel_std`.
    pub zupt: Option<AdaptiveNoise>,
    /// ZARU (body rate), started from `ZuptConfig::zaru_std`.
    pub zaru: Option<AdaptiveNoise>,
}

/// The innovation was not used for adaptation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdaptReject {
    /// Beyond the χ² gate at the ceiling R (an outlier).
    Gate,
    /// Not finite.
    NonFinite,
}

/// Adaptive diagonal R of an `M`-dimensional pseudo-measurement (fixed size,
/// no allocation). See the module documentation for the method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseEstimator<const M: usize> {
    cfg: AdaptiveNoise,
    /// χ²_M quantile of `cfg.gate_probability`.
    gate: f64,
    /// Running mean of `ν_j² − (H P⁻ Hᵀ)_jj` (unclamped).
    mean: [f64; M],
    used: u64,
    rejected: u64,
}

impl<const M: usize> NoiseEstimator<M> {
    /// An estimator starting from 1-σ `initial_std` on every axis. `None` if
    /// `cfg` is inconsistent (window < 1, bounds not `0 < min ≤ max`, gate
    /// probability outside (0, 1)) or `initial_std` is not finite and positive.
    pub fn new(cfg: AdaptiveNoise, initial_std: f64) -> Option<Self> {
        if !(cfg.is_valid() && initial_std.is_finite() && initial_std > 0.0) {
            return None;
        }
        Some(NoiseEstimator {
            cfg,
            gate: kalman::chi2_quantile(M, cfg.gate_probability),
            mean: [initial_std * initial_std; M],
            used: 0,
            rejected: 0,
        })
    }

    /// Variance of axis `j` to apply, clamped to `[min_std², max_std²]`.
    pub fn var(&self, j: usize) -> f64 {
        let (lo, hi) = (self.cfg.min_std, self.cfg.max_std);
        self.mean[j].clamp(lo * lo, hi * hi)
    }

    /// Diagonal of R to apply.
    pub fn r_diag(&self) -> SVector<f64, M> {
        SVector::<f64, M>::from_fn(|j, _| self.var(j))
    }

    /// Adapted 1-σ per axis (`√` of [`Self::r_diag`]).
    pub fn std(&self) -> [f64; M] {
        let mut s = [0.0; M];
        for (j, v) in s.iter_mut().enumerate() {
            *v = self.var(j).sqrt();
        }
        s
    }

    /// Innovations used / rejected so far.
    pub fn counts(&self) -> (u64, u64) {
        (self.used, self.rejected)
    }

    /// Fold in innovation `nu` whose predicted part of the covariance has
    /// diagonal `hph = diag(H P⁻ Hᵀ)` (P⁻ before this update).
    pub fn observe(
        &mut self,
        nu: &SVector<f64, M>,
        hph: &SVector<f64, M>,
    ) -> Result<(), AdaptReject> {
        if !(nu.iter().chain(hph.iter()).all(|v| v.is_finite())) {
            self.rejected += 1;
            return Err(AdaptReject::NonFinite);
        }
        let ceil = self.cfg.max_std * self.cfg.max_std;
        let nis_ceil: f64 = (0..M)
            .map(|j| nu[j] * nu[j] / (hph[j].max(0.0) + ceil))
            .sum();
        if nis_ceil > self.gate {
            self.rejected += 1;
            return Err(AdaptReject::Gate);
        }
        self.used += 1;
        let alpha = (1.0 / (self.used as f64 + 1.0)).max(1.0 / self.cfg.window);
        for j in 0..M {
            self.mean[j] += alpha * (nu[j] * nu[j] - hph[j] - self.mean[j]);
        }
        Ok(())
    }
}

/// The adapted σ of each constraint and how many innovations it used and
/// rejected (for a run summary). `None`: that constraint is not adaptive.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AdaptedNoise {
    /// NHC body (y, z) velocity σ [m/s].
    pub nhc_std: Option<[f64; 2]>,
    /// ZUPT NED velocity σ [m/s].
    pub zupt_std: Option<[f64; 3]>,
    /// ZARU body rate σ [rad/s].
    pub zaru_std: Option<[f64; 3]>,
    /// (used, rejected) innovations of NHC, ZUPT, ZARU.
    pub nhc_counts: (u64, u64),
    pub zupt_counts: (u64, u64),
    pub zaru_counts: (u64, u64),
}

/// Multiplier of a GNSS fix's position σ by its solution quality, indexed by
/// the RTKLIB Q code of [`crate::GnssFix::quality`] (0 unknown, 1 fix,
/// 2 float, 3 SBAS, 4 DGPS, 5 single, 6 PPP; navfuse's NMEA reader maps GGA
/// quality to these codes). Codes beyond the table use 1.
///
/// [`GnssQualityScale::IDENTITY`] (all 1) is the right default for RTKLIB
/// `.pos` input: its `sdn/sde/sdu` are the square roots of the filter
/// covariance of that epoch (RTKLIB `rtkpos.c`: the fixed-solution covariance
/// when fixed, the float filter's otherwise), so a float solution already
/// carries its ambiguity uncertainty (RTKLIB 2.4.2 manual, solution format). A
/// source whose σ does not depend on the status (e.g. a receiver reporting a
/// fixed σ, or none) needs the caller's table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssQualityScale(pub [f64; 7]);

impl GnssQualityScale {
    /// Every multiplier 1: outputs identical to no scaling.
    pub const IDENTITY: Self = GnssQualityScale([1.0; 7]);

    /// Multiplier for quality code `q` (1 outside the table or if the entry is
    /// not finite and positive).
    pub fn factor(&self, q: u8) -> f64 {
        match self.0.get(q as usize) {
            Some(&f) if f.is_finite() && f > 0.0 => f,
            _ => 1.0,
        }
    }
}

impl Default for GnssQualityScale {
    fn default() -> Self {
        Self::IDENTITY
    }
}

/// Bounded inflation of a measurement's R from its windowed NIS
/// ([`NisScale`]): the settings.
///
/// **Method.** Mehra's (1972) innovation test and covariance matching reduced
/// to one scale per measurement type, with Bar-Shalom, Li & Kirubarajan's
/// (2001, §5.4.2) χ² test of the windowed NIS as the trigger. The R applied
/// is `λ·R_model`, `1 ≤ λ ≤ max_scale`. Updates are taken in windows of
/// `window` updates (non-overlapping). At the end of a window of `d = window·M`
/// degrees of freedom with `Σε` the sum of the NIS (each computed with the R
/// applied, capped at the filter's own gate so that one outlier cannot move
/// λ), `q = Σε/d`:
/// - `Σε > χ²_d(p_up)` in this window and the one before (significantly
///   overconfident twice in a row): `λ ← min(λ·q, max_scale)`;
/// - `q < 1` (NIS below its expectation): `λ ← max(λ·q, 1)`;
/// - otherwise λ is kept.
///
/// So λ rises only on evidence (a consistent filter crosses the upper test
/// twice in a row in `(1 − p_up)²` of its windows — 10⁻⁴, once in 28 h of
/// 10 s windows; a single crossing, once in 17 min, moved a consistent
/// simulated run by 12 cm at σ 0.5 m, which is why two are required),
/// and never falls below the model's R: the adaptation can only widen σ, and
/// a filter whose NIS agrees with its model runs with λ = 1 (identical to no
/// adaptation) except after such a false alarm. `λ·q` is the covariance
/// matching step when R dominates the innovation covariance, an under-step
/// otherwise (the next window continues), so λ approaches the needed scale
/// from below.
///
/// What it cannot see: errors the filter follows instead of rejecting (a
/// GNSS error correlated over minutes moves the estimate with it and keeps
/// the NIS small; that needs a model, e.g. Schmidt consider states).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NisAdaptation {
    /// Updates per window (≥ 2).
    pub window: u32,
    /// Probability of the upper χ² test (e.g. 0.99).
    pub p_up: f64,
    /// Largest factor on the model's R (variance; ≥ 1).
    pub max_scale: f64,
}

impl NisAdaptation {
    /// GNSS position and velocity fixes.
    /// - Window 10 updates: ten 1 Hz fixes, 30 degrees of freedom for a 3-D
    ///   fix; the window of [`super::consistency::NIS_WINDOW_S`]. A
    ///   consistent window's `q` scatters by `√(2/30)` ≈ 0.26, so an
    ///   overconfidence by 2 in variance is detected within a window or two.
    /// - Upper test at 99 %, twice in a row: a consistent filter raises λ in
    ///   one window in 10⁴.
    /// - Ceiling 100 in variance (σ × 10): the formal σ of GNSS solutions is
    ///   reported optimistic by factors of ≈ 2 to 10 when time correlation
    ///   and multipath are ignored (Tiberius & Kenselaar 2003, "Variance
    ///   component estimation and precise GPS positioning", GPS Solutions
    ///   7(2)); beyond one order of magnitude the fix is no longer the
    ///   measurement its σ describes, and the gate handles it.
    pub const fn gnss() -> Self {
        NisAdaptation {
            window: 10,
            p_up: 0.99,
            max_scale: 100.0,
        }
    }

    fn is_valid(&self) -> bool {
        self.window >= 2
            && self.p_up > 0.5
            && self.p_up < 1.0
            && self.max_scale.is_finite()
            && self.max_scale >= 1.0
    }
}

/// The R scale λ of one measurement type (see [`NisAdaptation`]); fixed size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NisScale {
    cfg: NisAdaptation,
    dof: usize,
    /// χ²_{window·dof}(p_up).
    upper: f64,
    /// Per-update NIS cap (the filter's gate, ∞ without one).
    cap: f64,
    scale: f64,
    n: u32,
    sum: f64,
    /// The previous window was above the upper test.
    prev_above: bool,
    windows: u64,
    raised: u64,
    max_scale_seen: f64,
}

impl NisScale {
    /// A scale for `dof`-dimensional updates whose NIS is capped at `cap`
    /// (the filter's χ² gate; `f64::INFINITY` without one). `None` if `cfg`
    /// is invalid (window < 2, `p_up` outside (0.5, 1), `max_scale` < 1) or
    /// `dof` is 0.
    pub fn new(cfg: NisAdaptation, dof: usize, cap: f64) -> Option<Self> {
        if !cfg.is_valid() || dof == 0 || cap.is_nan() || cap <= 0.0 {
            return None;
        }
        Some(NisScale {
            cfg,
            dof,
            upper: kalman::chi2_quantile(cfg.window as usize * dof, cfg.p_up),
            cap,
            scale: 1.0,
            n: 0,
            sum: 0.0,
            prev_above: false,
            windows: 0,
            raised: 0,
            max_scale_seen: 1.0,
        })
    }

    /// The factor λ ≥ 1 on the model's R now.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// Fold in the NIS of one update tried with R = λ·R_model (accepted,
    /// de-weighted or gated; non-finite values are ignored).
    pub fn observe(&mut self, nis: f64) {
        if !nis.is_finite() || nis < 0.0 {
            return;
        }
        self.sum += nis.min(self.cap);
        self.n += 1;
        if self.n < self.cfg.window {
            return;
        }
        let d = (self.cfg.window as usize * self.dof) as f64;
        let q = self.sum / d;
        let above = self.sum > self.upper;
        if above && self.prev_above {
            self.scale = (self.scale * q).min(self.cfg.max_scale);
            self.raised += 1;
        } else if q < 1.0 {
            self.scale = (self.scale * q).max(1.0);
        }
        self.prev_above = above;
        self.max_scale_seen = self.max_scale_seen.max(self.scale);
        self.windows += 1;
        self.n = 0;
        self.sum = 0.0;
    }

    /// (complete windows, windows that raised λ, largest λ so far).
    pub fn summary(&self) -> (u64, u64, f64) {
        (self.windows, self.raised, self.max_scale_seen)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimators::pf_lc::rng::SplitMix64;

    fn cfg() -> AdaptiveNoise {
        AdaptiveNoise {
            window: 100.0,
            min_std: 1e-3,
            max_std: 5.0,
            gate_probability: 0.9999,
        }
    }

    #[test]
    fn learns_the_measurement_part_of_the_innovation_variance() {
        // ν_j ~ N(0, hph_j + σ_j²): the estimate must return σ_j, not √(hph+σ²).
        let sigma = [0.3, 0.05];
        let hph = SVector::<f64, 2>::new(0.04, 0.001);
        for start in [0.01, 3.0] {
            let mut e = NoiseEstimator::<2>::new(cfg(), start).unwrap();
            let mut n = SplitMix64::new(42);
            for _ in 0..5_000 {
                let nu = SVector::<f64, 2>::from_fn(|j, _| {
                    n.normal() * (hph[j] + sigma[j] * sigma[j]).sqrt()
                });
                let _ = e.observe(&nu, &hph);
            }
            let s = e.std();
            for j in 0..2 {
                assert!(
                    (s[j] / sigma[j] - 1.0).abs() < 0.2,
                    "start {start}: axis {j} σ̂ {} vs {}",
                    s[j],
                    sigma[j]
                );
            }
        }
    }

    #[test]
    fn outliers_are_counted_not_used_and_bounds_hold() {
        let mut c = cfg();
        c.min_std = 0.1;
        c.max_std = 0.5;
        let mut e = NoiseEstimator::<1>::new(c, 0.2).unwrap();
        let zero = SVector::<f64, 1>::zeros();
        // Innovations far beyond the ceiling's gate (|ν| > √15.1·0.5 ≈ 1.9).
        for _ in 0..100 {
            assert_eq!(
                e.observe(&SVector::<f64, 1>::new(50.0), &zero),
                Err(AdaptReject::Gate)
            );
        }
        assert_eq!(e.counts(), (0, 100));
        assert_eq!(e.std(), [0.2]);
        // Large but plausible: the estimate saturates at the ceiling.
        for _ in 0..1_000 {
            e.observe(&SVector::<f64, 1>::new(1.5), &zero).unwrap();
        }
        assert_eq!(e.std(), [0.5]);
        // Zero innovations: it falls to the floor, never below.
        for _ in 0..1_000 {
            e.observe(&zero, &SVector::<f64, 1>::new(0.01)).unwrap();
        }
        assert_eq!(e.std(), [0.1]);
        assert_eq!(
            e.observe(&SVector::<f64, 1>::new(f64::NAN), &zero),
            Err(AdaptReject::NonFinite)
        );
        assert_eq!(e.counts(), (2_000, 101));
    }

    #[test]
    fn invalid_configurations_are_refused() {
        let bad = [
            AdaptiveNoise {
                window: 0.5,
                ..cfg()
            },
            AdaptiveNoise {
                min_std: 0.0,
                ..cfg()
            },
            AdaptiveNoise {
                max_std: 1e-4,
                ..cfg()
            },
            AdaptiveNoise {
                gate_probability: 1.0,
                ..cfg()
            },
            AdaptiveNoise {
                window: f64::NAN,
                ..cfg()
            },
        ];
        for b in bad {
            assert!(NoiseEstimator::<2>::new(b, 0.1).is_none(), "{b:?}");
        }
        assert!(NoiseEstimator::<2>::new(cfg(), 0.0).is_none());
        assert!(NoiseEstimator::<2>::new(cfg(), 0.1).is_some());
    }

    #[test]
    fn quality_scale_defaults_to_one() {
        let s = GnssQualityScale([1.0, 1.0, 3.0, 1.0, 2.0, 5.0, f64::NAN]);
        assert_eq!(s.factor(2), 3.0);
        assert_eq!(s.factor(6), 1.0);
        assert_eq!(s.factor(200), 1.0);
        assert!((0..=255).all(|q| GnssQualityScale::default().factor(q) == 1.0));
    }

    #[test]
    fn nis_scale_stays_at_one_when_consistent_and_learns_an_understated_r() {
        // Scalar measurement, R_true = 1, predicted part 0: with the model's
        // R right, λ stays ≈ 1; with R_model = R_true/25 it rises towards
        // 25 (bounded by max_scale).
        let cfg = NisAdaptation::gnss();
        for (r_model, want) in [(1.0, 1.0), (1.0 / 25.0, 25.0), (1e-4, 100.0)] {
            let mut s = NisScale::new(cfg, 1, f64::INFINITY).unwrap();
            let mut n = SplitMix64::new(7);
            let (mut acc, mut k) = (0.0, 0);
            for i in 0..20_000 {
                let nu = n.normal();
                let nis = nu * nu / (s.scale() * r_model);
                if i >= 10_000 {
                    acc += s.scale();
                    k += 1;
                }
                s.observe(nis);
            }
            let mean = acc / k as f64;
            assert!(mean >= 1.0 && mean <= cfg.max_scale);
            // λ approaches from below (raised only on significant windows,
            // lowered on every window with q < 1): first run gave 16.2
            // against 25; within [0.5, 1.1] × the needed scale.
            assert!(
                (0.5..=1.1).contains(&(mean / want)),
                "R_model {r_model}: mean λ {mean} vs {want}"
            );
        }
        // Outliers are capped at the gate: single large NIS do not raise λ.
        let mut s = NisScale::new(cfg, 3, 21.1).unwrap();
        for i in 0..1000 {
            s.observe(if i % 10 == 0 { 1e6 } else { 3.0 });
        }
        assert_eq!(s.scale(), 1.0);
        assert!(NisScale::new(NisAdaptation { window: 1, ..cfg }, 3, 1.0).is_none());
        assert!(NisScale::new(
            NisAdaptation {
                max_scale: 0.5,
                ..cfg
            },
            3,
            1.0
        )
        .is_none());
    }
}
