//! A bank of ESKFs over yaw hypotheses: in-motion alignment when the heading
//! is unknown and the platform's course is not its heading (pedestrian,
//! multirotor, boat).
//!
//! The yaw Gaussian-sum filter ([`navfuse_core::ins::yaw_gsf`]) narrows the
//! heading slowly on its own: it has no position states and no gyro-bias
//! state, so a walker at 1 m/s waits tens of seconds before its mixture σ is
//! small. A full ESKF started within its small-angle region of the truth
//! (≲ 15°) pulls the yaw in within seconds of the first turn, because the
//! GNSS positions (cm with RTK) see the velocity error `δψ × Δv` integrate.
//! So the hand-over starts a full ESKF ([`Member`]) at every point of a yaw
//! grid inside the ESKF's small-angle region of its neighbours (σ 5°,
//! spacing 10°) where the GSF's mixture density is still significant, its
//! prior weight that density (Gaussian-sum filtering with
//! full filters, Groves 2nd ed. §3.4.5; the same multiple-model idea as PX4's
//! EKF-GSF, one level up). All members see the same events; each member's
//! log-likelihood is `−½ Σ NIS` of its GNSS updates (the `ln |S|` term is
//! left out: the members share R, which dominates S after the first epochs).
//!
//! The bank starts at the first epoch the tilt is known. Two members whose
//! yaws are within the smaller of their yaw σ hold the same hypothesis
//! twice: they merge (weights add) into the one whose own hypothesis needed
//! the smaller yaw correction ([`Member::yaw_moved`]) — the other got there
//! from further than its prior σ and its bias state absorbed part of the
//! way (walker, seed 11 of the align check: a member started 27° off at σ
//! 5° won on score, with its z-gyro bias 600°/h off, 2.5σ of the turn-on
//! spec, and drifted 3° on the next straight). A member is also dropped —
//! only once the yaw is
//! observable ([`BankGate::t_observable`]: the GSF's test for a significant
//! horizontal acceleration has passed) — when its likelihood, counted from
//! that epoch on (times its prior), is below [`PRUNE_RATIO`]⁻¹ of the best.
//! Before that every yaw explains a constant velocity, and the likelihood
//! spread is model error (the members' biases absorb a wrong yaw), not
//! evidence: seen on a multirotor with a consumer IMU cruising at 12 m/s,
//! where the spread gathered before the first acceleration picked a member
//! 150° off, or decided within 2 s of it for one that doubled the position
//! error. The bank is resolved when one member
//! is left; its whole history from the bank start becomes the run's output
//! (post-processing: the choice is made with hindsight, nothing is output
//! twice). At most [`MAX_BANK_S`] after the start one member continues
//! alone, its covariance unchanged: the best if the yaw was observable by
//! then, else the one closest to the GSF's mixture mean
//! ([`BankGate::fallback_yaw`]) — the score of an unobservable contest
//! is no evidence.
//!
//! Frames: body FRD, nav NED; angles in rad.

use navfuse_core::attitude::wrap_pi;
use navfuse_core::estimators::consistency::{AidTracker, NisMonitor};
use navfuse_core::estimators::eskf::{Eskf, SmootherRecord, UpdateKind, UpdateLog};
use navfuse_core::types::{Estimator, Event, GnssFix, ImuSample, NavSolution};
use navfuse_io::stdfile::StdRow;

/// Likelihood ratio at which a member is dropped: posterior odds of 1000:1
/// against it with equal priors (a 3.7σ-equivalent decision; a wrong drop
/// costs the run its heading, so the evidence asked for is strong).
pub const PRUNE_RATIO: f64 = 1000.0;
/// Longest the bank runs [s]: a cost bound (≤ 12 filters in parallel), not
/// a tuning; a heading still ambiguous after 2 min of data is one the motion
/// does not reveal, and the best member goes on with its honest covariance.
pub const MAX_BANK_S: f64 = 120.0;

