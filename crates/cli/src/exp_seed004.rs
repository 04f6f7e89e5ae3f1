//! `navfuse experiment seed004`: the GPS + accelerometer dead reckoning of
//! seed 004 (`SEEDS.md §4`), Table 3 (simulation) and Table 4 (car; here the
//! real drive_0708) beside the paper's numbers.
//!
//! Simulation (Table 3): the seed 004 profile generated here with exact
//! kinematics (navfuse-sim had not landed when this was written): start
//! 35° N 125° E, level road, rest / acceleration / constant speed / turns /
//! deceleration; accelerometer at 10 Hz with white noise of variance
//! 0.01 G² per axis (G = 9.8 m/s², the MMA7260Q case of the paper), GPS
//! noise-free at 1 Hz. Specific force is the exact planar kinematics
//! (`f = (v̇, v·ψ̇, −G)` in FRD), Earth rate and transport rate ignored as
//! in the paper. Error = mean |north| and |east| error [m] of the output at
//! every 1 Hz epoch (used or not) against the truth, averaged over the run
//! and then over the seeds (± the standard deviation over seeds).
//!
//! Real data (Table 4): drive_0708 accelerometer (CSV, g, mounting preset
//! roll 180°, yaw 180° → FRD; gyro ignored) and the RTK `.pos` decimated
//! to 1 Hz (the x.999 s epochs, as the KF-GINS files), used every N s; errors
//! against all 4 Hz RTK positions (output interpolated to the epoch).

use clap::Args as ClapArgs;
use navfuse_core::earth;
use navfuse_core::estimators::accel_dr::{AccelDr, AccelDrConfig, ChordMode, GpsHold};
use navfuse_core::types::{Estimator, Event, GnssFix, ImuSample, NavSolution, Vec3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::path::PathBuf;

/// GPS + accelerometer dead reckoning (seed 004): Tables 3 and 4.
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// Number of Monte Carlo seeds for the simulation table.
    #[arg(long, default_value_t = 20)]
    pub seeds: u64,
    /// First seed.
    #[arg(long, default_value_t = 1)]
    pub seed0: u64,
    /// Write the tables as JSON to FILE.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Skip the real-data table (otherwise missing data is an error).
    #[arg(long)]
    pub no_real: bool,
    /// Data root holding drive_0708/ (default: $NAVFUSE_DATA or ../shared/data).
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Override the accelerometer filter's process noise Q per sample [G²]
    /// (all configurations; paper: 1e-6; the main one otherwise uses 0.01 G²/s·dt).
    #[arg(long)]
    pub kf_q: Option<f64>,
    /// Accelerometer white-noise variance per axis [G²] of the simulation
    /// (paper: 0.01; 0 shows the method's error without sensor noise).
    #[arg(long, default_value_t = 0.01)]
    pub accel_noise: f64,
    /// Chord mode of the main configuration: literal, midpoint, displacement.
    #[arg(long, default_value = "displacement")]
    pub chord: String,
}

/// GPS intervals of Tables 3 and 4 [s].
pub const INTERVALS: [u32; 6] = [1, 2, 4, 6, 8, 10];

/// Table 3 of the thesis: (interval, acc lon, acc lat, gps-only lon, lat) [m].
pub const PAPER_T3: [(u32, f64, f64, f64, f64); 6] = [
    (1, 0.8510, 0.6304, f64::NAN, f64::NAN),
    (2, 1.2255, 0.9888, 7.6266, 4.2942),
    (4, 2.4562, 1.6685, 22.6293, 12.9561),
    (6, 3.6246, 3.2429, 37.8717, 21.1743),
    (8, 5.6924, 4.4643, 52.7708, 29.3810),
    (10, 8.7662, 6.8453, 67.2081, 39.0326),
];
/// Table 4 of the thesis (car, ~59 Hz accelerometer).
pub const PAPER_T4: [(u32, f64, f64, f64, f64); 6] = [
    (1, 0.3623, 0.4040, f64::NAN, f64::NAN),
    (2, 0.6004, 0.6675, 1.2322, 2.4579),
    (4, 0.9645, 1.1244, 3.7115, 7.3663),
    (6, 1.1491, 1.3893, 6.1234, 12.3554),
    (8, 1.4959, 1.6467, 8.5382, 17.2757),
    (10, 1.8188, 1.7291, 11.1635, 22.3146),
];

/// 1 G of the paper [m/s²].
const G: f64 = 9.8;

