//! `navfuse baseline`: carrier-phase double-difference baseline between two
//! RINEX 2 observation files (base at its header position), static or
//! kinematic, float (Kalman filter) and fixed (LAMBDA + ratio test).
//!
//! Model (Teunissen & Montenbruck, *Handbook of GNSS* ch. 23; Groves §10.2):
//! states rover ECEF position and single-difference ambiguities per satellite
//! and frequency [cycles]; measurements the DDs of phase [m] and code against
//! the highest satellite, `DDφ = DDρ + λ(a_i − a_ref)`, `DDP = DDρ`, with the
//! exact DD covariance of elevation-weighted undifferenced noise
//! `σ² = a² + b²/sin²el`. Satellite positions at each receiver's transmission
//! time (from its pseudorange), earth rotation during travel. Epochs of the
//! two files are paired within a tolerance (the GEONET tags drift by ~9 ms).
//! A loss-of-lock flag resets the satellite's ambiguity. Fixing: LAMBDA on the
//! DD ambiguities, ratio ≥ threshold, fixed position by the conditional update.

#![allow(clippy::needless_range_loop)] // per-frequency/per-satellite index loops

use clap::Args as ClapArgs;
use nalgebra::{DMatrix, DVector};
use std::path::{Path, PathBuf};

use navfuse_core::gnss::{c_e_enu, tropo, KeplerOrbit, C_LIGHT, LAMBDA_L1, LAMBDA_L2, OMEGA_E_DOT};
use navfuse_core::Vec3;
use navfuse_io::rinex::{read_nav, read_obs, select_ephemeris, ObsFile};

/// Carrier-phase baseline between two RINEX observation files.
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// Rover observation file (RINEX 2).
    #[arg(long)]
    pub rover: PathBuf,
    /// Base observation file (RINEX 2); its header position is held fixed.
    #[arg(long)]
    pub base: PathBuf,
    /// Navigation file(s) (RINEX 2/3 GPS).
    #[arg(long, required = true)]
    pub nav: Vec<PathBuf>,
    /// Kinematic rover (position re-estimated every epoch).
    #[arg(long)]
    pub kinematic: bool,
    /// Use L2 too (needs L2/P2 observables).
    #[arg(long)]
    pub l2: bool,
    /// Elevation mask [deg].
    #[arg(long, default_value_t = 15.0)]
    pub mask_deg: f64,
    /// Ratio-test threshold.
    #[arg(long, default_value_t = 3.0)]
    pub ratio: f64,
    /// Epoch pairing tolerance [s].
    #[arg(long, default_value_t = 0.02)]
    pub pair_tol: f64,
    /// Reject epochs whose GDOP exceeds this (RTKLIB `pos2-rejgdop`, default
    /// 30); rejected epochs are counted, not solved.
    #[arg(long, default_value_t = 30.0)]
    pub max_gdop: f64,
    /// Do not model the troposphere (Saastamoinen + Niell at both sites).
    #[arg(long)]
    pub no_trop: bool,
    /// Relative humidity for the tropospheric model (0: hydrostatic only).
    #[arg(long, default_value_t = 0.0)]
    pub humidity: f64,
    /// Reference baseline ECEF (dx,dy,dz) [m] to print errors against.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub reference: Option<Vec<f64>>,
    /// Per-epoch CSV output.
    #[arg(long, short)]
    pub out: Option<PathBuf>,
}

/// Processing options.
#[derive(Clone, Copy, Debug)]
pub struct Opts {
    pub kinematic: bool,
    pub l2: bool,
    pub mask: f64,
    pub ratio_min: f64,
    pub pair_tol: f64,
    /// Phase noise a, b [m] of σ² = a² + b²/sin²el; code = `code_factor` × phase.
    pub sigma_phase: f64,
    pub code_factor: f64,
    /// Model the troposphere at both sites (Saastamoinen + Niell,
    /// [`navfuse_core::gnss::tropo`]) with relative humidity `humidity`
    /// (0: hydrostatic part only, as RTKLIB's relative mode).
    pub trop: bool,
    pub humidity: f64,
    /// Reject epochs whose rover GDOP (satellites used, clock included)
    /// exceeds this, before the filter sees them (RTKLIB `pos2-rejgdop`,
    /// default 30). Rejected epochs are counted in [`Summary::rejected`].
    pub max_gdop: f64,
}

impl Default for Opts {
    fn default() -> Self {
        Opts {
            kinematic: false,
            l2: false,
            mask: 15f64.to_radians(),
            ratio_min: 3.0,
            pair_tol: 0.02,
            sigma_phase: 0.003,
            code_factor: 100.0,
            trop: true,
            humidity: 0.0,
            max_gdop: 30.0,
        }
    }
}

