//! Which augmented ESKF states a run estimates
//! ([`navfuse_core::estimators::eskf::AugmentedStates`]) and with what
//! parameters: `[filter.gnss_error]` (a first-order Gauss–Markov GNSS
//! position error) and `[filter] time_offset_state`.
//!
//! **GNSS error model** (`model = "white" | "gauss_markov" | "consider" |
//! "auto"`, default `auto`; `white` for preset `kf-gins`). A code-based
//! solution (single point, DGNSS, float) has errors
//! correlated for minutes: the slow terms of the standard-positioning error
//! budget (satellite clock/ephemeris, ionosphere, troposphere) carry ≈ 90 %
//! of the range-error variance, multipath and receiver noise the rest
//! (Kaplan & Hegarty, *Understanding GPS*, 2nd ed., Table 7.4, SA off:
//! 2.0² + 4.0² + 0.7² m² slow against 1.4² + 0.5² m² fast ≈ 0.89). Treated as
//! white, such errors make the filter overconfident by the number of fixes
//! per correlation time. A carrier-phase fixed solution has cm-level σ and
//! stays white. `auto` therefore picks the model from the data: considered
//! Gauss–Markov states when the median reported horizontal σ exceeds
//! [`CODE_GRADE_SIGMA_M`], white otherwise (RTK input runs bit-identically
//! to `white`).
//!
//! **Considered, not estimated** (`consider`; Schmidt 1966, the
//! Schmidt–Kalman filter; Simon, *Optimal State Estimation* §7.5): the GM
//! error enters the covariance, the innovation covariance and the gain of
//! the navigation states, but is never corrected (zero gain rows). The
//! navigation states then get the best gain among filters that leave the
//! GNSS error unestimated — the white filter is one — and `P` is their error
//! covariance under the model. Estimating it (`gauss_markov`) is optimal
//! when started on the truth (simulated consumer cells, oracle start: h RMS
//! 1.90 vs 2.13 m white), but from a GNSS-derived start the position error
//! and the GM error are confounded (the first fix's error *is* b₀) and single
//! seeds went 2–3× worse (robot 8.8 vs 2.7 m); considering keeps the white
//! filter's accuracy (within ±5 % on four consumer cells) with coverage
//! 0.96–0.98 instead of 0.22–0.31.
//!
//! For `gauss_markov` τ and σ come from the data when the fixes carry a velocity
//! (Doppler, independent of the position error): the structure function of
//! `d(L) = p(t+L) − p(t) − ∫v` is `2(σ_w² + σ_b²(1 − e^{−L/τ})) + var(∫v)`
//! (white σ_w, Gauss–Markov σ_b, τ), fitted over lags of 1 s to a third of
//! the record with robust (MAD) variances; its uncertainty is the
//! difference of the fits to the two halves of the record. Without velocity
//! or with too short a record the literature prior is used: σ_b = √0.9 ×
//! the median reported σ (the budget above), τ = [`PRIOR_TAU_S`]. `consider`
//! takes τ = [`CONSIDER_TAU_S`] (on 600 s records the long-lag fit was too
//! unstable to set a reported σ) and splits the reported σ into its white
//! and Gauss–Markov parts from the fix-to-fix differences
//! ([`fit_fast_part`], well determined on minutes of data): σ_b² =
//! σ_fix² − σ_w². The fixed 0.9 share had σ_b 2.01 m against the
//! simulator's 1.78 m (coverage 1.00, above issue 20's 0.99) and a white
//! part of 0.67 m against 1.16 m, which overweighted fix-to-fix changes
//! (pedestrian h RMS 30 % above white). When the differences show no
//! significant correlated part the fixes are treated as white. Without
//! GNSS velocity the 0.9 prior remains.

use crate::config::RunConfig;
use crate::error::Result;
use navfuse_core::estimators::eskf::{
    AugmentedStates, GnssErrorStates, SensitivityModel, TimeOffsetState,
};
use navfuse_core::types::{GnssFix, ImuSample};
use navfuse_core::Vec3;
use serde::{Deserialize, Serialize};

/// Median horizontal per-axis σ above which fixes are code-grade [m]:
/// carrier-phase fixed solutions report 1–3 cm, float and code solutions
/// decimetres to metres.
pub const CODE_GRADE_SIGMA_M: f64 = 0.1;
/// Share of the code-solution error variance that is slow (Kaplan & Hegarty
/// 2nd ed. Table 7.4, see the module documentation).
pub const PRIOR_SLOW_SHARE: f64 = 0.9;
/// Prior correlation time [s]: the slow error of a position solution changes
/// when the satellite set or geometry changes, and satellites rise or set
/// every few minutes at a 30-satellite constellation (Groves 2nd ed. §9.4:
/// ionosphere and troposphere residuals correlate over minutes to hours).
pub const PRIOR_TAU_S: f64 = 300.0;
/// Correlation time of the considered (not estimated) GNSS error [s]: the
/// short end of the minutes-long correlation of code-solution errors
/// (satellite geometry changes, multipath over a moving antenna). For a
/// consider state the two directions of error are not symmetric: a τ
/// longer than the truth makes the filter trust the fixes less than it
/// could (measured on the simulated consumer cells: τ 300 s raised the
/// pedestrian h RMS 21 %), a shorter one makes σ optimistic; 60 s is the
/// value the Gauss–Markov literature models of consumer receivers start
/// from, and also the simulator's consumer preset (so the generalise
/// matrix tests the method, not this value).
pub const CONSIDER_TAU_S: f64 = 60.0;
/// Correlation time [s] of the correlated part of carrier-phase (RTK)
/// fix errors under which their σ is reported ([`sensitivity_model`]).
/// Not identifiable from the fixes: at RTK noise the integrated Doppler
/// noise of the structure function (σ_v² Δt² L) exceeds the whole
/// Gauss–Markov signal (2σ_b² ≈ 4e-4 m² at 2 cm) after two or three lags.
/// Literature: L1 carrier-phase residuals on baselines up to 10 km stay
/// correlated for 115 s on average (Miller, O'Keefe & Gao, "Time
/// correlation in GNSS positioning over short baselines", J. Surveying
/// Eng. 138(1), 2012); network-RTK position errors have correlation lengths
/// of 13–17 min horizontally (Odolinski, "Temporal correlation for network
/// RTK positioning", GPS Solutions 16, 2012). The short end, 115 s, is
/// used: position errors correlate at least as long as the phase
/// residuals they come from, and a longer τ only makes the reported σ
/// larger (by at most σ_b/√(σ_b² + the filter's white part), once τ exceeds
/// the filter's own time constant of a few seconds at 1 Hz RTK).
pub const RTK_TAU_S: f64 = 115.0;

