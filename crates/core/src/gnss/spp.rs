//! Single-point positioning (SPP): weighted least squares position and
//! receiver clock from code pseudoranges and broadcast ephemerides, Doppler
//! velocity and clock drift, RAIM fault detection and exclusion, DOPs.
//!
//! Model of one pseudorange `P` (L1 C/A, metres), Groves 2nd ed. eq. 9.122
//! / RTKLIB manual eq. E.6.1:
//!
//! `P − c·T_GD = r + c·dt_r[sys] − c·dt^s + I + T + ε`
//!
//! - satellite at the transmission time `t_tx = t_rx − P/c − dt^s` (the
//!   pseudorange gives the transmission time in satellite time without
//!   knowing the receiver clock; RTKLIB `satposs`); `dt^s` the broadcast
//!   clock polynomial with the relativistic term `F e √a sin E_k`
//!   (IS-GPS-200 §20.3.3.3.3.1) and `T_GD` for L1 users (§20.3.3.3.3.2);
//! - `r = |r^s − r_r| + Ω̇e (x^s y_r − y^s x_r)/c`: geometric range with the
//!   earth rotation during the signal's travel (Sagnac term, Groves eq.
//!   8.41; IS-GPS-200 §20.3.3.4.3.3.2);
//! - `I`: Klobuchar ([`super::iono`]) from the navigation header, `T`:
//!   Saastamoinen ([`super::tropo`]);
//! - one receiver clock per system (`sys` 0..[`MAX_SYS`]) so that
//!   inter-system offsets are unknowns.
//! - GLONASS satellites ([`SppObs::glo`]): RK4 orbit and −τ_n + γ_n (t −
//!   t_b) clock of [`super::glonass`], no group delay, their own clock
//!   group (an inter-system bias unknown, as for Galileo and BeiDou), the
//!   receiver noise σ × [`GLO_NOISE_FACTOR`] (inter-frequency code biases
//!   not modelled).
//!
//! Weights: the variance of each pseudorange is the sum of (RTKLIB 2.4
//! manual eq. E.6.24 and `pntpos.c`, whose model this is)
//! - receiver noise and multipath `a² + b²/sin El` with a = b = 0.3 m
//!   (RTKLIB `stats-eratio1 · stats-errphase` = 100 · 0.003 m);
//! - the broadcast signal-in-space accuracy URA² (IS-GPS-200 §20.3.3.3.1.3,
//!   the broadcast index's upper bound, from the navigation record);
//! - code bias 0.3 m (P1−C1 bias left uncorrected; published P1−C1 DCBs are
//!   up to ±1 ns ≈ 0.3 m, CODE monthly DCB files);
//! - ionosphere residual 50 % of the Klobuchar correction (the model's
//!   design: it removes about half the delay, Klobuchar 1987);
//! - troposphere residual `(0.3 m / (sin El + 0.1))²` (Saastamoinen in a
//!   standard atmosphere; zenith wet delay unknown to some decimetres).
//!
//! Gauss–Newton on the linearised model (Groves eq. 9.135), ≤ 10 iterations,
//! stop when |Δx| < 0.1 mm. Validation after convergence: GDOP ≤
//! [`SppConfig::max_gdop`] and the χ² test of the weighted residuals (sum of
//! `v²/σ²` against the 99.9 % χ² quantile with n − (3 + n_sys) degrees of
//! freedom). RAIM FDE: when the test fails and a further satellite can be
//! spared (at least one degree of freedom left), the satellite with the
//! largest standardised residual `|v_i|/√(Q_v,ii)`, `Q_v = R − H N⁻¹ Hᵀ`
//! (Baarda's w-test; Groves §17.4.2) is excluded and the epoch solved and
//! tested again.
//!
//! Doppler: range rate `−λ D = e·(v^s − v_r) + Ω̇e/c (ẋ^s y_r + x^s ẏ_r −
//! ẏ^s x_r − y^s ẋ_r) + c·ḋt_r[sys] − c·ḋt^s`, the time derivative of the
//! range model above (RTKLIB `resdop` writes the Sagnac term with the
//! opposite sign, a ≈ 1 cm/s difference), with the satellite share scaled by
//! dt_tx/dt_rx = 1 − ρ̇/c (≤ 2 mm/s); solved by
//! WLS for velocity and one clock drift per system on the satellites the
//! position used.
//!
//! Nothing allocates per epoch: satellites live in fixed arrays of
//! [`MAX_SATS`]; normal equations are fixed-size `nalgebra` matrices.

#![allow(clippy::needless_range_loop)] // index loops mirror the matrix equations

#[allow(unused_imports)]
use crate::prelude::*;