/// One processed epoch.
#[derive(Clone, Debug)]
pub struct EpochOut {
    /// 1-based number among the paired epochs (solved and rejected).
    pub epoch: usize,
    pub t: f64,
    pub n_sats: usize,
    /// Baseline rover − base, ECEF [m]: float and (when the ratio passes) fixed.
    pub float_b: Vec3,
    pub fixed_b: Option<Vec3>,
    pub ratio: f64,
    /// Position and geometric dilution of precision of the rover's
    /// satellites used (GDOP includes the receiver clock).
    pub pdop: f64,
    pub gdop: f64,
}

/// Why a paired epoch produced no solution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RejectReason {
    /// Fewer than 4 common satellites above the mask with all observables.
    FewSatellites,
    /// GDOP above [`Opts::max_gdop`].
    Gdop,
    /// The innovation covariance could not be inverted.
    Singular,
}

impl RejectReason {
    pub fn label(self) -> &'static str {
        match self {
            RejectReason::FewSatellites => "few_satellites",
            RejectReason::Gdop => "gdop",
            RejectReason::Singular => "singular",
        }
    }
}

/// A paired epoch without a solution (the filter state is left untouched).
#[derive(Clone, Debug)]
pub struct Rejected {
    /// 1-based number among the paired epochs.
    pub epoch: usize,
    pub t: f64,
    pub n_sats: usize,
    pub gdop: f64,
    pub reason: RejectReason,
}

/// Processing summary. Every paired epoch is either in `epochs` (solved,
/// float or fixed) or in `rejected` (with its reason).
#[derive(Clone, Debug, Default)]
pub struct Summary {
    pub epochs: Vec<EpochOut>,
    pub rejected: Vec<Rejected>,
    pub unpaired: usize,
    pub slips: usize,
}

impl Summary {
    /// Paired epochs: solved plus rejected.
    pub fn paired(&self) -> usize {
        self.epochs.len() + self.rejected.len()
    }
    /// Rejected epochs for `reason`.
    pub fn rejected_for(&self, reason: RejectReason) -> usize {
        self.rejected.iter().filter(|r| r.reason == reason).count()
    }
}

const NPRN: usize = 33;

fn sat_range(eph: &KeplerOrbit, rx: &Vec3, t_tag: f64, pr: f64) -> Option<(f64, Vec3)> {
    let mut t_tx = t_tag - pr / C_LIGHT;
    t_tx -= eph.clock_offset(t_tx);
    let p = eph.position_ecef(t_tx);
    let mut tau = (p - rx).norm() / C_LIGHT;
    let mut rho = 0.0;
    let mut e = Vec3::zeros();
    for _ in 0..3 {
        let th = OMEGA_E_DOT * tau;
        let (s, c) = (th.sin(), th.cos());
        let pr_ = Vec3::new(c * p.x + s * p.y, -s * p.x + c * p.y, p.z);
        let d = pr_ - rx;
        rho = d.norm();
        e = d / rho;
        tau = rho / C_LIGHT;
    }
    if !rho.is_finite() {
        return None;
    }
    Some((rho, e))
}

