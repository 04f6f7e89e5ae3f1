//! GNSS-only comparison mode of the RTK block ([`RtkConfig::gnss_only`]):
//! an RTK filter whose states are the position, a velocity and the
//! ambiguities, predicted by a constant-velocity model, not by the INS.
//!
//! **Why not the old model.** The mode used to restart the position each
//! epoch at the last posterior with σ 30 m (RTKLIB kinematic with
//! `pos1-dynamics = off`) after moving it onto an unweighted code-DD
//! solution, with the INS still propagating the velocity (never observed:
//! its error grew to 15 m/s in 300 s on seed 12) and the INS-predicted slip
//! test still running against a 30 m "prediction" (so it never fired). In
//! the 4-satellite window the code solution has 3 DDs for 3 unknowns, no
//! redundancy and a large DOP: on seed 12 (phone and industrial IMU alike)
//! it put the float 307 m off at the first epoch of the window (t = 420 s)
//! and 10⁵ m off three epochs later, and the phase DDs of that window,
//! exactly determined, could not gate a slip either.
//!
//! **Model** (RTKLIB kinematic with `pos1-dynamics = on`, `udpos`, but with
//! white acceleration instead of RTKLIB's random-walk acceleration state;
//! Brown & Hwang, *Introduction to Random Signals and Applied Kalman
//! Filtering*, 4th ed., §9.3, the "PV model"): per NED axis
//! `r(t+dt) = r + v dt`, `v(t+dt) = v`, with the discrete process noise
//! `Q = q [[dt³/3, dt²/2], [dt²/2, dt]]`; `q` from the vehicle's dynamics
//! ([`GNSS_ONLY_Q_H`], [`GNSS_ONLY_Q_V`]). The ambiguities are constants,
//! their covariance with the position and velocity carried by `Φ`.
//! When the predicted position σ exceeds [`RtkConfig::gnss_only_sigma`]
//! (an outage), the position restarts on the code-DD solution with that σ,
//! the velocity with that σ in m/s (RTKLIB `udpos`: "if var > VAR_POS
//! reinitialise"), provided the code solution is redundant
//! ([`Eskf::recentre_on_code`]); otherwise the prediction is kept.
//!
//! **Lost**: when no code DD of an epoch passes its gate (some tried), the
//! filter has lost itself — its position is inconsistent with every code
//! DD, so it cannot be pulled back by them: each is gated, the phase DDs
//! too (their ambiguities re-initialised), and the covariance grows only
//! by `Q` while the error may be any size (seed 19 of `experiment rtk`
//! with a perturbed scene coasted 2.7·10⁶ m off to the end of the run).
//! The next epoch then restarts position and velocity as above, the
//! velocity at 0 (RTKLIB `udpos`'s reset without Doppler), whatever the
//! σ. False-alarm rate: a consistent filter fails all of `m ≥ 1` code DDs
//! with probability ≤ that of failing any one of them, `1 −`
//! [`RtkConfig::gate_probability`] (1e-4 per epoch by default), whatever
//! their correlation; the cost of a false alarm is one restart from the
//! code solution. It is RTKLIB's reset on rejected measurements (`relpos`
//! gives no solution without a valid DD residual, and `udpos` then resets
//! at the single-point position) without waiting for the variance to
//! grow past [`RtkConfig::gnss_only_sigma`]. The restart point is computed
//! independently of the lost state ([`Eskf::recentre_on_code`] starts at
//! the base).
//!
//! **Kept out of it: the INS.** The IMU still drives the mechanisation
//! between epochs (the caller pushes it), but at each epoch the position,
//! velocity and ambiguities are restored from this model's own posterior of
//! the last epoch, and their covariance with the attitude and the sensor
//! errors is zeroed; the INS attitude only turns the lever arm. The
//! INS-predicted slip test is not run (`rtk.rs`, step 3): slips are caught
//! by the loss-of-lock flag, the dual-frequency geometry-free and
//! Melbourne–Wübbena tests ([`crate::gnss::slip`]) and the DD gates — what
//! RTKLIB has without an INS.

use super::*;

/// Horizontal white-acceleration PSD of the constant-velocity model
/// [m²/s³]: a car's horizontal acceleration in ordinary driving stays
/// within ~3 m/s² (0.3 g: firm braking, a brisk turn), taken as the σ of
/// the velocity change over one 1 s epoch, so `q = (3 m/s²)² · 1 s`.
/// Per 1 s prediction that is a position σ of 1.7 m and a velocity σ of
/// 3 m/s: generous for a car, so the model does not pretend to know more
/// than the dynamics allow.
pub const GNSS_ONLY_Q_H: f64 = 9.0;
/// Vertical PSD [m²/s³]: road grade changes and suspension, σ 1 m/s² over
/// one second (a third of the horizontal; RTKLIB's default vertical
/// acceleration noise is likewise a fraction of the horizontal one).
pub const GNSS_ONLY_Q_V: f64 = 1.0;

/// This model's posterior at its last epoch (filter time, IMU position,
/// velocity, their 6×6 covariance and cross-covariance with the block, the
/// block's state and covariance).
#[derive(Clone, Copy, Debug)]
pub(in crate::estimators::eskf) struct CvPosterior {
    t: f64,
    lat: f64,
    lon: f64,
    h: f64,
    v_n: Vec3,
    p6: SMatrix<f64, 6, 6>,
    p6k: SMatrix<f64, 6, NK>,
    x: SVector<f64, NK>,
    p_aa: SMatrix<f64, NK, NK>,
}