/// When the bank may decide, from the GSF run over the same data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BankGate {
    /// GPS time [s] of the first GNSS epoch at which the GSF saw a
    /// significant horizontal acceleration (+∞: none within [`MAX_BANK_S`]).
    pub t_observable: f64,
    /// GSF mixture yaw [rad] at the end of the bank's time bound (used only
    /// when the yaw never became observable).
    pub fallback_yaw: f64,
}

/// One filter of the bank and everything it has output.
pub(crate) struct Member {
    pub eskf: Eskf,
    pub sols: Vec<NavSolution>,
    pub records: Vec<SmootherRecord>,
    pub innovations: Vec<UpdateLog>,
    /// ½ Σ NIS of the GNSS updates so far (the negative log-likelihood up to
    /// a constant shared by the members).
    pub score: f64,
    /// Aiding status of each epoch (for the σ rows) and the NIS self-check.
    pub aid: AidTracker,
    pub nis: NisMonitor,
    /// σ rows of every solution ([`Member::tracking`] with `with_std`).
    pub std: Vec<StdRow>,
    with_std: bool,
    /// −ln of the prior weight (the score at the bank's start; the score is
    /// reset to it when the yaw becomes observable).
    prior: f64,
    /// Sum of the yaw corrections the filter's updates applied since the
    /// member's start [rad]: its yaw minus its hypothesis carried by the
    /// gyro (Euler-rate kinematics with the member's own tilt and bias
    /// estimate). See [`prune`] for why it matters.
    pub yaw_moved: f64,
}

impl Member {
    /// A member around `eskf`, with `cap` solutions reserved.
    pub fn new(eskf: Eskf, cap: usize) -> Self {
        Member {
            eskf,
            sols: Vec::with_capacity(cap),
            records: Vec::new(),
            innovations: Vec::new(),
            score: 0.0,
            aid: AidTracker::new(f64::NAN, f64::INFINITY),
            nis: NisMonitor::default(),
            std: Vec::new(),
            with_std: false,
            prior: 0.0,
            yaw_moved: 0.0,
        }
    }

    /// Track the aiding status from `t0` (coasting after `coast_after_s`
    /// without a position update) and, with `with_std`, keep a σ row per
    /// solution.
    pub fn tracking(mut self, t0: f64, coast_after_s: f64, with_std: bool) -> Self {
        self.aid = AidTracker::new(t0, coast_after_s);
        self.with_std = with_std;
        if with_std {
            self.std.reserve(self.sols.capacity());
        }
        self
    }

    fn take_updates(&mut self) {
        for u in self.eskf.updates() {
            self.aid.observe(u);
            self.nis.observe(u);
            if matches!(
                u.kind,
                UpdateKind::GnssPosition | UpdateKind::GnssVelocity | UpdateKind::Height
            ) && u.nis.is_finite()
            {
                self.score += 0.5 * u.nis;
            }
        }
        self.innovations.extend_from_slice(self.eskf.updates());
    }

    /// Feed one aiding event (a GNSS fix, a heading, …) between IMU samples.
    pub fn aid(&mut self, ev: &Event) {
        self.eskf.push(ev);
        self.take_updates();
    }

    /// Feed the fixes `fixes` (all at or before `s.t`) and then the IMU sample `s`.
    pub fn step(&mut self, fixes: &[GnssFix], s: &ImuSample) {
        // Yaw the mechanisation alone would give at the end of `s`: ψ̇ =
        // (sin φ ω_y + cos φ ω_z)/cos θ (Groves 2nd ed. eq. 2.58), with the
        // bias estimate removed; earth and transport rate (≤ 15°/h) ignored.
        let rpy0 = self.eskf.nav().rpy();
        let w = s.dtheta_b - self.eskf.imu_errors().bg * s.dt;
        let (sr, cr) = rpy0.x.sin_cos();
        let predicted = rpy0.z + (sr * w.y + cr * w.z) / rpy0.y.cos().max(1e-3);
        for f in fixes {
            self.eskf.push(&Event::Gnss(*f));
            self.take_updates();
        }
        let sol = self.eskf.push(&Event::Imu(*s));
        self.take_updates();
        if self.eskf.time() >= s.t - 1e-9 {
            self.yaw_moved += wrap_pi(self.eskf.nav().rpy().z - predicted);
        }
        if let Some(sol) = sol {
            if self.with_std {
                let p = self.eskf.reported_covariance();
                let row = crate::sigma::std_row(
                    sol.t,
                    &p.diagonal(),
                    navfuse_core::estimators::eskf::pos_cross_ned(p),
                    Some(self.aid.status(sol.t)),
                );
                self.std.push(row);
            }
            self.sols.push(sol);
        }
        if let Some(r) = self.eskf.take_record() {
            self.records.push(r);
        }
    }

