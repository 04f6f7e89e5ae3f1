//! Raw GNSS input of `navfuse run` (issue 14): a u-blox log (`.ubx`,
//! RXM-RAWX epochs + RXM-SFRBX ephemerides, [`navfuse_io::ubx_gnss`]) or a
//! RINEX observation file with `[input] nav` (RINEX 2 or 3 broadcast
//! navigation), read by [`crate::spp::load`], turned into
//! - one [`RawSat`] record per satellite and epoch for the tightly coupled
//!   ESKF ([`navfuse_core::estimators::eskf::tight`]), its [`SatState`]
//!   from the broadcast ephemeris nearest in t_oe (the SPP's choice,
//!   [`crate::spp`]), and
//! - the single-point solution of every epoch ([`crate::spp::solve_obs`],
//!   core `gnss::spp`) as [`GnssFix`]es: the position/course source of the
//!   alignment ([`crate::align`]) with tight coupling, and the fixes of a
//!   loosely coupled run (`gnss_format = "raw"`).
//!
//! Every observation is accounted for: a record reaches the filter, or it
//! is counted per satellite with its reason (no code, no ephemeris within
//! the SPP's age limit, unhealthy, system not supported, over capacity).
//!
//! Per-record satellite error variance `var_m2` (what the filter adds to its
//! white code noise): the broadcast URA² (the nominal value of its index,
//! [`ura_nominal_m`], IS-GPS-200's value for accuracy use; Galileo SISA as
//! given) plus the ionosphere residual:
//! 50 % of the broadcast Klobuchar delay (RTKLIB `ERR_BRDCI`, the model's
//! design removes about half, Klobuchar 1987; the SPP's weight), or 5 m
//! when the input carries no Klobuchar coefficients (RTKLIB `ERR_ION`, the
//! uncorrected ionosphere); both scaled by the a-posteriori variance factor
//! σ̂₀² = Σχ²/Σdof that the SPP of the same epochs estimates for this
//! error model (Teunissen, *Adjustment theory*, §4.4) — only when that
//! factor has [`crate::spp::MIN_POOLED_DOF`] *effective* degrees of freedom
//! for these slowly varying errors ([`slow_error_dof`]: a satellite's error
//! over a file shorter than its correlation time is one sample, however many
//! epochs see it); else the a-priori budget stands (scale 1; the URA
//! and the 50 % Klobuchar rule are conservative by design). The
//! fixes' σ keep the factor at its plain dof count, as `navfuse spp` writes
//! them. The
//! filter's own white code/multipath terms are not scaled. The Klobuchar delay `iono_m` is evaluated at
//! the epoch's SPP position (the nearest solved epoch's when this one has
//! none; the model varies over hundreds of km, Klobuchar 1987).

use crate::error::{PipelineError, Result};
use crate::input::InputReport;
use crate::spp::{by_prn, gps_ephemeris, other_system, solve_obs, SppNav, SppOptions, SppSummary};
use navfuse_core::geodesy::{c_en, ecef_to_geodetic};
use navfuse_core::gnss::glonass::SIGMA_EPH_M;
use navfuse_core::gnss::orbit_gnss::OrbitKind;
use navfuse_core::gnss::raw::{
    GnssSystem, RawObs, RawSat, SatState, Signal, FLAG_LOSS_OF_LOCK, MAX_RAW_SATS,
};
use navfuse_core::gnss::spp::{ura_nominal_m, SppSolution};
use navfuse_core::gnss::{LAMBDA_L1, LAMBDA_L2, SECONDS_PER_WEEK};
use navfuse_core::types::GnssFix;
use navfuse_core::Vec3;
use navfuse_io::rinex::{GnssObs, ObsFile};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Ionosphere residual as a fraction of the Klobuchar delay (RTKLIB
/// `ERR_BRDCI`).
pub const IONO_RESIDUAL: f64 = 0.5;
/// Ionosphere σ without a broadcast model [m] (RTKLIB `ERR_ION`).
pub const IONO_SIGMA_NO_MODEL_M: f64 = 5.0;

/// Records of one satellite not given to the filter, by reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct PreCounts {
    pub no_code: u64,
    pub no_ephemeris: u64,
    pub unhealthy: u64,
    pub unsupported_system: u64,
    pub over_capacity: u64,
}

