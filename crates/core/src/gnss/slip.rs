//! Dual-frequency cycle-slip detectors per satellite, without any position
//! or INS: the **geometry-free** phase jump and the **Melbourne–Wübbena**
//! wide-lane (issue 15). Pure, fixed capacity ([`SLIP_SATS`] satellites),
//! no allocation.
//!
//! Inputs are per satellite and epoch: the carrier phases `L1`, `L2` and
//! the pseudoranges `P1`, `P2` [m] on the two frequencies `f1 > f2`, of one
//! receiver or single-differenced between two (rover − base: the receiver
//! clocks, which the two combinations cancel anyway, and most of the
//! ionosphere drop out), with their variances.
//!
//! **Geometry-free (GF)**, `GF = L1 − L2 = (γ−1) I₁ + λ₁N₁ − λ₂N₂ + const`
//! (`γ = f1²/f2²`, `I₁` the L1 ionospheric delay): range, clocks and
//! troposphere cancel, so between two epochs only the ionosphere changes.
//! A slip is flagged when `|ΔGF| > k σ_ΔGF + ρ̇ dt`, with `σ²_ΔGF` the four
//! phases' variances and `ρ̇` the largest GF rate the ionosphere can make:
//! [`GF_ROT_TECU_S`] TECU/s of slant TEC rate times
//! `40.3·10¹⁶ (1/f2² − 1/f1²)` m/TECU (1.05 cm/s at GPS L1/L2). RTKLIB's
//! fixed `pos2-slipthres` 5 cm (manual 2.4.3 Table F.4-1) is the same test
//! at ≈ 4 σ of a 3 mm phase. Insensitive to slips with
//! `λ₁ΔN₁ ≈ λ₂ΔN₂` (GPS: ΔN₁ = 9, ΔN₂ = 7 gives 4 mm).
//!
//! **Melbourne–Wübbena (MW)** (Melbourne 1985, Wübbena 1985; Blewitt 1990,
//! *Geophys. Res. Lett.* 17(3):199, "An automatic editing algorithm for GPS
//! data"): `MW = [(f1 L1 − f2 L2)/(f1 − f2) − (f1 P1 + f2 P2)/(f1 + f2)] / λ_WL
//! = N₁ − N₂ + noise` [wide-lane cycles], `λ_WL = c/(f1 − f2)`: geometry,
//! clocks and the (first-order) ionosphere cancel, so it is constant along
//! an arc. Blewitt's test: a slip when the epoch's MW differs from the
//! arc's running mean by more than [`MW_K`] σ, σ the larger of the code
//! noise model and the arc's sample σ (after [`MW_MIN_N`] epochs), times
//! `√(1 + 1/n)` for the mean's own error. Insensitive to equal slips on both
//! frequencies (ΔN₁ = ΔN₂ leaves `N₁ − N₂`), which GF sees as
//! `(λ₁ − λ₂) ΔN` (−5.4 cm per cycle at GPS L1/L2); with a consumer code
//! (σ_MW ≈ 1 wide-lane cycle per epoch) it catches only wide-lane jumps of
//! several cycles, so the two are complementary, not redundant.
//!
//! An arc restarts (no test) at the first epoch, after a gap longer than
//! [`MAX_GAP_S`], or when the caller [`DualFreqSlip::restart`]s it (a
//! loss-of-lock flag or another test's slip); after a detected slip the arc
//! restarts at that epoch.

use crate::gnss::raw::GnssSystem;
use crate::gnss::C_LIGHT;
#[allow(unused_imports)]
use crate::prelude::*;

/// Satellites tracked at once (GPS 32 + Galileo 36 + BeiDou 63 would be
/// more, but never in view together: 64 ≥ the ≤ 48 records of an epoch).
pub const SLIP_SATS: usize = 64;

/// Threshold of the GF test in σ of the epoch difference: 4σ, a false alarm
/// rate of 6·10⁻⁵ per satellite and epoch for Gaussian noise (the RTK
/// slip test's 0.9999 is 3.9σ).
pub const GF_K: f64 = 4.0;

/// Largest slant-TEC rate the GF test allows for [TECU/s]. Rates of TEC of
/// 0.5 TECU/min (0.008 TECU/s) already mark irregularities (Pi et al. 1997,
/// *Geophys. Res. Lett.* 24:2283, the ROTI index); 0.1 TECU/s is 12× that,
/// so a disturbed ionosphere does not raise false alarms at 1 Hz, while the
/// 1.05 cm/s it allows at L1/L2 stays well under a 1-cycle L1 slip (19 cm).
pub const GF_ROT_TECU_S: f64 = 0.1;