    fn yaw(&self) -> (f64, f64) {
        self.sols
            .last()
            .map_or((f64::NAN, f64::NAN), |s| (s.rpy.z, s.std_rpy.z))
    }
}

/// What the bank did (the summary's alignment text).
pub(crate) struct BankOutcome {
    /// The member left (or the best at [`MAX_BANK_S`]).
    pub winner: Member,
    /// Index of the next IMU sample and of the next fix to feed.
    pub k_next: usize,
    pub g_next: usize,
    /// Fixes fed during the bank.
    pub gnss_fed: usize,
    pub description: String,
}

/// Run the bank `members` over `imu[k_start..]` and the fixes from
/// `gnss[g_start..]` until it is resolved (see the module doc).
pub(crate) fn run_bank(
    mut members: Vec<Member>,
    imu: &[ImuSample],
    gnss: &[GnssFix],
    k_start: usize,
    g_start: usize,
    gate: BankGate,
) -> BankOutcome {
    let n0 = members.len();
    let t0 = imu[k_start].t;
    let (mut k, mut g, mut fed) = (k_start, g_start, 0usize);
    let ln_prune = PRUNE_RATIO.ln();
    for m in members.iter_mut() {
        m.prior = m.score;
    }
    let mut was_obs = imu[k_start].t >= gate.t_observable;
    let mut why = "the data ended";
    while k < imu.len() && members.len() > 1 {
        let s = &imu[k];
        let g0 = g;
        while g < gnss.len() && gnss[g].t <= s.t + 1e-3 {
            g += 1;
        }
        fed += g - g0;
        for m in members.iter_mut() {
            m.step(&gnss[g0..g], s);
        }
        k += 1;
        // The likelihood counts from the epoch the yaw became observable:
        // the spread gathered before it is the members' model error (their
        // biases absorbing a wrong yaw at constant velocity), not evidence.
        if !was_obs && s.t >= gate.t_observable {
            was_obs = true;
            for m in members.iter_mut() {
                m.score = m.prior;
            }
        }
        if g > g0 {
            let ln = if s.t >= gate.t_observable {
                ln_prune
            } else {
                f64::INFINITY
            };
            prune(&mut members, ln);
        }
        if s.t - t0 >= MAX_BANK_S {
            why = "the time limit";
            break;
        }
    }
    let resolved = members.len() == 1;
    let t_last = imu[k.saturating_sub(1).min(imu.len() - 1)].t;
    let observable = t_last >= gate.t_observable;
    let mut kept = "best";
    let best = if observable || !gate.fallback_yaw.is_finite() {
        members
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.score.total_cmp(&b.1.score))
            .map_or(0, |(i, _)| i)
    } else {
        kept = "yaw unobservable: the one closest to the GSF's yaw";
        closest(&members, gate.fallback_yaw)
    };
    let winner = members.swap_remove(best);
    let (yaw, std) = winner.yaw();
    let t_end = imu[k.min(imu.len() - 1)].t;
    let description = if resolved {
        format!(
            "bank of {n0} ESKFs over yaw hypotheses resolved {:.1} s after its start: \
             yaw {:.1}° ± {:.1}°",
            t_end - t0,
            yaw.to_degrees(),
            std.to_degrees()
        )
    } else {
        format!(
            "bank of {n0} ESKFs over yaw hypotheses not resolved ({why}, {} left): \
             {kept} kept, yaw {:.1}° ± {:.1}°",
            members.len() + 1,
            yaw.to_degrees(),
            std.to_degrees()
        )
    };
    BankOutcome {
        winner,
        k_next: k,
        g_next: g,
        gnss_fed: fed,
        description,
    }
}