impl PreCounts {
    pub fn total(&self) -> u64 {
        self.no_code
            + self.no_ephemeris
            + self.unhealthy
            + self.unsupported_system
            + self.over_capacity
    }
}

/// What [`load_raw`] read.
#[derive(Clone, Debug)]
pub struct RawInput {
    /// Records with an ephemeris, time-ordered, each epoch's last flagged
    /// `obs.last_in_epoch` (receiver time tags, GPS seconds).
    pub records: Vec<RawSat>,
    /// Satellite observations read (records + the ones counted in `rejected`).
    pub observations: u64,
    /// Observations not made into records, per satellite (`G05`, `E11`, …).
    pub rejected: BTreeMap<String, PreCounts>,
    /// Epochs read.
    pub epochs: usize,
    /// The SPP solutions as fixes (GPS time of the measurement, antenna).
    pub fixes: Vec<GnssFix>,
    /// The SPP's account of the epochs.
    pub spp: SppSummary,
    /// The reader's report (summary.json `inputs.gnss`).
    pub report: InputReport,
    /// The scale of the fixes' σ (the SPP's pooled variance factor, 1
    /// below [`crate::spp::MIN_POOLED_DOF`] degrees of freedom).
    pub var_scale: f64,
    /// The scale applied to every record's satellite variance: the SPP's
    /// variance factor when its effective degrees of freedom for the slow
    /// satellite errors ([`slow_error_dof`]) reach
    /// [`crate::spp::MIN_POOLED_DOF`], else 1 (the a-priori budget).
    pub sat_var_scale: f64,
    /// Those effective degrees of freedom.
    pub sat_var_dof_eff: f64,
}

/// Satellite id as in the SPP summary (`G05`, `E11`, `C03`, `J193`).
pub fn sat_id(system: char, prn: u8) -> String {
    format!("{system}{prn:02}")
}

/// Read `obs` (`.ubx`, or RINEX observations with `nav`) as raw records and
/// SPP fixes.
pub fn load_raw(obs: &Path, nav: &[PathBuf]) -> Result<RawInput> {
    let ubx = crate::spp::is_ubx(obs);
    if !ubx && nav.is_empty() {
        return Err(PipelineError::Input(format!(
            "{}: raw GNSS observations from a RINEX file need broadcast ephemerides: \
             give [input] nav = \"brdc.nav\" (a .ubx log carries its own)",
            obs.display()
        )));
    }
    let (o, g, n) = crate::spp::load(obs, nav)?;
    let format = if ubx { "ubx-raw" } else { "rinex-obs" };
    raw_from_obs(&o, &g, &n, obs, format)
}

/// [`load_raw`], with `second_frequency` the second-frequency records too
/// (GPS L2, Galileo E5b, BeiDou B2I; [`raw_from_obs_with`]).
pub fn load_raw_with(obs: &Path, nav: &[PathBuf], second_frequency: bool) -> Result<RawInput> {
    if !second_frequency {
        return load_raw(obs, nav);
    }
    if !crate::spp::is_ubx(obs) && nav.is_empty() {
        return load_raw(obs, nav);
    }
    let (o, g, n) = crate::spp::load(obs, nav)?;
    let format = if crate::spp::is_ubx(obs) {
        "ubx-raw"
    } else {
        "rinex-obs"
    };
    raw_from_obs_with(&o, &g, &n, obs, format, true)
}

/// [`load_raw`] on observations and ephemerides already in memory.
pub fn raw_from_obs(
    o: &ObsFile,
    g: &GnssObs,
    n: &SppNav,
    file: &Path,
    format: &'static str,
) -> Result<RawInput> {
    raw_from_obs_with(o, g, n, file, format, false)
}

