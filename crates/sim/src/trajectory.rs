//! Trajectories: motion segments → exact truth and ideal IMU output.
//!
//! Motion model (the same as gnss-ins-sim's "body velocity + Euler rates"):
//! the state is geodetic position (lat, lon, h), Euler angles `rpy` (ZYX,
//! body FRD w.r.t. NED) and the velocity resolved in the body frame `v_b`
//! (a car drives with `v_b = (speed, 0, 0)`). Each segment compiles into
//! phases with constant Euler-angle rates and constant body acceleration
//! `v̇_b` (plus an optional sinusoid on the angles), so within a phase `rpy(τ)`
//! and `v_b(τ)` are known in closed form. Position is integrated with RK4 at
//! the internal step; the ideal IMU is the exact kinematics
//! (Groves 2nd ed. eq. 5.53 solved for f^b, eq. 2.58 for ω):
//!
//! ```text
//! v_n   = C_bn v_b,          a_n = C_bn (v̇_b + ω_nb^b × v_b)
//! f_b   = C_nb (a_n + (2ω_ie^n + ω_en^n) × v_n − g^n)
//! ω_ib^b = ω_nb^b + C_nb (ω_ie^n + ω_en^n)
//! ```
//!
//! Increments are integrals of these rates over each IMU interval by
//! composite Simpson at the internal step (phase boundaries lie on the
//! internal grid, so every Simpson panel sees smooth motion): the error is
//! O(h⁴), far below any sensor noise. g^n is `earth::gravity_n(lat, h)`.

use crate::rot;
use crate::SimError;

use navfuse_core::earth;
use navfuse_core::{ImuSample, Vec3};

mod segment;
mod walk;
use segment::seg_name;
pub use segment::{Segment, Start};
pub use walk::{strides as walk_strides, Gait};

const DEG: f64 = core::f64::consts::PI / 180.0;

/// A compiled phase: constant Euler rates and acceleration plus optional
/// sinusoids, lasting `steps` internal steps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Phase {
    pub steps: u64,
    /// Euler-angle rates [rad/s].
    pub rpy_rate: Vec3,
    /// Acceleration [m/s²]: body-frame v̇_b, or NED a_n when `ned` is set.
    pub acc: Vec3,
    /// `acc` is a_n (velocity held in NED, independent of attitude) instead of v̇_b.
    pub ned: bool,
    /// Sinusoid amplitude on (roll, pitch, yaw) [rad] and angular frequency [rad/s].
    pub osc: Option<(Vec3, f64)>,
    /// Step-periodic walking motion (body-frame phases only).
    pub gait: Option<Gait>,
}

impl Phase {
    /// A body-frame phase with constant rates and v̇_b, no sinusoids.
    pub fn body(steps: u64, rpy_rate: Vec3, acc_b: Vec3) -> Self {
        Phase {
            steps,
            rpy_rate,
            acc: acc_b,
            ned: false,
            osc: None,
            gait: None,
        }
    }

    /// Kinematics `tau` seconds into the phase that starts at `rpy0`, `vb0`
    /// (every sinusoid is zero at τ = 0, so the start state is continuous).
    fn eval(&self, rpy0: &Vec3, vb0: &Vec3, tau: f64) -> Kin {
        let mut rpy = rpy0 + self.rpy_rate * tau;
        let mut rpy_dot = self.rpy_rate;
        if let Some((amp, w)) = self.osc {
            let (s, c) = (w * tau).sin_cos();
            rpy += amp * s;
            rpy_dot += amp * (w * c);
        }
        let (mut dv, mut dv_dot) = (Vec3::zeros(), Vec3::zeros());
        if let Some(g) = &self.gait {
            g.add(tau, &mut rpy, &mut rpy_dot, &mut dv, &mut dv_dot);
        }
        let c_bn = rot::dcm_from_euler(&rpy);
        let w_nb_b = rot::omega_nb_b_from_euler_rates(&rpy, &rpy_dot);
        if self.ned {
            // v_n = v_n0 + a_n τ; the body velocity follows from the attitude.
            let v_n = rot::dcm_from_euler(rpy0) * vb0 + self.acc * tau;
            Kin {
                rpy,
                c_bn,
                w_nb_b,
                v_b: c_bn.transpose() * v_n,
                v_n,
                a_n: self.acc,
            }
        } else {
            // Groves eq. 5.53 rearranged: a_n = C_bn (v̇_b + ω_nb^b × v_b).
            let v_b = vb0 + self.acc * tau + dv;
            let v_b_dot = self.acc + dv_dot;
            Kin {
                rpy,
                c_bn,
                w_nb_b,
                v_b,
                v_n: c_bn * v_b,
                a_n: c_bn * (v_b_dot + w_nb_b.cross(&v_b)),
            }
        }
    }
}