/// Run the DD filter over paired epochs.
pub fn process(
    base: &ObsFile,
    rover: &ObsFile,
    nav: &[KeplerOrbit],
    opts: &Opts,
) -> Result<Summary, String> {
    let base_pos = Vec3::new(base.approx_pos[0], base.approx_pos[1], base.approx_pos[2]);
    let rover0 = Vec3::new(
        rover.approx_pos[0],
        rover.approx_pos[1],
        rover.approx_pos[2],
    );
    let idx = |f: &ObsFile, c: &str| {
        f.index(c)
            .ok_or_else(|| format!("{}: observable {c} missing", f.marker))
    };
    let (bl1, bc1, rl1, rc1) = (
        idx(base, "L1")?,
        idx(base, "C1")?,
        idx(rover, "L1")?,
        idx(rover, "C1")?,
    );
    let l2idx = if opts.l2 {
        Some((
            idx(base, "L2")?,
            idx(base, "P2")?,
            idx(rover, "L2")?,
            idx(rover, "P2")?,
        ))
    } else {
        None
    };
    let nf = if opts.l2 { 2 } else { 1 };
    let ns = 3 + nf * NPRN;
    let mut x = DVector::<f64>::zeros(ns);
    let mut p = DMatrix::<f64>::zeros(ns, ns);
    x.fixed_rows_mut::<3>(0).copy_from(&rover0);
    for i in 0..3 {
        p[(i, i)] = 100.0;
    }
    let mut active = vec![false; nf * NPRN];
    let navfuse_core::geodesy::Geodetic { lat, lon, .. } =
        navfuse_core::geodesy::ecef_to_geodetic(&base_pos);
    let c_enu = c_e_enu(lat, lon);
    let base_geo = navfuse_core::geodesy::ecef_to_geodetic(&base_pos);
    let mut out = Summary::default();
    let mut j = 0usize;
    for be in &base.epochs {
        while j < rover.epochs.len() && rover.epochs[j].t < be.t - opts.pair_tol {
            j += 1;
            out.unpaired += 1;
        }
        let Some(re) = rover.epochs.get(j) else { break };
        if (re.t - be.t).abs() > opts.pair_tol {
            out.unpaired += 1;
            continue;
        }
        j += 1;
        let epoch = out.paired() + 1;
        if opts.kinematic {
            for i in 0..3 {
                for k in 0..ns {
                    p[(i, k)] = 0.0;
                    p[(k, i)] = 0.0;
                }
                p[(i, i)] = 900.0;
            }
        }
        let xr = Vec3::new(x[0], x[1], x[2]);
        let rover_geo = navfuse_core::geodesy::ecef_to_geodetic(&xr);
        let c_enu_r = c_e_enu(rover_geo.lat, rover_geo.lon);
        let doy = tropo::day_of_year(be.t);
        let trop = |geo: &navfuse_core::geodesy::Geodetic, el: f64| {
            if opts.trop {
                tropo::slant_delay(el, geo.lat, geo.h, doy, opts.humidity)
            } else {
                0.0
            }
        };
        // Common satellites with L1+C1 (and L2+P2), healthy ephemeris, above the mask.
        struct S {
            prn: usize,
            el: f64,
            // per frequency: SD phase [m] and SD code [m], slip flag
            sd_phi: [f64; 2],
            sd_code: [f64; 2],
            slip: [bool; 2],
            // modelled ranges incl. troposphere [m], rover line of sight (ECEF)
            rho_b: f64,
            rho_r: f64,
            e_r: Vec3,
        }
        let mut sats: Vec<S> = Vec::new();
        for (prn, bv) in &be.sats {
            let Some((_, rv)) = re.sats.iter().find(|(q, _)| q == prn) else {
                continue;
            };
            let g = |v: &Vec<Option<navfuse_io::rinex::ObsValue>>, i: usize| {
                v.get(i).copied().flatten()
            };
            let (Some(bl), Some(bc), Some(rl), Some(rc)) =
                (g(bv, bl1), g(bv, bc1), g(rv, rl1), g(rv, rc1))
            else {
                continue;
            };
            let Some(eph) = select_ephemeris(nav, *prn, be.t) else {
                continue;
            };
            let Some((rho_b, e_b)) = sat_range(eph, &base_pos, be.t, bc.value) else {
                continue;
            };
            let Some((rho_r, e_r)) = sat_range(eph, &xr, re.t, rc.value) else {
                continue;
            };
            let el = (c_enu * e_b).z.asin();
            if el < opts.mask {
                continue;
            }
            let el_r = (c_enu_r * e_r).z.asin();
            let rho_b = rho_b + trop(&base_geo, el);
            let rho_r = rho_r + trop(&rover_geo, el_r);
            let mut s = S {
                prn: *prn as usize,
                el,
                sd_phi: [LAMBDA_L1 * (rl.value - bl.value), 0.0],
                sd_code: [rc.value - bc.value, 0.0],
                slip: [(rl.lli | bl.lli) & 1 != 0, false],
                rho_b,
                rho_r,
                e_r,
            };
            if let Some((b2, bp2, r2, rp2)) = l2idx {
                let (Some(bl2), Some(bp), Some(rl2), Some(rp)) =
                    (g(bv, b2), g(bv, bp2), g(rv, r2), g(rv, rp2))
                else {
                    continue;
                };
                s.sd_phi[1] = LAMBDA_L2 * (rl2.value - bl2.value);
                s.sd_code[1] = rp.value - bp.value;
                s.slip[1] = (rl2.lli | bl2.lli) & 1 != 0;
            }
            if s.prn < NPRN {
                sats.push(s);
            }
        }
        sats.sort_by(|a, b| b.el.total_cmp(&a.el));
        let (pdop, gdop) = dops(sats.iter().map(|s| s.e_r));
        let reject = if sats.len() < 4 {
            Some(RejectReason::FewSatellites)
        } else if gdop.is_nan() || gdop > opts.max_gdop {
            Some(RejectReason::Gdop)
        } else {
            None
        };
        let lam = [LAMBDA_L1, LAMBDA_L2];
        // Ambiguity states: reset on slips or (re)appearance; drop vanished.
        for f in 0..nf {
            let mut seen = [false; NPRN];
            for s in &sats {
                seen[s.prn] = true;
                let k = 3 + f * NPRN + s.prn;
                if !active[f * NPRN + s.prn] || s.slip[f] {
                    if s.slip[f] && active[f * NPRN + s.prn] {
                        out.slips += 1;
                    }
                    for c in 0..ns {
                        p[(k, c)] = 0.0;
                        p[(c, k)] = 0.0;
                    }
                    x[k] = (s.sd_phi[f] - s.sd_code[f]) / lam[f];
                    p[(k, k)] = 30.0 * 30.0;
                    active[f * NPRN + s.prn] = true;
                }
            }
            for prn in 0..NPRN {
                if !seen[prn] && active[f * NPRN + prn] {
                    active[f * NPRN + prn] = false;
                    let k = 3 + f * NPRN + prn;
                    for c in 0..ns {
                        p[(k, c)] = 0.0;
                        p[(c, k)] = 0.0;
                    }
                    x[k] = 0.0;
                }
            }
        }
        // A rejected epoch still resets slipped ambiguities (above) but does
        // not update the filter (RTKLIB: no relative solution when the
        // point positioning fails its GDOP check).
        if let Some(reason) = reject {
            out.rejected.push(Rejected {
                epoch,
                t: be.t,
                n_sats: sats.len(),
                gdop,
                reason,
            });
            continue;
        }
        let m = sats.len() - 1;
        let nm = 2 * nf * m;
        let mut h = DMatrix::<f64>::zeros(nm, ns);
        let mut v = DVector::<f64>::zeros(nm);
        let mut r = DMatrix::<f64>::zeros(nm, nm);
        let sig2 = |el: f64, code: bool| {
            let a = opts.sigma_phase * if code { opts.code_factor } else { 1.0 };
            a * a + a * a / (el.sin() * el.sin())
        };
        let refs = &sats[0];
        let xr = Vec3::new(x[0], x[1], x[2]);
        for f in 0..nf {
            for (kind, code) in [(0usize, false), (1usize, true)] {
                let row0 = (f * 2 + kind) * m;
                for (i, s) in sats[1..].iter().enumerate() {
                    let row = row0 + i;
                    let dd_rho = (s.rho_r - s.rho_b) - (refs.rho_r - refs.rho_b);
                    let hp = -(s.e_r - refs.e_r);
                    for c in 0..3 {
                        h[(row, c)] = hp[c];
                    }
                    let obs = if code {
                        s.sd_code[f] - refs.sd_code[f]
                    } else {
                        s.sd_phi[f] - refs.sd_phi[f]
                    };
                    let mut model = dd_rho;
                    if !code {
                        let ki = 3 + f * NPRN + s.prn;
                        let kr = 3 + f * NPRN + refs.prn;
                        h[(row, ki)] = lam[f];
                        h[(row, kr)] = -lam[f];
                        model += lam[f] * (x[ki] - x[kr]);
                    }
                    // The range was computed at the current estimate: the innovation is linear around it.
                    let _ = xr;
                    v[row] = obs - model;
                    let sref = 2.0 * sig2(refs.el, code);
                    for i2 in 0..m {
                        r[(row, row0 + i2)] = sref;
                    }
                    r[(row, row)] += 2.0 * sig2(s.el, code);
                }
            }
        }
        // Kalman update (Joseph form).
        let pht = &p * h.transpose();
        let s_mat = &h * &pht + &r;
        let Some(s_inv) = s_mat.clone().try_inverse() else {
            out.rejected.push(Rejected {
                epoch,
                t: be.t,
                n_sats: sats.len(),
                gdop,
                reason: RejectReason::Singular,
            });
            continue;
        };
        let k = &pht * &s_inv;
        x += &k * &v;
        let ikh = DMatrix::<f64>::identity(ns, ns) - &k * &h;
        p = &ikh * &p * ikh.transpose() + &k * &r * k.transpose();
        let float_b = Vec3::new(x[0], x[1], x[2]) - base_pos;
        // LAMBDA on the DD ambiguities.
        let na = nf * m;
        let mut d = DMatrix::<f64>::zeros(na, ns);
        for f in 0..nf {
            for (i, s) in sats[1..].iter().enumerate() {
                d[(f * m + i, 3 + f * NPRN + s.prn)] = 1.0;
                d[(f * m + i, 3 + f * NPRN + refs.prn)] = -1.0;
            }
        }
        let a_hat = &d * &x;
        let q_a = &d * &p * d.transpose();
        let mut fixed_b = None;
        let mut ratio = 0.0;
        let qv: Vec<f64> = (0..na * na).map(|t| q_a[(t / na, t % na)]).collect();
        if let Ok(res) = navfuse_core::lambda::lambda(a_hat.as_slice(), &qv, na, 2) {
            ratio = res.ratio();
            if ratio >= opts.ratio_min {
                let z = DVector::from_iterator(na, res.fixed[0][..na].iter().copied());
                if let Some(qi) = q_a.clone().try_inverse() {
                    let p_xa = p.rows(0, 3) * d.transpose();
                    let dx = p_xa * (qi * (&a_hat - z));
                    let xf = Vec3::new(x[0] - dx[0], x[1] - dx[1], x[2] - dx[2]);
                    fixed_b = Some(xf - base_pos);
                }
            }
        }
        out.epochs.push(EpochOut {
            epoch,
            t: be.t,
            n_sats: sats.len(),
            float_b,
            fixed_b,
            ratio,
            pdop,
            gdop,
        });
    }
    Ok(out)
}