/// [`raw_from_obs`], with `second_frequency` also the GPS L2 records of a
/// RINEX 2 or 3 file (RTK, `[filter] coupling = "rtk"`; RINEX 3 codes are
/// mapped to RINEX 2 names by `navfuse_io::rinex::rinex2_name`, L2C's
/// `C2L`/`L2L` to `C2`/`L2`): carrier `L2`, code
/// `P2` else `C2` (the order `navfuse baseline` and RTKLIB's RINEX 2
/// defaults use: the GEONET receivers log P2), loss of lock from `L2`'s
/// LLI bit 0, signal [`Signal::GpsL2C`] (the L2 carrier, 1227.60 MHz,
/// whichever code was tracked: only the frequency matters to the DD model),
/// the Klobuchar delay scaled by (λ₂/λ₁)². Each such record follows its L1
/// record in the epoch. Likewise for a RINEX 3 file's Galileo and BeiDou
/// satellites: their first signal (E1, B1I) gets its carrier, LLI and C/N0
/// (without `second_frequency` those records carry code and Doppler only,
/// as the SPP and tight filter use them), and the second (E5b, B2I: band 7,
/// codes in [`rtk_codes`]) follows it with the same ephemeris, the
/// Klobuchar delay scaled by (λ₂/λ₁)². The SPP, the fixes, the tight path and the account
/// are those of the first signal (`second_frequency = false` gives
/// exactly [`raw_from_obs`]). A UBX log takes the same path: its reader
/// ([`navfuse_io::ubx_gnss`]) names RAWX GPS L2 CL/CM `C2 L2 D2 S2`,
/// Galileo E5b I/Q `C7I…`/`C7Q…` and BeiDou B2I `C7I…`, with the loss of
/// lock from the RAWX lock time in LLI bit 0.
pub fn raw_from_obs_with(
    o: &ObsFile,
    g: &GnssObs,
    n: &SppNav,
    file: &Path,
    format: &'static str,
    second_frequency: bool,
) -> Result<RawInput> {
    // The SPP of every epoch (pooled variance factor scales the fixes' σ,
    // as `navfuse spp` writes them).
    let mut sols: Vec<SppSolution> = Vec::with_capacity(o.epochs.len());
    let spp = solve_obs(o, g, n, &SppOptions::default(), |s| {
        sols.push(*s);
        Ok(())
    })?;
    let scale = if spp.dof_sum >= crate::spp::MIN_POOLED_DOF {
        spp.variance_factor
    } else {
        1.0
    };
    let fixes: Vec<GnssFix> = sols.iter().map(|s| fix_of(s, scale)).collect();
    let fix_scale = scale;
    let span = match (sols.first(), sols.last()) {
        (Some(a), Some(b)) => b.t_rx - a.t_rx,
        _ => 0.0,
    };
    let sat_dof_eff = slow_error_dof(
        spp.dof_sum,
        spp.solved,
        span,
        crate::tight_run::tight_config().sat_error_tau_s,
    );
    let sat_scale = if sat_dof_eff >= crate::spp::MIN_POOLED_DOF as f64 {
        spp.variance_factor
    } else {
        1.0
    };
    #[cfg(test)]
    let sat_scale = VAR_SCALE_OVERRIDE.with(|c| c.get()).unwrap_or(sat_scale);
    let scale = sat_scale;
    let pos_at = |t: f64| -> Option<Vec3> {
        let k = sols.partition_point(|s| s.t_rx < t - 1e-6);
        let cand = [k.checked_sub(1), (k < sols.len()).then_some(k)];
        cand.into_iter()
            .flatten()
            .min_by(|&a, &b| {
                (sols[a].t_rx - t)
                    .abs()
                    .total_cmp(&(sols[b].t_rx - t).abs())
            })
            .map(|i| sols[i].pos_e)
    };
    let iono = n.gps.iono.filter(|k| !k.is_zero());
    let idx = |c: &str| o.index(c);
    let (i_c1, i_p1, i_l1, i_d1, i_s1) = (idx("C1"), idx("P1"), idx("L1"), idx("D1"), idx("S1"));
    let (i_p2, i_c2, i_l2, i_s2) = (idx("P2"), idx("C2"), idx("L2"), idx("S2"));
    let eph = by_prn(&n.gps);
    let mut records = Vec::with_capacity(o.epochs.len() * 10);
    let mut rejected: BTreeMap<String, PreCounts> = BTreeMap::new();
    let mut observations = 0u64;
    let mut bump = |id: String, f: &dyn Fn(&mut PreCounts)| f(rejected.entry(id).or_default());
    for (k_ep, ep) in o.epochs.iter().enumerate() {
        let rx = pos_at(ep.t);
        let start = records.len();
        let push = |r: RawSat, records: &mut Vec<RawSat>| -> bool {
            if records.len() - start >= MAX_RAW_SATS {
                return false;
            }
            records.push(r);
            true
        };
        for (prn, vals) in &ep.sats {
            observations += 1;
            let id = sat_id('G', *prn);
            let get = |i: Option<usize>| {
                i.and_then(|i| vals.get(i).copied().flatten())
                    .filter(|v| v.value != 0.0)
            };
            let Some(pr) = get(i_c1).or_else(|| get(i_p1)).map(|v| v.value) else {
                bump(id, &|c| c.no_code += 1);
                continue;
            };
            let Some(ki) = gps_ephemeris(&n.gps, &eph, *prn, ep.t) else {
                bump(id, &|c| c.no_ephemeris += 1);
                continue;
            };
            let orbit = &n.gps.orbits[ki];
            if orbit.health != 0 {
                bump(id, &|c| c.unhealthy += 1);
                continue;
            }
            let ura = sat_sigma_m('G', n.gps.ura_m.get(ki).copied().unwrap_or(f64::NAN));
            let l1 = get(i_l1);
            let mut r = RawSat {
                obs: RawObs {
                    t: ep.t,
                    pseudorange_m: pr,
                    carrier_m: l1.map_or(f64::NAN, |v| v.value * LAMBDA_L1),
                    doppler_hz: get(i_d1).map_or(f64::NAN, |v| v.value),
                    cn0_dbhz: get(i_s1).map_or(0.0, |v| v.value as f32),
                    system: GnssSystem::Gps,
                    prn: *prn,
                    signal: Signal::GpsL1Ca,
                    flags: if l1.is_some_and(|v| v.lli & 1 != 0) {
                        FLAG_LOSS_OF_LOCK
                    } else {
                        0
                    },
                    ..RawObs::default()
                },
                sat: sat_state(orbit, OrbitKind::Gps, ep.t, pr),
            };
            atmosphere(&mut r, rx, iono.as_ref(), ura, 1.0, scale);
            if !push(r, &mut records) {
                bump(id, &|c| c.over_capacity += 1);
                continue;
            }
            if second_frequency {
                let l2 = get(i_l2);
                if let Some(pr2) = get(i_p2).or_else(|| get(i_c2)).map(|v| v.value) {
                    let mut r2 = RawSat {
                        obs: RawObs {
                            t: ep.t,
                            pseudorange_m: pr2,
                            carrier_m: l2.map_or(f64::NAN, |v| v.value * LAMBDA_L2),
                            cn0_dbhz: get(i_s2).map_or(0.0, |v| v.value as f32),
                            system: GnssSystem::Gps,
                            prn: *prn,
                            signal: Signal::GpsL2C,
                            flags: if l2.is_some_and(|v| v.lli & 1 != 0) {
                                FLAG_LOSS_OF_LOCK
                            } else {
                                0
                            },
                            ..RawObs::default()
                        },
                        sat: sat_state(orbit, OrbitKind::Gps, ep.t, pr2),
                    };
                    let f2 = (LAMBDA_L2 / LAMBDA_L1).powi(2);
                    atmosphere(&mut r2, rx, iono.as_ref(), ura, f2, scale);
                    if !push(r2, &mut records) {
                        bump(id, &|c| c.over_capacity += 1);
                    }
                }
            }
        }
        // Galileo, BeiDou, QZSS of a RINEX 3 file (the SPP's signals and
        // age limits); other systems counted as not supported.
        for (sys, prn, vals) in g.epochs.get(k_ep).into_iter().flatten() {
            if *sys == 'G' {
                continue;
            }
            observations += 1;
            let id = sat_id(*sys, *prn);
            if *sys == 'R' {
                // GLONASS: the SPP's codes and ephemeris choice
                // (crate::spp::GLO_CODES, ±15 min), the satellite's FDMA
                // channel for its wavelength (Doppler, ionosphere scale).
                let get = |c: &[&str]| g.first_value('R', c, vals);
                let Some(pr) = get(crate::spp::GLO_CODES) else {
                    bump(id, &|c| c.no_code += 1);
                    continue;
                };
                let Some(e) = n.glonass_ephemeris(*prn, ep.t) else {
                    bump(id, &|c| c.no_ephemeris += 1);
                    continue;
                };
                if e.health != 0 {
                    bump(id, &|c| c.unhealthy += 1);
                    continue;
                }
                let mut r = RawSat {
                    obs: RawObs {
                        t: ep.t,
                        pseudorange_m: pr,
                        doppler_hz: get(crate::spp::GLO_DOPPLERS).unwrap_or(f64::NAN),
                        cn0_dbhz: get(&["S1C", "S1P"]).map_or(0.0, |v| v as f32),
                        system: GnssSystem::Glonass,
                        prn: *prn,
                        signal: Signal::GloG1,
                        glo_fcn: e.freq_ch,
                        ..RawObs::default()
                    },
                    sat: e.sat_state(ep.t, pr),
                };
                let f2 = (r.obs.wavelength_m() / LAMBDA_L1).powi(2);
                atmosphere(&mut r, rx, iono.as_ref(), SIGMA_EPH_M, f2, scale);
                if !push(r, &mut records) {
                    bump(id, &|c| c.over_capacity += 1);
                }
                continue;
            }
            let (system, signal) = match sys {
                'E' => (GnssSystem::Galileo, Signal::GalE1),
                'C' => (GnssSystem::BeiDou, Signal::BdsB1I),
                // QZSS (and SBAS, NavIC): the tight filter's
                // per-satellite slots are GPS/Galileo/BeiDou/GLONASS PRN
                // 1–63.
                _ => {
                    bump(id, &|c| c.unsupported_system += 1);
                    continue;
                }
            };
            let Some((_, codes, dops, lambda, max_age)) = other_system(*sys) else {
                bump(id, &|c| c.unsupported_system += 1);
                continue;
            };
            let get = |c: &[&str]| g.first_value(*sys, c, vals);
            let Some(pr) = get(codes) else {
                bump(id, &|c| c.no_code += 1);
                continue;
            };
            let Some(e) = n.other_ephemeris(*sys, *prn, ep.t, max_age) else {
                bump(id, &|c| c.no_ephemeris += 1);
                continue;
            };
            if e.orbit.health != 0 {
                bump(id, &|c| c.unhealthy += 1);
                continue;
            }
            let ura = sat_sigma_m(*sys, e.accuracy_m);
            let mut r = RawSat {
                obs: RawObs {
                    t: ep.t,
                    pseudorange_m: pr,
                    doppler_hz: get(dops).unwrap_or(f64::NAN),
                    system,
                    prn: *prn,
                    signal,
                    ..RawObs::default()
                },
                sat: sat_state(&e.orbit, e.kind, ep.t, pr),
            };
            if second_frequency {
                // RTK: the first signal's carrier and C/N0 too
                // (raw_from_obs_with).
                let (phases, _, snr) = rtk_codes(signal);
                r.obs.cn0_dbhz = get(snr).map_or(0.0, |v| v as f32);
                if let Some(l) = first_obs(g, *sys, phases, vals) {
                    r.obs.carrier_m = l.value * lambda;
                    r.obs.flags = if l.lli & 1 != 0 { FLAG_LOSS_OF_LOCK } else { 0 };
                }
            }
            let f2 = (lambda / LAMBDA_L1).powi(2);
            atmosphere(&mut r, rx, iono.as_ref(), ura, f2, scale);
            if !push(r, &mut records) {
                bump(id, &|c| c.over_capacity += 1);
                continue;
            }
            let Some(sig2) = Signal::second_of(system).filter(|_| second_frequency) else {
                continue;
            };
            let (phases, codes2, snr2) = rtk_codes(sig2);
            let Some(pr2) = get(codes2) else {
                continue;
            };
            let lambda2 = sig2.wavelength_m(0);
            let l2 = first_obs(g, *sys, phases, vals);
            let mut r2 = RawSat {
                obs: RawObs {
                    t: ep.t,
                    pseudorange_m: pr2,
                    carrier_m: l2.map_or(f64::NAN, |v| v.value * lambda2),
                    cn0_dbhz: get(snr2).map_or(0.0, |v| v as f32),
                    system,
                    prn: *prn,
                    signal: sig2,
                    flags: if l2.is_some_and(|v| v.lli & 1 != 0) {
                        FLAG_LOSS_OF_LOCK
                    } else {
                        0
                    },
                    ..RawObs::default()
                },
                sat: sat_state(&e.orbit, e.kind, ep.t, pr2),
            };
            let f2 = (lambda2 / LAMBDA_L1).powi(2);
            atmosphere(&mut r2, rx, iono.as_ref(), ura, f2, scale);
            if !push(r2, &mut records) {
                bump(id, &|c| c.over_capacity += 1);
            }
        }
        if let Some(last) = records[start..].last_mut() {
            last.obs.last_in_epoch = true;
        }
    }
    let n_rej: u64 = rejected.values().map(PreCounts::total).sum();
    let mut report = InputReport::new(
        file,
        format,
        &navfuse_io::error::RecordStats {
            lines: observations,
            used: observations - n_rej,
            ..Default::default()
        },
        fixes.len(),
    );
    for (what, v) in [
        (
            "no L1 code",
            rejected.values().map(|c| c.no_code).sum::<u64>(),
        ),
        (
            "no ephemeris",
            rejected.values().map(|c| c.no_ephemeris).sum(),
        ),
        ("unhealthy", rejected.values().map(|c| c.unhealthy).sum()),
        (
            "system not supported",
            rejected.values().map(|c| c.unsupported_system).sum(),
        ),
        (
            "over epoch capacity",
            rejected.values().map(|c| c.over_capacity).sum(),
        ),
    ] {
        if v > 0 {
            report.rejected.insert(what.into(), v.into());
        }
    }
    Ok(RawInput {
        records,
        observations,
        rejected,
        epochs: o.epochs.len(),
        fixes,
        spp,
        report,
        var_scale: fix_scale,
        sat_var_scale: sat_scale,
        sat_var_dof_eff: sat_dof_eff,
    })
}

