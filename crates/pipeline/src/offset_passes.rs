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
//! The offset is applied only when the final one is significant against an
//! honest σ (|τ| > 3.29 σ, a 0.1 % two-sided false alarm, and σ ≤ 20 ms):
//! the last pass's σ (itself at least the split-half σ of the core fit),
//! its residual and the spread of the last two passes ([`honest_std`]);
//! otherwise the first pass (no offset) is the result. An applied offset is
//! then refined by the filter's own GNSS likelihood
//! ([`refine_by_likelihood`]), which also reads τ from the positions. An
//! applied offset's
//! σ enters the reported σ (two more runs at τ ± σ_τ,
//! [`crate::offset_sens`]); the solutions stay those at τ. No assumption about
//! course and heading is made, so every platform is served by the same
//! rule. The receiver's velocity latency is removed first
//! ([`crate::time_offset::latency_corrected`]).
//!
//! Why the σ needed more than the residuals (found on the 90 s car starts
//! of `experiment align`, true τ = 0, before this rule): a filter still
//! converging from an in-motion start and a free lever arm produced
//! residual σ of 2–8 ms around estimates of 27 ms to 0.48 s, and passes that
//! oscillated (±0.07 s alternately) or crept to the scan edge.

use crate::error::Result;
use crate::eskf_run::EskfRun;
use crate::time_offset::latency_significant;
use navfuse_core::attitude::{dcm_from_euler, skew};
use navfuse_core::estimators::eskf::UpdateLog;
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
    // Pass 1 is linearised at 0, possibly far from the truth, so its halves
    // may disagree for that reason alone: whether to iterate is decided on
    // the residual σ; whether to apply, on the honest σ of the last pass.
    let (Some(mut tau), true) = (e0.tau_s, e0.significant_fit(&VelOffsetConfig::default())) else {
        return Ok(done(r0, None, log, "no significant offset; none applied"));
    };
    let mut last = None;
    // The total estimate of every pass after the first: its shift plus its
    // remaining offset. Passes measure the same offset from different
    // linearisation points; their scatter beyond σ is model error the
    // single-pass σ does not see.
    let mut totals: Vec<f64> = Vec::with_capacity(MAX_PASSES);
    let mut prev: Option<(f64, f64)> = None;
    for pass in 2..=MAX_PASSES + 1 {
        let imu_s = shifted(imu, tau);
        let r = run(&imu_s)?;
        let e = residual(&r, &imu_s, gnss);
        log.push(format!("pass {pass} ({tau:+.4} s): {}", fmt(&e)));
        let Some(d) = e.tau_s.filter(|_| e.std_fit_s.is_finite()) else {
            break;
        };
        let step = d / gain(prev, (tau, d));
        prev = Some((tau, d));
        totals.push(tau + step);
        let converged = d.abs() <= CONVERGED_S.max(0.25 * e.std_fit_s);
        last = Some((r, tau, honest_std(e.std_s, step, &totals)));
        if converged || pass == MAX_PASSES + 1 {
            break;
        }
        tau = (tau + step).clamp(-MAX_SHIFT_S, MAX_SHIFT_S);
    }
    let cfg = VelOffsetConfig::default();
    match last {
        Some((r, tau, std))
            if std <= cfg.max_std_s
                && tau.abs() > cfg.k_sigma * std
                && tau.abs() < MAX_SHIFT_S - cfg.grid_step_s =>
        {
            // Probes at τ ± σ_τ: the likelihood refinement
            // ([`refine_by_likelihood`]) and σ_τ's share of the reported
            // covariance (`crate::offset_sens`, scaled to the final σ_τ).
            let plus = run(&shifted(imu, tau + std))?;
            let minus = run(&shifted(imu, tau - std))?;
            let mut run_at = |t: f64| run(&shifted(imu, t));
            let mut terms_at = |t: f64| Ok(gnss_nll_terms(&run_at(t)?.updates, gnss));
            let refined = refine_by_likelihood(
                [
                    gnss_nll_terms(&minus.updates, gnss),
                    gnss_nll_terms(&r.updates, gnss),
                    gnss_nll_terms(&plus.updates, gnss),
                ],
                tau,
                std,
                &mut terms_at,
            )?;
            let (mut r, tau, sd, by) = match refined {
                Ok((t_ml, s_ml)) => {
                    log.push(format!(
                        "likelihood refinement: {t_ml:+.4} ± {s_ml:.4} s (from {tau:+.4} ± {std:.4} s)"
                    ));
                    (run_at(t_ml)?, t_ml, s_ml, "velocity passes + likelihood")
                }
                Err(why) => {
                    log.push(format!("likelihood refinement not used: {why}"));
                    (r, tau, std, "velocity passes")
                }
            };
            let most =
                crate::offset_sens::add_offset_covariance_scaled(&mut r, &plus, &minus, sd / std);
            log.push(format!(
                "σ_τ in the reported σ: runs at τ ± σ_τ, largest horizontal {most:.3} m"
            ));
            let how = format!("auto ({by}): {tau:+.4} ± {sd:.4} s");
            Ok(done(r, Some((tau, how)), log, "significant; applied"))
        }
        Some((_, tau, std)) => Ok(done(
            r0,
            None,
            log,
            &format!("{tau:+.4} ± {std:.4} s not significant after iterating; none applied"),
        )),
        None => Ok(done(
            r0,
            None,
            log,
            "no estimate after iterating; none applied",
        )),
    }
}