/// Blewitt's (1990) MW threshold: 4 σ.
pub const MW_K: f64 = 4.0;

/// Epochs of an arc before its sample σ may replace the code model's.
pub const MW_MIN_N: u32 = 10;

/// Longest gap [s] an arc survives: beyond it the ionosphere may have
/// changed the GF by more than a cycle's worth at [`GF_ROT_TECU_S`]
/// (30 s · 1.05 cm/s = 32 cm > λ₁), so the arc restarts rather than test.
pub const MAX_GAP_S: f64 = 30.0;

/// One satellite's two-frequency observation at an epoch [m, m²].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DualObs {
    pub t: f64,
    /// Frequencies [Hz], `f1 > f2`.
    pub f1_hz: f64,
    pub f2_hz: f64,
    /// Carrier phases and pseudoranges [m].
    pub l1_m: f64,
    pub l2_m: f64,
    pub p1_m: f64,
    pub p2_m: f64,
    /// Variances [m²] of the phases and the pseudoranges.
    pub var_l1: f64,
    pub var_l2: f64,
    pub var_p1: f64,
    pub var_p2: f64,
}

impl DualObs {
    /// Geometry-free phase `L1 − L2` [m].
    pub fn gf_m(&self) -> f64 {
        self.l1_m - self.l2_m
    }
    /// Variance of [`DualObs::gf_m`] [m²].
    pub fn gf_var(&self) -> f64 {
        self.var_l1 + self.var_l2
    }
    /// Wide-lane wavelength [m].
    pub fn lambda_wl(&self) -> f64 {
        C_LIGHT / (self.f1_hz - self.f2_hz)
    }
    /// Melbourne–Wübbena combination [wide-lane cycles].
    pub fn mw_cyc(&self) -> f64 {
        let (f1, f2) = (self.f1_hz, self.f2_hz);
        let wl = (f1 * self.l1_m - f2 * self.l2_m) / (f1 - f2);
        let nl = (f1 * self.p1_m + f2 * self.p2_m) / (f1 + f2);
        (wl - nl) / self.lambda_wl()
    }
    /// Variance of [`DualObs::mw_cyc`] [cycles²] (independent observables).
    pub fn mw_var(&self) -> f64 {
        let (f1, f2) = (self.f1_hz, self.f2_hz);
        let a = f1 * f1 * self.var_l1 + f2 * f2 * self.var_l2;
        let b = f1 * f1 * self.var_p1 + f2 * f2 * self.var_p2;
        let l = self.lambda_wl();
        (a / ((f1 - f2) * (f1 - f2)) + b / ((f1 + f2) * (f1 + f2))) / (l * l)
    }
    /// GF rate allowed for the ionosphere [m/s] ([`GF_ROT_TECU_S`]).
    pub fn gf_iono_rate(&self) -> f64 {
        let (f1, f2) = (self.f1_hz, self.f2_hz);
        GF_ROT_TECU_S * 40.3e16 * (1.0 / (f2 * f2) - 1.0 / (f1 * f1))
    }
    fn is_valid(&self) -> bool {
        [
            self.t,
            self.l1_m,
            self.l2_m,
            self.p1_m,
            self.p2_m,
            self.var_l1,
            self.var_l2,
            self.var_p1,
            self.var_p2,
        ]
        .iter()
        .all(|v| v.is_finite())
            && self.f1_hz > self.f2_hz
            && self.f2_hz > 0.0
    }
}

/// What the tests said at one epoch.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlipVerdict {
    /// The arc (re)started here: nothing tested.
    pub new_arc: bool,
    pub gf: bool,
    pub mw: bool,
}

impl SlipVerdict {
    /// Either test flagged a slip.
    pub fn slip(&self) -> bool {
        self.gf || self.mw
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Arc {
    key: Option<(GnssSystem, u8)>,
    t: f64,
    gf: f64,
    gf_var: f64,
    /// MW running mean, sum of squared deviations (Welford), count.
    mw_mean: f64,
    mw_m2: f64,
    n: u32,
}

/// Per-satellite GF and MW detectors (module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DualFreqSlip {
    arcs: [Arc; SLIP_SATS],
}

impl Default for DualFreqSlip {
    fn default() -> Self {
        DualFreqSlip {
            arcs: [Arc::default(); SLIP_SATS],
        }
    }
}

impl DualFreqSlip {
    /// Forget satellite `key`'s arc (its next epoch starts a new one).
    pub fn restart(&mut self, key: (GnssSystem, u8)) {
        if let Some(a) = self.arcs.iter_mut().find(|a| a.key == Some(key)) {
            *a = Arc::default();
        }
    }