/// RINEX 3.04 (Table 4) carrier, code and C/N0 codes the RTK input reads
/// for a Galileo or BeiDou signal, in preference order: E1 pilot/combined
/// (`1C`, `1X`, `1B`: the SPP's code order), B1I on band 2 (`2I`, and the
/// RINEX 3.01 `1I`), E5b (`7Q`, `7X`, `7I`), B2I (`7I`, `7Q`, `7X`).
/// The simulated scene ([`Signal::rinex3_codes`]) writes `L1C`, `L2I`,
/// `L7Q`, `L7I`.
type Codes = &'static [&'static str];
fn rtk_codes(sig: Signal) -> (Codes, Codes, Codes) {
    match sig {
        Signal::GalE1 => (
            &["L1C", "L1X", "L1B"],
            &["C1C", "C1X", "C1B"],
            &["S1C", "S1X", "S1B"],
        ),
        Signal::BdsB1I => (&["L2I", "L1I"], &["C2I", "C1I"], &["S2I", "S1I"]),
        Signal::GalE5b => (
            &["L7Q", "L7X", "L7I"],
            &["C7Q", "C7X", "C7I"],
            &["S7Q", "S7X", "S7I"],
        ),
        Signal::BdsB2I => (
            &["L7I", "L7Q", "L7X"],
            &["C7I", "C7Q", "C7X"],
            &["S7I", "S7Q", "S7X"],
        ),
        _ => (&[], &[], &[]),
    }
}

