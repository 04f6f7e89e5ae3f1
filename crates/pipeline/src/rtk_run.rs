//! RTK/INS in `navfuse run` (`[filter] coupling = "rtk"`, issue 15): the
//! rover's raw records (`[input] gnss`, RINEX + `nav` or `.ubx`, with the
//! second-frequency records — GPS L2, Galileo E5b, BeiDou B2I — of a
//! RINEX 2/3 file or a dual-frequency u-blox log's RXM-RAWX,
//! [`navfuse_io::ubx_gnss`]) and a base station's (`[input] base`,
//! `base_position`, [`crate::base_station`]) through
//! [`Eskf::rtk_update`] after the alignment, which used the rover's
//! single-point fixes as the tight path does.
//!
//! Per rover epoch (true time = stamp − receiver clock bias, the median
//! pseudorange residual at the INS antenna, [`receiver_clock_bias_m`];
//! applied after the IMU sample nearest to it):
//! - paired with a base epoch within [`crate::base_station::MAX_AGE_S`]:
//!   the RTK update; the solution written for that IMU sample is the
//!   **fixed** one when the validation passed (its σ from the conditional
//!   covariance `P − P_xâ Q⁻¹ P_âx`), else the float filter's;
//!   between epochs the fixed solution is carried by the INS: the float
//!   filter's motion plus the epoch's fixed − float offset, σ² = the
//!   fixed σ² + the float σ² grown since the epoch (written with Q = 1
//!   until the coasting time passes); after a float epoch the float filter;
//! - unpaired: **no GNSS update** that epoch (the RTK filter has no
//!   receiver clock states, so the tight pseudorange update cannot run;
//!   a code-only single-point update is not made), counted.
//!
//! `.pos` quality ([`RtkEpochOut`], [`crate::pos_out`]): 1 fixed, 2 float
//! after an RTK epoch, until the coasting time passes; 7 dead reckoning
//! after it or before the first RTK epoch. Q 5 (single) is not written:
//! no code-only solution is made in this mode. The ratio column holds the
//! epoch's ratio test value, age the rover − base time difference.
//!
//! The RTS smoother is refused (its records do not carry the ambiguity
//! block, [`navfuse_core::estimators::eskf`] `rtk` module). Every RTK
//! epoch's fix decision is a `rtk_fix` row of the run journal
//! (`solution.innovations.csv`, [`crate::outputs::write_innovations_rtk`]:
//! ambiguities offered / fixed, ratio, success rate, decision and reason,
//! resets), and counted in summary.json `rtk`.

use crate::base_station::{pair_epochs, BasePosition, BaseStation, Pairing, MAX_AGE_S};
use crate::config::RunConfig;
use crate::error::{PipelineError, Result};
use crate::raw_input::{sat_id, RawInput};
use crate::yaw_bank::Member;
use navfuse_core::estimators::eskf::{
    receiver_clock_bias_m, Eskf, RtkConfig, RtkSatCounts, RtkSolution, RtkStats,
};
use navfuse_core::geodesy::{geodetic_to_ecef, Geodetic};
use navfuse_core::gnss::raw::{GnssSystem, RawEpoch, RawSat};
use navfuse_core::gnss::C_LIGHT;
use navfuse_core::Vec3;
use serde::Serialize;
use std::collections::BTreeMap;

/// The `[input] base` / `base_position` / `[filter] coupling = "rtk"`
/// rules that need no file: RTK needs a base, a base needs RTK, the
/// position must parse.
pub fn check_keys(cfg: &RunConfig, rtk: bool) -> Result<()> {
    let i = &cfg.input;
    if rtk && i.base.is_none() {
        return Err(cfg.err(
            "[filter] coupling = \"rtk\" needs [input] base = \"base.obs\" (the base \
             station's RINEX observations, with [input] nav, or its .ubx log)",
        ));
    }
    if !rtk && (i.base.is_some() || i.base_position.is_some()) {
        return Err(cfg.err(
            "[input] base / base_position are for [filter] coupling = \"rtk\" \
             (remove them or set coupling = \"rtk\")",
        ));
    }
    if let Some(p) = &i.base_position {
        p.spec().map_err(|e| cfg.err(format!("[input] {e}")))?;
    }
    Ok(())
}

