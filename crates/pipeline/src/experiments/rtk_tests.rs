//! The RTK/INS experiment at CI size (2 seeds × 500 s, both IMU grades;
//! the YUMA almanac of the data folder). The assertions are the module's
//! targets, written before the runs: with the INS every seed fixes, no
//! wrong fix, fixed epochs ≤ 2 cm horizontal RMS, the injected slip caught
//! by the INS-predicted test, float ≤ 0.3 m in the 4-satellite window, and
//! a faster re-fix after the outage than without the INS.

use super::*;

/// The dual-frequency G+E+C scenario at CI size (1 seed × 500 s,
/// both IMU grades; synthetic constellations, no data files). Asserted
/// with the INS (targets of the module documentation that the 20-seed run
/// reached): a fix within 5 s, re-fix within 2 epochs after the 30 s
/// outage, no wrong fix, full-sky fixed epochs ≤ 2 cm horizontal RMS, the
/// injected slip caught by the INS-predicted test. GNSS-only (the
/// comparison mode): no wrong fix, the injected slip caught by the GF/MW
/// test, and no divergence (float horizontal RMS < 10 m; it was 10⁵ m on
/// 5 of 20 seeds before its constant-velocity model). The 4-satellite
/// window's comparison (the "where GNSS-only RTK loses the fix")
/// is not asserted on one seed: with a sound GNSS-only mode it was a tie on
/// seed 1 (0.715 m with the phone IMU, 0.713 m without); the 20-seed run
/// of the module documentation reports it.
#[test]
fn dual_frequency_rtk_ins_fixes_fast_and_right() {
    let o = Options {
        seeds: 1,
        duration: 500.0,
        ..Default::default()
    };
    let r = run_rtk(&o).unwrap();
    assert!(r.failed.is_empty(), "{:?}", r.failed);
    for (g, gr) in &r.by_imu {
        let w = &gr.with_ins;
        assert_eq!(w.never_fixed, 0, "{g}: {w:?}");
        assert!(w.first_fix_s.unwrap() <= 5.0, "{g}: {w:?}");
        assert!(w.refix_epochs.unwrap() <= 2.0, "{g}: {w:?}");
        assert_eq!(w.refix_censored, 0, "{g}: {w:?}");
        assert_eq!(w.wrong_fixes, 0.0, "{g}: {w:?}");
        assert!(w.fixed_h_rms_full_sky_m.unwrap() <= 0.02, "{g}: {w:?}");
        assert_eq!(w.injected_slip_detected, 1, "{g}: {w:?}");
        let wo = &gr.without_ins;
        assert_eq!(wo.wrong_fixes, 0.0, "{g}: {wo:?}");
        assert_eq!(wo.injected_slip_dual, 1, "{g}: {wo:?}");
        assert!(wo.float_h_rms_m.unwrap() < 10.0, "{g}: {wo:?}");
    }
}

#[test]
#[ignore = "real data (YUMA almanac): run with `cargo test --release -- --ignored`"]
fn rtk_ins_fixes_right_and_refixes_faster_than_gnss_only() {
    navfuse_io::data::require("gnss/almanac/yuma_week1011.alm");
    let o = Options {
        seeds: 2,
        duration: 500.0,
        single_frequency: true,
        ..Default::default()
    };
    let r = run_rtk(&o).unwrap();
    assert!(r.failed.is_empty(), "{:?}", r.failed);
    for (g, gr) in &r.by_imu {
        let w = &gr.with_ins;
        assert_eq!(w.never_fixed, 0, "{g}: {w:?}");
        assert_eq!(w.wrong_fixes, 0.0, "{g}: {w:?}");
        assert!(w.fixed_h_rms_m.unwrap() <= 0.02, "{g}: {w:?}");
        assert_eq!(w.injected_slip_detected, 2, "{g}: {w:?}");
        assert!(w.partial_sky_h_m.unwrap() <= 0.3, "{g}: {w:?}");
        let wo = &gr.without_ins;
        assert!(
            w.refix_epochs.unwrap() < wo.refix_epochs.unwrap(),
            "{g}: {w:?} {wo:?}"
        );
        // Epochs are applied at their estimated true time (IMU at 100 Hz).
        assert!(w.max_time_error_s < 1e-3, "{g}: {w:?}");
    }
}