/// One run's NLL terms by (fix index, kind): (½ capped NIS, dof).
pub type NllTerms = std::collections::BTreeMap<(usize, u8), (f64, u8)>;

/// The GNSS terms of a run's negative log-likelihood, keyed by update
/// (index of the fix in `gnss`, kind): `½ min(NIS, c_d)` for every GNSS position and
/// velocity update (prediction-error decomposition of the filter's
/// likelihood, Schweppe 1965; Gupta & Mehra 1974 for parameter estimation
/// with it), and the update's dof. `log|S|` is left out: S barely depends on
/// a millisecond shift of the IMU stamps, while ν does. Each term is capped
/// at its χ²_d 99.9 % quantile `c_d` (a bounded-influence likelihood): an
/// update the gate treats as an outlier must not move τ, and the cap keeps
/// the sum continuous in τ. Gated and accepted updates alike count.
pub fn gnss_nll_terms(updates: &[UpdateLog], gnss: &[GnssFix]) -> NllTerms {
    use navfuse_core::estimators::eskf::UpdateKind;
    // χ²_d 0.999 quantiles, d = 1, 2, 3.
    const CAP: [f64; 3] = [10.83, 13.82, 16.27];
    let mut out = std::collections::BTreeMap::new();
    for u in updates {
        let kind = match u.kind {
            UpdateKind::GnssPosition => 0u8,
            UpdateKind::GnssVelocity => 1u8,
            _ => continue,
        };
        let Some(&cap) = CAP.get(usize::from(u.dof).wrapping_sub(1)) else {
            continue;
        };
        // The fix applied: the last one at or before the update's step (the
        // run applies a fix at the first step with t + 1 ms ≥ its time).
        let g = gnss.partition_point(|f| f.t <= u.t + 1e-3);
        if u.nis.is_finite() && g > 0 {
            out.insert((g - 1, kind), (0.5 * u.nis.min(cap), u.dof));
        }
    }
    out
}

/// The NLL of every probe over the updates all of them share (a shifted
/// IMU span can gain or lose the first or last fix), and Σ dof.
fn common_nll(terms: &[NllTerms]) -> (Vec<f64>, f64) {
    let mut nll = vec![0.0; terms.len()];
    let mut dof = 0.0;
    let Some((first, rest)) = terms.split_first() else {
        return (nll, dof);
    };
    for (key, &(l, d)) in first {
        let others: Option<Vec<f64>> = rest.iter().map(|t| t.get(key).map(|x| x.0)).collect();
        if let Some(o) = others {
            nll[0] += l;
            for (n, x) in nll[1..].iter_mut().zip(o) {
                *n += x;
            }
            dof += f64::from(d);
        }
    }
    (nll, dof)
}

/// Vertex and curvature of the parabola through three points `(τ, L)`
/// (Lagrange form; `None` when two τ coincide).
fn parabola(p: &[(f64, f64); 3]) -> Option<(f64, f64)> {
    let [(x0, y0), (x1, y1), (x2, y2)] = *p;
    let d01 = (y1 - y0) / (x1 - x0);
    let d12 = (y2 - y1) / (x2 - x1);
    let a = (d12 - d01) / (x2 - x0);
    let b = d01 - a * (x0 + x1);
    (a.is_finite() && b.is_finite()).then(|| (-b / (2.0 * a), 2.0 * a))
}

