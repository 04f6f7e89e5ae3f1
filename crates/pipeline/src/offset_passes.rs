//! The IMU–GNSS time offset from filter passes (policy; the math is
//! [`navfuse_core::ins::time_offset_vel`]). Convention: true time = IMU
//! stamp + τ.
//!
//! A first pass runs the filter without an offset; its INS velocity
//! trajectory (velocity increments between GNSS updates: attitude, biases,
//! gravity and Coriolis as the filter knows them) is compared with the GNSS
//! velocities, giving the residual offset with an honest σ. When it is
//! significant the IMU stamps are shifted by it and the filter re-run, and
//! the residual of that pass is added, until it is negligible: a pass far
//! from the truth has an attitude bent to absorb the timing error, so one
//! linearisation is biased at large offsets; the iteration removes that.
//! The offset is applied only when the final one is significant against the
//! σ of the last pass (|τ| > 3.29 σ, a 0.1 % two-sided false alarm, and
//! σ ≤ 20 ms); otherwise the first pass (no offset) is the result. No
//! assumption about course and heading is made, so every platform is served
//! by the same rule.

use crate::error::Result;
use crate::eskf_run::EskfRun;
use navfuse_core::attitude::{dcm_from_euler, skew};
use navfuse_core::ins::time_offset::TimeOffsetReason;
use navfuse_core::ins::time_offset_vel::{
    estimate_from_velocity, InsSample, VelOffsetConfig, VelOffsetEstimate,
};
use navfuse_core::types::{GnssFix, ImuSample, NavSolution};
use navfuse_core::Vec3;

/// Passes after the first at most. Each pass removes most of the residual
/// (the linearisation error shrinks with it), so 4 reach ≪ 1 ms from ±0.5 s.
const MAX_PASSES: usize = 4;
/// A residual below this [s] ends the iteration: 1 ms is 1/10 of the
/// accuracy asked of the estimate and below any filter effect.
const CONVERGED_S: f64 = 1e-3;
/// Largest offset the passes try [s]: the velocity estimator's own scan
/// range. A τ driven to this bound is not an estimate but the edge of the
/// search (a short or poorly excited record): nothing is applied then, as
/// the single-pass estimator does at its scan edge (`AtScanEdge`).
const MAX_SHIFT_S: f64 = 0.5;

/// Whether the fixes carry velocities (most of them): the passes need them.
pub fn has_velocity(gnss: &[GnssFix]) -> bool {
    let n = gnss.iter().filter(|g| g.v_n.is_some()).count();
    n > 0 && 2 * n >= gnss.len()
}

/// The INS trajectory of a pass (`sols` one per IMU sample, stamps as run;
/// `imu` the samples the pass ran on): `a_n` from the velocity increments,
/// held over the step that applied a GNSS fix (its jump is the update, not
/// motion); the lever map `C_bn·[ω_ib]×` from the attitude and the gyro.
pub fn ins_track(sols: &[NavSolution], imu: &[ImuSample], gnss: &[GnssFix]) -> Vec<InsSample> {
    let mut out: Vec<InsSample> = Vec::with_capacity(sols.len());
    let mut k = 0usize;
    let mut g = 0usize;
    let mut prev: Option<&NavSolution> = None;
    for s in sols {
        let ok = s.v_n.iter().chain(s.rpy.iter()).all(|x| x.is_finite());
        while k < imu.len() && imu[k].t < s.t - 1e-9 {
            k += 1;
        }
        let Some(i) = imu
            .get(k)
            .filter(|i| (i.t - s.t).abs() < 1e-6 && i.dt > 0.0)
        else {
            prev = None;
            continue;
        };
        if !ok {
            prev = None;
            continue;
        }
        // The run applies fix g at the first step with t + 1 ms ≥ g.t.
        let mut updated = false;
        while g < gnss.len() && gnss[g].t <= s.t + 1e-3 {
            updated = true;
            g += 1;
        }
        let a_n = match prev {
            Some(p) if !updated && s.t > p.t => (s.v_n - p.v_n) / (s.t - p.t),
            _ => out.last().map_or(Vec3::zeros(), |l| l.a_n),
        };
        let w = i.dtheta_b / i.dt;
        out.push(InsSample {
            t: s.t,
            a_n,
            lever_map: dcm_from_euler(&s.rpy) * skew(&w),
        });
        prev = Some(s);
    }
    out
}

