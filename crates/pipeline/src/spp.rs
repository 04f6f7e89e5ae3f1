//! `navfuse spp`: single-point positions from a RINEX observation file and
//! broadcast navigation file(s) ([`navfuse_core::gnss::spp`] per epoch),
//! written as an RTKLIB `.pos` (Q = 5 "single") with a summary of the
//! epochs used and rejected, and of the satellites skipped, with reasons.
//!
//! Inputs: GPS L1 C/A code (`C1`, else `P1` when an epoch has no `C1`),
//! Doppler `D1` when present; Galileo, BeiDou, QZSS (`other_system`) and
//! GLONASS (clock group 3, `GLO_GROUP`) from RINEX 3 (GLONASS also from RINEX 2 mixed
//! files) or UBX. GLONASS satellites are looked at only when GLONASS
//! ephemerides were given (a file's GLONASS entries are otherwise counted
//! among the non-GPS entries only, as before); then one without an
//! ephemeris within ±15 min counts as "no ephemeris". GLONASS t_b is UTC
//! in the navigation data; it becomes GPS time with the leap seconds of
//! hifitime's IERS table at that epoch (`navfuse_io::time::gps_minus_utc`),
//! not the file header's `LEAP SECONDS`. Ephemeris: per satellite the record whose
//! t_oe is nearest the epoch, within ±2 h (half the 4 h curve-fit interval
//! of IS-GPS-200 §20.3.4.4; RTKLIB `MAXDTOE`); its health is then checked
//! by the solver. The output time is the receiver time tag corrected by the
//! estimated receiver clock (GPS time of the measurement), as RTKLIB's.

use crate::error::{PipelineError, Result};
use navfuse_core::geodesy::{c_en, ecef_to_geodetic};
use navfuse_core::gnss::glonass::{self, GlonassEph};
use navfuse_core::gnss::orbit_gnss::OrbitKind;
use navfuse_core::gnss::spp::{
    ura_sigma_m, SkipCounts, Spp, SppConfig, SppObs, SppReject, SppSolution, MAX_SATS,
};
use navfuse_core::gnss::{C_LIGHT, LAMBDA_L1};
use navfuse_core::types::{NavSolution, Vec3};
use navfuse_io::pos_writer::{PosEpoch, PosWriter, Q_SINGLE};
use navfuse_io::rinex::{read_nav_data, read_obs_gnss, GnssObs, NavData, ObsFile};
use navfuse_io::rinex_nav3::{read_nav_gnss, GnssEph};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Half the IS-GPS-200 4 h curve-fit interval [s].
pub const MAX_EPH_AGE_S: f64 = 7200.0;

/// Navigation data: GPS records with the header ionosphere, the
/// Galileo, BeiDou and QZSS records of RINEX 3 files, and GLONASS records
/// (RINEX 2 `.g`/`.??g`, the `R` records of RINEX 3, UBX strings 1–4).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct SppNav {
    pub gps: NavData,
    pub other: Vec<GnssEph>,
    pub glonass: Vec<GlonassEph>,
}

impl SppNav {
    /// The record of non-GPS satellite `prn` of system `sys` whose t_oe is
    /// nearest `t` [s], within `max_age_s` (healthy or not: the caller counts).
    pub(crate) fn other_ephemeris(
        &self,
        sys: char,
        prn: u8,
        t: f64,
        max_age_s: f64,
    ) -> Option<&GnssEph> {
        self.other
            .iter()
            .filter(|e| e.sys == sys && e.orbit.prn == prn)
            .filter(|e| (e.orbit.t_oe - t).abs() <= max_age_s)
            .min_by(|a, b| nearer_toe(t, a.orbit.t_oe, b.orbit.t_oe))
    }

    /// The GLONASS record of slot `slot` whose t_b is nearest `t` [s],
    /// within ±[`glonass::MAX_AGE_S`] (healthy or not: the caller counts).
    pub(crate) fn glonass_ephemeris(&self, slot: u8, t: f64) -> Option<&GlonassEph> {
        self.glonass
            .iter()
            .filter(|e| e.slot == slot && (e.t_b - t).abs() <= glonass::MAX_AGE_S)
            .min_by(|a, b| nearer_toe(t, a.t_b, b.t_b))
    }
}