/// Kinematics at one instant: attitude, body rate, velocity and acceleration.
#[derive(Clone, Copy, Debug)]
struct Kin {
    rpy: Vec3,
    c_bn: navfuse_core::Mat3,
    w_nb_b: Vec3,
    v_b: Vec3,
    v_n: Vec3,
    a_n: Vec3,
}

/// Compiler state: attitude and body velocity at the end of the phases so far.
struct Compiler {
    h: f64,
    rpy: Vec3,
    v_b: Vec3,
    phases: Vec<Phase>,
}

impl Compiler {
    fn steps(&self, dur: f64, what: &str) -> Result<u64, SimError> {
        if !dur.is_finite() || dur < 0.0 {
            return Err(SimError::Scenario(format!(
                "{what}: duration {dur} s is not ≥ 0"
            )));
        }
        Ok((dur / self.h).round() as u64)
    }
    /// Push a phase reaching `d_rpy`, `d_v` exactly in `steps` (rates from the rounded duration).
    fn push_delta(&mut self, steps: u64, d_rpy: Vec3, d_v: Vec3) {
        if steps == 0 {
            return;
        }
        let t = steps as f64 * self.h;
        self.push(Phase::body(steps, d_rpy / t, d_v / t));
    }
    fn push(&mut self, p: Phase) {
        if p.steps == 0 {
            return;
        }
        let t = p.steps as f64 * self.h;
        let k = p.eval(&self.rpy, &self.v_b, t);
        self.rpy = k.rpy;
        self.v_b = k.v_b;
        self.phases.push(p);
    }
    fn speed(&self) -> f64 {
        self.v_b.x
    }
    fn change_speed(&mut self, target: f64, accel: f64, what: &str) -> Result<(), SimError> {
        if accel.is_nan() || accel <= 0.0 {
            return Err(SimError::Scenario(format!(
                "{what}: acceleration must be > 0"
            )));
        }
        let dv = target - self.speed();
        let steps = self.steps(dv.abs() / accel, what)?;
        if steps == 0 && dv.abs() > 0.0 {
            self.push_delta(1, Vec3::zeros(), Vec3::new(dv, 0.0, 0.0));
        } else {
            self.push_delta(steps, Vec3::zeros(), Vec3::new(dv, 0.0, 0.0));
        }
        Ok(())
    }
    fn cruise_distance(&mut self, d: f64, what: &str) -> Result<(), SimError> {
        let v = self.v_b.norm();
        if v < 1e-6 {
            return Err(SimError::Scenario(format!(
                "{what}: a distance needs a moving vehicle (speed is 0)"
            )));
        }
        let s = self.steps(d / v, what)?;
        self.push_delta(s, Vec3::zeros(), Vec3::zeros());
        Ok(())
    }
    fn turn(&mut self, rate: f64, angle: f64, what: &str) -> Result<(), SimError> {
        if rate == 0.0 {
            return Err(SimError::Scenario(format!("{what}: turn rate is 0")));
        }
        let s = self.steps((angle / rate).abs(), what)?;
        let signed = angle.abs() * rate.signum();
        self.push_delta(s.max(1), Vec3::new(0.0, 0.0, signed), Vec3::zeros());
        Ok(())
    }

