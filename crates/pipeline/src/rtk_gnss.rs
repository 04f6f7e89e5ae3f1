//! The RTK/INS filter with the INS switched off (issue 15, must-show 1):
//! the GEONET pair (or any RINEX 2 rover/base pair) through
//! [`Eskf::rtk_update`] in the RTK core's GNSS-only modes, with the choices
//! of `navfuse baseline` ([`crate::experiments::baseline`]), so that the two
//! can be compared epoch by epoch ([`rtk_gnss_only`]).
//!
//! "INS off" without an IMU: the filter is started by one stationary IMU
//! sample and never propagated (no further IMU sample), so nothing of the
//! inertial model enters:
//! - **static**: the position is a constant (no process noise), prior the
//!   rover header's position with σ 10 m per axis (`baseline`: 100 m² per
//!   ECEF axis, isotropic, hence the same in NED);
//! - **kinematic**: position and velocity lose their prior before each
//!   epoch, σ 30 m (`baseline`: 900 m²), the estimate kept at the last
//!   epoch's ([`Eskf::rtk_forget_position`], as `baseline`); optionally the
//!   core's [`RtkConfig::gnss_only`] instead, a constant-velocity model
//!   (RTKLIB with dynamics, not `baseline`'s model:
//!   [`RtkGnssOpts::core_gnss_only`]; on GEONET its fixed baselines differ
//!   from `baseline`'s by up to ~15 mm; diagnostic only, not asserted).
//!
//! Choices reconciled with `baseline` (each one read in both codes):
//! - elevation weights `σ² = a² + a²/sin²el`, a = 3 mm, code 100× (both:
//!   [`RtkConfig::rtklib`]); elevation mask 15° — `baseline` tests the
//!   *base*'s elevation, the core the rover's: the records offered here are
//!   first cut at the base's elevation as `baseline` does (the core's own
//!   rover test then differs only for a satellite within ~0.03° of the mask
//!   over 3.3 km);
//! - ratio threshold 3, ambiguities fixed all-or-nothing: `baseline` has no
//!   partial fixing and no success-rate test, so `min_fix` is set each epoch
//!   to the number of DD ambiguities expected ([`Eskf::rtk_set_config`]) and
//!   `success_min` to 1e-12 (off); an epoch whose candidate count differs
//!   from the expected one is counted ([`RtkGnssRun::candidate_mismatch`]);
//! - GDOP > 30 or < 4 common satellites: epoch rejected before the filter
//!   (`baseline`'s `pos2-rejgdop` rule, its [`dops`] on the rover's lines of
//!   sight); `baseline` still resets slipped ambiguities in a rejected
//!   epoch, here the epoch is skipped whole (a slip there is caught by the
//!   next epoch's loss-of-lock flag only if the receiver repeats it: the
//!   difference is reported if it shows);
//! - pairing tolerance 0.02 s ([`crate::base_station::pair_epochs`] with
//!   `baseline`'s `pair_tol`, not [`crate::base_station::MAX_AGE_S`]);
//! - loss-of-lock (LLI bit 0, either receiver) resets the ambiguity (both);
//! - troposphere: Saastamoinen + Niell at both sites, humidity 0 (both);
//!   ionosphere: none (`baseline` and RTKLIB relative mode `ionoopt` off);
//!   the records' broadcast Klobuchar delay is zeroed here, the core would
//!   otherwise difference the two sites' Klobuchar delays (~mm over 3 km);
//! - the core's χ² gates and INS slip test have no counterpart in
//!   `baseline`: their probabilities are set to 1 − 1e-15 (gates at ~8σ);
//! - a satellite needs all its signals at both receivers (with L2: L1, C1,
//!   L2, P2), as in `baseline`, else none of its records is offered;
//! - new ambiguity σ: `baseline` 30 cycles on each frequency, the core
//!   [`RtkConfig::amb_prior_m`] in metres: 30 L1 cycles (5.7 m), i.e. 23.4
//!   cycles on L2 — not reconcilable without a per-signal prior; a vague
//!   prior either way (the SD code error is ~0.4 m).
//!
//! Base position: the base's header (`baseline` uses the header).