/// GLONASS in the SPP: clock group 3 (its own receiver clock, the
/// inter-system bias to GPS an unknown), FDMA L1 code `C1C` (C/A; else
/// `C1P`) and Doppler `D1C`/`D1P`; the wavelength is the satellite's, from
/// the frequency channel of its ephemeris (1602 MHz + k · 562.5 kHz, ICD
/// 5.1 §3.3.1.1); the broadcast σ is [`glonass::SIGMA_EPH_M`] (no accuracy
/// index in RINEX), the receiver noise σ × [`navfuse_core::gnss::spp::GLO_NOISE_FACTOR`].
pub(crate) const GLO_GROUP: u8 = 3;
pub(crate) const GLO_CODES: &[&str] = &["C1C", "C1P"];
pub(crate) const GLO_DOPPLERS: &[&str] = &["D1C", "D1P"];

/// The broadcast σ [m] of a record's accuracy field: Galileo SISA is a σ
/// in metres already; the others carry a URA ([`ura_sigma_m`]).
pub(crate) fn broadcast_sigma_m(sys: char, accuracy_m: f64) -> f64 {
    if sys == 'E' && accuracy_m > 0.0 {
        accuracy_m
    } else {
        ura_sigma_m(accuracy_m)
    }
}

/// Clock group, code and Doppler codes (in order of preference), carrier
/// wavelength and largest ephemeris age of the non-GPS systems used:
/// Galileo E1 (own clock; 4 h, RTKLIB `MAXDTOE_GAL`), BeiDou B1I (own clock,
/// RINEX 3.02+ `C2I`, 3.01 `C1I`; 6 h, `MAXDTOE_CMP`), QZSS L1 C/A (GPS
/// time, the GPS clock; 2 h).
pub(crate) type SystemSignal = (
    u8,
    &'static [&'static str],
    &'static [&'static str],
    f64,
    f64,
);

pub(crate) fn other_system(sys: char) -> Option<SystemSignal> {
    const C: f64 = navfuse_core::gnss::C_LIGHT;
    match sys {
        'E' => Some((
            1,
            &["C1C", "C1X", "C1B"],
            &["D1C", "D1X", "D1B"],
            C / 1575.42e6,
            14_400.0,
        )),
        'C' => Some((
            2,
            &["C2I", "C1I"],
            &["D2I", "D1I"],
            C / 1561.098e6,
            21_600.0,
        )),
        'J' => Some((0, &["C1C"], &["D1C"], C / 1575.42e6, MAX_EPH_AGE_S)),
        _ => None,
    }
}

/// Options of `navfuse spp`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SppOptions {
    /// Solver options (elevation mask, models, RAIM, GDOP limit).
    pub solver: SppConfig,
    /// Scale the written σ by the file's a-posteriori variance factor
    /// ([`SppSummary::variance_factor`]) instead of the a-priori model's.
    pub sigma_from_residuals: bool,
}

impl Default for SppOptions {
    fn default() -> Self {
        SppOptions {
            solver: SppConfig::default(),
            sigma_from_residuals: true,
        }
    }
}

/// Fewest pooled degrees of freedom for the variance factor to be used
/// (its relative standard error √(2/dof) is then ≤ 26 %).
pub const MIN_POOLED_DOF: u64 = 30;

/// What happened to the epochs and satellites of a file.
#[derive(Clone, Debug, PartialEq, Default, serde::Serialize)]
pub struct SppSummary {
    pub epochs: usize,
    pub solved: usize,
    pub rejected_too_few_satellites: usize,
    pub rejected_gdop: usize,
    pub rejected_chi_square: usize,
    pub rejected_singular: usize,
    pub rejected_no_convergence: usize,
    /// Satellite-epochs without an ephemeris within ±2 h.
    pub sat_no_ephemeris: u64,
    /// Satellite-epochs without an L1 code observation.
    pub sat_no_code: u64,
    pub sat_unhealthy: u64,
    pub sat_below_mask: u64,
    pub sat_bad_range: u64,
    pub sat_over_capacity: u64,
    /// RAIM exclusions in total and per satellite (`G05`, `E11`, …).
    pub raim_excluded: u64,
    pub raim_by_sat: Vec<(String, u32)>,
    /// Satellite-epochs of Galileo/BeiDou/QZSS given to the solver.
    pub other_systems_used: u64,
    /// Satellite-epochs of GLONASS given to the solver.
    pub glonass_used: u64,
    /// Non-GPS satellite entries the reader skipped, event records skipped.
    pub non_gps_skipped: usize,
    pub events_skipped: usize,
    /// Epochs with a Doppler velocity.
    pub with_velocity: usize,
    /// Σ v²/σ² and Σ dof over the solved epochs, and their ratio, the
    /// a-posteriori variance factor σ̂₀² of the a-priori error model
    /// (Teunissen, *Adjustment theory*, §4.4: E[χ²] = dof when the model's σ
    /// are right; relative standard error √(2/Σdof)); 1 when Σdof <
    /// [`MIN_POOLED_DOF`].
    pub chi2_sum: f64,
    pub dof_sum: u64,
    pub variance_factor: f64,
    /// Whether the written σ were scaled by √σ̂₀².
    pub sigma_scaled: bool,
}