/// The first non-zero observation (value and LLI) among `codes` of one
/// satellite's RINEX 3 values ([`GnssObs::first_value`] with the LLI).
fn first_obs(
    g: &GnssObs,
    sys: char,
    codes: &[&str],
    vals: &[Option<navfuse_io::rinex::ObsValue>],
) -> Option<navfuse_io::rinex::ObsValue> {
    codes
        .iter()
        .filter_map(|c| g.index(sys, c))
        .filter_map(|i| vals.get(i).copied().flatten())
        .find(|v| v.value != 0.0)
}

/// Satellite orbit/clock σ [m] of a record for the tight filter: Galileo
/// SISA as given ([`crate::spp::broadcast_sigma_m`]), a URA as its nominal value
/// ([`ura_nominal_m`], the ICD's value for accuracy use; the SPP weights
/// with the interval's upper bound,
/// [`navfuse_core::gnss::spp::ura_sigma_m`], as RTKLIB does).
fn sat_sigma_m(sys: char, accuracy_m: f64) -> f64 {
    #[cfg(test)]
    if URA_UPPER_BOUND.with(|c| c.get()) {
        return crate::spp::broadcast_sigma_m(sys, accuracy_m);
    }
    if sys == 'E' && accuracy_m > 0.0 {
        accuracy_m
    } else {
        ura_nominal_m(accuracy_m)
    }
}

