//! Carrier-phase attitude scenes (seed 003, `SEEDS.md §3`): a master and N
//! slave antennas fixed in the body, a vehicle attitude history, real or
//! synthetic GPS orbits, integer ambiguities per antenna–satellite, receiver
//! clocks, elevation-dependent phase noise, optional Gauss–Markov multipath
//! and cycle slips. Deterministic from a seed (ChaCha8).
//!
//! Undifferenced phase of antenna a, satellite s [m]:
//! `φ = ρ + c·δt_a + λ N + m + ε` (satellite clock, orbit and atmosphere are
//! common to the antennas and omitted). Ranges are exact ECEF distances to
//! each antenna, not the plane-wave approximation the filter assumes.
//! Attitude convention: the paper's `C_nb` (`cp_attitude::paper_dcm_nb`),
//! navigation frame ENU at the master.

#![allow(clippy::needless_range_loop)] // per-antenna/satellite index loops

use navfuse_core::estimators::cp_attitude::{paper_dcm_nb, CpEpoch, MAX_BASELINES};
use navfuse_core::gnss::dd::MAX_SATS;
use navfuse_core::gnss::{
    c_e_enu, visible_by_elevation, KeplerOrbit, Look, MU_GPS, SECONDS_PER_WEEK,
};
use navfuse_core::{Mat3, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// GPS L1 wavelength [m].
pub const LAMBDA_L1: f64 = 0.190293673;

/// Vehicle attitude history (the paper's angles roll φ, pitch θ, yaw ψ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Motion {
    /// The paper's simulation: each angle `A·sin(ω t + phase)`, ω = 0.02 rad/s.
    PaperSinusoid { amp_rad: [f64; 3], omega: f64 },
    /// A car: yaw turning with slowly varying rate, pitch/roll a few degrees.
    Car,
    /// A ship rolling ±15° (period 12 s), pitching ±3° (period 8 s), steady heading.
    ShipRolling,
    /// Constant attitude.
    Static { rpy: [f64; 3] },
}

impl Motion {
    /// (roll, pitch, yaw) [rad] at time `t` since the start.
    pub fn rpy(&self, t: f64) -> Vec3 {
        use core::f64::consts::PI;
        match *self {
            Motion::PaperSinusoid { amp_rad, omega } => Vec3::new(
                amp_rad[0] * (omega * t).sin(),
                amp_rad[1] * (omega * t + 2.0 * PI / 3.0).sin(),
                amp_rad[2] * (omega * t + 4.0 * PI / 3.0).sin(),
            ),
            Motion::Car => {
                let yaw = 0.6 * t / 60.0 + 1.2 * (t / 90.0).sin();
                Vec3::new(
                    0.03 * (t / 7.0).sin(),
                    0.04 * (t / 23.0).sin(),
                    navwrap(yaw),
                )
            }
            Motion::ShipRolling => Vec3::new(
                15f64.to_radians() * (2.0 * PI * t / 12.0).sin(),
                3f64.to_radians() * (2.0 * PI * t / 8.0).sin(),
                0.7,
            ),
            Motion::Static { rpy } => Vec3::new(rpy[0], rpy[1], rpy[2]),
        }
    }
}

impl Motion {
    /// Bounds of the attitude dynamics over the first `horizon` seconds:
    /// entry k = (max horizontal (east, north) norm, max |vertical|) of the
    /// k-th time derivative of `ω_n`, the body's angular rate in ENU (the
    /// attitude filter's state), k = 0 (rate) … 3 (snap);
    /// `ω_n(t) = rotvec(c_bn(t + h/2) c_bn(t − h/2)ᵀ)/h`, derivatives by
    /// central differences, h = 0.5 s. Each at least 1e-12 (a filter needs
    /// some process noise).
    pub fn dynamics_bounds(&self, horizon: f64) -> [[f64; 2]; 4] {
        let h = 0.5;
        let c_bn = |t: f64| {
            let r = self.rpy(t);
            paper_dcm_nb(r.x, r.y, r.z).transpose()
        };
        let w = |t: f64| {
            navfuse_core::attitude::rotvec_from_dcm(
                &(c_bn(t + 0.5 * h) * c_bn(t - 0.5 * h).transpose()),
            ) / h
        };
        let mut out = [[1e-12f64; 2]; 4];
        let mut t = 3.0 * h;
        while t <= horizon {
            let (m2, m1, w0, p1, p2) = (w(t - 2.0 * h), w(t - h), w(t), w(t + h), w(t + 2.0 * h));
            let d = [
                w0,
                (p1 - m1) / (2.0 * h),
                (p1 - 2.0 * w0 + m1) / (h * h),
                (p2 - 2.0 * p1 + 2.0 * m1 - m2) / (2.0 * h * h * h),
            ];
            for (o, v) in out.iter_mut().zip(&d) {
                o[0] = o[0].max(v.x.hypot(v.y));
                o[1] = o[1].max(v.z.abs());
            }
            t += h;
        }
        out
    }
}

