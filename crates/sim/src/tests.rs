//! Whole-simulator tests: ideal-sensor consistency through a reference
//! strapdown, determinism, static sanity.

use super::*;
use crate::rot::{dcm_from_euler, dcm_from_rotvec, euler_from_dcm, skew};
use crate::trajectory::{generate, Segment, Start};
use navfuse_core::Mat3;

/// Compact reference strapdown (Groves 2nd ed. §5.4–5.5 precision form; the
/// same structure as KF-GINS' insmech): two-sample coning and sculling,
/// navigation-frame rotation over the interval, Coriolis and gravity at the
/// extrapolated mid-epoch, trapezoidal position. For tests only — the
/// production mechanization lives in `navfuse_core::ins`.
pub(crate) struct RefIns {
    lat: f64,
    lon: f64,
    h: f64,
    v_n: Vec3,
    v_prev: Vec3,
    pub(crate) c_bn: Mat3,
    dth_prev: Vec3,
    dv_prev: Vec3,
}

impl RefIns {
    pub(crate) fn new(t: &trajectory::TruthEpoch) -> Self {
        RefIns {
            lat: t.lat,
            lon: t.lon,
            h: t.h,
            v_n: t.v_n,
            v_prev: t.v_n,
            c_bn: dcm_from_euler(&t.rpy),
            dth_prev: Vec3::zeros(),
            dv_prev: Vec3::zeros(),
        }
    }

    pub(crate) fn step(&mut self, s: &ImuSample) {
        let dt = s.dt;
        let (dth, dv) = (s.dtheta_b, s.dvel_b);
        // Mid-epoch extrapolation of velocity and position.
        let v_mid = 1.5 * self.v_n - 0.5 * self.v_prev;
        let rates = earth::geodetic_rates(self.lat, self.h, &v_mid);
        let lat_mid = self.lat + 0.5 * rates.x * dt;
        let h_mid = self.h + 0.5 * rates.z * dt;
        let w_ie = earth::omega_ie_n(lat_mid);
        let w_en = earth::omega_en_n(lat_mid, h_mid, &v_mid);
        let zeta = (w_ie + w_en) * dt;
        // Velocity: sculling, frame rotation, gravity/Coriolis.
        let scul =
            0.5 * dth.cross(&dv) + (self.dth_prev.cross(&dv) + self.dv_prev.cross(&dth)) / 12.0;
        let dv_f = (Mat3::identity() - 0.5 * skew(&zeta)) * self.c_bn * (dv + scul);
        let g = earth::gravity_n(lat_mid, h_mid);
        let dv_gc = (g - (2.0 * w_ie + w_en).cross(&v_mid)) * dt;
        let v_new = self.v_n + dv_f + dv_gc;
        // Position: trapezoid (h, then lat with the mid height, then lon).
        let h_new = self.h - 0.5 * (self.v_n.z + v_new.z) * dt;
        let hm = 0.5 * (self.h + h_new);
        let (rm, _) = earth::radii(self.lat);
        let lat_new = self.lat + 0.5 * (self.v_n.x + v_new.x) / (rm + hm) * dt;
        let latm = 0.5 * (self.lat + lat_new);
        let (_, rn) = earth::radii(latm);
        let lon_new = self.lon + 0.5 * (self.v_n.y + v_new.y) / ((rn + hm) * latm.cos()) * dt;
        // Attitude: coning, body rotation, nav-frame rotation at the new mid-epoch.
        let v_mid2 = 0.5 * (self.v_n + v_new);
        let w2 = earth::omega_ie_n(latm) + earth::omega_en_n(latm, hm, &v_mid2);
        let phi = dth + self.dth_prev.cross(&dth) / 12.0;
        self.c_bn = dcm_from_rotvec(&(-w2 * dt)) * self.c_bn * dcm_from_rotvec(&phi);
        self.v_prev = self.v_n;
        self.v_n = v_new;
        self.lat = lat_new;
        self.lon = lon_new;
        self.h = h_new;
        self.dth_prev = dth;
        self.dv_prev = dv;
    }

    pub(crate) fn pos_err_m(&self, t: &trajectory::TruthEpoch) -> Vec3 {
        let (rm, rn) = earth::radii(t.lat);
        Vec3::new(
            (self.lat - t.lat) * (rm + t.h),
            (self.lon - t.lon) * (rn + t.h) * t.lat.cos(),
            t.h - self.h,
        )
    }
}