/// Read `[input] base` (with the GPS L2 records) and settle its position.
pub fn load_base_cfg(
    cfg: &RunConfig,
    rel: &dyn Fn(&str) -> std::path::PathBuf,
    nav: &[std::path::PathBuf],
) -> Result<BaseStation> {
    let path = rel(cfg.input.base.as_deref().unwrap_or_default());
    let spec = match &cfg.input.base_position {
        Some(p) => p.spec().map_err(|e| cfg.err(format!("[input] {e}")))?,
        None => crate::base_station::BasePositionSpec::Auto,
    };
    crate::base_station::load_base_with(&path, nav, spec, true).map_err(|e| match e {
        PipelineError::Input(m) => {
            PipelineError::Input(format!("{}: [input] base: {m}", cfg.name()))
        }
        e => e,
    })
}

/// Put the base's record times on the rover's time base: the time of week
/// when the IMU file has only that (the rule [`crate::input`] applies to
/// the rover's records).
pub fn base_on_rover_time(b: &mut BaseStation, imu_t0: f64) {
    const WEEK_S: f64 = 604_800.0;
    if imu_t0 < WEEK_S {
        for x in b.raw.records.iter_mut() {
            x.obs.t = navfuse_io::time::week_tow(x.obs.t).1;
        }
    }
}

/// The records of `records` as epochs (time-ordered, grouped by time tag).
pub fn epochs_of(records: &[RawSat]) -> Vec<RawEpoch> {
    let mut out: Vec<RawEpoch> = Vec::new();
    for r in records {
        if out.last().is_none_or(|e| e.t != r.obs.t) {
            out.push(RawEpoch::new(r.obs.t));
        }
        if let Some(e) = out.last_mut() {
            e.push(*r);
        }
    }
    out
}

/// Everything of a run's RTK input.
#[derive(Clone, Debug)]
pub struct RtkSpan {
    pub rover: Vec<RawEpoch>,
    pub base: Vec<RawEpoch>,
    pub pairing: Pairing,
    pub base_position: BasePosition,
    pub base_e: Vec3,
    pub base_warnings: Vec<String>,
    pub base_file: String,
    pub rover_epochs_read: usize,
    pub rover_epochs_cut_by_outage: usize,
    pub cfg: RtkConfig,
    pub measurement_model: String,
}

/// The measurement model: [`RtkConfig::consumer`] (code variance by C/N0
/// and elevation of [`navfuse_core::estimators::eskf::TightConfig::consumer`])
/// when the rover reports C/N0 for most records, else [`RtkConfig::rtklib`]
/// (code σ = 100 × phase σ by elevation: a C/N0 model cannot run without
/// C/N0, and RTKLIB's ratio is its documented default). Both with the DD
/// groups float-linked ([`RtkConfig::float_links`]: geometry without an
/// assumption about the receivers' biases, whatever the code model).
pub fn rtk_config(rover: &[RawSat]) -> (RtkConfig, String) {
    const LINKED: &str = "DD groups float-linked (no zero inter-system bias assumed)";
    let with_cn0 = rover.iter().filter(|r| r.obs.cn0_dbhz > 0.0).count();
    if 2 * with_cn0 > rover.len() {
        (
            RtkConfig::consumer(),
            format!(
                "RtkConfig::consumer: phase 3 mm + 3 mm/sin el, code by C/N0 and elevation \
                 (TightConfig::consumer), mask 15°, ratio 3, success rate 0.999, partial \
                 fixing, {LINKED}"
            ),
        )
    } else {
        (
            RtkConfig {
                float_links: true,
                ..RtkConfig::rtklib()
            },
            format!(
                "RtkConfig::rtklib (the rover reports no C/N0): phase 3 mm + 3 mm/sin el, \
                 code 100 × phase, mask 15°, ratio 3, success rate 0.999, partial fixing, \
                 {LINKED}"
            ),
        )
    }
}

