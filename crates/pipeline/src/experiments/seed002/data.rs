//! The data sets: the simulated campus loop (built-in or navfuse-sim) and
//! drive_0708 with seeded GNSS errors on its RTK truth.

use super::*;

// ---------------------------------------------------------------- simulation

/// The campus loop: (leg length [m], turn angle after it [deg, + right]).
pub(super) const LOOP_LEGS: [(f64, f64); 10] = [
    (150.0, 90.0),
    (120.0, 60.0),
    (80.0, 30.0),
    (200.0, 90.0),
    (90.0, -45.0),
    (110.0, 45.0),
    (140.0, 90.0),
    (70.0, -30.0),
    (120.0, 30.0),
    (60.0, 0.0),
];
pub(super) const SPEED_M_S: f64 = 20.0 / 3.6;
pub(super) const CORNER_PEAK_RATE: f64 = 15.0 * DEG;
pub(super) const STATIC_START_S: f64 = 10.0;
pub(super) const ACCEL_M_S2: f64 = 1.0;

/// Kinematic phases: duration and (v̇, ψ̇) as functions of phase time.
#[derive(Clone, Copy)]
pub(super) enum Phase {
    Hold(f64),
    Accel(f64, f64),
    Turn(f64),
}

impl Phase {
    pub(super) fn duration(&self) -> f64 {
        match *self {
            Phase::Hold(d) | Phase::Accel(d, _) => d,
            Phase::Turn(angle) => 2.0 * angle.abs() / CORNER_PEAK_RATE,
        }
    }
    /// (v̇, ψ̇) at phase time τ.
    pub(super) fn rates(&self, tau: f64) -> (f64, f64) {
        match *self {
            Phase::Hold(_) => (0.0, 0.0),
            Phase::Accel(_, a) => (a, 0.0),
            Phase::Turn(angle) => {
                let d = self.duration();
                let s = (std::f64::consts::PI * tau / d).sin();
                (0.0, angle.signum() * CORNER_PEAK_RATE * s * s)
            }
        }
    }
}

pub(super) fn campus_phases() -> Vec<Phase> {
    let mut ph = vec![Phase::Hold(STATIC_START_S)];
    let t_acc = SPEED_M_S / ACCEL_M_S2;
    ph.push(Phase::Accel(t_acc, ACCEL_M_S2));
    let mut first = true;
    for &(len, turn) in LOOP_LEGS.iter() {
        // The acceleration phase covers ½ v t of the first leg.
        let l = if first {
            len - 0.5 * SPEED_M_S * t_acc
        } else {
            len
        };
        first = false;
        ph.push(Phase::Hold(l / SPEED_M_S));
        if turn != 0.0 {
            ph.push(Phase::Turn(turn * DEG));
        }
    }
    ph.push(Phase::Accel(t_acc, -ACCEL_M_S2));
    ph.push(Phase::Hold(5.0));
    ph
}