use super::glonass::GlonassEph;
use super::iono::Klobuchar;
use super::orbit_gnss::{self, OrbitKind};
use super::tropo::{niell_mapping, saastamoinen_zenith};
use super::{c_e_enu, KeplerOrbit, C_LIGHT, LAMBDA_L1, OMEGA_E_DOT, SECONDS_PER_WEEK};
use crate::geodesy::ecef_to_geodetic;
use crate::{Mat3, Vec3};
use nalgebra::{SMatrix, SVector};

/// Satellites one epoch can hold (more are counted as over capacity).
pub const MAX_SATS: usize = 32;
/// Clock groups (systems) with their own receiver clock bias.
pub const MAX_SYS: usize = 4;
const NX: usize = 3 + MAX_SYS;
type MatX = SMatrix<f64, NX, NX>;
type VecX = SVector<f64, NX>;

/// χ² quantiles at 0.999 for 1..32 degrees of freedom (regularised lower
/// incomplete gamma P(k/2, x/2) = 0.999, solved by bisection; the first
/// values agree with the usual tables: 10.828, 13.816, 16.266, …).
const CHI2_999: [f64; 32] = [
    10.828, 13.816, 16.266, 18.467, 20.515, 22.458, 24.322, 26.124, 27.877, 29.588, 31.264, 32.909,
    34.528, 36.123, 37.697, 39.252, 40.790, 42.312, 43.820, 45.315, 46.797, 48.268, 49.728, 51.179,
    52.620, 54.052, 55.476, 56.892, 58.301, 59.703, 61.098, 62.487,
];

/// The 99.9 % χ² quantile for `dof` degrees of freedom (1..=32).
pub fn chi2_999(dof: usize) -> f64 {
    CHI2_999[dof.clamp(1, 32) - 1]
}

/// Upper bounds of the GPS URA index intervals N = 0..14 [m]
/// (IS-GPS-200 §20.3.3.3.1.3).
pub const URA_UPPER_M: [f64; 15] = [
    2.4, 3.4, 4.85, 6.85, 9.65, 13.65, 24.0, 48.0, 96.0, 192.0, 384.0, 768.0, 1536.0, 3072.0,
    6144.0,
];

/// Range σ [m] for a broadcast "SV accuracy" value [m] (as RINEX writes
/// it): the upper bound of the URA interval holding it (IS-GPS-200
/// §20.3.3.3.1.3; the conservative reading, as RTKLIB's `uraindex`). Index
/// 15 ("no accuracy prediction") and missing values give 6144 m.
pub fn ura_sigma_m(broadcast_m: f64) -> f64 {
    if broadcast_m.is_nan() || broadcast_m < 0.0 {
        return URA_UPPER_M[14];
    }
    URA_UPPER_M
        .iter()
        .copied()
        .find(|&b| b >= broadcast_m)
        .unwrap_or(URA_UPPER_M[14])
}

/// Nominal URA [m] for a broadcast "SV accuracy" value [m]: the value X
/// of its URA index N, `X = 2^(1 + N/2)` for N ≤ 6 and `2^(N − 2)` for
/// 6 < N ≤ 14 (IS-GPS-200 §20.3.3.3.1.3.1: "suitable for use as a
/// conservative prediction of the RMS signal-in-space range errors for
/// accuracy-related purposes"; the interval's upper bound,
/// [`ura_sigma_m`], is the integrity reading). Index 15 and missing
/// values give 6144 m, as [`ura_sigma_m`].
pub fn ura_nominal_m(broadcast_m: f64) -> f64 {
    if broadcast_m.is_nan() || broadcast_m < 0.0 {
        return URA_UPPER_M[14];
    }
    match URA_UPPER_M.iter().position(|&b| b >= broadcast_m) {
        Some(n) if n <= 6 => 2f64.powf(1.0 + n as f64 / 2.0),
        Some(n) => 2f64.powi(n as i32 - 2),
        None => URA_UPPER_M[14],
    }
}

