//! The IMU–GNSS time offset: how a run applies one ([`TimeOffset`],
//! [`TimeOffsetCfg`]) and its estimate from the data ([`auto_estimate`]).
//! Convention: true time = IMU stamp + τ.

use crate::error::{PipelineError, Result};
use navfuse_core::ins::time_offset::{TimeOffsetConfig, TimeOffsetEstimate};
use navfuse_core::types::{GnssFix, ImuSample};
use navfuse_core::Vec3;
use serde::{Deserialize, Serialize};

/// `imu_time_offset`: a number of seconds or `"auto"`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(untagged)]
pub enum TimeOffsetCfg {
    Seconds(f64),
    Named(String),
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TimeOffset {
    /// No offset applied.
    None,
    /// Estimated with its σ ([`auto_estimate`]), applied when significant.
    Auto,
    /// Given [s].
    Seconds(f64),
}

impl TimeOffset {
    /// `none`, `auto` or a number of seconds (finite, |τ| < 10 s).
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "none" => Ok(TimeOffset::None),
            "auto" => Ok(TimeOffset::Auto),
            _ => s
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && v.abs() < 10.0)
                .map(TimeOffset::Seconds)
                .ok_or_else(|| {
                    PipelineError::Options(format!(
                        "time offset {s:?}: expected seconds (|τ| < 10), auto or none"
                    ))
                }),
        }
    }

    /// The offset [s] to apply and how it was found. `Auto` estimates τ with
    /// its σ ([`auto_estimate`]) and applies it only when it is significantly
    /// non-zero (|τ| > 3.29 σ, a 0.1 % two-sided false alarm, and σ ≤ 20 ms);
    /// otherwise nothing is applied (`Ok(None)`): a default must never make a
    /// data set worse, and an unsignificant τ can only add error.
    pub fn resolve(self, imu: &[ImuSample], gnss: &[GnssFix]) -> Result<Option<(f64, String)>> {
        match self {
            TimeOffset::None => Ok(None),
            TimeOffset::Seconds(s) => Ok(Some((s, "given".into()))),
            TimeOffset::Auto => {
                let e = auto_estimate(imu, gnss);
                Ok(match (e.apply, e.tau_s) {
                    (true, Some(tau)) => Some((tau, describe(&e))),
                    _ => None,
                })
            }
        }
    }
}

/// The IMU–GNSS time offset τ with its σ, and whether applying it is safe
/// (convention: true time = IMU stamp + τ).
///
/// Each estimate is [`navfuse_core::ins::time_offset::estimate`] (GNSS course
/// against the integrated z gyro, gyro bias/scale fitted, gross errors
/// rejected, course σ from the GNSS σ and speed, so no fixed speed
/// threshold). Its σ is honest for its own model only, and two model choices
/// the data cannot settle move τ by more than σ on real drives: whether the
/// antenna sits ahead of the vehicle's zero-sideslip point (a course lead
/// `l·ω/v`, which looks like a time shift), and whether the receiver's
/// velocity is as timely as its positions (a filtered velocity lags — the
/// RTKLIB `.pos` of `../shared/data/drive_0708` by ~0.12 s). So τ is
/// estimated under every available variant — lever fitted or not, course
/// from the receiver velocity (its latency behind the positions first
/// estimated and removed, [`velocity_latency`]) or from position chords —
/// and applied only when every variant with σ ≤ 20 ms is significant
/// (|τ| > 3.29 σ, a 0.1 % two-sided false alarm) and of one sign; the
/// applied τ is their inverse-variance mean when they agree within 3 σ of
/// their differences, else the least extreme of them (every model supports
/// moving the stamps at least that far). Otherwise it is reported, not
/// applied.
pub fn auto_estimate(imu: &[ImuSample], gnss: &[GnssFix]) -> AutoOffset {
    // A run estimates τ while loading its inputs and again for its summary
    // on the same samples (when nothing was shifted or cut): the estimate
    // is a pure function of them, so the last one is reused when the
    // inputs' fingerprint matches (≈ 2 × 4 course fits saved; on the
    // simulated 1 h RTK car that was ~23 % of `navfuse run`'s time).
    let key = fingerprint(imu, gnss);
    let cached = |k: &Fingerprint| {
        LAST_AUTO
            .lock()
            .ok()?
            .as_ref()
            .filter(|(c, _)| c == k)
            .map(|(_, e)| e.clone())
    };
    if let Some(hit) = cached(&key) {
        return hit;
    }
    let e = auto_estimate_uncached(imu, gnss);
    if let Ok(mut c) = LAST_AUTO.lock() {
        *c = Some((key, e.clone()));
    }
    e
}