/// Simulate one run of the campus loop.
pub(super) fn simulate(seed: u64, model: GnssErrModel) -> DataSet {
    let t0 = 2374.0 * 604_800.0 + 200_000.0;
    let origin = Geodetic::from_degrees(36.37, 127.36, 60.0);
    let frame = LocalFrame::new(origin);
    let mut rng = SplitMix64::new(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x0002);
    let gyro_bias = Vec3::new(rng.normal(), rng.normal(), rng.normal()) * (1.0 * DEG);
    let acc_bias = Vec3::new(rng.normal(), rng.normal(), rng.normal()) * (50e-3 / 3.0 * G);
    let gyro_sd = 0.8 * DEG * 0.01; // Δθ σ per 100 Hz sample
    let acc_sd = 9e-3 * G * 0.01; // Δv σ per sample
    let mut gnss = GnssErrGen::new(model, seed ^ 0xA5A5_0002);

    let phases = campus_phases();
    let (imu_dt, sub) = (0.01, 10usize);
    let h = imu_dt / sub as f64;
    let gnss_every = (1.0 / model.rate_hz / imu_dt).round() as usize;
    let (mut v, mut psi, mut n, mut e) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut events = Vec::new();
    let mut truth = Vec::new();
    let mut corners = Vec::new();
    let mut t_rel = 0.0;
    let mut k_imu = 0usize;
    let mut t_last_fix = f64::NAN;
    for ph in &phases {
        let dur = ph.duration();
        let steps = (dur / imu_dt).round() as usize;
        if let Phase::Turn(..) = ph {
            corners.push((t0 + t_rel, t0 + t_rel + steps as f64 * imu_dt));
        }
        for s in 0..steps {
            let mut dth = Vec3::zeros();
            let mut dv = Vec3::zeros();
            for j in 0..sub {
                let tau = (s * sub + j) as f64 * h;
                let (a0, r0) = ph.rates(tau);
                let (am, rm) = ph.rates(tau + 0.5 * h);
                let (a1, r1) = ph.rates(tau + h);
                // Simpson for v and ψ; midpoint state for the position.
                let dvs = h / 6.0 * (a0 + 4.0 * am + a1);
                let dps = h / 6.0 * (r0 + 4.0 * rm + r1);
                let (vm, pm) = (
                    v + 0.5 * h * (a0 + am) * 0.5,
                    psi + 0.5 * h * (r0 + rm) * 0.5,
                );
                n += h * vm * pm.cos();
                e += h * vm * pm.sin();
                // Body FRD, level, no sideslip: ω = (0,0,ψ̇), f = (v̇, vψ̇, −g).
                dth.z += dps;
                dv += Vec3::new(dvs, h * vm * rm, -G * h);
                v += dvs;
                psi += dps;
            }
            k_imu += 1;
            let t = t0 + k_imu as f64 * imu_dt;
            let noise =
                |r: &mut SplitMix64, sd: f64| Vec3::new(r.normal(), r.normal(), r.normal()) * sd;
            events.push(Event::Imu(ImuSample {
                t,
                dt: imu_dt,
                dtheta_b: dth + gyro_bias * imu_dt + noise(&mut rng, gyro_sd),
                dvel_b: dv + acc_bias * imu_dt + noise(&mut rng, acc_sd),
            }));
            if k_imu.is_multiple_of(gnss_every) {
                let tr = frame.geodetic_from_ned(&Vec3::new(n, e, 0.0));
                let dt = if t_last_fix.is_finite() {
                    t - t_last_fix
                } else {
                    0.25
                };
                t_last_fix = t;
                let err = gnss.next(dt);
                let z = frame.geodetic_from_ned(&Vec3::new(n + err[0], e + err[1], 0.0));
                events.push(Event::Gnss(GnssFix {
                    t,
                    lat: z.lat,
                    lon: z.lon,
                    h: z.h,
                    std_ned: Vec3::new(model.sigma_h, model.sigma_h, 1.5 * model.sigma_h),
                    ..Default::default()
                }));
                truth.push(tr);
            }
        }
        t_rel += steps as f64 * imu_dt;
    }
    DataSet {
        events,
        truth,
        corners,
    }
}

/// One run of a navfuse-sim scenario with the GNSS GM share overridden.
pub(super) fn simulate_navfuse(
    sc: &navfuse_sim::Scenario,
    seed: u64,
    gm_fraction: f64,
) -> Result<DataSet, String> {
    let mut gnss = sc.gnss_spec().map_err(|e| e.to_string())?;
    gnss.gm_fraction = gm_fraction;
    let run = navfuse_sim::simulate(sc, seed, None, Some(gnss)).map_err(|e| e.to_string())?;
    let truth: Vec<(f64, Geodetic)> = run
        .gnss
        .iter()
        .zip(run.gnss_truth.iter())
        .map(|(f, &(lat, lon, h))| (f.t, Geodetic { lat, lon, h }))
        .collect();
    if truth.len() < 10 {
        return Err(format!("scenario {}: fewer than 10 GNSS fixes", sc.name));
    }
    let corners = real_corners(&truth);
    Ok(DataSet {
        events: run.events(),
        truth: truth.into_iter().map(|(_, g)| g).collect(),
        corners,
    })
}

pub(super) fn default_scenario() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/seed002_campus_loop.toml")
}

// ---------------------------------------------------------------- real data

pub(super) struct RealInputs {
    pub(super) imu: Vec<ImuSample>,
    /// RTK truth (antenna): time and position.
    pub(super) truth: Vec<(f64, Geodetic)>,
}

