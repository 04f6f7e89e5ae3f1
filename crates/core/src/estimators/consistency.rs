//! Self-checks of a Kalman filter from its own innovations, and the aiding
//! status of each epoch. Fed with the filter's update journal
//! ([`UpdateLog`]); fixed-size state, nothing allocated per update.
//!
//! **NIS test** (Bar-Shalom, Li & Kirubarajan 2001, §5.4.2): for a
//! consistent filter the normalised innovation squared `ε_ν = νᵀS⁻¹ν` of an
//! `m`-dimensional update is χ²(m); the sum over a run of `N` updates is
//! χ²(Σm) (innovations are white), so `q = Σε_ν / Σm` has mean 1 and a
//! two-sided 95 % interval `[χ²_{0.025}(Σm), χ²_{0.975}(Σm)] / Σm`.
//! [`NisMonitor`] keeps these sums per measurement type over the run and
//! over fixed windows ([`NIS_WINDOW_S`]).

use super::eskf::{UpdateKind, UpdateLog};
use crate::kalman::chi2_quantile;

/// Number of [`UpdateKind`]s (array size of the per-type statistics).
pub const N_KINDS: usize = 11;

/// Every update kind, in the index order of [`kind_index`].
pub const KINDS: [UpdateKind; N_KINDS] = [
    UpdateKind::GnssPosition,
    UpdateKind::GnssVelocity,
    UpdateKind::Height,
    UpdateKind::Zupt,
    UpdateKind::Zaru,
    UpdateKind::Nhc,
    UpdateKind::Odometer,
    UpdateKind::Heading,
    UpdateKind::Mag,
    UpdateKind::Pseudorange,
    UpdateKind::Doppler,
];

/// Index of `k` in [`KINDS`].
pub fn kind_index(k: UpdateKind) -> usize {
    match k {
        UpdateKind::GnssPosition => 0,
        UpdateKind::GnssVelocity => 1,
        UpdateKind::Height => 2,
        UpdateKind::Zupt => 3,
        UpdateKind::Zaru => 4,
        UpdateKind::Nhc => 5,
        UpdateKind::Odometer => 6,
        UpdateKind::Heading => 7,
        UpdateKind::Mag => 8,
        UpdateKind::Pseudorange => 9,
        UpdateKind::Doppler => 10,
    }
}

/// Window of the windowed NIS test [s]: ten 1 Hz GNSS epochs (30 degrees
/// of freedom for a position), enough for the χ² bounds of one window to
/// mean something, short against a drive.
pub const NIS_WINDOW_S: f64 = 10.0;

/// The mean NIS per degree of freedom above which a run is called
/// overconfident (besides being outside its sampling interval). Real
/// innovations are not white (GNSS errors correlated for tens of seconds),
/// which makes the χ² interval of a long run far too narrow; a factor 2 in
/// NIS means innovation σ understated by √2, the upper end of the honest
/// band of issue 20 (2-D NEES ≤ 4, i.e. ≤ 2 per degree of freedom).
pub const OVERCONFIDENT_RATIO: f64 = 2.0;