impl SppSummary {
    /// Human-readable lines for the terminal.
    pub fn text(&self) -> String {
        let mut s = format!(
            "epochs {}: solved {}, rejected {} (too few satellites {}, GDOP {}, chi-square {}, singular {}, no convergence {})\n",
            self.epochs,
            self.solved,
            self.epochs - self.solved,
            self.rejected_too_few_satellites,
            self.rejected_gdop,
            self.rejected_chi_square,
            self.rejected_singular,
            self.rejected_no_convergence
        );
        s += &format!(
            "satellites skipped: no ephemeris {}, no L1 code {}, unhealthy {}, below mask {}, bad range {}, over capacity {}; RAIM excluded {}",
            self.sat_no_ephemeris,
            self.sat_no_code,
            self.sat_unhealthy,
            self.sat_below_mask,
            self.sat_bad_range,
            self.sat_over_capacity,
            self.raim_excluded
        );
        if !self.raim_by_sat.is_empty() {
            let list: Vec<String> = self
                .raim_by_sat
                .iter()
                .map(|(p, n)| format!("{p}×{n}"))
                .collect();
            s += &format!(" ({})", list.join(", "));
        }
        s += &format!(
            "\na-posteriori variance factor {:.4} (Σχ² {:.1} / Σdof {}; σ {} by {:.3})",
            self.variance_factor,
            self.chi2_sum,
            self.dof_sum,
            if self.sigma_scaled {
                "scaled"
            } else {
                "not scaled"
            },
            self.variance_factor.sqrt()
        );
        s += &format!(
            "\nnon-GPS entries in the file {} (Galileo/BeiDou/QZSS satellite-epochs used {}), event records skipped {}, epochs with Doppler velocity {}",
            self.non_gps_skipped, self.other_systems_used, self.events_skipped, self.with_velocity
        );
        if self.glonass_used > 0 {
            s += &format!("\nGLONASS satellite-epochs used {}", self.glonass_used);
        }
        s
    }
}

/// The ephemerides of each PRN (1..=32), as indices into `nav.orbits`.
pub(crate) fn by_prn(nav: &NavData) -> Vec<Vec<usize>> {
    let mut v = vec![Vec::new(); 33];
    for (i, o) in nav.orbits.iter().enumerate() {
        if (1..=32).contains(&o.prn) {
            v[o.prn as usize].push(i);
        }
    }
    v
}

/// Index in `nav.orbits` of GPS satellite `prn`'s record whose t_oe is
/// nearest `t` [s] within [`MAX_EPH_AGE_S`] (`eph` = [`by_prn`] of `nav`;
/// healthy or not: the caller counts).
pub(crate) fn gps_ephemeris(nav: &NavData, eph: &[Vec<usize>], prn: u8, t: f64) -> Option<usize> {
    eph.get(prn as usize)
        .into_iter()
        .flatten()
        .copied()
        .filter(|&i| (nav.orbits[i].t_oe - t).abs() <= MAX_EPH_AGE_S)
        .min_by(|&a, &b| nearer_toe(t, nav.orbits[a].t_oe, nav.orbits[b].t_oe))
}

/// Order of two ephemerides' t_oe for an epoch at `t`: the nearer first; on
/// a tie the later one (the newer upload).
pub(crate) fn nearer_toe(t: f64, ta: f64, tb: f64) -> std::cmp::Ordering {
    (ta - t)
        .abs()
        .total_cmp(&(tb - t).abs())
        .then(tb.total_cmp(&ta))
}