/// The last [`auto_estimate`] of the process and its inputs' [`fingerprint`]
/// (process-wide: a run loads its inputs and filters them on different
/// threads).
static LAST_AUTO: std::sync::Mutex<Option<(Fingerprint, AutoOffset)>> = std::sync::Mutex::new(None);

/// Lengths and two independent 64-bit hashes of every bit of the inputs
/// (each field of [`ImuSample`] and [`GnssFix`]): a false match needs a
/// 128-bit collision.
type Fingerprint = (usize, usize, u64, u64);

fn fingerprint(imu: &[ImuSample], gnss: &[GnssFix]) -> Fingerprint {
    use std::hash::{Hash, Hasher};
    let mut h1 = std::collections::hash_map::DefaultHasher::new();
    let mut h2 = std::collections::hash_map::DefaultHasher::new();
    0x9e37_79b9_7f4a_7c15u64.hash(&mut h2);
    let mut put = |v: f64| {
        v.to_bits().hash(&mut h1);
        v.to_bits().rotate_left(17).hash(&mut h2);
    };
    for s in imu {
        for v in [s.t, s.dt].into_iter().chain(s.dtheta_b.iter().copied()) {
            put(v);
        }
        s.dvel_b.iter().for_each(|v| put(*v));
    }
    for g in gnss {
        for v in [g.t, g.lat, g.lon, g.h] {
            put(v);
        }
        g.std_ned.iter().for_each(|v| put(*v));
        for o in [g.v_n, g.std_v_n] {
            match o {
                Some(v) => v.iter().for_each(|x| put(*x)),
                None => put(f64::from_bits(0x7ff8_dead_beef_0001)),
            }
        }
        put(f64::from(g.quality) + 256.0 * f64::from(g.num_sats));
    }
    (imu.len(), gnss.len(), h1.finish(), h2.finish())
}