pub(super) fn load_real() -> Result<RealInputs, String> {
    let dir = navfuse_io::data::data_dir().join("drive_0708/kfgins");
    let imu_p = dir.join("imu.txt");
    let nav_p = dir.join("truth.nav");
    for p in [&imu_p, &nav_p] {
        if !p.exists() {
            return Err(format!(
                "real data missing: {} (set NAVFUSE_DATA, or pass --no-real to skip the real-data table)",
                p.display()
            ));
        }
    }
    let week = 2374;
    let (r, name) = navfuse_io::open(&imu_p).map_err(|e| e.to_string())?;
    let opt = KfGinsImuOptions {
        week,
        nominal_rate_hz: Some(100.0),
        ..Default::default()
    };
    let imu = KfGinsImuReader::new(r, &name, opt)
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    let (r, name) = navfuse_io::open(&nav_p).map_err(|e| e.to_string())?;
    let truth = KfGinsNavReader::new(r, &name, week)
        .map(|s| {
            s.map(|s| {
                (
                    s.t,
                    Geodetic {
                        lat: s.lat,
                        lon: s.lon,
                        h: s.h,
                    },
                )
            })
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    if imu.is_empty() || truth.len() < 10 {
        return Err(format!("{}: too little data", dir.display()));
    }
    Ok(RealInputs { imu, truth })
}

/// Corners of the real drive from the truth course: maximal runs where the
/// course rate exceeds 8°/s at more than 2 m/s, lasting at least 1.5 s.
pub(super) fn real_corners(truth: &[(f64, Geodetic)]) -> Vec<(f64, f64)> {
    let frame = LocalFrame::new(truth[0].1);
    let p: Vec<Vec3> = truth.iter().map(|(_, g)| frame.ned(g)).collect();
    let mut course = vec![f64::NAN; p.len()];
    let mut speed = vec![0.0; p.len()];
    for i in 1..p.len() - 1 {
        let d = p[i + 1] - p[i - 1];
        let dt = truth[i + 1].0 - truth[i - 1].0;
        speed[i] = (d.x * d.x + d.y * d.y).sqrt() / dt;
        course[i] = d.y.atan2(d.x);
    }
    let mut out = Vec::new();
    let mut start: Option<f64> = None;
    for i in 2..p.len() - 2 {
        let dt = truth[i + 1].0 - truth[i - 1].0;
        let rate = navfuse_core::geodesy::wrap_pi(course[i + 1] - course[i - 1]) / dt;
        let turning = speed[i] > 2.0 && rate.abs() > 8.0 * DEG && rate.is_finite();
        match (turning, start) {
            (true, None) => start = Some(truth[i].0),
            (false, Some(t0)) => {
                if truth[i].0 - t0 >= 1.5 {
                    out.push((t0, truth[i].0));
                }
                start = None;
            }
            _ => {}
        }
    }
    out
}

pub(super) fn real_dataset(inp: &RealInputs, seed: u64, model: GnssErrModel) -> DataSet {
    let frame = LocalFrame::new(inp.truth[0].1);
    let mut gen = GnssErrGen::new(model, seed ^ 0x5EA1_0002);
    let sh = model.sigma_h;
    let mut fixes = Vec::with_capacity(inp.truth.len());
    let mut t_prev = f64::NAN;
    for (t, g) in &inp.truth {
        let dt = if t_prev.is_finite() { t - t_prev } else { 0.25 };
        t_prev = *t;
        let err = gen.next(dt);
        let z = frame.geodetic_from_ned(&(frame.ned(g) + Vec3::new(err[0], err[1], 0.0)));
        fixes.push(GnssFix {
            t: *t,
            lat: z.lat,
            lon: z.lon,
            h: z.h,
            std_ned: Vec3::new(sh, sh, 1.5 * sh),
            ..Default::default()
        });
    }
    // Merge by time; a fix at the same time as an IMU sample goes after it.
    let mut events = Vec::with_capacity(inp.imu.len() + fixes.len());
    let mut j = 0;
    for s in &inp.imu {
        while j < fixes.len() && fixes[j].t < s.t {
            events.push(Event::Gnss(fixes[j]));
            j += 1;
        }
        events.push(Event::Imu(*s));
    }
    events.extend(fixes[j..].iter().map(|f| Event::Gnss(*f)));
    DataSet {
        events,
        truth: inp.truth.iter().map(|(_, g)| *g).collect(),
        corners: real_corners(&inp.truth),
    }
}
