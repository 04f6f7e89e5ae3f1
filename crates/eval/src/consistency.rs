//! Is the solution's σ right? Normalised estimation error squared (NEES,
//! Bar-Shalom, Li & Kirubarajan 2001 §5.4.2) of the position error against
//! the solution's own 1-σ, horizontally (2 degrees of freedom) and
//! vertically (1), and the share of epochs inside the 68 / 95 / 99 %
//! regions (χ² quantiles below).
//!
//! The σ are the diagonal of the covariance (N, E, D independent: the
//! north–east correlation is not in the outputs). With a lever arm the
//! compared point is `p + C_bn l`; its variance adds the attitude term
//! `(l_n ×) diag(σ_att²) (l_n ×)ᵀ` (first order, attitude–position
//! correlation neglected; millimetres for a decimetre lever arm).

use crate::{ErrorEpoch, Outage};
use navfuse_core::attitude::dcm_from_euler;
use navfuse_core::{NavSolution, Vec3};
use serde::{Deserialize, Serialize};

/// χ²(2) quantiles at 68.27 / 95 / 99 %.
pub const CHI2_2DOF: [f64; 3] = [2.279, 5.991, 9.210];
/// χ²(1) quantiles at 68.27 / 95 / 99 %.
pub const CHI2_1DOF: [f64; 3] = [0.989, 3.841, 6.635];

/// NEES statistics of one set of epochs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NeesStats {
    /// Epochs with an error and a finite, positive σ.
    pub epochs: usize,
    /// Mean horizontal NEES (consistent: 2) and vertical NEES (consistent: 1).
    pub nees_h: f64,
    pub nees_v: f64,
    /// Share of epochs with horizontal NEES within the 68 / 95 / 99 % χ²(2) region.
    pub inside_h: [f64; 3],
    /// Share of epochs with vertical NEES within the 68 / 95 / 99 % χ²(1) region.
    pub inside_v: [f64; 3],
    /// Median horizontal σ (√(σN² + σE²)) [m] and RMS horizontal error [m].
    pub median_sigma_h: f64,
    pub rms_error_h: f64,
}

/// Consistency over the run and inside the outages.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Consistency {
    pub run: NeesStats,
    /// Epochs inside the outages given (`None`: no outages given).
    pub outages: Option<NeesStats>,
    /// Per epoch `(t, nees_h, nees_v)`, for plots.
    pub series: Vec<(f64, f64, f64)>,
}

/// The σ of `sols` at `t` [s]: position σ NED [m] of the compared point
/// (lever arm `l_b` applied), linearly interpolated between the two
/// solutions around `t` (exact at a solution epoch); `None` outside the
/// span or where σ is unknown.
fn sigma_at(sols: &[NavSolution], t: f64, l_b: Option<Vec3>) -> Option<Vec3> {
    let i = sols.partition_point(|s| s.t < t);
    let point = |s: &NavSolution| -> Option<Vec3> {
        let mut var = s.std_pos_ned.component_mul(&s.std_pos_ned);
        if let Some(l) = l_b {
            let l_n = dcm_from_euler(&s.rpy) * l;
            let a = s.std_rpy.component_mul(&s.std_rpy);
            if a.iter().all(|x| x.is_finite()) {
                // (l_n ×) diag(a) (l_n ×)ᵀ diagonal: for row r, Σ_k S_rk² a_k.
                var += Vec3::new(
                    l_n.z * l_n.z * a.y + l_n.y * l_n.y * a.z,
                    l_n.z * l_n.z * a.x + l_n.x * l_n.x * a.z,
                    l_n.y * l_n.y * a.x + l_n.x * l_n.x * a.y,
                );
            }
        }
        let sd = var.map(f64::sqrt);
        (sd.iter().all(|x| x.is_finite() && *x > 0.0)).then_some(sd)
    };
    if i < sols.len() && sols[i].t == t {
        return point(&sols[i]);
    }
    if i == 0 || i >= sols.len() {
        return None;
    }
    let (a, b) = (&sols[i - 1], &sols[i]);
    let w = (t - a.t) / (b.t - a.t);
    Some(point(a)? * (1.0 - w) + point(b)? * w)
}

