//! The σ of an applied IMU–GNSS time offset in the reported covariance.
//!
//! When the offset passes ([`crate::offset_passes`]) apply an estimate τ̂
//! with an honest σ_τ, the solutions are those of the filter run on the IMU
//! shifted by τ̂; the filter's covariance knows nothing of σ_τ, so wherever
//! the solution depends on the offset (outages after turns, attitude and
//! velocity during manoeuvres) the reported σ is too small — the
//! RTK cells with a 0.1 s offset of `experiment generalise` sat at the
//! lower edge of the 95 % band for that reason.
//!
//! A Schmidt consider state would carry σ_τ in the filter, but it changes
//! the gain: on drive_0708's raw CSV (σ_τ up to 20 ms at 20 m/s) it pulled
//! the solution off its 1 cm fixes (0.012 → 0.126 m). Here the gain is
//! left alone. The error the offset error δτ ~ N(0, σ_τ²) causes is, to
//! first order, `δx(t) = (∂x/∂τ)(t) δτ`, and its covariance
//! `σ_τ² (∂x/∂τ)(∂x/∂τ)ᵀ` is added to the reported one — a sensitivity
//! analysis of the filter to an unmodelled parameter (Gelb, *Applied
//! Optimal Estimation*, 1974, ch. 7, error budgets; Maybeck vol. 1 §6.8) with the derivative taken numerically
//! over the whole nonlinear run: the central difference of two runs at
//! τ̂ ± σ_τ, `σ_τ ∂x/∂τ ≈ (x₊ − x₋)/2`, compared at equal GPS times. The
//! offset error is independent of the filter's own errors (it comes from
//! the velocity residual fit, not from the noise the filter models), so the
//! two covariances add. Solutions are bit-identical to the run without it.
//!
//! Frames: position differences are NED [m] at the base solution's
//! latitude (`R_M`, `R_N` of WGS-84), velocity NED [m/s], attitude roll,
//! pitch, yaw [rad] wrapped to (−π, π].

use crate::eskf_run::EskfRun;
use navfuse_core::earth::radii;
use navfuse_core::geodesy::wrap_pi;
use navfuse_core::types::NavSolution;
use navfuse_core::Vec3;
use navfuse_eval::interpolate_held;
use navfuse_io::stdfile::StdRow;

/// `σ_τ ∂x/∂τ` of one epoch: position NED [m], velocity NED [m/s],
/// attitude [rad].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensitivity {
    pub pos_ned: Vec3,
    pub vel_ned: Vec3,
    pub att_rpy: Vec3,
}

/// Half the difference `plus − minus` as seen from `base` (its latitude
/// for the radii). Non-finite components are zero (an unknown attitude
/// contributes nothing; it already has a NaN σ).
fn half_difference(base: &NavSolution, plus: &NavSolution, minus: &NavSolution) -> Sensitivity {
    let (r_m, r_n) = radii(base.lat);
    let fin = |x: f64| if x.is_finite() { x } else { 0.0 };
    let pos = Vec3::new(
        (plus.lat - minus.lat) * (r_m + base.h),
        wrap_pi(plus.lon - minus.lon) * (r_n + base.h) * base.lat.cos(),
        -(plus.h - minus.h),
    );
    let mut att = Vec3::zeros();
    for i in 0..3 {
        att[i] = wrap_pi(plus.rpy[i] - minus.rpy[i]);
    }
    Sensitivity {
        pos_ned: (pos * 0.5).map(fin),
        vel_ned: ((plus.v_n - minus.v_n) * 0.5).map(fin),
        att_rpy: (att * 0.5).map(fin),
    }
}

/// The sensitivity of every solution of `base` (time-ordered) from the runs
/// at τ̂ + σ_τ (`plus`) and τ̂ − σ_τ (`minus`), interpolated at `base`'s
/// times. Empty when either run has no solutions.
pub fn sensitivities(
    base: &[NavSolution],
    plus: &[NavSolution],
    minus: &[NavSolution],
) -> Vec<Sensitivity> {
    let mut out = Vec::with_capacity(base.len());
    for b in base {
        let (Some(p), Some(m)) = (interpolate_held(plus, b.t), interpolate_held(minus, b.t)) else {
            return Vec::new();
        };
        out.push(half_difference(b, &p, &m));
    }
    out
}

/// `σ ← √(σ² + d²)` per component (a NaN σ stays NaN: unknown).
fn add_var(sigma: &mut Vec3, d: &Vec3) {
    for i in 0..3 {
        sigma[i] = (sigma[i] * sigma[i] + d[i] * d[i]).sqrt();
    }
}

/// Adds `d dᵀ` to one solution's σ.
fn add_to_solution(s: &mut NavSolution, d: &Sensitivity) {
    add_var(&mut s.std_pos_ned, &d.pos_ned);
    add_var(&mut s.std_v_n, &d.vel_ned);
    add_var(&mut s.std_rpy, &d.att_rpy);
}