/// Refinements after the first parabola at most, each one more run: the
/// passes' τ̂ is within 1–2 σ_τ of the answer, so one re-centred probe is
/// enough in practice; 2 leave room without letting a flat likelihood
/// wander.
const MAX_REFINE: usize = 2;

/// Refines the passes' τ̂ by the filter's own likelihood: the GNSS NLL
/// ([`gnss_nll_terms`]) of the runs at τ̂ − h, τ̂, τ̂ + h (h = σ_τ of the
/// passes) fitted by a parabola; its vertex is the maximum-likelihood τ and
/// its curvature the observed information (σ = 1/√curvature). A vertex
/// more than h beyond the probed span is not trusted (the parabola would
/// be extrapolated), nor is a parabola that is not convex: a run at the
/// vertex (at most 2h beyond) or 2h downhill is added and the parabola
/// refitted on the three probes nearest to it, ≤ [`MAX_REFINE`] times. Returns the refined τ and its σ.
///
/// Why: the passes read τ from the GNSS *velocities* only (`∂v/∂τ = −a`);
/// the filter also sees τ in the *positions* (`∂p/∂τ = −v`: a turn shifts
/// the track sideways by Δv·δτ, about 2 cm per ms at 20 m/s — an RTK σ),
/// so a filter given τ̂ is sensitive to errors far below the passes' σ
/// (1.5–3 ms on the simulated car with RTK; 2–4 ms errors there cost 5 %
/// of the horizontal RMS, mostly as heading errors `ω·δτ` carried into
/// outages). The likelihood uses every measurement the filter uses, with
/// the filter's own weights.
///
/// σ is inflated by √(mean NIS per dof) when that exceeds 1 (the filter's R
/// too small for its residuals; the reduced-χ² scaling of a least-squares
/// σ). Declined (`Err`, the passes' τ̂ stays) when the curvature is still
/// not positive or the vertex still beyond the probes after that.
fn refine_by_likelihood(
    [minus, center, plus]: [NllTerms; 3],
    tau: f64,
    h: f64,
    terms_at: &mut dyn FnMut(f64) -> Result<NllTerms>,
) -> Result<core::result::Result<(f64, f64), String>> {
    if h.is_nan() || h <= 0.0 {
        return Ok(Err("no step".into()));
    }
    let mut taus = vec![tau - h, tau, tau + h];
    let mut terms = vec![minus, center, plus];
    for round in 0..=MAX_REFINE {
        let (nll, dof) = common_nll(&terms);
        if dof == 0.0 {
            return Ok(Err("no common GNSS updates".into()));
        }
        // The three probes nearest to the last one added (or to τ̂).
        let focus = *taus.last().filter(|_| round > 0).unwrap_or(&tau);
        let mut idx: Vec<usize> = (0..taus.len()).collect();
        idx.sort_by(|&a, &b| (taus[a] - focus).abs().total_cmp(&(taus[b] - focus).abs()));
        let mut pts = [(0.0, 0.0); 3];
        for (p, &i) in pts.iter_mut().zip(&idx[..3]) {
            *p = (taus[i], nll[i]);
        }
        let Some((vertex, curv)) = parabola(&pts) else {
            return Ok(Err("degenerate probes".into()));
        };
        let lo = pts.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
        let hi = pts.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
        let convex = curv.is_finite() && curv > 0.0;
        if convex && vertex >= lo - h && vertex <= hi + h {
            let chi2_per_dof = (2.0 * nll[idx[0]] / dof).max(1.0);
            return Ok(Ok((vertex, (chi2_per_dof / curv).sqrt())));
        }
        if round == MAX_REFINE {
            let why = if convex {
                "vertex beyond the probes"
            } else {
                "likelihood not convex over the probes"
            };
            return Ok(Err(format!("{why} after {MAX_REFINE} re-centred runs")));
        }
        // Not convex over the probes (the capped terms flatten the NLL away
        // from its minimum, so probes far from it can bend the other way):
        // a step of 2h downhill from the lower end probe; else a step to
        // the vertex, at most 2h beyond the probes.
        let at = |t: f64| pts.iter().find(|p| p.0 == t).map_or(f64::NAN, |p| p.1);
        let next = if !convex {
            if at(hi) < at(lo) {
                hi + 2.0 * h
            } else {
                lo - 2.0 * h
            }
        } else {
            vertex.clamp(lo - 2.0 * h, hi + 2.0 * h)
        };
        terms.push(terms_at(next)?);
        taus.push(next);
    }
    Ok(Err("no refinement".into()))
}