fn car_with_turns_and_hills() -> (Start, Vec<Segment>) {
    let start = Start {
        lat_deg: 30.5,
        lon_deg: 114.3,
        h_m: 30.0,
        rpy_deg: [0.0, 0.0, 20.0],
        v_b: [0.0; 3],
        gps_week: 2300,
        tow_s: 345_600.0,
    };
    let text = r#"
[[s]]
type = "hold"
duration_s = 5
[[s]]
type = "accelerate"
speed_kmh = 60
accel = 2.0
[[s]]
type = "cruise"
duration_s = 20
[[s]]
type = "turn"
rate_deg_s = 10
angle_deg = 90
[[s]]
type = "grade"
grade_pct = 6
[[s]]
type = "cruise"
distance_m = 400
[[s]]
type = "grade"
grade_pct = -4
transition_s = 5
[[s]]
type = "turn"
rate_deg_s = -8
angle_deg = 135
[[s]]
type = "grade"
grade_pct = 0
[[s]]
type = "cruise"
duration_s = 60
[[s]]
type = "uturn"
[[s]]
type = "accelerate"
speed_kmh = 90
[[s]]
type = "cruise"
duration_s = 120
[[s]]
type = "turn"
rate_deg_s = 5
duration_s = 40
[[s]]
type = "stop"
decel = 2.5
[[s]]
type = "hold"
duration_s = 10
[[s]]
type = "accelerate"
speed_kmh = 40
[[s]]
type = "cruise"
duration_s = 600
"#;
    #[derive(serde::Deserialize)]
    struct S {
        s: Vec<Segment>,
    }
    let s: S = toml::from_str(text).unwrap();
    (start, s.s)
}

#[test]
fn static_ideal_imu_is_earth_rate_and_gravity() {
    let start = Start {
        lat_deg: 45.0,
        lon_deg: 10.0,
        h_m: 100.0,
        rpy_deg: [0.0; 3],
        v_b: [0.0; 3],
        gps_week: 2300,
        tow_s: 0.0,
    };
    let tr = generate(&start, &[Segment::Hold { duration_s: 1.0 }], 100.0, 4).unwrap();
    let s = tr.imu[50];
    let lat = 45f64.to_radians();
    let g = earth::gravity(lat, 100.0);
    assert!((s.dvel_b - Vec3::new(0.0, 0.0, -g * 0.01)).norm() < 1e-12);
    assert!((s.dtheta_b - earth::omega_ie_n(lat) * 0.01).norm() < 1e-16);
    assert_eq!(tr.imu.len(), 100);
    assert!((tr.truth.last().unwrap().lat - lat).abs() < 1e-15);
}

#[test]
fn ideal_increments_reproduce_truth_through_strapdown() {
    // Issue 4 must-show 1: free-inertial integration of the ideal 100 Hz IMU
    // from the true initial state stays within 0.01 m after 60 s and 0.1 m
    // after 10 min on a car trajectory with turns and hills.
    let (start, segs) = car_with_turns_and_hills();
    let tr = generate(&start, &segs, 100.0, 4).unwrap();
    assert!(tr.duration() > 600.0, "{}", tr.duration());
    let mut ins = RefIns::new(&tr.truth[0]);
    let mut max60: f64 = 0.0;
    let mut max600: f64 = 0.0;
    let mut max_att: f64 = 0.0;
    let mut max_hspeed: f64 = 0.0;
    let mut max_climb: f64 = 0.0;
    for (i, s) in tr.imu.iter().enumerate() {
        ins.step(s);
        let t = &tr.truth[i + 1];
        let e = ins.pos_err_m(t).norm();
        let el = t.t - tr.truth[0].t;
        if el <= 60.0 + 1e-9 {
            max60 = max60.max(e);
        }
        if el <= 600.0 + 1e-9 {
            max600 = max600.max(e);
            let da = euler_from_dcm(&(ins.c_bn * dcm_from_euler(&t.rpy).transpose()));
            max_att = max_att.max(da.norm());
        }
        max_hspeed = max_hspeed.max(t.v_n.xy().norm());
        max_climb = max_climb.max(-t.v_n.z);
    }
    eprintln!(
        "ideal-sensor strapdown: max |Δp| 60 s = {max60:.3e} m, 10 min = {max600:.3e} m, max attitude error {max_att:.3e} rad"
    );
    assert!(max_hspeed > 24.0 && max_climb > 0.5, "trajectory too tame");
    assert!(max60 < 0.01, "60 s: {max60} m");
    assert!(max600 < 0.1, "10 min: {max600} m");
    // A rate×dt (not integral) IMU would fail: check the test is sensitive by
    // replacing the increments with rate·dt at the end of each interval.
    let mut bad = RefIns::new(&tr.truth[0]);
    let mut bad_err: f64 = 0.0;
    for (i, s) in tr.imu.iter().enumerate().take(60_00) {
        let t = &tr.truth[i + 1];
        let crude = ImuSample {
            dtheta_b: t.w_ib_b * s.dt,
            dvel_b: t.f_b * s.dt,
            ..*s
        };
        bad.step(&crude);
        bad_err = bad_err.max(bad.pos_err_m(t).norm());
    }
    assert!(bad_err > 10.0 * max60, "rate×dt gives {bad_err} m");
}

