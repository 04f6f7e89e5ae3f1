//! navfuse-sim: trajectories, ideal and erroneous sensors, deterministic from a seed.
//!
//! Pipeline: [`Scenario`] (TOML or gnss-ins-sim CSV) → [`trajectory::generate`]
//! (exact truth + ideal IMU increments) → [`imu_model::ImuCorrupter`] and the
//! GNSS error model → [`SimRun`], written by [`output`]. Every random number
//! comes from ChaCha12 seeded with the run's seed, one stream per error
//! source, so the same scenario and seed give byte-identical files.

pub mod aiding;
pub mod allan;
pub mod carrier_phase;
pub mod filter_noise;
pub mod gnss_model;
pub mod imu_model;
pub mod motion_csv;
pub mod multi_gnss;
pub mod output;
pub mod platform;
pub mod raw_gnss;
pub mod rot;
pub mod rtk_car;
pub mod rtk_scene;
pub mod scenario;
pub mod trajectory;
pub mod ubx_out;

pub use scenario::Scenario;

use gnss_model::GnssSpec;
use imu_model::{ImuCorrupter, ImuSpec};
use navfuse_core::{earth, Event, GnssFix, ImuSample, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha12Rng;
use rand_distr::StandardNormal;
use trajectory::Trajectory;

/// Errors of the simulator: bad scenario, unreadable input, failed write.
#[derive(Debug, Clone, PartialEq)]
pub enum SimError {
    Scenario(String),
    Parse(String),
    Io(String),
}

impl core::fmt::Display for SimError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SimError::Scenario(m) => write!(f, "scenario: {m}"),
            SimError::Parse(m) => write!(f, "{m}"),
            SimError::Io(m) => write!(f, "{m}"),
        }
    }
}

impl std::error::Error for SimError {}

/// ChaCha12 stream ids, one per error source.
const STREAM_IMU_CONST: u64 = 1;
const STREAM_IMU_NOISE: u64 = 2;
const STREAM_GNSS: u64 = 3;

fn rng(seed: u64, stream: u64) -> ChaCha12Rng {
    let mut r = ChaCha12Rng::seed_from_u64(seed);
    r.set_stream(stream);
    r
}

/// One simulated run: truth, ideal and measured IMU, GNSS fixes.
#[derive(Clone, Debug)]
pub struct SimRun {
    pub scenario: Scenario,
    pub seed: u64,
    pub imu_spec: ImuSpec,
    pub gnss_spec: GnssSpec,
    pub traj: Trajectory,
    /// Measured IMU increments (errors applied), same epochs as `traj.imu`.
    pub imu: Vec<ImuSample>,
    /// GNSS fixes at the antenna (errors applied, outages removed).
    pub gnss: Vec<GnssFix>,
    /// Truth antenna position (lat, lon, h) for each fix (for error statistics).
    pub gnss_truth: Vec<(f64, f64, f64)>,
    /// Turn-on gyro [rad/s] and accel [m/s²] biases drawn for this run (sensor frame).
    pub turn_on_bias: (Vec3, Vec3),
}

impl SimRun {
    /// IMU and GNSS events merged in time order (at equal times the IMU sample first).
    pub fn events(&self) -> Vec<Event> {
        let mut ev = Vec::with_capacity(self.imu.len() + self.gnss.len());
        let mut j = 0;
        for s in &self.imu {
            while j < self.gnss.len() && self.gnss[j].t < s.t {
                ev.push(Event::Gnss(self.gnss[j]));
                j += 1;
            }
            ev.push(Event::Imu(*s));
        }
        ev.extend(self.gnss[j..].iter().map(|g| Event::Gnss(*g)));
        ev
    }
}

/// Simulate a scenario with `seed`; `imu`/`gnss` override the scenario's sensor specs.
pub fn simulate(
    sc: &Scenario,
    seed: u64,
    imu: Option<ImuSpec>,
    gnss: Option<GnssSpec>,
) -> Result<SimRun, SimError> {
    let imu_spec = match imu {
        Some(s) => s,
        None => sc.imu_spec()?,
    };
    let gnss_spec = match gnss {
        Some(s) => s,
        None => sc.gnss_spec()?,
    };
    let traj = trajectory::generate(&sc.start, &sc.segment, sc.imu.rate_hz, sc.imu.substeps)?;
    simulate_sensors(sc, seed, imu_spec, gnss_spec, traj)
}

/// Sensors for an already generated trajectory (Monte Carlo reuses one trajectory).
pub fn simulate_sensors(
    sc: &Scenario,
    seed: u64,
    imu_spec: ImuSpec,
    gnss_spec: GnssSpec,
    traj: Trajectory,
) -> Result<SimRun, SimError> {
    let mut rc = rng(seed, STREAM_IMU_CONST);
    let mut rn = rng(seed, STREAM_IMU_NOISE);
    let mut corr = ImuCorrupter::new(&imu_spec, &mut rc)?;
    let turn_on_bias = (corr.gyro_draw.bias, corr.accel_draw.bias);
    let imu: Vec<ImuSample> = traj.imu.iter().map(|s| corr.apply(s, &mut rn)).collect();
    let (gnss, gnss_truth) = gnss_fixes(sc, seed, &gnss_spec, &traj)?;
    Ok(SimRun {
        scenario: sc.clone(),
        seed,
        imu_spec,
        gnss_spec,
        traj,
        imu,
        gnss,
        gnss_truth,
        turn_on_bias,
    })
}