/// The truth integers recovered from the simulated carrier stay constant
/// while a satellite is tracked (so the wrong-fix count compares with the
/// simulator's integers, not with noise).
#[test]
fn truth_integers_are_constant_while_tracked() {
    let (orbits, _) = super::super::tight::load_orbits(None);
    let t0 = 1.0e6;
    let off = orbits[0].t_oe - t0;
    let r0 = geodetic_to_ecef(&Geodetic {
        lat: 0.6,
        lon: 2.0,
        h: 40.0,
    });
    let cfg = RawConfig {
        iono_zenith_m: 0.0,
        tropo_zenith_m: 0.0,
        sat_sigma_m: 0.0,
        orbit_time_offset_s: off,
        ..Default::default()
    };
    let times: Vec<f64> = (0..120).map(|k| t0 + k as f64).collect();
    let v = Vec3::new(8.0, -3.0, 0.0);
    let eps = simulate_raw(&cfg, &orbits, &times, |t| (r0 + v * (t - t0), v));
    let first = truth_integers(&eps[0], &r0, &orbits, off);
    assert!(first.len() >= 4);
    for e in &eps[1..] {
        let n = truth_integers(e, &(r0 + v * (e.t - t0)), &orbits, off);
        for (p, a) in &n {
            if let Some(b) = first.get(p) {
                assert_eq!(a, b, "prn {p} at {}", e.t - t0);
            }
        }
    }
}