/// An offset to apply with how it was found, and the likelihood's note
/// when it ran ([`likelihood_on_positions`]).
pub type PositionsDecision = (Option<(f64, String)>, Option<String>);

/// Largest probe step of [`likelihood_on_positions`] [s]: 0.1 s is a
/// 10 Hz receiver's epoch, the largest offset a logger's time tagging
/// leaves unnoticed; larger ones are found by the course estimate itself.
const POSITION_PROBE_MAX_S: f64 = 0.1;
/// Smallest probe step [s]: below the course estimate's resolution.
const POSITION_PROBE_MIN_S: f64 = 0.005;
/// Smallest step of the fine parabola [s]: 2 ms moves a 20 m/s track by
/// 4 cm, two RTK σ, so the NLL still changes measurably over it.
const POSITION_PROBE_FINE_MIN_S: f64 = 0.002;

/// Records without GNSS velocity (no velocity passes) where the course
/// estimate ([`crate::time_offset::auto_estimate`]) finds an offset under
/// some model variant but cannot settle it (the variants differ in sign or
/// not all are significant): the filter's own GNSS-position likelihood
/// decides: the run repeated over a grid of 9 probes across ±h (h the
/// largest significant variant's |τ| within [5, 100] ms), then
/// [`refine_by_likelihood`] through the lowest probe and its neighbours
/// and again over its vertex ± σ. Positions see τ through
/// `∂p/∂τ = −v` with the filter's weights, and no course–heading model is
/// assumed, so the variants' disagreement (antenna ahead of the
/// zero-sideslip point or not) does not enter. Applied under the course
/// estimate's own rule: |τ| > 3.29 σ and σ ≤ 20 ms. `terms_at(τ)`: the
/// NLL terms of a run with the IMU stamps shifted by τ. `Ok(None)`: not
/// triggered or not significant (the note says which, when run).
pub fn likelihood_on_positions(
    course: &crate::time_offset::AutoOffset,
    terms_at: &mut dyn FnMut(f64) -> Result<NllTerms>,
) -> Result<PositionsDecision> {
    let cfg = VelOffsetConfig::default();
    if course.apply {
        return Ok((None, None));
    }
    let h = course
        .variants
        .iter()
        .filter(|(_, e)| e.significant && e.std_s <= cfg.max_std_s)
        .filter_map(|(_, e)| e.tau_s)
        .map(f64::abs)
        .fold(f64::NAN, f64::max);
    if h.is_nan() {
        return Ok((None, None));
    }
    let h = h.clamp(POSITION_PROBE_MIN_S, POSITION_PROBE_MAX_S);
    // The capped NLL is quadratic only near its minimum (measured on a
    // simulated car: a parabola through −h, 0, +h put the vertex 25 ms
    // from a minimum 8 σ deep): a grid of 9 probes over ±h locates it, a
    // parabola through its neighbours refines it, and a last one over the
    // vertex ± its σ (as the velocity passes' refinement) reads τ and σ.
    let d = h / 4.0;
    let grid: Vec<f64> = (-4..=4).map(|i| f64::from(i) * d).collect();
    let mut terms = Vec::with_capacity(grid.len());
    for &t in &grid {
        terms.push(terms_at(t)?);
    }
    let (nll, dof) = common_nll(&terms);
    let best = (0..grid.len()).min_by(|&a, &b| nll[a].total_cmp(&nll[b]));
    let fine = match best {
        _ if dof == 0.0 => Err("no common GNSS updates".to_string()),
        Some(i) if i > 0 && i + 1 < grid.len() => {
            let mut it = terms.into_iter().skip(i - 1);
            let three = [(); 3].map(|_| it.next().unwrap_or_default());
            match refine_by_likelihood(three, grid[i], d, terms_at)? {
                Ok((t1, s1)) => {
                    let h2 = s1.max(POSITION_PROBE_FINE_MIN_S);
                    let probes = [terms_at(t1 - h2)?, terms_at(t1)?, terms_at(t1 + h2)?];
                    refine_by_likelihood(probes, t1, h2, terms_at)?
                }
                Err(e) => Err(e),
            }
        }
        _ => Err(format!(
            "minimum at the edge of the ±{:.0} ms probes",
            h * 1e3
        )),
    };
    let note = match fine {
        Ok((tau, sd)) if sd <= cfg.max_std_s && tau.abs() > cfg.k_sigma * sd => {
            let how = format!(
                "auto (GNSS-position likelihood, the course variants disagreeing): {tau:+.4} ± {sd:.4} s"
            );
            return Ok((Some((tau, how.clone())), Some(how)));
        }
        Ok((tau, sd)) => {
            format!("GNSS-position likelihood {tau:+.4} ± {sd:.4} s: not significant; none applied")
        }
        Err(why) => format!("GNSS-position likelihood not used: {why}"),
    };
    Ok((None, Some(note)))
}