/// NEES of the position errors `errors` (from [`crate::evaluate`], lever
/// arm `lever_arm_b` as in its config) against the σ of `solution`
/// (time-ordered), over the run and inside `outages`.
pub fn consistency(
    solution: &[NavSolution],
    errors: &[ErrorEpoch],
    lever_arm_b: Option<[f64; 3]>,
    outages: Option<&[Outage]>,
) -> Consistency {
    let l_b = lever_arm_b.map(Vec3::from);
    let mut series = Vec::with_capacity(errors.len());
    let mut run = Acc::default();
    let mut inside = Acc::default();
    for e in errors {
        let Some(sd) = sigma_at(solution, e.t, l_b) else {
            continue;
        };
        let [n, ea, d] = e.pos_ned;
        let nh = (n / sd.x).powi(2) + (ea / sd.y).powi(2);
        let nv = (d / sd.z).powi(2);
        let sh = sd.x.hypot(sd.y);
        run.add(nh, nv, sh, e.horizontal);
        if outages.is_some_and(|o| o.iter().any(|o| o.contains(e.t))) {
            inside.add(nh, nv, sh, e.horizontal);
        }
        series.push((e.t, nh, nv));
    }
    Consistency {
        run: run.stats(),
        outages: outages.map(|_| inside.stats()),
        series,
    }
}

/// [`consistency`] of an [`crate::Evaluation`] of `solution` (with the
/// outages of `schedule` inside the solution span); `None` when no
/// solution epoch has a position σ.
pub fn consistency_of(
    solution: &[NavSolution],
    ev: &crate::Evaluation,
    schedule: Option<&crate::OutageSchedule>,
) -> Option<Consistency> {
    if !solution
        .iter()
        .any(|s| s.std_pos_ned.iter().all(|x| x.is_finite()))
    {
        return None;
    }
    let list = schedule.map(|sched| crate::outages_in_span(solution, sched));
    Some(consistency(
        solution,
        &ev.errors,
        ev.config.lever_arm_b,
        list.as_deref(),
    ))
}

/// The consistency table of `navfuse eval`.
pub fn render(c: &Consistency) -> String {
    use std::fmt::Write as _;
    let mut s = String::from("σ consistency (NEES; consistent: H 2, V 1; inside 68/95/99 %)\n");
    let mut row = |name: &str, n: &NeesStats| {
        let _ = writeln!(
            s,
            "  {name:<8} epochs {:>7}  NEES H {:>8.3} V {:>8.3}  inside H {:.3}/{:.3}/{:.3} V {:.3}/{:.3}/{:.3}  median σH {:.3} m, RMS eH {:.3} m",
            n.epochs,
            n.nees_h,
            n.nees_v,
            n.inside_h[0],
            n.inside_h[1],
            n.inside_h[2],
            n.inside_v[0],
            n.inside_v[1],
            n.inside_v[2],
            n.median_sigma_h,
            n.rms_error_h
        );
    };
    row("run", &c.run);
    if let Some(o) = &c.outages {
        row("outages", o);
    }
    s
}

#[derive(Default)]
struct Acc {
    nh: Vec<f64>,
    nv: Vec<f64>,
    sh: Vec<f64>,
    e2: f64,
}

