//! A small synthetic RUN_DIR (every input kind of the layout), so the report
//! is tested without the estimators or the simulator.
//!
//! A 300 s drive on a curving road at about 12 m/s, truth at 10 Hz with
//! attitude, 1 Hz GNSS fixes with two 20 s outages; two solutions: `eskf`
//! (navfuse CSV with σ) and `kfgins` (KF-GINS .nav, no σ, time of week only),
//! whose errors are known functions of time (noise outside outages, a
//! quadratic drift inside); innovations, states and a `summary.json`.

use navfuse_core::{NavSolution, Vec3};
use navfuse_io::trajectory::{create_writer, OutFormat};
use std::fmt::Write as _;
use std::path::Path;

/// GPS week of the fixture.
pub const WEEK: u32 = 2000;
/// Time of week of the first epoch [s].
pub const TOW0: f64 = 100_000.0;
/// Length of the drive [s].
pub const DURATION: f64 = 300.0;
/// Outages, seconds after the first epoch.
pub const OUTAGES: [(f64, f64); 2] = [(60.0, 80.0), (180.0, 200.0)];
/// Peak horizontal drift of the `eskf` solution at the end of each outage [m]
/// (quadratic growth `k·τ²`, τ the time into the outage, in north and east).
pub const ESKF_DRIFT_COEF: f64 = 0.004;
/// The `kfgins` solution drifts this many times more.
pub const KFGINS_FACTOR: f64 = 2.5;

const R_EARTH: f64 = 6_378_137.0;
const LAT0: f64 = 0.6998; // rad (~40.1°)
const LON0: f64 = -1.8352; // rad

/// Deterministic normal samples (xorshift64* + Box–Muller).
struct Noise(u64);