/// Solve every epoch of `obs`; `on_epoch` gets each solution.
pub fn solve_obs(
    obs: &ObsFile,
    gnss: &GnssObs,
    navs: &SppNav,
    opts: &SppOptions,
    mut on_epoch: impl FnMut(&SppSolution) -> Result<()>,
) -> Result<SppSummary> {
    let i_c1 = obs.index("C1");
    let i_p1 = obs.index("P1");
    if i_c1.is_none() && i_p1.is_none() {
        return Err(PipelineError::Input(format!(
            "{}: no L1 code observable (C1 or P1) among {:?}",
            obs.marker, obs.types
        )));
    }
    let i_d1 = obs.index("D1");
    let nav = &navs.gps;
    let eph = by_prn(nav);
    let mut spp = Spp::new(opts.solver, nav.iono);
    let mut sum = SppSummary {
        epochs: obs.epochs.len(),
        non_gps_skipped: obs.skipped_non_gps,
        events_skipped: obs.events_skipped,
        ..SppSummary::default()
    };
    let mut raim: Vec<(String, u32)> = Vec::new();
    let mut buf = [SppObs::default(); MAX_SATS];
    let mut prior: Option<Vec3> = None;
    for (k_ep, ep) in obs.epochs.iter().enumerate() {
        let mut n = 0usize;
        for (prn, vals) in &ep.sats {
            let get = |i: Option<usize>| {
                i.and_then(|i| vals.get(i).copied().flatten())
                    .map(|v| v.value)
                    .filter(|v| *v != 0.0)
            };
            let Some(pr) = get(i_c1).or_else(|| get(i_p1)) else {
                sum.sat_no_code += 1;
                continue;
            };
            let Some(k) = gps_ephemeris(nav, &eph, *prn, ep.t) else {
                sum.sat_no_ephemeris += 1;
                continue;
            };
            if n == MAX_SATS {
                sum.sat_over_capacity += 1;
                continue;
            }
            buf[n] = SppObs {
                sys: 0,
                prn: *prn,
                pr_m: pr,
                doppler_hz: get(i_d1).unwrap_or(f64::NAN),
                lambda_m: LAMBDA_L1,
                orbit: nav.orbits[k],
                kind: OrbitKind::Gps,
                ura_m: ura_sigma_m(nav.ura_m.get(k).copied().unwrap_or(f64::NAN)),
                glo: None,
            };
            n += 1;
        }
        // Galileo, BeiDou, QZSS (RINEX 3 with their navigation records).
        for (sys, prn, vals) in gnss.epochs.get(k_ep).into_iter().flatten() {
            let Some((group, codes, dops, lambda, max_age)) = other_system(*sys) else {
                continue;
            };
            let get = |c: &[&str]| gnss.first_value(*sys, c, vals);
            let Some(pr) = get(codes) else {
                sum.sat_no_code += 1;
                continue;
            };
            let Some(e) = navs.other_ephemeris(*sys, *prn, ep.t, max_age) else {
                sum.sat_no_ephemeris += 1;
                continue;
            };
            if n == MAX_SATS {
                sum.sat_over_capacity += 1;
                continue;
            }
            buf[n] = SppObs {
                sys: group,
                prn: *prn,
                pr_m: pr,
                doppler_hz: get(dops).unwrap_or(f64::NAN),
                lambda_m: lambda,
                orbit: e.orbit,
                kind: e.kind,
                ura_m: broadcast_sigma_m(*sys, e.accuracy_m),
                glo: None,
            };
            n += 1;
            sum.other_systems_used += 1;
        }
        // GLONASS (RINEX 3 or UBX observations with GLONASS ephemerides).
        if !navs.glonass.is_empty() {
            for (sys, slot, vals) in gnss.epochs.get(k_ep).into_iter().flatten() {
                if *sys != 'R' {
                    continue;
                }
                let get = |c: &[&str]| gnss.first_value('R', c, vals);
                let Some(pr) = get(GLO_CODES) else {
                    sum.sat_no_code += 1;
                    continue;
                };
                let Some(e) = navs.glonass_ephemeris(*slot, ep.t) else {
                    sum.sat_no_ephemeris += 1;
                    continue;
                };
                if n == MAX_SATS {
                    sum.sat_over_capacity += 1;
                    continue;
                }
                buf[n] = SppObs {
                    sys: GLO_GROUP,
                    prn: *slot,
                    pr_m: pr,
                    doppler_hz: get(GLO_DOPPLERS).unwrap_or(f64::NAN),
                    lambda_m: C_LIGHT / glonass::l1_frequency_hz(e.freq_ch),
                    ura_m: glonass::SIGMA_EPH_M,
                    glo: Some(*e),
                    ..SppObs::default()
                };
                n += 1;
                sum.glonass_used += 1;
            }
        }
        let res = spp.solve(ep.t, &buf[..n], prior);
        add_skips(&mut sum, &spp.skips());
        match res {
            Ok(sol) => {
                sum.solved += 1;
                sum.chi2_sum += sol.chi2;
                sum.dof_sum += sol.dof as u64;
                if sol.vel.is_some() {
                    sum.with_velocity += 1;
                }
                for j in 0..sol.n_excluded as usize {
                    // Clock group 0 holds GPS and QZSS; QZSS PRNs are ≥ 193.
                    let letter = match (sol.excluded_sys[j], sol.excluded_prn[j]) {
                        (1, _) => 'E',
                        (2, _) => 'C',
                        (GLO_GROUP, _) => 'R',
                        (_, p) if p > 32 => 'J',
                        _ => 'G',
                    };
                    let id = format!("{letter}{:02}", sol.excluded_prn[j]);
                    match raim.iter_mut().find(|(s, _)| *s == id) {
                        Some(r) => r.1 += 1,
                        None => raim.push((id, 1)),
                    }
                }
                prior = Some(sol.pos_e);
                on_epoch(&sol)?;
            }
            Err(SppReject::TooFewSatellites { .. }) => sum.rejected_too_few_satellites += 1,
            Err(SppReject::GdopTooHigh { .. }) => sum.rejected_gdop += 1,
            Err(SppReject::ChiSquare { .. }) => sum.rejected_chi_square += 1,
            Err(SppReject::Singular) => sum.rejected_singular += 1,
            Err(SppReject::NoConvergence) => sum.rejected_no_convergence += 1,
        }
    }
    raim.sort();
    sum.raim_by_sat = raim;
    sum.variance_factor = if sum.dof_sum >= MIN_POOLED_DOF {
        sum.chi2_sum / sum.dof_sum as f64
    } else {
        1.0
    };
    Ok(sum)
}

