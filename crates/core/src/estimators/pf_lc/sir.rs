//! A bootstrap (SIR) particle filter for GNSS positions — the principled
//! comparator to the paper's compensation (`SEEDS.md §2`, issue 6).
//!
//! State per particle: north, east [m], speed v [m/s], heading ψ [rad, from
//! north, clockwise], turn rate ω [rad/s] — the constant turn-rate and
//! velocity (CTRV) model, propagated exactly over Δt with piecewise-constant
//! random longitudinal acceleration and turn-rate acceleration (Gordon,
//! Salmond & Smith 1993; Arulampalam et al. 2002, Alg. 4). Likelihood:
//! isotropic Gaussian on the fix. Systematic resampling (Arulampalam Alg. 2)
//! when the effective sample size `1/Σw²` falls below `ess_fraction·NP`.
//! Estimate: weighted mean before resampling.
//!
//! Fixed storage: `NP` particles (const generic) plus one scratch copy, no
//! per-step allocation; seeded [`SplitMix64`]. Per-particle propagation and
//! weighting are independent (parallel-friendly); only the normalisation and
//! the resampling scan are sequential.

#[allow(unused_imports)]
use crate::prelude::*;

use super::rng::SplitMix64;

/// One particle (CTRV state).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Particle {
    pub north: f64,
    pub east: f64,
    pub v: f64,
    pub psi: f64,
    pub omega: f64,
}

/// Parameters of the SIR filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SirConfig {
    /// Fix error σ per horizontal axis assumed by the likelihood [m].
    pub sigma_meas_m: f64,
    /// Longitudinal acceleration noise σ [m/s²].
    pub sigma_accel_m_s2: f64,
    /// Turn-rate acceleration noise σ [rad/s²].
    pub sigma_yaw_accel_rad_s2: f64,
    /// Resample when ESS < `ess_fraction · NP`.
    pub ess_fraction: f64,
    /// Initial speeds uniform in [0, this] [m/s]; headings uniform.
    pub init_speed_max_m_s: f64,
    /// A gap longer than this re-initialises the cloud at the fix [s].
    pub max_gap_s: f64,
    /// Re-initialise the cloud at the fix when even the nearest particle is
    /// farther than this many `sigma_meas_m` (a diverged bootstrap filter
    /// cannot recover by reweighting; counted in `reinits`).
    pub reinit_sigmas: f64,
    /// Random seed.
    pub seed: u64,
}

impl Default for SirConfig {
    fn default() -> Self {
        SirConfig {
            sigma_meas_m: 5.0 / 1.1774,
            sigma_accel_m_s2: 1.0,
            sigma_yaw_accel_rad_s2: 0.3,
            ess_fraction: 0.5,
            init_speed_max_m_s: 15.0,
            max_gap_s: 2.0,
            reinit_sigmas: 6.0,
            seed: 0x5eed_0002,
        }
    }
}

/// Counters of the SIR filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SirStats {
    pub updates: u64,
    pub resamples: u64,
    /// Re-initialisations (first fix, gaps, collapsed weights).
    pub reinits: u64,
    pub rejected_nonfinite: u64,
}

/// SIR particle filter with `NP` particles.
#[derive(Clone, Debug)]
pub struct SirPf<const NP: usize> {
    cfg: SirConfig,
    parts: [Particle; NP],
    scratch: [Particle; NP],
    logw: [f64; NP],
    rng: SplitMix64,
    t_last: f64,
    init: bool,
    stats: SirStats,
}

impl<const NP: usize> SirPf<NP> {
    pub fn new(cfg: SirConfig) -> Self {
        SirPf {
            cfg,
            parts: [Particle::default(); NP],
            scratch: [Particle::default(); NP],
            logw: [0.0; NP],
            rng: SplitMix64::new(cfg.seed),
            t_last: f64::NAN,
            init: false,
            stats: SirStats::default(),
        }
    }

    pub fn stats(&self) -> &SirStats {
        &self.stats
    }

    pub fn particles(&self) -> &[Particle; NP] {
        &self.parts
    }

    fn reinit(&mut self, north: f64, east: f64) {
        let s = self.cfg.sigma_meas_m;
        for p in self.parts.iter_mut() {
            *p = Particle {
                north: north + s * self.rng.normal(),
                east: east + s * self.rng.normal(),
                v: self.cfg.init_speed_max_m_s * self.rng.uniform(),
                psi: core::f64::consts::TAU * self.rng.uniform() - core::f64::consts::PI,
                omega: 0.0,
            };
        }
        self.logw = [0.0; NP];
        self.init = true;
        self.stats.reinits += 1;
    }

    fn propagate(&mut self, dt: f64) {
        let (sa, sw) = (self.cfg.sigma_accel_m_s2, self.cfg.sigma_yaw_accel_rad_s2);
        for p in self.parts.iter_mut() {
            let a = sa * self.rng.normal();
            let alpha = sw * self.rng.normal();
            // Mid-interval speed and turn rate, exact CTRV arc for them.
            let v = (p.v + 0.5 * a * dt).max(0.0);
            let w = p.omega + 0.5 * alpha * dt;
            let psi1 = p.psi + w * dt;
            if w.abs() > 1e-6 {
                p.north += v / w * (psi1.sin() - p.psi.sin());
                p.east += v / w * (p.psi.cos() - psi1.cos());
            } else {
                p.north += v * dt * p.psi.cos();
                p.east += v * dt * p.psi.sin();
            }
            p.psi = crate::geodesy::wrap_pi(psi1);
            p.v = (p.v + a * dt).abs();
            p.omega += alpha * dt;
        }
    }