/// Adds `d dᵀ` to one σ row, cross terms (NE, ED, DN) included.
fn add_to_row(r: &mut StdRow, d: &Sensitivity) {
    add_var(&mut r.pos_ned, &d.pos_ned);
    add_var(&mut r.vel_ned, &d.vel_ned);
    add_var(&mut r.att_rpy, &d.att_rpy);
    let p = &d.pos_ned;
    r.pos_cross_ned += Vec3::new(p.x * p.y, p.y * p.z, p.z * p.x);
}

/// Adds the offset's covariance to `base`'s forward and smoothed σ (the
/// solutions' own σ and the σ rows), from the runs at τ̂ ± σ_τ. Returns the
/// largest horizontal sensitivity added [m] (for the summary note).
pub fn add_offset_covariance(base: &mut EskfRun, plus: &EskfRun, minus: &EskfRun) -> f64 {
    add_offset_covariance_scaled(base, plus, minus, 1.0)
}

/// [`add_offset_covariance`] from runs at τ̂ ± h where σ_τ = `scale`·h
/// (the sensitivity is linear in the step: `σ_τ ∂x/∂τ ≈ scale·(x₊ − x₋)/2`).
pub fn add_offset_covariance_scaled(
    base: &mut EskfRun,
    plus: &EskfRun,
    minus: &EskfRun,
    scale: f64,
) -> f64 {
    let mut largest = 0.0f64;
    let scaled = |v: Vec<Sensitivity>| -> Vec<Sensitivity> {
        v.into_iter()
            .map(|d| Sensitivity {
                pos_ned: d.pos_ned * scale,
                vel_ned: d.vel_ned * scale,
                att_rpy: d.att_rpy * scale,
            })
            .collect()
    };
    let fwd = scaled(sensitivities(
        &base.solutions,
        &plus.solutions,
        &minus.solutions,
    ));
    for (k, d) in fwd.iter().enumerate() {
        add_to_solution(&mut base.solutions[k], d);
        if let Some(r) = base.std.get_mut(k) {
            add_to_row(r, d);
        }
        largest = largest.max(d.pos_ned.xy().norm());
    }
    let smo = scaled(sensitivities(
        &base.smoothed,
        &plus.smoothed,
        &minus.smoothed,
    ));
    for (k, d) in smo.iter().enumerate() {
        add_to_solution(&mut base.smoothed[k], d);
        if let Some(r) = base.smoothed_std.get_mut(k) {
            add_to_row(r, d);
        }
    }
    largest
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sol(t: f64, lat: f64, v: f64) -> NavSolution {
        NavSolution {
            t,
            lat,
            lon: 0.5,
            h: 10.0,
            v_n: Vec3::new(v, 0.0, 0.0),
            rpy: Vec3::new(0.0, 0.0, 3.1),
            std_pos_ned: Vec3::repeat(0.1),
            std_v_n: Vec3::repeat(0.01),
            std_rpy: Vec3::repeat(0.001),
        }
    }

    /// A track moving north at 10 m/s: the runs at τ̂ ± σ_τ see it 10 σ_τ
    /// metres ahead/behind; the half difference at equal times is 10 σ_τ
    /// north and the variances add.
    #[test]
    fn a_shift_in_time_becomes_a_position_sigma_along_track() {
        let (r_m, _) = radii(0.6);
        let dlat = 10.0 / (r_m + 10.0); // 10 m per second
        let track = |shift: f64| -> Vec<NavSolution> {
            (0..100)
                .map(|k| {
                    let t = k as f64 * 0.01;
                    sol(t, 0.6 + dlat * (t + shift), 10.0)
                })
                .collect()
        };
        let sigma_tau = 0.004;
        let (base, plus, minus) = (track(0.0), track(sigma_tau), track(-sigma_tau));
        let d = sensitivities(&base, &plus, &minus);
        assert_eq!(d.len(), base.len());
        for s in &d[1..99] {
            assert!((s.pos_ned.x - 0.04).abs() < 1e-6, "{s:?}");
            assert!(s.pos_ned.y.abs() < 1e-9 && s.vel_ned.norm() < 1e-12);
        }
        let mut s = base[50];
        add_to_solution(&mut s, &d[50]);
        let want = (0.1f64 * 0.1 + 0.04 * 0.04).sqrt();
        assert!((s.std_pos_ned.x - want).abs() < 1e-6);
        assert_eq!(s.std_pos_ned.y, 0.1);
    }

    /// Yaw near ±π: the difference is wrapped, not 2π.
    #[test]
    fn yaw_difference_wraps() {
        let b = sol(0.0, 0.6, 0.0);
        let mut p = b;
        p.rpy.z = -3.1; // +0.083 rad across the wrap
        let d = half_difference(&b, &p, &b);
        let want = wrap_pi(-3.1 - 3.1) / 2.0;
        assert!((d.att_rpy.z - want).abs() < 1e-12 && d.att_rpy.z.abs() < 0.05);
    }

    #[test]
    fn a_nan_sigma_stays_nan() {
        let mut v = Vec3::new(f64::NAN, 1.0, 1.0);
        add_var(&mut v, &Vec3::new(1.0, 0.0, 1.0));
        assert!(v.x.is_nan() && v.y == 1.0 && (v.z - 2f64.sqrt()).abs() < 1e-12);
    }
}