type Fixes = (Vec<GnssFix>, Vec<(f64, f64, f64)>);

fn gnss_fixes(
    sc: &Scenario,
    seed: u64,
    spec: &GnssSpec,
    traj: &Trajectory,
) -> Result<Fixes, SimError> {
    let e = spec.errors()?;
    let sec = &sc.gnss;
    for o in &sec.outages {
        if !(o[0].is_finite() && o[1].is_finite() && o[1] >= o[0]) {
            return Err(SimError::Scenario(format!(
                "gnss.outages: [{}, {}] is not an interval",
                o[0], o[1]
            )));
        }
    }
    if !(sec.every_s.is_finite() && sec.every_s >= 0.0) {
        return Err(SimError::Scenario("gnss.every_s must be ≥ 0".into()));
    }
    let mut r = rng(seed, STREAM_GNSS);
    let t0 = traj.truth[0].t;
    let dur = traj.duration();
    let dt = 1.0 / spec.rate_hz;
    let n = (dur * spec.rate_hz + 1e-9).floor() as usize;
    let lever = Vec3::from(sec.lever_arm_m);
    let phi = if e.gm_tau > 0.0 {
        (-dt / e.gm_tau).exp()
    } else {
        0.0
    };
    let mut gm = Vec3::new(
        r.sample::<f64, _>(StandardNormal) * e.gm_ned[0],
        r.sample::<f64, _>(StandardNormal) * e.gm_ned[1],
        r.sample::<f64, _>(StandardNormal) * e.gm_ned[2],
    );
    let mut jump = Vec3::zeros();
    let mut jump_left = 0.0;
    let std_ned = Vec3::from_fn(|i, _| (e.white_ned[i].powi(2) + e.gm_ned[i].powi(2)).sqrt());
    let mut fixes = Vec::new();
    let mut truths = Vec::new();
    for j in 0..=n {
        let rel = j as f64 * dt;
        let t = t0 + rel;
        // The random processes advance at every epoch, used or not (outages
        // do not change the draws of later fixes).
        let w: [f64; 3] = [
            r.sample(StandardNormal),
            r.sample(StandardNormal),
            r.sample(StandardNormal),
        ];
        let wv: [f64; 3] = [
            r.sample(StandardNormal),
            r.sample(StandardNormal),
            r.sample(StandardNormal),
        ];
        let wg: [f64; 3] = [
            r.sample(StandardNormal),
            r.sample(StandardNormal),
            r.sample(StandardNormal),
        ];
        let u: f64 = r.gen();
        let wj: [f64; 2] = [r.sample(StandardNormal), r.sample(StandardNormal)];
        if j > 0 {
            for i in 0..3 {
                gm[i] = gm[i] * phi + wg[i] * e.gm_ned[i] * (1.0 - phi * phi).sqrt();
            }
        }
        if jump_left > 0.0 {
            jump_left -= dt;
            if jump_left <= 1e-9 {
                jump = Vec3::zeros();
            }
        } else if u < spec.jump_prob {
            jump = Vec3::new(wj[0], wj[1], 0.0) * spec.jump_sigma_m;
            jump_left = spec.jump_duration_s;
        }
        let t_meas = t - spec.latency_s;
        if t_meas < t0 - 1e-9 {
            continue;
        }
        if sec.outages.iter().any(|o| rel >= o[0] && rel < o[1]) {
            continue;
        }
        if sec.every_s > 0.0 {
            let k = rel / sec.every_s;
            if (k - k.round()).abs() > 1e-6 {
                continue;
            }
        }
        let tr = traj.at(t_meas);
        // Antenna = IMU + C_bn·l_b (NED offset → geodetic with the local radii).
        // The velocity is the IMU's: the lever-arm term C_bn(ω_nb^b × l_b) is
        // not added (≤ a few cm/s for a car and a 1 m lever arm).
        let c_bn = rot::dcm_from_euler(&tr.rpy);
        let d_n = c_bn * lever;
        let (rm, rn) = earth::radii(tr.lat);
        let ant = (
            tr.lat + d_n.x / (rm + tr.h),
            tr.lon + d_n.y / ((rn + tr.h) * tr.lat.cos()),
            tr.h - d_n.z,
        );
        let err = gm + jump + Vec3::from_fn(|i, _| w[i] * e.white_ned[i]);
        let fix = GnssFix {
            t,
            lat: ant.0 + err.x / (rm + tr.h),
            lon: ant.1 + err.y / ((rn + tr.h) * tr.lat.cos()),
            h: ant.2 - err.z,
            std_ned,
            v_n: (e.vel_sigma > 0.0).then(|| tr.v_n + Vec3::from(wv) * e.vel_sigma),
            std_v_n: (e.vel_sigma > 0.0).then(|| Vec3::repeat(e.vel_sigma)),
            quality: 1,
            num_sats: 10,
        };
        fixes.push(fix);
        truths.push(ant);
    }
    Ok((fixes, truths))
}

