//! End-to-end checks of [`crate::run()`]: other estimators, CSV/NMEA/UBX
//! inputs against KF-GINS text, magnetometer/AHRS headings, real data.

use crate::config::RunConfig;
use crate::kfgins_input::read_kfgins;
use crate::run::{run, RunOptions};
use crate::time_offset::auto_estimate;
use navfuse_core::types::{GnssFix, ImuSample, NavSolution};
use navfuse_core::Vec3;
use navfuse_io::kfgins_yaml::KfGinsConfig;
use std::path::Path;

/// `navfuse run CONFIG --output OUT [--estimator E]`: the error as text.
pub(super) fn run_with(config: &Path, out: &Path, estimator: Option<&str>) -> Result<(), String> {
    let cfg = RunConfig::from_toml_file(config).map_err(|e| e.to_string())?;
    let base = config.parent().map(Path::to_path_buf).unwrap_or_default();
    let opts = RunOptions {
        output: Some(out.to_path_buf()),
        estimator: estimator.map(str::to_string),
        ..Default::default()
    };
    run(&cfg, &base, &opts)
        .map(|_| ())
        .map_err(|e| e.to_string())
}

/// `navfuse run CONFIG --output OUT` with the config's estimator.
pub(super) fn run_to(config: &Path, out: &Path) -> Result<(), String> {
    run_with(config, out, None)
}

/// A trajectory file's solutions (`.nav` with TOW-only lines in GPS week `week`, `.pos`).
pub(super) fn read_trajectory(path: &Path, week: u32) -> Vec<NavSolution> {
    let fmt = navfuse_io::trajectory::InFormat::from_path(path).unwrap();
    navfuse_io::trajectory::open_nav_source(path, fmt, week)
        .unwrap()
        .collect::<Result<Vec<_>, _>>()
        .unwrap()
}

/// [`run_to`], then its `solution.nav` (GPS week `week` for TOW-only
/// lines) and `summary.json`.
pub(super) fn run_and_read(
    config: &Path,
    out: &Path,
    week: u32,
) -> (Vec<NavSolution>, serde_json::Value) {
    run_to(config, out).unwrap();
    let sols = read_trajectory(&out.join("solution.nav"), week);
    let summary =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    (sols, summary)
}

/// A 60 s drive north at 5 m/s in KF-GINS text (level, 100 Hz IMU with
/// gravity only, 1 Hz fixes): `imu.txt` and `gnss.txt` in `dir`.
pub(super) fn write_north_drive(dir: &Path) {
    use std::fmt::Write as _;
    let (lat0, lon0, h) = (40.0f64.to_radians(), -105.0f64.to_radians(), 1600.0);
    let (rm, _) = navfuse_core::earth::radii(lat0);
    let (t0, v, g) = (1000.0, 5.0, 9.8);
    let mut imu = String::new();
    for k in 1..=6000 {
        let t = t0 + k as f64 * 0.01;
        let _ = writeln!(imu, "{t:.3} 0 0 0 0 0 {:.6}", -g * 0.01);
    }
    let mut gnss = String::new();
    for k in 0..=60 {
        let t = t0 + k as f64;
        let lat = lat0 + v * (t - t0) / (rm + h);
        let _ = writeln!(
            gnss,
            "{t:.3} {:.9} {:.9} {h:.3} 0.5 0.5 1.0",
            lat.to_degrees(),
            lon0.to_degrees()
        );
    }
    std::fs::write(dir.join("imu.txt"), imu).unwrap();
    std::fs::write(dir.join("gnss.txt"), gnss).unwrap();
}