/// Index of the member whose yaw is closest to `yaw` [rad].
fn closest(members: &[Member], yaw: f64) -> usize {
    members
        .iter()
        .enumerate()
        .min_by(|a, b| {
            let da = wrap_pi(a.1.yaw().0 - yaw).abs();
            let db = wrap_pi(b.1.yaw().0 - yaw).abs();
            da.total_cmp(&db)
        })
        .map_or(0, |(i, _)| i)
}

/// The smaller of two members' yaw σ [rad].
fn std_min(a: &Member, b: &Member) -> f64 {
    a.yaw().1.min(b.yaw().1)
}

/// Drop members whose likelihood is below 1/[`PRUNE_RATIO`] of the best,
/// and members that repeat a better member's yaw (within the smaller σ).
/// `ln_prune = ∞` drops repeats only (the yaw not yet observable).
fn prune(members: &mut Vec<Member>, ln_prune: f64) {
    let best = members
        .iter()
        .map(|m| m.score)
        .fold(f64::INFINITY, f64::min);
    members.retain(|m| m.score - best <= ln_prune);
    members.sort_by(|a, b| a.score.total_cmp(&b.score));
    let mut i = 1;
    while i < members.len() {
        let (yi, si) = members[i].yaw();
        let dup = members[..i].iter().position(|b| {
            let (yb, sb) = b.yaw();
            wrap_pi(yi - yb).abs() < si.min(sb)
        });
        if let Some(b) = dup {
            // One posterior mode held twice: the components merge (their
            // weights add, Groves 2nd ed. §3.4.5; the covariance keeps their
            // spread, Eskf::add_mixture_spread), and the filter kept is the
            // one whose hypothesis needed the smaller yaw correction to get
            // there. The other started further from this yaw than its prior
            // σ allowed (e.g. 27° at σ 5°): on the way its linearised
            // filter put part of the yaw error into the correlated states
            // (the z-gyro bias) and its covariance no longer describes its
            // error. Its likelihood since the observability reset is no
            // guide: both explain the same data from then on.
            let (score_b, score_i) = (members[b].score, members[i].score);
            let merged = score_b.min(score_i) - (-(score_b - score_i).abs()).exp().ln_1p();
            // (A difference within the yaw σ is no difference.)
            let tol = std_min(&members[b], &members[i]);
            if members[i].yaw_moved.abs() + tol < members[b].yaw_moved.abs() {
                members.swap(b, i);
            }
            // The filter kept stands for both: its covariance takes the
            // other's offset from it (in yaw within σ, but possibly far in
            // the z-gyro bias or tilt that absorbed a wrong start), weighted
            // by the other's share of the merged weight.
            let w_i = 1.0 / (1.0 + (members[i].score - members[b].score).exp());
            let dx = {
                let o = &members[i].eskf;
                members[b].eskf.error_state_to(o.nav(), o.imu_errors())
            };
            members[b].eskf.add_mixture_spread(&dx, w_i);
            members[b].score = merged;
            members.remove(i);
        } else {
            i += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use navfuse_core::estimators::eskf::{EskfConfig, ImuErrors, InitStd};
    use navfuse_core::ins::mech::{q_bn_from_rpy, NavState};
    use navfuse_core::Vec3;

    /// A member at yaw `yaw_deg` with yaw σ `std_deg`, score `score`, after
    /// two level IMU samples at rest (so it has a solution).
    fn member(yaw_deg: f64, std_deg: f64, score: f64) -> Member {
        let nav = NavState {
            q_bn: q_bn_from_rpy(&Vec3::new(0.0, 0.0, yaw_deg.to_radians())),
            lat: 0.7,
            ..Default::default()
        };
        let std = InitStd {
            pos: Vec3::repeat(0.1),
            vel: Vec3::repeat(0.1),
            att: Vec3::new(0.01, 0.01, std_deg.to_radians()),
            bg: Vec3::repeat(1e-4),
            ba: Vec3::repeat(0.01),
            sg: Vec3::zeros(),
            sa: Vec3::zeros(),
        };
        let eskf = Eskf::new(EskfConfig::seed001(), nav, ImuErrors::default(), &std);
        let mut m = Member::new(eskf, 4);
        for k in 1..=3 {
            let s = ImuSample {
                t: k as f64 * 0.01,
                dt: 0.01,
                dtheta_b: Vec3::zeros(),
                dvel_b: Vec3::new(0.0, 0.0, -9.8 * 0.01),
            };
            m.step(&[], &s);
        }
        m.score = score;
        m
    }

    /// Pruning keeps the best, drops a member 1000:1 less likely and a
    /// member repeating a better one's yaw within σ, and keeps a distinct
    /// hypothesis whose evidence is not yet decisive.
    #[test]
    fn prune_drops_unlikely_and_repeated_members_only() {
        let mut ms = vec![
            member(10.0, 3.0, 5.0),                           // best
            member(11.0, 2.0, 6.0),                           // same yaw within both σ: repeat
            member(13.0, 2.0, 6.0),                           // 3° away, σ 2°: distinct
            member(40.0, 3.0, 5.0 + PRUNE_RATIO.ln() - 0.1),  // distinct, not decisive
            member(-80.0, 3.0, 5.0 + PRUNE_RATIO.ln() + 0.1), // 1000:1 against
        ];
        assert!(ms.iter().all(|m| m.yaw().0.is_finite()));
        prune(&mut ms, PRUNE_RATIO.ln());
        let yaws: Vec<f64> = ms.iter().map(|m| m.yaw().0.to_degrees().round()).collect();
        assert_eq!(yaws, vec![10.0, 13.0, 40.0]);
    }

    /// Before the yaw is observable (ln ratio ∞) only repeats are dropped,
    /// however large the likelihood spread.
    #[test]
    fn prune_keeps_unlikely_members_while_unobservable() {
        let mut ms = vec![
            member(10.0, 3.0, 5.0),
            member(11.0, 2.0, 6.0),    // repeat of the best
            member(-80.0, 3.0, 500.0), // far less likely, kept
        ];
        prune(&mut ms, f64::INFINITY);
        let yaws: Vec<f64> = ms.iter().map(|m| m.yaw().0.to_degrees().round()).collect();
        assert_eq!(yaws, vec![10.0, -80.0]);
    }

    /// Two members at the same yaw merge: the one whose hypothesis needed
    /// the smaller yaw correction stays, even with the worse score, and
    /// carries the summed weight (−ln(e^−a + e^−b)).
    #[test]
    fn repeats_keep_the_least_moved_member_with_the_summed_weight() {
        let mut far = member(10.0, 3.0, 5.0); // best score, moved 27° to get here
        far.yaw_moved = 27f64.to_radians();
        let mut near = member(11.0, 2.0, 6.0); // same yaw, moved 3°
        near.yaw_moved = (-3f64).to_radians();
        let mut ms = vec![far, near, member(60.0, 3.0, 7.0)];
        prune(&mut ms, PRUNE_RATIO.ln());
        assert_eq!(ms.len(), 2);
        assert_eq!(ms[0].yaw().0.to_degrees().round(), 11.0);
        let merged = -((-5.0f64).exp() + (-6.0f64).exp()).ln();
        assert!((ms[0].score - merged).abs() < 1e-12, "{}", ms[0].score);
        assert_eq!(ms[1].yaw().0.to_degrees().round(), 60.0);
    }

    /// The fallback member is the one nearest the GSF's yaw across ±180°,
    /// whatever the scores.
    #[test]
    fn closest_wraps_around_pi() {
        let ms = vec![
            member(170.0, 5.0, 0.0),
            member(-175.0, 5.0, 50.0),
            member(0.0, 5.0, 1.0),
        ];
        assert_eq!(closest(&ms, (-179.0f64).to_radians()), 1);
        assert_eq!(closest(&ms, (176.0f64).to_radians()), 0);
        assert_eq!(closest(&ms, (20.0f64).to_radians()), 2);
    }
}