/// The residual offset of one pass.
fn residual(r: &EskfRun, imu: &[ImuSample], gnss: &[GnssFix]) -> VelOffsetEstimate {
    let track = ins_track(&r.solutions, imu, gnss);
    estimate_from_velocity(&track, gnss, &VelOffsetConfig::default())
}

fn shifted(imu: &[ImuSample], tau: f64) -> Vec<ImuSample> {
    imu.iter()
        .map(|s| ImuSample { t: s.t + tau, ..*s })
        .collect()
}

/// The result of [`run_with_offset_passes`].
pub struct Passes {
    /// The run to keep (on the IMU shifted by `applied`, or unshifted).
    pub run: EskfRun,
    /// τ applied [s] and how, `None` when none.
    pub applied: Option<(f64, String)>,
    /// One line: every pass's residual, and the decision.
    pub note: String,
}

/// Runs `run` (the filter on the given IMU samples, GNSS fixed) in passes
/// and decides the offset (see the module doc). `imu` unshifted.
pub fn run_with_offset_passes(
    imu: &[ImuSample],
    gnss: &[GnssFix],
    run: &mut dyn FnMut(&[ImuSample]) -> Result<EskfRun>,
) -> Result<Passes> {
    let r0 = run(imu)?;
    let e0 = residual(&r0, imu, gnss);
    let mut log = vec![format!("pass 1 (0 s): {}", fmt(&e0))];
    let done = |run, applied, log: Vec<String>, why: &str| Passes {
        run,
        applied,
        note: format!("velocity passes: {why} [{}]", log.join("; ")),
    };
    let (Some(mut tau), true) = (e0.tau_s, e0.significant()) else {
        return Ok(done(r0, None, log, "no significant offset; none applied"));
    };
    let mut last = None;
    for pass in 2..=MAX_PASSES + 1 {
        let imu_s = shifted(imu, tau);
        let r = run(&imu_s)?;
        let e = residual(&r, &imu_s, gnss);
        log.push(format!("pass {pass} ({tau:+.4} s): {}", fmt(&e)));
        let Some(d) = e.tau_s.filter(|_| e.std_s.is_finite()) else {
            break;
        };
        let converged = d.abs() <= CONVERGED_S.max(0.25 * e.std_s);
        last = Some((r, tau, e.std_s));
        if converged || pass == MAX_PASSES + 1 {
            break;
        }
        tau = (tau + d).clamp(-MAX_SHIFT_S, MAX_SHIFT_S);
    }
    let cfg = VelOffsetConfig::default();
    match last {
        Some((r, tau, std))
            if std <= cfg.max_std_s
                && tau.abs() > cfg.k_sigma * std
                && tau.abs() < MAX_SHIFT_S - cfg.grid_step_s =>
        {
            let how = format!("auto (velocity passes): {tau:+.4} ± {std:.4} s");
            Ok(done(r, Some((tau, how)), log, "significant; applied"))
        }
        _ => Ok(done(
            r0,
            None,
            log,
            "not significant after iterating; none applied",
        )),
    }
}