/// Initial σ of the time-offset state [s]: logging latencies of USB/serial
/// IMU–GNSS setups are up to a few hundred milliseconds.
pub const TIME_OFFSET_STD_S: f64 = 0.2;

/// `[filter.gnss_error]`.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GnssErrorCfg {
    /// `"white"`, `"gauss_markov"`, `"consider"` or `"auto"` (default).
    pub model: Option<String>,
    /// Correlation time [s] (default: from the data, else [`PRIOR_TAU_S`]).
    pub tau_s: Option<f64>,
    /// Horizontal per-axis σ [m] (default: from the data, else the prior).
    pub sigma_m: Option<f64>,
    /// Vertical σ [m] (default: from the data, else the prior).
    pub sigma_v_m: Option<f64>,
}

/// `[filter] time_offset_state`: `true`, `false` or `"auto"`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(untagged)]
pub enum BoolOrAuto {
    Bool(bool),
    Named(String),
}

/// GM parameters identified from the data, with uncertainties (half the
/// difference of the two halves' fits).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GmFit {
    pub tau_s: f64,
    pub tau_unc_s: f64,
    /// Horizontal and vertical Gauss–Markov σ [m].
    pub sigma_h_m: f64,
    pub sigma_v_m: f64,
    pub sigma_unc_m: f64,
    /// White σ, horizontal [m].
    pub white_h_m: f64,
}

/// The augmented states of a run and a sentence for the summary.
pub fn augmented_states(cfg: &RunConfig, gnss: &[GnssFix]) -> Result<(AugmentedStates, String)> {
    let g = cfg.filter.gnss_error.clone().unwrap_or_default();
    // Default `auto`: considered Gauss–Markov states on code-grade fixes,
    // white on carrier-phase ones (module documentation). The KF-GINS
    // model (preset `kf-gins`) is the plain white-noise one.
    let default_model = if cfg.filter.preset == "kf-gins" {
        "white"
    } else {
        "auto"
    };
    let model = g.model.as_deref().unwrap_or(default_model);
    let med_h = median(gnss.iter().map(|f| 0.5 * (f.std_ned.x + f.std_ned.y)));
    let med_v = median(gnss.iter().map(|f| f.std_ned.z));
    let code_grade = med_h.is_some_and(|s| s > CODE_GRADE_SIGMA_M);
    let (gm, consider) = match model {
        "white" => (false, false),
        "gauss_markov" => (true, false),
        "consider" => (true, true),
        "auto" => (code_grade, true),
        m => {
            return Err(cfg.err(format!(
                "[filter.gnss_error] model = {m:?}: expected white, gauss_markov, consider or auto"
            )))
        }
    };
    for (k, v) in [
        ("tau_s", g.tau_s),
        ("sigma_m", g.sigma_m),
        ("sigma_v_m", g.sigma_v_m),
    ] {
        if v.is_some_and(|x| !(x.is_finite() && x > 0.0)) {
            return Err(cfg.err(format!("[filter.gnss_error] {k} must be finite and > 0")));
        }
    }
    let mut notes = Vec::new();
    let gnss_error = if gm {
        // Considered states take the prior: on 600 s simulated consumer
        // records (τ 60 s) the structure-function fit gave τ 5–24 s and
        // σ_b 0.9–1.5 m against 1.78 m, too unstable to set the reported σ.
        let fit = if consider {
            None
        } else {
            fit_gauss_markov(gnss)
        };
        let prior_tau = if consider {
            CONSIDER_TAU_S
        } else {
            PRIOR_TAU_S
        };
        let (mh, mv) = (med_h.unwrap_or(1.0), med_v.unwrap_or(1.5));
        let (prior, prior_how, white_after_all) = if consider {
            code_grade_split(gnss, mh, mv, prior_tau)
        } else {
            (
                (PRIOR_SLOW_SHARE.sqrt() * mh, PRIOR_SLOW_SHARE.sqrt() * mv),
                PRIOR_HOW.to_string(),
                false,
            )
        };
        if white_after_all {
            notes.push(format!("GNSS error white ({prior_how})"));
        }
        let (tau, sh, sv, how) = match fit {
            Some(f) => (
                f.tau_s,
                f.sigma_h_m,
                f.sigma_v_m,
                format!(
                    "fitted to the fixes: tau {:.0} ± {:.0} s, sigma {:.2} ± {:.2} m (h), {:.2} m (v), white {:.2} m",
                    f.tau_s, f.tau_unc_s, f.sigma_h_m, f.sigma_unc_m, f.sigma_v_m, f.white_h_m
                ),
            ),
            None => (prior_tau, prior.0, prior.1, prior_how),
        };
        let tau = g.tau_s.unwrap_or(tau);
        let sh = g.sigma_m.unwrap_or(sh);
        let sv = g.sigma_v_m.unwrap_or(sv);
        let kind = if consider {
            "Gauss–Markov, considered (Schmidt–Kalman: in the covariance and gain, not estimated)"
        } else {
            "Gauss–Markov"
        };
        if white_after_all && g.sigma_m.is_none() && g.model.as_deref() != Some("consider") {
            None
        } else {
            notes.push(format!(
                "GNSS error {kind} (tau {tau:.0} s, sigma {sh:.2} m h / {sv:.2} m v; {how})"
            ));
            Some(GnssErrorStates {
                tau_s: tau,
                sigma_m: Vec3::new(sh, sh, sv),
                consider,
            })
        }
    } else {
        notes.push("GNSS error white".into());
        None
    };
    // Default off: with `auto` the uav RTK cells' RMS improved (tactical
    // 1.78 → 0.97 m) but their NEES rose to 900–1200 (see `model` above).
    let tos = match &cfg.filter.time_offset_state {
        None => "false".to_string(),
        Some(BoolOrAuto::Bool(b)) => b.to_string(),
        Some(BoolOrAuto::Named(s)) => s.clone(),
    };
    let time_offset = match tos.as_str() {
        "true" => true,
        "false" => false,
        // On where the course-based offset estimate is off (the platform's
        // course does not follow its heading: uav, marine).
        "auto" => {
            crate::time_offset::default_mode(cfg) == crate::time_offset::TimeOffset::None
                && cfg.filter.platform.is_some()
        }
        s => {
            return Err(cfg.err(format!(
                "[filter] time_offset_state = {s:?}: expected true, false or \"auto\""
            )))
        }
    }
    .then_some(TimeOffsetState {
        initial_s: 0.0,
        std_s: TIME_OFFSET_STD_S,
        rw_psd: 0.0,
        consider: false,
    });
    if time_offset.is_some() {
        notes.push(format!(
            "time-offset state (initial 0 ± {:.0} ms)",
            TIME_OFFSET_STD_S * 1e3
        ));
    }
    Ok((
        AugmentedStates {
            gnss_error,
            time_offset,
            nhc_mount: None,
        },
        notes.join("; "),
    ))
}