    fn segment(&mut self, i: usize, seg: &Segment) -> Result<(), SimError> {
        let what = format!("segment {} ({})", i + 1, seg_name(seg));
        let what = what.as_str();
        match *seg {
            Segment::Hold { duration_s } => {
                let s = self.steps(duration_s, what)?;
                self.push_delta(s, Vec3::zeros(), Vec3::zeros());
            }
            Segment::Accelerate {
                speed_mps,
                speed_kmh,
                accel,
            } => {
                let v = match (speed_mps, speed_kmh) {
                    (Some(v), None) => v,
                    (None, Some(k)) => k / 3.6,
                    _ => {
                        return Err(SimError::Scenario(format!(
                            "{what}: give exactly one of speed_mps, speed_kmh"
                        )))
                    }
                };
                self.change_speed(v, accel, what)?;
            }
            Segment::Stop { decel } => self.change_speed(0.0, decel, what)?,
            Segment::Cruise {
                duration_s,
                distance_m,
            } => match (duration_s, distance_m) {
                (Some(t), None) => {
                    let s = self.steps(t, what)?;
                    self.push_delta(s, Vec3::zeros(), Vec3::zeros());
                }
                (None, Some(d)) => self.cruise_distance(d, what)?,
                _ => {
                    return Err(SimError::Scenario(format!(
                        "{what}: give exactly one of duration_s, distance_m"
                    )))
                }
            },
            Segment::Turn {
                rate_deg_s,
                angle_deg,
                duration_s,
            } => match (angle_deg, duration_s) {
                (Some(a), None) => self.turn(rate_deg_s * DEG, a * DEG, what)?,
                (None, Some(t)) => {
                    let s = self.steps(t, what)?;
                    self.push(Phase::body(
                        s,
                        Vec3::new(0.0, 0.0, rate_deg_s * DEG),
                        Vec3::zeros(),
                    ));
                }
                _ => {
                    return Err(SimError::Scenario(format!(
                        "{what}: give exactly one of angle_deg, duration_s"
                    )))
                }
            },
            Segment::Uturn { rate_deg_s } => self.turn(rate_deg_s * DEG, 180.0 * DEG, what)?,
            Segment::Grade {
                grade_pct,
                transition_s,
            } => {
                // Pitch up (nose up = positive pitch) to climb: θ = atan(grade).
                let target = (grade_pct / 100.0).atan();
                let s = self.steps(transition_s, what)?.max(1);
                self.push_delta(s, Vec3::new(0.0, target - self.rpy.y, 0.0), Vec3::zeros());
            }
            Segment::Oscillate {
                amplitude_deg,
                omega_rad_s,
                duration_s,
            } => {
                let s = self.steps(duration_s, what)?;
                self.push(Phase {
                    osc: Some((Vec3::from(amplitude_deg) * DEG, omega_rad_s)),
                    ..Phase::body(s, Vec3::zeros(), Vec3::zeros())
                });
            }
            Segment::Rates {
                rpy_rate_deg_s,
                accel_b,
                duration_s,
            } => {
                let s = self.steps(duration_s, what)?;
                self.push(Phase::body(
                    s,
                    Vec3::from(rpy_rate_deg_s) * DEG,
                    Vec3::from(accel_b),
                ));
            }
            Segment::RatesNed {
                rpy_rate_deg_s,
                accel_n,
                duration_s,
            } => {
                let s = self.steps(duration_s, what)?;
                self.push(Phase {
                    ned: true,
                    ..Phase::body(s, Vec3::from(rpy_rate_deg_s) * DEG, Vec3::from(accel_n))
                });
            }
            Segment::Walk { .. } => self.walk(seg, what)?,
            Segment::Target {
                rpy_deg,
                v_b,
                rpy_relative,
                v_relative,
                duration_s,
                max_rate_deg_s,
                max_accel,
            } => {
                let total = self.steps(duration_s, what)?;
                let rpy_t = Vec3::from(rpy_deg) * DEG;
                let d_rpy = if rpy_relative {
                    rpy_t
                } else {
                    rpy_t - self.rpy
                };
                let v_t = Vec3::from(v_b);
                let d_v = if v_relative { v_t } else { v_t - self.v_b };
                if !(max_rate_deg_s > 0.0 && max_accel > 0.0) {
                    return Err(SimError::Scenario(format!(
                        "{what}: max_rate_deg_s and max_accel must be > 0"
                    )));
                }
                let t_need = (d_rpy.amax() / (max_rate_deg_s * DEG)).max(d_v.amax() / max_accel);
                let s = self.steps(t_need, what)?.min(total);
                if s == 0 && (d_rpy.amax() > 0.0 || d_v.amax() > 0.0) {
                    // The target is reached in one internal step.
                    self.push_delta(1, d_rpy, d_v);
                    self.push_delta(total.saturating_sub(1), Vec3::zeros(), Vec3::zeros());
                } else {
                    self.push_delta(s, d_rpy, d_v);
                    self.push_delta(total - s, Vec3::zeros(), Vec3::zeros());
                }
            }
            Segment::Loop {
                speed_kmh,
                length_m,
                width_m,
                laps,
                corner_rate_deg_s,
            } => {
                let v = speed_kmh / 3.6;
                let w = corner_rate_deg_s * DEG;
                if !(v > 0.0 && w > 0.0) {
                    return Err(SimError::Scenario(format!(
                        "{what}: speed and corner rate must be > 0"
                    )));
                }
                if self.speed().abs() > 1e-9 {
                    return Err(SimError::Scenario(format!("{what}: a loop starts at rest")));
                }
                let r = v / w; // corner radius
                let (acc, d_acc) = (1.0, v * v / 2.0);
                let (sl, sw) = (length_m - 2.0 * r, width_m - 2.0 * r);
                if sl < d_acc || sw < 0.0 {
                    return Err(SimError::Scenario(format!(
                        "{what}: sides too short for corner radius {r:.1} m and the run-up"
                    )));
                }
                self.change_speed(v, acc, what)?;
                self.cruise_distance(sl - d_acc, what)?;
                for lap in 0..laps {
                    if lap > 0 {
                        self.cruise_distance(sl, what)?;
                    }
                    for side in [sw, sl, sw] {
                        self.turn(w, 90.0 * DEG, what)?;
                        self.cruise_distance(side, what)?;
                    }
                    self.turn(w, 90.0 * DEG, what)?;
                }
                // Run up the first side again and stop on it.
                self.cruise_distance(d_acc, what)?;
                self.change_speed(0.0, acc, what)?;
            }
        }
        Ok(())
    }
}

