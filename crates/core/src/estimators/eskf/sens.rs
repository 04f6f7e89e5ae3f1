//! Covariance of the white-noise filter's error under a correlated GNSS
//! error model: the "true covariance of a suboptimal filter" (Gelb, *Applied
//! Optimal Estimation*, 1974, §7.2, sensitivity analysis; Maybeck,
//! *Stochastic Models, Estimation and Control* vol. 1, §6.8).
//!
//! The filter treats each fix's error as white with the reported σ. When
//! part of that error is a first-order Gauss–Markov process `b` (carrier
//! multipath, residual atmosphere), the filter's gain `K` is unchanged —
//! so are its solutions — but its own `P` understates the error: `b` is
//! not averaged away over the filter's time constant. This module carries
//! a second covariance over the true error `[δx, δa, δb]` (the filter's
//! navigation and augmented error states plus `b`) under that model:
//!
//! * propagation with the filter's `Φ` and `Q` (the INS part is modelled
//!   exactly as in the filter), `b` with `Φ_b = e^{−dt/τ}`,
//!   `Q_b = σ_b²(1 − e^{−2dt/τ})`;
//! * every update with the gain the filter applied (`K_b = 0`: `b` is not
//!   estimated) in the Joseph form, valid for any gain:
//!   `P ← P − K H P − P Hᵀ Kᵀ + K (H P Hᵀ + R) Kᵀ`, where for GNSS position
//!   (and height) `H` has the true `+I` on `δb` and `R` is the white part
//!   `σ_fix² − σ_b²` (floored at `σ_fix²/16` as [`super::aug`] does);
//!   every other measurement keeps its `H` and `R` (the R the update
//!   applied, de-weighting included: it is the filter's estimate of that
//!   measurement's actual noise).
//!
//! The reported σ ([`super::Eskf::solution`]) then comes from this
//! covariance; the filter's own `P`, its gates, constraints and every
//! decision keep using the white model, so the solutions are bit-identical
//! to the filter without it. Cost per IMU sample: one more sparse `Φ P Φᵀ`
//! (as the filter's own) and a 21×3 product; per update an `O(26² M)`
//! Joseph step. Nothing is allocated.
//!
//! **Smoothed σ.** The RTS smoother averages the fixes on both sides of an
//! epoch, which shrinks the filter's white-model covariance, including the
//! share of `σ_fix²` that is really `b`; but `b` is correlated over τ (tens
//! to hundreds of seconds, against a smoothing span of seconds at 1 Hz
//! fixes), so both passes see the same `b` and the smoother cannot average it
//! away (Gelb §7.2 applied to the smoother; the same argument as for the
//! forward filter). The smoothed σ is therefore the smoother's white-model
//! covariance plus the part of the forward error covariance driven by `b`
//! alone. That part is exact by linearity: a second sensitivity covariance,
//! the *white twin* (same gains, same white part of `R`, `b` never excited),
//! carries the error from every source but `b`, and the difference of the
//! two is `b`'s (the sources are independent). Its position part is capped
//! at `σ_b²` per axis: a smoothed position is a weighted mean of fixes on
//! both sides, so the `b` it carries has at most `b`'s variance, while the
//! forward part inside an outage also holds the velocity error `b`'s drift
//! left before the gap, which the fix after the gap removes. The twin runs
//! only when the smoother does. Carrying the forward `P − P_filter` instead (the first
//! version) under-states the smoothed σ: with half of an RTK fix's variance
//! in `b` the simulated car cells' smoothed coverage95_h was 0.86–0.91 with
//! GNSS present (`experiments::honesty_diag`, variant `smooth`).
//!
//! **Smoother's own model.** The split of `σ_fix²` into white and `b` comes
//! from the data; where the data bound `σ_b` only from below (a walker's
//! steps leave no quiet fix interval, and the trajectory between fixes then
//! raises the white estimate), the forward σ keeps the point estimate but
//! the smoother must not assume that the unresolved share averages out:
//! [`super::Eskf::start_smoother_sensitivity`] runs a second sensitivity
//! covariance and its twin under the upper end of the interval (`σ_b` up
//! to `σ_fix`), used for the smoothed σ only, still capped at the forward σ.

use super::aug::{Aug, AugConfigError, FullCov, IA_GNSS, NA, NF};
use super::{AugmentedStates, Cov, FSparse, GnssErrorStates, UpdateKind, NX};
use crate::measurements::odometer::OdometerConfig;
#[allow(unused_imports)]
use crate::prelude::*;
use crate::Vec3;
use nalgebra::SMatrix;

/// The correlated GNSS error model under which the σ is reported.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensitivityModel {
    /// Correlation time τ [s] (> 0).
    pub tau_s: f64,
    /// Gauss–Markov σ per NED axis [m] (≥ 0; part of the reported fix σ).
    pub sigma_m: Vec3,
}

