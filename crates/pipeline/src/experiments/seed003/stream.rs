//! Seed 003 through the streaming [`Estimator`] interface (issue 17, must
//! show 3): each simulated epoch becomes per-satellite
//! [`Event::CarrierPhase`] records, a [`CpAttStream`] per reported method
//! consumes them, and its [`NavSolution`] attitude (NED/FRD ZYX, default
//! mounting) is turned back into the paper's angles exactly
//! ([`paper_rpy_from_ned_default`]), so Table 1 computed from these rows
//! must equal the batch [`run_scene`](super::super::attitude::run_scene)'s
//! to the last bit (`navfuse experiment seed003 --via-estimator`).

use super::super::attitude::{Row, SceneRun};
use navfuse_core::estimators::cp_att_stream::{
    epoch_records, paper_rpy_from_ned_default, CpAttStream, CpAttStreamConfig,
};
use navfuse_core::estimators::cp_attitude::{CpAttConfig, CpAttOutput, FixConfig};
use navfuse_core::types::{Estimator, Event, NavSolution};
use navfuse_core::Vec3;
use navfuse_sim::carrier_phase::{SceneConfig, SceneEpoch};

/// The scene's measurements as the event stream a recording would give.
pub fn scene_events(scene: &[SceneEpoch]) -> Vec<Event> {
    scene
        .iter()
        .flat_map(|s| epoch_records(&s.epoch).map(Event::CarrierPhase))
        .collect()
}

/// A row with the truth and no estimate.
fn truth_row(s: &SceneEpoch) -> Row {
    let nan = Vec3::repeat(f64::NAN);
    Row {
        t: s.epoch.t,
        n_sats: s.epoch.n_sats,
        rpy_true: s.rpy,
        rpy_float: nan,
        rpy_float_wahba: nan,
        rpy_fixed: None,
        rpy_wahba: None,
        rpy_joint: None,
        rpy_smoothed: None,
        att_nis: f64::NAN,
        joint_ssr: f64::NAN,
        fix_correct: None,
        by_lambda: false,
        amb_err0: f64::NAN,
        amb_sd0: f64::NAN,
        amb: Vec::new(),
    }
}

/// Run one [`CpAttStream`] over `events` through [`Estimator::push`] (and
/// the end-of-stream flush); its solutions in time order.
pub fn stream_solutions(cfg: CpAttStreamConfig, events: &[Event]) -> Vec<NavSolution> {
    let mut est = CpAttStream::new(cfg).expect("seed 003 geometry is valid");
    let mut out = Vec::with_capacity(events.len());
    for ev in events {
        out.extend(Estimator::push(&mut est, ev));
    }
    out.extend(est.flush());
    out
}

/// [`run_scene`](super::super::attitude::run_scene)'s rows (truth and the
/// float, float-Wahba and, with `fix`, the fixed, fixed-Wahba and joint
/// attitudes) computed through the `cp-att` [`Estimator`]: one stream per
/// method, no float fallback. The float methods run without fixing (fixing
/// never touches the float filters). Ambiguity diagnostics stay empty.
pub fn run_scene_via_estimator(
    scene: &[SceneEpoch],
    cfg: &SceneConfig,
    fcfg: CpAttConfig,
    fix: Option<FixConfig>,
) -> SceneRun {
    let events = scene_events(scene);
    let mut rows: Vec<Row> = scene.iter().map(truth_row).collect();
    let mut methods = vec![CpAttOutput::Float, CpAttOutput::FloatWahba];
    if fix.is_some() {
        methods.extend([
            CpAttOutput::Fixed,
            CpAttOutput::FixedWahba,
            CpAttOutput::FixedJoint,
        ]);
    }
    for m in methods {
        let float = matches!(m, CpAttOutput::Float | CpAttOutput::FloatWahba);
        let scfg = CpAttStreamConfig {
            filter: fcfg,
            fix: if float { None } else { fix },
            output: m,
            fallback_float: false,
            ..CpAttStreamConfig::new(&cfg.b_b)
        };
        let mut k = 0;
        for sol in stream_solutions(scfg, &events) {
            while rows[k].t < sol.t {
                k += 1;
            }
            let r = &mut rows[k];
            let v = paper_rpy_from_ned_default(&sol.rpy);
            match m {
                CpAttOutput::Float => r.rpy_float = v,
                CpAttOutput::FloatWahba => r.rpy_float_wahba = v,
                CpAttOutput::Fixed => r.rpy_fixed = Some(v),
                CpAttOutput::FixedWahba => r.rpy_wahba = Some(v),
                CpAttOutput::FixedJoint => r.rpy_joint = Some(v),
            }
        }
    }
    SceneRun {
        rows,
        ..Default::default()
    }
}