use crate::base_station::{pair_epochs, settle_position, BasePositionSpec};
use crate::error::{PipelineError, Result};
use crate::experiments::baseline::{
    dops, EpochOut, Opts as BaselineOpts, RejectReason, Rejected, Summary,
};
use crate::raw_input::raw_from_obs_with;
use navfuse_core::estimators::eskf::{
    Eskf, EskfConfig, ImuErrors, InitStd, RtkConfig, RtkSolution, RtkStats, NAMB,
};
use navfuse_core::geodesy::{c_en, ecef_to_geodetic, geodetic_to_ecef, Geodetic};
use navfuse_core::gnss::raw::{geometric_range, RawEpoch, RawSat, Signal};
use navfuse_core::gnss::LAMBDA_L1;
use navfuse_core::ins::mech::{q_bn_from_rpy, NavState};
use navfuse_core::types::ImuSample;
use navfuse_core::{Estimator, Event, Vec3};
use std::path::{Path, PathBuf};

/// Probability of the core's gates and slip test in this mode (module
/// documentation): 1 − 1e-15, a χ²₁ gate of ~64 (8σ).
const GATE_OFF: f64 = 1.0 - 1e-15;

/// Kinematic position σ per axis [m] before each epoch: `baseline`'s 900 m²
/// (RTKLIB's 30 m re-initialisation of the position, `udpos`).
const KINEMATIC_SIGMA_M: f64 = 30.0;

/// Options: those of `navfuse baseline` this path honours.
#[derive(Clone, Copy, Debug)]
pub struct RtkGnssOpts {
    pub kinematic: bool,
    pub l2: bool,
    pub mask_rad: f64,
    pub ratio_min: f64,
    pub pair_tol_s: f64,
    pub max_gdop: f64,
    pub humidity: f64,
    /// Kinematic by the core's [`RtkConfig::gnss_only`] (its own
    /// constant-velocity model) instead of [`Eskf::rtk_forget_position`]
    /// (prior forgotten each epoch, kept at the last estimate, as
    /// `baseline`). For the comparison.
    pub core_gnss_only: bool,
}

impl From<&BaselineOpts> for RtkGnssOpts {
    fn from(o: &BaselineOpts) -> Self {
        RtkGnssOpts {
            kinematic: o.kinematic,
            l2: o.l2,
            mask_rad: o.mask,
            ratio_min: o.ratio_min,
            pair_tol_s: o.pair_tol,
            max_gdop: o.max_gdop,
            humidity: if o.trop { o.humidity } else { 0.0 },
            core_gnss_only: false,
        }
    }
}

/// One solved epoch.
#[derive(Clone, Copy, Debug)]
pub struct RtkGnssEpoch {
    /// 1-based among the paired epochs (solved and rejected), as `baseline`.
    pub epoch: usize,
    /// Base epoch time [s].
    pub t: f64,
    pub n_sats: usize,
    /// Rover − base, ECEF [m]: float, and fixed when the validation passed
    /// and the fixed DDs determine the position (`RtkSolution::position_fixed`).
    pub float_b: Vec3,
    pub fixed_b: Option<Vec3>,
    pub ratio: f64,
    pub n_candidates: usize,
    pub n_fixed: usize,
    pub pdop: f64,
    pub gdop: f64,
}

/// The run.
#[derive(Clone, Debug)]
pub struct RtkGnssRun {
    pub epochs: Vec<RtkGnssEpoch>,
    /// Rejected paired epochs, as `baseline` reports them.
    pub rejected: Vec<Rejected>,
    pub unpaired_rover: usize,
    /// Epochs whose DD candidate count was not the expected one.
    pub candidate_mismatch: usize,
    pub stats: RtkStats,
    pub base_e: Vec3,
}

impl RtkGnssRun {
    pub fn paired(&self) -> usize {
        self.epochs.len() + self.rejected.len()
    }
    pub fn fixed(&self) -> usize {
        self.epochs.iter().filter(|e| e.fixed_b.is_some()).count()
    }
    /// As `baseline`'s [`Summary`] (`navfuse baseline --via-rtk`): the
    /// fixed integers and the runner-up baseline are not carried (empty,
    /// `None`); slips = loss-of-lock and detected-slip resets.
    pub fn to_summary(&self) -> Summary {
        let t = self.stats.total();
        Summary {
            epochs: self
                .epochs
                .iter()
                .map(|e| EpochOut {
                    epoch: e.epoch,
                    t: e.t,
                    n_sats: e.n_sats,
                    float_b: e.float_b,
                    fixed_b: e.fixed_b,
                    ratio: e.ratio,
                    pdop: e.pdop,
                    gdop: e.gdop,
                    fixed_dd: Vec::new(),
                    runner_up_b: None,
                })
                .collect(),
            rejected: self.rejected.clone(),
            unpaired: self.unpaired_rover,
            slips: (t.lli_resets + t.slips + t.dual_slips) as usize,
        }
    }
    pub fn first_fix_epoch(&self) -> Option<usize> {
        self.epochs
            .iter()
            .find(|e| e.fixed_b.is_some())
            .map(|e| e.epoch)
    }
}

