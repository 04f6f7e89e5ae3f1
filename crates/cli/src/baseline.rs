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

use navfuse_core::gnss::{
    c_e_enu, ecef_to_llh, KeplerOrbit, C_LIGHT, LAMBDA_L1, LAMBDA_L2, OMEGA_E_DOT,
};
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
        }
    }
}

/// One processed epoch.
#[derive(Clone, Debug)]
pub struct EpochOut {
    pub t: f64,
    pub n_sats: usize,
    /// Baseline rover − base, ECEF [m]: float and (when the ratio passes) fixed.
    pub float_b: Vec3,
    pub fixed_b: Option<Vec3>,
    pub ratio: f64,
    /// Position dilution of precision of the rover's satellites used.
    pub pdop: f64,
}

/// Processing summary.
#[derive(Clone, Debug, Default)]
pub struct Summary {
    pub epochs: Vec<EpochOut>,
    pub unpaired: usize,
    pub slips: usize,
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
    let (lat, lon, _) = ecef_to_llh(&base_pos);
    let c_enu = c_e_enu(lat, lon);
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
        // Common satellites with L1+C1 (and L2+P2), healthy ephemeris, above the mask.
        struct S {
            prn: usize,
            el: f64,
            // per frequency: SD phase [m] and SD code [m], slip flag
            sd_phi: [f64; 2],
            sd_code: [f64; 2],
            slip: [bool; 2],
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
        if sats.len() < 4 {
            continue;
        }
        sats.sort_by(|a, b| b.el.total_cmp(&a.el));
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
        let mut g = nalgebra::Matrix4::<f64>::zeros();
        for s in &sats {
            let row = nalgebra::Vector4::new(-s.e_r.x, -s.e_r.y, -s.e_r.z, 1.0);
            g += row * row.transpose();
        }
        let pdop = g
            .try_inverse()
            .map(|q| (q[(0, 0)] + q[(1, 1)] + q[(2, 2)]).sqrt())
            .unwrap_or(f64::INFINITY);
        out.epochs.push(EpochOut {
            t: be.t,
            n_sats: sats.len(),
            float_b,
            fixed_b,
            ratio,
            pdop,
        });
    }
    Ok(out)
}

/// ENU components of an ECEF baseline error at the base.
fn enu_at(base: &ObsFile, d: &Vec3) -> Vec3 {
    let (lat, lon, _) = ecef_to_llh(&Vec3::new(
        base.approx_pos[0],
        base.approx_pos[1],
        base.approx_pos[2],
    ));
    c_e_enu(lat, lon) * d
}

/// RTKLIB 2.4.2 reference baseline 0759→3040 (data README).
pub const GEONET_REF: [f64; 3] = [-2022.7699, 468.6277, -2610.2896];

/// Statistics of a run against a reference baseline.
pub struct Stats {
    pub n: usize,
    pub fixed: usize,
    pub first_fix_epoch: Option<usize>,
    pub first_correct_fix_epoch: Option<usize>,
    pub wrong_fixed: usize,
    pub last_float_err: Vec3,
    pub last_fixed_err: Option<Vec3>,
    pub last_ratio: f64,
    pub rms_fixed_3d: f64,
    pub rms_float_3d: f64,
    /// RMS 3D over fixed epochs with PDOP ≤ 10, and their count.
    pub rms_fixed_3d_pdop10: f64,
    pub n_fixed_pdop10: usize,
}

