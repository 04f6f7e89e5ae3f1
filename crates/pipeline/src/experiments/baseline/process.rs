//! The DD filter: satellite ranges, the per-epoch update and fixing, DOPs.

use super::*;

const NPRN: usize = 33;

pub(super) fn sat_range(eph: &KeplerOrbit, rx: &Vec3, t_tag: f64, pr: f64) -> Option<(f64, Vec3)> {
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
) -> Result<Summary, ToolError> {
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
        let mut fixed_dd = Vec::new();
        let mut runner_up_b = None;
        let mut ratio = 0.0;
        let qv: Vec<f64> = (0..na * na).map(|t| q_a[(t / na, t % na)]).collect();
        if let Ok(res) = navfuse_core::lambda::lambda(a_hat.as_slice(), &qv, na, 2) {
            ratio = res.ratio();
            if ratio >= opts.ratio_min {
                let z = DVector::from_iterator(na, res.fixed[0][..na].iter().copied());
                if let Some(qi) = q_a.clone().try_inverse() {
                    // Conditional update x̌ = x̂ − Q_xa Q_a⁻¹ (â − ž) for a candidate ž.
                    let p_xa = p.rows(0, 3) * d.transpose();
                    let cond = |z: &DVector<f64>| {
                        let dx = &p_xa * (&qi * (&a_hat - z));
                        Vec3::new(x[0] - dx[0], x[1] - dx[1], x[2] - dx[2]) - base_pos
                    };
                    fixed_b = Some(cond(&z));
                    if res.m > 1 {
                        let z2 = DVector::from_iterator(na, res.fixed[1][..na].iter().copied());
                        runner_up_b = Some(cond(&z2));
                    }
                    for f in 0..nf {
                        for (i, s) in sats[1..].iter().enumerate() {
                            fixed_dd.push(FixedDd {
                                freq: f,
                                prn: s.prn,
                                ref_prn: refs.prn,
                                n: z[f * m + i].round() as i64,
                            });
                        }
                    }
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
            fixed_dd,
            runner_up_b,
        });
    }
    Ok(out)
}

/// PDOP and GDOP of unit lines of sight (ECEF; any frame gives the same
/// traces): `Q = (GᵀG)⁻¹` with rows `[−eᵀ, 1]`, PDOP = √(Q₁₁+Q₂₂+Q₃₃),
/// GDOP = √tr Q (Misra & Enge §6.1.2). ∞ when fewer than 4 satellites or singular.
pub fn dops(los: impl Iterator<Item = Vec3>) -> (f64, f64) {
    let mut g = nalgebra::Matrix4::<f64>::zeros();
    let mut n = 0;
    for e in los {
        let row = nalgebra::Vector4::new(-e.x, -e.y, -e.z, 1.0);
        g += row * row.transpose();
        n += 1;
    }
    if n < 4 {
        return (f64::INFINITY, f64::INFINITY);
    }
    match g.try_inverse() {
        Some(q) if q.trace() > 0.0 => {
            ((q[(0, 0)] + q[(1, 1)] + q[(2, 2)]).sqrt(), q.trace().sqrt())
        }
        _ => (f64::INFINITY, f64::INFINITY),
    }
}

/// ENU components of an ECEF baseline error at the base.
pub fn enu_at(base: &ObsFile, d: &Vec3) -> Vec3 {
    enu_at_ecef(
        &Vec3::new(base.approx_pos[0], base.approx_pos[1], base.approx_pos[2]),
        d,
    )
}

/// [`enu_at`] for a base given by its ECEF position [m].
pub fn enu_at_ecef(base_e: &Vec3, d: &Vec3) -> Vec3 {
    let navfuse_core::geodesy::Geodetic { lat, lon, .. } =
        navfuse_core::geodesy::ecef_to_geodetic(base_e);
    c_e_enu(lat, lon) * d
}