/// PDOP and GDOP of unit lines of sight (ECEF; any frame gives the same
/// traces): `Q = (GᵀG)⁻¹` with rows `[−eᵀ, 1]`, PDOP = √(Q₁₁+Q₂₂+Q₃₃),
/// GDOP = √tr Q (Misra & Enge §6.1.2). ∞ when fewer than 4 satellites or singular.
fn dops(los: impl Iterator<Item = Vec3>) -> (f64, f64) {
    let mut g = nalgebra::Matrix4::<f64>::zeros();
    for e in los {
        let row = nalgebra::Vector4::new(-e.x, -e.y, -e.z, 1.0);
        g += row * row.transpose();
    }
    match g.try_inverse() {
        Some(q) if q.trace() > 0.0 => {
            ((q[(0, 0)] + q[(1, 1)] + q[(2, 2)]).sqrt(), q.trace().sqrt())
        }
        _ => (f64::INFINITY, f64::INFINITY),
    }
}

/// ENU components of an ECEF baseline error at the base.
fn enu_at(base: &ObsFile, d: &Vec3) -> Vec3 {
    let navfuse_core::geodesy::Geodetic { lat, lon, .. } = navfuse_core::geodesy::ecef_to_geodetic(
        &Vec3::new(base.approx_pos[0], base.approx_pos[1], base.approx_pos[2]),
    );
    c_e_enu(lat, lon) * d
}