/// One satellite's code (and optional Doppler) observation with its ephemeris.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct SppObs {
    /// Clock group: 0 GPS, 1.. other systems (each its own receiver clock).
    pub sys: u8,
    /// PRN (or slot) number, for reports.
    pub prn: u8,
    /// Pseudorange [m] (L1 C/A for GPS).
    pub pr_m: f64,
    /// Doppler [Hz], RINEX sign (positive when approaching); NaN when absent.
    pub doppler_hz: f64,
    /// Carrier wavelength of the signal [m] (Doppler, and the ionospheric
    /// delay scales as λ² from L1's; 0: L1).
    pub lambda_m: f64,
    /// Broadcast ephemeris selected for this epoch (times in GPS seconds;
    /// `tgd` the group delay of the tracked code: GPS T_GD, Galileo BGD,
    /// BeiDou TGD1).
    pub orbit: KeplerOrbit,
    /// Which system's constants evaluate `orbit`.
    pub kind: OrbitKind,
    /// Signal-in-space range accuracy (URA) [m], 1σ.
    pub ura_m: f64,
    /// A GLONASS satellite: its broadcast ephemeris (RK4 orbit and the
    /// −τ_n + γ_n (t − t_b) clock, [`super::glonass`]); `orbit` and `kind`
    /// are then not used. `lambda_m` must be the satellite's FDMA L1
    /// wavelength (channel k: 1602 MHz + k · 562.5 kHz).
    pub glo: Option<GlonassEph>,
}

/// Factor on the receiver noise σ (`a² + b²/sin El` scaled by its square)
/// of GLONASS FDMA pseudoranges: RTKLIB's `EFACT_GLO` = 1.5 (pntpos.c
/// `varerr`, `SQR(fact)·varr`). It stands for what is not modelled here:
/// the receiver's inter-frequency code biases, which differ between the
/// FDMA channels (decimetres to metres, receiver-dependent; Wanninger 2012,
/// *GPS Solutions* 16:439) and are not estimated. A heuristic, copied so
/// that `navfuse spp` and `rnx2rtkp` weigh GLONASS alike; not from a
/// datasheet.
pub const GLO_NOISE_FACTOR: f64 = 1.5;

/// Tropospheric model applied to the pseudoranges.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum TropoModel {
    /// No tropospheric correction.
    None,
    /// Saastamoinen zenith delays mapped with 1/sin El (Saastamoinen's
    /// sec z, as RTKLIB's `tropmodel`).
    #[default]
    Saastamoinen,
    /// Saastamoinen zenith delays with the Niell (1996) mapping functions.
    SaastamoinenNiell,
}

/// SPP options (see the module doc for where each number comes from).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SppConfig {
    /// Elevation mask [rad] (15°: RTKLIB's default; low satellites carry
    /// most multipath and tropospheric mis-modelling).
    pub elev_mask: f64,
    /// Apply the Klobuchar model (needs coefficients in [`Spp::new`]).
    pub iono: bool,
    pub tropo: TropoModel,
    /// Relative humidity of the standard atmosphere (0.7, RTKLIB `REL_HUMI`).
    pub rel_humidity: f64,
    /// Receiver noise terms a, b [m] of `a² + b²/sin El`.
    pub sigma_a_m: f64,
    pub sigma_b_m: f64,
    /// Uncorrected code bias [m].
    pub sigma_code_bias_m: f64,
    /// Ionosphere residual as a fraction of the Klobuchar correction.
    pub iono_residual: f64,
    /// Troposphere residual numerator [m] of `σ/(sin El + 0.1)`.
    pub sigma_tropo_m: f64,
    /// RAIM fault detection and exclusion.
    pub raim: bool,
    /// Epochs with a larger GDOP are rejected (30: RTKLIB `pos2-rejgdop`
    /// default; with σ ≈ 2.5 m per range a 75 m position σ).
    pub max_gdop: f64,
    /// Doppler noise at the zenith [m/s] (shaped by elevation like the code
    /// noise; the covariance is then scaled by the a-posteriori variance
    /// factor when it exceeds 1).
    pub sigma_doppler_mps: f64,
}

impl Default for SppConfig {
    fn default() -> Self {
        SppConfig {
            elev_mask: 15f64.to_radians(),
            iono: true,
            tropo: TropoModel::Saastamoinen,
            rel_humidity: 0.7,
            sigma_a_m: 0.3,
            sigma_b_m: 0.3,
            sigma_code_bias_m: 0.3,
            iono_residual: 0.5,
            sigma_tropo_m: 0.3,
            raim: true,
            max_gdop: 30.0,
            // Code-tracking receivers' Doppler: a few cm/s (e.g. u-blox M8
            // velocity accuracy 0.05 m/s); 0.1 m/s per satellite at zenith.
            sigma_doppler_mps: 0.1,
        }
    }
}

/// Why an epoch has no solution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SppReject {
    /// Fewer usable satellites than unknowns.
    TooFewSatellites { have: usize, need: usize },
    /// Gauss–Newton did not converge in 10 iterations.
    NoConvergence,
    /// Normal equations not positive definite (degenerate geometry).
    Singular,
    /// GDOP above [`SppConfig::max_gdop`].
    GdopTooHigh { gdop: f64 },
    /// χ² test failed and no satellite could be excluded.
    ChiSquare { chi2: f64, dof: usize },
}