/// Compile segments into phases on an internal grid of step `h` [s].
pub fn compile(start: &Start, segments: &[Segment], h: f64) -> Result<Vec<Phase>, SimError> {
    let mut c = Compiler {
        h,
        rpy: Vec3::from(start.rpy_deg) * DEG,
        v_b: Vec3::from(start.v_b),
        phases: Vec::new(),
    };
    for (i, s) in segments.iter().enumerate() {
        c.segment(i, s)?;
    }
    if c.phases.is_empty() {
        return Err(SimError::Scenario(
            "the scenario has no motion (0 s long)".into(),
        ));
    }
    Ok(c.phases)
}

/// Exact state at one IMU epoch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TruthEpoch {
    /// GPS time [s].
    pub t: f64,
    pub lat: f64,
    pub lon: f64,
    pub h: f64,
    /// Velocity NED [m/s].
    pub v_n: Vec3,
    /// Roll, pitch, yaw [rad], yaw wrapped to (−π, π].
    pub rpy: Vec3,
    /// Instantaneous ω_ib^b [rad/s] and specific force f^b [m/s²] (ideal rate outputs).
    pub w_ib_b: Vec3,
    pub f_b: Vec3,
}

/// Truth at the IMU epochs and the ideal IMU increments between them.
#[derive(Clone, Debug)]
pub struct Trajectory {
    /// Truth at t₀ and at the end of every IMU interval (`truth.len() = imu.len() + 1`).
    pub truth: Vec<TruthEpoch>,
    /// Ideal increments (exact integrals of ω_ib^b and f^b over each interval).
    pub imu: Vec<ImuSample>,
    pub imu_dt: f64,
}

#[derive(Clone, Copy)]
struct Geo {
    lat: f64,
    lon: f64,
    h: f64,
}

fn pos_rate(p: &Geo, v_n: &Vec3) -> Vec3 {
    earth::geodetic_rates(p.lat, p.h, v_n)
}

fn add(p: &Geo, d: &Vec3, s: f64) -> Geo {
    Geo {
        lat: p.lat + d.x * s,
        lon: p.lon + d.y * s,
        h: p.h + d.z * s,
    }
}