/// `navfuse run`'s file path: when `[input] imu_time_offset` is unset or
/// `"auto"` the inputs were loaded without an offset
/// ([`wants_passes`]); this decides it on them — by passes when the fixes
/// carry velocities, else by the course estimate
/// ([`crate::time_offset::auto_estimate`], only where the course follows
/// the heading: [`crate::time_offset::default_mode`]) — shifts the IMU and
/// aux stamps of `loaded` by it, records it in `loaded`, and returns the
/// final pass's run (to keep, on the shifted inputs) when passes ran.
pub fn decide_on_loaded(
    cfg: &crate::config::RunConfig,
    base_dir: &std::path::Path,
    loaded: &mut crate::input::Loaded,
    with_std: bool,
) -> Result<Option<EskfRun>> {
    use crate::time_offset::{default_mode, TimeOffset};
    let (mut kept, applied) = if serves(cfg, &loaded.gnss) {
        let (imu0, gnss, aux0) = (&loaded.imu, &loaded.gnss, &loaded.aux);
        let mut run = |imu: &[ImuSample]| {
            let tau = imu
                .first()
                .zip(imu0.first())
                .map_or(0.0, |(a, b)| a.t - b.t);
            let aux = aux0.as_ref().map(|a| shift_aux(a, tau));
            let span = crate::eskf_run::select_span(cfg, imu, gnss)?;
            crate::eskf_run::run_eskf_span(cfg, base_dir, &span, aux.as_ref(), with_std)
        };
        let p = run_with_offset_passes(imu0, gnss, &mut run)?;
        let mut r = p.run;
        r.time_offset_passes = Some(p.note);
        (Some(r), p.applied)
    } else if cfg.input.imu_time_offset.is_some() || default_mode(cfg) == TimeOffset::Auto {
        (None, TimeOffset::Auto.resolve(&loaded.imu, &loaded.gnss)?)
    } else {
        (None, None)
    };
    if let Some((tau, _)) = &applied {
        loaded.imu.iter_mut().for_each(|s| s.t += tau);
        if let Some(a) = &mut loaded.aux {
            *a = shift_aux(a, *tau);
        }
        loaded.resolved["imu_time_offset_s"] = serde_json::json!(tau);
    }
    if let Some(r) = &mut kept {
        r.time_offset_applied = applied.clone();
    }
    loaded.imu_time_offset = applied;
    Ok(kept)
}

/// Whether the velocity passes decide the offset: the fixes carry
/// velocities and the platform's course does not follow its heading (uav,
/// marine, static: [`crate::time_offset::default_mode`] is `None` there).
/// Where the course follows the heading (car, robot, pedestrian, no
/// platform) the course estimate ([`crate::time_offset::auto_estimate`])
/// stays: on drive_0708's
/// raw log (stamps ≈ 0.2 s late) the passes found +0.03 s where the course
/// estimate finds −0.15…−0.21 s, and on 90 s car runs starting in motion
/// they applied offsets of up to 0.5 s where the truth is 0
/// (`experiment align`: heading 94 %, 24 % worse than RTK at the fixes).
pub fn serves(cfg: &crate::config::RunConfig, gnss: &[GnssFix]) -> bool {
    has_velocity(gnss)
        && crate::time_offset::default_mode(cfg) == crate::time_offset::TimeOffset::None
}

/// Whether `navfuse run` loads without an offset and leaves it to
/// [`decide_on_loaded`]: `[input] imu_time_offset` unset or `"auto"`.
pub fn wants_passes(cfg: &crate::config::RunConfig) -> bool {
    use crate::time_offset::TimeOffsetCfg;
    match &cfg.input.imu_time_offset {
        // One receiver clock stamps a UBX log's IMU and GNSS.
        None if cfg.input.ubx.is_some() => false,
        None => true,
        Some(TimeOffsetCfg::Named(n)) => n == "auto",
        Some(TimeOffsetCfg::Seconds(_)) => false,
    }
}

fn shift_aux(a: &crate::input::AuxSeries, tau: f64) -> crate::input::AuxSeries {
    let mut a = a.clone();
    a.0.iter_mut().for_each(|x| x.t += tau);
    a
}

fn fmt(e: &VelOffsetEstimate) -> String {
    match e.tau_s {
        Some(t) => format!(
            "{t:+.4} ± {:.4} s, {} epochs, lever [{:.2}, {:.2}, {:.2}] m ({})",
            e.std_s,
            e.pairs_used,
            e.lever_b.x,
            e.lever_b.y,
            e.lever_b.z,
            e.reason.describe()
        ),
        None => format!("no estimate ({})", TimeOffsetReason::describe(e.reason)),
    }
}

#[cfg(test)]
#[path = "offset_passes_tests.rs"]
mod tests;