/// Diagnostic (issue 15, the fixed epochs' error budget), not an
/// assertion: for the seeds of `RTK_DIAG_SEEDS` (default 5,10,13,1,2) and the
/// consumer IMU, runs the with-INS filter epoch by epoch and writes per
/// epoch the fixed/float horizontal errors and σ beside the scene's truth
/// of the unmodelled double-difference errors (ionosphere: the simulated
/// slant delay minus the broadcast model the filter subtracts; troposphere:
/// the simulated delay minus the filter's Saastamoinen + Niell at the true
/// antenna) and the position error those alone imply through an
/// unweighted least-squares of the phase DDs (same-signal groups against
/// their highest satellite). `RTK_DIAG_SCENE=nograd` zeroes the scene's
/// ionosphere gradient (ablation, this test only); `RTK_DIAG_IONO=0` runs
/// the filter with the ionosphere as white noise. CSV per seed in
/// `$TMPDIR/rtk_diag`.
#[test]
#[ignore = "diagnostic: prints the DD error budget per seed"]
fn rtk_fixed_error_budget_diagnostic() {
    use navfuse_core::gnss::raw::geometric_range;
    let seeds: Vec<u64> = std::env::var("RTK_DIAG_SEEDS")
        .unwrap_or_else(|_| "5,10,13,1,2".into())
        .split(',')
        .filter_map(|x| x.trim().parse().ok())
        .collect();
    let tweak = std::env::var("RTK_DIAG_SCENE").unwrap_or_default();
    let est = std::env::var("RTK_DIAG_IONO").map_or(true, |v| v != "0");
    let rc = RtkConfig {
        inter_system: true,
        iono_estimate: est,
        ..RtkConfig::consumer()
    };
    let tweak = format!("{tweak}_est{}", u8::from(est));
    let dir = std::env::temp_dir().join("rtk_diag");
    std::fs::create_dir_all(&dir).unwrap();
    for seed in seeds {
        let opts = PlatformOptions {
            duration_s: 600.0,
            static_start: true,
            imu: ImuGrade::Consumer,
            gnss: GnssGrade::Consumer,
            ..Default::default()
        };
        let pr = platform_run(Platform::Car, seed, &opts).unwrap();
        let (d, (rt, bt)) = drive_dual_with(seed, &pr.run, |c| {
            if tweak.starts_with("nograd") {
                c.iono_gradient_ppm = 0.0;
            }
            if tweak.starts_with("noiono") {
                c.iono_gradient_ppm = 0.0;
                c.raw.iono_zenith_m = 0.0;
            }
        })
        .unwrap();
        let mut f = car_filter(d.traj, d.lever, ImuGrade::Consumer)
            .unwrap()
            .with_rtk(rc)
            .unwrap();
        let mut i = 0usize;
        let dt_imu = d.imu[1].t - d.imu[0].t;
        let mut bias_m = 0.0;
        let mut csv = String::from(
            "t,fixed,n_fixed,n_cand,fix_n,fix_e,float_n,float_e,sfix_n,sfix_e,sflt_n,sflt_e,\
             dd_iono_rms,dd_trop_rms,ls_n,ls_e,ls_u,nsat,amb_worst_cyc,amb_worst_prn,amb_worst_sys,amb_worst_sig,n_phase,n_code\n",
        );
        let (mut s2, mut c_in, mut c_n) = (0.0, 0usize, 0usize);
        let (mut s2ls, mut nfix) = (0.0, 0usize);
        for (k, (re, be)) in d.rover.iter().zip(&d.base).enumerate() {
            let nav = *f.nav();
            let r_ins = geodetic_to_ecef(&Geodetic {
                lat: nav.lat,
                lon: nav.lon,
                h: nav.h,
            });
            if let Some(b) = receiver_clock_bias_m(&re.epoch, &r_ins) {
                bias_m = b;
            }
            let te = re.epoch.t - bias_m / C_LIGHT;
            while i < d.imu.len() && d.imu[i].t <= te + 0.5 * dt_imu {
                f.push(&Event::Imu(d.imu[i]));
                i += 1;
            }
            if i >= d.imu.len() {
                break;
            }
            let sol = f.rtk_update(&re.epoch, &be.epoch, &d.base_e).unwrap();
            if re.epoch.n == 0 {
                continue;
            }
            let tr = d.traj.at(sol.t);
            let (n, e) = super::super::h_error_ne(sol.pos.lat, sol.pos.lon, &tr);
            let (fnn, fe) = super::super::h_error_ne(sol.float_pos.lat, sol.float_pos.lon, &tr);
            // Truth DD errors at the true antenna.
            let (ra, _) = d.traj.antenna_ecef(re.t, &d.lever);
            let g = ecef_to_geodetic(&ra);
            let cen = c_en(g.lat, g.lon);
            let bg = ecef_to_geodetic(&d.base_e);
            let doy = day_of_year(re.epoch.t);
            // (sys, sig, el, u_n, e_iono_phase, e_trop)
            let mut sd: Vec<(usize, u8, f64, Vec3, f64, f64)> = Vec::new();
            for (s, x) in re.epoch.sats().iter().zip(&rt[k]) {
                let Some((b, y)) = be.epoch.sats().iter().zip(&bt[k]).find(|(b, _)| {
                    b.obs.system == s.obs.system
                        && b.obs.prn == s.obs.prn
                        && b.obs.signal == s.obs.signal
                }) else {
                    continue;
                };
                let (_, los) = geometric_range(&s.sat.pos_e, &ra);
                let u = cen * los;
                let el = (-u.z).asin();
                if el < rc.elevation_mask_rad {
                    continue;
                }
                let (_, losb) = geometric_range(&b.sat.pos_e, &d.base_e);
                let elb = (-(c_en(bg.lat, bg.lon) * losb).z).asin();
                let gam = (s.obs.wavelength_m() / (C_LIGHT / 1575.42e6)).powi(2);
                let ei =
                    gam * (x.iono_l1_m - y.iono_l1_m) - (s.sat.iono_m as f64 - b.sat.iono_m as f64);
                let et = (x.tropo_m - y.tropo_m)
                    - (slant_delay(el, g.lat, g.h, doy, rc.humidity)
                        - slant_delay(elb, bg.lat, bg.h, doy, rc.humidity));
                sd.push((s.obs.system.index(), s.obs.signal as u8, el, u, -ei, et));
            }
            let mut ddi = Vec::new();
            let mut ddt = Vec::new();
            let mut nm = navfuse_core::Mat3::zeros();
            let mut rhs = Vec3::zeros();
            for a in &sd {
                let r = sd
                    .iter()
                    .filter(|b| b.0 == a.0 && b.1 == a.1)
                    .max_by(|x, y| x.2.total_cmp(&y.2))
                    .unwrap();
                if r.2 == a.2 {
                    continue;
                }
                let (e_i, e_t) = (a.4 - r.4, a.5 - r.5);
                ddi.push(e_i);
                ddt.push(e_t);
                // DD phase = −Δuᵀ r + err → LS position error.
                let h = -(a.3 - r.3);
                nm += h * h.transpose();
                rhs += h * (e_i + e_t);
            }
            // Float SD ambiguities against the truth, per (system, signal)
            // minus the group's median (the unobservable common part).
            let mut amb: Vec<(usize, u8, u8, f64, f64)> = Vec::new();
            for s in re.epoch.sats() {
                let key = (s.obs.system, s.obs.prn, s.obs.signal);
                let (Some((a, sa)), Some(t)) = (
                    f.rtk_ambiguity(key),
                    d.sd_truth[k].get(&tkey(s.obs.system, s.obs.prn, s.obs.signal)),
                ) else {
                    continue;
                };
                amb.push((
                    s.obs.system.index(),
                    s.obs.prn,
                    s.obs.signal as u8,
                    a - *t as f64,
                    sa,
                ));
            }
            let mut worst = (0.0f64, 0u8, 0.0f64, 0usize);
            for a in &amb {
                let mut g: Vec<f64> = amb
                    .iter()
                    .filter(|b| b.0 == a.0 && b.2 == a.2)
                    .map(|b| b.3)
                    .collect();
                g.sort_by(|x, y| x.total_cmp(y));
                let e = a.3 - g[g.len() / 2];
                if e.abs() > worst.0.abs() {
                    worst = (e, a.1, a.4, a.0);
                }
            }
            let rms =
                |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt();
            let ls = nm.try_inverse().map_or(Vec3::zeros(), |m| m * rhs);
            if sol.fixed {
                s2 += n * n + e * e;
                s2ls += ls.x * ls.x + ls.y * ls.y;
                nfix += 1;
                c_n += 1;
                if (n / sol.std_ned.x).powi(2) + (e / sol.std_ned.y).powi(2) <= 5.991 {
                    c_in += 1;
                }
            }
            csv += &format!(
                "{:.0},{},{},{},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{:.3},{},{},{:.3},{},{}\n",
                re.t - d.t0,
                u8::from(sol.fixed),
                sol.n_fixed,
                sol.n_candidates,
                n,
                e,
                fnn,
                fe,
                sol.std_ned.x,
                sol.std_ned.y,
                sol.float_std_ned.x,
                sol.float_std_ned.y,
                rms(&ddi),
                rms(&ddt),
                ls.x,
                ls.y,
                ls.z,
                sd.len(),
                worst.0,
                worst.1,
                worst.3,
                worst.2,
                sol.n_phase,
                sol.n_code
            );
        }
        std::fs::write(dir.join(format!("seed{seed}_{tweak}.csv")), csv).unwrap();
        let st = f.rtk_stats().unwrap();
        println!(
            "seed {seed} {tweak}: fixed {nfix}, h rms {:.4} m, LS-from-truth-DD h rms {:.4} m, cover95 {:.3}, NIS code {:.3} phase {:.3}",
            (s2 / nfix.max(1) as f64).sqrt(),
            (s2ls / nfix.max(1) as f64).sqrt(),
            c_in as f64 / c_n.max(1) as f64,
            st.nis_code.0 / st.nis_code.1.max(1) as f64,
            st.nis_phase.0 / st.nis_phase.1.max(1) as f64,
        );
    }
}

