//! Honesty of the tight filter's σ (issue 20 for `coupling = "tight"`):
//! the diagnostic that split the simulated pseudorange error into its
//! components and compared each with the filter's model, and the test of
//! the coverage band on seeds not used to build the model.

use crate::config::RunConfig;
use crate::experiments::h_error_ne;
use crate::experiments::tight::simulate_drive_raw;
use crate::run::{run, RunOptions};
use navfuse_core::estimators::eskf::TightConfig;
use navfuse_core::geodesy::{c_en, ecef_to_geodetic};
use navfuse_sim::raw_gnss::RawConfig;
use std::collections::HashMap;
use std::path::PathBuf;

struct Drive {
    dir: PathBuf,
    raw: crate::raw_drive::RawDrive,
}

fn drive(tag: &str, seed: u64, duration_s: f64) -> Drive {
    let dir = crate::test_dir(&format!("{tag}-{seed}"));
    let imu = match std::env::var("DIAG_IMU").as_deref() {
        Ok("tactical") => navfuse_sim::platform::ImuGrade::Tactical,
        Ok("industrial") => navfuse_sim::platform::ImuGrade::Industrial,
        _ => navfuse_sim::platform::ImuGrade::Consumer,
    };
    let raw = crate::raw_drive::write_raw_drive_imu(&dir, seed, duration_s, imu).unwrap();
    Drive { dir, raw }
}

fn config(d: &Drive, loose: bool) -> RunConfig {
    let mut text = std::fs::read_to_string(d.dir.join("tight.toml")).unwrap();
    if loose {
        text = text.replace("coupling = \"tight\"\n", "");
    }
    let mut c: RunConfig = toml::from_str(&text).unwrap();
    if loose {
        c.input.gnss_format = Some("raw".into());
    }
    c
}