/// Floor of `t` as an integer second.
fn floor_s(t: f64) -> i64 {
    let i = t as i64;
    if (i as f64) > t {
        i - 1
    } else {
        i
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct KindSums {
    n: u64,
    gated: u64,
    sum_nis: f64,
    sum_dof: u64,
    above95: u64,
    win_start: f64,
    win_nis: f64,
    win_dof: u64,
    windows: u64,
    windows_above: u64,
    windows_below: u64,
}

/// Per-type NIS sums over the run and over [`NIS_WINDOW_S`] windows.
#[derive(Clone, Copy, Debug, Default)]
pub struct NisMonitor {
    k: [KindSums; N_KINDS],
}

/// The NIS verdict of one measurement type.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NisStats {
    pub kind: UpdateKind,
    /// Updates tried (accepted or gated) and of them gated.
    pub updates: u64,
    pub gated: u64,
    /// `Σ NIS / Σ dof` over every update tried (1 when consistent).
    pub mean_per_dof: f64,
    /// Two-sided 95 % interval of `mean_per_dof` for a consistent filter
    /// with white innovations.
    pub ci95: (f64, f64),
    /// Share of updates with NIS above the χ²(dof) 95 % quantile (0.05 when
    /// consistent).
    pub share_above95: f64,
    /// Complete windows, and of them with a mean NIS above / below the
    /// two-sided 99 % χ² interval of the window.
    pub windows: u64,
    pub windows_above: u64,
    pub windows_below: u64,
    /// `mean_per_dof` above both the 95 % interval and [`OVERCONFIDENT_RATIO`].
    pub overconfident: bool,
}

impl NisMonitor {
    /// Add one update of the journal.
    pub fn observe(&mut self, u: &UpdateLog) {
        if !u.nis.is_finite() || u.dof == 0 {
            return;
        }
        let s = &mut self.k[kind_index(u.kind)];
        let dof = u.dof as u64;
        if s.win_dof == 0 {
            s.win_start = u.t;
        } else if u.t - s.win_start >= NIS_WINDOW_S {
            Self::close_window(s);
            s.win_start = u.t;
        }
        s.n += 1;
        s.gated += u64::from(!u.accepted);
        s.sum_nis += u.nis;
        s.sum_dof += dof;
        s.above95 += u64::from(u.nis > chi2_q95(u.dof));
        s.win_nis += u.nis;
        s.win_dof += dof;
    }

    fn close_window(s: &mut KindSums) {
        let d = s.win_dof as usize;
        if d > 0 {
            s.windows += 1;
            if s.win_nis > chi2_quantile(d, 0.995) {
                s.windows_above += 1;
            } else if s.win_nis < chi2_quantile(d, 0.005) {
                s.windows_below += 1;
            }
        }
        s.win_nis = 0.0;
        s.win_dof = 0;
    }

    /// The verdict of `kind` (`None`: no update of that type).
    pub fn stats(&self, kind: UpdateKind) -> Option<NisStats> {
        let s = self.k[kind_index(kind)];
        if s.n == 0 {
            return None;
        }
        let d = s.sum_dof as usize;
        let mean = s.sum_nis / d as f64;
        let ci95 = (
            chi2_quantile(d, 0.025) / d as f64,
            chi2_quantile(d, 0.975) / d as f64,
        );
        // The window in progress counts when it is complete enough to be
        // tested like the others (a run's last partial window is not).
        Some(NisStats {
            kind,
            updates: s.n,
            gated: s.gated,
            mean_per_dof: mean,
            ci95,
            share_above95: s.above95 as f64 / s.n as f64,
            windows: s.windows,
            windows_above: s.windows_above,
            windows_below: s.windows_below,
            overconfident: mean > ci95.1 && mean > OVERCONFIDENT_RATIO,
        })
    }
}

/// χ²(dof) 95 % quantile for the dimensions of the filter's updates.
fn chi2_q95(dof: u8) -> f64 {
    match dof {
        1 => 3.841_458_820_694_124,
        2 => 5.991_464_547_107_979,
        3 => 7.814_727_903_251_178,
        d => chi2_quantile(d as usize, 0.95),
    }
}

/// What aided an epoch (the status column of `solution.std`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EpochStatus {
    /// The last accepted update, `None` ("coast") when none was accepted
    /// within the coast threshold.
    pub aid: Option<UpdateKind>,
    /// Seconds since the last accepted position update (GNSS position or
    /// height), or since the tracker's start when there was none.
    pub since_pos_s: f64,
    /// Updates gated (rejected) in the last 10 s (whole seconds).
    pub gated_10s: u32,
}

impl EpochStatus {
    /// `gnss_pos`, `nhc`, … or `coast`.
    pub fn aid_name(&self) -> &'static str {
        self.aid.map_or("coast", UpdateKind::name)
    }
}

/// Tracks [`EpochStatus`] from the update journal (fixed size).
#[derive(Clone, Copy, Debug)]
pub struct AidTracker {
    coast_after_s: f64,
    last: Option<(UpdateKind, f64)>,
    t_last_pos: f64,
    /// Gated counts per whole second, ring of 10 (second, count).
    gated: [(i64, u32); 10],
}

impl AidTracker {
    /// Start at `t0` [s]; an epoch is coasting after `coast_after_s` without
    /// any accepted update.
    pub fn new(t0: f64, coast_after_s: f64) -> Self {
        AidTracker {
            coast_after_s,
            last: None,
            t_last_pos: t0,
            gated: [(i64::MIN, 0); 10],
        }
    }