/// DD geometry of the line-of-sight rows `rows` (NED, unit weights):
/// condition number of the 3×3 normal matrix, HDOP- and VDOP-like
/// `√(N⁻¹)` numbers (∞ when singular), rank (eigenvalues above 1e-9 of the
/// largest), and the weakest eigenvector (NED).
struct DdGeometry {
    cond: f64,
    hdop: f64,
    /// HDOP with the height known (the horizontal 2×2 block inverted).
    hdop_h_known: f64,
    vdop: f64,
    rank: usize,
    weak: Vec3,
}

fn dd_geometry(rows: &[Vec3]) -> DdGeometry {
    let n: navfuse_core::Mat3 = rows.iter().map(|h| h * h.transpose()).sum();
    let eig = n.symmetric_eigen();
    let (mut imin, mut imax) = (0, 0);
    for i in 1..3 {
        if eig.eigenvalues[i] < eig.eigenvalues[imin] {
            imin = i;
        }
        if eig.eigenvalues[i] > eig.eigenvalues[imax] {
            imax = i;
        }
    }
    let (lmin, lmax) = (eig.eigenvalues[imin].max(0.0), eig.eigenvalues[imax]);
    let rank = eig.eigenvalues.iter().filter(|l| **l > 1e-9 * lmax).count();
    let (hdop, vdop) = match (rank == 3).then(|| n.try_inverse()).flatten() {
        Some(q) => ((q[(0, 0)] + q[(1, 1)]).sqrt(), q[(2, 2)].sqrt()),
        None => (f64::INFINITY, f64::INFINITY),
    };
    let nh = n.fixed_view::<2, 2>(0, 0).into_owned();
    let hdop_h_known = nh
        .try_inverse()
        .map_or(f64::INFINITY, |q| (q[(0, 0)] + q[(1, 1)]).max(0.0).sqrt());
    DdGeometry {
        hdop_h_known,
        cond: if rank == 3 {
            lmax / lmin
        } else {
            f64::INFINITY
        },
        hdop,
        vdop,
        rank,
        weak: eig.eigenvectors.column(imin).into_owned(),
    }
}

/// One filter's 4-satellite window, from the per-epoch observer.
#[derive(Default)]
struct WindowRun {
    /// Largest horizontal error [m], its epoch index, NE error and the
    /// reported horizontal σ √(σn² + σe²) there, fixed there.
    max_h: f64,
    k_max: usize,
    ne_max: (f64, f64),
    sigma_h: f64,
    fixed_at_max: bool,
    /// Fixed epochs / epochs; phase DDs min / max / sum; epochs whose
    /// phase DD count is below what the records allow.
    fixed: usize,
    epochs: usize,
    /// Epochs whose horizontal error is inside the reported 95 % ellipse.
    inside95: usize,
    /// The full outage (no satellite, INS alone): epochs, epochs inside the
    /// 95 % ellipse, the largest horizontal error and σ at its last epoch.
    outage: (usize, usize, f64, f64),
    n_phase: (usize, usize, usize),
    short: usize,
    /// Counter totals before and at the end of the window.
    before: Option<RtkStats>,
    after: Option<RtkStats>,
}