fn add_skips(sum: &mut SppSummary, s: &SkipCounts) {
    sum.sat_unhealthy += s.unhealthy as u64;
    sum.sat_below_mask += s.below_mask as u64;
    sum.sat_bad_range += s.bad_range as u64;
    sum.sat_over_capacity += s.over_capacity as u64;
    sum.raim_excluded += s.raim as u64;
}

/// The GPS time of the measurement: time tag minus the receiver clock of
/// the first system present.
pub fn solution_time(sol: &SppSolution) -> f64 {
    let clk = sol.clk_m.iter().copied().find(|c| c.is_finite());
    sol.t_rx - clk.unwrap_or(0.0) / C_LIGHT
}

/// The `.pos` row of a solution: geodetic position, NED σ and cross terms,
/// the covariance multiplied by `var_scale`.
pub fn pos_row(sol: &SppSolution, var_scale: f64) -> (NavSolution, PosEpoch) {
    let g = ecef_to_geodetic(&sol.pos_e);
    let c = c_en(g.lat, g.lon);
    let p = c * sol.cov_pos_e * c.transpose() * var_scale;
    let mut s = NavSolution::unknown_at(solution_time(sol));
    s.lat = g.lat;
    s.lon = g.lon;
    s.h = g.h;
    s.std_pos_ned = Vec3::new(p[(0, 0)].sqrt(), p[(1, 1)].sqrt(), p[(2, 2)].sqrt());
    s.v_n = Vec3::repeat(f64::NAN);
    if let Some(v) = &sol.vel {
        s.v_n = c * v.vel_e;
        let pv = c * v.cov_vel_e * c.transpose();
        s.std_v_n = Vec3::new(pv[(0, 0)].sqrt(), pv[(1, 1)].sqrt(), pv[(2, 2)].sqrt());
    }
    let e = PosEpoch {
        q: Q_SINGLE,
        ns: sol.n_used,
        pos_cross_ned: Vec3::new(p[(0, 1)], p[(1, 2)], p[(2, 0)]),
        ..PosEpoch::UNKNOWN
    };
    (s, e)
}

/// Whether `p` is a UBX log (`.ubx`, any case): raw GPS, Galileo and
/// BeiDou epochs (RXM-RAWX) and their own ephemerides (RXM-SFRBX),
/// [`navfuse_io::ubx_gnss`].
pub fn is_ubx(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("ubx"))
}