/// How the split of a code-grade fix error is found without GNSS velocity.
const PRIOR_HOW: &str = "literature prior (no GNSS velocity or record too short to fit)";

/// Split the reported σ of code-grade fixes (median `mh` per horizontal
/// axis, `mv` vertical) into its Gauss–Markov part (correlation time
/// `tau_s`): σ_b² = σ_fix² − σ_w² with σ_w from the fix-to-fix differences
/// ([`fit_fast_part`]), else the literature prior σ_b = √[`PRIOR_SLOW_SHARE`]
/// σ_fix (module documentation). Returns (σ_b h, σ_b v), how, and whether
/// the differences show no significant correlated part (then the fixes are
/// treated as white).
fn code_grade_split(gnss: &[GnssFix], mh: f64, mv: f64, tau_s: f64) -> ((f64, f64), String, bool) {
    let Some(sp) = fit_fast_part(gnss, tau_s, None) else {
        return (
            (PRIOR_SLOW_SHARE.sqrt() * mh, PRIOR_SLOW_SHARE.sqrt() * mv),
            PRIOR_HOW.to_string(),
            false,
        );
    };
    let how = format!(
        "fast part from the fix-to-fix differences: white {:.2} ± {:.2} m (h), {:.2} m (v) of the reported {mh:.2} m; {}",
        sp.white_h_m,
        sp.white_h_unc_m,
        sp.white_v_m,
        if sp.correlated {
            "correlated part significant"
        } else {
            "no significant correlated part: white"
        }
    );
    (
        (
            (mh * mh - sp.white_h_m.powi(2)).max(0.0).sqrt(),
            (mv * mv - sp.white_v_m.powi(2)).max(0.0).sqrt(),
        ),
        how,
        !sp.correlated,
    )
}

/// Median horizontal per-axis and vertical reported σ of `gnss` [m].
fn median_sigma(gnss: &[GnssFix]) -> Option<(f64, f64)> {
    let mh = median(gnss.iter().map(|f| 0.5 * (f.std_ned.x + f.std_ned.y)))?;
    let mv = median(gnss.iter().map(|f| f.std_ned.z))?;
    Some((mh, mv))
}

/// The σ models of a white-gain filter ([`sensitivity_model`],
/// [`white_gain_sigma_model`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SigmaModels {
    /// The correlated fix error the forward σ is reported under
    /// ([`Eskf::start_sensitivity`](navfuse_core::estimators::eskf::Eskf::start_sensitivity);
    /// `None`: the white model).
    pub forward: Option<SensitivityModel>,
    /// The one the smoothed σ's correlated part is taken under when it is
    /// not `forward`'s ([`Eskf::start_smoother_sensitivity`](navfuse_core::estimators::eskf::Eskf::start_smoother_sensitivity)):
    /// the upper end of σ_b when the data bound it only from below
    /// ([`SMOOTHER_SPLIT_Z`]).
    pub smoothed: Option<SensitivityModel>,
    /// How they were chosen (for `summary.json`).
    pub how: String,
}

impl SigmaModels {
    fn white(how: impl Into<String>) -> Self {
        SigmaModels {
            how: how.into(),
            ..Default::default()
        }
    }
}

/// z of the lower confidence bound of σ_w² below which the split is taken
/// as uninformative for the smoother (two-sided 95 %, the level the σ is
/// judged at): when `σ_w² − z·δ(σ_w²) ≤ 0` the data allow every σ_b up to
/// σ_fix, and the smoothed σ takes σ_b = σ_fix ([`SigmaModels::smoothed`]).
/// (On σ_w², which the split estimates linearly in the variance of the
/// differences; the delta-method interval of σ_w breaks down near 0.)
/// The same upper end is taken, whatever the z, when the split had to use
/// every fix interval (too few quiet ones, [`crate::fix_dynamics`]): the
/// trajectory's term between fixes then only raises σ_w, so the fit bounds
/// σ_b from below and not from above.
pub const SMOOTHER_SPLIT_Z: f64 = 1.96;