/// The INS attitude rows of `P` set aside during a GNSS-only update.
pub(in crate::estimators::eskf) type AttRows = SMatrix<f64, 3, NX>;

const _: () = assert!(I_VEL == I_POS + 3, "position and velocity adjacent");

impl Eskf {
    /// Before a GNSS-only epoch: the constant-velocity prediction from the
    /// last posterior (module documentation); at the first epoch the code
    /// solution with σ [`RtkConfig::gnss_only_sigma`]. The attitude's rows
    /// of `P` are set aside (zeroed) until [`Eskf::gnss_only_store`]: the
    /// lever arm is turned by the INS attitude taken as exact, so the DDs
    /// do not estimate the attitude (and with it move the IMU position by
    /// lever × angle, which made the GNSS-only result depend on the IMU).
    pub(super) fn gnss_only_predict(
        &mut self,
        rover: &RawEpoch,
        base: &RawEpoch,
        base_e: &Vec3,
        cfg: &RtkConfig,
    ) {
        self.gnss_only_predict_pv(rover, base, base_e, cfg);
        let att: AttRows = self.p.fixed_rows::<3>(I_ATT).into_owned();
        for k in I_ATT..I_ATT + 3 {
            for j in 0..NX {
                self.p[(k, j)] = 0.0;
                self.p[(j, k)] = 0.0;
            }
        }
        if let Some(rt) = &mut self.rtk {
            for k in I_ATT..I_ATT + 3 {
                for j in 0..NK {
                    rt.p_xa[(k, j)] = 0.0;
                }
            }
            rt.att_aside = Some(att);
        }
    }

    fn gnss_only_predict_pv(
        &mut self,
        rover: &RawEpoch,
        base: &RawEpoch,
        base_e: &Vec3,
        cfg: &RtkConfig,
    ) {
        let Some(s) = self.rtk.as_ref().and_then(|r| r.cv) else {
            self.recentre_on_code(rover, base, base_e, cfg);
            self.rtk_forget_position(cfg.gnss_only_sigma);
            return;
        };
        let dt = (self.t - s.t).max(0.0);
        let (rm, rn) = earth::radii(s.lat);
        self.nav.lat = s.lat + s.v_n.x * dt / (rm + s.h);
        self.nav.lon = s.lon + s.v_n.y * dt / ((rn + s.h) * s.lat.cos());
        self.nav.h = s.h - s.v_n.z * dt;
        self.nav.v_n = s.v_n;
        let mut phi = SMatrix::<f64, 6, 6>::identity();
        for i in 0..3 {
            phi[(i, i + 3)] = dt;
        }
        let mut p6 = phi * s.p6 * phi.transpose();
        for i in 0..3 {
            let q = if i < 2 { GNSS_ONLY_Q_H } else { GNSS_ONLY_Q_V };
            p6[(i, i)] += q * dt * dt * dt / 3.0;
            p6[(i, i + 3)] += q * dt * dt / 2.0;
            p6[(i + 3, i)] += q * dt * dt / 2.0;
            p6[(i + 3, i + 3)] += q * dt;
        }
        let p6k = phi * s.p6k;
        for k in I_POS..I_VEL + 3 {
            for j in 0..NX {
                self.p[(k, j)] = 0.0;
                self.p[(j, k)] = 0.0;
            }
        }
        self.p.fixed_view_mut::<6, 6>(I_POS, I_POS).copy_from(&p6);
        if let Some(rt) = &mut self.rtk {
            rt.x = s.x;
            rt.p_aa = s.p_aa;
            rt.p_xa = SMatrix::zeros();
            rt.p_xa.fixed_view_mut::<6, NK>(I_POS, 0).copy_from(&p6k);
        }
        // RTKLIB `udpos`: the test is on the last posterior, before the
        // prediction (testing the prediction would restart every epoch
        // while the velocity is still at its initial σ). Lost (module
        // documentation): restart now, the velocity too.
        let var = (s.p6[(0, 0)] + s.p6[(1, 1)] + s.p6[(2, 2)]) / 3.0;
        let lost = self.rtk.as_ref().is_some_and(|r| r.lost);
        if (var > cfg.gnss_only_sigma * cfg.gnss_only_sigma || lost)
            && self.recentre_on_code(rover, base, base_e, cfg)
        {
            self.rtk_forget_position(cfg.gnss_only_sigma);
            if lost {
                self.nav.v_n = Vec3::zeros();
            }
        }
    }

    /// After a GNSS-only epoch: keep this model's posterior, give the INS
    /// its attitude rows back.
    pub(super) fn gnss_only_store(&mut self) {
        if let Some(att) = self.rtk.as_mut().and_then(|r| r.att_aside.take()) {
            for k in 0..3 {
                for j in 0..NX {
                    self.p[(I_ATT + k, j)] = att[(k, j)];
                    self.p[(j, I_ATT + k)] = att[(k, j)];
                }
            }
        }
        let t = self.t;
        let (lat, lon, h, v_n) = (self.nav.lat, self.nav.lon, self.nav.h, self.nav.v_n);
        let p6 = self.p.fixed_view::<6, 6>(I_POS, I_POS).into_owned();
        if let Some(rt) = &mut self.rtk {
            rt.cv = Some(CvPosterior {
                t,
                lat,
                lon,
                h,
                v_n,
                p6,
                p6k: rt.p_xa.fixed_view::<6, NK>(I_POS, 0).into_owned(),
                x: rt.x,
                p_aa: rt.p_aa,
            });
        }
    }
}