/// The seed 004 profile: (duration s, forward acceleration m/s², yaw rate
/// rad/s) on a level road from rest, initial heading [`PROFILE_HEADING0`].
pub const PROFILE: [(f64, f64, f64); 13] = [
    (5.0, 0.0, 0.0),         // rest
    (10.0, 2.25, 0.0),       // accelerate to 22.5 m/s
    (25.0, 0.0, 0.0),        // constant
    (10.0, 0.0, 4.5 * DEG),  // right turn 45°
    (20.0, 0.0, 0.0),        // constant
    (6.0, -1.5, 0.0),        // decelerate to 13.5 m/s
    (15.0, 0.0, -6.0 * DEG), // left turn 90°
    (6.0, 1.5, 0.0),         // accelerate to 22.5 m/s
    (25.0, 0.0, 0.0),        // constant
    (10.0, 0.0, 6.0 * DEG),  // right turn 60°
    (20.0, 0.0, 0.0),        // constant
    (11.25, -2.0, 0.0),      // decelerate to rest
    (5.0, 0.0, 0.0),         // rest
];
const DEG: f64 = core::f64::consts::PI / 180.0;
/// Initial heading of the profile [rad]. The paper's Figure 8 is not
/// reproducible from the text; speed and headings were chosen so that the
/// estimator-independent GPS-only column (mean |Δeast|, |Δnorth| travelled
/// per second ≈ 7.5 m and 4.3 m) matches Table 3's GPS-only column.
pub const PROFILE_HEADING0: f64 = 68.0 * DEG;

/// A simulated run: time-ordered events and the truth at each whole second.
pub struct SimRun {
    pub events: Vec<Event>,
    /// (t, lat, lon) at t = 0, 1, 2, … s.
    pub truth: Vec<(f64, f64, f64)>,
}

/// Generate the profile with exact kinematics (1 ms midpoint integration of
/// speed, heading and WGS84 position), the accelerometer at `imu_hz` with
/// white noise of variance `noise_var_g2` [G²] per axis, and noise-free
/// 1 Hz fixes.
// `%` rather than `is_multiple_of` keeps the workspace MSRV (1.80).
#[allow(clippy::manual_is_multiple_of)]
pub fn simulate(seed: u64, imu_hz: f64, noise_var_g2: f64) -> SimRun {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let normal = Normal::new(0.0, noise_var_g2.sqrt() * G).expect("finite σ");
    let (mut lat, mut lon) = (35f64.to_radians(), 125f64.to_radians());
    let (mut v, mut psi) = (0.0f64, PROFILE_HEADING0);
    const STEPS_PER_S: u64 = 1000;
    let step = 1.0 / STEPS_PER_S as f64;
    let n_imu = (STEPS_PER_S as f64 / imu_hz).round() as u64;
    let fix = |t: f64, lat: f64, lon: f64| {
        Event::Gnss(GnssFix {
            t,
            lat,
            lon,
            quality: 1,
            ..Default::default()
        })
    };
    let mut events = vec![fix(0.0, lat, lon)];
    let mut truth = vec![(0.0, lat, lon)];
    let mut k: u64 = 0;
    for &(dur, acc, w) in PROFILE.iter() {
        let n = (dur * STEPS_PER_S as f64).round() as u64;
        for _ in 0..n {
            let vm = v + 0.5 * acc * step;
            let pm = psi + 0.5 * w * step;
            let (rm, rn) = earth::radii(lat);
            let dlat = vm * pm.cos() * step / rm;
            lon += vm * pm.sin() * step / (rn * (lat + 0.5 * dlat).cos());
            lat += dlat;
            v += acc * step;
            psi += w * step;
            k += 1;
            let t = k as f64 / STEPS_PER_S as f64;
            if k % n_imu == 0 {
                let dt = n_imu as f64 * step;
                let f_b = Vec3::new(
                    acc + normal.sample(&mut rng),
                    v * w + normal.sample(&mut rng),
                    -G + normal.sample(&mut rng),
                );
                events.push(Event::Imu(ImuSample {
                    t,
                    dt,
                    dtheta_b: Vec3::zeros(),
                    dvel_b: f_b * dt,
                }));
            }
            if k % STEPS_PER_S == 0 {
                truth.push((t, lat, lon));
                events.push(fix(t, lat, lon));
            }
        }
    }
    SimRun { events, truth }
}