/// Read the inputs: the observation file (or a UBX log, [`is_ubx`]) (every system of a RINEX 3 file)
/// and the navigation file(s) (GPS with the header ionosphere; RINEX 3 files
/// also their Galileo, BeiDou and QZSS records).
pub fn load(obs: &Path, nav: &[PathBuf]) -> Result<(ObsFile, GnssObs, SppNav)> {
    let mut n = SppNav::default();
    let (o, g) = if is_ubx(obs) {
        let (rdr, name) = navfuse_io::open(obs).map_err(|e| PipelineError::Input(e.to_string()))?;
        let u = navfuse_io::ubx_gnss::read_ubx_gnss(rdr, &name)
            .map_err(|e| PipelineError::Input(e.to_string()))?;
        n.gps = u.nav;
        n.other = u.other;
        n.glonass = u.glonass;
        (u.obs, u.gnss)
    } else {
        read_obs_gnss(obs).map_err(|e| PipelineError::Input(e.to_string()))?
    };
    for p in nav {
        let (version, kind) = nav_version_type(p)?;
        if version >= 3.0 || kind == 'G' {
            n.glonass.extend(
                navfuse_io::rinex_glonass::read_nav_glonass(p)
                    .map_err(|e| PipelineError::Input(e.to_string()))?,
            );
        }
        if version < 3.0 && kind == 'G' {
            // A RINEX 2 GLONASS navigation file holds nothing else.
            continue;
        }
        n.gps
            .merge(read_nav_data(p).map_err(|e| PipelineError::Input(e.to_string()))?);
        match read_nav_gnss(p) {
            Ok(all) => n
                .other
                .extend(all.ephs.into_iter().filter(|e| e.sys != 'G')),
            // RINEX 2: GPS only, read above.
            Err(e) if e.to_string().contains(navfuse_io::rinex_nav3::NOT_RINEX3) => {}
            Err(e) => return Err(PipelineError::Input(e.to_string())),
        }
    }
    if n.gps.orbits.is_empty() && n.other.is_empty() && n.glonass.is_empty() {
        return Err(PipelineError::Input(format!(
            "{}: no GPS, Galileo, BeiDou, QZSS or GLONASS ephemeris in the navigation file(s)",
            nav.iter()
                .chain(is_ubx(obs).then_some(&obs.to_path_buf()))
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    Ok((o, g, n))
}

/// RINEX version and file type letter of a navigation file's
/// `RINEX VERSION / TYPE` line (2.0 and ' ' when absent: the readers
/// report the problem).
fn nav_version_type(p: &Path) -> Result<(f64, char)> {
    use std::io::BufRead;
    let f = std::fs::File::open(p).map_err(PipelineError::io(p, "cannot open: "))?;
    for l in std::io::BufReader::new(f).lines().take(200) {
        let Ok(l) = l else { break };
        let label = l.get(60..).unwrap_or("");
        if label.starts_with("RINEX VERSION") {
            let v = l.get(..9).unwrap_or("").trim().parse().unwrap_or(2.0);
            let k = l.get(20..21).and_then(|s| s.chars().next()).unwrap_or(' ');
            return Ok((v, k));
        }
        if label.starts_with("END OF HEADER") {
            break;
        }
    }
    Ok((2.0, ' '))
}

/// `navfuse spp`: solve `obs` with `nav` and write `out` (`.pos`), atomically.
pub fn run_spp(obs: &Path, nav: &[PathBuf], out: &Path, opts: &SppOptions) -> Result<SppSummary> {
    let (o, g, n) = load(obs, nav)?;
    let mut sols = Vec::with_capacity(o.epochs.len());
    let mut sum = solve_obs(&o, &g, &n, opts, |sol| {
        sols.push(*sol);
        Ok(())
    })?;
    sum.sigma_scaled = opts.sigma_from_residuals && sum.dof_sum >= MIN_POOLED_DOF;
    let scale = if sum.sigma_scaled {
        sum.variance_factor
    } else {
        1.0
    };
    let mut f = navfuse_io::atomic::AtomicFile::create(out)
        .map_err(PipelineError::io(out, "cannot create: "))?;
    {
        let mut w = PosWriter::new(std::io::BufWriter::with_capacity(1 << 16, &mut f));
        for sol in &sols {
            let (s, e) = pos_row(sol, scale);
            w.write_epoch(&s, &e)
                .map_err(PipelineError::io(out, "cannot write: "))?;
        }
        navfuse_io::writers::TrajectoryWriter::finish(&mut w)
            .map_err(PipelineError::io(out, "cannot write: "))?;
    }
    if sum.solved == 0 {
        return Err(PipelineError::Input(format!(
            "{}: no epoch could be solved\n{}",
            obs.display(),
            sum.text()
        )));
    }
    f.flush()
        .map_err(PipelineError::io(out, "cannot write: "))?;
    f.commit()
        .map_err(PipelineError::io(out, "cannot write: "))?;
    Ok(sum)
}

#[cfg(test)]
#[path = "spp_tests.rs"]
mod tests;