fn go(d: &Drive, cfg: &RunConfig, name: &str) -> crate::run::RunOutcome {
    let opts = RunOptions {
        output: Some(d.dir.join(name)),
        ..Default::default()
    };
    run(cfg, &d.dir, &opts).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Consistency of one run from 30 s after its start: (share of epochs
/// with horizontal NEES ≤ 5.991, mean horizontal NEES, h RMS [m],
/// median σ_H [m]); NEES with the N/E σ of `solution.std`.
pub(crate) struct Consistency {
    pub cover: f64,
    pub nees: f64,
    pub rms: f64,
    pub sigma_h: f64,
}

fn consistency(d: &Drive, out: &crate::run::RunOutcome) -> Consistency {
    let std = navfuse_io::stdfile::read_std_file(&out.out_dir.join("solution.std")).unwrap();
    let t0 = out.trajectory[0].t + 30.0;
    let (mut n, mut inside, mut nees, mut e2) = (0usize, 0usize, 0.0, 0.0);
    let mut sig = Vec::new();
    for (s, sd) in out.trajectory.iter().zip(&std) {
        if s.t < t0 {
            continue;
        }
        let (dn, de) = h_error_ne(s.lat, s.lon, &d.raw.sim.traj.at(s.t));
        let (sn, se) = (sd.pos_ned.x, sd.pos_ned.y);
        // The file carries no N–E covariance (KF-GINS layout): the
        // diagonal, as the tests of `tight_run_tests` score it.
        let q = (dn / sn).powi(2) + (de / se).powi(2);
        n += 1;
        nees += q;
        e2 += dn * dn + de * de;
        if q <= 5.991 {
            inside += 1;
        }
        sig.push((sn * sn + se * se).sqrt());
    }
    sig.sort_by(f64::total_cmp);
    Consistency {
        cover: inside as f64 / n as f64,
        nees: nees / n as f64,
        rms: (e2 / n as f64).sqrt(),
        sigma_h: sig[sig.len() / 2],
    }
}

/// The error components of every simulated pseudorange: the drive's
/// observables re-simulated with all error σ but one set to 0 (the draws
/// do not depend on the σ: same seed, same sequence), minus the
/// error-free observables. Key: (receiver stamp in ms, PRN).
fn components(d: &Drive, seed: u64, duration_s: f64) -> HashMap<(i64, u8), [f64; 6]> {
    let (orbits, cfg) = crate::raw_drive::drive_sky(&d.raw.sim, seed, duration_s);
    let zero = RawConfig {
        code_sigma_ref_m: 0.0,
        mp_zenith_m: 0.0,
        mp_cap_m: 0.0,
        iono_zenith_m: 0.0,
        tropo_zenith_m: 0.0,
        sat_sigma_m: 0.0,
        ..cfg.clone()
    };
    let only: [RawConfig; 5] = [
        RawConfig {
            code_sigma_ref_m: cfg.code_sigma_ref_m,
            ..zero.clone()
        },
        RawConfig {
            mp_zenith_m: cfg.mp_zenith_m,
            mp_cap_m: cfg.mp_cap_m,
            ..zero.clone()
        },
        RawConfig {
            iono_zenith_m: cfg.iono_zenith_m,
            ..zero.clone()
        },
        RawConfig {
            tropo_zenith_m: cfg.tropo_zenith_m,
            ..zero.clone()
        },
        RawConfig {
            sat_sigma_m: cfg.sat_sigma_m,
            ..zero.clone()
        },
    ];
    let base = simulate_drive_raw(&d.raw.sim, &orbits, &zero);
    let full = simulate_drive_raw(&d.raw.sim, &orbits, &cfg);
    let parts: Vec<_> = only
        .iter()
        .map(|c| simulate_drive_raw(&d.raw.sim, &orbits, c))
        .collect();
    let mut out = HashMap::new();
    for (k, e) in base.iter().enumerate() {
        for (j, s) in e.epoch.sats().iter().enumerate() {
            let mut v = [0.0; 6];
            for (c, p) in parts.iter().enumerate() {
                v[c] = p[k].epoch.sats()[j].obs.pseudorange_m - s.obs.pseudorange_m;
            }
            v[5] = full[k].epoch.sats()[j].obs.pseudorange_m - s.obs.pseudorange_m;
            out.insert(((full[k].epoch.t * 1e3).round() as i64, s.obs.prn), v);
        }
    }
    out
}

/// Lag-`lag` autocorrelation of per-satellite series, pooled.
fn autocorr(series: &HashMap<u8, Vec<f64>>, lag: usize) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for v in series.values() {
        for i in 0..v.len() {
            den += v[i] * v[i];
            if i + lag < v.len() {
                num += v[i] * v[i + lag];
            }
        }
    }
    num / den
}

/// Diagnostic (measurement, not a check): per seed, the simulated
/// pseudorange error by component against the filter's model of it, and
/// the tight run's consistency under model variants.
#[test]
#[ignore = "diagnostic: cargo test --release -p navfuse-pipeline tight_sigma_diagnostic -- --ignored --nocapture"]
fn tight_sigma_diagnostic() {
    let dur = 300.0;
    let seeds: Vec<u64> = std::env::var("DIAG_SEEDS")
        .ok()
        .map(|s| s.split(',').map(|x| x.parse().unwrap()).collect())
        .unwrap_or_else(|| (1..=6).collect());
    let variants: Vec<String> = std::env::var("DIAG_VARIANTS")
        .unwrap_or_else(|_| "base".into())
        .split(',')
        .map(String::from)
        .collect();
    let names = ["code", "mp", "iono", "trop", "sat", "total"];
    for seed in seeds {
        let d = drive("tight-diag", seed, dur);
        let comp = components(&d, seed, dur);
        let raw = crate::raw_input::load_raw(&d.dir.join("raw.ubx"), &[]).unwrap();
        let tc = TightConfig::consumer();
        // Per-record: truth² by component, model variances (code, mp,
        // slow var_m2, trop_var), binned by elevation.
        let mut acc = [[0.0f64; 10]; 3];
        let mut cnt = [0usize; 3];
        let mut series: [HashMap<u8, Vec<f64>>; 6] = Default::default();
        for r in &raw.records {
            let Some(v) = comp.get(&((r.obs.t * 1e3).round() as i64, r.obs.prn)) else {
                continue;
            };
            let tr = d.raw.sim.traj.at(r.obs.t);
            let rx = navfuse_core::geodesy::geodetic_to_ecef(&navfuse_core::geodesy::Geodetic {
                lat: tr.lat,
                lon: tr.lon,
                h: tr.h,
            });
            let g = ecef_to_geodetic(&rx);
            let u = c_en(g.lat, g.lon) * (r.sat.pos_e - rx).normalize();
            let el = (-u.z).asin();
            if el < tc.elevation_mask_rad {
                continue;
            }
            let b = if el < 30f64.to_radians() {
                0
            } else if el < 60f64.to_radians() {
                1
            } else {
                2
            };
            for c in 0..6 {
                acc[b][c] += v[c] * v[c];
                series[c].entry(r.obs.prn).or_default().push(v[c]);
            }
            let cn0 = r.obs.cn0_dbhz as f64;
            let white = tc.pr_var_white(el, cn0);
            let code =
                (tc.code_sigma_m * 10f64.powf(((tc.cn0_ref_dbhz - cn0) / 20.0).max(0.0))).powi(2);
            acc[b][6] += code;
            acc[b][7] += white - code;
            acc[b][8] += r.sat.var_m2 as f64;
            acc[b][9] += tc.trop_var(el);
            cnt[b] += 1;
        }
        eprintln!(
            "seed {seed}: SPP variance factor {:.3} (dof {})",
            raw.var_scale, raw.spp.dof_sum
        );
        for (b, lab) in ["10-30°", "30-60°", "60-90°"].iter().enumerate() {
            let n = cnt[b].max(1) as f64;
            let rms = |c: usize| (acc[b][c] / n).sqrt();
            eprintln!(
                "  el {lab} n {:4}: truth RMS code {:.2} mp {:.2} iono {:.2} trop {:.2} sat {:.2} \
                 slow {:.2} total {:.2} | model code {:.2} mp {:.2} slow(var_m2) {:.2} trop {:.2}",
                cnt[b],
                rms(0),
                rms(1),
                rms(2),
                rms(3),
                rms(4),
                ((acc[b][2] + acc[b][3] + acc[b][4]) / n).sqrt(),
                rms(5),
                rms(6),
                rms(7),
                rms(8),
                rms(9)
            );
        }
        for (c, name) in names.iter().enumerate() {
            let r1 = autocorr(&series[c], 1);
            let r10 = autocorr(&series[c], 10);
            let r60 = autocorr(&series[c], 60);
            eprintln!("  {name}: autocorr lag 1 {r1:.3}, 10 {r10:.3}, 60 {r60:.3}");
        }
        for v in &variants {
            let mut cfg_t = crate::tight_run::tight_config();
            let mut scale = None;
            match v.as_str() {
                "base" => {}
                "mp_whiten" => cfg_t.mp_tau_s = 10.0,
                "scale1" => scale = Some(1.0),
                "white" => cfg_t.consider_sat_errors = false,
                "keep" => crate::tight_run::diag::KEEP_PRIOR.with(|c| c.set(true)),
                // The model before this session: prior kept, URA upper
                // bound, the SPP's factor at its plain dof.
                "upper" => crate::raw_input::URA_UPPER_BOUND.with(|c| c.set(true)),
                "before" => {
                    crate::tight_run::diag::KEEP_PRIOR.with(|c| c.set(true));
                    crate::raw_input::URA_UPPER_BOUND.with(|c| c.set(true));
                    scale = Some(raw.var_scale);
                }
                "simvar" => crate::raw_input::DIAG_SIM_VAR.with(|c| c.set(true)),
                "simvar_mp" => {
                    crate::raw_input::DIAG_SIM_VAR.with(|c| c.set(true));
                    cfg_t.mp_tau_s = 10.0;
                }
                "scale1_mp" => {
                    scale = Some(1.0);
                    cfg_t.mp_tau_s = 10.0;
                }
                other => panic!("variant {other}"),
            }
            crate::tight_run::diag::TIGHT_OVERRIDE.with(|c| c.set(Some(cfg_t)));
            crate::raw_input::VAR_SCALE_OVERRIDE.with(|c| c.set(scale));
            let out = go(&d, &config(&d, false), &format!("tight-{v}"));
            crate::tight_run::diag::TIGHT_OVERRIDE.with(|c| c.set(None));
            crate::raw_input::VAR_SCALE_OVERRIDE.with(|c| c.set(None));
            crate::raw_input::DIAG_SIM_VAR.with(|c| c.set(false));
            crate::tight_run::diag::KEEP_PRIOR.with(|c| c.set(false));
            crate::raw_input::URA_UPPER_BOUND.with(|c| c.set(false));
            let k = consistency(&d, &out);
            let tc = &out.summary["tight_coupling"];
            eprintln!(
                "    NIS pr {:.2} dop {:.2}",
                tc["mean_nis_pseudorange"].as_f64().unwrap_or(f64::NAN),
                tc["mean_nis_doppler"].as_f64().unwrap_or(f64::NAN)
            );
            if std::env::var("DIAG_SERIES").is_ok() {
                series_print(&d, &out);
            }
            eprintln!(
                "  tight[{v}]: cover {:.3} NEES {:.2} h RMS {:.3} median σ_H {:.3}",
                k.cover, k.nees, k.rms, k.sigma_h
            );
        }
        if std::env::var("DIAG_LOOSE").is_ok() {
            let out = go(&d, &config(&d, true), "loose");
            let k = consistency(&d, &out);
            eprintln!(
                "    loose model: {}",
                out.summary["filter"]["augmented_states"]
            );
            eprintln!(
                "  loose: cover {:.3} NEES {:.2} h RMS {:.3} median σ_H {:.3}",
                k.cover, k.nees, k.rms, k.sigma_h
            );
        }
        let _ = std::fs::remove_dir_all(&d.dir);
    }
}

/// Error and σ every 20 s (N, E) of one run.
fn series_print(d: &Drive, out: &crate::run::RunOutcome) {
    let std = navfuse_io::stdfile::read_std_file(&out.out_dir.join("solution.std")).unwrap();
    let t0 = out.trajectory[0].t;
    let mut next = t0;
    for (s, sd) in out.trajectory.iter().zip(&std) {
        if s.t >= next {
            next += 20.0;
            let tr = d.raw.sim.traj.at(s.t);
            let (dn, de) = h_error_ne(s.lat, s.lon, &tr);
            let dyaw = navfuse_core::geodesy::wrap_pi(s.rpy.z - tr.rpy.z).to_degrees();
            eprintln!(
                "    t {:5.0}: err N {dn:6.2} E {de:6.2} | σ N {:5.2} E {:5.2} | yaw err {dyaw:6.2}° σ {:5.2}° | v {:4.1}",
                s.t - t0,
                sd.pos_ned.x,
                sd.pos_ned.y,
                sd.att_rpy.z.to_degrees(),
                tr.v_n.norm()
            );
        }
    }
}

/// Issue 20's band for the tight filter's σ on drives not used to build
/// its model: seeds 19–24 (300 s each), pooled over the epochs from 30 s
/// after the start, the truth inside the 95 % horizontal region in
/// [0.90, 0.99] of the epochs and the mean horizontal NEES in [0.7, 4]
/// (issue 20, must-show 1).
///
/// History (said, not hidden): first written for seeds 13–18 with the URA
/// interval's upper bound in the satellite budget; it failed above the
/// band (coverage 1.000, NEES 1.27: conservative). The budget then took the
/// URA's nominal value (IS-GPS-200's value for accuracy use,
/// [`crate::raw_input`]), chosen after that result; seeds 1–18 have all
/// been looked at since, so the test moved to seeds 19–24, with the same
/// bounds, before it was run on them.
#[test]
fn tight_sigma_covers_the_truth_on_fresh_seeds() {
    let (mut cover, mut nees, mut n) = (0.0, 0.0, 0.0);
    for seed in 19..=24u64 {
        let d = drive("tight-sigma", seed, 300.0);
        let out = go(&d, &config(&d, false), "tight");
        let k = consistency(&d, &out);
        eprintln!(
            "seed {seed}: cover {:.3} NEES {:.2} h RMS {:.3} median σ_H {:.3}",
            k.cover, k.nees, k.rms, k.sigma_h
        );
        cover += k.cover;
        nees += k.nees;
        n += 1.0;
        let _ = std::fs::remove_dir_all(&d.dir);
    }
    let (cover, nees) = (cover / n, nees / n);
    eprintln!("seeds 19–24: coverage95_h {cover:.3}, mean NEES_h {nees:.2}");
    assert!((0.90..=0.99).contains(&cover), "coverage {cover}");
    assert!((0.7..=4.0).contains(&nees), "NEES {nees}");
}