impl Noise {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let v = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D);
        ((v >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let (u1, u2) = (self.uniform(), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

fn t_gps(rel: f64) -> f64 {
    f64::from(WEEK) * 604_800.0 + TOW0 + rel
}

/// Time into the outage containing `rel` (seconds after the start), if any.
pub fn in_outage(rel: f64) -> Option<f64> {
    OUTAGES
        .iter()
        .find(|(a, b)| rel >= *a && rel < *b)
        .map(|(a, _)| rel - a)
}

/// The truth at 10 Hz (position by integrating the velocity).
pub fn truth() -> Vec<NavSolution> {
    let n = (DURATION * 10.0) as usize + 1;
    let (mut north, mut east) = (0.0f64, 0.0f64);
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let rel = i as f64 * 0.1;
        let yaw = 0.6 * (rel / 45.0).sin() + 0.004 * rel;
        let speed = 12.0 + 2.0 * (rel / 30.0).sin();
        let v_n = Vec3::new(
            speed * yaw.cos(),
            speed * yaw.sin(),
            0.05 * (rel / 20.0).cos(),
        );
        if i > 0 {
            north += v_n.x * 0.1;
            east += v_n.y * 0.1;
        }
        let mut s = NavSolution::unknown_at(t_gps(rel));
        s.lat = LAT0 + north / R_EARTH;
        s.lon = LON0 + east / (R_EARTH * LAT0.cos());
        s.h = 1600.0 + 2.0 * (rel / 60.0).sin();
        s.v_n = v_n;
        s.rpy = Vec3::new(0.01 * (rel / 7.0).sin(), 0.005, yaw);
        out.push(s);
    }
    out
}

/// A solution: the truth plus known errors (see the module doc).
fn solution(truth: &[NavSolution], drift: f64, seed: u64, with_sigma: bool) -> Vec<NavSolution> {
    let mut rng = Noise(seed);
    truth
        .iter()
        .map(|tr| {
            let rel = tr.t - t_gps(0.0);
            let tau = in_outage(rel).unwrap_or(0.0);
            let d = drift * tau * tau;
            let dn = Vec3::new(
                d + 0.05 * rng.normal(),
                0.6 * d + 0.05 * rng.normal(),
                0.03 * rng.normal() + 0.2 * d,
            );
            let mut s = *tr;
            s.lat += dn.x / R_EARTH;
            s.lon += dn.y / (R_EARTH * LAT0.cos());
            s.h -= dn.z;
            s.v_n += Vec3::new(2.0 * drift * tau, 1.2 * drift * tau, 0.0)
                + Vec3::new(rng.normal(), rng.normal(), rng.normal()) * 0.02;
            s.rpy += Vec3::new(rng.normal(), rng.normal(), rng.normal()) * 0.001
                + Vec3::new(0.0, 0.0, 0.0005 * tau);
            if with_sigma {
                let sp = 0.06 + 1.5 * drift * tau * tau;
                s.std_pos_ned = Vec3::new(sp, sp, 0.05 + 0.5 * drift * tau * tau);
                s.std_v_n = Vec3::repeat(0.03 + 2.0 * drift * tau);
                s.std_rpy = Vec3::new(0.0015, 0.0015, 0.002 + 0.0005 * tau);
            } else {
                s.std_pos_ned = Vec3::repeat(f64::NAN);
                s.std_v_n = Vec3::repeat(f64::NAN);
                s.std_rpy = Vec3::repeat(f64::NAN);
            }
            s
        })
        .collect()
}

fn io(p: &Path, e: impl std::fmt::Display) -> String {
    format!("{}: {e}", p.display())
}

/// Write the fixture RUN_DIR into `dir` (created if missing).
pub fn write_fixture(dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    let truth = truth();
    let write = |name: &str, fmt: OutFormat, s: &[NavSolution]| -> Result<(), String> {
        let p = dir.join(name);
        let mut w = create_writer(&p, fmt).map_err(|e| io(&p, e))?;
        for x in s {
            w.write(x).map_err(|e| io(&p, e))?;
        }
        w.finish().map_err(|e| io(&p, e))
    };
    write("truth.csv", OutFormat::Csv, &truth)?;
    write(
        "eskf.csv",
        OutFormat::Csv,
        &solution(&truth, ESKF_DRIFT_COEF, 0x9E37_79B9_7F4A_7C15, true),
    )?;
    // KF-GINS writes GPS week 0 (time of week only): the report must place it.
    let mut kf = solution(
        &truth,
        ESKF_DRIFT_COEF * KFGINS_FACTOR,
        0xD1B5_4A32_D192_ED03,
        false,
    );
    for s in kf.iter_mut() {
        s.t -= f64::from(WEEK) * 604_800.0;
    }
    write("kfgins.nav", OutFormat::Nav, &kf)?;

    // GNSS fixes at 1 Hz outside the outages.
    let mut rng = Noise(0x1234_5678_9ABC_DEF1);
    let fixes: Vec<NavSolution> = truth
        .iter()
        .step_by(10)
        .filter(|t| in_outage(t.t - t_gps(0.0)).is_none())
        .map(|t| {
            let mut f = NavSolution::unknown_at(t.t);
            f.lat = t.lat + 0.3 * rng.normal() / R_EARTH;
            f.lon = t.lon + 0.3 * rng.normal() / (R_EARTH * LAT0.cos());
            f.h = t.h + 0.5 * rng.normal();
            f.std_pos_ned = Vec3::new(0.3, 0.3, 0.5);
            f.v_n = Vec3::repeat(f64::NAN);
            f
        })
        .collect();
    write("gnss.csv", OutFormat::Csv, &fixes)?;

    // Innovations: GNSS position (dof 3) at the fixes, NHC (dof 2) at 2 Hz.
    let mut s = String::from("t,kind,nis,dof,accepted\n");
    let mut rng = Noise(0x0F0F_1234_ABCD_5555);
    let mut n_rej = 0;
    for (i, f) in fixes.iter().enumerate() {
        let mut nis: f64 = (0..3).map(|_| rng.normal().powi(2)).sum();
        let rejected = i % 37 == 20;
        if rejected {
            n_rej += 1;
            nis = 30.0 + 10.0 * rng.uniform();
        }
        let _ = writeln!(s, "{:.3},gnss_pos,{nis:.4},3,{}", f.t, u8::from(!rejected));
    }
    for t in truth.iter().step_by(5) {
        let nis: f64 = (0..2).map(|_| rng.normal().powi(2)).sum();
        let _ = writeln!(s, "{:.3},nhc,{nis:.4},2,1", t.t);
    }
    let p = dir.join("eskf.innovations.csv");
    navfuse_io::atomic::write_atomic(&p, s).map_err(|e| io(&p, e))?;

    // States at 1 Hz: gyro bias [°/h], accelerometer bias [mg], time offset [s].
    let mut s = String::from(
        "t_gps_s,bg_x_dph,bg_y_dph,bg_z_dph,ba_x_mg,ba_y_mg,ba_z_mg,td_s,std_bg_x_dph,std_bg_y_dph,std_bg_z_dph\n",
    );
    for t in truth.iter().step_by(10) {
        let rel = t.t - t_gps(0.0);
        let c = 1.0 - (-rel / 40.0).exp();
        let sb = 2.0 + 20.0 * (-rel / 40.0).exp();
        let _ = writeln!(
            s,
            "{:.3},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.5},{sb:.3},{sb:.3},{sb:.3}",
            t.t,
            10.0 * c,
            -5.0 * c,
            3.0 * c,
            1.5 * c,
            -0.8 * c,
            2.0 * c,
            0.02 * c
        );
    }
    let p = dir.join("eskf.states.csv");
    navfuse_io::atomic::write_atomic(&p, s).map_err(|e| io(&p, e))?;

    let summary = serde_json::json!({
        "estimator": "eskf (synthetic fixture)",
        "config": {"imu_rate_hz": 100, "gnss_rate_hz": 1, "lever_arm_b": [0.0, 0.0, 0.0],
                   "gate_chi2_p": 0.999},
        "records": {"imu": {"used": 30000, "rejected": 0}, "gnss": {"used": fixes.len(), "rejected": 0}},
        "updates": {"gnss_pos": {"accepted": fixes.len() - n_rej, "rejected_gate": n_rej}},
        "outages": OUTAGES.iter().map(|(a, b)| [t_gps(*a), t_gps(*b)]).collect::<Vec<_>>(),
    });
    let p = dir.join("summary.json");
    navfuse_io::atomic::write_atomic(
        &p,
        serde_json::to_string_pretty(&summary).map_err(|e| io(&p, e))? + "\n",
    )
    .map_err(|e| io(&p, e))?;
    // A file the report must ignore (eval's error CSV).
    let p = dir.join("errors.csv");
    navfuse_io::atomic::write_atomic(&p, "t,north_m\n1,2\n").map_err(|e| io(&p, e))?;
    Ok(())
}
