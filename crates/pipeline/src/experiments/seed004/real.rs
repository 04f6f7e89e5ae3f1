//! Table 4: drive_0708 read and run at each GPS interval (and the ESKF rows).

use super::*;

/// drive_0708 inputs: merged events (IMU then fixes at equal times), the
/// 4 Hz RTK truth, and a description of what was read.
pub struct RealRun {
    pub events: Vec<Event>,
    pub truth: Vec<(f64, f64, f64)>,
    pub summary: String,
}

/// Read drive_0708 from `data_root` (errors name the missing file).
pub fn load_drive_0708(
    data_root: &std::path::Path,
    mount_rpy_deg: [f64; 3],
) -> Result<RealRun, ToolError> {
    use navfuse_io::csv_imu::{CsvImuConfig, CsvImuReader};
    use navfuse_io::pos::PosReader;
    let imu_path = data_root.join("drive_0708/imu_1934_gpst.csv");
    let pos_path = data_root.join("drive_0708/gnss_1934_sf.pos");
    for p in [&imu_path, &pos_path] {
        if !p.exists() {
            return Err(format!(
                "real data missing: {} (set --data or NAVFUSE_DATA to the folder holding drive_0708/, or pass --no-real)",
                p.display()
            ).into());
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
    let mut imu_cfg = CsvImuConfig::drive_0708();
    imu_cfg.mount_rpy_deg = Some(mount_rpy_deg);
    let mut imu = CsvImuReader::new(r, &name, imu_cfg);
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

/// Table 4 on drive_0708 (the [`REPORT_EVERY`] row's solutions kept in `keep`).
pub fn table4(cfgs: &Configs, run: &RealRun, mut keep: Option<&mut Kept>) -> Vec<Row> {
    INTERVALS
        .iter()
        .map(|&every| {
            let mut kept = Vec::new();
            let e = cfgs.all().map(|cfg| {
                let sols = run_with_interval(&mut AccelDr::new(cfg), &run.events, every);
                let e = mean_errors(&sols, &run.truth);
                kept.push(sols);
                e
            });
            let sols = run_with_interval(&mut GpsHold::new(), &run.events, every);
            let h = mean_errors(&sols, &run.truth);
            if every == REPORT_EVERY {
                if let Some(k) = keep.as_deref_mut() {
                    keep_row(k, kept, sols, &run.events, every, &run.truth);
                }
            }
            Row {
                interval_s: every,
                gps_acc: cell(&[e[0]]),
                gps_acc_default: cell(&[e[1]]),
                gps_acc_literal: cell(&[e[2]]),
                gps_only: cell(&[h]),
                eskf: None,
                eskf_nhc: None,
            }
        })
        .collect()
}

/// Mean |longitude| and |latitude| error [m].
pub type LonLat = (f64, f64);

/// navfuse's ESKF on drive_0708 with the KF-GINS inputs of the data folder
/// (`kfgins/kf-gins_full.yaml`: imu.txt in vehicle FRD, 1 Hz fixes at the
/// same x.999 epochs), fixes used every `every` s; antenna position errors
/// against the same 4 Hz RTK truth. Returns (plain, with NHC/ZUPT) per
/// interval; the [`REPORT_EVERY`] row's solutions are added to `keep`.
pub fn eskf_rows(
    data_root: &std::path::Path,
    truth: &[(f64, f64, f64)],
    mut keep: Option<&mut Kept>,
) -> Result<Vec<(LonLat, LonLat)>, ToolError> {
    use navfuse_core::estimators::eskf::Eskf;
    let yaml = data_root.join("drive_0708/kfgins/kf-gins_full.yaml");
    let cfg = navfuse_io::kfgins_yaml::KfGinsConfig::load(&yaml)?;
    let input = crate::kfgins_input::read_kfgins(&cfg).map_err(|e| e.to_string())?;
    // The KF-GINS files carry the time of week only.
    let week_s = (truth.first().ok_or("no truth")?.0 / 604_800.0).floor() * 604_800.0;
    let i0 = input.imu.partition_point(|s| s.t < cfg.starttime);
    let run_one = |ecfg: navfuse_core::estimators::eskf::EskfConfig, every: u32| {
        let mut f = Eskf::new(ecfg, cfg.init_nav(), cfg.init_errors(), &cfg.init_std());
        let fixes: Vec<_> = input.gnss.iter().filter(|g| g.t > cfg.starttime).collect();
        let t_first = fixes.first().map_or(0.0, |g| g.t);
        let mut g = 0;
        let mut sols = Vec::with_capacity(input.imu.len() - i0);
        for s in &input.imu[i0..] {
            while g < fixes.len() && fixes[g].t <= s.t + 1e-3 {
                let k = (fixes[g].t - t_first).round();
                if (k as i64) % every as i64 == 0 {
                    f.push(&Event::Gnss(*fixes[g]));
                }
                g += 1;
            }
            if f.push(&Event::Imu(*s)).is_some() {
                let (lat, lon, _) = f.antenna_position();
                let mut sol = NavSolution::unknown_at(s.t + week_s);
                sol.lat = lat;
                sol.lon = lon;
                sols.push(sol);
            }
        }
        (mean_errors(&sols, truth), sols)
    };
    Ok(INTERVALS
        .iter()
        .map(|&every| {
            let (a, sa) = run_one(cfg.eskf_config(), every);
            let (b, sb) = run_one(crate::kf_gins::enhanced(cfg.eskf_config()), every);
            if every == REPORT_EVERY {
                if let Some(k) = keep.as_deref_mut() {
                    k.series.push(("ESKF (gyro)".into(), sa));
                    k.series.push(("ESKF+NHC/ZUPT".into(), sb));
                }
            }
            (a, b)
        })
        .collect())
}