impl core::fmt::Display for SppReject {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SppReject::TooFewSatellites { have, need } => {
                write!(f, "too few satellites ({have} < {need})")
            }
            SppReject::NoConvergence => write!(f, "no convergence"),
            SppReject::Singular => write!(f, "singular geometry"),
            SppReject::GdopTooHigh { gdop } => write!(f, "GDOP {gdop:.1} too high"),
            SppReject::ChiSquare { chi2, dof } => {
                write!(
                    f,
                    "chi-square {chi2:.1} > {:.1} (dof {dof})",
                    chi2_999(*dof)
                )
            }
        }
    }
}

/// Satellites of the last epoch not used, by reason.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct SkipCounts {
    /// Health word not zero.
    pub unhealthy: u32,
    /// Below the elevation mask at the solution.
    pub below_mask: u32,
    /// Pseudorange missing, not finite or outside 1e7..5e7 m.
    pub bad_range: u32,
    /// Beyond [`MAX_SATS`] or system index ≥ [`MAX_SYS`].
    pub over_capacity: u32,
    /// Excluded by RAIM.
    pub raim: u32,
}

impl SkipCounts {
    pub fn add(&mut self, o: &SkipCounts) {
        self.unhealthy += o.unhealthy;
        self.below_mask += o.below_mask;
        self.bad_range += o.bad_range;
        self.over_capacity += o.over_capacity;
        self.raim += o.raim;
    }
}

/// Dilutions of precision (unit weights, ENU).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Dop {
    pub gdop: f64,
    pub pdop: f64,
    pub hdop: f64,
    pub vdop: f64,
}

/// Doppler velocity solution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SppVelocity {
    /// Receiver velocity, ECEF [m/s].
    pub vel_e: Vec3,
    /// Receiver clock drift per system [m/s] (NaN where absent).
    pub drift_mps: [f64; MAX_SYS],
    /// Velocity covariance, ECEF [m²/s²].
    pub cov_vel_e: Mat3,
    /// Dopplers used.
    pub n_used: u8,
}

/// One epoch's solution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SppSolution {
    /// Receiver time tag [GPS s].
    pub t_rx: f64,
    /// Receiver position, ECEF [m].
    pub pos_e: Vec3,
    /// Receiver clock bias per system [m] (c·dt_r; NaN where absent).
    pub clk_m: [f64; MAX_SYS],
    /// Position covariance, ECEF [m²].
    pub cov_pos_e: Mat3,
    /// Position covariance, local ENU at the solution [m²].
    pub cov_pos_enu: Mat3,
    /// Satellites used.
    pub n_used: u8,
    /// Bit k set when input observation k was used.
    pub used_mask: u64,
    /// PRNs excluded by RAIM (first `n_excluded`) and their clock groups.
    pub excluded_prn: [u8; 4],
    pub excluded_sys: [u8; 4],
    pub n_excluded: u8,
    pub dop: Dop,
    /// Σ v²/σ² and its degrees of freedom.
    pub chi2: f64,
    pub dof: u8,
    pub iterations: u8,
    /// Doppler velocity (None without ≥ 3 + n_sys Dopplers).
    pub vel: Option<SppVelocity>,
}

/// One row of the design matrix for unknowns [x, y, z, clock per system]:
/// −(line of sight, ECEF, receiver to satellite) and 1 in the satellite's
/// system clock column (the pseudorange and Doppler models share it).
fn design_row(e_e: &Vec3, sys: usize) -> VecX {
    let mut h = VecX::zeros();
    h[0] = -e_e.x;
    h[1] = -e_e.y;
    h[2] = -e_e.z;
    h[3 + sys] = 1.0;
    h
}

/// Per-satellite working state of one epoch.
#[derive(Clone, Copy, Debug, Default)]
struct Sat {
    /// Index in the input observations.
    idx: usize,
    sys: usize,
    prn: u8,
    /// Pseudorange corrected for T_GD [m].
    p: f64,
    pos_e: Vec3,
    vel_e: Vec3,
    /// c·dt^s [m], c·ḋt^s [m/s].
    clk_m: f64,
    drift_mps: f64,
    var_eph: f64,
    doppler_rr: f64,
    /// (f_L1/f)²: the ionospheric delay of the tracked frequency relative to L1.
    iono_scale: f64,
    /// Factor on the receiver noise variance (1; GLONASS
    /// [`GLO_NOISE_FACTOR`]²).
    noise_var_fact: f64,
    /// Still a candidate (healthy, valid, not excluded by RAIM).
    active: bool,
    // Filled by `residuals`:
    used: bool,
    el: f64,
    v: f64,
    var: f64,
    e_e: Vec3,
}