/// The phase DDs the records of a rover epoch allow with the filter's
/// grouping (groups of n records: n − 1 each), and their LOS-difference
/// rows against each group's highest satellite; the window's satellites
/// (first signal) with elevation, azimuth [°] and signal count.
#[allow(clippy::type_complexity)]
fn window_rows(
    d: &Drive,
    k: usize,
    rc: &RtkConfig,
) -> (
    usize,
    Vec<Vec3>,
    Vec<(GnssSystem, u8, f64, f64, usize, Vec3)>,
) {
    use navfuse_core::gnss::raw::geometric_range;
    let re = &d.rover[k];
    let (ra, _) = d.traj.antenna_ecef(re.t, &d.lever);
    let g = ecef_to_geodetic(&ra);
    let cen = c_en(g.lat, g.lon);
    // (group, prn/system key, el, u)
    let mut recs = Vec::new();
    let mut sats: Vec<(GnssSystem, u8, f64, f64, usize, Vec3)> = Vec::new();
    for s in re.epoch.sats() {
        if !d.base[k].epoch.sats().iter().any(|b| {
            b.obs.system == s.obs.system && b.obs.prn == s.obs.prn && b.obs.signal == s.obs.signal
        }) {
            continue;
        }
        let u = cen * geometric_range(&s.sat.pos_e, &ra).1;
        let el = (-u.z).asin();
        if el < rc.elevation_mask_rad {
            continue;
        }
        recs.push((rc.dd_group(s.obs.system, s.obs.signal), el, u));
        match sats
            .iter_mut()
            .find(|x| x.0 == s.obs.system && x.1 == s.obs.prn)
        {
            Some(x) => x.4 += 1,
            None => sats.push((
                s.obs.system,
                s.obs.prn,
                el.to_degrees(),
                u.y.atan2(u.x).to_degrees().rem_euclid(360.0),
                1,
                u,
            )),
        }
    }
    sats.sort_by(|a, b| b.2.total_cmp(&a.2));
    let mut rows = Vec::new();
    let mut n = 0;
    for r in &recs {
        let rf = recs
            .iter()
            .filter(|x| x.0 == r.0)
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        if rf.1 != r.1 {
            rows.push(r.2 - rf.2);
            n += 1;
        }
    }
    (n, rows, sats)
}