/// RTKLIB 2.4.2 reference baseline 0759→3040 (data README).
pub const GEONET_REF: [f64; 3] = [-2022.7699, 468.6277, -2610.2896];

/// Statistics of a run against a reference baseline. Epoch numbers and the
/// fix rate count every paired epoch (rejected ones included); the RMS is
/// over the fixed epochs (`fixed` of them).
pub struct Stats {
    /// Paired epochs, and how many of them were rejected (by reason).
    pub n: usize,
    pub rejected_gdop: usize,
    pub rejected_few_sats: usize,
    pub rejected_singular: usize,
    pub fixed: usize,
    /// `fixed / n`.
    pub fix_rate: f64,
    pub first_fix_epoch: Option<usize>,
    /// First fixed epoch within 5 cm of the reference, and its ratio.
    pub first_correct_fix_epoch: Option<usize>,
    pub first_correct_fix_ratio: f64,
    pub wrong_fixed: usize,
    pub last_float_err: Vec3,
    pub last_fixed_err: Option<Vec3>,
    pub last_ratio: f64,
    /// 3D RMS of the fixed baselines against the reference [m].
    pub rms_fixed_3d: f64,
    /// 3D RMS of the float baselines of the solved epochs [m].
    pub rms_float_3d: f64,
}

pub fn stats(sum: &Summary, reference: &Vec3) -> Stats {
    let mut st = Stats {
        n: sum.paired(),
        rejected_gdop: sum.rejected_for(RejectReason::Gdop),
        rejected_few_sats: sum.rejected_for(RejectReason::FewSatellites),
        rejected_singular: sum.rejected_for(RejectReason::Singular),
        fixed: 0,
        fix_rate: f64::NAN,
        first_fix_epoch: None,
        first_correct_fix_epoch: None,
        first_correct_fix_ratio: f64::NAN,
        wrong_fixed: 0,
        last_float_err: Vec3::repeat(f64::NAN),
        last_fixed_err: None,
        last_ratio: f64::NAN,
        rms_fixed_3d: f64::NAN,
        rms_float_3d: f64::NAN,
    };
    let (mut sf, mut sfl) = (0.0, 0.0);
    for e in &sum.epochs {
        sfl += (e.float_b - reference).norm_squared();
        if let Some(b) = e.fixed_b {
            st.fixed += 1;
            st.first_fix_epoch.get_or_insert(e.epoch);
            let err = (b - reference).norm();
            // "Correct" = within 5 cm of the reference (evaluation only).
            if err < 0.05 {
                if st.first_correct_fix_epoch.is_none() {
                    st.first_correct_fix_epoch = Some(e.epoch);
                    st.first_correct_fix_ratio = e.ratio;
                }
            } else {
                st.wrong_fixed += 1;
            }
            sf += err * err;
        }
    }
    if let Some(e) = sum.epochs.last() {
        st.last_float_err = e.float_b - reference;
        st.last_fixed_err = e.fixed_b.map(|b| b - reference);
        st.last_ratio = e.ratio;
    }
    if st.fixed > 0 {
        st.rms_fixed_3d = (sf / st.fixed as f64).sqrt();
    }
    if !sum.epochs.is_empty() {
        st.rms_float_3d = (sfl / sum.epochs.len() as f64).sqrt();
    }
    if st.n > 0 {
        st.fix_rate = st.fixed as f64 / st.n as f64;
    }
    st
}