/// Effective degrees of freedom of the SPP's pooled variance factor for the
/// slowly varying satellite errors (orbit, clock, ionosphere; first-order
/// Gauss–Markov with correlation time `tau_s`), from `dof_sum` residual
/// degrees of freedom over `epochs` solved epochs spanning `span_s`
/// seconds: the mean residual dof per epoch times the number of
/// independent samples of a Gauss–Markov process observed for `span_s`,
/// `ν(T) = T² / ∫∫ ρ²(t − s) ds dt = T² / (Tτ − τ²/2 · (1 − e^(−2T/τ)))`
/// (Bayley & Hammersley 1946, the effective sample size of a variance
/// estimated from a correlated series; ν → 1 for T ≪ τ, T/τ for T ≫ τ).
///
/// Why: the pooled factor Σχ²/Σdof counts every epoch's residuals as new
/// samples, but a satellite's slow error is the same sample for all of a
/// short file. Measured on the simulated car drives of the tight tests
/// (seeds 1–12, 300 s, ≈ 1 residual dof per epoch, so ν ≈ 1.1): the factor
/// ranged 0.13–1.94 from seed to seed, and the σ it scaled covered the
/// truth in 4–100 % of the epochs.
pub fn slow_error_dof(dof_sum: u64, epochs: usize, span_s: f64, tau_s: f64) -> f64 {
    if epochs == 0 || span_s.is_nan() || tau_s.is_nan() || span_s <= 0.0 || tau_s <= 0.0 {
        return 0.0;
    }
    let t = span_s;
    let denom = t * tau_s - 0.5 * tau_s * tau_s * (1.0 - (-2.0 * t / tau_s).exp());
    let nu = if denom > 0.0 {
        (t * t / denom).max(1.0)
    } else {
        1.0
    };
    dof_sum as f64 / epochs as f64 * nu
}