fn epochs_of(records: &[RawSat]) -> Vec<RawEpoch> {
    let mut out: Vec<RawEpoch> = Vec::new();
    for r in records {
        if out.last().is_none_or(|e| e.t != r.obs.t) {
            out.push(RawEpoch::new(r.obs.t));
        }
        if let Some(e) = out.last_mut() {
            let mut r = *r;
            // No ionosphere model (module documentation).
            r.sat.iono_m = 0.0;
            e.push(r);
        }
    }
    out
}

/// The GEONET-style pair through the RTK core with the INS off (module
/// documentation). `nav`: RINEX navigation files (both receivers).
pub fn rtk_gnss_only(
    rover: &Path,
    base: &Path,
    nav: &[PathBuf],
    opts: &RtkGnssOpts,
) -> Result<RtkGnssRun> {
    let load = |p: &Path| -> Result<_> {
        if nav.is_empty() {
            return Err(PipelineError::Input(format!(
                "{}: RTK needs broadcast ephemerides: give the nav file",
                p.display()
            )));
        }
        let (o, g, n) = crate::spp::load(p, nav)?;
        let format = if crate::spp::is_ubx(p) {
            "ubx-raw"
        } else {
            "rinex-obs"
        };
        let raw = raw_from_obs_with(&o, &g, &n, p, format, opts.l2)?;
        Ok((o.approx_pos, raw))
    };
    let (rover_hdr, rraw) = load(rover)?;
    let (base_hdr, braw) = load(base)?;
    let (bpos, _) = settle_position(&braw.fixes, base_hdr, BasePositionSpec::Header)
        .map_err(|e| PipelineError::Input(format!("{}: {e}", base.display())))?;
    let base_e = Vec3::from(bpos.pos_e);
    let bg = ecef_to_geodetic(&base_e);
    let cen_b = c_en(bg.lat, bg.lon);
    let rov = epochs_of(&rraw.records);
    let bas = epochs_of(&braw.records);
    let rt: Vec<f64> = rov.iter().map(|e| e.t).collect();
    let bt: Vec<f64> = bas.iter().map(|e| e.t).collect();
    let pairing = pair_epochs(&rt, &bt, opts.pair_tol_s);
    let Some(t0) = rt.first().copied() else {
        return Err(PipelineError::Input(format!(
            "{}: no epoch with observations",
            rover.display()
        )));
    };
    // The filter: rover header, σ 10 m (static) — never propagated.
    let r0 = Vec3::from(rover_hdr);
    let r0 = if r0.norm() > 6.0e6 { r0 } else { base_e };
    let g0 = ecef_to_geodetic(&r0);
    let nav0 = NavState {
        lat: g0.lat,
        lon: g0.lon,
        h: g0.h,
        v_n: Vec3::zeros(),
        q_bn: q_bn_from_rpy(&Vec3::zeros()),
    };
    let std = InitStd {
        pos: Vec3::repeat(10.0),
        vel: Vec3::repeat(1.0),
        att: Vec3::repeat(0.1),
        bg: Vec3::repeat(1e-4),
        ba: Vec3::repeat(0.01),
        sg: Vec3::repeat(1e-3),
        sa: Vec3::repeat(1e-3),
    };
    let cfg = RtkConfig {
        elevation_mask_rad: opts.mask_rad,
        ratio_min: opts.ratio_min,
        humidity: opts.humidity,
        gate_probability: GATE_OFF,
        slip_probability: GATE_OFF,
        success_min: 1e-12,
        amb_prior_m: 30.0 * LAMBDA_L1,
        gnss_only: opts.kinematic && opts.core_gnss_only,
        gnss_only_sigma: KINEMATIC_SIGMA_M,
        ..RtkConfig::rtklib()
    };
    let mut f = Eskf::new(EskfConfig::seed001(), nav0, ImuErrors::default(), &std)
        .with_rtk(cfg)
        .map_err(|e| PipelineError::Options(e.to_string()))?;
    let dt = 0.01;
    f.push(&Event::Imu(ImuSample {
        t: t0,
        dt,
        dtheta_b: Vec3::zeros(),
        dvel_b: Vec3::new(0.0, 0.0, -9.8 * dt),
    }));
    let signals: &[Signal] = if opts.l2 {
        &[Signal::GpsL1Ca, Signal::GpsL2C]
    } else {
        &[Signal::GpsL1Ca]
    };
    let mut run = RtkGnssRun {
        epochs: Vec::new(),
        rejected: Vec::new(),
        unpaired_rover: pairing.rover_unpaired,
        candidate_mismatch: 0,
        stats: RtkStats::default(),
        base_e,
    };
    let ecef = |g: &Geodetic| geodetic_to_ecef(g);
    for (k, re) in rov.iter().enumerate() {
        let Some(jb) = pairing.base_of[k] else {
            continue;
        };
        let be = &bas[jb];
        let epoch = run.paired() + 1;
        let nv = *f.nav();
        let rx = ecef(&Geodetic {
            lat: nv.lat,
            lon: nv.lon,
            h: nv.h,
        });
        // Satellites with every signal at both receivers, above the mask
        // at the base (baseline's selection).
        let mut r_ep = RawEpoch::new(re.t);
        let mut b_ep = RawEpoch::new(be.t);
        let mut los = Vec::new();
        let ok = |s: &RawSat| {
            s.sat.valid && s.obs.pseudorange_m.is_finite() && s.obs.carrier_m.is_finite()
        };
        for s in re.sats() {
            if s.obs.signal != Signal::GpsL1Ca || s.obs.prn >= 33 {
                continue;
            }
            let find = |e: &RawEpoch, sig: Signal| {
                e.sats()
                    .iter()
                    .find(|x| x.obs.prn == s.obs.prn && x.obs.signal == sig && ok(x))
                    .copied()
            };
            let pairs: Option<Vec<(RawSat, RawSat)>> = signals
                .iter()
                .map(|&sig| Some((find(re, sig)?, find(be, sig)?)))
                .collect();
            let Some(pairs) = pairs else { continue };
            let (_, los_b) = geometric_range(&pairs[0].1.sat.pos_e, &base_e);
            let el_b = (-(cen_b * los_b).z).clamp(-1.0, 1.0).asin();
            if el_b < opts.mask_rad {
                continue;
            }
            let (_, los_r) = geometric_range(&pairs[0].0.sat.pos_e, &rx);
            los.push(los_r);
            for (a, b) in pairs {
                r_ep.push(a);
                b_ep.push(b);
            }
        }
        let n_sats = los.len();
        let (pdop, gdop) = dops(los.into_iter());
        let reject = if n_sats < 4 {
            Some(RejectReason::FewSatellites)
        } else if gdop.is_nan() || gdop > opts.max_gdop {
            Some(RejectReason::Gdop)
        } else {
            None
        };
        if let Some(reason) = reject {
            run.rejected.push(Rejected {
                epoch,
                t: be.t,
                n_sats,
                gdop,
                reason,
            });
            continue;
        }
        let expected = signals.len() * (n_sats - 1);
        f.rtk_set_config(RtkConfig {
            min_fix: expected.clamp(1, NAMB),
            ..cfg
        })
        .map_err(|e| PipelineError::Options(e.to_string()))?;
        if opts.kinematic && !opts.core_gnss_only {
            f.rtk_forget_position(KINEMATIC_SIGMA_M);
        }
        let sol: RtkSolution = f
            .rtk_update(&r_ep, &b_ep, &base_e)
            .map_err(|e| PipelineError::Input(e.to_string()))?;
        if sol.n_candidates != expected {
            run.candidate_mismatch += 1;
        }
        run.epochs.push(RtkGnssEpoch {
            epoch,
            t: be.t,
            n_sats,
            float_b: ecef(&sol.float_pos) - base_e,
            // Fixed as `.pos` Q 1: the fixed DDs determine the position.
            fixed_b: sol.position_fixed().then(|| ecef(&sol.pos) - base_e),
            ratio: sol.ratio,
            n_candidates: sol.n_candidates,
            n_fixed: sol.n_fixed,
            pdop,
            gdop,
        });
    }
    if let Some(s) = f.rtk_stats() {
        run.stats = *s;
    }
    Ok(run)
}

#[cfg(test)]
#[path = "rtk_gnss_tests.rs"]
mod tests;
