//! navfuse-core: the navigation math and the four estimators of navfuse.
//!
//! Builds `#![no_std]` when the default `std` feature is off
//! (`cargo build -p navfuse-core --no-default-features`).
//!
//! Conventions used by every public item (see `ARCHITECTURE.md`):
//! - SI units and radians inside; degrees only at the I/O edges.
//! - Navigation frame NED (north-east-down) unless a name says `enu`;
//!   body frame FRD (forward-right-down).
//! - Attitude as `c_bn` (body → navigation DCM, `v_n = c_bn · v_b`) or the
//!   equivalent quaternion `q_bn`; Euler angles are roll/pitch/yaw, ZYX.
//! - Time: GPS time as `f64` seconds.
#![cfg_attr(not(feature = "std"), no_std)]
// The only `unsafe` is the call of the AVX2-compiled ESKF covariance kernel
// after run-time feature detection (`estimators::eskf`).
#![deny(unsafe_code)]

#[cfg(feature = "alloc")]
extern crate alloc;

pub mod attitude;
pub mod earth;
pub mod estimators;
pub mod geodesy;
pub mod gnss;
pub mod ins;
pub mod kalman;
pub mod lambda;
pub mod measurements;
pub mod types;

/// Float math methods (`sin`, `sqrt`, …) for `f64` in `no_std` builds.
///
/// Start a module with `#[allow(unused_imports)] use crate::prelude::*;`:
/// with `std` the inherent methods win and the import is unused; without
/// `std` the `num_traits::Float` methods (backed by `libm`) are used.
pub mod prelude {
    pub use num_traits::Float;
}

pub use types::*;

/// Deterministic standard normal draws for unit tests (no RNG dependency
/// in core): a 64-bit LCG (Knuth's MMIX constants) and Box–Muller.
#[cfg(test)]
pub(crate) struct TestGauss(pub u64);

#[cfg(test)]
impl TestGauss {
    /// The next N(0, 1) draw.
    pub(crate) fn next(&mut self) -> f64 {
        let mut u = || {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (a, b) = (u(), u());
        (-2.0 * a.ln()).sqrt() * (core::f64::consts::TAU * b).cos()
    }
}