/// Diagnostic of the 4-satellite window (issue 15, "fixed solution kept or
/// float ≤ 0.3 m"), not an assertion: per seed (`RTK_DIAG_SEEDS`, default
/// 1–20) and IMU grade, the experiment's own drive and filters (with the
/// INS; with the INS and fix-and-hold) observed epoch by epoch. Printed:
/// - the window's satellites at the with-INS filter's worst epoch
///   (system+PRN elevation/azimuth [°], the signal count);
/// - the DD geometry there, unit weights, LOS differences `u_i − u_ref`:
///   (a) "1ref": the 4 satellites against the highest (the brief's
///   idealisation), (b) "grp": the filter's own DDs, each (system, signal)
///   group ([`RtkConfig::dd_group`]) against its highest satellite, both
///   frequencies — rank, condition number, HDOP/VDOP-like `√diag(N⁻¹)`,
///   "H|v" the HDOP were the height known (the horizontal 2×2 block), the
///   weakest eigenvector's horizontal share and azimuth (mod 180°);
/// - per filter: the largest horizontal error, its time, the reported
///   horizontal σ there (F fixed, f float), |cos| of the error against the
///   weak eigenvector's horizontal direction (b), fixed share, the share of
///   window epochs inside the reported 95 % ellipse, the same for the 30 s
///   full outage (INS alone: its largest error, σ at its end, share inside
///   the 95 % ellipse — the INS model's own consistency), phase DDs used per epoch
///   (min–max / the records' allowance), epochs short of the allowance;
/// - the filter counters' increments over the window (phase gated, code
///   gated, INS slips, GF/MW slips, loss-of-lock resets, reference resets,
///   reference changes, held DDs).
///
/// Run: `cargo test --release -p navfuse-pipeline
/// rtk_partial_window_geometry_diagnostic -- --ignored --nocapture`.
///
/// **Measured** (seeds 1–20, `RAYON_NUM_THREADS=2`; the means equal the
/// experiment JSON's `partial_sky_h_m`: 0.615 / 0.555 m phone with the INS
/// / with hold, 0.276 / 0.253 m industrial): geometry-limited, no defect
/// of the phase processing found.
/// - The 4 highest satellites are all at 56–89° elevation, a cap around
///   the zenith, often two near-coincident pairs (seeds 12–14: E04/C14 and
///   C20/E10 1–4° apart). The filter's DDs have a condition number of
///   3.7e3–3.4e5 and a unit-weight HDOP of 11–349 (median ≈ 80): with the
///   ≈ 7 mm of a DD phase that is 0.08–2.4 m per epoch. Seeds 19 and 20
///   (GPS + BeiDou only, no shared frequency) give rank 2, but their
///   unobserved direction is nearly vertical (HDOP 1.8 with the height
///   known) and their errors are the smallest (0.03–0.15 m).
/// - The largest error lies along the weakest eigenvector's horizontal
///   direction (|cos| ≥ 0.9 in 17–20 of 20 seeds per grade and filter).
/// - Every epoch of the window uses all the phase DDs its records allow
///   (4, or 5 in seeds 12–14), hold holds them all; no phase or code
///   gating, no reference resets, no loss-of-lock resets; one INS slip
///   reset (seed 20) and one reference change (seed 4, SD states: no
///   reset). With the scene's ionosphere removed (`RTK_DIAG_SCENE=noiono`)
///   the means are 0.609 / 0.558 / 0.251 / 0.228 m: the ionosphere states
///   do not cause it.
/// - Industrial: the error follows the reported σ (median error/σ 1.06 /
///   1.21; ≥ 90 % of the window inside the 95 % ellipse in 18 / 20 of 20
///   seeds). Phone: median error/σ 1.97 / 1.73, only 12 of 20 seeds: the
///   phone INS, which carries the weak direction, is over-confident
///   (< 90 % in seeds 1, 3, 6, 7, 8, 16, 20, and 2 with hold); its own 30 s
///   outage shows it too (coverage 3–73 % in seeds 1, 8, 11; the
///   industrial's is 100 % in every seed). The phone
///   preset's 5 mrad axis misalignment and gyro g-sensitivity are not
///   ESKF states (`sensors::imu_noise_preset`): the likely cause, not
///   verified here.
#[test]
#[ignore = "diagnostic: prints the 4-satellite window's geometry per seed"]
fn rtk_partial_window_geometry_diagnostic() {
    let seeds: Vec<u64> = std::env::var("RTK_DIAG_SEEDS")
        .map(|v| v.split(',').filter_map(|x| x.trim().parse().ok()).collect())
        .unwrap_or_else(|_| (1..=20).collect());
    let o = Options {
        seeds: 1,
        ..Default::default()
    };
    let rc = filter_config(&o);
    // Ablation (diagnosis only, never the experiment's scenario):
    // `RTK_DIAG_SCENE=noiono` removes the scene's ionosphere, so the DDs
    // carry no differential ionosphere.
    let ablation = std::env::var("RTK_DIAG_SCENE").unwrap_or_default();
    println!("scene ablation: {ablation:?}");
    let grades = [ImuGrade::Consumer, ImuGrade::Industrial];
    let jobs: Vec<(u64, ImuGrade)> = seeds
        .iter()
        .flat_map(|&s| grades.iter().map(move |&g| (s, g)))
        .collect();
    // Per job: the line, and per filter (largest error, its σ, window
    // epochs inside the 95 % ellipse / epochs).
    #[allow(clippy::type_complexity)]
    let lines: Vec<(u64, ImuGrade, String, [(f64, f64, usize, usize); 2])> = jobs
        .par_iter()
        .map(|&(seed, grade)| {
            let pr = platform_run(Platform::Car, seed, &platform_options(grade, o.duration, o.imu_ideal()))
                .unwrap();
            let (d, _) = drive_dual_with(seed, &pr.run, |c| {
                if ablation == "noiono" {
                    c.iono_gradient_ppm = 0.0;
                    c.raw.iono_zenith_m = 0.0;
                }
            })
            .unwrap();
            let [with, _, hold] = seed_filters(&d, grade, rc).unwrap();
            let (p0, p1) = (d.t0 + PARTIAL_START_S, d.t0 + PARTIAL_START_S + PARTIAL_S);
            let in_window = |k: usize| d.rover[k].t >= p0 && d.rover[k].t < p1;
            let mut runs = [WindowRun::default(), WindowRun::default()];
            for (f, w) in [with, hold].into_iter().zip(runs.iter_mut()) {
                run_filter_observed(&d, f, |k, sol, f, (n, e)| {
                    if d.rover[k].epoch.n == 0 {
                        let s = sol.float_std_ned;
                        let o = &mut w.outage;
                        o.0 += 1;
                        o.1 += usize::from((n / s.x).powi(2) + (e / s.y).powi(2) <= 5.991);
                        o.2 = o.2.max(n.hypot(e));
                        o.3 = s.x.hypot(s.y);
                    }
                    if !in_window(k) {
                        if d.rover[k].t < p0 {
                            w.before = f.rtk_stats().copied();
                        }
                        return;
                    }
                    w.after = f.rtk_stats().copied();
                    w.epochs += 1;
                    w.fixed += usize::from(sol.fixed);
                    let sd = if sol.fixed { sol.std_ned } else { sol.float_std_ned };
                    if (n / sd.x).powi(2) + (e / sd.y).powi(2) <= 5.991 {
                        w.inside95 += 1;
                    }
                    let np = sol.n_phase;
                    w.n_phase = if w.epochs == 1 {
                        (np, np, np)
                    } else {
                        (w.n_phase.0.min(np), w.n_phase.1.max(np), w.n_phase.2 + np)
                    };
                    if np < window_rows(&d, k, &rc).0 {
                        w.short += 1;
                    }
                    let h = n.hypot(e);
                    if h >= w.max_h {
                        let s = if sol.fixed { sol.std_ned } else { sol.float_std_ned };
                        *w = WindowRun {
                            max_h: h,
                            k_max: k,
                            ne_max: (n, e),
                            sigma_h: s.x.hypot(s.y),
                            fixed_at_max: sol.fixed,
                            ..std::mem::take(w)
                        };
                    }
                })
                .unwrap();
            }
            let k = runs[0].k_max;
            let (allow, rows, sats) = window_rows(&d, k, &rc);
            let sys = |s: GnssSystem| match s {
                GnssSystem::Gps => 'G',
                GnssSystem::Galileo => 'E',
                GnssSystem::BeiDou => 'C',
                _ => '?',
            };
            let sat_txt: Vec<String> = sats
                .iter()
                .map(|s| format!("{}{:02} {:>2.0}/{:>3.0}{}", sys(s.0), s.1, s.2, s.3, if s.4 == 2 { "" } else { "*" }))
                .collect();
            let one: Vec<Vec3> = sats[1..].iter().map(|s| s.5 - sats[0].5).collect();
            let ga = dd_geometry(&one);
            let gb = dd_geometry(&rows);
            let weak = |g: &DdGeometry| {
                format!(
                    "h{:>3.0}% az{:>4.0}",
                    100.0 * g.weak.x.hypot(g.weak.y),
                    g.weak.y.atan2(g.weak.x).to_degrees().rem_euclid(180.0)
                )
            };
            let wh = Vec3::new(gb.weak.x, gb.weak.y, 0.0);
            let num = |x: f64| if x.is_finite() { format!("{x:>6.1}") } else { "   inf".into() };
            let mut s = format!(
                "{:>2} {:<10} {} | 1ref c{} H{} V{} {} | grp r{} c{} H{} V{} H|v{} {}",
                seed,
                grade.preset(),
                sat_txt.join(" "),
                num(ga.cond),
                num(ga.hdop),
                num(ga.vdop),
                weak(&ga),
                gb.rank,
                num(gb.cond),
                num(gb.hdop),
                num(gb.vdop),
                num(gb.hdop_h_known),
                weak(&gb),
            );
            for (name, w) in ["ins", "hold"].iter().zip(&runs) {
                let (en, ee) = w.ne_max;
                let cos = if wh.norm() > 1e-9 && w.max_h > 0.0 {
                    (en * wh.x + ee * wh.y).abs() / (wh.norm() * w.max_h)
                } else {
                    f64::NAN
                };
                let (b, a) = (w.before.unwrap_or_default(), w.after.unwrap_or_default());
                let (tb, ta) = (b.total(), a.total());
                s += &format!(
                    " | {name} {:.3}m@{:>3.0}s σ{:.3}{} cos{:.2} fix{:>3.0}% in95 {:>3.0}% outage {:.2}m σ{:.2} in95 {:>3.0}% nφ{}-{}/{} short{} Δ[pg{} cg{} sl{} mw{} lli{} rr{} rc{} held{}]",
                    w.max_h,
                    d.rover[w.k_max].t - d.t0,
                    w.sigma_h,
                    if w.fixed_at_max { "F" } else { "f" },
                    cos,
                    100.0 * w.fixed as f64 / w.epochs.max(1) as f64,
                    100.0 * w.inside95 as f64 / w.epochs.max(1) as f64,
                    w.outage.2,
                    w.outage.3,
                    100.0 * w.outage.1 as f64 / w.outage.0.max(1) as f64,
                    w.n_phase.0,
                    w.n_phase.1,
                    allow,
                    w.short,
                    ta.phase_gated - tb.phase_gated,
                    ta.code_gated - tb.code_gated,
                    ta.slips - tb.slips,
                    ta.dual_slips - tb.dual_slips,
                    ta.lli_resets - tb.lli_resets,
                    ta.ref_resets - tb.ref_resets,
                    a.reference_changes - b.reference_changes,
                    a.held - b.held,
                );
            }
            let sum = |w: &WindowRun| (w.max_h, w.sigma_h, w.inside95, w.epochs);
            (seed, grade, s, [sum(&runs[0]), sum(&runs[1])])
        })
        .collect();
    for g in grades {
        println!("== {} ==", g.preset());
        for (_, gg, s, _) in &lines {
            if *gg == g {
                println!("{s}");
            }
        }
        for (j, name) in ["with_ins", "with_ins_hold"].iter().enumerate() {
            let v: Vec<_> = lines.iter().filter(|x| x.1 == g).map(|x| x.3[j]).collect();
            let n = v.len().max(1) as f64;
            let mut ratio: Vec<f64> = v.iter().map(|x| x.0 / x.1).collect();
            ratio.sort_by(f64::total_cmp);
            println!(
                "{} {name}: mean largest error {:.3} m (the JSON's partial_sky_h_m), seeds > 0.3 m {}, \
                 median error/σ {:.2}, seeds with ≥ 90 % of the window inside the 95 % ellipse {} of {}",
                g.preset(),
                v.iter().map(|x| x.0).sum::<f64>() / n,
                v.iter().filter(|x| x.0 > 0.3).count(),
                ratio.get(ratio.len() / 2).copied().unwrap_or(f64::NAN),
                v.iter().filter(|x| x.2 * 10 >= x.3 * 9).count(),
                v.len()
            );
        }
    }
}