/// The correlated GNSS error model under which a white-gain filter reports
/// σ ([`navfuse_core::estimators::eskf::Eskf::start_sensitivity`]; Gelb,
/// *Applied Optimal Estimation* §7.2): for carrier-phase (RTK) fixes the
/// filter keeps its white model — the consider states that make σ honest
/// cost 27–38 % of pedestrian accuracy — and the σ it reports is the
/// covariance of its error under white + Gauss–Markov fix errors. The split
/// comes from the data ([`fit_fast_part`]: σ_b² = σ_fix² − σ_w²), τ is
/// [`RTK_TAU_S`] (or `[filter.gnss_error] tau_s`). `forward` is `None` (σ
/// from the white model, as before) unless the model is `auto` on fixes
/// that are not code-grade, carry velocities, and the split finds a
/// correlated part; `smoothed` is set on the same fixes where the split
/// bounds σ_b only from below ([`SigmaModels::smoothed`]), whatever
/// `forward` is; both `None` without GNSS velocity.
/// (Code-grade fixes get considered states in `navfuse run`,
/// [`augmented_states`]; a filter that must keep the white gain uses
/// [`white_gain_sigma_model`].)
pub fn sensitivity_model(
    cfg: &RunConfig,
    gnss: &[GnssFix],
    imu: Option<&[ImuSample]>,
) -> SigmaModels {
    let g = cfg.filter.gnss_error.clone().unwrap_or_default();
    let model = g
        .model
        .as_deref()
        .unwrap_or(if cfg.filter.preset == "kf-gins" {
            "white"
        } else {
            "auto"
        });
    match median_sigma(gnss) {
        Some((mh, mv)) if model == "auto" && mh <= CODE_GRADE_SIGMA_M => {
            let quiet = imu.map(|i| crate::fix_dynamics::quiet_pairs(i, gnss));
            let tau = g.tau_s.unwrap_or(RTK_TAU_S);
            carrier_phase_sensitivity(gnss, quiet.as_deref(), tau, mh, mv)
        }
        _ => SigmaModels::default(),
    }
}

/// The σ model of a filter that keeps the white-noise GNSS gain whatever
/// the fixes (`navfuse kf-gins` with a platform profile, `navfuse live`):
/// the correlated fix error `navfuse run` models by default (`auto`) on the
/// same fixes, carried as a sensitivity covariance (Gelb §7.2), so only the
/// reported σ changes, never a solution.
/// - carrier-phase fixes: as [`sensitivity_model`] (τ [`RTK_TAU_S`]);
/// - code-grade fixes: the Gauss–Markov error `run` considers
///   ([`augmented_states`]): τ [`CONSIDER_TAU_S`], σ_b from the
///   fix-to-fix differences or the literature prior, none (white) when the
///   differences show no significant correlated part. `run`'s consider
///   states also change its gain; here the white gain is kept (KF-GINS's),
///   and the σ is that gain's error covariance under the same model.
pub fn white_gain_sigma_model(gnss: &[GnssFix], imu: Option<&[ImuSample]>) -> SigmaModels {
    let Some((mh, mv)) = median_sigma(gnss) else {
        return SigmaModels::default();
    };
    if mh <= CODE_GRADE_SIGMA_M {
        let quiet = imu.map(|i| crate::fix_dynamics::quiet_pairs(i, gnss));
        return carrier_phase_sensitivity(gnss, quiet.as_deref(), RTK_TAU_S, mh, mv);
    }
    let ((sh, sv), how, white) = code_grade_split(gnss, mh, mv, CONSIDER_TAU_S);
    if white {
        return SigmaModels::white(format!("σ from the white model ({how})"));
    }
    SigmaModels {
        forward: Some(SensitivityModel {
            tau_s: CONSIDER_TAU_S,
            sigma_m: Vec3::new(sh, sh, sv),
        }),
        smoothed: None,
        how: format!(
            "σ reported under a correlated fix error (white gain kept; Gauss–Markov tau {CONSIDER_TAU_S:.0} s, sigma {sh:.2} m h / {sv:.2} m v; {how})"
        ),
    }
}

/// [`sensitivity_model`] for carrier-phase fixes (median σ `mh`, `mv`).
fn carrier_phase_sensitivity(
    gnss: &[GnssFix],
    quiet: Option<&[bool]>,
    tau: f64,
    mh: f64,
    mv: f64,
) -> SigmaModels {
    // The quiet pairs when there are enough of them (a platform that never
    // stops manoeuvring — a walker's steps — or a gyro bias above ~0.5 °/s
    // leaves too few), else every pair: σ_w then includes the trajectory's
    // term and σ_b is a lower bound, as the note below says.
    let fit = quiet
        .and_then(|q| fit_fast_part(gnss, tau, Some(q)).map(|f| (f, true)))
        .or_else(|| fit_fast_part(gnss, tau, None).map(|f| (f, false)));
    let Some((sp, quiet_only)) = fit else {
        return SigmaModels::white(
            "σ from the white model (no GNSS velocity or too few fixes to split the fix error)",
        );
    };
    // The point estimate of the split, significant or not: the test of
    // `fit_fast_part` decides the *gain* model (consider states change the
    // solution); for the reported σ, treating an insignificant correlated
    // part as zero would bias σ low. Unmodelled differences between the
    // fixes' positions and velocities (dynamics between fixes, velocity
    // noise above the reported) only raise σ_w, so σ_b is a lower bound.
    let sh = (mh * mh - sp.white_h_m.powi(2)).max(0.0).sqrt();
    let sv = (mv * mv - sp.white_v_m.powi(2)).max(0.0).sqrt();
    // The smoother averages whatever the split calls white, so it takes the
    // upper end of σ_b where the data bound σ_b only from below
    // ([`SMOOTHER_SPLIT_Z`]); the forward σ keeps the point estimate.
    // σ_w²'s interval (linear in var d, so its normal interval holds down
    // to 0, unlike σ_w's); δ(σ_w²) as `fit_fast_part` converted it.
    let sw2_se = 2.0 * sp.white_h_m.max(1e-3) * sp.white_h_unc_m;
    let which = if quiet_only {
        "quiet intervals"
    } else {
        "all intervals"
    };
    let unbounded = !quiet_only || sp.white_h_m.powi(2) - SMOOTHER_SPLIT_Z * sw2_se <= 0.0;
    let smoothed = unbounded.then_some(SensitivityModel {
        tau_s: tau,
        sigma_m: Vec3::new(mh, mh, mv),
    });
    let smoothed_how = if unbounded {
        format!(
            "; smoothed σ under the upper end sigma {mh:.3} m h / {mv:.3} m v (the split bounds σ_b only from below)"
        )
    } else {
        String::new()
    };
    if sh <= 0.0 && sv <= 0.0 {
        return SigmaModels {
            forward: None,
            smoothed,
            how: format!(
                "σ from the white model (fix-to-fix differences, {which}: white {:.3} ± {:.3} m of the reported {mh:.3} m, no correlated part){smoothed_how}",
                sp.white_h_m, sp.white_h_unc_m
            ),
        };
    }
    SigmaModels {
        forward: Some(SensitivityModel {
            tau_s: tau,
            sigma_m: Vec3::new(sh, sh, sv),
        }),
        smoothed,
        how: format!(
            "σ reported under a correlated fix error (white gain kept; Gauss–Markov tau {tau:.0} s, sigma {sh:.3} m h / {sv:.3} m v; white {:.3} ± {:.3} m of the reported {mh:.3} m from the fix-to-fix differences, {which}){smoothed_how}",
            sp.white_h_m, sp.white_h_unc_m
        ),
    }
}