fn load(
    rover: &Path,
    base: &Path,
    navs: &[PathBuf],
) -> Result<(ObsFile, ObsFile, Vec<KeplerOrbit>), String> {
    let r = read_obs(rover).map_err(|e| e.to_string())?;
    let b = read_obs(base).map_err(|e| e.to_string())?;
    let mut nav = Vec::new();
    for n in navs {
        nav.extend(read_nav(n).map_err(|e| e.to_string())?);
    }
    Ok((r, b, nav))
}

/// The GEONET part of `navfuse experiment seed003`: static and kinematic,
/// L1 and L1+L2, against RTKLIB's fixed baseline; the kinematic L1+L2 run
/// also without the GDOP gate, to show what the gate changes.
pub fn geonet_part(dir: &Path) -> Result<serde_json::Value, String> {
    let (rover, base, nav) = load(
        &dir.join("30400920.05o"),
        &dir.join("07590920.05o"),
        &[dir.join("07590920.05n"), dir.join("30400920.05n")],
    )?;
    let reference = Vec3::new(GEONET_REF[0], GEONET_REF[1], GEONET_REF[2]);
    let max_gdop = Opts::default().max_gdop;
    println!(
        "\nGEONET 0759 (base) → 3040 (rover), {} / {} epochs, RTKLIB reference baseline |b| = {:.4} m",
        base.epochs.len(),
        rover.epochs.len(),
        reference.norm()
    );
    println!(
        "epochs with GDOP > {max_gdop} are rejected (RTKLIB pos2-rejgdop) and count as not fixed; RMS over the fixed epochs"
    );
    println!(
        "{:>17} | {:>15} | {:>26} | {:>8} | {:>9} | {:>6} | {:>13} | {:>8} | {:>8}",
        "mode",
        "1st fix (ratio)",
        "fixed err ENU [mm] (last)",
        "|err| mm",
        "float mm",
        "ratio",
        "fixed/epochs",
        "rej.GDOP",
        "RMS3D mm"
    );
    let mut obj = serde_json::Map::new();
    for (label, kin, l2, gdop) in [
        ("static L1", false, false, max_gdop),
        ("static L1+L2", false, true, max_gdop),
        ("kin. L1", true, false, max_gdop),
        ("kin. L1+L2", true, true, max_gdop),
        ("kin. L1+L2 no gate", true, true, f64::INFINITY),
    ] {
        let opts = Opts {
            kinematic: kin,
            l2,
            max_gdop: gdop,
            ..Default::default()
        };
        let sum = process(&base, &rover, &nav, &opts)?;
        let st = stats(&sum, &reference);
        let fe = st.last_fixed_err.map(|e| enu_at(&base, &e));
        println!(
            "{:>17} | {:>15} | {:>26} | {:>8} | {:>9.1} | {:>6.1} | {:>13} | {:>8} | {:>8.1}",
            label,
            st.first_correct_fix_epoch
                .map(|k| format!("{k} ({:.2})", st.first_correct_fix_ratio))
                .unwrap_or("-".into()),
            fe.map(|e| format!("{:+.1} {:+.1} {:+.1}", e.x * 1e3, e.y * 1e3, e.z * 1e3))
                .unwrap_or("-".into()),
            st.last_fixed_err
                .map(|e| format!("{:.1}", e.norm() * 1e3))
                .unwrap_or("-".into()),
            st.last_float_err.norm() * 1e3,
            st.last_ratio,
            format!("{}/{} ({:.1} %)", st.fixed, st.n, 100.0 * st.fix_rate),
            st.rejected_gdop,
            st.rms_fixed_3d * 1e3,
        );
        let key = label
            .replace(' ', "_")
            .replace('.', "")
            .replace('+', "_")
            .to_lowercase();
        obj.insert(
            key,
            serde_json::json!({
                "epochs": st.n,
                "max_gdop": if gdop.is_finite() { Some(gdop) } else { None },
                "rejected_gdop": st.rejected_gdop,
                "rejected_few_satellites": st.rejected_few_sats,
                "rejected_singular": st.rejected_singular,
                "float_error_m": st.last_float_err.norm(),
                "fixed_error_m": st.last_fixed_err.map(|e| e.norm()),
                "fixed_error_enu_m": fe.map(|e| [e.x, e.y, e.z]),
                "ratio": st.last_ratio,
                "first_fix_epoch": st.first_fix_epoch,
                "first_correct_fix_epoch": st.first_correct_fix_epoch,
                "first_correct_fix_ratio": st.first_correct_fix_ratio,
                "fixed_epochs": st.fixed,
                "fix_rate": st.fix_rate,
                "fixed_epochs_over_5cm": st.wrong_fixed,
                "rms_fixed_3d_m": st.rms_fixed_3d,
                "unpaired_epochs": sum.unpaired,
                "slips": sum.slips,
            }),
        );
    }
    // Top-level keys of the schema: static L1 for the fix, kinematic
    // L1+L2 (GDOP-gated; RMS over its fixed epochs) for the RMS.
    let s = obj.get("static_l1").cloned().unwrap_or_default();
    let s2 = obj.get("static_l1_l2").cloned().unwrap_or_default();
    let k = obj.get("kin_l1_l2").cloned().unwrap_or_default();
    let k0 = obj.get("kin_l1_l2_no_gate").cloned().unwrap_or_default();
    for (to, from, key) in [
        ("float_error_m", &s, "float_error_m"),
        ("fixed_error_m", &s, "fixed_error_m"),
        ("ratio", &s, "ratio"),
        ("first_fix_epoch", &s, "first_correct_fix_epoch"),
        ("first_fix_ratio", &s, "first_correct_fix_ratio"),
        ("fix_rate", &s, "fix_rate"),
        ("first_fix_epoch_l1_l2", &s2, "first_correct_fix_epoch"),
        ("fix_rate_l1_l2", &s2, "fix_rate"),
        ("max_gdop", &k, "max_gdop"),
        ("rejected_gdop", &k, "rejected_gdop"),
        ("kinematic_rms_m", &k, "rms_fixed_3d_m"),
        ("kinematic_epochs", &k, "fixed_epochs"),
        ("kinematic_fix_rate", &k, "fix_rate"),
        ("kinematic_rms_no_gate_m", &k0, "rms_fixed_3d_m"),
        ("kinematic_epochs_no_gate", &k0, "fixed_epochs"),
    ] {
        obj.insert(to.into(), from[key].clone());
    }
    obj.insert(
        "kinematic_rms_over".into(),
        "fixed epochs of kin_l1_l2 (GDOP-gated); fix rates over all paired epochs".into(),
    );
    Ok(serde_json::Value::Object(obj))
}