/// The offset of a record without GNSS velocity in `auto` mode: the course
/// estimate when it is conclusive, else [`likelihood_on_positions`] with
/// `run` (the filter on the given IMU samples). Returns the offset to apply
/// with how it was found, and the likelihood's note when it ran.
pub fn decide_positions_only(
    imu: &[ImuSample],
    gnss: &[GnssFix],
    run: &mut dyn FnMut(&[ImuSample]) -> Result<EskfRun>,
) -> Result<PositionsDecision> {
    let course = crate::time_offset::auto_estimate(imu, gnss);
    if course.apply {
        let how = crate::time_offset::describe(&course);
        return Ok((course.tau_s.map(|t| (t, how)), None));
    }
    let mut terms_at = |t: f64| Ok(gnss_nll_terms(&run(&shifted(imu, t))?.updates, gnss));
    likelihood_on_positions(&course, &mut terms_at)
}

/// The share of the remaining offset a pass measures, from the last two
/// passes (secant of the residual against the shift; both after pass 1,
/// which is linearised far from the answer). A filter absorbs part of a
/// timing error into its attitude and biases, so a pass's residual is
/// `g·(τ_true − τ)` with `g` < 1 near the answer (e.g. g ≈ 0.3–0.6 on a
/// simulated car whose plain iteration crept 0.230 → 0.221 → 0.214 →
/// 0.210 s towards 0.2 s); stepping by `d/g` (the secant method) reaches the
/// root in one or two passes. Used only when the secant is a plausible
/// gain, 0.2–1.5 (noise can tilt a secant over a short step arbitrarily);
/// otherwise 1 (the plain step).
fn gain(prev: Option<(f64, f64)>, now: (f64, f64)) -> f64 {
    let Some((t0, d0)) = prev else {
        return 1.0;
    };
    let (t1, d1) = now;
    if (t1 - t0).abs() < 1e-4 {
        return 1.0;
    }
    let g = -(d1 - d0) / (t1 - t0);
    if (0.2..=1.5).contains(&g) {
        g
    } else {
        1.0
    }
}