/// Feed `events` to `est`, passing only the fixes at t0 + m·`every` s
/// (whole seconds, within 0.01 s); returns every solution.
pub fn run_with_interval<E: Estimator>(
    est: &mut E,
    events: &[Event],
    every: u32,
) -> Vec<NavSolution> {
    let t0 = events
        .iter()
        .find_map(|e| match e {
            Event::Gnss(f) => Some(f.t),
            _ => None,
        })
        .unwrap_or(0.0);
    let mut out = Vec::with_capacity(events.len());
    for ev in events {
        if let Event::Gnss(f) = ev {
            let s = (f.t - t0).round();
            if (f.t - t0 - s).abs() > 0.01 || (s as i64) % every as i64 != 0 {
                continue;
            }
        }
        if let Some(s) = est.push(ev) {
            // A solution at the same time replaces the previous one (the fix
            // after the IMU sample of its epoch).
            if out.last().is_some_and(|p: &NavSolution| p.t == s.t) {
                out.pop();
            }
            out.push(s);
        }
    }
    out
}

/// Position of `sols` at `t`, linearly interpolated (None outside).
fn interp(sols: &[NavSolution], t: f64) -> Option<(f64, f64)> {
    let i = sols.partition_point(|s| s.t <= t);
    if i == 0 {
        return None;
    }
    let a = &sols[i - 1];
    if (a.t - t).abs() < 1e-6 || i == sols.len() {
        return ((t - a.t).abs() < 0.05).then_some((a.lat, a.lon));
    }
    let b = &sols[i];
    let w = (t - a.t) / (b.t - a.t);
    Some((a.lat + w * (b.lat - a.lat), a.lon + w * (b.lon - a.lon)))
}

/// Mean |longitude| and |latitude| error [m] of `sols` against `truth`
/// (t, lat, lon) at the truth epochs the solutions cover.
pub fn mean_errors(sols: &[NavSolution], truth: &[(f64, f64, f64)]) -> (f64, f64) {
    let (mut e_lon, mut e_lat, mut n) = (0.0, 0.0, 0usize);
    for &(t, lat, lon) in truth {
        let Some((la, lo)) = interp(sols, t) else {
            continue;
        };
        let (rm, rn) = earth::radii(lat);
        e_lat += ((la - lat) * rm).abs();
        e_lon += ((lo - lon) * rn * lat.cos()).abs();
        n += 1;
    }
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    (e_lon / n as f64, e_lat / n as f64)
}

/// One table row: mean and spread over runs (seeds).
#[derive(Clone, Copy, Debug, Default)]
pub struct Cell {
    pub lon_m: f64,
    pub lat_m: f64,
    pub lon_sd_m: f64,
    pub lat_sd_m: f64,
}