/// [`SatState`] of a broadcast orbit of any Kepler system for a record
/// received at `t_rx` with pseudorange `pr`:
/// [`navfuse_core::gnss::raw::sat_state_from_orbit`] (transmission time
/// `t_rx − pr/c − δt_s`, velocity and clock rate by ±0.5 ms central
/// differences, clock with relativity minus the group delay of the tracked
/// signal; the simulator's scenes use the same function).
pub fn sat_state(
    o: &navfuse_core::gnss::KeplerOrbit,
    kind: OrbitKind,
    t_rx: f64,
    pr: f64,
) -> SatState {
    navfuse_core::gnss::raw::sat_state_from_orbit(o, kind, t_rx, pr)
}

/// Broadcast ionosphere delay and the record's error variance (module
/// documentation); `scale` = (λ/λ_L1)² for the delay, `var_scale` the
/// variance factor.
fn atmosphere(
    r: &mut RawSat,
    rx: Option<Vec3>,
    iono: Option<&navfuse_core::gnss::iono::Klobuchar>,
    ura_m: f64,
    scale: f64,
    var_scale: f64,
) {
    let mut var = ura_m * ura_m;
    match (iono, rx) {
        (Some(k), Some(rx)) => {
            let g = ecef_to_geodetic(&rx);
            let d = r.sat.pos_e - rx;
            let u_n = c_en(g.lat, g.lon) * (d / d.norm());
            let el = (-u_n.z).clamp(-1.0, 1.0).asin();
            let az = u_n.y.atan2(u_n.x);
            let tow = r.obs.t - (r.obs.t / SECONDS_PER_WEEK).floor() * SECONDS_PER_WEEK;
            let di = scale * k.delay_l1(g.lat, g.lon, az, el, tow);
            r.sat.iono_m = di as f32;
            var += (IONO_RESIDUAL * di).powi(2);
        }
        _ => var += IONO_SIGMA_NO_MODEL_M * IONO_SIGMA_NO_MODEL_M,
    }
    r.sat.var_m2 = (var * var_scale) as f32;
    #[cfg(test)]
    if DIAG_SIM_VAR.with(|c| c.get()) {
        // The simulator's documented budget (σ_sat 1 m, iono 1 m × obliquity).
        if let Some(rx) = rx {
            let g = ecef_to_geodetic(&rx);
            let d = r.sat.pos_e - rx;
            let u_n = c_en(g.lat, g.lon) * (d / d.norm());
            let el = (-u_n.z).clamp(-1.0, 1.0).asin();
            let of = navfuse_sim::raw_gnss::obliquity(el);
            r.sat.var_m2 = (1.0 + of * of) as f32;
        }
    }
}