/// Pair the rover's records (outage cut from the first IMU sample
/// `t_imu0`, the fixes' rule) with the base's; an error when no rover
/// epoch has a base epoch within [`MAX_AGE_S`].
pub fn rtk_span(
    cfg: &RunConfig,
    t_imu0: f64,
    rover: &RawInput,
    base: BaseStation,
    base_file: &str,
) -> Result<RtkSpan> {
    let all = epochs_of(&rover.records);
    let read = all.len();
    let rover: Vec<RawEpoch> = all
        .into_iter()
        .filter(|e| {
            !cfg.outage.as_ref().is_some_and(|o| {
                let t0 = t_imu0 + o.start;
                e.t >= t0 && (e.t - t0) % o.period < o.length
            })
        })
        .collect();
    let cut = read - rover.len();
    let base_ep = epochs_of(&base.raw.records);
    let rt: Vec<f64> = rover.iter().map(|e| e.t).collect();
    let bt: Vec<f64> = base_ep.iter().map(|e| e.t).collect();
    let pairing = pair_epochs(&rt, &bt, MAX_AGE_S);
    if pairing.base_of.iter().all(Option::is_none) {
        let span = |t: &[f64]| match (t.first(), t.last()) {
            (Some(a), Some(b)) => format!("{a:.1}–{b:.1} s"),
            _ => "no epoch".into(),
        };
        return Err(PipelineError::Input(format!(
            "[input] base = {base_file:?}: no base epoch within {MAX_AGE_S} s of any rover epoch \
             (rover {}, base {}, GPS seconds): the two files do not overlap in time",
            span(&rt),
            span(&bt)
        )));
    }
    let (rcfg, model) = rtk_config(&rover_records(&rover));
    Ok(RtkSpan {
        base_e: Vec3::from(base.position.pos_e),
        base_position: base.position,
        base_warnings: base.warnings,
        base_file: base_file.to_string(),
        rover,
        base: base_ep,
        pairing,
        rover_epochs_read: read,
        rover_epochs_cut_by_outage: cut,
        cfg: rcfg,
        measurement_model: model,
    })
}

fn rover_records(ep: &[RawEpoch]) -> Vec<RawSat> {
    ep.iter().flat_map(|e| e.sats().iter().copied()).collect()
}

/// One applied RTK epoch: the `.pos` quality and the fix decision (a row
/// of the run journal, [`crate::outputs::write_innovations_rtk`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RtkEpochOut {
    /// Filter time of the update [s].
    pub t: f64,
    /// 1 fixed, 2 float.
    pub q: u8,
    /// Satellites with records at both receivers.
    pub ns: u8,
    /// Ratio test of the last subset tried (0 when none was).
    pub ratio: f32,
    /// Rover − base time difference [s].
    pub age_s: f32,
    /// DD ambiguities offered to LAMBDA, and fixed (fewer than offered:
    /// a partial fix of the lowest-variance subset).
    pub n_candidates: u16,
    pub n_fixed: u16,
    /// Bootstrapped success rate of the last subset tried (0 when none).
    pub success_rate: f64,
    pub decision: FixDecision,
    /// Ambiguities reset or (re)initialised this epoch.
    pub resets: RtkResets,
}

/// What an epoch's fix validation decided; for a rejection, why the last
/// (smallest) subset tried failed ([`RtkStats`] reasons).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FixDecision {
    /// Every DD ambiguity offered was fixed.
    Fixed,
    /// A subset was fixed (partial ambiguity resolution).
    FixedPartial,
    /// Fixed (all or a subset), but the fixed DDs alone do not determine
    /// the position (position DOP > `MAX_DD_PDOP`): written as float
    /// (`RtkSolution::position_fixed`).
    FixedWeakGeometry,
    /// No DD ambiguity to try (no phase DD this epoch).
    NoAmbiguities,
    /// Fewer ambiguities than the configured minimum remained.
    RejectedTooFew,
    /// Bootstrapped success rate below the threshold.
    RejectedSuccessRate,
    /// Ratio test below the threshold.
    RejectedRatio,
    /// LAMBDA (or the conditional update's factorisation) failed.
    RejectedLambda,
}