    /// Systematic resampling (one uniform draw, NP evenly spaced pointers).
    fn resample(&mut self, w: &[f64; NP]) {
        let u0 = self.rng.uniform() / NP as f64;
        let mut c = w[0];
        let mut i = 0;
        for j in 0..NP {
            let u = u0 + j as f64 / NP as f64;
            while u > c && i + 1 < NP {
                i += 1;
                c += w[i];
            }
            self.scratch[j] = self.parts[i];
        }
        self.parts = self.scratch;
        self.logw = [0.0; NP];
        self.stats.resamples += 1;
    }

    /// Process the fix `(north, east)` at `t` [s]; returns the posterior-mean
    /// position (north, east), or `None` for a non-finite input (counted).
    pub fn push(&mut self, t: f64, north: f64, east: f64) -> Option<[f64; 2]> {
        if !(t.is_finite() && north.is_finite() && east.is_finite()) {
            self.stats.rejected_nonfinite += 1;
            return None;
        }
        let gap = t - self.t_last;
        if !(self.init && gap > 0.0 && gap <= self.cfg.max_gap_s) {
            self.reinit(north, east);
            self.t_last = t;
            return Some([north, east]);
        }
        self.t_last = t;
        self.propagate(gap);
        let inv2s2 = 0.5 / (self.cfg.sigma_meas_m * self.cfg.sigma_meas_m);
        let mut maxl = f64::NEG_INFINITY;
        let mut min_d2 = f64::INFINITY;
        for (lw, p) in self.logw.iter_mut().zip(self.parts.iter()) {
            let (dn, de) = (p.north - north, p.east - east);
            let d2 = dn * dn + de * de;
            min_d2 = min_d2.min(d2);
            *lw -= d2 * inv2s2;
            maxl = maxl.max(*lw);
        }
        let far = self.cfg.reinit_sigmas * self.cfg.sigma_meas_m;
        if !maxl.is_finite() || min_d2 > far * far {
            self.reinit(north, east);
            return Some([north, east]);
        }
        let mut w = [0.0; NP];
        let mut sum = 0.0;
        for (wi, lw) in w.iter_mut().zip(self.logw.iter()) {
            *wi = (lw - maxl).exp();
            sum += *wi;
        }
        let (mut en, mut ee, mut s2) = (0.0, 0.0, 0.0);
        for (wi, p) in w.iter_mut().zip(self.parts.iter()) {
            *wi /= sum;
            en += *wi * p.north;
            ee += *wi * p.east;
            s2 += *wi * *wi;
        }
        // Keep log-weights bounded.
        for lw in self.logw.iter_mut() {
            *lw -= maxl;
        }
        self.stats.updates += 1;
        if 1.0 / s2 < self.cfg.ess_fraction * NP as f64 {
            self.resample(&w);
        }
        Some([en, ee])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tracks_a_circle_better_than_raw_fixes_and_is_seeded() {
        let run = |seed: u64| {
            let mut pf: Box<SirPf<400>> = Box::new(SirPf::new(SirConfig {
                sigma_meas_m: 3.0,
                seed,
                ..Default::default()
            }));
            let mut noise = SplitMix64::new(seed ^ 99);
            let (r, w) = (60.0, 0.1); // 6 m/s around a 60 m circle
            let (mut er, mut ef, mut n) = (0.0, 0.0, 0);
            for k in 0..1200 {
                let t = k as f64 * 0.25;
                let (tn, te) = (r * (w * t).sin(), r * (1.0 - (w * t).cos()));
                let (zn, ze) = (tn + 3.0 * noise.normal(), te + 3.0 * noise.normal());
                let est = pf.push(t, zn, ze).unwrap();
                if k > 40 {
                    er += ((zn - tn).powi(2) + (ze - te).powi(2)).sqrt();
                    ef += ((est[0] - tn).powi(2) + (est[1] - te).powi(2)).sqrt();
                    n += 1;
                }
            }
            (er / n as f64, ef / n as f64, *pf.stats())
        };
        let (er, ef, st) = run(1);
        assert!(ef < 0.6 * er, "raw {er} pf {ef}");
        assert!(st.resamples > 10 && st.reinits == 1, "{st:?}");
        // A jump far away re-initialises the cloud instead of diverging.
        let mut pf: Box<SirPf<100>> = Box::new(SirPf::new(SirConfig::default()));
        for k in 0..20 {
            pf.push(k as f64 * 0.25, 0.0, 0.0);
        }
        let est = pf.push(5.0, 1000.0, 0.0).unwrap();
        assert_eq!(est, [1000.0, 0.0]);
        assert_eq!(pf.stats().reinits, 2);
        assert_eq!(run(1).1, ef);
        assert_ne!(run(2).1, ef);
    }

    #[test]
    fn systematic_resampling_keeps_heavy_particle() {
        let mut pf: SirPf<8> = SirPf::new(SirConfig::default());
        for (i, p) in pf.parts.iter_mut().enumerate() {
            p.north = i as f64;
        }
        let mut w = [0.0; 8];
        w[3] = 1.0;
        pf.resample(&w);
        assert!(pf.parts.iter().all(|p| p.north == 3.0));
        let w = [0.125; 8];
        for (i, p) in pf.parts.iter_mut().enumerate() {
            p.north = i as f64;
        }
        pf.resample(&w);
        for (i, p) in pf.parts.iter().enumerate() {
            assert_eq!(p.north, i as f64);
        }
    }
}