/// The fixes of a loosely coupled run on its own raw observations
/// (`gnss_format = "raw"`): their position σ rescaled from the SPP's variance
/// factor at its plain dof count ([`RawInput::var_scale`], as `navfuse
/// spp` writes them) to the satellite-variance scale of the records
/// ([`RawInput::sat_var_scale`], module documentation), the rule a tightly
/// coupled run applies to the same errors. The filter weights these fixes
/// as measurements of a slowly varying error; a factor estimated from a
/// few minutes of those errors is a draw of a χ² with a handful of
/// degrees of freedom (0.3–4.5 m of σ_b over six simulated 300 s drives of
/// one error model), and on the drive where it came out low the loose σ
/// covered the truth in 7 % of the epochs. The alignment of tight and RTK
/// runs keeps the SPP's own σ.
pub fn loose_fix_sigma(fixes: &mut [GnssFix], r: &RawInput) {
    let k = (r.sat_var_scale / r.var_scale).sqrt();
    if !(k.is_finite() && k > 0.0) || k == 1.0 {
        return;
    }
    for f in fixes.iter_mut() {
        f.std_ned *= k; // the Doppler velocity's σ carries no factor
    }
}

/// An SPP solution as a fix: antenna position at the GPS time of the
/// measurement ([`crate::spp::pos_row`]), position σ scaled by `var_scale`,
/// Doppler velocity when solved (its σ as the SPP gives it).
pub fn fix_of(sol: &SppSolution, var_scale: f64) -> GnssFix {
    let (s, _) = crate::spp::pos_row(sol, var_scale);
    let v = sol.vel.is_some();
    GnssFix {
        t: s.t,
        lat: s.lat,
        lon: s.lon,
        h: s.h,
        std_ned: s.std_pos_ned,
        v_n: v.then_some(s.v_n),
        std_v_n: v.then_some(s.std_v_n),
        quality: navfuse_io::pos_writer::Q_SINGLE,
        num_sats: sol.n_used,
    }
}

#[cfg(test)]
thread_local! {
    /// Test-only: the URA's upper bound in the satellite budget (before).
    pub(crate) static URA_UPPER_BOUND: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    /// Test-only: the simulator's own satellite budget as `var_m2`.
    pub(crate) static DIAG_SIM_VAR: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    /// Test-only: the satellite-variance scale in place of the SPP's.
    pub(crate) static VAR_SCALE_OVERRIDE: std::cell::Cell<Option<f64>> =
        const { std::cell::Cell::new(None) };
}

#[cfg(test)]
#[test]
fn slow_error_dof_limits() {
    // T ≪ τ: one sample per residual dof; T ≫ τ: T/τ samples.
    assert!((slow_error_dof(100, 100, 1.0, 1800.0) - 1.0).abs() < 1e-3);
    let long = slow_error_dof(100, 100, 1800.0 * 1000.0, 1800.0);
    assert!((long / 1000.0 - 1.0).abs() < 1e-2, "{long}");
    assert_eq!(slow_error_dof(0, 0, 300.0, 1800.0), 0.0);
}

#[cfg(test)]
#[path = "raw_input_tests.rs"]
mod tests;