impl FixDecision {
    /// Stable journal name.
    pub fn name(self) -> &'static str {
        match self {
            FixDecision::Fixed => "fixed",
            FixDecision::FixedPartial => "fixed_partial",
            FixDecision::FixedWeakGeometry => "fixed_weak_geometry",
            FixDecision::NoAmbiguities => "no_ambiguities",
            FixDecision::RejectedTooFew => "rejected_too_few",
            FixDecision::RejectedSuccessRate => "rejected_success_rate",
            FixDecision::RejectedRatio => "rejected_ratio",
            FixDecision::RejectedLambda => "rejected_lambda",
        }
    }
    pub fn is_fixed(self) -> bool {
        matches!(
            self,
            FixDecision::Fixed | FixDecision::FixedPartial | FixDecision::FixedWeakGeometry
        )
    }
}

/// Ambiguity resets and initialisations of one epoch, by reason (the
/// differences of the core's [`RtkStats`] counters across the update).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RtkResets {
    pub loss_of_lock: u16,
    /// Slips the INS-predicted phase test found.
    pub ins_slip: u16,
    /// Re-initialisations because the reference's DDs failed their gates.
    pub reference: u16,
    /// New ambiguities (satellites rising or first seen).
    pub rises: u16,
    /// Ambiguities freed (satellites set).
    pub sets: u16,
}

/// The [`RtkStats`] counters an epoch's decision is read from.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct DecisionCounters {
    total: RtkSatCounts,
    too_few: u64,
    success: u64,
    ratio: u64,
    lambda: u64,
}

impl DecisionCounters {
    fn of(s: Option<&RtkStats>) -> Self {
        s.map_or_else(Self::default, |s| DecisionCounters {
            total: s.total(),
            too_few: s.rejected_too_few,
            success: s.rejected_success_rate,
            ratio: s.rejected_ratio,
            lambda: s.rejected_lambda,
        })
    }

    /// The decision and resets between `self` (before) and `after`.
    fn decision(&self, after: &Self, sol: &RtkSolution) -> (FixDecision, RtkResets) {
        let d = if sol.n_candidates == 0 {
            FixDecision::NoAmbiguities
        } else if sol.fixed {
            if !sol.position_fixed() {
                FixDecision::FixedWeakGeometry
            } else if sol.n_fixed < sol.n_candidates {
                FixDecision::FixedPartial
            } else {
                FixDecision::Fixed
            }
        } else if after.success > self.success {
            FixDecision::RejectedSuccessRate
        } else if after.ratio > self.ratio {
            FixDecision::RejectedRatio
        } else if after.lambda > self.lambda {
            FixDecision::RejectedLambda
        } else {
            FixDecision::RejectedTooFew
        };
        let (a, b) = (&after.total, &self.total);
        let n = |x: u32, y: u32| x.saturating_sub(y).min(u16::MAX as u32) as u16;
        let r = RtkResets {
            loss_of_lock: n(a.lli_resets, b.lli_resets),
            ins_slip: n(a.slips, b.slips),
            reference: n(a.ref_resets, b.ref_resets),
            rises: n(a.rises, b.rises),
            sets: n(a.sets, b.sets),
        };
        (d, r)
    }
}

/// Applies the rover epochs as the IMU samples pass them.
pub(crate) struct RtkDriver<'a> {
    span: &'a RtkSpan,
    next: usize,
    bias_m: f64,
    pub out: Vec<RtkEpochOut>,
    before_start: usize,
    unpaired: usize,
    errors: usize,
    first_error: Option<String>,
    fixed_ratios: Vec<f64>,
    float_ratios: Vec<f64>,
    first_t: f64,
    first_fix_t: Option<f64>,
    /// The last epoch's fixed − float position (lat, lon, h) and variances
    /// (fixed σ², float σ² NED at that epoch), carried to the samples up
    /// to the next epoch; `None` after a float epoch.
    carry: Option<Carry>,
    coast_after_s: f64,
}

#[derive(Clone, Copy, Debug)]
struct Carry {
    t: f64,
    d: Vec3,
    var_fixed: Vec3,
    var_float: Vec3,
}

