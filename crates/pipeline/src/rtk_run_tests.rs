use crate::config::RunConfig;
use std::path::Path;

fn run_err(toml: &str) -> String {
    let cfg: RunConfig = toml::from_str(toml).unwrap();
    match crate::run::run(&cfg, Path::new("/nonexistent"), &Default::default()) {
        Ok(_) => panic!("ran"),
        Err(e) => e.to_string(),
    }
}

const HEAD: &str = "[input]\nimu = \"imu.csv\"\ngnss = \"rover.ubx\"\n";

#[test]
fn rtk_without_base_is_an_error_naming_the_key() {
    let e = run_err(&format!("{HEAD}[filter]\ncoupling = \"rtk\"\n"));
    assert!(e.contains("[input] base"), "{e}");
}

#[test]
fn base_without_rtk_is_an_error() {
    let e = run_err(&format!(
        "{HEAD}base = \"b.obs\"\n[filter]\ncoupling = \"tight\"\n"
    ));
    assert!(e.contains("coupling = \"rtk\""), "{e}");
    let e = run_err(&format!("{HEAD}base_position = \"header\"\n"));
    assert!(e.contains("base_position"), "{e}");
}

#[test]
fn rinex_base_without_nav_is_an_error_naming_nav() {
    let e = run_err(&format!(
        "{HEAD}base = \"base.obs\"\n[filter]\ncoupling = \"rtk\"\nsmooth = false\n"
    ));
    assert!(e.contains("[input] nav") && e.contains("base"), "{e}");
}

#[test]
fn bad_base_position_is_an_error() {
    for bp in ["\"headr\"", "[95.0, 10.0, 0.0]", "[1.0e7, 0.0, 0.0]"] {
        let e = run_err(&format!(
            "{HEAD}base = \"base.obs\"\nbase_position = {bp}\n[filter]\ncoupling = \"rtk\"\n"
        ));
        assert!(e.contains("base_position"), "{bp}: {e}");
    }
}

#[test]
fn rtk_refuses_the_smoother() {
    let e = run_err(&format!(
        "{HEAD}base = \"base.obs\"\n[filter]\ncoupling = \"rtk\"\nsmooth = true\n"
    ));
    assert!(e.contains("smooth"), "{e}");
}

/// A base whose epochs are nowhere near the rover's (the GEONET 2005 base
/// against the simulated drive): an input error saying so.
#[test]
#[ignore = "real data: NAVFUSE_DATA=… cargo test --release -p navfuse-pipeline rtk_run -- --ignored"]
fn base_without_overlapping_epochs_is_an_error() {
    let base = navfuse_io::data::require("gnss/rinex/07590920.05o");
    let nav = navfuse_io::data::require("gnss/rinex/07590920.05n");
    let dir = crate::test_dir("rtk-no-overlap");
    crate::raw_drive::write_raw_drive(&dir, 1, 300.0).unwrap();
    let t = std::fs::read_to_string(dir.join("tight.toml"))
        .unwrap()
        .replace("coupling = \"tight\"", "coupling = \"rtk\"\nsmooth = false")
        .replace(
            "gnss = \"raw.ubx\"\n",
            &format!(
                "gnss = \"raw.ubx\"\nbase = {:?}\nnav = {:?}\n",
                base.display().to_string(),
                nav.display().to_string()
            ),
        );
    std::fs::write(dir.join("rtk.toml"), t).unwrap();
    let e = crate::run_tests::run_to(&dir.join("rtk.toml"), &dir.join("out")).unwrap_err();
    assert!(e.contains("do not overlap"), "{e}");
}