fn navwrap(a: f64) -> f64 {
    use core::f64::consts::PI;
    let mut x = (a + PI) % (2.0 * PI);
    if x < 0.0 {
        x += 2.0 * PI;
    }
    x - PI
}

/// Scene configuration. Defaults: the paper's setup.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneConfig {
    /// Master antenna latitude, longitude [rad], height [m].
    pub lat: f64,
    pub lon: f64,
    pub h: f64,
    /// Start, GPS seconds since the GPS epoch.
    pub t0: f64,
    /// Epoch interval [s] and count.
    pub dt: f64,
    pub n_epochs: usize,
    /// Slave antennas in the body frame relative to the master [m].
    pub b_b: Vec<Vec3>,
    pub motion: Motion,
    /// Undifferenced phase noise σ [m] (at zenith when elevation-dependent).
    pub sigma_phase: f64,
    /// σ(el) = σ / sin(el) (capped at 10σ) instead of constant.
    pub elevation_dependent: bool,
    /// Elevation mask [rad].
    pub mask: f64,
    /// Gauss–Markov multipath: σ [m] and correlation time [s] (σ = 0 off).
    pub multipath_sigma: f64,
    pub multipath_tau: f64,
    /// Probability per antenna, satellite and epoch of a cycle slip.
    pub slip_prob: f64,
    /// Receiver clock random walk per antenna [m/√s] (one receiver per antenna).
    pub clock_rw: f64,
    pub seed: u64,
}

impl Default for SceneConfig {
    fn default() -> Self {
        SceneConfig {
            lat: 37.5665f64.to_radians(),
            lon: 126.978f64.to_radians(),
            h: 50.0,
            t0: 2035.0 * SECONDS_PER_WEEK + 319_488.0,
            dt: 10.0,
            n_epochs: 500,
            b_b: vec![Vec3::x(), Vec3::y(), Vec3::z()],
            motion: Motion::PaperSinusoid {
                amp_rad: [10f64.to_radians(), 10f64.to_radians(), 30f64.to_radians()],
                omega: 0.02,
            },
            sigma_phase: 0.002,
            elevation_dependent: false,
            mask: 10f64.to_radians(),
            multipath_sigma: 0.0,
            multipath_tau: 100.0,
            slip_prob: 0.0,
            clock_rw: 0.3,
            seed: 1,
        }
    }
}

/// One simulated epoch: the measurements and the truth.
#[derive(Clone, Debug)]
pub struct SceneEpoch {
    pub epoch: CpEpoch,
    /// True (roll, pitch, yaw) [rad], paper's convention.
    pub rpy: Vec3,
    pub c_nb: Mat3,
    /// True baselines, ENU [m].
    pub b_n: [Vec3; MAX_BASELINES],
    /// True SD integer ambiguities `N_master − N_slave` per baseline and satellite (epoch order).
    pub sd_amb: [[i64; MAX_SATS]; MAX_BASELINES],
    /// Elevations [rad] in epoch order.
    pub el: [f64; MAX_SATS],
    /// Whether a cycle slip happened at this epoch on (baseline's slave or master, satellite).
    pub slipped: [[bool; MAX_SATS]; MAX_BASELINES],
}