impl<'a> RtkDriver<'a> {
    /// Epochs at or before `t_start` (the filter's start) are not applied.
    pub fn new(span: &'a RtkSpan, t_start: f64, coast_after_s: f64) -> Self {
        let next = span.rover.partition_point(|e| e.t <= t_start);
        RtkDriver {
            span,
            next,
            bias_m: 0.0,
            out: Vec::new(),
            before_start: next,
            unpaired: 0,
            errors: 0,
            first_error: None,
            fixed_ratios: Vec::new(),
            float_ratios: Vec::new(),
            first_t: f64::NAN,
            first_fix_t: None,
            carry: None,
            coast_after_s,
        }
    }

    /// After the IMU sample at `t_imu` (interval `dt`): apply the rover
    /// epochs whose true time is at most half an interval later.
    pub fn after_imu(&mut self, m: &mut Member, t_imu: f64, dt: f64) {
        // Between epochs: the fixed solution carried by the INS (the float
        // filter's motion since the epoch plus the epoch's fixed − float
        // offset; σ² = fixed σ² + the float σ² grown since the epoch).
        if let Some(c) = self.carry.filter(|c| t_imu - c.t <= self.coast_after_s) {
            if let Some(s) = m.sols.last_mut().filter(|s| (s.t - t_imu).abs() < 1e-9) {
                s.lat += c.d.x;
                s.lon += c.d.y;
                s.h += c.d.z;
                let grown =
                    (s.std_pos_ned.component_mul(&s.std_pos_ned) - c.var_float).map(|v| v.max(0.0));
                s.std_pos_ned = (c.var_fixed + grown).map(f64::sqrt);
                if let Some(r) = m.std.last_mut().filter(|r| (r.t - t_imu).abs() < 1e-9) {
                    r.pos_ned = s.std_pos_ned;
                    r.pos_cross_ned = Vec3::repeat(f64::NAN);
                }
            }
        }
        while let Some(re) = self.span.rover.get(self.next) {
            // The clock bias moves the true time by ≤ 1 ms (steered
            // receivers): only look at epochs that could be due.
            if re.t > t_imu + 0.5 * dt + 0.01 {
                return;
            }
            let nav = *m.eskf.nav();
            let r_ins = geodetic_to_ecef(&Geodetic {
                lat: nav.lat,
                lon: nav.lon,
                h: nav.h,
            });
            if let Some(b) = receiver_clock_bias_m(re, &r_ins) {
                // A bias beyond ±10 ms is a receiver that does not steer
                // its clock: its stamps are then kept (the time tag error
                // cancels in the differences only as far as the base shares it).
                if b.abs() < 0.01 * C_LIGHT {
                    self.bias_m = b;
                }
            }
            let te = re.t - self.bias_m / C_LIGHT;
            if te > t_imu + 0.5 * dt {
                return;
            }
            let k = self.next;
            self.next += 1;
            let Some(jb) = self.span.pairing.base_of[k] else {
                self.unpaired += 1;
                continue;
            };
            let be = &self.span.base[jb];
            let before = DecisionCounters::of(m.eskf.rtk_stats());
            match m.eskf.rtk_update(re, be, &self.span.base_e) {
                Ok(sol) => {
                    let (decision, resets) =
                        before.decision(&DecisionCounters::of(m.eskf.rtk_stats()), &sol);
                    if self.first_t.is_nan() {
                        self.first_t = t_imu;
                    }
                    let ns =
                        re.sats()
                            .iter()
                            .filter(|s| {
                                s.obs.signal.is_first()
                                    && be.sats().iter().any(|b| {
                                        b.obs.system == s.obs.system && b.obs.prn == s.obs.prn
                                    })
                            })
                            .count();
                    self.carry = sol.fixed.then(|| Carry {
                        t: t_imu,
                        d: Vec3::new(
                            sol.pos.lat - sol.float_pos.lat,
                            sol.pos.lon - sol.float_pos.lon,
                            sol.pos.h - sol.float_pos.h,
                        ),
                        var_fixed: sol.std_ned.component_mul(&sol.std_ned),
                        var_float: sol.float_std_ned.component_mul(&sol.float_std_ned),
                    });
                    if sol.position_fixed() {
                        self.fixed_ratios.push(sol.ratio);
                        self.first_fix_t.get_or_insert(t_imu);
                    } else if sol.n_candidates > 0 {
                        self.float_ratios.push(sol.ratio);
                    }
                    self.out.push(RtkEpochOut {
                        t: t_imu,
                        q: if sol.position_fixed() { 1 } else { 2 },
                        ns: ns.min(255) as u8,
                        ratio: sol.ratio as f32,
                        age_s: (re.t - be.t).abs() as f32,
                        n_candidates: sol.n_candidates.min(u16::MAX as usize) as u16,
                        n_fixed: sol.n_fixed.min(u16::MAX as usize) as u16,
                        success_rate: sol.success_rate,
                        decision,
                        resets,
                    });
                    // The solution written at this sample: the fixed one
                    // when fixed, else the float filter's.
                    if let Some(s) = m.sols.last_mut().filter(|s| (s.t - t_imu).abs() < 1e-9) {
                        s.lat = sol.pos.lat;
                        s.lon = sol.pos.lon;
                        s.h = sol.pos.h;
                        s.std_pos_ned = sol.std_ned;
                    }
                    if let Some(r) = m.std.last_mut().filter(|r| (r.t - t_imu).abs() < 1e-9) {
                        r.pos_ned = sol.std_ned;
                        if sol.fixed {
                            // The conditional covariance's cross terms are
                            // not formed: unknown rather than the float's.
                            r.pos_cross_ned = Vec3::repeat(f64::NAN);
                        }
                    }
                }
                Err(e) => {
                    self.errors += 1;
                    self.first_error.get_or_insert(e.to_string());
                }
            }
        }
    }

