//! `navfuse spp`: single-point positions from a RINEX observation file and
//! broadcast navigation file(s) ([`navfuse_core::gnss::spp`] per epoch),
//! written as an RTKLIB `.pos` (Q = 5 "single") with a summary of the
//! epochs used and rejected, and of the satellites skipped, with reasons.
//!
//! Inputs: GPS L1 C/A code (`C1`, else `P1` when an epoch has no `C1`),
//! Doppler `D1` when present. Ephemeris: per satellite the record whose
//! t_oe is nearest the epoch, within ±2 h (half the 4 h curve-fit interval
//! of IS-GPS-200 §20.3.4.4; RTKLIB `MAXDTOE`); its health is then checked
//! by the solver. The output time is the receiver time tag corrected by the
//! estimated receiver clock (GPS time of the measurement), as RTKLIB's.

use crate::error::{PipelineError, Result};
use navfuse_core::geodesy::{c_en, ecef_to_geodetic};
use navfuse_core::gnss::spp::{
    ura_sigma_m, SkipCounts, Spp, SppConfig, SppObs, SppReject, SppSolution, MAX_SATS,
};
use navfuse_core::gnss::{C_LIGHT, LAMBDA_L1};
use navfuse_core::types::{NavSolution, Vec3};
use navfuse_io::pos_writer::{PosEpoch, PosWriter, Q_SINGLE};
use navfuse_io::rinex::{read_nav_data, read_obs, NavData, ObsFile};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Half the IS-GPS-200 4 h curve-fit interval [s].
pub const MAX_EPH_AGE_S: f64 = 7200.0;

/// Options of `navfuse spp`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct SppOptions {
    /// Solver options (elevation mask, models, RAIM, GDOP limit).
    pub solver: SppConfig,
}

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
    /// RAIM exclusions in total and per PRN (index = PRN).
    pub raim_excluded: u64,
    pub raim_by_prn: Vec<(u8, u32)>,
    /// Non-GPS satellite entries the reader skipped, event records skipped.
    pub non_gps_skipped: usize,
    pub events_skipped: usize,
    /// Epochs with a Doppler velocity.
    pub with_velocity: usize,
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
        if !self.raim_by_prn.is_empty() {
            let list: Vec<String> = self
                .raim_by_prn
                .iter()
                .map(|(p, n)| format!("G{p:02}×{n}"))
                .collect();
            s += &format!(" ({})", list.join(", "));
        }
        s += &format!(
            "\nnon-GPS entries skipped {}, event records skipped {}, epochs with Doppler velocity {}",
            self.non_gps_skipped, self.events_skipped, self.with_velocity
        );
        s
    }
}

/// The ephemerides of each PRN (1..=32), as indices into `nav.orbits`.
fn by_prn(nav: &NavData) -> Vec<Vec<usize>> {
    let mut v = vec![Vec::new(); 33];
    for (i, o) in nav.orbits.iter().enumerate() {
        if (1..=32).contains(&o.prn) {
            v[o.prn as usize].push(i);
        }
    }
    v
}

/// Solve every epoch of `obs`; `on_epoch` gets each solution.
pub fn solve_obs(
    obs: &ObsFile,
    nav: &NavData,
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
    let eph = by_prn(nav);
    let mut spp = Spp::new(opts.solver, nav.iono);
    let mut sum = SppSummary {
        epochs: obs.epochs.len(),
        non_gps_skipped: obs.skipped_non_gps,
        events_skipped: obs.events_skipped,
        ..SppSummary::default()
    };
    let mut raim = [0u32; 33];
    let mut buf = [SppObs::default(); MAX_SATS];
    let mut prior: Option<Vec3> = None;
    for ep in &obs.epochs {
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
            let best = eph
                .get(*prn as usize)
                .into_iter()
                .flatten()
                .copied()
                .filter(|&i| (nav.orbits[i].t_oe - ep.t).abs() <= MAX_EPH_AGE_S)
                // Nearest t_oe; on a tie the later one (newer upload).
                .min_by(|&a, &b| {
                    let (ta, tb) = (nav.orbits[a].t_oe, nav.orbits[b].t_oe);
                    (ta - ep.t)
                        .abs()
                        .total_cmp(&(tb - ep.t).abs())
                        .then(tb.total_cmp(&ta))
                });
            let Some(k) = best else {
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
                kind: navfuse_core::gnss::orbit_gnss::OrbitKind::Gps,
                ura_m: ura_sigma_m(nav.ura_m.get(k).copied().unwrap_or(f64::NAN)),
            };
            n += 1;
        }
        let res = spp.solve(ep.t, &buf[..n], prior);
        add_skips(&mut sum, &spp.skips());
        match res {
            Ok(sol) => {
                sum.solved += 1;
                if sol.vel.is_some() {
                    sum.with_velocity += 1;
                }
                for p in &sol.excluded_prn[..sol.n_excluded as usize] {
                    raim[(*p as usize).min(32)] += 1;
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
    sum.raim_by_prn = (0..33u8)
        .filter(|&p| raim[p as usize] > 0)
        .map(|p| (p, raim[p as usize]))
        .collect();
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

/// The `.pos` row of a solution: geodetic position, NED σ and cross terms.
pub fn pos_row(sol: &SppSolution) -> (NavSolution, PosEpoch) {
    let g = ecef_to_geodetic(&sol.pos_e);
    let c = c_en(g.lat, g.lon);
    let p = c * sol.cov_pos_e * c.transpose();
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
    };
    (s, e)
}

/// Read the inputs: the observation file and the navigation file(s).
pub fn load(obs: &Path, nav: &[PathBuf]) -> Result<(ObsFile, NavData)> {
    let o = read_obs(obs).map_err(|e| PipelineError::Input(e.to_string()))?;
    let mut n = NavData::default();
    for p in nav {
        n.merge(read_nav_data(p).map_err(|e| PipelineError::Input(e.to_string()))?);
    }
    if n.orbits.is_empty() {
        return Err(PipelineError::Input(format!(
            "{}: no GPS ephemeris in the navigation file(s)",
            nav.iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    Ok((o, n))
}

/// `navfuse spp`: solve `obs` with `nav` and write `out` (`.pos`), atomically.
pub fn run_spp(obs: &Path, nav: &[PathBuf], out: &Path, opts: &SppOptions) -> Result<SppSummary> {
    let (o, n) = load(obs, nav)?;
    let mut f = navfuse_io::atomic::AtomicFile::create(out)
        .map_err(PipelineError::io(out, "cannot create: "))?;
    let sum = {
        let mut w = PosWriter::new(std::io::BufWriter::with_capacity(1 << 16, &mut f));
        let sum = solve_obs(&o, &n, opts, |sol| {
            let (s, e) = pos_row(sol);
            w.write_epoch(&s, &e)
                .map_err(PipelineError::io(out, "cannot write: "))
        })?;
        navfuse_io::writers::TrajectoryWriter::finish(&mut w)
            .map_err(PipelineError::io(out, "cannot write: "))?;
        sum
    };
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