    /// Test satellite `key`'s epoch `o` against its arc and add it (a slip
    /// or a new arc starts the arc here). Invalid input (non-finite,
    /// `f1 ≤ f2`) restarts the arc and tests nothing. When all slots are
    /// taken, the one not seen the longest is reused.
    pub fn update(&mut self, key: (GnssSystem, u8), o: &DualObs) -> SlipVerdict {
        let i = match self.arcs.iter().position(|a| a.key == Some(key)) {
            Some(i) => i,
            None => {
                let free = self.arcs.iter().position(|a| a.key.is_none());
                let i = free.unwrap_or_else(|| {
                    let mut j = 0;
                    for (k, a) in self.arcs.iter().enumerate() {
                        if a.t < self.arcs[j].t {
                            j = k;
                        }
                    }
                    j
                });
                self.arcs[i] = Arc {
                    key: Some(key),
                    t: f64::NAN,
                    ..Arc::default()
                };
                i
            }
        };
        let a = &mut self.arcs[i];
        if !o.is_valid() {
            *a = Arc::default();
            return SlipVerdict {
                new_arc: true,
                ..SlipVerdict::default()
            };
        }
        let gf = o.gf_m();
        let mw = o.mw_cyc();
        let dt = o.t - a.t;
        let mut v = SlipVerdict::default();
        if !(a.n > 0 && dt > 0.0 && dt <= MAX_GAP_S) {
            v.new_arc = true;
        } else {
            let s_gf = (o.gf_var() + a.gf_var).sqrt();
            v.gf = (gf - a.gf).abs() > GF_K * s_gf + o.gf_iono_rate() * dt;
            let mut var = o.mw_var();
            if a.n >= MW_MIN_N {
                var = var.max(a.mw_m2 / (a.n - 1) as f64);
            }
            let s = (var * (1.0 + 1.0 / a.n as f64)).sqrt();
            v.mw = (mw - a.mw_mean).abs() > MW_K * s;
        }
        if v.new_arc || v.slip() {
            a.mw_mean = mw;
            a.mw_m2 = 0.0;
            a.n = 1;
        } else {
            // Welford's running mean and sum of squares.
            a.n += 1;
            let d = mw - a.mw_mean;
            a.mw_mean += d / a.n as f64;
            a.mw_m2 += d * (mw - a.mw_mean);
        }
        a.t = o.t;
        a.gf = gf;
        a.gf_var = o.gf_var();
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const F1: f64 = 1575.42e6;
    const F2: f64 = 1227.60e6;
    const SAT: (GnssSystem, u8) = (GnssSystem::Gps, 7);

    /// A satellite over `n` epochs at 1 Hz: range rising 500 m/s, an
    /// ionosphere of 5 m on L1 changing 1 mm/s, ambiguities `N1`, `N2`
    /// (+ `slip` from epoch `at` on), noise-free or with a deterministic
    /// pseudo-random code/phase noise of σ `code`, `phase`.
    fn arc(
        n: usize,
        at: usize,
        slip: (i64, i64),
        code: f64,
        phase: f64,
    ) -> impl Iterator<Item = DualObs> {
        let (l1, l2) = (C_LIGHT / F1, C_LIGHT / F2);
        let g = (F1 / F2) * (F1 / F2);
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut noise = move || {
            // Sum of 12 uniforms − 6: ≈ N(0, 1), deterministic.
            let mut s = -6.0;
            for _ in 0..12 {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                s += (seed >> 11) as f64 / (1u64 << 53) as f64;
            }
            s
        };
        (0..n).map(move |k| {
            let t = 1000.0 + k as f64;
            let rho = 2.1e7 + 500.0 * k as f64;
            let i1 = 5.0 + 0.001 * k as f64;
            let (d1, d2) = if k >= at { slip } else { (0, 0) };
            DualObs {
                t,
                f1_hz: F1,
                f2_hz: F2,
                l1_m: rho - i1 + l1 * (12 + d1) as f64 + phase * noise(),
                l2_m: rho - g * i1 + l2 * (-40 + d2) as f64 + phase * noise(),
                p1_m: rho + i1 + code * noise(),
                p2_m: rho + g * i1 + code * noise(),
                var_l1: (phase * phase).max(1e-8),
                var_l2: (phase * phase).max(1e-8),
                var_p1: (code * code).max(1e-6),
                var_p2: (code * code).max(1e-6),
            }
        })
    }

    /// Epochs flagged by (GF, MW) over an arc.
    fn flags(obs: impl Iterator<Item = DualObs>) -> (Vec<usize>, Vec<usize>) {
        let mut d = DualFreqSlip::default();
        let (mut g, mut m) = (Vec::new(), Vec::new());
        for (k, o) in obs.enumerate() {
            let v = d.update(SAT, &o);
            if v.gf {
                g.push(k);
            }
            if v.mw {
                m.push(k);
            }
        }
        (g, m)
    }

    #[test]
    fn combinations_cancel_geometry_and_ionosphere() {
        let o: Vec<DualObs> = arc(3, 99, (0, 0), 0.0, 0.0).collect();
        // MW = N1 − N2 = 12 − (−40) = 52 wide-lane cycles, constant.
        for x in &o {
            assert!((x.mw_cyc() - 52.0).abs() < 1e-6, "{}", x.mw_cyc());
        }
        // GF changes only by (γ − 1) · 1 mm per epoch.
        let g = (F1 / F2) * (F1 / F2);
        assert!(((o[1].gf_m() - o[0].gf_m()) - (g - 1.0) * 0.001).abs() < 1e-6);
        // 0.1 TECU/s at L1/L2: 1.05 cm/s.
        assert!((o[0].gf_iono_rate() - 0.0105).abs() < 2e-4);
    }

    #[test]
    fn quiet_arc_raises_no_flag() {
        // Consumer-like noise: 1 m code, 3 mm phase, 600 epochs.
        let (g, m) = flags(arc(600, 9999, (0, 0), 1.0, 0.003));
        assert!(g.is_empty() && m.is_empty(), "{g:?} {m:?}");
    }

    #[test]
    fn one_cycle_on_l1_only_is_caught_by_gf() {
        // Consumer noise: GF sees 19 cm; MW's 1 wide-lane cycle is under
        // its 4σ with a 1 m code (not asserted either way there).
        let (g, _) = flags(arc(100, 50, (1, 0), 1.0, 0.003));
        assert_eq!(g, vec![50]);
        // Geodetic code (0.1 m): MW catches the same 1-cycle slip.
        let (g, m) = flags(arc(100, 50, (1, 0), 0.1, 0.002));
        assert_eq!((g, m), (vec![50], vec![50]));
    }

    #[test]
    fn equal_slips_are_missed_by_mw_caught_by_gf() {
        // ΔN1 = ΔN2 = 1 leaves N1 − N2: MW blind; GF sees λ1 − λ2 = −5.4 cm.
        let (g, m) = flags(arc(100, 50, (1, 1), 0.1, 0.002));
        assert_eq!(g, vec![50]);
        assert!(m.is_empty(), "{m:?}");
    }

    #[test]
    fn gf_blind_pair_is_caught_by_mw() {
        // ΔN1 = 9, ΔN2 = 7: λ1·9 − λ2·7 = 4 mm, under GF's threshold;
        // the wide lane jumps by 2 cycles, which MW sees (geodetic code).
        let (g, m) = flags(arc(100, 50, (9, 7), 0.1, 0.002));
        assert!(g.is_empty(), "{g:?}");
        assert_eq!(m, vec![50]);
    }

    #[test]
    fn gaps_restart_arcs_and_bad_input_tests_nothing() {
        let mut d = DualFreqSlip::default();
        let o: Vec<DualObs> = arc(3, 1, (5, 0), 0.1, 0.002).collect();
        assert!(d.update(SAT, &o[0]).new_arc);
        // 5-cycle slip after a 40 s gap: a new arc, not a slip.
        let late = DualObs {
            t: o[0].t + 40.0,
            ..o[1]
        };
        let v = d.update(SAT, &late);
        assert!(v.new_arc && !v.slip(), "{v:?}");
        let bad = DualObs {
            l1_m: f64::NAN,
            ..o[2]
        };
        assert!(d.update(SAT, &bad).new_arc);
        // restart(): the next epoch starts a new arc.
        d.update(SAT, &o[2]);
        d.restart(SAT);
        assert!(d.update(SAT, &o[2]).new_arc);
    }

    #[test]
    fn full_table_reuses_the_stalest_slot() {
        let mut d = DualFreqSlip::default();
        let o: Vec<DualObs> = arc(2, 99, (0, 0), 0.0, 0.0).collect();
        for p in 0..SLIP_SATS as u8 {
            d.update((GnssSystem::BeiDou, p), &o[0]);
        }
        // One more satellite: no panic, a new arc.
        assert!(d.update((GnssSystem::Galileo, 1), &o[1]).new_arc);
        assert!(!d.update((GnssSystem::Galileo, 1), &o[1]).slip());
    }
}
