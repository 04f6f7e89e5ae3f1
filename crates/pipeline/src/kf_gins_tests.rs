//! Real-data checks of the KF-GINS drop-in (drive_0708): parity with
//! KF-GINS's own results, the enhanced/smoothed runs, paper mode, outliers.

use crate::check;
use crate::kf_gins::{run_kf_gins, KfGinsOptions, KfGinsRun};
use navfuse_core::types::NavSolution;
use std::path::{Path, PathBuf};

use navfuse_io::data::require;
use std::io::Write as _;

const KFGINS_OUTAGE_RMS: f64 = 44.85;

fn kfgins(rel: &str) -> PathBuf {
    require(&format!("drive_0708/kfgins/{rel}"))
}

fn temp_dir(name: &str) -> PathBuf {
    crate::test_dir(&format!("kfgins-{name}"))
}

/// A YAML and the options of a run (the options reachable as fields).
struct Args {
    config: PathBuf,
    opts: KfGinsOptions,
}

impl std::ops::Deref for Args {
    type Target = KfGinsOptions;
    fn deref(&self) -> &KfGinsOptions {
        &self.opts
    }
}

impl std::ops::DerefMut for Args {
    fn deref_mut(&mut self) -> &mut KfGinsOptions {
        &mut self.opts
    }
}

fn args(config: PathBuf, out: &Path) -> Args {
    Args {
        config,
        opts: KfGinsOptions {
            output: Some(out.to_path_buf()),
            ..Default::default()
        },
    }
}

fn run_config(a: &Args) -> Result<KfGinsRun, crate::PipelineError> {
    run_kf_gins(&a.config, &a.opts)
}

/// A copy of `kf-gins_full.yaml` in `dir` with absolute data paths, GNSS
/// from `gnss` and optionally `gnssvelpath: vel`.
fn yaml_copy(dir: &Path, gnss: &Path, vel: Option<&Path>) -> PathBuf {
    let src = kfgins("kf-gins_full.yaml");
    let text = std::fs::read_to_string(&src).unwrap();
    let imu = kfgins("imu.txt");
    let mut out = String::new();
    for line in text.lines() {
        if line.starts_with("imupath:") {
            out += &format!("imupath: \"{}\"\n", imu.display());
        } else if line.starts_with("gnsspath:") {
            out += &format!("gnsspath: \"{}\"\n", gnss.display());
            if let Some(v) = vel {
                out += &format!("gnssvelpath: \"{}\"\n", v.display());
            }
        } else {
            out += line;
            out += "\n";
        }
    }
    let p = dir.join("config.yaml");
    std::fs::write(&p, out).unwrap();
    p
}

fn truth() -> Vec<NavSolution> {
    check::read_nav(&kfgins("truth.nav")).unwrap()
}