/// [`write_north_drive`] run with `--estimator` pf-lc and gps-acc:
/// every estimator writes its solutions in the extra formats and a
/// summary naming it and accounting for every fix.
#[test]
fn run_other_estimators_write_solutions_and_summary() {
    let dir = crate::test_dir("run-other");
    write_north_drive(&dir);
    std::fs::write(
        dir.join("run.toml"),
        "formats = [\"csv\", \"geojson\"]\n[input]\nimu = \"imu.txt\"\ngnss = \"gnss.txt\"\n",
    )
    .unwrap();
    for name in ["pf-lc", "gps-acc"] {
        let out = dir.join(name);
        run_with(&dir.join("run.toml"), &out, Some(name)).unwrap();
        for f in [
            "solution.nav",
            "solution.csv",
            "solution.geojson",
            "summary.json",
        ] {
            assert!(out.join(f).exists(), "{name}: {f}");
        }
        let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
        assert!(
            summary.contains(&format!("\"estimator\": \"{name}\"")),
            "{summary}"
        );
        assert!(summary.contains("\"gnss_fed\": 61"), "{summary}");
        let nav = std::fs::read_to_string(out.join("solution.nav")).unwrap();
        assert!(
            nav.lines().count() > 1000,
            "{name}: {} lines",
            nav.lines().count()
        );
    }
    let e = run_with(&dir.join("run.toml"), &dir.join("x"), Some("kalman-magic")).unwrap_err();
    assert!(e.contains("kalman-magic"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The same 60 s drive north (level, 5 m/s) as KF-GINS text (time of
/// week) and as a generic CSV IMU in rates (GPS seconds, header, own
/// column names) with NMEA fixes: the two ESKF runs must agree and the
/// summary must account for every line of each file. The CSV with UBX
/// NAV-PVT fixes (which carry velocity) must end on the truth.
#[test]
fn csv_imu_with_nmea_or_ubx_gnss_runs_like_kfgins_text() {
    use navfuse_io::nmea::NmeaWriter;
    use std::fmt::Write as _;
    let dir = crate::test_dir("run-csv");
    let week = 2374.0;
    let (lat0, lon0, h) = (40.0f64.to_radians(), -105.0f64.to_radians(), 1600.0);
    let (rm, _) = navfuse_core::earth::radii(lat0);
    let (tow0, v, g, dt) = (243_000.0, 5.0, 9.8, 0.01);
    let (mut imu_txt, mut imu_csv) = (String::new(), String::from("t,wx,wy,wz,fx,fy,fz\n"));
    // Zero-mean vibration, so that the IMU does not look parked; the
    // text file holds the trapezoid increments of the CSV's rates.
    let rates = |k: i32| {
        let t = k as f64 * dt;
        let s = |hz: f64| (std::f64::consts::TAU * hz * t).sin();
        [
            0.02 * s(3.0),
            0.0,
            0.0,
            0.3 * s(5.0),
            0.0,
            -g + 0.5 * s(7.0),
        ]
    };
    for k in 1..=6000 {
        let tow = tow0 + k as f64 * dt;
        let (r0, r1) = (rates(k - 1), rates(k));
        let inc: Vec<String> = (0..6)
            .map(|i| format!("{:.9}", 0.5 * (r0[i] + r1[i]) * dt))
            .collect();
        let _ = writeln!(imu_txt, "{tow:.3} {}", inc.join(" "));
        let r: Vec<String> = r1.iter().map(|x| format!("{x:.9}")).collect();
        let _ = writeln!(imu_csv, "{:.3},{}", week * 604_800.0 + tow, r.join(","));
    }
    let (mut gnss_txt, mut nmea, mut ubx) = (String::new(), Vec::new(), Vec::new());
    {
        let mut w = NmeaWriter::new(&mut nmea);
        for k in 0..=60 {
            let tow = tow0 + k as f64;
            let lat = lat0 + v * (tow - tow0) / (rm + h);
            // The same fix as UBX NAV-PVT (UTC calendar, 1e-7°, mm, mm/s).
            let c = navfuse_io::time::calendar_from_gps(
                week * 604_800.0 + tow,
                navfuse_io::time::TimeSystem::Utc,
                3,
            );
            let pvt = navfuse_io::ubx::NavPvt {
                itow_ms: (tow * 1e3).round() as u32,
                year: c.year as u16,
                month: c.month,
                day: c.day,
                hour: c.hour,
                min: c.minute,
                sec: c.second.floor() as u8,
                nano_ns: ((c.second - c.second.floor()) * 1e9).round() as i32,
                valid: 0x07,
                fix_type: 3,
                flags: 0x01,
                num_sv: 9,
                lat_e7: (lat.to_degrees() * 1e7).round() as i32,
                lon_e7: (lon0.to_degrees() * 1e7).round() as i32,
                height_mm: (h * 1e3) as i32,
                h_acc_mm: 707,
                v_acc_mm: 1000,
                vel_n_mms: (v * 1e3) as i32,
                s_acc_mms: 200,
                ..Default::default()
            };
            ubx.extend(navfuse_io::ubx::encode(
                &navfuse_io::ubx::UbxMessage::NavPvt(pvt),
            ));
            let _ = writeln!(
                gnss_txt,
                "{tow:.3} {:.9} {:.9} {h:.3} 0.5 0.5 1.0",
                lat.to_degrees(),
                lon0.to_degrees()
            );
            w.write_fix(&GnssFix {
                t: week * 604_800.0 + tow,
                lat,
                lon: lon0,
                h,
                std_ned: Vec3::new(0.5, 0.5, 1.0),
                quality: 1,
                num_sats: 9,
                ..Default::default()
            })
            .unwrap();
        }
    }
    std::fs::write(dir.join("imu.txt"), imu_txt).unwrap();
    std::fs::write(dir.join("gnss.txt"), gnss_txt).unwrap();
    std::fs::write(dir.join("imu.csv"), imu_csv).unwrap();
    std::fs::write(dir.join("gnss.nmea"), nmea).unwrap();
    std::fs::write(dir.join("gnss.ubx"), ubx).unwrap();
    std::fs::write(
        dir.join("txt.toml"),
        "[input]\nimu = \"imu.txt\"\ngnss = \"gnss.txt\"\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("csv.toml"),
        "[input]\nimu = \"imu.csv\"\ngnss = \"gnss.nmea\"\n[input.csv]\ntime = \"t\"\n\
         gyro = [\"wx\", \"wy\", \"wz\"]\naccel = [4, 5, 6]\ngyro_unit = \"rad\"\n",
    )
    .unwrap();
    let last = |name: &str| -> (NavSolution, serde_json::Value) {
        let (sols, summary) = run_and_read(&dir.join(format!("{name}.toml")), &dir.join(name), 0);
        (*sols.last().unwrap(), summary)
    };
    std::fs::write(
        dir.join("ubx.toml"),
        std::fs::read_to_string(dir.join("csv.toml"))
            .unwrap()
            .replace("gnss.nmea", "gnss.ubx"),
    )
    .unwrap();
    let (a, _) = last("txt");
    let (b, sb) = last("csv");
    // UBX NAV-PVT (with velocity, which the other two files lack).
    let (u, su) = last("ubx");
    assert_eq!(su["inputs"]["gnss"]["format"], "ubx");
    assert_eq!(su["inputs"]["gnss"]["records"], 61);
    let truth_n = v * (u.t - week * 604_800.0 - tow0);
    let dn_u = (u.lat - lat0) * (rm + h) - truth_n;
    assert!(
        dn_u.abs() < 0.5 && ((u.lon - lon0) * rm).abs() < 0.5,
        "UBX end {dn_u} m"
    );
    let inputs = &sb["inputs"];
    assert_eq!(inputs["imu"]["format"], "csv");
    assert_eq!(inputs["gnss"]["format"], "nmea");
    assert_eq!(inputs["imu"]["used"], 6000);
    assert_eq!(inputs["gnss"]["records"], 61);
    assert_eq!(inputs["gnss"]["used"], 3 * 61, "GGA, RMC and GST per fix");
    assert_eq!(inputs["time_base"], "both files carry GPS seconds");
    // Every fix is either fed to the filter or outside its span.
    let fed = sb["gnss_fixes_fed"].as_u64().unwrap();
    let outside = sb["gnss_fixes_outside_filter_span"].as_u64().unwrap();
    assert_eq!(fed + outside, 61, "{sb}");
    assert!(fed > 50, "{sb}");
    // Same end point (NMEA keeps ~0.1 mm of latitude, GPS seconds ~1e-7 s).
    assert!(
        (b.t - week * 604_800.0 - a.t).abs() < 1e-3,
        "{} {}",
        a.t,
        b.t
    );
    let dn = (b.lat - a.lat) * rm;
    let de = (b.lon - a.lon) * rm * lat0.cos();
    eprintln!(
        "end points differ by {:.5} m; GNSS position updates {}",
        dn.hypot(de),
        sb["used_rejected"]["gnss_position"]
    );
    // 2 cm: the alignment seeds the initial covariance from each file's own
    // fix σ (GST in the NMEA, the σ columns of the text), so the two runs
    // differ by more than the NMEA rounding alone.
    assert!(
        dn.hypot(de) < 0.02,
        "end points differ by {dn:.4} N {de:.4} E m; {}",
        dir.display()
    );
    let truth_n = v * (a.t - tow0);
    assert!(((a.lat - lat0) * (rm + h) - truth_n).abs() < 0.5);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A parked car (yaw 123°, rolled 2°) with a magnetometer in its CSV
/// and static fixes: the GNSS course can never give a heading, the
/// tilt-compensated magnetometer mean (with the declination) does, and
/// so does an AHRS yaw column; the summary says which was used.
#[test]
fn static_start_takes_the_heading_from_the_magnetometer_or_ahrs() {
    use navfuse_core::attitude::dcm_from_euler;
    use std::fmt::Write as _;
    let dir = crate::test_dir("run-mag");
    let (yaw, roll, dec) = (
        123.0f64.to_radians(),
        2.0f64.to_radians(),
        8.0f64.to_radians(),
    );
    let c_bn = dcm_from_euler(&Vec3::new(roll, 0.0, yaw));
    // Field in NED: magnetic north is `dec` east of true north.
    let (bh, bz) = (21.0, 45.0);
    let m_n = Vec3::new(bh * dec.cos(), bh * dec.sin(), bz);
    let m_b = c_bn.transpose() * m_n;
    let g = navfuse_core::earth::gravity(40f64.to_radians(), 1600.0);
    let f_b = c_bn.transpose() * Vec3::new(0.0, 0.0, -g);
    let w_b = c_bn.transpose()
        * Vec3::new(
            navfuse_core::earth::OMEGA_IE * 40f64.to_radians().cos(),
            0.0,
            -navfuse_core::earth::OMEGA_IE * 40f64.to_radians().sin(),
        );
    let mut csv = String::from("t,gx,gy,gz,ax,ay,az,mx,my,mz,yaw\n");
    for k in 1..=3000 {
        let t = 2374.0 * 604_800.0 + 1000.0 + k as f64 * 0.01;
        let _ = writeln!(
            csv,
            "{t:.3},{},{},{},{},{},{},{},{},{},{}",
            w_b.x, w_b.y, w_b.z, f_b.x, f_b.y, f_b.z, m_b.x, m_b.y, m_b.z, 123.0
        );
    }
    let mut gnss = String::new();
    for k in 0..=30 {
        let _ = writeln!(
            gnss,
            "{:.3} 40.0 -105.0 1600.0 0.5 0.5 1.0",
            1000.0 + k as f64
        );
    }
    std::fs::write(dir.join("imu.csv"), csv).unwrap();
    std::fs::write(dir.join("gnss.txt"), gnss).unwrap();
    let toml = |heading: &str| {
        format!(
            "[input]\nimu = \"imu.csv\"\ngnss = \"gnss.txt\"\n[input.csv]\ntime = \"t\"\n\
             gyro = [\"gx\", \"gy\", \"gz\"]\naccel = [\"ax\", \"ay\", \"az\"]\ngyro_unit = \"rad\"\n\
             mag = [\"mx\", \"my\", \"mz\"]\nahrs_yaw = \"yaw\"\n\
             [init]\nheading = \"{heading}\"\nmagnetic_declination_deg = 8.0\n"
        )
    };
    for (heading, expect) in [
        ("magnetometer", "magnetometer"),
        ("ahrs", "AHRS"),
        ("auto", "AHRS"),
    ] {
        std::fs::write(dir.join("run.toml"), toml(heading)).unwrap();
        let (sols, summary) = run_and_read(&dir.join("run.toml"), &dir.join(heading), 0);
        let how = summary["alignment"].as_str().unwrap();
        assert!(how.contains(expect), "{heading}: {how}");
        let first = sols.first().unwrap();
        let d = (first.rpy.z - yaw).to_degrees();
        assert!(
            d.abs() < 0.2,
            "{heading}: yaw {} vs 123",
            first.rpy.z.to_degrees()
        );
        assert!(
            (first.rpy.x - roll).abs().to_degrees() < 0.2,
            "{heading}: roll"
        );
    }
    // Without a magnetometer or AHRS a parked start has no heading: said so.
    std::fs::write(dir.join("run.toml"), toml("course")).unwrap();
    let e = run_to(&dir.join("run.toml"), &dir.join("course")).unwrap_err();
    assert!(e.contains("no GNSS course"), "{e}");
    // The IMU noise in KF-GINS units is checked like KF-GINS's YAML.
    let noise = "[filter.imu_noise]\narw = [-1.0, 1.0, 1.0]\nvrw = [1.0, 1.0, 1.0]\n\
                 gbstd = [5.0, 5.0, 5.0]\nabstd = [300.0, 300.0, 300.0]\ngsstd = [0.0, 0.0, 0.0]\n\
                 asstd = [0.0, 0.0, 0.0]\ncorrtime = 1.0\n";
    let both = format!(
        "[filter]\nnoise_yaml = \"kf.yaml\"\n{}",
        noise.replace("-1.0", "1.0")
    );
    for (extra, expect) in [
        (noise.to_string(), "filter.imu_noise.arw"),
        (both, "one IMU noise source"),
    ] {
        std::fs::write(
            dir.join("run.toml"),
            format!("{}{extra}", toml("magnetometer")),
        )
        .unwrap();
        let e = run_to(&dir.join("run.toml"), &dir.join("noise")).unwrap_err();
        assert!(e.contains(expect), "{e}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The parked VN-310 (INSTINCT data): no motion, so only the
/// magnetometer can give the heading. Its calibrated `IMU::Mag` columns
/// start the ESKF at the first sample; the solution stays on the GNSS
/// mean position and the heading stays where the magnetometer put it.
#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn parked_vn310_starts_from_its_magnetometer() {
    let imu = navfuse_io::data::require("static_vn310/vn310-imu.csv");
    let gnss_csv = navfuse_io::data::require("static_vn310/vn310-gnss.csv");
    let dir = crate::test_dir("run-vn310");
    // The receiver's fixes as KF-GINS GNSS text (TOW, lat, lon, h, σNED).
    let text = std::fs::read_to_string(&gnss_csv).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| head.iter().position(|h| *h == n).unwrap();
    let cols = [
        "GpsTow [s]",
        "GNSS1::PosLla::latitude [deg]",
        "GNSS1::PosLla::longitude [deg]",
        "GNSS1::PosLla::altitude [m]",
        "GNSS1::PosU::N [m]",
        "GNSS1::PosU::E [m]",
        "GNSS1::PosU::D [m]",
    ]
    .map(col);
    let mut gnss = String::new();
    let (mut lat_sum, mut lon_sum, mut n) = (0.0, 0.0, 0.0);
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        let row: Vec<&str> = cols.iter().map(|&k| f[k]).collect();
        lat_sum += row[1].parse::<f64>().unwrap();
        lon_sum += row[2].parse::<f64>().unwrap();
        n += 1.0;
        gnss.push_str(&row.join(" "));
        gnss.push('\n');
    }
    std::fs::write(dir.join("gnss.txt"), gnss).unwrap();
    std::fs::write(
        dir.join("run.toml"),
        format!(
            "[input]\nimu = {:?}\nimu_rate = 50.0\ngnss = \"gnss.txt\"\n[input.csv]\npreset = \"vn310\"\n\
             mag = [\"IMU::Mag::X [Gauss]\", \"IMU::Mag::Y [Gauss]\", \"IMU::Mag::Z [Gauss]\"]\n",
            imu.display().to_string()
        ),
    )
    .unwrap();
    let (sols, summary) = run_and_read(&dir.join("run.toml"), &dir.join("out"), 0);
    let how = summary["alignment"].as_str().unwrap();
    assert!(how.contains("magnetometer"), "{how}");
    assert!(sols.len() > 1500, "{} solutions", sols.len());
    let (lat0, lon0) = ((lat_sum / n).to_radians(), (lon_sum / n).to_radians());
    let (rm, rn) = navfuse_core::earth::radii(lat0);
    let yaw0 = sols[0].rpy.z;
    for s in &sols {
        let d = ((s.lat - lat0) * rm).hypot((s.lon - lon0) * rn * lat0.cos());
        assert!(d < 2.0, "t {}: {d:.2} m from the GNSS mean", s.t);
        let dy = (s.rpy.z - yaw0 + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        assert!(dy.abs() < 1f64.to_radians(), "t {}: yaw moved {dy}", s.t);
    }
    eprintln!(
        "VN-310 parked: magnetometer heading {:.2}°",
        yaw0.to_degrees()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Run `DIR/NAME.toml` (a drive_0708 run, GPS week 2374) into `DIR/NAME`:
/// the horizontal RMS [m] of its antenna (lever arm (0, −0.05, 0) m FRD)
/// against `reference` (the 4 Hz `.pos`), and its summary.
pub(super) fn drive_rms(
    dir: &Path,
    name: &str,
    reference: &[NavSolution],
) -> (f64, serde_json::Value) {
    let (mut sols, summary) =
        run_and_read(&dir.join(format!("{name}.toml")), &dir.join(name), 2374);
    for s in sols.iter_mut() {
        if s.t < 604_800.0 {
            s.t += 2374.0 * 604_800.0;
        }
    }
    let cfg = navfuse_eval::EvalConfig {
        lever_arm_b: Some([0.0, -0.05, 0.0]),
        ..Default::default()
    };
    let ev = navfuse_eval::evaluate(&sols, reference, &cfg, None, None).unwrap();
    (ev.summary.horizontal.unwrap().rms, summary)
}

/// drive_0708 from the raw CSV IMU (preset, duplicates rejected, offset
/// estimated) and the 4 Hz RTKLIB .pos must give what the prepared
/// KF-GINS `imu.txt` gives with the same .pos: the generic path loses
/// nothing against the hand-made file.
#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn raw_csv_drive_matches_the_prepared_kfgins_file() {
    let imu_csv = navfuse_io::data::require("drive_0708/imu_1934_gpst.csv");
    let imu_txt = navfuse_io::data::require("drive_0708/kfgins/imu.txt");
    let pos = navfuse_io::data::require("drive_0708/gnss_1934_sf.pos");
    let dir = crate::test_dir("run-raw");
    let q = |p: &Path| format!("{:?}", p.display().to_string());
    std::fs::write(
        dir.join("csv.toml"),
        format!(
            "[input]\nimu = {}\ngnss = {}\nimu_time_offset = \"auto\"\n[input.csv]\npreset = \"drive_0708\"\n\
             [filter]\nlever_arm = [0.0, -0.05, 0.0]\n",
            q(&imu_csv),
            q(&pos)
        ),
    )
    .unwrap();
    std::fs::write(
        dir.join("txt.toml"),
        format!(
            "[input]\nimu = {}\ngnss = {}\n[filter]\nlever_arm = [0.0, -0.05, 0.0]\n",
            q(&imu_txt),
            q(&pos)
        ),
    )
    .unwrap();
    let reference = read_trajectory(&pos, 0);
    let rms = |name: &str| drive_rms(&dir, name, &reference);
    let (rms_txt, _) = rms("txt");
    let (rms_csv, s) = rms("csv");
    eprintln!("horizontal RMS vs the .pos: raw CSV {rms_csv:.4} m, imu.txt {rms_txt:.4} m");
    let tau = s["inputs"]["imu_time_offset_applied_s"].as_f64().unwrap();
    // The stamps lag by ≈ 0.2 s (README); `auto` applies the least extreme
    // of its model variants (the antenna-lever fit says −0.15 s, without it
    // −0.21 s), so anything clearly negative and within that spread.
    assert!((-0.25..-0.1).contains(&tau), "estimated IMU offset {tau}");
    let imu = &s["inputs"]["imu"];
    assert_eq!(imu["used"], 53_720);
    let rejected: u64 = imu["rejected"]
        .as_object()
        .unwrap()
        .values()
        .map(|v| v.as_u64().unwrap())
        .sum();
    assert_eq!(
        imu["used"].as_u64().unwrap() + imu["skipped"].as_u64().unwrap() + rejected,
        imu["lines_or_messages"].as_u64().unwrap()
    );
    assert!(
        rms_csv < 0.06 && (rms_csv - rms_txt).abs() < 0.005,
        "{rms_csv} vs {rms_txt}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn time_offset_estimate_recovers_a_shift() {
    let cfg = KfGinsConfig::load(&navfuse_io::data::require(
        "drive_0708/kfgins/kf-gins_full.yaml",
    ))
    .unwrap();
    let input = read_kfgins(&cfg).unwrap();
    // imu.txt already has its −0.2 s applied: nothing more is applied.
    let e0 = auto_estimate(&input.imu, &input.gnss);
    assert!(!e0.apply, "{}", crate::time_offset::describe(&e0));
    for shift in [0.15, -0.1] {
        let shifted: Vec<ImuSample> = input
            .imu
            .iter()
            .map(|s| ImuSample {
                t: s.t + shift,
                ..*s
            })
            .collect();
        let e = auto_estimate(&shifted, &input.gnss);
        // Every model variant moves by the shift (within 11 ms).
        for ((name, v0), (_, v)) in e0.variants.iter().zip(&e.variants) {
            let (t0, t) = (v0.tau_s.unwrap(), v.tau_s.unwrap());
            assert!(
                (t - (t0 - shift)).abs() < 0.011,
                "shift {shift}, {name}: estimated {t} from {t0}"
            );
        }
    }
}

#[test]
fn run_config_rejects_unknown_keys_with_the_field() {
    let e =
        toml::from_str::<RunConfig>("[input]\nimu = \"a\"\ngnss = \"b\"\nbogus = 1\n").unwrap_err();
    assert!(e.to_string().contains("bogus"), "{e}");
    let c: RunConfig = toml::from_str("[input]\nimu = \"a\"\ngnss = \"b\"\n").unwrap();
    assert_eq!(c.filter.preset, "enhanced");
    assert_eq!(c.input.imu_rate, 100.0);
}

/// `[filter.nhc] mount_states`: the run estimates the mounting states from
/// the given start (summary text and estimates), a non-positive σ is an
/// error naming the key, and a run without NHC carries none.
#[test]
fn nhc_mount_states_are_configured_reported_and_checked() {
    let dir = std::env::temp_dir().join(format!("navfuse-mount-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    write_north_drive(&dir);
    let cfg = |platform: &str, nhc: &str| {
        let p = dir.join(format!("{platform}.toml"));
        std::fs::write(
            &p,
            format!(
                "[input]\nimu = \"imu.txt\"\ngnss = \"gnss.txt\"\n[filter]\nplatform = \"{platform}\"\n\
                 [filter.nhc]\nmount_states = true\n{nhc}\n"
            ),
        )
        .unwrap();
        p
    };
    let (_, s) = run_and_read(
        &cfg("car", "mount_initial = [0.0, 1.0, 0.5]"),
        &dir.join("out_car"),
        0,
    );
    let f = &s["filter"];
    assert!(
        f["augmented_states"]
            .as_str()
            .unwrap()
            .contains("NHC mounting states estimated from pitch 0.00 ± 3.00°, yaw 1.00 ± 3.00°"),
        "{}",
        f["augmented_states"]
    );
    let a = &f["augmented_estimate"];
    let yaw_std = a["nhc_mount_pitch_yaw_std_deg"][1].as_f64().unwrap();
    assert!(yaw_std > 0.0 && yaw_std < 3.0, "{a}");
    let e = run_to(
        &cfg("car", "mount_std = [1.0, 0.0, 1.0]"),
        &dir.join("out_bad"),
    )
    .unwrap_err();
    assert!(e.contains("mount_std"), "{e}");
    // NHC switched off: the states are not created (σ stays 0).
    let (_, s) = run_and_read(&cfg("car", "enabled = false"), &dir.join("out_off"), 0);
    let a = &s["filter"]["augmented_estimate"];
    assert!(
        a.is_null() || a["nhc_mount_pitch_yaw_std_deg"][1].as_f64() == Some(0.0),
        "{a}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