/// Reusable SPP solver (all scratch space inside; no allocation per epoch).
#[derive(Clone, Debug)]
pub struct Spp {
    pub cfg: SppConfig,
    iono: Klobuchar,
    sats: [Sat; MAX_SATS],
    n: usize,
    skips: SkipCounts,
}

/// Satellite clock polynomial without relativity at satellite time `t`,
/// iterated for `t − t_oc` measured in GPS time (RTKLIB `eph2clk`).
fn clock_poly(o: &KeplerOrbit, t: f64) -> f64 {
    let mut dt = t - o.t_oc;
    for _ in 0..2 {
        dt -= o.af0 + o.af1 * dt + o.af2 * dt * dt;
    }
    o.af0 + o.af1 * dt + o.af2 * dt * dt
}

/// Geometric range with the Sagnac term and the unit vector receiver →
/// satellite, ECEF.
fn geodist(sat_e: &Vec3, rx_e: &Vec3) -> (f64, Vec3) {
    let d = sat_e - rx_e;
    let r = d.norm();
    (
        r + OMEGA_E_DOT * (sat_e.x * rx_e.y - sat_e.y * rx_e.x) / C_LIGHT,
        d / r,
    )
}

impl Spp {
    /// A solver with options `cfg` and broadcast ionosphere coefficients
    /// (`None` or all zero: no ionospheric correction is possible).
    pub fn new(cfg: SppConfig, iono: Option<Klobuchar>) -> Self {
        Spp {
            cfg,
            iono: iono.unwrap_or_default(),
            sats: [Sat::default(); MAX_SATS],
            n: 0,
            skips: SkipCounts::default(),
        }
    }

    /// Satellites not used in the last [`Spp::solve`], by reason.
    pub fn skips(&self) -> SkipCounts {
        self.skips
    }