/// Kinematics → (v_n, ω_ib^b, f^b) at a position.
fn sensors(k: &Kin, p: &Geo) -> (Vec3, Vec3, Vec3) {
    let (c_bn, w_nb_b, v_n, a_n) = (k.c_bn, k.w_nb_b, k.v_n, k.a_n);
    let w_ie = earth::omega_ie_n(p.lat);
    let w_en = earth::omega_en_n(p.lat, p.h, &v_n);
    let g_n = earth::gravity_n(p.lat, p.h);
    let c_nb = c_bn.transpose();
    let f_b = c_nb * (a_n + (2.0 * w_ie + w_en).cross(&v_n) - g_n);
    let w_ib_b = w_nb_b + c_nb * (w_ie + w_en);
    (v_n, w_ib_b, f_b)
}

/// Generate truth and ideal IMU increments at `imu_rate_hz`, integrating with
/// `substeps` internal steps per IMU interval (must be even for Simpson panels
/// of two… here each internal step is its own Simpson panel, so any ≥ 1 works).
pub fn generate(
    start: &Start,
    segments: &[Segment],
    imu_rate_hz: f64,
    substeps: u32,
) -> Result<Trajectory, SimError> {
    if !(imu_rate_hz > 0.0 && imu_rate_hz.is_finite()) || substeps == 0 {
        return Err(SimError::Scenario(format!(
            "imu rate {imu_rate_hz} Hz / substeps {substeps} invalid"
        )));
    }
    let dt = 1.0 / imu_rate_hz;
    let h = dt / substeps as f64;
    let phases = compile(start, segments, h)?;
    let t0 = start.gps_week as f64 * 604_800.0 + start.tow_s;
    let total: u64 = phases.iter().map(|p| p.steps).sum();
    let n_imu = (total / substeps as u64) as usize;
    if n_imu == 0 {
        return Err(SimError::Scenario(
            "the scenario is shorter than one IMU interval".into(),
        ));
    }
    let mut truth = Vec::with_capacity(n_imu + 1);
    let mut imu = Vec::with_capacity(n_imu);

    let mut p = Geo {
        lat: start.lat_deg * DEG,
        lon: start.lon_deg * DEG,
        h: start.h_m,
    };
    let mut rpy0 = Vec3::from(start.rpy_deg) * DEG;
    let mut vb0 = Vec3::from(start.v_b);
    let mut k_step: u64 = 0; // internal steps done
    let mut acc_th = Vec3::zeros();
    let mut acc_dv = Vec3::zeros();
    let mut sub = 0u32;

    let epoch = |t: f64, p: &Geo, k: &Kin| {
        let (v_n, w, f) = sensors(k, p);
        TruthEpoch {
            t,
            lat: p.lat,
            lon: p.lon,
            h: p.h,
            v_n,
            rpy: Vec3::new(k.rpy.x, k.rpy.y, rot::wrap_pi(k.rpy.z)),
            w_ib_b: w,
            f_b: f,
        }
    };
    truth.push(epoch(t0, &p, &phases[0].eval(&rpy0, &vb0, 0.0)));

    'outer: for ph in &phases {
        for j in 0..ph.steps {
            let ta = j as f64 * h;
            let ka = ph.eval(&rpy0, &vb0, ta);
            let km = ph.eval(&rpy0, &vb0, ta + 0.5 * h);
            let kb = ph.eval(&rpy0, &vb0, ta + h);
            // RK4 on position with the closed-form velocity.
            let (va, vm, vb) = (ka.v_n, km.v_n, kb.v_n);
            let d1 = pos_rate(&p, &va);
            let d2 = pos_rate(&add(&p, &d1, 0.5 * h), &vm);
            let d3 = pos_rate(&add(&p, &d2, 0.5 * h), &vm);
            let d4 = pos_rate(&add(&p, &d3, h), &vb);
            let pb = add(&p, &(d1 + 2.0 * d2 + 2.0 * d3 + d4), h / 6.0);
            // Midpoint position by cubic Hermite (O(h⁴)).
            let db = pos_rate(&pb, &vb);
            let pm = Geo {
                lat: 0.5 * (p.lat + pb.lat) + h / 8.0 * (d1.x - db.x),
                lon: 0.5 * (p.lon + pb.lon) + h / 8.0 * (d1.y - db.y),
                h: 0.5 * (p.h + pb.h) + h / 8.0 * (d1.z - db.z),
            };
            let (_, wa, fa) = sensors(&ka, &p);
            let (_, wm, fm) = sensors(&km, &pm);
            let (_, wb, fb) = sensors(&kb, &pb);
            acc_th += (wa + 4.0 * wm + wb) * (h / 6.0);
            acc_dv += (fa + 4.0 * fm + fb) * (h / 6.0);
            p = pb;
            k_step += 1;
            sub += 1;
            if sub == substeps {
                let n = imu.len() + 1;
                let t = t0 + n as f64 * dt;
                imu.push(ImuSample {
                    t,
                    dt,
                    dtheta_b: acc_th,
                    dvel_b: acc_dv,
                });
                truth.push(epoch(t, &p, &kb));
                acc_th = Vec3::zeros();
                acc_dv = Vec3::zeros();
                sub = 0;
                if imu.len() == n_imu {
                    break 'outer;
                }
            }
        }
        let end = ph.eval(&rpy0, &vb0, ph.steps as f64 * h);
        rpy0 = end.rpy;
        vb0 = end.v_b;
    }
    debug_assert_eq!(k_step, n_imu as u64 * substeps as u64);
    Ok(Trajectory {
        truth,
        imu,
        imu_dt: dt,
    })
}

