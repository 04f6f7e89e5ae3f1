//! `navfuse baseline`: carrier-phase double-difference baseline between two
//! RINEX 2 observation files (base at its header position), static or
//! kinematic, float (Kalman filter) and fixed (LAMBDA + ratio test).
//!
//! Model (Teunissen & Montenbruck, *Handbook of GNSS* ch. 23; Groves §10.2):
//! states rover ECEF position and single-difference ambiguities per satellite
//! and frequency [cycles]; measurements the DDs of phase [m] and code against
//! the highest satellite, `DDφ = DDρ + λ(a_i − a_ref)`, `DDP = DDρ`, with the
//! exact DD covariance of elevation-weighted undifferenced noise
//! `σ² = a² + b²/sin²el`. Satellite positions at each receiver's transmission
//! time (from its pseudorange), earth rotation during travel. Troposphere
//! modelled at each site with its own height and elevation (Saastamoinen
//! hydrostatic zenith delay, Niell mapping, [`tropo`]; as RTKLIB's relative
//! mode). Epochs of the two files are paired within a tolerance (the GEONET
//! tags drift by ~9 ms). A loss-of-lock flag resets the satellite's ambiguity.
//! Epochs whose GDOP exceeds `max_gdop` (RTKLIB `pos2-rejgdop`, default 30)
//! or with < 4 satellites are rejected before the update and counted by
//! reason. Fixing: LAMBDA on the DD ambiguities, ratio ≥ threshold, fixed
//! position by the conditional update.

#![allow(clippy::needless_range_loop)] // per-frequency/per-satellite index loops

use nalgebra::{DMatrix, DVector};
use std::path::{Path, PathBuf};

use crate::ToolError;
use navfuse_core::gnss::{c_e_enu, tropo, KeplerOrbit, C_LIGHT, LAMBDA_L1, LAMBDA_L2, OMEGA_E_DOT};
use navfuse_core::Vec3;
use navfuse_io::rinex::{read_nav, read_obs, select_ephemeris, ObsFile};

mod process;
mod stats;
#[cfg(test)]
mod tests;

pub use process::*;
pub use stats::*;

/// Processing options.
#[derive(Clone, Copy, Debug)]
pub struct Opts {
    pub kinematic: bool,
    pub l2: bool,
    pub mask: f64,
    pub ratio_min: f64,
    pub pair_tol: f64,
    /// Phase noise a, b [m] of σ² = a² + b²/sin²el; code = `code_factor` × phase.
    pub sigma_phase: f64,
    pub code_factor: f64,
    /// Model the troposphere at both sites (Saastamoinen + Niell,
    /// [`navfuse_core::gnss::tropo`]) with relative humidity `humidity`
    /// (0: hydrostatic part only, as RTKLIB's relative mode).
    pub trop: bool,
    pub humidity: f64,
    /// Reject epochs whose rover GDOP (satellites used, clock included)
    /// exceeds this, before the filter sees them (RTKLIB `pos2-rejgdop`,
    /// default 30). Rejected epochs are counted in [`Summary::rejected`].
    pub max_gdop: f64,
}

impl Default for Opts {
    fn default() -> Self {
        Opts {
            kinematic: false,
            l2: false,
            mask: 15f64.to_radians(),
            ratio_min: 3.0,
            pair_tol: 0.02,
            sigma_phase: 0.003,
            code_factor: 100.0,
            trop: true,
            humidity: 0.0,
            max_gdop: 30.0,
        }
    }
}

/// One processed epoch.
#[derive(Clone, Debug)]
pub struct EpochOut {
    /// 1-based number among the paired epochs (solved and rejected).
    pub epoch: usize,
    pub t: f64,
    pub n_sats: usize,
    /// Baseline rover − base, ECEF [m]: float and (when the ratio passes) fixed.
    pub float_b: Vec3,
    pub fixed_b: Option<Vec3>,
    pub ratio: f64,
    /// Position and geometric dilution of precision of the rover's
    /// satellites used (GDOP includes the receiver clock).
    pub pdop: f64,
    pub gdop: f64,
    /// The accepted integer DD ambiguities (empty when not fixed).
    pub fixed_dd: Vec<FixedDd>,
    /// When fixed: the baseline the second-best integer candidate would have
    /// given (how far a wrong fix would have moved the solution).
    pub runner_up_b: Option<Vec3>,
}

/// One fixed double-difference ambiguity `N_prn − N_ref` [cycles] on
/// frequency `freq` (0: L1, 1: L2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FixedDd {
    pub freq: usize,
    pub prn: usize,
    pub ref_prn: usize,
    pub n: i64,
}

impl EpochOut {
    /// The fixed integer `N_a − N_b` on `freq`, whatever this epoch's
    /// reference satellite (`None` unless both satellites were fixed).
    pub fn fixed_between(&self, freq: usize, a: usize, b: usize) -> Option<i64> {
        let sd = |prn: usize| {
            self.fixed_dd
                .iter()
                .filter(|d| d.freq == freq)
                .find_map(|d| {
                    if d.prn == prn {
                        Some(d.n)
                    } else if d.ref_prn == prn {
                        Some(0)
                    } else {
                        None
                    }
                })
        };
        Some(sd(a)? - sd(b)?)
    }

    /// Whether every DD integer this epoch shares with `other` (same
    /// frequency and satellite pair) is equal; `None` without a shared pair.
    pub fn integers_agree(&self, other: &EpochOut) -> Option<bool> {
        let mut shared = false;
        for d in &self.fixed_dd {
            if let Some(n) = other.fixed_between(d.freq, d.prn, d.ref_prn) {
                shared = true;
                if n != d.n {
                    return Some(false);
                }
            }
        }
        shared.then_some(true)
    }
}

/// Why a paired epoch produced no solution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RejectReason {
    /// Fewer than 4 common satellites above the mask with all observables.
    FewSatellites,
    /// GDOP above [`Opts::max_gdop`].
    Gdop,
    /// The innovation covariance could not be inverted.
    Singular,
}

impl RejectReason {
    pub fn label(self) -> &'static str {
        match self {
            RejectReason::FewSatellites => "few_satellites",
            RejectReason::Gdop => "gdop",
            RejectReason::Singular => "singular",
        }
    }
}

/// A paired epoch without a solution (the filter state is left untouched).
#[derive(Clone, Debug)]
pub struct Rejected {
    /// 1-based number among the paired epochs.
    pub epoch: usize,
    pub t: f64,
    pub n_sats: usize,
    pub gdop: f64,
    pub reason: RejectReason,
}

/// Processing summary. Every paired epoch is either in `epochs` (solved,
/// float or fixed) or in `rejected` (with its reason).
#[derive(Clone, Debug, Default)]
pub struct Summary {
    pub epochs: Vec<EpochOut>,
    pub rejected: Vec<Rejected>,
    pub unpaired: usize,
    pub slips: usize,
}

impl Summary {
    /// Paired epochs: solved plus rejected.
    pub fn paired(&self) -> usize {
        self.epochs.len() + self.rejected.len()
    }
    /// Rejected epochs for `reason`.
    pub fn rejected_for(&self, reason: RejectReason) -> usize {
        self.rejected.iter().filter(|r| r.reason == reason).count()
    }
}