    /// Solve one epoch observed at receiver time tag `t_rx` [GPS s].
    /// `prior_e` (e.g. the previous solution) only speeds up convergence.
    pub fn solve(
        &mut self,
        t_rx: f64,
        obs: &[SppObs],
        prior_e: Option<Vec3>,
    ) -> Result<SppSolution, SppReject> {
        self.skips = SkipCounts::default();
        self.n = 0;
        for (k, o) in obs.iter().enumerate() {
            if k >= MAX_SATS || o.sys as usize >= MAX_SYS {
                self.skips.over_capacity += 1;
                continue;
            }
            let health = o.glo.map_or(o.orbit.health, |g| g.health);
            if health != 0 {
                self.skips.unhealthy += 1;
                continue;
            }
            if !(o.pr_m.is_finite() && (1.0e7..5.0e7).contains(&o.pr_m)) {
                self.skips.bad_range += 1;
                continue;
            }
            let rr = if o.doppler_hz.is_finite() && o.lambda_m > 0.0 {
                -o.lambda_m * o.doppler_hz
            } else {
                f64::NAN
            };
            let var_eph = if o.ura_m.is_finite() {
                o.ura_m * o.ura_m
            } else {
                0.0
            };
            // Group delay ∝ 1/f² (λ²); L1 when the wavelength is not given.
            let iono_scale = if o.lambda_m > 0.0 && o.lambda_m.is_finite() {
                (o.lambda_m / LAMBDA_L1).powi(2)
            } else {
                1.0
            };
            if let Some(g) = &o.glo {
                // GLONASS: the record's state at transmission
                // (GlonassEph::sat_state; no group delay on L1).
                let st = g.sat_state(t_rx, o.pr_m);
                if !st.pos_e.x.is_finite() {
                    self.skips.bad_range += 1;
                    continue;
                }
                self.sats[self.n] = Sat {
                    idx: k,
                    sys: o.sys as usize,
                    prn: o.prn,
                    p: o.pr_m,
                    pos_e: st.pos_e,
                    vel_e: st.vel_e,
                    clk_m: st.clock_m,
                    drift_mps: st.clock_rate_mps,
                    var_eph,
                    doppler_rr: rr,
                    iono_scale,
                    noise_var_fact: GLO_NOISE_FACTOR * GLO_NOISE_FACTOR,
                    active: true,
                    ..Sat::default()
                };
                self.n += 1;
                continue;
            }
            let t_sv = t_rx - o.pr_m / C_LIGHT;
            let t_tx = t_sv - clock_poly(&o.orbit, t_sv);
            let h = 1e-2;
            let pos = |t: f64| orbit_gnss::position_ecef(&o.orbit, o.kind, t);
            let clk = |t: f64| orbit_gnss::clock_offset(&o.orbit, o.kind, t);
            let p_plus = pos(t_tx + h);
            let p_minus = pos(t_tx - h);
            self.sats[self.n] = Sat {
                idx: k,
                sys: o.sys as usize,
                prn: o.prn,
                p: o.pr_m - C_LIGHT * o.orbit.tgd,
                pos_e: pos(t_tx),
                vel_e: (p_plus - p_minus) / (2.0 * h),
                clk_m: C_LIGHT * clk(t_tx),
                drift_mps: C_LIGHT * (clk(t_tx + h) - clk(t_tx - h)) / (2.0 * h),
                var_eph,
                doppler_rr: rr,
                iono_scale,
                noise_var_fact: 1.0,
                active: true,
                ..Sat::default()
            };
            self.n += 1;
        }

        let mut x = VecX::zeros();
        if let Some(p) = prior_e.filter(|p| p.iter().all(|c| c.is_finite())) {
            x.fixed_rows_mut::<3>(0).copy_from(&p);
        }
        let mut excluded = [0u8; 4];
        let mut excluded_sys = [0u8; 4];
        let mut n_excl = 0usize;
        loop {
            let (nv, need, iters) = self.iterate(&mut x, t_rx)?;
            let (n_mat, _) = self.normal();
            let q = n_mat.cholesky().ok_or(SppReject::Singular)?.inverse();
            let dop = self.dops(&x);
            if dop.gdop.is_nan() || dop.gdop > self.cfg.max_gdop {
                return Err(SppReject::GdopTooHigh { gdop: dop.gdop });
            }
            let chi2: f64 = (0..self.n)
                .filter(|&i| self.sats[i].used)
                .map(|i| self.sats[i].v * self.sats[i].v / self.sats[i].var)
                .sum();
            let dof = nv - need;
            if dof >= 1 && chi2 > chi2_999(dof) {
                if self.cfg.raim && dof >= 2 && n_excl < excluded.len() {
                    let worst = self.worst_standardised(&q);
                    self.sats[worst].active = false;
                    excluded[n_excl] = self.sats[worst].prn;
                    excluded_sys[n_excl] = self.sats[worst].sys as u8;
                    n_excl += 1;
                    continue;
                }
                return Err(SppReject::ChiSquare { chi2, dof });
            }
            let pos = Vec3::new(x[0], x[1], x[2]);
            let g = ecef_to_geodetic(&pos);
            let c = c_e_enu(g.lat, g.lon);
            let cov_pos_e: Mat3 = q.fixed_view::<3, 3>(0, 0).into_owned();
            let mut clk_m = [f64::NAN; MAX_SYS];
            let mut present = [false; MAX_SYS];
            let mut used_mask = 0u64;
            let mut below = 0u32;
            for i in 0..self.n {
                let s = &self.sats[i];
                if s.used {
                    present[s.sys] = true;
                    used_mask |= 1u64 << s.idx;
                } else if s.active {
                    below += 1;
                }
            }
            for k in 0..MAX_SYS {
                if present[k] {
                    clk_m[k] = x[3 + k];
                }
            }
            self.skips.below_mask = below;
            self.skips.raim = n_excl as u32;
            let vel = self.velocity(&pos);
            return Ok(SppSolution {
                t_rx,
                pos_e: pos,
                clk_m,
                cov_pos_e,
                cov_pos_enu: c * cov_pos_e * c.transpose(),
                n_used: nv as u8,
                used_mask,
                excluded_prn: excluded,
                excluded_sys,
                n_excluded: n_excl as u8,
                dop,
                chi2,
                dof: dof as u8,
                iterations: iters,
                vel,
            });
        }
    }