#[cfg(test)]
mod tests;

/// Error statistics of the simulated sensors against truth.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SensorStats {
    pub gnss_fixes: usize,
    /// Horizontal error RMS, 50 % (CEP) and max [m]; vertical RMS [m].
    pub gnss_h_rms: f64,
    pub gnss_h_cep: f64,
    pub gnss_h_max: f64,
    pub gnss_v_rms: f64,
    /// RMS of the gyro [rad/s] and accelerometer [m/s²] error (average rate
    /// over each interval, measured − ideal, all axes; sensor frame vs body
    /// frame, so a mounting rotation shows up here).
    pub gyro_err_rms: f64,
    pub accel_err_rms: f64,
    /// Mean error over the run per axis (≈ total bias) of gyro and accel.
    pub gyro_err_mean: Vec3,
    pub accel_err_mean: Vec3,
}

impl SimRun {
    /// Sensor error statistics against truth.
    pub fn sensor_stats(&self) -> SensorStats {
        let mut s = SensorStats {
            gnss_fixes: self.gnss.len(),
            ..Default::default()
        };
        let mut hs: Vec<f64> = Vec::with_capacity(self.gnss.len());
        let mut v2 = 0.0;
        for (g, t) in self.gnss.iter().zip(&self.gnss_truth) {
            let (rm, rn) = earth::radii(t.0);
            let h = ((g.lat - t.0) * (rm + t.2)).hypot((g.lon - t.1) * (rn + t.2) * t.0.cos());
            hs.push(h);
            v2 += (g.h - t.2).powi(2);
        }
        if !hs.is_empty() {
            let n = hs.len() as f64;
            s.gnss_h_rms = (hs.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
            s.gnss_h_max = hs.iter().cloned().fold(0.0, f64::max);
            s.gnss_v_rms = (v2 / n).sqrt();
            hs.sort_by(f64::total_cmp);
            s.gnss_h_cep = hs[hs.len() / 2];
        }
        let n = self.imu.len().max(1) as f64;
        let (mut g2, mut a2) = (0.0, 0.0);
        let (mut gm, mut am) = (Vec3::zeros(), Vec3::zeros());
        for (m, i) in self.imu.iter().zip(&self.traj.imu) {
            let eg = (m.dtheta_b - i.dtheta_b) / m.dt;
            let ea = (m.dvel_b - i.dvel_b) / m.dt;
            g2 += eg.norm_squared();
            a2 += ea.norm_squared();
            gm += eg;
            am += ea;
        }
        s.gyro_err_rms = (g2 / (3.0 * n)).sqrt();
        s.accel_err_rms = (a2 / (3.0 * n)).sqrt();
        s.gyro_err_mean = gm / n;
        s.accel_err_mean = am / n;
        s
    }

    /// A short human-readable summary of the run and its sensors' errors.
    pub fn summary(&self) -> String {
        let s = self.sensor_stats();
        let r2d = 180.0 / core::f64::consts::PI;
        let gyro = if self.imu_spec.gyro.is_some() {
            format!(
                "gyro error rms {:.4} °/s, mean ({:.2}, {:.2}, {:.2}) °/h",
                s.gyro_err_rms * r2d,
                s.gyro_err_mean.x * r2d * 3600.0,
                s.gyro_err_mean.y * r2d * 3600.0,
                s.gyro_err_mean.z * r2d * 3600.0
            )
        } else {
            "no gyro (accelerometer-only preset: gyro increments are written as 0)".into()
        };
        let g0 = earth::STANDARD_GRAVITY;
        format!(
            "scenario '{}': {:.1} s, {} IMU samples at {} Hz, seed {}\n\
             IMU  {} — {}; {gyro}; accel error rms {:.2} mg, mean ({:.3}, {:.3}, {:.3}) mg\n\
             GNSS {} — {} fixes at {} Hz; horizontal error rms {:.2} m, CEP {:.2} m, max {:.2} m; vertical rms {:.2} m",
            self.scenario.name,
            self.traj.duration(),
            self.imu.len(),
            self.scenario.imu.rate_hz,
            self.seed,
            self.imu_spec.name,
            self.imu_spec.source,
            s.accel_err_rms / g0 * 1e3,
            s.accel_err_mean.x / g0 * 1e3,
            s.accel_err_mean.y / g0 * 1e3,
            s.accel_err_mean.z / g0 * 1e3,
            self.gnss_spec.name,
            s.gnss_fixes,
            self.gnss_spec.rate_hz,
            s.gnss_h_rms,
            s.gnss_h_cep,
            s.gnss_h_max,
            s.gnss_v_rms,
        )
    }
}