fn small_scenario() -> Scenario {
    Scenario::from_toml(
        r#"
name = "det"
[start]
lat_deg = 35.0
lon_deg = 125.0
[imu]
preset = "phone"
rate_hz = 50
substeps = 2
[gnss]
preset = "lowcost-4hz"
outages = [[10, 15]]
lever_arm_m = [0.5, 0.0, -1.0]
[[segment]]
type = "accelerate"
speed_mps = 10
[[segment]]
type = "turn"
rate_deg_s = 20
angle_deg = 90
[[segment]]
type = "cruise"
duration_s = 10
"#,
        "det",
    )
    .unwrap()
}

fn read_dir_bytes(dir: &std::path::Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

#[test]
fn same_seed_gives_byte_identical_files() {
    let sc = small_scenario();
    let base = std::env::temp_dir().join(format!("navfuse-sim-det-{}", std::process::id()));
    let dirs = [base.join("a"), base.join("b"), base.join("c")];
    for (d, seed) in dirs.iter().zip([7u64, 7, 8]) {
        let run = simulate(&sc, seed, None, None).unwrap();
        output::write_run(&run, d).unwrap();
    }
    let (a, b, c) = (
        read_dir_bytes(&dirs[0]),
        read_dir_bytes(&dirs[1]),
        read_dir_bytes(&dirs[2]),
    );
    assert_eq!(a.len(), 8);
    assert!(a == b, "same seed, different bytes");
    let imu = |v: &Vec<(String, Vec<u8>)>| v.iter().find(|x| x.0 == "imu.txt").unwrap().1.clone();
    assert_ne!(imu(&a), imu(&c), "different seeds, same IMU file");
    // Truth does not depend on the seed.
    let truth =
        |v: &Vec<(String, Vec<u8>)>| v.iter().find(|x| x.0 == "truth.nav").unwrap().1.clone();
    assert_eq!(truth(&a), truth(&c));
    let _ = std::fs::remove_dir_all(&base);
}

#[test]
fn gnss_outages_every_n_and_noise_level() {
    let mut sc = small_scenario();
    let run = simulate(&sc, 1, None, None).unwrap();
    let t0 = run.traj.truth[0].t;
    assert!(run
        .gnss
        .iter()
        .all(|g| !(g.t - t0 >= 10.0 && g.t - t0 < 15.0)));
    // 4 Hz: consecutive fixes 0.25 s apart outside the outage.
    assert!((run.gnss[1].t - run.gnss[0].t - 0.25).abs() < 1e-9);
    sc.gnss.every_s = 2.0;
    sc.gnss.outages.clear();
    let run = simulate(&sc, 1, None, None).unwrap();
    assert!(run
        .gnss
        .windows(2)
        .all(|w| (w[1].t - w[0].t - 2.0).abs() < 1e-9));
    // Horizontal error statistics on a long static run match the 5 m CEP.
    let mut sc = small_scenario();
    sc.imu.rate_hz = 1.0;
    sc.imu.substeps = 1;
    sc.segment = vec![Segment::Hold {
        duration_s: 20_000.0,
    }];
    sc.gnss.outages.clear();
    let mut spec = gnss_model::gnss_preset("lowcost-4hz").unwrap();
    spec.jump_prob = 0.0;
    spec.gm_tau_s = 5.0;
    let run = simulate(
        &sc,
        3,
        Some(imu_model::imu_preset("ideal").unwrap()),
        Some(spec),
    )
    .unwrap();
    let mut errs: Vec<f64> = run
        .gnss
        .iter()
        .zip(&run.gnss_truth)
        .map(|(g, t)| {
            let (rm, rn) = earth::radii(t.0);
            ((g.lat - t.0) * rm).hypot((g.lon - t.1) * rn * t.0.cos())
        })
        .collect();
    errs.sort_by(f64::total_cmp);
    let cep = errs[errs.len() / 2];
    assert!((cep / 5.0 - 1.0).abs() < 0.05, "empirical CEP {cep} m");
}

#[test]
fn scenario_errors_are_clear() {
    let e = Scenario::from_toml(
        "[start]\nlat_deg = 1\nlon_deg = 2\n[[segment]]\ntype = \"fly\"\n",
        "x.toml",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("x.toml") && e.contains("fly"), "{e}");
    let sc = Scenario::from_toml(
        "[start]\nlat_deg = 1\nlon_deg = 2\n[[segment]]\ntype = \"cruise\"\ndistance_m = 5\n",
        "y.toml",
    )
    .unwrap();
    let e = simulate(&sc, 0, None, None).unwrap_err().to_string();
    assert!(
        e.contains("segment 1 (cruise)") && e.contains("speed is 0"),
        "{e}"
    );
}

#[test]
fn campus_loop_closes() {
    let sc = Scenario::from_toml(
        "[start]\nlat_deg = 36.0\nlon_deg = 127.0\n[[segment]]\ntype = \"loop\"\nspeed_kmh = 20\nlength_m = 300\nwidth_m = 150\nlaps = 2\n",
        "loop",
    )
    .unwrap();
    let tr = generate(&sc.start, &sc.segment, 100.0, 4).unwrap();
    let (a, b) = (&tr.truth[0], tr.truth.last().unwrap());
    let (rm, rn) = earth::radii(a.lat);
    let dn = (b.lat - a.lat) * rm;
    let de = (b.lon - a.lon) * rn * a.lat.cos();
    // Ends at rest on the first side (east offset only from rounding the
    // straights to the internal grid and meridian convergence), heading as at the start.
    assert!(b.v_n.norm() < 1e-9);
    assert!(de.abs() < 0.05 && dn > 0.0 && dn < 300.0, "dn {dn} de {de}");
    assert!(b.rpy.z.abs() < 1e-9);
}

#[test]
fn written_files_read_back_with_navfuse_io() {
    use navfuse_io::kfgins::{
        KfGinsGnssReader, KfGinsImuOptions, KfGinsImuReader, KfGinsNavReader,
    };
    let sc = small_scenario();
    let run = simulate(&sc, 3, None, None).unwrap();
    let dir = std::env::temp_dir().join(format!("navfuse-sim-rt-{}", std::process::id()));
    output::write_run(&run, &dir).unwrap();
    let week = sc.start.gps_week;
    let open = |n: &str| navfuse_io::open(&dir.join(n)).unwrap();
    let (r, name) = open("imu.txt");
    let opt = KfGinsImuOptions {
        week,
        nominal_rate_hz: Some(sc.imu.rate_hz),
        ..Default::default()
    };
    let imu: Vec<ImuSample> = KfGinsImuReader::new(r, &name, opt)
        .collect::<Result<_, _>>()
        .unwrap();
    assert_eq!(imu.len(), run.imu.len());
    for (a, b) in imu.iter().zip(&run.imu) {
        assert!((a.t - b.t).abs() < 1e-6 && (a.dt - b.dt).abs() < 1e-6);
        assert!((a.dtheta_b - b.dtheta_b).norm() < 1e-15 + 1e-11 * b.dtheta_b.norm());
        assert!((a.dvel_b - b.dvel_b).norm() < 1e-15 + 1e-11 * b.dvel_b.norm());
    }
    let (r, name) = open("gnss.txt");
    let fixes: Vec<GnssFix> = KfGinsGnssReader::new(r, &name, week)
        .collect::<Result<_, _>>()
        .unwrap();
    assert_eq!(fixes.len(), run.gnss.len());
    for (a, b) in fixes.iter().zip(&run.gnss) {
        assert!((a.t - b.t).abs() < 1e-6);
        assert!((a.lat - b.lat).abs() < 1e-12 && (a.lon - b.lon).abs() < 1e-12);
        assert!((a.h - b.h).abs() < 1e-4 && (a.std_ned - b.std_ned).norm() < 1e-4);
    }
    let (r, name) = open("truth.nav");
    let nav: Vec<navfuse_core::NavSolution> = KfGinsNavReader::new(r, &name, week)
        .collect::<Result<_, _>>()
        .unwrap();
    assert_eq!(nav.len(), run.traj.truth.len());
    let last = (nav.last().unwrap(), run.traj.truth.last().unwrap());
    assert!((last.0.lat - last.1.lat).abs() < 1e-10 && (last.0.rpy.z - last.1.rpy.z).abs() < 1e-6);
    let _ = std::fs::remove_dir_all(&dir);
}