    /// Residuals, variances and line-of-sight vectors of every active
    /// satellite at the state `x`; marks the used ones. Returns (used
    /// count, unknowns needed = 3 + systems present).
    fn residuals(&mut self, x: &VecX, t_rx: f64) -> (usize, usize) {
        let rx = Vec3::new(x[0], x[1], x[2]);
        // Away from the earth's centre the local geometry is defined
        // (the first pass from the centre uses no mask and no corrections).
        let at_earth = rx.norm() > 6.0e6;
        let g = ecef_to_geodetic(&rx);
        let c = c_e_enu(g.lat, g.lon);
        let tow = t_rx - (t_rx / SECONDS_PER_WEEK).floor() * SECONDS_PER_WEEK;
        let (zhd, zwd) = saastamoinen_zenith(g.lat, g.h, self.cfg.rel_humidity);
        let cfg = self.cfg;
        let use_iono = cfg.iono && !self.iono.is_zero();
        let mut present = [false; MAX_SYS];
        let mut nv = 0usize;
        for i in 0..self.n {
            let s = &mut self.sats[i];
            s.used = false;
            if !s.active {
                continue;
            }
            let (r, e_e) = geodist(&s.pos_e, &rx);
            let mut el = core::f64::consts::FRAC_PI_2;
            let (mut di, mut dt) = (0.0, 0.0);
            if at_earth {
                let los = c * e_e;
                el = los.z.clamp(-1.0, 1.0).asin();
                let az = los.x.atan2(los.y);
                if el < cfg.elev_mask {
                    continue;
                }
                if use_iono {
                    di = s.iono_scale * self.iono.delay_l1(g.lat, g.lon, az, el, tow);
                }
                let valid_h = (-100.0..1.0e4).contains(&g.h);
                dt = match cfg.tropo {
                    TropoModel::None => 0.0,
                    _ if !valid_h => 0.0,
                    TropoModel::Saastamoinen => (zhd + zwd) / el.sin(),
                    TropoModel::SaastamoinenNiell => {
                        let doy = super::tropo::day_of_year(t_rx);
                        let (mh, mw) = niell_mapping(el, g.lat, g.h, doy);
                        zhd * mh + zwd * mw
                    }
                };
            }
            let sin_el = el.sin().max(5f64.to_radians().sin());
            s.v = s.p - (r + x[3 + s.sys] - s.clk_m + di + dt);
            s.var = s.noise_var_fact
                * (cfg.sigma_a_m * cfg.sigma_a_m + cfg.sigma_b_m * cfg.sigma_b_m / sin_el)
                + s.var_eph
                + cfg.sigma_code_bias_m * cfg.sigma_code_bias_m
                + (cfg.iono_residual * di).powi(2)
                + if cfg.tropo == TropoModel::None {
                    0.0
                } else {
                    (cfg.sigma_tropo_m / (sin_el + 0.1)).powi(2)
                };
            s.e_e = e_e;
            s.el = el;
            s.used = true;
            present[s.sys] = true;
            nv += 1;
        }
        (nv, 3 + present.iter().filter(|&&p| p).count())
    }

    /// Normal matrix N = Hᵀ W H and right side Hᵀ W v of the used
    /// satellites (absent systems get a unit diagonal, zero right side).
    fn normal(&self) -> (MatX, VecX) {
        let mut n = MatX::zeros();
        let mut b = VecX::zeros();
        let mut present = [false; MAX_SYS];
        for i in 0..self.n {
            let s = &self.sats[i];
            if !s.used {
                continue;
            }
            present[s.sys] = true;
            let h = design_row(&s.e_e, s.sys);
            let w = 1.0 / s.var;
            n += h * h.transpose() * w;
            b += h * (w * s.v);
        }
        for k in 0..MAX_SYS {
            if !present[k] {
                n[(3 + k, 3 + k)] = 1.0;
            }
        }
        (n, b)
    }

    /// Gauss–Newton iterations; on return the residuals are those at the
    /// final state.
    fn iterate(&mut self, x: &mut VecX, t_rx: f64) -> Result<(usize, usize, u8), SppReject> {
        for it in 0..10u8 {
            let (nv, need) = self.residuals(x, t_rx);
            if nv < need {
                return Err(SppReject::TooFewSatellites { have: nv, need });
            }
            let (n, b) = self.normal();
            let dx = n.cholesky().ok_or(SppReject::Singular)?.solve(&b);
            *x += dx;
            if dx.norm() < 1e-4 {
                let (nv, need) = self.residuals(x, t_rx);
                if nv < need {
                    return Err(SppReject::TooFewSatellites { have: nv, need });
                }
                return Ok((nv, need, it + 1));
            }
        }
        Err(SppReject::NoConvergence)
    }

    /// Index of the used satellite with the largest standardised residual.
    fn worst_standardised(&self, q: &MatX) -> usize {
        let mut worst = 0usize;
        let mut w_max = -1.0;
        for i in 0..self.n {
            let s = &self.sats[i];
            if !s.used {
                continue;
            }
            let h = design_row(&s.e_e, s.sys);
            let qv = (s.var - (h.transpose() * q * h)[(0, 0)]).max(1e-12 * s.var);
            let w = s.v.abs() / qv.sqrt();
            if w > w_max {
                w_max = w;
                worst = i;
            }
        }
        worst
    }