/// End to end, simulated (scenario fixed before any run): the car of
/// [`crate::raw_drive`] (seed 3, 300 s, static start, consumer MEMS, its
/// lever arm), its antenna simulated by [`navfuse_sim::rtk_scene`]
/// (dual-frequency GPS L1 + L2C, default error model, base 5.4 km away at
/// its true position in the header), written as RINEX 3 + nav + `imu.csv`
/// and run by `navfuse run` with `coupling = "rtk"`. Expected: every rover
/// epoch accounted for; no failed or unpaired epoch; at least half of the
/// applied epochs fixed; `.pos` rows with Q = 1 within 5 cm horizontal RMS
/// of the truth (the target is 2 cm; this bound leaves room for
/// the consumer IMU between epochs) and no Q = 1 row off by more than
/// 0.2 m.
#[test]
fn simulated_car_rtk_run_fixes_and_writes_quality() {
    use navfuse_core::geodesy::{c_en, geodetic_to_ecef, Geodetic};
    use navfuse_core::ins::mech::q_bn_from_rpy;
    use navfuse_core::Vec3;
    use navfuse_sim::multi_gnss::constellations;
    use navfuse_sim::platform::{platform_run, GnssGrade, ImuGrade, Platform, PlatformOptions};
    use navfuse_sim::rtk_scene::{offset_position, simulate_rtk, RtkSceneConfig, SceneSat};
    let seed = 3u64;
    let duration = 300.0;
    let dir = crate::test_dir("rtk-run-sim");
    let opts = PlatformOptions {
        duration_s: duration,
        static_start: true,
        imu: ImuGrade::Consumer,
        gnss: GnssGrade::Consumer,
        ..Default::default()
    };
    let sim = platform_run(Platform::Car, seed, &opts).unwrap().run;
    let t0 = sim.traj.truth[0].t;
    let lever = Vec3::from(sim.scenario.gnss.lever_arm_m);
    let traj = &sim.traj;
    let antenna = |t: f64| {
        let s = traj.at(t);
        let c_bn = q_bn_from_rpy(&s.rpy).to_rotation_matrix().into_inner();
        let p = geodetic_to_ecef(&Geodetic {
            lat: s.lat,
            lon: s.lon,
            h: s.h,
        });
        let cne = c_en(s.lat, s.lon).transpose();
        let v_n = s.v_n + c_bn * s.w_ib_b.cross(&lever);
        (p + cne * (c_bn * lever), cne * v_n)
    };
    let t_oe = ((t0 - 1.0) / 960.0).floor() * 960.0;
    let (nav_gps, _) = constellations(t_oe, seed);
    let sats = SceneSat::from_broadcast(&nav_gps, &[]);
    let base = offset_position(&antenna(t0).0, 5000.0, 2000.0, 20.0);
    let mut cfg = RtkSceneConfig::default();
    cfg.raw.seed = seed * 7919 + 17;
    let times: Vec<f64> = (1..duration as usize - 1).map(|k| t0 + k as f64).collect();
    let sc = simulate_rtk(&cfg, &sats, &times, antenna, base);
    let (rover_text, base_text) = sc.obs_texts();
    std::fs::write(dir.join("rover.obs"), rover_text).unwrap();
    std::fs::write(dir.join("base.obs"), base_text).unwrap();
    std::fs::write(
        dir.join("nav.rnx"),
        navfuse_io::rinex_write::nav3_text(&nav_gps, &[]),
    )
    .unwrap();
    navfuse_sim::output::write_run(&sim, &dir).unwrap();
    let toml = format!(
        "formats = [\"nav\", \"pos\"]\n\
         [input]\nimu = \"imu.csv\"\nimu_rate = {}\ngnss = \"rover.obs\"\nnav = \"nav.rnx\"\n\
         base = \"base.obs\"\n\
         [input.csv]\ntime = \"t_gps_s\"\ntime_base = \"gps_seconds\"\n\
         gyro = [\"dtheta_x_rad\", \"dtheta_y_rad\", \"dtheta_z_rad\"]\n\
         accel = [\"dvel_x_m_s\", \"dvel_y_m_s\", \"dvel_z_m_s\"]\n\
         gyro_unit = \"rad\"\naccel_unit = \"m/s2\"\nform = \"increment\"\n\
         [filter]\nimu_preset = \"{}\"\nlever_arm = [{}, {}, {}]\ncoupling = \"rtk\"\nsmooth = false\n",
        sim.scenario.imu.rate_hz,
        ImuGrade::Consumer.preset(),
        lever.x,
        lever.y,
        lever.z
    );
    std::fs::write(dir.join("rtk.toml"), toml).unwrap();
    let out = dir.join("out");
    let week = (t0 / 604_800.0).floor() as u32;
    let (sols, summary) = crate::run_tests::run_and_read(&dir.join("rtk.toml"), &out, week);
    let r = &summary["rtk"];
    eprintln!("{}", serde_json::to_string_pretty(r).unwrap());
    let n = |k: &str| r[k].as_u64().unwrap_or_else(|| panic!("{k}"));
    assert_eq!(
        n("rover_epochs_read"),
        n("rover_epochs_cut_by_outage")
            + n("rover_epochs_before_filter_start")
            + n("rover_epochs_unpaired_no_update")
            + n("rover_epochs_applied")
            + n("rover_epochs_failed")
            + n("rover_epochs_not_reached")
    );
    assert_eq!(n("rover_epochs_failed"), 0);
    assert_eq!(n("rover_epochs_unpaired_no_update"), 0);
    assert!(2 * n("fixed") >= n("rover_epochs_applied"), "{r}");
    // Q of each .pos row (same order as solution.nav).
    let pos = std::fs::read_to_string(out.join("solution.pos")).unwrap();
    let q: Vec<u8> = pos
        .lines()
        .filter(|l| !l.starts_with('%'))
        .map(|l| l.split_whitespace().nth(5).unwrap().parse().unwrap())
        .collect();
    assert_eq!(q.len(), sols.len());
    let mut e2 = Vec::new();
    for (s, q) in sols.iter().zip(&q) {
        if *q == 1 {
            let tr = traj.at(s.t);
            let (rm, rn) = navfuse_core::earth::radii(tr.lat);
            let dn = (s.lat - tr.lat) * (rm + tr.h);
            let de = (s.lon - tr.lon) * (rn + tr.h) * tr.lat.cos();
            e2.push(dn * dn + de * de);
            if e2.len() % 2000 == 1 {
                let sp = tr.v_n.xy().norm();
                let along = (dn * tr.v_n.x + de * tr.v_n.y) / sp.max(1e-6);
                eprintln!(
                    "t {:.2} dn {dn:.3} de {de:.3} speed {sp:.2} along {along:.3}",
                    s.t - t0
                );
            }
        }
    }
    let rms = (e2.iter().sum::<f64>() / e2.len().max(1) as f64).sqrt();
    let max = e2.iter().fold(0.0f64, |a, b| a.max(b.sqrt()));
    eprintln!(
        "Q=1 rows {} of {}: horizontal RMS {:.4} m, max {:.4} m",
        e2.len(),
        q.len(),
        rms,
        max
    );
    assert!(!e2.is_empty());
    assert!(rms <= 0.05 && max <= 0.2, "rms {rms} max {max}");
}