pub fn stats(sum: &Summary, reference: &Vec3) -> Stats {
    let mut st = Stats {
        n: sum.epochs.len(),
        fixed: 0,
        first_fix_epoch: None,
        first_correct_fix_epoch: None,
        wrong_fixed: 0,
        last_float_err: Vec3::repeat(f64::NAN),
        last_fixed_err: None,
        last_ratio: f64::NAN,
        rms_fixed_3d: f64::NAN,
        rms_float_3d: f64::NAN,
        rms_fixed_3d_pdop10: f64::NAN,
        n_fixed_pdop10: 0,
    };
    let (mut sf, mut nf, mut sfl) = (0.0, 0usize, 0.0);
    let mut sp = 0.0;
    for (k, e) in sum.epochs.iter().enumerate() {
        sfl += (e.float_b - reference).norm_squared();
        if let Some(b) = e.fixed_b {
            st.fixed += 1;
            st.first_fix_epoch.get_or_insert(k + 1);
            let err = (b - reference).norm();
            // "Correct" = within 5 cm of the reference (evaluation only).
            if err < 0.05 {
                st.first_correct_fix_epoch.get_or_insert(k + 1);
            } else {
                st.wrong_fixed += 1;
            }
            sf += err * err;
            nf += 1;
            if e.pdop <= 10.0 {
                sp += err * err;
                st.n_fixed_pdop10 += 1;
            }
        }
    }
    if let Some(e) = sum.epochs.last() {
        st.last_float_err = e.float_b - reference;
        st.last_fixed_err = e.fixed_b.map(|b| b - reference);
        st.last_ratio = e.ratio;
    }
    if nf > 0 {
        st.rms_fixed_3d = (sf / nf as f64).sqrt();
    }
    if st.n_fixed_pdop10 > 0 {
        st.rms_fixed_3d_pdop10 = (sp / st.n_fixed_pdop10 as f64).sqrt();
    }
    if st.n > 0 {
        st.rms_float_3d = (sfl / st.n as f64).sqrt();
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
/// L1 and L1+L2, against RTKLIB's fixed baseline.
pub fn geonet_part(dir: &Path) -> Result<serde_json::Value, String> {
    let (rover, base, nav) = load(
        &dir.join("30400920.05o"),
        &dir.join("07590920.05o"),
        &[dir.join("07590920.05n"), dir.join("30400920.05n")],
    )?;
    let reference = Vec3::new(GEONET_REF[0], GEONET_REF[1], GEONET_REF[2]);
    println!(
        "\nGEONET 0759 (base) → 3040 (rover), {} / {} epochs, RTKLIB reference baseline |b| = {:.4} m",
        base.epochs.len(),
        rover.epochs.len(),
        reference.norm()
    );
    println!(
        "{:>12} | {:>8} | {:>26} | {:>8} | {:>9} | {:>6} | {:>6} | {:>9} | {:>12}",
        "mode",
        "first fix",
        "fixed err ENU [mm] (last)",
        "|err| mm",
        "float mm",
        "ratio",
        "fix %",
        "RMS3D mm",
        "PDOP≤10 (n)"
    );
    let mut obj = serde_json::Map::new();
    for (label, kin, l2) in [
        ("static L1", false, false),
        ("static L1+L2", false, true),
        ("kin. L1", true, false),
        ("kin. L1+L2", true, true),
    ] {
        let opts = Opts {
            kinematic: kin,
            l2,
            ..Default::default()
        };
        let sum = process(&base, &rover, &nav, &opts)?;
        let st = stats(&sum, &reference);
        let fe = st.last_fixed_err.map(|e| enu_at(&base, &e));
        println!(
            "{:>12} | {:>8} | {:>26} | {:>8} | {:>9.1} | {:>6.1} | {:>6.1} | {:>9.1} | {:>6.1} ({:>3})",
            label,
            st.first_correct_fix_epoch
                .map(|k| k.to_string())
                .unwrap_or("-".into()),
            fe.map(|e| format!("{:+.1} {:+.1} {:+.1}", e.x * 1e3, e.y * 1e3, e.z * 1e3))
                .unwrap_or("-".into()),
            st.last_fixed_err
                .map(|e| format!("{:.1}", e.norm() * 1e3))
                .unwrap_or("-".into()),
            st.last_float_err.norm() * 1e3,
            st.last_ratio,
            100.0 * st.fixed as f64 / st.n.max(1) as f64,
            st.rms_fixed_3d * 1e3,
            st.rms_fixed_3d_pdop10 * 1e3,
            st.n_fixed_pdop10
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
                "float_error_m": st.last_float_err.norm(),
                "fixed_error_m": st.last_fixed_err.map(|e| e.norm()),
                "fixed_error_enu_m": fe.map(|e| [e.x, e.y, e.z]),
                "ratio": st.last_ratio,
                "first_fix_epoch": st.first_fix_epoch,
                "first_correct_fix_epoch": st.first_correct_fix_epoch,
                "fix_rate": st.fixed as f64 / st.n.max(1) as f64,
                "fixed_epochs_over_5cm": st.wrong_fixed,
                "rms_fixed_3d_m": st.rms_fixed_3d,
                "rms_fixed_3d_pdop_le_10_m": st.rms_fixed_3d_pdop10,
                "fixed_epochs_pdop_le_10": st.n_fixed_pdop10,
                "unpaired_epochs": sum.unpaired,
                "slips": sum.slips,
            }),
        );
    }
    // Top-level keys of the schema from static L1 and kinematic L1+L2.
    let s = obj.get("static_l1").cloned().unwrap_or_default();
    let k = obj.get("kin_l1_l2").cloned().unwrap_or_default();
    obj.insert("float_error_m".into(), s["float_error_m"].clone());
    obj.insert("fixed_error_m".into(), s["fixed_error_m"].clone());
    obj.insert("ratio".into(), s["ratio"].clone());
    obj.insert(
        "first_fix_epoch".into(),
        s["first_correct_fix_epoch"].clone(),
    );
    obj.insert("fix_rate".into(), s["fix_rate"].clone());
    obj.insert("kinematic_rms_m".into(), k["rms_fixed_3d_m"].clone());
    obj.insert(
        "kinematic_rms_pdop_le_10_m".into(),
        k["rms_fixed_3d_pdop_le_10_m"].clone(),
    );
    Ok(serde_json::Value::Object(obj))
}