/// σ of the shift a pass ran with: its own residual's σ, the remaining
/// offset `d` (the residual over the [`gain`]: the shift is off by it, by
/// that pass's own measure) and the
/// spread of the last two passes' totals (`|T₁ − T₂|/√2`, their sample
/// σ), in quadrature. Only the last two: the early passes are linearised
/// far from the answer (module doc) and a slowly contracting iteration is
/// not a scatter. On a converged record the last two terms are ≪ σ; where
/// the passes wander or oscillate (a model misfit, e.g. a filter still
/// converging through most of a short record) they dominate, and the
/// offset is applied only if it is significant against them too.
fn honest_std(std: f64, d: f64, totals: &[f64]) -> f64 {
    let spread = match totals {
        [.., a, b] => (a - b).abs() / core::f64::consts::SQRT_2,
        _ => 0.0,
    };
    (std * std + d * d + spread * spread).sqrt()
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
    let (mut kept, applied) = if serves(&loaded.gnss) {
        let (retimed, latency) = crate::time_offset::latency_corrected(&loaded.gnss);
        if let Some(g) = retimed {
            loaded.gnss = g;
        }
        if let Some((l, sl)) = latency {
            loaded.resolved["gnss_velocity_latency_s"] = serde_json::json!({
                "estimate": l, "std": sl, "removed": latency_significant(l, sl),
            });
        }
        let (imu0, gnss) = (&loaded.imu, &loaded.gnss);
        let mut run = shifted_runner(cfg, base_dir, imu0, gnss, &loaded.aux, with_std);
        let p = run_with_offset_passes(imu0, gnss, &mut run)?;
        let mut r = p.run;
        r.time_offset_passes = Some(latency_note(latency) + &p.note);
        match (p.applied, course_fallback(cfg, imu0, gnss)?) {
            (None, Some(c)) => (None, Some(c)),
            (applied, _) => (Some(r), applied),
        }
    } else if cfg.input.imu_time_offset.is_some() || default_mode(cfg) == TimeOffset::Auto {
        let (imu0, gnss) = (&loaded.imu, &loaded.gnss);
        let mut run = shifted_runner(cfg, base_dir, imu0, gnss, &loaded.aux, false);
        let (applied, note) = decide_positions_only(imu0, gnss, &mut run)?;
        if let Some(n) = note {
            loaded.resolved["imu_time_offset_likelihood"] = serde_json::json!(n);
        }
        (None, applied)
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

/// The filter on a loaded record with the IMU samples given (shifted
/// copies of `imu0`; the aux series shifted by the same amount).
fn shifted_runner<'a>(
    cfg: &'a crate::config::RunConfig,
    base_dir: &'a std::path::Path,
    imu0: &'a [ImuSample],
    gnss: &'a [GnssFix],
    aux0: &'a Option<crate::input::AuxSeries>,
    with_std: bool,
) -> impl FnMut(&[ImuSample]) -> Result<EskfRun> + 'a {
    move |imu: &[ImuSample]| {
        let tau = imu
            .first()
            .zip(imu0.first())
            .map_or(0.0, |(a, b)| a.t - b.t);
        let aux = aux0.as_ref().map(|a| shift_aux(a, tau));
        let span = crate::eskf_run::select_span(cfg, imu, gnss)?;
        crate::eskf_run::run_eskf_span(cfg, base_dir, &span, aux.as_ref(), with_std)
    }
}

/// Where the passes decline (their honest σ is too large, e.g. consumer
/// GNSS whose record halves disagree) and the platform's course follows its
/// heading, the course estimate decides by its own rule (significant and of
/// one sign under every model variant, [`crate::time_offset::auto_estimate`]):
/// it reads other information (course against the z gyro), so a decline
/// by the passes is no reason to drop it — and it is what a run did before
/// the passes served these platforms.
pub fn course_fallback(
    cfg: &crate::config::RunConfig,
    imu: &[ImuSample],
    gnss: &[GnssFix],
) -> Result<Option<(f64, String)>> {
    use crate::time_offset::{default_mode, TimeOffset};
    if default_mode(cfg) != TimeOffset::Auto {
        return Ok(None);
    }
    Ok(TimeOffset::Auto.resolve(imu, gnss)?.map(|(tau, how)| {
        (
            tau,
            format!("{how} (course estimate; the velocity passes declined)"),
        )
    }))
}

/// Whether the velocity passes decide the offset: the fixes carry
/// velocities (any platform: they assume nothing about course and heading).
/// Without velocities the course estimate
/// ([`crate::time_offset::auto_estimate`]) decides where the course follows
/// the heading ([`crate::time_offset::default_mode`]).
pub fn serves(gnss: &[GnssFix]) -> bool {
    has_velocity(gnss)
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

/// The passes' note prefix on the receiver velocity's latency.
pub fn latency_note(latency: Option<(f64, f64)>) -> String {
    match latency {
        Some((l, sl)) if latency_significant(l, sl) => {
            format!("receiver velocity latency {l:+.3} ± {sl:.3} s, removed; ")
        }
        Some((l, sl)) => {
            format!("receiver velocity latency {l:+.3} ± {sl:.3} s, not significant; ")
        }
        None => String::new(),
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
            "{t:+.4} ± {:.4} s (residual σ {:.4} s), {} epochs, lever [{:.2}, {:.2}, {:.2}] m ({})",
            e.std_s,
            e.std_fit_s,
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