impl Acc {
    fn add(&mut self, nh: f64, nv: f64, sh: f64, eh: f64) {
        self.nh.push(nh);
        self.nv.push(nv);
        self.sh.push(sh);
        self.e2 += eh * eh;
    }
    fn stats(mut self) -> NeesStats {
        let n = self.nh.len();
        if n == 0 {
            return NeesStats::default();
        }
        let share = |v: &[f64], q: f64| v.iter().filter(|x| **x <= q).count() as f64 / n as f64;
        let mean = |v: &[f64]| v.iter().sum::<f64>() / n as f64;
        self.sh.sort_by(f64::total_cmp);
        NeesStats {
            epochs: n,
            nees_h: mean(&self.nh),
            nees_v: mean(&self.nv),
            inside_h: CHI2_2DOF.map(|q| share(&self.nh, q)),
            inside_v: CHI2_1DOF.map(|q| share(&self.nv, q)),
            median_sigma_h: self.sh[n / 2],
            rms_error_h: (self.e2 / n as f64).sqrt(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sol(t: f64, sd: f64) -> NavSolution {
        let mut s = NavSolution::unknown_at(t);
        s.rpy = Vec3::zeros();
        s.std_pos_ned = Vec3::new(sd, sd, 2.0 * sd);
        s.std_rpy = Vec3::repeat(0.01);
        s
    }

    fn err(t: f64, n: f64, e: f64, d: f64) -> ErrorEpoch {
        ErrorEpoch {
            t,
            pos_ned: [n, e, d],
            horizontal: n.hypot(e),
            vertical: d.abs(),
            vel_ned: None,
            att_rpy: None,
        }
    }

    #[test]
    fn gaussian_errors_with_their_sigma_are_consistent_and_halved_sigma_is_not() {
        // Errors drawn N(0, σ²) per axis (deterministic normal stream).
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut u = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let mut z = move || (-2.0 * u().ln()).sqrt() * (std::f64::consts::TAU * u()).cos();
        let sols: Vec<NavSolution> = (0..4000).map(|k| sol(k as f64, 0.5)).collect();
        let errs: Vec<ErrorEpoch> = (0..4000)
            .map(|k| err(k as f64, 0.5 * z(), 0.5 * z(), 1.0 * z()))
            .collect();
        let out = [Outage {
            start: 1000.0,
            end: 2000.0,
        }];
        let c = consistency(&sols, &errs, None, Some(&out));
        assert_eq!(c.run.epochs, 4000);
        assert!((c.run.nees_h - 2.0).abs() < 0.15, "{:?}", c.run);
        assert!((c.run.nees_v - 1.0).abs() < 0.1, "{:?}", c.run);
        for (got, want) in c.run.inside_h.iter().zip([0.68, 0.95, 0.99]) {
            assert!((got - want).abs() < 0.03, "{:?}", c.run);
        }
        for (got, want) in c.run.inside_v.iter().zip([0.68, 0.95, 0.99]) {
            assert!((got - want).abs() < 0.03, "{:?}", c.run);
        }
        let o = c.outages.unwrap();
        assert!((999..=1001).contains(&o.epochs), "{o:?}");
        // The same errors against σ/2: NEES × 4, coverage far below 95 %.
        let half: Vec<NavSolution> = (0..4000).map(|k| sol(k as f64, 0.25)).collect();
        let h = consistency(&half, &errs, None, None);
        assert!((h.run.nees_h / c.run.nees_h - 4.0).abs() < 1e-9);
        assert!(h.run.inside_h[1] < 0.6, "{:?}", h.run);
        assert!(h.outages.is_none());
    }

    #[test]
    fn lever_arm_adds_attitude_variance_and_interpolates_between_epochs() {
        let sols = [sol(0.0, 0.1), sol(1.0, 0.3)];
        let l = Some(Vec3::new(10.0, 0.0, 0.0));
        // At 0.5 s: σN 0.2 (interpolated); σE² = 0.1² + (10·0.01)² at both ends.
        let sd = sigma_at(&sols, 0.5, l).unwrap();
        assert!((sd.x - 0.2).abs() < 1e-12, "{sd}");
        let e0 = (0.1f64.powi(2) + 0.01).sqrt();
        let e1 = (0.3f64.powi(2) + 0.01).sqrt();
        assert!((sd.y - 0.5 * (e0 + e1)).abs() < 1e-12, "{sd}");
        assert!(sigma_at(&sols, 1.5, l).is_none());
        let mut unknown = sols;
        unknown[1].std_pos_ned = Vec3::repeat(f64::NAN);
        assert!(sigma_at(&unknown, 0.5, None).is_none());
    }
}