/// The sensitivity covariance (see the module documentation).
#[derive(Clone, Copy, Debug)]
pub(super) struct Sens {
    /// Covariance of the true navigation error `δx`.
    pub(super) p: Cov,
    /// Its cross blocks with the augmented states and their covariance,
    /// `δb` active (the filter's τ and odometer states mirrored).
    aug: Aug,
    var_b: Vec3,
}

impl Sens {
    /// Start from the filter's covariance `p` (and `filter_aug`'s blocks),
    /// with `b` at its steady-state variance, uncorrelated with `δx`; with
    /// `excite_b` false, the white twin (module doc): `R`'s white part as
    /// under the model, `b` at zero variance and never driven.
    pub(super) fn new(
        m: SensitivityModel,
        p: &Cov,
        filter_aug: Option<&Aug>,
        odo: Option<&OdometerConfig>,
        excite_b: bool,
    ) -> Result<Self, AugConfigError> {
        let cfg = AugmentedStates {
            gnss_error: Some(GnssErrorStates {
                tau_s: m.tau_s,
                sigma_m: if excite_b { m.sigma_m } else { Vec3::zeros() },
                consider: false,
            }),
            time_offset: filter_aug.and_then(|a| a.cfg.time_offset),
            nhc_mount: filter_aug.and_then(|a| a.cfg.nhc_mount),
        };
        let mut aug = Aug::new(cfg, filter_aug.and(odo))?;
        if let Some(fa) = filter_aug {
            if fa.has_gnss_error() {
                // The filter already models the correlated error.
                return Err(AugConfigError::GnssError);
            }
            let is_b = |j: usize| (IA_GNSS..IA_GNSS + 3).contains(&j);
            for j in (0..NA).filter(|j| !is_b(*j)) {
                aug.p_xa.set_column(j, &fa.p_xa.column(j));
                for i in (0..NA).filter(|i| !is_b(*i)) {
                    aug.p_aa[(i, j)] = fa.p_aa[(i, j)];
                }
            }
        }
        Ok(Sens {
            p: *p,
            aug,
            var_b: m.sigma_m.component_mul(&m.sigma_m),
        })
    }

    /// The Gauss–Markov variance of `b` per NED axis [m²].
    pub(super) fn var_b(&self) -> Vec3 {
        self.var_b
    }

    /// Propagate the augmented blocks (`fs`: this interval's `F`, already
    /// set; the `δx` block is propagated with the filter's).
    pub(super) fn propagate_aug(&mut self, fs: &FSparse, dt: f64) {
        self.aug.propagate(fs, dt);
    }

    /// Apply the filter's update with gain `k` (over the filter's states:
    /// `NX` rows, or `NF` when `k_a` carries the augmented rows) to the
    /// true error (module documentation). `h`, `h_a`, `r`: the filter's
    /// measurement model as applied.
    pub(super) fn update<const M: usize>(
        &mut self,
        h: &SMatrix<f64, M, NX>,
        h_a: &SMatrix<f64, M, NA>,
        r: &SMatrix<f64, M, M>,
        k_x: &SMatrix<f64, NX, M>,
        k_a: Option<&SMatrix<f64, NA, M>>,
        kind: UpdateKind,
    ) {
        let mut hf = SMatrix::<f64, M, NF>::zeros();
        hf.fixed_view_mut::<M, NX>(0, 0).copy_from(h);
        hf.fixed_view_mut::<M, NA>(0, NX).copy_from(h_a);
        let mut rt = *r;
        // Rows of the measurement that see b, and which axis.
        let axis = |i: usize| match kind {
            UpdateKind::GnssPosition if M == 3 => Some(i),
            UpdateKind::Height if M == 1 => Some(2),
            _ => None,
        };
        for i in 0..M {
            if let Some(ax) = axis(i) {
                for k in 0..3 {
                    hf[(i, NX + IA_GNSS + k)] = if k == ax { 1.0 } else { 0.0 };
                }
                let ri = r[(i, i)];
                rt[(i, i)] = (ri - self.var_b[ax]).max(ri / 16.0);
            }
        }
        let mut k = SMatrix::<f64, NF, M>::zeros();
        k.fixed_view_mut::<NX, M>(0, 0).copy_from(k_x);
        if let Some(ka) = k_a {
            k.fixed_view_mut::<NA, M>(NX, 0).copy_from(ka);
        }
        for j in 0..M {
            for i in 0..3 {
                k[(NX + IA_GNSS + i, j)] = 0.0;
            }
        }
        let mut pf: FullCov = self.aug.full(&self.p);
        let hp = hf * pf;
        let s = hp * hf.transpose() + rt;
        let khp = k * hp;
        pf -= khp + khp.transpose();
        pf += k * s * k.transpose();
        pf = (pf + pf.transpose()) * 0.5;
        self.aug.split(&pf, &mut self.p);
    }
}