fn cell(v: &[(f64, f64)]) -> Cell {
    let n = v.len() as f64;
    let (ml, mt) = (
        v.iter().map(|x| x.0).sum::<f64>() / n,
        v.iter().map(|x| x.1).sum::<f64>() / n,
    );
    let sd = |m: f64, f: &dyn Fn(&(f64, f64)) -> f64| {
        if v.len() < 2 {
            0.0
        } else {
            (v.iter().map(|x| (f(x) - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
        }
    };
    Cell {
        lon_m: ml,
        lat_m: mt,
        lon_sd_m: sd(ml, &|x| x.0),
        lat_sd_m: sd(mt, &|x| x.1),
    }
}

/// One row of Table 3/4.
#[derive(Clone, Debug)]
pub struct Row {
    pub interval_s: u32,
    /// The headline configuration ([`AccelDrConfig::rate_scaled`] unless overridden).
    pub gps_acc: Cell,
    /// [`AccelDrConfig::default`]: navfuse corrections, the paper's per-sample Q.
    pub gps_acc_default: Cell,
    /// The paper's literal method ([`AccelDrConfig::paper_literal`]).
    pub gps_acc_literal: Cell,
    pub gps_only: Cell,
}

/// The three GPS+accel configurations of a table: headline, default, literal.
#[derive(Clone, Copy, Debug)]
pub struct Configs {
    pub main: AccelDrConfig,
    pub default: AccelDrConfig,
    pub literal: AccelDrConfig,
}

impl Configs {
    fn all(&self) -> [AccelDrConfig; 3] {
        [self.main, self.default, self.literal]
    }
}

/// Table 3: the simulation over `seeds` seeds starting at `seed0`.
pub fn table3(cfgs: &Configs, seed0: u64, seeds: u64, noise: f64) -> Vec<Row> {
    let mut acc: Vec<[Vec<(f64, f64)>; 3]> = vec![Default::default(); INTERVALS.len()];
    let mut hold: Vec<Vec<(f64, f64)>> = vec![Vec::new(); INTERVALS.len()];
    for seed in seed0..seed0 + seeds {
        let run = simulate(seed, 10.0, noise);
        let truth = &run.truth[1..];
        for (i, &every) in INTERVALS.iter().enumerate() {
            for (c, cfg) in cfgs.all().iter().enumerate() {
                let sols = run_with_interval(&mut AccelDr::new(*cfg), &run.events, every);
                acc[i][c].push(mean_errors(&sols, truth));
            }
            let sols = run_with_interval(&mut GpsHold::new(), &run.events, every);
            hold[i].push(mean_errors(&sols, truth));
        }
    }
    INTERVALS
        .iter()
        .enumerate()
        .map(|(i, &interval_s)| Row {
            interval_s,
            gps_acc: cell(&acc[i][0]),
            gps_acc_default: cell(&acc[i][1]),
            gps_acc_literal: cell(&acc[i][2]),
            gps_only: cell(&hold[i]),
        })
        .collect()
}

/// drive_0708 inputs: merged events (IMU then fixes at equal times), the
/// 4 Hz RTK truth, and a description of what was read.
pub struct RealRun {
    pub events: Vec<Event>,
    pub truth: Vec<(f64, f64, f64)>,
    pub summary: String,
}

/// Read drive_0708 from `data_root` (errors name the missing file).
pub fn load_drive_0708(data_root: &std::path::Path) -> Result<RealRun, String> {
    use navfuse_io::csv_imu::{CsvImuConfig, CsvImuReader};
    use navfuse_io::pos::PosReader;
    let imu_path = data_root.join("drive_0708/imu_1934_gpst.csv");
    let pos_path = data_root.join("drive_0708/gnss_1934_sf.pos");
    for p in [&imu_path, &pos_path] {
        if !p.exists() {
            return Err(format!(
                "real data missing: {} (set --data or NAVFUSE_DATA to the folder holding drive_0708/, or pass --no-real)",
                p.display()
            ));
        }
    }
    let (r, name) = navfuse_io::open(&pos_path).map_err(|e| e.to_string())?;
    let mut truth = Vec::new();
    let mut fixes = Vec::new();
    let mut rdr = PosReader::new(r, &name);
    for f in &mut rdr {
        let f = f.map_err(|e| e.to_string())?;
        truth.push((f.t, f.lat, f.lon));
        // 1 Hz: the x.999 s epochs, stamped as they are.
        let frac = f.t - f.t.floor();
        if frac > 0.99 {
            fixes.push(f);
        }
    }
    let (r, name) = navfuse_io::open(&imu_path).map_err(|e| e.to_string())?;
    let mut imu = CsvImuReader::new(r, &name, CsvImuConfig::drive_0708());
    let mut samples = Vec::new();
    for s in &mut imu {
        samples.push(s.map_err(|e| e.to_string())?);
    }
    let summary = format!(
        "{} IMU samples ({} rejected rows), {} RTK epochs, {} fixes at 1 Hz",
        samples.len(),
        imu.stats().rejected.iter().map(|r| r.1).sum::<u64>(),
        truth.len(),
        fixes.len()
    );
    // Merge; the run starts at the first fix.
    let t_first = fixes.first().ok_or("no fixes in the .pos")?.t;
    let mut events = Vec::with_capacity(samples.len() + fixes.len());
    let (mut i, mut j) = (0, 0);
    while i < samples.len() || j < fixes.len() {
        let take_imu = j >= fixes.len() || (i < samples.len() && samples[i].t <= fixes[j].t);
        if take_imu {
            if samples[i].t >= t_first {
                events.push(Event::Imu(samples[i]));
            }
            i += 1;
        } else {
            events.push(Event::Gnss(fixes[j]));
            j += 1;
        }
    }
    truth.retain(|x| x.0 >= t_first);
    Ok(RealRun {
        events,
        truth,
        summary,
    })
}

/// Table 4 on drive_0708.
pub fn table4(cfgs: &Configs, run: &RealRun) -> Vec<Row> {
    INTERVALS
        .iter()
        .map(|&every| {
            let e = cfgs.all().map(|cfg| {
                let sols = run_with_interval(&mut AccelDr::new(cfg), &run.events, every);
                mean_errors(&sols, &run.truth)
            });
            let sols = run_with_interval(&mut GpsHold::new(), &run.events, every);
            let h = mean_errors(&sols, &run.truth);
            Row {
                interval_s: every,
                gps_acc: cell(&[e[0]]),
                gps_acc_default: cell(&[e[1]]),
                gps_acc_literal: cell(&[e[2]]),
                gps_only: cell(&[h]),
            }
        })
        .collect()
}

fn print_table(title: &str, rows: &[Row], paper: &[(u32, f64, f64, f64, f64)], spread: bool) {
    println!("{title}");
    let w = if spread { 29 } else { 17 };
    println!(
        "{:>5} | {:>w$} {:>15} | {:>w$} {:>w$} | {:>w$} {:>15}",
        "GPS",
        "GPS+accel (main)",
        "paper",
        "(default cfg)",
        "(literal cfg)",
        "GPS-only (hold)",
        "paper"
    );
    let f = |c: &Cell| {
        if spread {
            format!(
                "{:6.2}±{:5.2} / {:6.2}±{:5.2}",
                c.lon_m, c.lon_sd_m, c.lat_m, c.lat_sd_m
            )
        } else {
            format!("{:7.2} / {:7.2}", c.lon_m, c.lat_m)
        }
    };
    for (r, p) in rows.iter().zip(paper) {
        let pp = |a: f64, b: f64| {
            if a.is_nan() {
                "      –".to_string()
            } else {
                format!("{a:7.3}/{b:7.3}")
            }
        };
        println!(
            "{:>4}s | {:>w$} {:>15} | {:>w$} {:>w$} | {:>w$} {:>15}",
            r.interval_s,
            f(&r.gps_acc),
            pp(p.1, p.2),
            f(&r.gps_acc_default),
            f(&r.gps_acc_literal),
            f(&r.gps_only),
            pp(p.3, p.4)
        );
    }
    println!();
}

fn cell_json(c: &Cell) -> serde_json::Value {
    serde_json::json!({"lon_m": c.lon_m, "lat_m": c.lat_m, "lon_sd_m": c.lon_sd_m, "lat_sd_m": c.lat_sd_m})
}

fn rows_json(rows: &[Row], paper: &[(u32, f64, f64, f64, f64)]) -> serde_json::Value {
    let num = |x: f64| {
        if x.is_nan() {
            serde_json::Value::Null
        } else {
            serde_json::json!(x)
        }
    };
    serde_json::Value::Array(
        rows.iter()
            .zip(paper)
            .map(|(r, p)| {
                serde_json::json!({
                    "interval_s": r.interval_s,
                    "gps_acc": cell_json(&r.gps_acc),
                    "gps_acc_default_cfg": cell_json(&r.gps_acc_default),
                    "gps_acc_paper_literal": cell_json(&r.gps_acc_literal),
                    "gps_only": cell_json(&r.gps_only),
                    "paper": {"gps_acc": {"lon_m": p.1, "lat_m": p.2},
                              "gps_only": {"lon_m": num(p.3), "lat_m": num(p.4)}},
                })
            })
            .collect(),
    )
}

pub fn run(args: Args) -> Result<(), String> {
    if args.seeds == 0 {
        return Err("--seeds must be at least 1".into());
    }
    let mut cfg = AccelDrConfig::rate_scaled();
    let mut def = AccelDrConfig::default();
    let mut lit = AccelDrConfig::paper_literal();
    cfg.chord = match args.chord.as_str() {
        "literal" => ChordMode::Literal,
        "midpoint" => ChordMode::Midpoint,
        "displacement" => ChordMode::Displacement,
        c => {
            return Err(format!(
                "--chord: unknown mode `{c}` (literal, midpoint, displacement)"
            ))
        }
    };
    if let Some(q) = args.kf_q {
        if !(q > 0.0 && q.is_finite()) {
            return Err(format!("--kf-q must be a positive number, got {q}"));
        }
        cfg.kf_q = q;
        cfg.kf_q_psd = None;
        def.kf_q = q;
        lit.kf_q = q;
    }
    println!("seed 004 GPS-ACC (SEEDS.md §4)\n main config:    {cfg:?}\n default config: {def:?}\n literal config: {lit:?}\n");
    let cfgs = Configs {
        main: cfg,
        default: def,
        literal: lit,
    };
    // Load the real data first so a missing file fails before the long part.
    let real = if args.no_real {
        None
    } else {
        let root = args.data.clone().unwrap_or_else(navfuse_io::data::data_dir);
        Some(load_drive_0708(&root)?)
    };
    if !(args.accel_noise >= 0.0 && args.accel_noise.is_finite()) {
        return Err(format!(
            "--accel-noise must be ≥ 0, got {}",
            args.accel_noise
        ));
    }
    let t3 = table3(&cfgs, args.seed0, args.seeds, args.accel_noise);
    print_table(
        &format!(
            "Table 3 (simulation, 10 Hz accel σ² = {} G², noise-free 1 Hz GPS; mean ± sd over {} seeds {}..{}): mean position error [m]",
            args.accel_noise,
            args.seeds,
            args.seed0,
            args.seed0 + args.seeds - 1
        ),
        &t3,
        &PAPER_T3,
        true,
    );
    let t4 = match &real {
        Some(run) => {
            println!("drive_0708: {}", run.summary);
            let t4 = table4(&cfgs, run);
            print_table(
                "Table 4 (drive_0708, accelerometer only, RTK decimated to 1 Hz; error vs 4 Hz RTK) — paper: its own car",
                &t4,
                &PAPER_T4,
                false,
            );
            println!("ESKF column: pending (the ESKF has not landed on main)\n");
            Some(t4)
        }
        None => {
            println!("real-data table skipped (--no-real)\n");
            None
        }
    };
    if let Some(path) = &args.json {
        let doc = serde_json::json!({
            "config": format!("{cfg:?}"),
            "config_default": format!("{def:?}"),
            "config_paper_literal": format!("{lit:?}"),
            "seeds": args.seeds,
            "seed0": args.seed0,
            "rows": rows_json(&t3, &PAPER_T3),
            "real": t4.as_deref().map_or(serde_json::Value::Null, |t| rows_json(t, &PAPER_T4)),
        });
        std::fs::write(path, serde_json::to_string_pretty(&doc).expect("json"))
            .map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn simulated_profile_is_consistent() {
        let run = simulate(1, 10.0, 0.0);
        let dur: f64 = PROFILE.iter().map(|s| s.0).sum();
        assert_eq!(run.truth.len(), dur as usize + 1);
        // Ends at rest: the last two truth positions coincide.
        let n = run.truth.len();
        assert!((run.truth[n - 1].1 - run.truth[n - 2].1).abs() < 1e-12);
        // GPS-only hold with fixes every second has zero error.
        let sols = run_with_interval(&mut GpsHold::new(), &run.events, 1);
        let (lo, la) = mean_errors(&sols, &run.truth[1..]);
        assert!(lo < 1e-9 && la < 1e-9);
    }

    #[test]
    fn noise_free_gps_acc_beats_hold_at_every_interval() {
        let run = simulate(1, 10.0, 0.0);
        let err = |cfg: Option<AccelDrConfig>, every: u32| {
            let sols = match cfg {
                Some(c) => run_with_interval(&mut AccelDr::new(c), &run.events, every),
                None => run_with_interval(&mut GpsHold::new(), &run.events, every),
            };
            let e = mean_errors(&sols, &run.truth[1..]);
            e.0 + e.1
        };
        for every in [2, 4, 10] {
            let h = err(None, every);
            let main = err(Some(AccelDrConfig::rate_scaled()), every);
            let def = err(Some(AccelDrConfig::default()), every);
            let lit = err(Some(AccelDrConfig::paper_literal()), every);
            assert!(main < 0.2 * h, "{every} s: main {main} vs hold {h}");
            assert!(def < h && lit < h, "{every} s: {def} {lit} vs hold {h}");
        }
    }

    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn drive_0708_table4_gps_acc_beats_hold() {
        let root = navfuse_io::data::require("drive_0708/gnss_1934_sf.pos");
        let root = root.parent().and_then(|p| p.parent()).expect("data root");
        let run = load_drive_0708(root).expect("drive_0708");
        let cfgs = Configs {
            main: AccelDrConfig::rate_scaled(),
            default: AccelDrConfig::default(),
            literal: AccelDrConfig::paper_literal(),
        };
        let rows = table4(&cfgs, &run);
        for r in &rows[1..] {
            let a = r.gps_acc.lon_m + r.gps_acc.lat_m;
            let h = r.gps_only.lon_m + r.gps_only.lat_m;
            assert!(a < h, "{} s: gps+acc {a} vs hold {h}", r.interval_s);
        }
        // With every fix used the error is of the order of 1 s of prediction.
        assert!(rows[0].gps_acc.lon_m < 1.5 && rows[0].gps_acc.lat_m < 1.5);
    }
}