fn auto_estimate_uncached(imu: &[ImuSample], gnss: &[GnssFix]) -> AutoOffset {
    let has_vel = gnss.iter().filter(|g| g.v_n.is_some()).count() * 2 >= gnss.len().max(1);
    let positions: Vec<GnssFix>;
    let retimed: Option<Vec<GnssFix>>;
    let mut sources: Vec<(&'static str, &[GnssFix])> = Vec::with_capacity(2);
    let mut latency = None;
    if has_vel {
        (retimed, latency) = latency_corrected(gnss);
        match &retimed {
            Some(r) => sources.push(("velocity (latency-corrected)", r)),
            None => sources.push(("velocity", gnss)),
        }
        positions = gnss
            .iter()
            .map(|g| GnssFix {
                v_n: None,
                std_v_n: None,
                ..*g
            })
            .collect();
        sources.push(("positions", &positions));
    } else {
        sources.push(("positions", gnss));
    }
    let mut variants = Vec::with_capacity(4);
    for (src, fixes) in sources {
        for lever in [true, false] {
            let cfg = TimeOffsetConfig {
                fit_lever: lever,
                ..TimeOffsetConfig::default()
            };
            let e = navfuse_core::ins::time_offset::estimate(imu, fixes, &cfg);
            let name = if lever { "lever fitted" } else { "no lever" };
            variants.push((format!("{src}, {name}"), e));
        }
    }
    let mut d = decide(variants);
    d.velocity_latency = latency;
    d
}

/// Whether a receiver velocity latency `l` ± `sl` [s] is significant:
/// |L| > 3.29 σ_L, the 0.1 % two-sided false alarm used for τ itself.
pub fn latency_significant(l: f64, sl: f64) -> bool {
    l.abs() > 3.29 * sl
}

/// The receiver velocity's latency behind its positions
/// ([`velocity_latency`], from the GNSS alone) and, when it is significant
/// ([`latency_significant`]), the fixes with their velocities retimed to
/// their own epochs ([`retime_velocity`]). A filtered Doppler velocity
/// reported at `t` describes `t − L` (drive_0708's RTKLIB `.pos`: L ≈
/// 0.13 s, README); fused or compared as reported it is a model error of
/// `L·a` and it adds `L` to any τ read from velocities, so the filter
/// passes ([`crate::offset_passes`]) and the course estimate
/// ([`auto_estimate`]) both take the retimed fixes.
pub fn latency_corrected(gnss: &[GnssFix]) -> (Option<Vec<GnssFix>>, Option<(f64, f64)>) {
    let latency = velocity_latency(gnss);
    let retimed = match latency {
        Some((l, sl)) if latency_significant(l, sl) => Some(retime_velocity(gnss, l)),
        _ => None,
    };
    (retimed, latency)
}

/// The latency `L` [s] of a receiver's velocity behind its positions (a
/// filtered velocity reported at `t` is the velocity of `t − L`) and its σ,
/// from the GNSS alone. Over a baseline from fix `a` to fix `b` the
/// displacement is the integral of the true velocity, i.e. of the reported
/// one shifted by `L`; to first order in `L`
/// `p_b − p_a − ∫ u = L · (u_b − u_a)`, with `∫ u` the trapezoid over the
/// reported velocities `u` of every fix in between. `L` is the weighted
/// least-squares slope of that regression (horizontal, weights from the
/// fixes' σ); its σ is the largest of the classical one scaled by the
/// reduced χ² (so a wrong σ of the fixes cannot make it overconfident), a
/// Newey–West sandwich (correlated residuals) and the split-half σ (the
/// halves of the record fitted apart: a misfit that changes along it).
///
/// Baselines span about [`LATENCY_BASELINE_S`], whatever the fix rate:
/// at 10 Hz consecutive fixes differ in velocity by little more than their
/// noise, which would bias the slope toward zero. An earlier grid search
/// over `L` that interpolated the reported velocities between fixes had a
/// cost rippling with the fix interval (the interpolated noise depends on
/// where `t + L` falls between two fixes); its minimum and curvature were
/// the ripple's, not the latency's: ±0.15–0.45 s at σ ≈ 0.04 s on 10 Hz
/// receivers without latency (simulated car, robot and uav with consumer
/// GNSS, seeds 100–129: the IMU offset that then answered it was applied on
/// 20 of 90 runs), ±0.25 s on 30 of 300 runs at 4 Hz.
/// `None` with fewer than 30 baselines, or when the fit's `L` is beyond
/// ±0.5 s (no receiver filter lags that much behind its positions).
pub fn velocity_latency(gnss: &[GnssFix]) -> Option<(f64, f64)> {
    /// Largest gap between fixes inside a baseline [s].
    const MAX_GAP_S: f64 = 1.5;
    let fixes: Vec<&GnssFix> = gnss.iter().filter(|g| g.v_n.is_some()).collect();
    let mut rows: Vec<LatencyRow> = Vec::new();
    let mut i = 0;
    let mut joined = false;
    while i + 1 < fixes.len() {
        // The baseline: from fix i over consecutive fixes without a gap,
        // up to LATENCY_BASELINE_S (at least one interval).
        let mut j = i;
        let mut int = Vec3::zeros();
        while j + 1 < fixes.len() {
            let (p, q) = (fixes[j], fixes[j + 1]);
            let dt = q.t - p.t;
            if !(dt > 0.0 && dt <= MAX_GAP_S)
                || (j > i && q.t - fixes[i].t > LATENCY_BASELINE_S + 1e-6)
            {
                break;
            }
            int += (p.v_n? + q.v_n?) * (0.5 * dt);
            j += 1;
        }
        if j == i {
            i += 1;
            joined = false;
            continue;
        }
        let (a, b) = (fixes[i], fixes[j]);
        let (rm, rn) = navfuse_core::earth::radii(a.lat);
        let dp = nalgebra::Vector2::new(
            (b.lat - a.lat) * (rm + a.h),
            (b.lon - a.lon) * (rn + a.h) * a.lat.cos(),
        );
        let w = 1.0 / (a.std_ned.xy().norm_squared() + b.std_ned.xy().norm_squared()).max(1e-6);
        rows.push(LatencyRow {
            w,
            x: (b.v_n? - a.v_n?).xy(),
            r: dp - int.xy(),
            joined,
        });
        joined = true;
        i = j;
    }
    let n = 2 * rows.len();
    let (l, sxx) = latency_slope(&rows)?;
    if !(l.is_finite() && l.abs() <= 0.5) {
        return None;
    }
    // σ: the largest of the classical one (reduced χ², n − 1 dof, floored
    // at 1), a Newey–West sandwich over up to LATENCY_HAC_LAGS baselines of
    // one unbroken run (Bartlett weights: consecutive baselines share a fix,
    // and dynamics the fixes do not resolve leave correlated residuals) and
    // the split-half σ below.
    let score: Vec<f64> = rows
        .iter()
        .map(|b| b.w * b.x.dot(&(b.r - b.x * l)))
        .collect();
    let chi2: f64 = rows
        .iter()
        .map(|b| b.w * (b.r - b.x * l).norm_squared())
        .sum();
    let dof = (n - 1) as f64;
    let classical = (chi2 / dof).max(1.0) / sxx;
    let mut meat = 0.0;
    for k in 0..score.len() {
        meat += score[k] * score[k];
        for lag in 1..=LATENCY_HAC_LAGS {
            if k + lag >= score.len() || !rows[k + 1..=k + lag].iter().all(|b| b.joined) {
                break;
            }
            let wl = 1.0 - lag as f64 / (LATENCY_HAC_LAGS as f64 + 1.0);
            meat += 2.0 * wl * score[k] * score[k + lag];
        }
    }
    let sandwich = meat / (sxx * sxx) * n as f64 / dof;
    // The model check the IMU-offset fits use (split-half σ,
    // `navfuse_core::ins::time_offset_vel`): the slope of each half of the
    // baselines apart; if a constant latency holds, |L₁ − L₂|/2 estimates
    // σ itself, and a misfit that changes along the record makes it larger
    // (a steady one, as the aliased gait of 1 Hz walkers, passes). A half
    // too short to fit is no check, and then no latency is claimed.
    let mid = rows.len() / 2;
    let split = match (latency_slope(&rows[..mid]), latency_slope(&rows[mid..])) {
        (Some((l1, _)), Some((l2, _))) => 0.5 * (l1 - l2).abs(),
        _ => f64::INFINITY,
    };
    Some((l, classical.max(sandwich).sqrt().max(split)))
}

/// One baseline of [`velocity_latency`]'s regression `r = L · x`.
struct LatencyRow {
    /// Weight: 1 / the horizontal variance of the two end fixes [1/m²].
    w: f64,
    /// Regressor: the reported velocity change over the baseline, NE [m/s].
    x: nalgebra::Vector2<f64>,
    /// Displacement minus the trapezoid of the reported velocities, NE [m].
    r: nalgebra::Vector2<f64>,
    /// Continues the previous baseline (they share the fix between them).
    joined: bool,
}

/// Weighted least-squares slope of `rows` and its information Σ w |x|²;
/// `None` under 30 baselines (60 equations) or without information.
fn latency_slope(rows: &[LatencyRow]) -> Option<(f64, f64)> {
    let sxx: f64 = rows.iter().map(|b| b.w * b.x.norm_squared()).sum();
    let sxr: f64 = rows.iter().map(|b| b.w * b.x.dot(&b.r)).sum();
    (2 * rows.len() >= 60 && sxx > 0.0).then(|| (sxr / sxx, sxx))
}

/// Newey–West lags of [`velocity_latency`] [baselines]: as the IMU-offset
/// fits' (`navfuse_core::ins::time_offset`), ~5 s of correlated residuals.
pub const LATENCY_HAC_LAGS: usize = 5;

/// Baseline of [`velocity_latency`]'s regression [s]: the velocity change
/// over it must stand well above the velocity noise (a car's ~1 m/s² against
/// a consumer receiver's 0.1 m/s), while the first-order model in `L` stays
/// exact for the dynamics of a vehicle (1 s, the common fix interval: at
/// 1 Hz a baseline is one interval, as before).
pub const LATENCY_BASELINE_S: f64 = 1.0;

/// `gnss` with each fix's velocity replaced by the velocity reported `l` s
/// later (interpolated), i.e. the velocity of the fix's own time when the
/// receiver reports it with latency `l`. Fixes past the end keep theirs.
pub(crate) fn retime_velocity(gnss: &[GnssFix], l: f64) -> Vec<GnssFix> {
    let with: Vec<&GnssFix> = gnss.iter().filter(|g| g.v_n.is_some()).collect();
    gnss.iter()
        .map(|g| {
            let t = g.t + l;
            let k = with.partition_point(|x| x.t < t);
            let v = match (k.checked_sub(1).and_then(|i| with.get(i)), with.get(k)) {
                (Some(a), Some(b)) if b.t - a.t <= 1.5 => {
                    let w = (t - a.t) / (b.t - a.t).max(1e-9);
                    match (a.v_n, b.v_n) {
                        (Some(va), Some(vb)) => Some(va * (1.0 - w) + vb * w),
                        _ => g.v_n,
                    }
                }
                _ => g.v_n,
            };
            GnssFix { v_n: v, ..*g }
        })
        .collect()
}

/// The combined decision over the model variants (see [`auto_estimate`]).
fn decide(variants: Vec<(String, TimeOffsetEstimate)>) -> AutoOffset {
    let max_std = TimeOffsetConfig::default().max_std_s;
    let usable: Vec<(f64, f64, bool)> = variants
        .iter()
        .filter_map(|(_, e)| e.tau_s.map(|t| (t, e.std_s, e.significant)))
        .filter(|(_, s, _)| s.is_finite() && *s <= max_std)
        .collect();
    let all_significant = usable.iter().all(|u| u.2);
    let one_sign = usable.iter().all(|u| u.0.signum() == usable[0].0.signum());
    let consistent = usable.iter().all(|(a, sa, _)| {
        usable
            .iter()
            .all(|(b, sb, _)| (a - b).abs() <= 3.0 * sa.hypot(*sb))
    });
    // Consistent variants: their inverse-variance mean (unbiased). Variants
    // that disagree but agree in sign: the least extreme — every model
    // supports moving the stamps at least that far, none supports less.
    let pick = if consistent {
        let (sw, swt) = usable.iter().fold((0.0, 0.0), |(w, wt), (t, s, _)| {
            (w + 1.0 / (s * s), wt + t / (s * s))
        });
        (sw > 0.0).then(|| (swt / sw, (1.0 / sw).sqrt()))
    } else {
        usable
            .iter()
            .min_by(|a, b| a.0.abs().total_cmp(&b.0.abs()))
            .map(|u| (u.0, u.1))
    };
    let (apply, reason) = if usable.is_empty() {
        (false, "no variant estimates τ within 20 ms")
    } else if !one_sign {
        (
            false,
            "model-dependent: the variants differ in sign; not applied",
        )
    } else if !all_significant {
        (false, "not significant under every variant; not applied")
    } else if consistent {
        (
            true,
            "significant and consistent under every variant; their weighted mean applied",
        )
    } else {
        (
            true,
            "significant under every variant but model-dependent; the least extreme applied",
        )
    };
    let (tau, std) = pick.map_or((None, f64::INFINITY), |(t, s)| (Some(t), s));
    AutoOffset {
        tau_s: tau,
        std_s: std,
        apply,
        reason,
        variants,
        velocity_latency: None,
    }
}

/// The decision of [`auto_estimate`].
#[derive(Clone, Debug)]
pub struct AutoOffset {
    /// The τ chosen from the usable variants [s] (see [`auto_estimate`]), and its σ.
    pub tau_s: Option<f64>,
    pub std_s: f64,
    /// Whether τ is applied.
    pub apply: bool,
    /// Why (one phrase).
    pub reason: &'static str,
    /// Every variant's estimate, named.
    pub variants: Vec<(String, TimeOffsetEstimate)>,
    /// The receiver velocity's latency behind its positions [s] and σ
    /// ([`velocity_latency`]), when the fixes carry velocity.
    pub velocity_latency: Option<(f64, f64)>,
}

/// One line: `τ = +0.1000 ± 0.0040 s: significant … [velocity, no lever: …]`.
pub fn describe(e: &AutoOffset) -> String {
    let head = match e.tau_s {
        Some(tau) => format!("τ = {tau:+.4} ± {:.4} s: {}", e.std_s, e.reason),
        None => format!("no estimate: {}", e.reason),
    };
    let parts: Vec<String> = e
        .variants
        .iter()
        .map(|(n, v)| match v.tau_s {
            Some(t) => format!("{n}: {t:+.4} ± {:.4} s ({})", v.std_s, v.reason.describe()),
            None => format!("{n}: {}", v.reason.describe()),
        })
        .collect();
    let lat = match e.velocity_latency {
        Some((l, sl)) => format!("; receiver velocity latency {l:+.3} ± {sl:.3} s"),
        None => String::new(),
    };
    format!("{head} [{}]{lat}", parts.join("; "))
}

/// The summary's `time_offset` text: the offset the input loading applied
/// (`applied`: τ [s] and how) and the estimate on the run's inputs after it
/// (`residual`, reported, never applied twice).
pub fn time_offset_note(residual: &AutoOffset, applied: Option<&(f64, String)>) -> String {
    let applied = match applied {
        Some((tau, how)) => format!("{tau:+.4} s, {how}"),
        None => "none".into(),
    };
    format!(
        "applied to the IMU stamps: {applied}; estimate on the inputs after it: {}",
        describe(residual)
    )
}

/// The time-offset mode of a run whose `[input] imu_time_offset` is unset:
/// `auto` when the platform's course follows its heading (car, robot,
/// walker; and with no platform named, the KF-GINS model's vehicles), else
/// none — the course-vs-gyro estimate has nothing to hold on to when a
/// multirotor flies sideways or a boat crabs.
pub fn default_mode(cfg: &crate::config::RunConfig) -> TimeOffset {
    let platform = cfg
        .filter
        .platform
        .or((cfg.filter.preset == "enhanced").then_some(crate::profile::Platform::Car));
    match platform {
        Some(p) if !p.profile().course_follows_heading => TimeOffset::None,
        _ => TimeOffset::Auto,
    }
}

#[cfg(test)]
mod latency_tests {
    use super::{latency_significant, velocity_latency};
    use navfuse_sim::platform::{platform_run, GnssGrade, ImuGrade, Platform, PlatformOptions};

    /// A car's fixes at `rate_hz`, with the velocity reported `l_s` late
    /// (the velocity of `t − l_s` plus the grade's noise, which the
    /// simulator drew for the fix's own epoch).
    fn fixes(
        grade: GnssGrade,
        rate_hz: f64,
        seed: u64,
        l_s: f64,
    ) -> Vec<navfuse_core::types::GnssFix> {
        let opt = PlatformOptions {
            static_start: false,
            imu: ImuGrade::Industrial,
            gnss: grade,
            gnss_rate_hz: Some(rate_hz),
            duration_s: 300.0,
            ..Default::default()
        };
        let pr = platform_run(Platform::Car, seed, &opt).unwrap();
        let t0 = pr.run.traj.truth[0].t;
        pr.run
            .gnss
            .iter()
            .map(|g| {
                let v = g.v_n.unwrap();
                let late = pr.run.traj.at((g.t - l_s).max(t0)).v_n - pr.run.traj.at(g.t).v_n;
                navfuse_core::types::GnssFix {
                    v_n: Some(v + late),
                    ..*g
                }
            })
            .collect()
    }

    /// The latency fit at fix rates other than 1 Hz. The grid search it
    /// replaced returned 0.207 ± 0.011 s on every 5 Hz receiver without
    /// latency, ±0.25 s on 30 of 300 simulated 4 Hz consumer runs and
    /// ±0.15–0.45 s at 10 Hz. Bars, written before the run: without latency
    /// never significant (consumer and RTK, 1/2/4/5/10 Hz, three seeds); an
    /// injected 0.13 s (drive_0708's receiver) found within 3σ with
    /// σ ≤ 0.02 s from RTK positions.
    #[test]
    fn velocity_latency_holds_at_any_fix_rate() {
        for rate in [1.0, 2.0, 4.0, 5.0, 10.0] {
            for seed in [61u64, 62, 63] {
                for grade in [GnssGrade::Consumer, GnssGrade::Rtk] {
                    let (l, sl) = velocity_latency(&fixes(grade, rate, seed, 0.0)).unwrap();
                    assert!(
                        !latency_significant(l, sl),
                        "{grade} {rate} Hz seed {seed}: {l:.3} ± {sl:.3} s without latency"
                    );
                }
                let (l, sl) = velocity_latency(&fixes(GnssGrade::Rtk, rate, seed, 0.13)).unwrap();
                assert!(
                    (l - 0.13).abs() <= 3.0 * sl && sl <= 0.02,
                    "rtk {rate} Hz seed {seed}: {l:.3} ± {sl:.3} s against 0.13 s"
                );
            }
        }
    }
}