impl Trajectory {
    /// Truth position/velocity/attitude at any time inside the trajectory:
    /// cubic Hermite on position (with the velocity as derivative), linear on
    /// velocity, nearest epoch for attitude. Exact at IMU epochs.
    /// True antenna position and velocity, ECEF [m, m/s], at time `t` for
    /// the lever arm `lever_b` (body FRD, from the IMU [m]):
    /// `p_e + C_ne C_bn l`, `C_ne (v_n + C_bn (ω_ib × l))` (Groves 2nd ed.
    /// eqs. 2.150 and 2.158, the earth-rate term of the lever velocity
    /// neglected: < 1 mm/s for a 2 m lever).
    pub fn antenna_ecef(&self, t: f64, lever_b: &Vec3) -> (Vec3, Vec3) {
        use navfuse_core::geodesy::{c_en, geodetic_to_ecef, Geodetic};
        let s = self.at(t);
        let c_bn = navfuse_core::ins::mech::q_bn_from_rpy(&s.rpy)
            .to_rotation_matrix()
            .into_inner();
        let p = geodetic_to_ecef(&Geodetic {
            lat: s.lat,
            lon: s.lon,
            h: s.h,
        });
        let c_ne = c_en(s.lat, s.lon).transpose();
        let v_n = s.v_n + c_bn * s.w_ib_b.cross(lever_b);
        (p + c_ne * (c_bn * lever_b), c_ne * v_n)
    }

    pub fn at(&self, t: f64) -> TruthEpoch {
        let t0 = self.truth[0].t;
        let x = ((t - t0) / self.imu_dt).clamp(0.0, (self.truth.len() - 1) as f64);
        let i = (x.floor() as usize).min(self.truth.len() - 2);
        let s = x - i as f64;
        let (a, b) = (&self.truth[i], &self.truth[i + 1]);
        if s < 1e-9 {
            return *a;
        }
        if s > 1.0 - 1e-9 {
            return *b;
        }
        let da = earth::geodetic_rates(a.lat, a.h, &a.v_n) * self.imu_dt;
        let db = earth::geodetic_rates(b.lat, b.h, &b.v_n) * self.imu_dt;
        let h00 = 2.0 * s.powi(3) - 3.0 * s * s + 1.0;
        let h10 = s.powi(3) - 2.0 * s * s + s;
        let h01 = -2.0 * s.powi(3) + 3.0 * s * s;
        let h11 = s.powi(3) - s * s;
        let pa = Vec3::new(a.lat, a.lon, a.h);
        let pb = Vec3::new(b.lat, b.lon, b.h);
        let p = pa * h00 + da * h10 + pb * h01 + db * h11;
        let near = if s < 0.5 { a } else { b };
        TruthEpoch {
            t,
            lat: p.x,
            lon: p.y,
            h: p.z,
            v_n: a.v_n * (1.0 - s) + b.v_n * s,
            ..*near
        }
    }

    /// Duration [s].
    pub fn duration(&self) -> f64 {
        self.imu.len() as f64 * self.imu_dt
    }
}