fn outage_rms(sols: &[NavSolution], lever: &navfuse_core::Vec3) -> (Vec<f64>, f64) {
    let outages = check::parse_outages("243382,30,90,5").unwrap();
    let fixes: Vec<f64> = crate::kfgins_input::read_kfgins_gnss(&kfgins("gnss_outage.txt"))
        .unwrap()
        .iter()
        .map(|g| g.t)
        .collect();
    let m = check::outage_drift(sols, &truth(), lever, &outages, &fixes);
    let rms = (m.iter().map(|x| x * x).sum::<f64>() / m.len() as f64).sqrt();
    (m, rms)
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn parity_with_kfgins_full_run() {
    let out = temp_dir("parity-full");
    let r = run_config(&args(kfgins("kf-gins_full.yaml"), &out)).unwrap();
    let theirs = check::read_nav(&kfgins("kfgins_result_full_10hz.nav")).unwrap();
    let a = check::accuracy(&r.solutions, &theirs, &navfuse_core::Vec3::zeros());
    eprintln!(
        "vs KF-GINS: horizontal RMS {:.5} m over {} epochs",
        a.h_rms, a.n
    );
    assert!(a.n > 5000);
    assert!(a.h_rms < 0.05, "horizontal RMS vs KF-GINS {}", a.h_rms);
    // And its accuracy against the RTK truth (KF-GINS: 0.032 m).
    let t = check::accuracy(&r.solutions, &truth(), &r.config.lever_arm_b);
    eprintln!("vs truth: horizontal RMS {:.4} m", t.h_rms);
    assert!(t.h_rms < 0.05);
    // The three files exist with KF-GINS's column counts.
    for (f, cols) in [
        ("KF_GINS_Navresult.nav", 11),
        ("KF_GINS_IMU_ERR.txt", 13),
        ("KF_GINS_STD.txt", 22),
    ] {
        let text = std::fs::read_to_string(out.join(f)).unwrap();
        let first = text.lines().next().unwrap();
        assert_eq!(first.split_whitespace().count(), cols, "{f}");
        assert_eq!(text.lines().count(), r.solutions.len(), "{f}");
    }
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn parity_with_kfgins_outage_drift() {
    let out = temp_dir("parity-outage");
    let r = run_config(&args(kfgins("kf-gins_outage.yaml"), &out)).unwrap();
    let (m, rms) = outage_rms(&r.solutions, &r.config.lever_arm_b);
    eprintln!("outage maxima {m:.2?} m, RMS {rms:.2} m (KF-GINS {KFGINS_OUTAGE_RMS})");
    assert!((rms - KFGINS_OUTAGE_RMS).abs() < 0.15 * KFGINS_OUTAGE_RMS);
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn enhanced_and_smoothed_beat_kfgins_on_outages() {
    let out = temp_dir("enhanced-outage");
    let mut a = args(kfgins("kf-gins_outage.yaml"), &out);
    a.enhanced = true;
    a.smooth = true;
    let r = run_config(&a).unwrap();
    let lever = r.config.lever_arm_b;
    let (m, fwd) = outage_rms(&r.solutions, &lever);
    eprintln!("enhanced forward: maxima {m:.2?} m, RMS {fwd:.2} m");
    let sm: Vec<NavSolution> = r.smoothed.iter().map(check::smoothed_solution).collect();
    let (ms, smo) = outage_rms(&sm, &lever);
    eprintln!("enhanced smoothed: maxima {ms:.2?} m, RMS {smo:.2} m");
    assert!(fwd <= 10.0, "forward drift RMS {fwd}");
    assert!(smo <= 3.0, "smoothed drift RMS {smo}");
    assert!(out.join("KF_GINS_Navresult_smoothed.nav").exists());
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn enhanced_smoothed_full_run_tracks_rtk() {
    let out = temp_dir("enhanced-full");
    let mut a = args(kfgins("kf-gins_full.yaml"), &out);
    a.enhanced = true;
    a.smooth = true;
    let r = run_config(&a).unwrap();
    let sm: Vec<NavSolution> = r.smoothed.iter().map(check::smoothed_solution).collect();
    let acc = check::accuracy(&sm, &truth(), &r.config.lever_arm_b);
    eprintln!(
        "enhanced smoothed, 1 Hz GNSS: horizontal RMS {:.4} m",
        acc.h_rms
    );
    assert!(acc.n > 2000);
    assert!(acc.h_rms <= 0.03, "horizontal RMS {}", acc.h_rms);
}

/// GNSS velocity at the fix epochs from the RTKLIB .pos (its own vn/ve/vu
/// and σ columns), in the `gnssvelpath` layout.
fn write_velocity_file(path: &Path) {
    let fixes = crate::kfgins_input::read_kfgins_gnss(&kfgins("gnss_full.txt")).unwrap();
    let pos = require("drive_0708/gnss_1934_sf.pos");
    let (rdr, name) = navfuse_io::open(&pos).unwrap();
    let mut f = std::fs::File::create(path).unwrap();
    let mut n = 0;
    for g in navfuse_io::pos::PosReader::new(rdr, &name) {
        let g = g.unwrap();
        let (_, tow) = navfuse_io::time::week_tow(g.t);
        let k = fixes.partition_point(|x| x.t < tow - 1e-3);
        if k < fixes.len() && (fixes[k].t - tow).abs() < 1e-3 {
            let (v, s) = (g.v_n.unwrap(), g.std_v_n.unwrap());
            writeln!(
                f,
                "{tow:.3} {} {} {} {} {} {}",
                v.x, v.y, v.z, s.x, s.y, s.z
            )
            .unwrap();
            n += 1;
        }
    }
    assert!(n > 500, "only {n} velocity epochs matched");
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn paper_mode_velocity_and_height_after_300_s() {
    let dir = temp_dir("paper");
    let vel = dir.join("gnss_vel.txt");
    write_velocity_file(&vel);
    let cfg = yaml_copy(&dir, &kfgins("gnss_full.txt"), Some(&vel));
    let mut a = args(cfg, &dir.join("out"));
    a.position_until = Some(300.0);
    let r = run_config(&a).unwrap();
    assert!(r.stats.gnss_vel_used > 500 && r.stats.height_used > 200);
    assert!(r.stats.gnss_pos_used <= 301);
    let truth = truth();
    let last = truth
        .iter()
        .rev()
        .find(|t| t.t <= r.solutions.last().unwrap().t)
        .unwrap();
    let e = check::error_at(&r.solutions, last, &r.config.lever_arm_b).unwrap();
    let h = e.x.hypot(e.y);
    eprintln!(
        "paper mode: horizontal error at the end (t = {:.2}) {h:.2} m after {:.0} s without positions",
        last.t,
        last.t - 243262.0 - 300.0
    );
    assert!(h <= 3.0, "end error {h}");
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn injected_gnss_outliers_are_gated_and_counted() {
    use rand::{Rng, SeedableRng};
    let dir = temp_dir("outliers");
    let clean_cfg = yaml_copy(&dir, &kfgins("gnss_full.txt"), None);
    let mut a = args(clean_cfg, &dir.join("clean"));
    a.enhanced = true;
    let clean = run_config(&a).unwrap();
    // 50 fixes (after the first 60 s) moved 20–100 m in a random direction.
    let text = std::fs::read_to_string(kfgins("gnss_full.txt")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mut picked = std::collections::BTreeSet::new();
    while picked.len() < 50 {
        picked.insert(rng.gen_range(60..lines.len() - 1));
    }
    for &k in &picked {
        let mut f: Vec<f64> = lines[k]
            .split_whitespace()
            .map(|x| x.parse().unwrap())
            .collect();
        let d = rng.gen_range(20.0..100.0);
        let az: f64 = rng.gen_range(0.0..std::f64::consts::TAU);
        let (rm, rn) = navfuse_core::earth::radii(f[1].to_radians());
        f[1] += (d * az.cos() / rm).to_degrees();
        f[2] += (d * az.sin() / (rn * f[1].to_radians().cos())).to_degrees();
        lines[k] = format!(
            "{:.3} {:.9} {:.9} {:.4} {} {} {}",
            f[0], f[1], f[2], f[3], f[4], f[5], f[6]
        );
    }
    let bad = dir.join("gnss_outliers.txt");
    std::fs::write(&bad, lines.join("\n") + "\n").unwrap();
    let cfg = yaml_copy(&dir, &bad, None);
    let mut a = args(cfg, &dir.join("outliers"));
    a.enhanced = true;
    let r = run_config(&a).unwrap();
    let lever = r.config.lever_arm_b;
    let t = truth();
    let h0 = check::accuracy(&clean.solutions, &t, &lever).h_rms;
    let h1 = check::accuracy(&r.solutions, &t, &lever).h_rms;
    let extra = r.stats.gnss_pos_rejected_gate - clean.stats.gnss_pos_rejected_gate;
    eprintln!(
        "outliers: RMS clean {h0:.4} m, with 50 outliers {h1:.4} m; rejected {} (clean run {})",
        r.stats.gnss_pos_rejected_gate, clean.stats.gnss_pos_rejected_gate
    );
    assert!((h1 - h0).abs() < 0.02, "RMS changed by {}", h1 - h0);
    assert_eq!(extra, 50, "each injected outlier is rejected and counted");
    assert_eq!(r.stats.gnss_pos_forced, 0);
}
