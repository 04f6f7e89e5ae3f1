//! Rauch–Tung–Striebel fixed-interval smoother store (feature `alloc`).
//!
//! The forward filter pushes one [`RtsStep`] per epoch: the transition `F`
//! from the previous epoch, the predicted `(x⁻, P⁻)` and the filtered
//! `(x⁺, P⁺)` (equal to the prediction when the epoch had no measurement).
//! [`RtsStore::smooth`] then runs the backward pass (Rauch, Tung & Striebel
//! 1965; Groves 2nd ed. ch. 3, fixed-interval smoothing):
//!
//! ```text
//! G_k   = P⁺_k F_{k+1}ᵀ (P⁻_{k+1})⁻¹
//! x̂ˢ_k = x⁺_k + G_k (x̂ˢ_{k+1} − x⁻_{k+1})
//! Pˢ_k  = P⁺_k + G_k (Pˢ_{k+1} − P⁻_{k+1}) G_kᵀ
//! ```
//!
//! Memory is ~3·N² f64 per step (5.4 kB at N = 15): push at the epochs you
//! want smoothed (e.g. each GNSS fix) and pass the accumulated transition
//! `F = F_j ⋯ F_i` over the IMU steps in between, with `P⁻` the covariance
//! predicted over that interval. For an error-state filter with feedback the
//! stored `x` are the error states before reset, and `F` must be the error
//! transition of the corrected trajectory.

use alloc::vec::Vec;
use nalgebra::{Cholesky, SMatrix, SVector};

use super::symmetrize;

/// One forward-filter epoch.
#[derive(Clone, Debug, PartialEq)]
pub struct RtsStep<const N: usize> {
    /// Epoch time [s] (GPS seconds), carried through to the output.
    pub t: f64,
    /// Transition from the previous stored epoch to this one (unused for the first).
    pub f: SMatrix<f64, N, N>,
    /// Predicted state x⁻.
    pub x_pred: SVector<f64, N>,
    /// Predicted covariance P⁻.
    pub p_pred: SMatrix<f64, N, N>,
    /// Filtered state x⁺.
    pub x_filt: SVector<f64, N>,
    /// Filtered covariance P⁺.
    pub p_filt: SMatrix<f64, N, N>,
}

/// A smoothed epoch.
#[derive(Clone, Debug, PartialEq)]
pub struct Smoothed<const N: usize> {
    /// Epoch time [s].
    pub t: f64,
    /// Smoothed state x̂ˢ.
    pub x: SVector<f64, N>,
    /// Smoothed covariance Pˢ.
    pub p: SMatrix<f64, N, N>,
}

/// The backward pass could not invert a predicted covariance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RtsError {
    /// `P⁻` of step `step` (index into the store) is not positive definite
    /// (Cholesky failed) or the gain is not finite. Give states without
    /// process noise a tiny one if they must be smoothed.
    SingularPrediction {
        /// Index of the offending step.
        step: usize,
    },
}

impl core::fmt::Display for RtsError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            RtsError::SingularPrediction { step } => write!(
                f,
                "RTS smoother: predicted covariance of step {step} is singular"
            ),
        }
    }
}

/// History of a forward Kalman filter for the RTS backward pass.
#[derive(Clone, Debug, Default)]
pub struct RtsStore<const N: usize> {
    steps: Vec<RtsStep<N>>,
}

impl<const N: usize> RtsStore<N> {
    /// An empty store.
    pub fn new() -> Self {
        Self { steps: Vec::new() }
    }

    /// An empty store with room for `n` steps.
    pub fn with_capacity(n: usize) -> Self {
        Self {
            steps: Vec::with_capacity(n),
        }
    }

    /// Record one epoch; `f` is the transition from the previously pushed
    /// epoch (ignored for the first one). Without a measurement pass the
    /// prediction as the filtered values too.
    pub fn push(
        &mut self,
        t: f64,
        f: &SMatrix<f64, N, N>,
        x_pred: &SVector<f64, N>,
        p_pred: &SMatrix<f64, N, N>,
        x_filt: &SVector<f64, N>,
        p_filt: &SMatrix<f64, N, N>,
    ) {
        self.steps.push(RtsStep {
            t,
            f: *f,
            x_pred: *x_pred,
            p_pred: *p_pred,
            x_filt: *x_filt,
            p_filt: *p_filt,
        });
    }

    /// Record the initial epoch (no transition; prediction = filtered = prior).
    pub fn push_initial(&mut self, t: f64, x0: &SVector<f64, N>, p0: &SMatrix<f64, N, N>) {
        self.push(t, &SMatrix::identity(), x0, p0, x0, p0);
    }

    /// Number of stored epochs.
    pub fn len(&self) -> usize {
        self.steps.len()
    }

    /// True when nothing is stored.
    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }

    /// Forget everything (keeps the allocation).
    pub fn clear(&mut self) {
        self.steps.clear();
    }

    /// The stored forward-filter epochs.
    pub fn steps(&self) -> &[RtsStep<N>] {
        &self.steps
    }

    /// Backward RTS pass over all stored epochs, oldest first in the output.
    pub fn smooth(&self) -> Result<Vec<Smoothed<N>>, RtsError> {
        let n = self.steps.len();
        let mut out: Vec<Smoothed<N>> = Vec::with_capacity(n);
        let Some(last) = self.steps.last() else {
            return Ok(out);
        };
        // Built newest-first, reversed at the end.
        out.push(Smoothed {
            t: last.t,
            x: last.x_filt,
            p: last.p_filt,
        });
        for k in (0..n - 1).rev() {
            let cur = &self.steps[k];
            let next = &self.steps[k + 1];
            let s_next = out.last().expect("pushed above");
            // G = P⁺ Fᵀ (P⁻)⁻¹ ⇔ Gᵀ = (P⁻)⁻¹ F P⁺ (both covariances symmetric).
            let fp = next.f * cur.p_filt;
            let gt = Cholesky::new(next.p_pred)
                .ok_or(RtsError::SingularPrediction { step: k + 1 })?
                .solve(&fp);
            if !gt.iter().all(|v| v.is_finite()) {
                return Err(RtsError::SingularPrediction { step: k + 1 });
            }
            let g = gt.transpose();
            let x = cur.x_filt + g * (s_next.x - next.x_pred);
            let mut p = cur.p_filt + g * (s_next.p - next.p_pred) * gt;
            symmetrize(&mut p);
            out.push(Smoothed { t: cur.t, x, p });
        }
        out.reverse();
        Ok(out)
    }
}