    /// The account (summary.json `rtk`).
    pub fn account(&self, eskf: &Eskf) -> RtkAccount {
        let stats = eskf.rtk_stats().copied().unwrap_or_default();
        let applied = self.out.len();
        let fixed = self.out.iter().filter(|e| e.q == 1).count();
        let mut per = BTreeMap::new();
        for (k, c) in stats.per_sat.iter().enumerate() {
            if *c != RtkSatCounts::default() {
                let id = sat_id(GnssSystem::ALL[k / 64].letter(), (k % 64) as u8);
                per.insert(id, SatJson::from(*c));
            }
        }
        let t = stats.total();
        let s = self.span;
        RtkAccount {
            rover_epochs_read: s.rover_epochs_read,
            rover_epochs_cut_by_outage: s.rover_epochs_cut_by_outage,
            rover_epochs_before_filter_start: self.before_start,
            rover_epochs_unpaired_no_update: self.unpaired,
            rover_epochs_applied: applied,
            rover_epochs_failed: self.errors,
            first_failure: self.first_error.clone(),
            rover_epochs_not_reached: s.rover.len().saturating_sub(self.next),
            fixed,
            float: applied - fixed,
            fix_rate: if applied > 0 {
                fixed as f64 / applied as f64
            } else {
                f64::NAN
            },
            first_fix_after_s: self.first_fix_t.map(|t| t - self.first_t),
            ratio_fixed: RatioStats::of(&self.fixed_ratios),
            ratio_not_fixed: RatioStats::of(&self.float_ratios),
            fix_attempts: stats.fix_attempts,
            fixed_partial: stats.fixed_partial,
            fixed_weak_geometry: stats.fixed_weak_geometry,
            rejected_too_few: stats.rejected_too_few,
            rejected_success_rate: stats.rejected_success_rate,
            rejected_ratio: stats.rejected_ratio,
            rejected_lambda: stats.rejected_lambda,
            reference_changes: stats.reference_changes,
            position_resets: stats.position_resets,
            slip_untestable_epochs: stats.slip_untestable,
            mean_nis_code: stats.nis_code.0 / stats.nis_code.1.max(1) as f64,
            mean_nis_phase: stats.nis_phase.0 / stats.nis_phase.1.max(1) as f64,
            total: SatJson::from(t),
            per_satellite: per,
            base_file: s.base_file.clone(),
            base_position: s.base_position,
            pairing: s.pairing.clone(),
            max_age_limit_s: MAX_AGE_S,
            measurement_model: s.measurement_model.clone(),
            warnings: s.base_warnings.clone(),
        }
    }
}