/// Per-epoch trace of the GNSS-only ("without INS") filter of one seed
/// with the phone IMU: float N/E/U error, its σ, velocity error, fixed,
/// DDs used, and the counters' increments (phase / code gated, reference
/// resets, GF/MW slips, loss of lock) between `RTK_DIAG_FROM` and
/// `RTK_DIAG_TO` s (default 400–520: the 4-satellite window).
///
/// Run: `RTK_DIAG_SEED=19 cargo test --release -p navfuse-pipeline
/// rtk_gnss_only_trace_diagnostic -- --ignored --nocapture`.
///
/// **Found with it** (seed 19 with the phone preset's misalignment and
/// g-sensitivity set to 0, which only changes the scene's random stream):
/// in the window (G06, G13, C03, C20: one DD per system and signal, rank
/// 2, the unobserved direction near-vertical) the vertical σ grew to 91 m
/// at t = 448 s, the mean position variance passed 30², and the restart
/// took the code-DD "solution" of that rank-2 geometry (4 DDs, so it
/// counted as redundant): 27 600 km below the base. Every DD was gated
/// from then on and the restart from the lost state found no solution:
/// float 2.7·10⁶ m to the end. Fixed in `rtk/gnss_only.rs` and
/// `Eskf::recentre_on_code` (DOP test, start at the base, restart when
/// every code DD is gated).
#[test]
#[ignore = "diagnostic: per-epoch GNSS-only trace"]
fn rtk_gnss_only_trace_diagnostic() {
    let seed: u64 = std::env::var("RTK_DIAG_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(19);
    let t_from: f64 = std::env::var("RTK_DIAG_FROM")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(400.0);
    let t_to: f64 = std::env::var("RTK_DIAG_TO")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(520.0);
    let o = Options {
        seeds: 1,
        ..Default::default()
    };
    let rc = filter_config(&o);
    let pr = platform_run(
        Platform::Car,
        seed,
        &platform_options(ImuGrade::Consumer, o.duration, o.imu_ideal()),
    )
    .unwrap();
    let d = drive_dual(seed, &pr.run).unwrap();
    let [_, without, _] = seed_filters(&d, ImuGrade::Consumer, rc).unwrap();
    let mut prev = navfuse_core::estimators::eskf::RtkSatCounts::default();
    run_filter_observed(&d, without, |k, sol, f, (n, e)| {
        let t = d.rover[k].t - d.t0;
        let tot = f.rtk_stats().unwrap().total();
        if t >= t_from && t <= t_to {
            let tr = d.traj.at(sol.t);
            let (fnn, fe) = super::super::h_error_ne(sol.float_pos.lat, sol.float_pos.lon, &tr);
            let s = sol.float_std_ned;
            let nv = f.nav().v_n;
            let vt = tr.v_n;
            println!(
                "t {:>5.0} nsat {:>2} float N {:>10.2} E {:>10.2} U {:>9.2} σ {:>7.2} {:>7.2} {:>7.2} dv {:>7.2} {:>7.2} fix {} ({:>6.2},{:>6.2}) n_code {:>2} n_phase {:>2} Δpg {:>2} Δcg {:>2} Δrr {} Δdual {} Δlli {}",
                t,
                d.rover[k].epoch.n,
                fnn,
                fe,
                sol.float_pos.h - tr.h,
                s.x,
                s.y,
                s.z,
                nv.x - vt.x,
                nv.y - vt.y,
                u8::from(sol.fixed),
                n,
                e,
                sol.n_code,
                sol.n_phase,
                tot.phase_gated - prev.phase_gated,
                tot.code_gated - prev.code_gated,
                tot.ref_resets - prev.ref_resets,
                tot.dual_slips - prev.dual_slips,
                tot.lli_resets - prev.lli_resets,
            );
        }
        prev = tot;
    })
    .unwrap();
}

/// `IdealImuTerm`'s `FromStr` takes exactly `--ideal-imu`'s spellings.
#[test]
fn ideal_imu_terms_parse_as_the_command_spells_them() {
    #[cfg(feature = "clap")]
    for t in <IdealImuTerm as clap::ValueEnum>::value_variants() {
        let name = clap::ValueEnum::to_possible_value(t).unwrap();
        assert_eq!(name.get_name().parse::<IdealImuTerm>(), Ok(*t));
    }
    assert_eq!("g-sensitivity".parse(), Ok(IdealImuTerm::GSensitivity));
    assert!("gm".parse::<IdealImuTerm>().is_err());
}