pub fn run(args: Args) -> Result<(), String> {
    let (rover, base, nav) = load(&args.rover, &args.base, &args.nav)?;
    let opts = Opts {
        kinematic: args.kinematic,
        l2: args.l2,
        mask: args.mask_deg.to_radians(),
        ratio_min: args.ratio,
        pair_tol: args.pair_tol,
        ..Default::default()
    };
    let sum = process(&base, &rover, &nav, &opts)?;
    if let Some(p) = &args.out {
        use std::io::Write;
        let mut w = std::io::BufWriter::new(
            std::fs::File::create(p).map_err(|e| format!("{}: {e}", p.display()))?,
        );
        let io = |e: std::io::Error| format!("{}: {e}", p.display());
        writeln!(
            w,
            "gps_time_s,n_sats,float_dx,float_dy,float_dz,fixed_dx,fixed_dy,fixed_dz,ratio"
        )
        .map_err(io)?;
        for e in &sum.epochs {
            let f = e.fixed_b.unwrap_or(Vec3::repeat(f64::NAN));
            writeln!(
                w,
                "{:.3},{},{:.2},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.2}",
                e.t,
                e.n_sats,
                e.pdop,
                e.float_b.x,
                e.float_b.y,
                e.float_b.z,
                f.x,
                f.y,
                f.z,
                e.ratio
            )
            .map_err(io)?;
        }
    }
    let n = sum.epochs.len();
    let nfix = sum.epochs.iter().filter(|e| e.fixed_b.is_some()).count();
    println!(
        "{} paired epochs ({} unpaired), {} fixed ({:.1} %), {} slips reset",
        n,
        sum.unpaired,
        nfix,
        100.0 * nfix as f64 / n.max(1) as f64,
        sum.slips
    );
    if let Some(last) = sum.epochs.last() {
        let b = last.fixed_b.unwrap_or(last.float_b);
        println!(
            "last epoch ({}): baseline ECEF ({:+.4}, {:+.4}, {:+.4}) m, length {:.4} m, ratio {:.1}",
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
            "against the reference: first fix epoch {:?} (correct {:?}), last float error {:.1} mm, last fixed error {} mm, RMS 3D over fixed epochs {:.1} mm ({:.1} mm over the {} with PDOP ≤ 10), epochs > 5 cm off {}",
            st.first_fix_epoch,
            st.first_correct_fix_epoch,
            st.last_float_err.norm() * 1e3,
            st.last_fixed_err.map(|e| format!("{:.1}", e.norm() * 1e3)).unwrap_or("-".into()),
            st.rms_fixed_3d * 1e3,
            st.rms_fixed_3d_pdop10 * 1e3,
            st.n_fixed_pdop10,
            st.wrong_fixed
        );
    }
    Ok(())
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