    /// DOPs of the used satellites (unit weights), position block in ENU.
    fn dops(&self, x: &VecX) -> Dop {
        let mut n = MatX::zeros();
        let mut present = [false; MAX_SYS];
        for i in 0..self.n {
            let s = &self.sats[i];
            if !s.used {
                continue;
            }
            present[s.sys] = true;
            let h = design_row(&s.e_e, s.sys);
            n += h * h.transpose();
        }
        for k in 0..MAX_SYS {
            if !present[k] {
                n[(3 + k, 3 + k)] = 1.0;
            }
        }
        let Some(ch) = n.cholesky() else {
            return Dop {
                gdop: f64::INFINITY,
                pdop: f64::INFINITY,
                hdop: f64::INFINITY,
                vdop: f64::INFINITY,
            };
        };
        let q = ch.inverse();
        let g = ecef_to_geodetic(&Vec3::new(x[0], x[1], x[2]));
        let c = c_e_enu(g.lat, g.lon);
        let qp: Mat3 = c * q.fixed_view::<3, 3>(0, 0) * c.transpose();
        let clk: f64 = (0..MAX_SYS)
            .filter(|&k| present[k])
            .map(|k| q[(3 + k, 3 + k)])
            .sum();
        let p = qp.trace();
        Dop {
            gdop: (p + clk).sqrt(),
            pdop: p.sqrt(),
            hdop: (qp[(0, 0)] + qp[(1, 1)]).sqrt(),
            vdop: qp[(2, 2)].sqrt(),
        }
    }

    /// Doppler WLS for velocity and clock drifts on the satellites the
    /// position used (see the module doc).
    fn velocity(&self, rx: &Vec3) -> Option<SppVelocity> {
        let cfg = &self.cfg;
        let shape0 = cfg.sigma_a_m * cfg.sigma_a_m + cfg.sigma_b_m * cfg.sigma_b_m;
        let mut x = VecX::zeros();
        let mut last = None;
        for _ in 0..4 {
            let mut n = MatX::zeros();
            let mut b = VecX::zeros();
            let mut present = [false; MAX_SYS];
            let mut nv = 0usize;
            let mut vtpv = 0.0;
            for i in 0..self.n {
                let s = &self.sats[i];
                if !s.used || !s.doppler_rr.is_finite() {
                    continue;
                }
                let v_r = Vec3::new(x[0], x[1], x[2]);
                let e = s.e_e;
                // d/dt of the range model of `geodist`, Sagnac term included.
                let rate = e.dot(&(s.vel_e - v_r))
                    + OMEGA_E_DOT / C_LIGHT
                        * (s.vel_e.x * rx.y + s.pos_e.x * v_r.y
                            - s.vel_e.y * rx.x
                            - s.pos_e.y * v_r.x);
                // The transmission time moves with the range: dt_tx/dt_rx =
                // 1 − ρ̇/c, so the satellite's share is scaled by it (first
                // order, ≤ 2 mm/s; RTKLIB omits it).
                let rate = rate - e.dot(&s.vel_e) * rate / C_LIGHT;
                let v = s.doppler_rr - (rate + x[3 + s.sys] - s.drift_mps);
                let sin_el = s.el.sin().max(5f64.to_radians().sin());
                let shape = (cfg.sigma_a_m * cfg.sigma_a_m
                    + cfg.sigma_b_m * cfg.sigma_b_m / sin_el)
                    / shape0;
                let var = cfg.sigma_doppler_mps * cfg.sigma_doppler_mps * shape;
                let h = design_row(&e, s.sys);
                n += h * h.transpose() / var;
                b += h * (v / var);
                vtpv += v * v / var;
                present[s.sys] = true;
                nv += 1;
            }
            let need = 3 + present.iter().filter(|&&p| p).count();
            if nv < need {
                return None;
            }
            for k in 0..MAX_SYS {
                if !present[k] {
                    n[(3 + k, 3 + k)] = 1.0;
                }
            }
            let ch = n.cholesky()?;
            let dx = ch.solve(&b);
            x += dx;
            last = Some((ch.inverse(), present, nv, need, vtpv));
            if dx.norm() < 1e-6 {
                break;
            }
        }
        let (q, present, nv, need, vtpv) = last?;
        // A-posteriori variance factor (≥ 1): the stated Doppler noise is a
        // floor, a noisier receiver shows in its residuals.
        let dof = nv - need;
        let f = if dof > 0 {
            (vtpv / dof as f64).max(1.0)
        } else {
            1.0
        };
        let mut drift = [f64::NAN; MAX_SYS];
        for k in 0..MAX_SYS {
            if present[k] {
                drift[k] = x[3 + k];
            }
        }
        Some(SppVelocity {
            vel_e: Vec3::new(x[0], x[1], x[2]),
            drift_mps: drift,
            cov_vel_e: q.fixed_view::<3, 3>(0, 0).into_owned() * f,
            n_used: nv as u8,
        })
    }
}

/// GPS L1 wavelength, re-exported for callers building [`SppObs`].
pub const GPS_L1_WAVELENGTH: f64 = LAMBDA_L1;

#[cfg(test)]
#[path = "spp_tests.rs"]
mod tests;