/// [`RtkSatCounts`] for summary.json.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct SatJson {
    pub code_used: u32,
    pub code_gated_chi2: u32,
    pub phase_used: u32,
    pub phase_gated_chi2: u32,
    pub below_elevation_mask: u32,
    pub not_at_base: u32,
    pub bad: u32,
    pub over_capacity: u32,
    pub ambiguity_inits_rise: u32,
    pub ambiguity_frees_set: u32,
    pub resets_loss_of_lock: u32,
    pub resets_ins_slip: u32,
    /// Both signals reset on a dual-frequency geometry-free /
    /// Melbourne–Wübbena slip (`navfuse_core::gnss::slip`).
    pub resets_dual_slip: u32,
    pub resets_reference: u32,
}

impl From<RtkSatCounts> for SatJson {
    fn from(c: RtkSatCounts) -> Self {
        SatJson {
            code_used: c.code_used,
            code_gated_chi2: c.code_gated,
            phase_used: c.phase_used,
            phase_gated_chi2: c.phase_gated,
            below_elevation_mask: c.low_elevation,
            not_at_base: c.no_base,
            bad: c.bad,
            over_capacity: c.capacity,
            ambiguity_inits_rise: c.rises,
            ambiguity_frees_set: c.sets,
            resets_loss_of_lock: c.lli_resets,
            resets_ins_slip: c.slips,
            resets_dual_slip: c.dual_slips,
            resets_reference: c.ref_resets,
        }
    }
}

/// Min / median / max of ratio-test values (NaN when none).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct RatioStats {
    pub n: usize,
    pub min: f64,
    pub median: f64,
    pub max: f64,
}

impl RatioStats {
    fn of(v: &[f64]) -> Self {
        let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
        s.sort_by(f64::total_cmp);
        let n = s.len();
        RatioStats {
            n,
            min: s.first().copied().unwrap_or(f64::NAN),
            median: if n > 0 { s[n / 2] } else { f64::NAN },
            max: s.last().copied().unwrap_or(f64::NAN),
        }
    }
}

/// summary.json `rtk`: every rover epoch accounted for (read = cut +
/// before start + unpaired + applied + failed + not reached), the fix
/// decisions, and every record by satellite and reason.
#[derive(Clone, Debug, Serialize)]
pub struct RtkAccount {
    pub rover_epochs_read: usize,
    pub rover_epochs_cut_by_outage: usize,
    pub rover_epochs_before_filter_start: usize,
    /// No base epoch within `max_age_limit_s`: no GNSS update that epoch.
    pub rover_epochs_unpaired_no_update: usize,
    pub rover_epochs_applied: usize,
    pub rover_epochs_failed: usize,
    pub first_failure: Option<String>,
    /// After the last IMU sample.
    pub rover_epochs_not_reached: usize,
    pub fixed: usize,
    pub float: usize,
    pub fix_rate: f64,
    /// From the first applied epoch [s].
    pub first_fix_after_s: Option<f64>,
    pub ratio_fixed: RatioStats,
    pub ratio_not_fixed: RatioStats,
    pub fix_attempts: u64,
    pub fixed_partial: u64,
    /// Integers validated but the fixed DDs alone do not determine the
    /// position (position DOP > 30): counted in `float` (Q 2).
    pub fixed_weak_geometry: u64,
    pub rejected_too_few: u64,
    pub rejected_success_rate: u64,
    pub rejected_ratio: u64,
    pub rejected_lambda: u64,
    pub reference_changes: u64,
    /// Epochs whose INS position the code DDs contradicted, reset to the
    /// code solution with every ambiguity (core
    /// `Eskf::rtk_test_position_on_code`).
    pub position_resets: u64,
    pub slip_untestable_epochs: u64,
    pub mean_nis_code: f64,
    pub mean_nis_phase: f64,
    pub total: SatJson,
    pub per_satellite: BTreeMap<String, SatJson>,
    pub base_file: String,
    pub base_position: BasePosition,
    pub pairing: Pairing,
    pub max_age_limit_s: f64,
    pub measurement_model: String,
    pub warnings: Vec<String>,
}

#[cfg(test)]
#[path = "rtk_run_tests.rs"]
mod tests;