pub fn run(args: Args) -> Result<(), String> {
    if args.max_gdop.is_nan() || args.max_gdop <= 0.0 {
        return Err(format!("--max-gdop must be > 0, got {}", args.max_gdop));
    }
    if !(0.0..=1.0).contains(&args.humidity) {
        return Err(format!("--humidity must be in 0..1, got {}", args.humidity));
    }
    let (rover, base, nav) = load(&args.rover, &args.base, &args.nav)?;
    let opts = Opts {
        kinematic: args.kinematic,
        l2: args.l2,
        mask: args.mask_deg.to_radians(),
        ratio_min: args.ratio,
        pair_tol: args.pair_tol,
        max_gdop: args.max_gdop,
        trop: !args.no_trop,
        humidity: args.humidity,
        ..Default::default()
    };
    let sum = process(&base, &rover, &nav, &opts)?;
    if let Some(p) = &args.out {
        write_csv(p, &sum)?;
    }
    let n = sum.paired();
    let nfix = sum.epochs.iter().filter(|e| e.fixed_b.is_some()).count();
    println!(
        "{} paired epochs ({} unpaired): {} solved, {} fixed ({:.1} % of paired), {} slips reset",
        n,
        sum.unpaired,
        sum.epochs.len(),
        nfix,
        100.0 * nfix as f64 / n.max(1) as f64,
        sum.slips
    );
    println!(
        "rejected: {} GDOP > {} , {} < 4 satellites, {} singular",
        sum.rejected_for(RejectReason::Gdop),
        args.max_gdop,
        sum.rejected_for(RejectReason::FewSatellites),
        sum.rejected_for(RejectReason::Singular)
    );
    if let Some(last) = sum.epochs.last() {
        let b = last.fixed_b.unwrap_or(last.float_b);
        println!(
            "last solved epoch {} ({}): baseline ECEF ({:+.4}, {:+.4}, {:+.4}) m, length {:.4} m, ratio {:.1}",
            last.epoch,
            if last.fixed_b.is_some() { "fixed" } else { "float" },
            b.x,
            b.y,
            b.z,
            b.norm(),
            last.ratio
        );
        let enu = enu_at(&base, &b);
        println!(
            "ENU at base: E {:+.4} N {:+.4} U {:+.4} m",
            enu.x, enu.y, enu.z
        );
    }
    if let Some(r) = &args.reference {
        if r.len() != 3 {
            return Err(format!(
                "--reference needs 3 values dx,dy,dz, got {}",
                r.len()
            ));
        }
        let reference = Vec3::new(r[0], r[1], r[2]);
        let st = stats(&sum, &reference);
        println!(
            "against the reference: first fix epoch {:?}, first correct fix epoch {:?} (ratio {:.2}), last float error {:.1} mm, last fixed error {} mm, 3D RMS over the {} fixed epochs {:.1} mm, fixed epochs > 5 cm off {}",
            st.first_fix_epoch,
            st.first_correct_fix_epoch,
            st.first_correct_fix_ratio,
            st.last_float_err.norm() * 1e3,
            st.last_fixed_err.map(|e| format!("{:.1}", e.norm() * 1e3)).unwrap_or("-".into()),
            st.fixed,
            st.rms_fixed_3d * 1e3,
            st.wrong_fixed
        );
    }
    Ok(())
}