/// The fast (white) part of code-grade fix errors, from the fix-to-fix
/// differences (see [`fit_fast_part`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FastPart {
    /// White σ per horizontal axis and vertical [m].
    pub white_h_m: f64,
    pub white_v_m: f64,
    /// 1-σ uncertainty of `white_h_m` [m].
    pub white_h_unc_m: f64,
    /// Whether the correlated part is significant: the lag-one variance is
    /// below the all-white value `2σ_fix² + var(∫v)` by more than
    /// [`FAST_PART_Z`] standard errors.
    pub correlated: bool,
}

/// One-sided z of the white-vs-correlated test of [`fit_fast_part`]
/// (3.09: 0.1 % false "correlated" on white fixes).
pub const FAST_PART_Z: f64 = 3.09;

/// Relative standard error of a (1.4826 MAD)² variance estimate from `n`
/// Gaussian samples: the MAD's asymptotic efficiency is 0.37 (Huber &
/// Ronchetti, *Robust Statistics* §5.1), so SE(var)/var ≈ √(2 / (0.37 n)).
fn mad_var_rel_se(n: usize) -> f64 {
    (2.0 / (0.37 * n as f64)).sqrt()
}

/// Split the reported fix σ into its fast (white) and slow (Gauss–Markov)
/// parts from the data. Between consecutive fixes `k, k+1` (interval `Δ`,
/// GNSS velocity `v`, which a receiver derives from Doppler, independent of
/// the position error) the difference `d = p_{k+1} − p_k − (v_k + v_{k+1}) Δ/2`
/// has per axis
/// `var d = 2σ_w² + 2σ_b²(1 − e^{−Δ/τ}) + σ_v²Δ²/2`
/// (white σ_w, Gauss–Markov σ_b with correlation time τ, velocity noise σ_v;
/// the trapezoid's error of a smooth trajectory is second order in Δ).
/// With `σ_b² = σ_fix² − σ_w²` this gives
/// `σ_w² = (var d − 2σ_fix²c − σ_v²Δ²/2) / (2(1 − c))`, `c = 1 − e^{−Δ/τ}`.
/// `var d` is the robust (MAD) variance, so rare multipath jumps do not
/// inflate it; unlike the long-lag structure function of
/// [`fit_gauss_markov`] it uses every epoch and is well determined on
/// minutes of data (≈ 7 % SE of the variance from 600 fixes × 2 axes).
/// `None` with fewer than 60 consecutive fix pairs with velocity.
///
/// `quiet` (one flag per consecutive pair, [`crate::fix_dynamics::quiet_pairs`]):
/// only the pairs whose trajectory the trapezoid follows are used. Without
/// it every pair is, and the trajectory's own term (0.03–0.09 m RMS per
/// axis at 1 Hz on manoeuvring platforms) raises σ_w — harmless against
/// metre-level code fixes, not against centimetre carrier-phase ones.
pub fn fit_fast_part(gnss: &[GnssFix], tau_s: f64, quiet: Option<&[bool]>) -> Option<FastPart> {
    let dt = median_interval(gnss.iter().map(|f| f.t))?;
    let (mut dh, mut dv, mut sf_h, mut sf_v, mut sv2) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (k, w) in gnss.windows(2).enumerate() {
        let (a, b) = (&w[0], &w[1]);
        let h = b.t - a.t;
        if quiet.is_some_and(|q| !q.get(k).copied().unwrap_or(false)) {
            continue;
        }
        let (Some(va), Some(vb), Some(sa), Some(sb)) = (a.v_n, b.v_n, a.std_v_n, b.std_v_n) else {
            continue;
        };
        if !(h > 0.0 && h < 1.5 * dt) {
            continue;
        }
        let d = a.ned_to(b) - (va + vb) * (0.5 * h);
        if !d.iter().all(|x| x.is_finite()) {
            continue;
        }
        dh.push(d.x);
        dh.push(d.y);
        dv.push(d.z);
        sf_h.push(0.25 * (a.std_ned.x + a.std_ned.y + b.std_ned.x + b.std_ned.y));
        sf_v.push(0.5 * (a.std_ned.z + b.std_ned.z));
        // Trapezoid of two independent velocity errors: (h/2)² (σ_a² + σ_b²).
        sv2.push(0.25 * h * h * (sa.norm_squared() + sb.norm_squared()) / 3.0);
    }
    if dv.len() < 60 {
        return None;
    }
    let c = 1.0 - (-dt / tau_s).exp();
    let iv = median(sv2.into_iter())?;
    let split = |d: Vec<f64>, sf: f64| {
        let n = d.len();
        let var_d = robust_var(d);
        let sw2 = ((var_d - 2.0 * sf * sf * c - iv) / (2.0 * (1.0 - c))).clamp(0.0, sf * sf);
        let se_var = var_d * mad_var_rel_se(n);
        // All-white fixes: var d = 2σ_fix² + iv.
        let white_var = 2.0 * sf * sf + iv;
        let correlated = var_d < white_var - FAST_PART_Z * white_var * mad_var_rel_se(n);
        let sw = sw2.sqrt();
        // δσ_w ≈ δ(σ_w²) / (2σ_w), δ(σ_w²) = δ(var d) / (2(1 − c)).
        let unc = se_var / (2.0 * (1.0 - c)) / (2.0 * sw.max(1e-3));
        (sw, unc, correlated)
    };
    let (sfh, sfv) = (median(sf_h.into_iter())?, median(sf_v.into_iter())?);
    let (wh, unc, corr_h) = split(dh, sfh);
    let (wv, _, _) = split(dv, sfv);
    Some(FastPart {
        white_h_m: wh,
        white_v_m: wv,
        white_h_unc_m: unc,
        correlated: corr_h,
    })
}

