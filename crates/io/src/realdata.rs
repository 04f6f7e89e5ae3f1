//! Real-data tests on `/work/shared/data` (ignored by default; run with
//! `cargo test -p navfuse-io --release -- --ignored`). Counts are those of
//! the files (see `data/README.md`), checked independently with `wc`/`awk`.

use crate::csv_imu::{CsvImuConfig, CsvImuReader, REASON_REPEATED};
use crate::data::require;
use crate::kfgins::{KfGinsGnssReader, KfGinsImuOptions, KfGinsImuReader, KfGinsNavReader};
use crate::pos::PosReader;
use crate::time::gps_seconds;
use std::time::Instant;

const IGN: &str = "real data";

fn open(rel: &str) -> (std::io::BufReader<std::fs::File>, String) {
    crate::open(&require(rel)).unwrap()
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn pos_file_parses_completely() {
    let (r, n) = open("drive_0708/gnss_1934_sf.pos");
    let mut rd = PosReader::new(r, &n);
    let fixes: Vec<_> = rd.by_ref().map(Result::unwrap).collect();
    assert_eq!(fixes.len(), 2197, "{IGN}");
    assert_eq!(fixes.iter().filter(|f| f.quality == 1).count(), 2189);
    assert_eq!(fixes.iter().filter(|f| f.quality == 2).count(), 8);
    assert!(fixes.iter().all(|f| f.v_n.is_some() && f.std_v_n.is_some()));
    assert_eq!(fixes[0].t, gps_seconds(2374, 243_258.499));
    assert!(fixes.windows(2).all(|w| w[1].t > w[0].t));
    assert!(rd.stats().is_balanced() && rd.stats().rejected_total() == 0);
    assert_eq!(rd.stats().skipped, 1);
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn kfgins_imu_parses_completely_and_fast() {
    let path = require("drive_0708/kfgins/imu.txt");
    let mut best = f64::INFINITY;
    let mut n = 0;
    for _ in 0..5 {
        let t0 = Instant::now();
        let (r, name) = crate::open(&path).unwrap();
        let opt = KfGinsImuOptions {
            week: 2374,
            ..Default::default()
        };
        let mut rd = KfGinsImuReader::new(r, &name, opt);
        let mut sum_dt = 0.0;
        n = 0;
        for s in rd.by_ref() {
            let s = s.unwrap();
            sum_dt += s.dt;
            n += 1;
        }
        best = best.min(t0.elapsed().as_secs_f64());
        assert!(
            rd.stats().is_balanced() && rd.stats().rejected_total() == 0,
            "{}",
            rd.stats()
        );
        assert!((sum_dt - (243810.384531 - 243261.664534 + 0.010003)).abs() < 1e-3);
    }
    assert_eq!(n, 53_719);
    eprintln!(
        "imu.txt: {n} samples parsed in {:.1} ms (best of 5)",
        best * 1e3
    );
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn kfgins_gnss_and_nav_parse_completely() {
    let (r, n) = open("drive_0708/kfgins/gnss_full.txt");
    let g: Vec<_> = KfGinsGnssReader::new(r, &n, 2374)
        .map(Result::unwrap)
        .collect();
    assert_eq!(g.len(), 545);
    assert!(g.iter().all(|f| f.std_ned.x >= 0.02 && f.v_n.is_none()));
    let (r, n) = open("drive_0708/kfgins/truth.nav");
    let t: Vec<_> = KfGinsNavReader::new(r, &n, 0).map(Result::unwrap).collect();
    assert_eq!(t.len(), 2189);
    assert!(
        t.iter().all(|s| s.rpy.x.is_nan()),
        "truth attitude is unknown"
    );
    let (r, n) = open("drive_0708/kfgins/kfgins_result_full_10hz.nav");
    let k: Vec<_> = KfGinsNavReader::new(r, &n, 2374)
        .map(Result::unwrap)
        .collect();
    assert_eq!(k.len(), 5369);
    assert!(k.iter().all(|s| s.rpy.iter().all(|a| a.is_finite())));
    assert_eq!(k[0].t, gps_seconds(2374, 243_262.014636));
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn drive_csv_imu_parses_with_repeated_rows_counted() {
    let (r, n) = open("drive_0708/imu_1934_gpst.csv");
    let cfg = CsvImuConfig {
        mount_rpy_deg: None,
        misalign_rpy_deg: None,
        ..CsvImuConfig::drive_0708()
    };
    let t0 = Instant::now();
    let mut rd = CsvImuReader::new(r, &n, cfg);
    let v: Vec<_> = rd.by_ref().map(Result::unwrap).collect();
    let el = t0.elapsed();
    let st = rd.stats();
    eprintln!(
        "imu_1934_gpst.csv: {st} in {:.1} ms",
        el.as_secs_f64() * 1e3
    );
    // 54,859 lines = 1 comment + 54,858 rows, of which 1,138 repeat the previous row (awk).
    assert_eq!(st.lines, 54_859);
    assert_eq!(st.skipped, 1);
    assert_eq!(st.rejected_for(REASON_REPEATED), 1_138);
    assert_eq!(v.len(), 54_858 - 1_138);
    assert!(st.is_balanced());
    // At rest the unrotated sensor z reads ≈ +1 g: mean Δv_z/dt over the first 2 s.
    let m: f64 = v[..200].iter().map(|s| s.dvel_b.z / s.dt).sum::<f64>() / 200.0;
    assert!((m - 9.8).abs() < 0.3, "{m}");
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn vn310_csv_imu_parses() {
    let (r, n) = open("static_vn310/vn310-imu.csv");
    let mut rd = CsvImuReader::new(r, &n, CsvImuConfig::vn310());
    let v: Vec<_> = rd.by_ref().map(Result::unwrap).collect();
    let st = rd.stats();
    assert_eq!(st.lines, 1613);
    assert_eq!(v.len() as u64 + st.rejected_total(), 1612, "{st}");
    assert!(st.is_balanced());
    let mean_dt = v.iter().map(|s| s.dt).sum::<f64>() / v.len() as f64;
    assert!((mean_dt - 0.02).abs() < 1e-4, "50 Hz: {mean_dt}");
    let fz = v.iter().map(|s| s.dvel_b.z / s.dt).sum::<f64>() / v.len() as f64;
    assert!((fz + 9.80).abs() < 0.05, "static specific force z {fz}");
    assert_eq!(v[0].t, gps_seconds(2303, 403_575.847627));
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn drive_preset_mounting_matches_kfgins_body_frame_at_rest() {
    // Mean specific force over the first 3 s (vehicle at rest), preset vs the
    // KF-GINS input that was prepared with the upstream mounting.
    let (r, n) = open("drive_0708/imu_1934_gpst.csv");
    let v: Vec<_> = CsvImuReader::new(r, &n, CsvImuConfig::drive_0708())
        .map(Result::unwrap)
        .take_while(|s| s.t < gps_seconds(2374, 243_264.85))
        .collect();
    let f = v
        .iter()
        .map(|s| s.dvel_b)
        .sum::<navfuse_core::types::Vec3>()
        / v.iter().map(|s| s.dt).sum::<f64>();
    let (r, n) = open("drive_0708/kfgins/imu.txt");
    let k: Vec<_> = KfGinsImuReader::new(
        r,
        &n,
        KfGinsImuOptions {
            week: 2374,
            ..Default::default()
        },
    )
    .map(Result::unwrap)
    .take_while(|s| s.t < gps_seconds(2374, 243_264.66))
    .collect();
    let fk = k
        .iter()
        .map(|s| s.dvel_b)
        .sum::<navfuse_core::types::Vec3>()
        / k.iter().map(|s| s.dt).sum::<f64>();
    eprintln!("static f_b: preset {f:?}, kfgins imu.txt {fk:?}");
    assert!(f.z < -9.7 && f.x.abs() < 0.05, "{f}");
    let cos = f.dot(&fk) / (f.norm() * fk.norm());
    assert!(
        cos.acos().to_degrees() < 1.0,
        "directions differ by {}°",
        cos.acos().to_degrees()
    );
}

/// Every broadcast ephemeris of the real `brdc1820.10n` (GPS, 2010-07-01)
/// written as LNAV subframes 1–3 and read back gives the same orbit: the
/// RINEX values are the broadcast ones, so re-quantising them must land on
/// the same integers (positions within 1 mm over ±2 h, clocks within
/// 1e-12 s) — a check of every field's bit position and scale factor
/// against real ephemerides, not only our own encoder.
#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn real_broadcast_ephemerides_survive_lnav_subframes() {
    use crate::gps_lnav::{decode_subframe, encode_ephemeris, Assembler};
    let nav = crate::rinex::read_nav_data(&require("gnss/rinex/brdc1820.10n")).unwrap();
    let ephs = &nav.orbits;
    assert!(ephs.len() > 300, "{} ephemerides", ephs.len());
    for (k, o) in ephs.iter().enumerate() {
        let week = (o.t_oe / 604_800.0).floor() as u16;
        let tow = ((o.t_oe - f64::from(week) * 604_800.0) / 6.0).floor() * 6.0;
        let sfs = encode_ephemeris(o, (k % 256) as u8, nav.ura_m[k], tow).unwrap();
        let mut a = Assembler::default();
        let mut got = None;
        for w in &sfs {
            got = a.push(o.prn, &decode_subframe(w).unwrap(), week);
        }
        let e = got.unwrap();
        let g = e.orbit;
        let ura = navfuse_core::gnss::spp::ura_sigma_m;
        assert_eq!(ura(e.ura_m), ura(nav.ura_m[k]), "PRN {} URA", o.prn);
        for dt in [-7200.0, 0.0, 7200.0] {
            let t = o.t_oe + dt;
            let d = (g.position_ecef(t) - o.position_ecef(t)).norm();
            assert!(d < 1e-3, "PRN {} t_oe {}: {d} m", o.prn, o.t_oe);
            assert!((g.clock_offset(t) - o.clock_offset(t)).abs() < 1e-12);
        }
        assert_eq!((g.t_oe, g.t_oc, g.health), (o.t_oe, o.t_oc, o.health));
    }
    let k = nav.iono.expect("header ionosphere");
    let mut a = Assembler::default();
    a.push(
        1,
        &decode_subframe(&crate::gps_lnav::encode_iono(&k, 0.0).unwrap()).unwrap(),
        1590,
    );
    // The header prints 4 significant digits of the broadcast values.
    let got = a.iono.expect("page 18 decoded");
    let pairs = got
        .alpha
        .iter()
        .chain(&got.beta)
        .zip(k.alpha.iter().chain(&k.beta));
    for (g, h) in pairs {
        assert!((g - h).abs() <= 1e-3 * h.abs(), "{got:?} vs header {k:?}");
    }
}