    /// Add one update of the journal.
    pub fn observe(&mut self, u: &UpdateLog) {
        if u.accepted {
            self.last = Some((u.kind, u.t));
            if matches!(
                u.kind,
                UpdateKind::GnssPosition | UpdateKind::Height | UpdateKind::Pseudorange
            ) {
                self.t_last_pos = u.t;
            }
        } else {
            let sec = floor_s(u.t);
            let slot = &mut self.gated[sec.rem_euclid(10) as usize];
            if slot.0 != sec {
                *slot = (sec, 0);
            }
            slot.1 += 1;
        }
    }

    /// The status at time `t` [s] (after the updates observed so far).
    pub fn status(&self, t: f64) -> EpochStatus {
        let now = floor_s(t);
        let aid = match self.last {
            Some((k, tk)) if t - tk <= self.coast_after_s => Some(k),
            _ => None,
        };
        EpochStatus {
            aid,
            since_pos_s: t - self.t_last_pos,
            gated_10s: self
                .gated
                .iter()
                .filter(|(s, _)| *s > now - 10 && *s <= now)
                .map(|(_, c)| c)
                .sum(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn log(t: f64, kind: UpdateKind, nis: f64, dof: u8, accepted: bool) -> UpdateLog {
        UpdateLog {
            t,
            kind,
            nis,
            dof,
            accepted,
        }
    }

    /// A deterministic stand-in for χ²(3) draws: sums of three squared
    /// standard normals from a Box–Muller over an xorshift stream.
    fn chi2_3(n: usize, scale: f64) -> impl Iterator<Item = f64> {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let mut u = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..n).map(move |_| {
            let mut acc = 0.0;
            for _ in 0..3 {
                let (a, b) = (u(), u());
                let z = (-2.0 * a.ln()).sqrt() * (2.0 * core::f64::consts::PI * b).cos();
                acc += z * z;
            }
            acc * scale
        })
    }

    #[test]
    fn consistent_nis_passes_and_inflated_nis_is_flagged() {
        let mut ok = NisMonitor::default();
        for (i, x) in chi2_3(2000, 1.0).enumerate() {
            ok.observe(&log(i as f64, UpdateKind::GnssPosition, x, 3, true));
        }
        let s = ok.stats(UpdateKind::GnssPosition).unwrap();
        assert!(!s.overconfident, "{s:?}");
        assert!(
            s.ci95.0 <= s.mean_per_dof && s.mean_per_dof <= s.ci95.1,
            "{s:?}"
        );
        assert!((s.share_above95 - 0.05).abs() < 0.015, "{s:?}");
        assert_eq!(s.windows, 199, "10 s windows over 2000 s (last open)");
        assert!(s.windows_above <= 6, "{s:?}");
        // σ × 0.1 in R ⇒ NIS × 100 for measurement-noise-dominated innovations;
        // already × 2.5 (σ understated by 37 %) is beyond the practical bound.
        let mut bad = NisMonitor::default();
        for (i, x) in chi2_3(2000, 2.5).enumerate() {
            bad.observe(&log(i as f64, UpdateKind::GnssPosition, x, 3, i % 7 != 0));
        }
        let b = bad.stats(UpdateKind::GnssPosition).unwrap();
        assert!(b.overconfident && b.windows_above > 100, "{b:?}");
        assert_eq!(b.gated, 286);
        assert!(bad.stats(UpdateKind::Nhc).is_none());
    }

    #[test]
    fn aid_status_tracks_last_update_coasting_and_gated_counts() {
        let mut a = AidTracker::new(100.0, 2.5);
        assert_eq!(a.status(100.5).aid_name(), "coast");
        assert_eq!(a.status(100.5).since_pos_s, 0.5);
        a.observe(&log(101.0, UpdateKind::GnssPosition, 1.0, 3, true));
        a.observe(&log(101.2, UpdateKind::Nhc, 1.0, 2, true));
        for k in 0..4 {
            a.observe(&log(
                102.0 + k as f64,
                UpdateKind::GnssPosition,
                99.0,
                3,
                false,
            ));
        }
        let s = a.status(105.5);
        assert_eq!(s.aid_name(), "coast", "nothing accepted for 4.3 s");
        assert!((s.since_pos_s - 4.5).abs() < 1e-12);
        assert_eq!(s.gated_10s, 4);
        assert_eq!(a.status(103.0).aid, Some(UpdateKind::Nhc));
        // Gated counts leave the 10 s window.
        assert_eq!(a.status(112.5).gated_10s, 3, "seconds 103…105 remain");
        assert_eq!(a.status(120.0).gated_10s, 0);
    }
}