/// A nominal 24-satellite GPS constellation (6 planes × 4, i = 55°, circular),
/// for tests that must run without the shared almanac.
pub fn synthetic_constellation(t_oe: f64) -> Vec<KeplerOrbit> {
    let a: f64 = 26_559_700.0;
    let _ = MU_GPS;
    let mut v = Vec::new();
    for plane in 0..6 {
        for k in 0..4 {
            v.push(KeplerOrbit {
                prn: (plane * 4 + k + 1) as u8,
                t_oe,
                t_oc: t_oe,
                sqrt_a: a.sqrt(),
                e: 0.0,
                i0: 55f64.to_radians(),
                omega0: plane as f64 * 60f64.to_radians(),
                m0: (k as f64 * 90.0 + plane as f64 * 15.0).to_radians(),
                ..Default::default()
            });
        }
    }
    v
}

/// Simulate a scene over `orbits`.
pub fn simulate(cfg: &SceneConfig, orbits: &[KeplerOrbit]) -> Vec<SceneEpoch> {
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let std = Normal::new(0.0, 1.0).expect("unit normal");
    let nb = cfg.b_b.len().min(MAX_BASELINES);
    let master_e = navfuse_core::geodesy::geodetic_to_ecef(&navfuse_core::geodesy::Geodetic {
        lat: cfg.lat,
        lon: cfg.lon,
        h: cfg.h,
    });
    let c_e_n = c_e_enu(cfg.lat, cfg.lon);
    let c_n_e = c_e_n.transpose();
    // Per (antenna 0 = master, 1.. slaves) and PRN (index prn): ambiguity, multipath.
    let n_ant = nb + 1;
    let mut amb = vec![[0i64; 64]; n_ant];
    let mut amb_set = vec![[false; 64]; n_ant];
    let mut mp = vec![[0.0f64; 64]; n_ant];
    let mut clock = vec![0.0f64; n_ant];
    let mut out = Vec::with_capacity(cfg.n_epochs);
    let mut looks = [Look::default(); MAX_SATS];
    let phi_mp = (-cfg.dt / cfg.multipath_tau.max(1e-9)).exp();
    for e in 0..cfg.n_epochs {
        let t = cfg.t0 + e as f64 * cfg.dt;
        let rpy = cfg.motion.rpy(e as f64 * cfg.dt);
        let c_nb = paper_dcm_nb(rpy.x, rpy.y, rpy.z);
        let mut b_n = [Vec3::zeros(); MAX_BASELINES];
        for k in 0..nb {
            b_n[k] = c_nb.transpose() * cfg.b_b[k];
        }
        for c in clock.iter_mut() {
            *c += cfg.clock_rw * cfg.dt.sqrt() * std.sample(&mut rng);
        }
        let n = visible_by_elevation(orbits, &master_e, t, cfg.mask, &mut looks);
        let mut ep = CpEpoch {
            t,
            n_sats: n,
            n_baselines: nb,
            ..Default::default()
        };
        let mut sd_amb = [[0i64; MAX_SATS]; MAX_BASELINES];
        let mut slipped = [[false; MAX_SATS]; MAX_BASELINES];
        let mut el = [0.0; MAX_SATS];
        for (i, l) in looks[..n].iter().enumerate() {
            let prn = l.prn as usize % 64;
            ep.prn[i] = l.prn;
            ep.los_enu[i] = l.los_enu;
            el[i] = l.el;
            let sigma = if cfg.elevation_dependent {
                (cfg.sigma_phase / l.el.sin().max(0.1)).min(10.0 * cfg.sigma_phase)
            } else {
                cfg.sigma_phase
            };
            ep.sigma[i] = sigma;
            let mut phase = [0.0f64; MAX_BASELINES + 1];
            let mut slip_ant = [false; MAX_BASELINES + 1];
            for a in 0..n_ant {
                if !amb_set[a][prn] {
                    amb[a][prn] = rng.gen_range(-1_000_000..1_000_000);
                    amb_set[a][prn] = true;
                } else if cfg.slip_prob > 0.0 && rng.gen::<f64>() < cfg.slip_prob {
                    let mag: i64 = rng.gen_range(1..=5);
                    amb[a][prn] += if rng.gen::<bool>() { mag } else { -mag };
                    slip_ant[a] = true;
                }
                if cfg.multipath_sigma > 0.0 {
                    mp[a][prn] = phi_mp * mp[a][prn]
                        + (1.0 - phi_mp * phi_mp).sqrt()
                            * cfg.multipath_sigma
                            * std.sample(&mut rng);
                }
                let pos_e = if a == 0 {
                    master_e
                } else {
                    master_e + c_n_e * b_n[a - 1]
                };
                let rho = (l.sat_e - pos_e).norm();
                phase[a] = rho
                    + clock[a]
                    + LAMBDA_L1 * amb[a][prn] as f64
                    + mp[a][prn]
                    + sigma * std.sample(&mut rng);
            }
            for k in 0..nb {
                ep.sd_phase[k][i] = phase[0] - phase[k + 1];
                sd_amb[k][i] = amb[0][prn] - amb[k + 1][prn];
                slipped[k][i] = slip_ant[0] || slip_ant[k + 1];
            }
        }
        // Satellites that set lose lock: new ambiguities when they rise again.
        for a in 0..n_ant {
            for prn in 0..64 {
                if !looks[..n].iter().any(|l| l.prn as usize % 64 == prn) {
                    amb_set[a][prn] = false;
                }
            }
        }
        out.push(SceneEpoch {
            epoch: ep,
            rpy,
            c_nb,
            b_n,
            sd_amb,
            el,
            slipped,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deterministic_and_dd_consistent() {
        let cfg = SceneConfig {
            n_epochs: 20,
            ..Default::default()
        };
        let orbits = synthetic_constellation(cfg.t0);
        let a = simulate(&cfg, &orbits);
        let b = simulate(&cfg, &orbits);
        assert_eq!(a.len(), 20);
        assert_eq!(a[7].epoch, b[7].epoch);
        for s in &a {
            let ep = &s.epoch;
            assert!(ep.n_sats >= 5, "{}", ep.n_sats);
            // DD phase − λ·DD integer − ΔS·b is noise (clocks cancel): < 6σ·2.
            for k in 0..3 {
                for i in 0..ep.n_sats - 1 {
                    let dd = ep.sd_phase[k][i] - ep.sd_phase[k][i + 1];
                    let ddn = (s.sd_amb[k][i] - s.sd_amb[k][i + 1]) as f64;
                    let ds = ep.los_enu[i] - ep.los_enu[i + 1];
                    let res = dd - LAMBDA_L1 * ddn - ds.dot(&s.b_n[k]);
                    assert!(res.abs() < 0.024, "{res}");
                }
            }
            for w in s.el[..ep.n_sats].windows(2) {
                assert!(w[0] >= w[1]);
            }
        }
        let c = simulate(&SceneConfig { seed: 2, ..cfg }, &orbits);
        assert_ne!(a[3].epoch, c[3].epoch);
    }

    /// The paper's sinusoid: bounds match the analytic A ω^(k+1).
    #[test]
    fn paper_dynamics_bounds() {
        let b = SceneConfig::default().motion.dynamics_bounds(2000.0);
        let (a_h, a_v) = (10f64.to_radians() * 2f64.sqrt(), 30f64.to_radians());
        for (k, bk) in b.iter().enumerate() {
            let w = 0.02f64.powi(k as i32 + 1);
            // Vertical: ≈ the yaw derivative. Horizontal: roll/pitch plus the
            // coupling of their rates with the ±30° yaw swing (up to ~2.7×);
            // higher derivatives gather more coupling terms (≤ 30 % here).
            assert!((bk[1] / (w * a_v) - 1.0).abs() < 0.3, "{k}: {bk:?}");
            assert!(
                bk[0] > 0.7 * w * a_h && bk[0] < 3.0 * w * a_h,
                "{k}: {bk:?}"
            );
        }
        let s = (Motion::Static {
            rpy: [0.1, 0.2, 3.1],
        })
        .dynamics_bounds(100.0);
        assert_eq!(s[2], [1e-12; 2]);
    }

    #[test]
    fn motions_are_bounded() {
        for m in [
            Motion::Car,
            Motion::ShipRolling,
            SceneConfig::default().motion,
        ] {
            for k in 0..100 {
                let r = m.rpy(k as f64 * 7.0);
                assert!(r.x.abs() < 0.3 && r.y.abs() < 0.3 && r.z.abs() <= core::f64::consts::PI);
            }
        }
    }
}
