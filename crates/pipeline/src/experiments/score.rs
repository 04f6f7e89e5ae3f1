//! Scoring of solutions against the simulator's truth: horizontal error,
//! per-outage drift and the horizontal NEES (Bar-Shalom, Li & Kirubarajan,
//! *Estimation with Applications to Tracking and Navigation*, §5.4.2).

use navfuse_core::earth::radii;
use navfuse_core::types::NavSolution;
use navfuse_sim::trajectory::{Trajectory, TruthEpoch};

/// Speed above which the platform counts as moving [m/s] (the issue's
/// definition of the motion start).
pub const MOTION_SPEED_M_S: f64 = 0.2;

/// χ²(2) 95 % quantile: a consistent 2-D horizontal error has NEES ≤ this
/// in 95 % of the epochs.
pub(crate) const CHI2_2_95: f64 = 5.991;

/// GPS time [s] of the first truth epoch with speed > 0.2 m/s (None: never moves).
pub fn motion_start(traj: &Trajectory) -> Option<f64> {
    traj.truth
        .iter()
        .find(|e| e.v_n.norm() > MOTION_SPEED_M_S)
        .map(|e| e.t)
}

/// Horizontal error (north, east) [m] of a position (lat, lon [rad]) with
/// respect to the truth epoch `tr` (local small-angle NED at the truth).
pub fn h_error_ne(lat: f64, lon: f64, tr: &TruthEpoch) -> (f64, f64) {
    let (rm, rn) = radii(tr.lat);
    (
        (lat - tr.lat) * (rm + tr.h),
        (lon - tr.lon) * (rn + tr.h) * tr.lat.cos(),
    )
}

/// Scores of the solutions of one run from `t_from` on (sums, to pool over seeds).
#[derive(Clone, Debug, Default)]
pub(crate) struct RunScore {
    /// Σ horizontal error² [m²] and the number of scored epochs.
    pub sum_e2: f64,
    pub n: usize,
    /// Max horizontal error [m] in each outage window that has scored epochs.
    pub outage_max: Vec<f64>,
    /// Σ horizontal NEES, epochs with a finite one, epochs with NEES ≤ χ²₂(95 %).
    pub nees_sum: f64,
    pub nees_n: usize,
    pub nees_in95: usize,
    /// IMU time offset the run applied [s] (0: none).
    pub tau_applied: f64,
    /// Diagnostics of the run (the per-seed rows of `generalise`).
    pub diag: RunDiag,
}

/// Per-run diagnostics: how the run aligned, its warnings and its yaw
/// error against the truth from `t_from` on.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct RunDiag {
    /// [`crate::EskfRun::align_method`], wait from the first IMU sample to
    /// the filter start [s] and the initial yaw σ [deg].
    pub align_method: String,
    pub align_wait_s: f64,
    pub align_yaw_std_deg: f64,
    /// RMS and max |yaw error| over the scored epochs [deg].
    pub yaw_err_rms_deg: f64,
    pub yaw_err_max_deg: f64,
    /// The run's warnings (summary.json `warnings`).
    pub warnings: Vec<String>,
    /// The time offset applied [s] (0 when none) and the velocity passes'
    /// note (every pass's residual and the decision; empty when none ran).
    pub tau_applied_s: f64,
    pub time_offset_passes: String,
}

/// Score `sols` against `traj` from `t_from` [s] on; `outages` are
/// `[start, end)` windows in GPS time. NEES = e_N²/σ_N² + e_E²/σ_E² (the
/// solution carries the diagonal of the position covariance only).
pub(crate) fn score_run(
    sols: &[NavSolution],
    traj: &Trajectory,
    t_from: f64,
    outages: &[[f64; 2]],
) -> RunScore {
    let mut s = RunScore::default();
    let mut omax = vec![f64::NAN; outages.len()];
    let (mut yaw2, mut yaw_max) = (0.0, 0.0f64);
    for sol in sols.iter().filter(|x| x.t >= t_from) {
        let tr = traj.at(sol.t);
        let dyaw = super::wrap_pi(sol.rpy.z - tr.rpy.z).abs().to_degrees();
        yaw2 += dyaw * dyaw;
        yaw_max = yaw_max.max(dyaw);
        let (en, ee) = h_error_ne(sol.lat, sol.lon, &tr);
        let e2 = en * en + ee * ee;
        s.sum_e2 += e2;
        s.n += 1;
        if let Some(k) = outages.iter().position(|o| sol.t >= o[0] && sol.t < o[1]) {
            // f64::max ignores the NaN start value; a NaN error stays NaN.
            omax[k] = if e2.is_nan() {
                f64::NAN
            } else {
                omax[k].max(e2.sqrt())
            };
        }
        let (sn, se) = (sol.std_pos_ned.x, sol.std_pos_ned.y);
        let nees = en * en / (sn * sn) + ee * ee / (se * se);
        if nees.is_finite() {
            s.nees_sum += nees;
            s.nees_n += 1;
            s.nees_in95 += usize::from(nees <= CHI2_2_95);
        }
    }
    s.outage_max = omax.into_iter().filter(|x| !x.is_nan()).collect();
    s.diag.yaw_err_rms_deg = (yaw2 / s.n.max(1) as f64).sqrt();
    s.diag.yaw_err_max_deg = yaw_max;
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use navfuse_core::Vec3;

    /// A 1 m north error: h_error_ne gives (1, 0); a solution with σ = 1 m
    /// has NEES 1 (inside 95 %), one with σ = 0.1 m NEES 100 (outside); the
    /// outage max takes the larger error in the window.
    #[test]
    fn errors_and_nees_of_a_known_offset() {
        let tr = TruthEpoch {
            t: 0.0,
            lat: 0.5,
            lon: 1.0,
            h: 100.0,
            v_n: Vec3::zeros(),
            rpy: Vec3::zeros(),
            w_ib_b: Vec3::zeros(),
            f_b: Vec3::zeros(),
        };
        let (rm, _) = radii(0.5);
        let dlat = 1.0 / (rm + 100.0);
        let (n, e) = h_error_ne(0.5 + dlat, 1.0, &tr);
        assert!((n - 1.0).abs() < 1e-9 && e.abs() < 1e-12, "{n} {e}");
        let traj = Trajectory {
            truth: vec![tr, TruthEpoch { t: 10.0, ..tr }],
            imu: vec![],
            imu_dt: 10.0,
        };
        let sol = |t: f64, k: f64, std: f64| NavSolution {
            t,
            lat: 0.5 + k * dlat,
            lon: 1.0,
            h: 100.0,
            v_n: Vec3::zeros(),
            rpy: Vec3::zeros(),
            std_pos_ned: Vec3::repeat(std),
            std_v_n: Vec3::repeat(1.0),
            std_rpy: Vec3::repeat(1.0),
        };
        let sols = [
            sol(0.5, 5.0, 1.0),
            sol(1.0, 1.0, 1.0),
            sol(2.0, 1.0, 0.1),
            sol(3.0, 2.0, 1.0),
        ];
        let s = score_run(&sols, &traj, 1.0, &[[1.5, 3.5]]);
        assert_eq!(s.n, 3);
        assert!((s.sum_e2 - 6.0).abs() < 1e-6, "{}", s.sum_e2);
        assert_eq!(s.outage_max.len(), 1);
        assert!((s.outage_max[0] - 2.0).abs() < 1e-6);
        assert_eq!((s.nees_n, s.nees_in95), (3, 2));
        assert!((s.nees_sum - 105.0).abs() < 1e-4, "{}", s.nees_sum);
    }
}