fn median(it: impl Iterator<Item = f64>) -> Option<f64> {
    let mut v: Vec<f64> = it.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

/// Robust variance: (1.4826 MAD)².
fn robust_var(mut v: Vec<f64>) -> f64 {
    let m = median(v.iter().copied()).unwrap_or(0.0);
    for x in &mut v {
        *x = (*x - m).abs();
    }
    let mad = median(v.into_iter()).unwrap_or(0.0);
    (1.4826 * mad).powi(2)
}

/// Lags [s] of the structure function.
const LAGS_S: [f64; 16] = [
    1.0, 2.0, 3.0, 5.0, 8.0, 12.0, 20.0, 30.0, 45.0, 60.0, 90.0, 120.0, 180.0, 240.0, 360.0, 480.0,
];

/// Fit τ, σ_b, σ_w to fixes with velocity (see the module documentation);
/// `None` when fewer than 120 fixes with velocity or no lag ≥ 30 s fits.
pub fn fit_gauss_markov(gnss: &[GnssFix]) -> Option<GmFit> {
    let fixes: Vec<&GnssFix> = gnss
        .iter()
        .filter(|f| f.v_n.is_some() && f.std_v_n.is_some())
        .collect();
    if fixes.len() < 120 {
        return None;
    }
    let n = fixes.len();
    let (a, b) = (fit_span(&fixes[..n / 2]), fit_span(&fixes[n / 2..]));
    let all = fit_span(&fixes)?;
    let (tau_unc, sig_unc) = match (a, b) {
        (Some(a), Some(b)) => (
            0.5 * (a.tau_s - b.tau_s).abs(),
            0.5 * (a.sigma_h_m - b.sigma_h_m).abs(),
        ),
        _ => (f64::INFINITY, f64::INFINITY),
    };
    Some(GmFit {
        tau_unc_s: tau_unc,
        sigma_unc_m: sig_unc,
        ..all
    })
}

/// Median interval of the stamps `t` [s]; `None` when it is not positive.
fn median_interval(t: impl Iterator<Item = f64>) -> Option<f64> {
    let t: Vec<f64> = t.collect();
    let dt = median(t.windows(2).map(|w| w[1] - w[0]))?;
    (dt.is_finite() && dt > 0.0).then_some(dt)
}

fn fit_span(fixes: &[&GnssFix]) -> Option<GmFit> {
    let n = fixes.len();
    let dt = median_interval(fixes.iter().map(|f| f.t))?;
    let f0 = fixes[0];
    let pos: Vec<Vec3> = fixes.iter().map(|f| f0.ned_to(f)).collect();
    let v: Vec<Vec3> = fixes.iter().map(|f| f.v_n.unwrap_or_default()).collect();
    let sv = median(
        fixes
            .iter()
            .filter_map(|f| f.std_v_n)
            .map(|s| s.norm() / 3f64.sqrt()),
    )?;
    // Cumulative trapezoid integral of v; a gap breaks continuity.
    let mut cum = vec![Vec3::zeros(); n];
    let mut seg = vec![0usize; n];
    for k in 1..n {
        let h = fixes[k].t - fixes[k - 1].t;
        seg[k] = seg[k - 1] + usize::from(h > 1.5 * dt);
        cum[k] = cum[k - 1] + (v[k] + v[k - 1]) * (0.5 * h);
    }
    let span = fixes[n - 1].t - fixes[0].t;
    let mut pts = Vec::new(); // (lag s, γ_h, γ_v)
    for &lag in LAGS_S.iter().filter(|l| **l <= span / 3.0) {
        let l = (lag / dt).round().max(1.0) as usize;
        let (mut dh, mut dv) = (Vec::new(), Vec::new());
        for k in 0..n.saturating_sub(l) {
            if seg[k + l] != seg[k] {
                continue;
            }
            let d = (pos[k + l] - pos[k]) - (cum[k + l] - cum[k]);
            dh.push(d.x);
            dh.push(d.y);
            dv.push(d.z);
        }
        if dh.len() < 60 {
            continue;
        }
        let int_var = sv * sv * dt * dt * (l as f64 - 0.5);
        let gh = 0.5 * (robust_var(dh) - int_var);
        let gv = 0.5 * (robust_var(dv) - int_var);
        pts.push((l as f64 * dt, gh.max(0.0), gv.max(0.0)));
    }
    if pts.iter().filter(|p| p.0 >= 30.0).count() < 2 {
        return None;
    }
    // γ(L) = a + c (1 − e^{−L/τ}): τ on a log grid, (a, c) by weighted LS
    // (relative errors), the τ with the least residual.
    let mut best: Option<(f64, f64, f64, f64)> = None; // (ssr, τ, a, c)
    for i in 0..60 {
        let tau = 3.0 * (1000.0f64 / 3.0).powf(i as f64 / 59.0);
        let Some((a, c, ssr)) = wls(&pts, tau, |p| p.1) else {
            continue;
        };
        if best.is_none_or(|b| ssr < b.0) {
            best = Some((ssr, tau, a, c));
        }
    }
    let (_, tau, a, c) = best?;
    let (_, cv, _) = wls(&pts, tau, |p| p.2)?;
    if c <= 0.0 {
        return None;
    }
    Some(GmFit {
        tau_s: tau,
        tau_unc_s: f64::NAN,
        sigma_h_m: c.sqrt(),
        sigma_v_m: cv.max(0.0).sqrt(),
        sigma_unc_m: f64::NAN,
        white_h_m: a.max(0.0).sqrt(),
    })
}

/// Weighted least squares of `y = a + c (1 − e^{−L/τ})` with weights
/// `1/y²`, `a, c ≥ 0`: (a, c, weighted SSR).
fn wls(
    pts: &[(f64, f64, f64)],
    tau: f64,
    y: impl Fn(&(f64, f64, f64)) -> f64,
) -> Option<(f64, f64, f64)> {
    let (mut s11, mut s12, mut s22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let w_of = |yv: f64| 1.0 / (yv * yv).max(1e-6);
    for p in pts {
        let (x, yv) = (1.0 - (-p.0 / tau).exp(), y(p));
        let w = w_of(yv);
        s11 += w;
        s12 += w * x;
        s22 += w * x * x;
        b1 += w * yv;
        b2 += w * x * yv;
    }
    let det = s11 * s22 - s12 * s12;
    let (mut a, mut c) = if det.abs() > 1e-12 {
        ((b1 * s22 - b2 * s12) / det, (s11 * b2 - s12 * b1) / det)
    } else {
        return None;
    };
    if a < 0.0 {
        a = 0.0;
        c = b2 / s22;
    }
    if c < 0.0 {
        c = 0.0;
        a = b1 / s11;
    }
    let ssr = pts
        .iter()
        .map(|p| {
            let r = y(p) - a - c * (1.0 - (-p.0 / tau).exp());
            w_of(y(p)) * r * r
        })
        .sum();
    Some((a, c, ssr))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight 10 m/s track with white 1 m + GM (σ 2 m, τ 60 s) position
    /// errors and 0.1 m/s velocity noise, 1 Hz for 1800 s.
    fn fixes(seed: u64) -> Vec<GnssFix> {
        fixes_with(seed, 1.0, 2.0)
    }

    /// [`fixes`] with white σ `sw` and Gauss–Markov σ `sg` (τ 60 s).
    fn fixes_with(seed: u64, sw: f64, sg: f64) -> Vec<GnssFix> {
        fixes_vel(seed, sw, sg, 0.1)
    }

    /// [`fixes_with`] with velocity noise σ `sv` [m/s].
    fn fixes_vel(seed: u64, sw: f64, sg: f64, sv: f64) -> Vec<GnssFix> {
        let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut normal = move || {
            // Sum of 12 uniforms − 6 (Irwin–Hall): N(0, 1) to a good approximation.
            (0..12)
                .map(|_| {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    (s >> 11) as f64 / (1u64 << 53) as f64
                })
                .sum::<f64>()
                - 6.0
        };
        let tau = 60.0;
        let phi = (-1.0f64 / tau).exp();
        let mut b = Vec3::new(normal(), normal(), normal()) * sg;
        let (rm, rn) = navfuse_core::earth::radii(0.7);
        (0..1800)
            .map(|k| {
                let t = k as f64;
                let e = b + Vec3::new(normal(), normal(), normal()) * sw;
                b = b * phi
                    + Vec3::new(normal(), normal(), normal()) * (sg * (1.0 - phi * phi).sqrt());
                GnssFix {
                    t,
                    lat: 0.7 + (10.0 * t + e.x) / rm,
                    lon: 0.1 + e.y / (rn * 0.7f64.cos()),
                    h: -e.z,
                    std_ned: Vec3::repeat((sw * sw + sg * sg).sqrt()),
                    v_n: Some(
                        Vec3::new(10.0, 0.0, 0.0) + Vec3::new(normal(), normal(), normal()) * sv,
                    ),
                    std_v_n: Some(Vec3::repeat(sv)),
                    ..Default::default()
                }
            })
            .collect()
    }

    #[test]
    fn structure_function_recovers_tau_and_sigma() {
        for seed in 1..4 {
            let f = fit_gauss_markov(&fixes(seed)).expect("fit");
            assert!(
                (30.0..120.0).contains(&f.tau_s) && (1.4..2.6).contains(&f.sigma_h_m),
                "seed {seed}: {f:?}"
            );
            assert!(f.tau_unc_s.is_finite() && f.sigma_unc_m.is_finite());
        }
    }

    #[test]
    fn too_few_fixes_or_no_velocity_gives_no_fit() {
        let mut f = fixes(7);
        assert!(fit_gauss_markov(&f[..100]).is_none());
        for x in &mut f {
            x.v_n = None;
        }
        assert!(fit_gauss_markov(&f).is_none());
    }

    /// Written before the run: the fast part of white 1 m + Gauss–Markov
    /// 2 m fixes is recovered within 0.15 m (≈ 3σ of 1,800 fixes) and the
    /// correlated part is significant; all-white fixes (σ 2.24 m, the same
    /// total) are found white.
    #[test]
    fn fast_part_of_the_fix_error_is_recovered() {
        for seed in 1..4 {
            let f = fit_fast_part(&fixes_with(seed, 1.0, 2.0), 60.0, None).expect("fit");
            assert!(
                (f.white_h_m - 1.0).abs() < 0.15 && f.correlated,
                "seed {seed}: {f:?}"
            );
            let w = fit_fast_part(&fixes_with(seed, 5f64.sqrt(), 0.0), 60.0, None).expect("fit");
            assert!(
                (w.white_h_m - 5f64.sqrt()).abs() < 0.2 && !w.correlated,
                "seed {seed}: {w:?}"
            );
        }
        assert!(fit_fast_part(&fixes(1)[..50], 60.0, None).is_none());
    }

    fn run_cfg(extra: &str) -> RunConfig {
        toml::from_str(&format!("[input]\nimu = \"i\"\ngnss = \"g\"\n{extra}")).expect("config")
    }

    /// Written before the run: RTK-grade fixes (white 1.4 cm + Gauss–Markov
    /// 1.4 cm, 2 cm/s velocity noise) get a sensitivity model whose σ_b is
    /// within 0.5 cm of the truth (±3σ of 1,800 fixes) and τ = RTK_TAU_S;
    /// code-grade fixes, fixes without velocity, `model = "white"` and the
    /// KF-GINS preset get none.
    #[test]
    fn rtk_fixes_get_a_sensitivity_model_from_the_data() {
        let s = 0.02 / 2f64.sqrt();
        let auto = run_cfg("");
        for seed in 1..4 {
            let f = fixes_vel(seed, s, s, 0.02);
            let SigmaModels {
                forward: m, how, ..
            } = sensitivity_model(&auto, &f, None);
            let m = m.unwrap_or_else(|| panic!("seed {seed}: none ({how})"));
            assert!(
                (m.sigma_m.x - s).abs() < 0.005 && m.tau_s == RTK_TAU_S,
                "seed {seed}: {m:?}"
            );
        }
        let f = fixes_vel(1, s, s, 0.02);
        let mut no_vel = f.clone();
        for x in &mut no_vel {
            x.v_n = None;
        }
        assert!(sensitivity_model(&auto, &no_vel, None).forward.is_none());
        assert!(sensitivity_model(&auto, &fixes(1), None).forward.is_none());
        let white = run_cfg("[filter.gnss_error]\nmodel = \"white\"\n");
        assert!(sensitivity_model(&white, &f, None).forward.is_none());
        let kf = run_cfg("[filter]\npreset = \"kf-gins\"\n");
        assert!(sensitivity_model(&kf, &f, None).forward.is_none());
    }

    /// The smoother's own model ([`SigmaModels::smoothed`]), written before
    /// the run: on half-white RTK fixes split on quiet intervals it is
    /// `None` (the forward model serves); the same fixes split on every
    /// interval (no quiet flags: σ_b only a lower bound) get σ_b = σ_fix
    /// for the smoother; all-white fixes keep the white model on quiet
    /// intervals (σ_w well determined) and get σ_fix for the smoother on
    /// every interval; on all-correlated quiet fixes σ_w²'s 95 % interval
    /// reaches 0 (a 97.5 % event for σ_w = 0; one seed), so they get σ_fix
    /// too. The forward model never changes with it.
    #[test]
    fn smoother_takes_the_upper_end_only_where_the_split_is_unbounded() {
        let s = 0.02 / 2f64.sqrt();
        let split = |f: &[GnssFix], quiet: bool| {
            let (mh, mv) = median_sigma(f).unwrap();
            let q = vec![true; f.len() - 1];
            let m = carrier_phase_sensitivity(f, quiet.then_some(&q[..]), RTK_TAU_S, mh, mv);
            (m, mh, mv)
        };
        let half = fixes_vel(1, s, s, 0.02);
        let (q, _, _) = split(&half, true);
        assert!(q.forward.is_some() && q.smoothed.is_none(), "{q:?}");
        let (a, mh, mv) = split(&half, false);
        assert_eq!(a.forward, q.forward);
        assert_eq!(
            a.smoothed.map(|m| (m.tau_s, m.sigma_m)),
            Some((RTK_TAU_S, Vec3::new(mh, mh, mv)))
        );
        let white = fixes_vel(2, 0.02, 0.0, 0.02);
        let (w, _, _) = split(&white, true);
        assert!(w.forward.is_none() && w.smoothed.is_none(), "{w:?}");
        let (w, mh, _) = split(&white, false);
        assert!(w.forward.is_none(), "{w:?}");
        assert_eq!(w.smoothed.map(|m| m.sigma_m.x), Some(mh), "{w:?}");
        let corr = fixes_vel(3, 0.0, 0.02, 0.02);
        let (c, mh, _) = split(&corr, true);
        assert!(c.forward.is_some(), "{c:?}");
        assert_eq!(c.smoothed.map(|m| m.sigma_m.x), Some(mh), "{c:?}");
    }

    /// `kf-gins` with a platform and `live` report σ under the model `run`
    /// uses on the same fixes: the sensitivity model on RTK fixes, the
    /// considered Gauss–Markov τ and σ on code-grade fixes (with and without
    /// velocity); none on fixes whose differences show no correlated part,
    /// as `run` treats them as white.
    #[test]
    fn white_gain_sigma_model_is_the_model_run_uses() {
        let auto = run_cfg("");
        let s = 0.02 / 2f64.sqrt();
        let rtk = fixes_vel(1, s, s, 0.02);
        let m = white_gain_sigma_model(&rtk, None)
            .forward
            .expect("RTK: sensitivity");
        assert_eq!(Some(m), sensitivity_model(&auto, &rtk, None).forward);
        let mut no_vel = fixes(2);
        for x in &mut no_vel {
            x.v_n = None;
        }
        for code in [fixes(1), no_vel] {
            let m = white_gain_sigma_model(&code, None)
                .forward
                .expect("code-grade: correlated");
            let g = augmented_states(&auto, &code)
                .unwrap()
                .0
                .gnss_error
                .unwrap();
            assert!(g.consider);
            assert_eq!((m.tau_s, m.sigma_m), (g.tau_s, g.sigma_m));
            assert!(sensitivity_model(&auto, &code, None).forward.is_none());
        }
        let white = fixes_with(3, 2.24, 0.0);
        assert!(augmented_states(&auto, &white)
            .unwrap()
            .0
            .gnss_error
            .is_none());
        assert!(white_gain_sigma_model(&white, None).forward.is_none());
    }
}