/// Per-epoch CSV: solved and rejected epochs in time order (`status` fixed,
/// float or `rejected_<reason>`; a rejected epoch has empty baselines).
fn write_csv(p: &Path, sum: &Summary) -> Result<(), String> {
    use std::io::Write;
    let mut w = std::io::BufWriter::new(
        std::fs::File::create(p).map_err(|e| format!("{}: {e}", p.display()))?,
    );
    let io = |e: std::io::Error| format!("{}: {e}", p.display());
    writeln!(
        w,
        "epoch,gps_time_s,status,n_sats,pdop,gdop,float_dx,float_dy,float_dz,fixed_dx,fixed_dy,fixed_dz,ratio"
    )
    .map_err(io)?;
    let mut rows: Vec<(usize, String)> = Vec::with_capacity(sum.paired());
    for e in &sum.epochs {
        let fixed = e
            .fixed_b
            .map(|f| format!("{:.4},{:.4},{:.4}", f.x, f.y, f.z))
            .unwrap_or(",,".into());
        rows.push((
            e.epoch,
            format!(
                "{},{:.3},{},{},{:.2},{:.2},{:.4},{:.4},{:.4},{},{:.2}",
                e.epoch,
                e.t,
                if e.fixed_b.is_some() {
                    "fixed"
                } else {
                    "float"
                },
                e.n_sats,
                e.pdop,
                e.gdop,
                e.float_b.x,
                e.float_b.y,
                e.float_b.z,
                fixed,
                e.ratio
            ),
        ));
    }
    for r in &sum.rejected {
        rows.push((
            r.epoch,
            format!(
                "{},{:.3},rejected_{},{},,{:.2},,,,,,,",
                r.epoch,
                r.t,
                r.reason.label(),
                r.n_sats,
                r.gdop
            ),
        ));
    }
    rows.sort_by_key(|r| r.0);
    for (_, line) in rows {
        writeln!(w, "{line}").map_err(io)?;
    }
    w.flush().map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Real data: the GEONET static baseline fixes and matches RTKLIB's.
    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn geonet_static_l1_matches_rtklib() {
        let dir = navfuse_io::data::require("gnss/rinex/07590920.05o");
        let dir = dir.parent().unwrap();
        let (rover, base, nav) = load(
            &dir.join("30400920.05o"),
            &dir.join("07590920.05o"),
            &[dir.join("07590920.05n")],
        )
        .unwrap();
        let sum = process(&base, &rover, &nav, &Opts::default()).unwrap();
        let st = stats(
            &sum,
            &Vec3::new(GEONET_REF[0], GEONET_REF[1], GEONET_REF[2]),
        );
        assert!(st.n >= 115, "{}", st.n);
        let e = st.last_fixed_err.expect("fixed at the last epoch");
        assert!(e.norm() < 0.02, "fixed error {:.4} m", e.norm());
        assert!(
            st.fixed as f64 >= 0.9 * st.n as f64,
            "fix rate {}/{}",
            st.fixed,
            st.n
        );
        assert_eq!(st.wrong_fixed, 0);
    }
}
