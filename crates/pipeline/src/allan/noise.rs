//! `navfuse allan`'s fit as a `[filter.imu_noise]` block in datasheet keys
//! (`crate::noise_cfg`) that a `navfuse run` configuration takes
//! as is.
//!
//! The ESKF models each bias as a first-order Gauss–Markov process (σ, T),
//! which shows in the Allan deviation as a bump on the falling white-noise
//! line, peaking at 0.617 σ for τ ≈ 1.89 T (`noise_cfg::gm_allan_deviation`).
//! Each axis' curve is fitted by σ_A²(τ) = N²/τ + σ²·g(τ/T), g the
//! Gauss–Markov Allan variance of unit σ: linear least squares in N², σ²
//! for each T on a log grid from 10 τ₀ to the longest τ with [`MIN_CLUSTERS`]
//! clusters, weighted by the cluster count on relative residuals; the T of
//! least residual wins. When it is the grid's last T the wander is slower
//! than the record shows: σ and T are lower bounds. When the fitted bump
//! stays below the white line everywhere no bias wander was seen: σ is then
//! the IEEE Std 952 reading min σ_A / 0.664 (an upper bound of the floor)
//! and T the longest τ / 1.89, a guess.

use super::{AllanResult, G0, R2D};
use crate::noise_cfg::gm_allan_deviation;
use navfuse_sim::allan::{AdevPoint, MIN_CLUSTERS};

/// τ_peak / T of a Gauss–Markov Allan curve.
const GM_PEAK_TAU: f64 = 1.89;
/// Its peak: 0.617 σ.
const GM_PEAK: f64 = 0.617;
/// IEEE Std 952 flicker floor: σ_A,min = 0.664 B.
const FLICKER: f64 = 0.664;

/// How the bias was read from one axis' curve.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Reading {
    /// σ, T of the best fit inside the grid.
    Fit,
    /// Best at the longest T: lower bounds.
    Beyond,
    /// No bump above the white line: IEEE min / 0.664, T a guess.
    NotSeen,
}

/// Weighted least squares of y = a·x1 + b·x2 with a, b ≥ 0; returns
/// (a, b, weighted residual²).
fn nnls2(rows: &[(f64, f64, f64, f64)]) -> (f64, f64, f64) {
    let fit = |use1: bool, use2: bool| {
        let (mut s11, mut s12, mut s22, mut s1y, mut s2y) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for &(x1, x2, y, w) in rows {
            let (x1, x2) = (if use1 { x1 } else { 0.0 }, if use2 { x2 } else { 0.0 });
            s11 += w * x1 * x1;
            s12 += w * x1 * x2;
            s22 += w * x2 * x2;
            s1y += w * x1 * y;
            s2y += w * x2 * y;
        }
        let det = s11 * s22 - s12 * s12;
        let (a, b) = match (use1, use2) {
            (true, true) if det > 0.0 => {
                ((s22 * s1y - s12 * s2y) / det, (s11 * s2y - s12 * s1y) / det)
            }
            (true, _) if s11 > 0.0 => (s1y / s11, 0.0),
            (_, true) if s22 > 0.0 => (0.0, s2y / s22),
            _ => (0.0, 0.0),
        };
        let r: f64 = rows
            .iter()
            .map(|&(x1, x2, y, w)| w * (y - a * x1 - b * x2).powi(2))
            .sum();
        (a, b, r)
    };
    let both = fit(true, true);
    if both.0 >= 0.0 && both.1 >= 0.0 {
        return both;
    }
    let (one, two) = (fit(true, false), fit(false, true));
    [one, two]
        .into_iter()
        .filter(|f| f.0 >= 0.0 && f.1 >= 0.0)
        .min_by(|x, y| x.2.total_cmp(&y.2))
        .unwrap_or((0.0, 0.0, f64::INFINITY))
}

/// Gauss–Markov σ [curve unit], T [s] and how they were read (module doc).
fn gm_bias(curve: &[AdevPoint], tau0: f64) -> Option<(f64, f64, Reading)> {
    let pts: Vec<&AdevPoint> = curve
        .iter()
        .filter(|p| p.adev > 0.0 && p.clusters >= 2.0)
        .collect();
    let usable: Vec<&&AdevPoint> = pts.iter().filter(|p| p.clusters >= MIN_CLUSTERS).collect();
    let t_max = usable.last()?.tau / GM_PEAK_TAU;
    let min = usable.iter().map(|p| p.adev).fold(f64::INFINITY, f64::min);
    let t_min = (10.0 * tau0).min(t_max);
    const STEPS: usize = 120;
    // Relative residuals weighted by the cluster count: first relative to
    // the observed σ_A², then to the first fit's model (observation-relative
    // weights bias the fit low, as in `navfuse_sim::allan::fit`).
    let search = |denom: &dyn Fn(&AdevPoint) -> f64| {
        let mut best = (f64::INFINITY, 0.0, 0.0, 0.0, 0usize);
        for k in 0..=STEPS {
            let t = t_min * (t_max / t_min).powf(k as f64 / STEPS as f64);
            let rows: Vec<(f64, f64, f64, f64)> = pts
                .iter()
                .map(|p| {
                    let o = denom(p);
                    let g = gm_allan_deviation(1.0, t, p.tau).powi(2);
                    (1.0 / p.tau / o, g / o, p.adev * p.adev / o, p.clusters)
                })
                .collect();
            let (n2, s2, r) = nnls2(&rows);
            if r < best.0 {
                best = (r, n2, s2, t, k);
            }
        }
        best
    };
    let (_, n2, s2, t1, _) = search(&|p| p.adev * p.adev);
    let model = |p: &AdevPoint| {
        (n2 / p.tau + s2 * gm_allan_deviation(1.0, t1, p.tau).powi(2)).max(1e-3 * p.adev * p.adev)
    };
    let (_, _, s2, t, k) = search(&model);
    let sigma = s2.sqrt();
    Some(if GM_PEAK * sigma < min {
        (min / FLICKER, t_max, Reading::NotSeen)
    } else if k == STEPS {
        (sigma, t, Reading::Beyond)
    } else {
        (sigma, t, Reading::Fit)
    })
}

impl AllanResult {
    /// The fit as a `[filter.imu_noise]` block in datasheet keys, per axis
    /// x, y, z: noise densities from the fitted white-noise N, biases read
    /// as Gauss–Markov processes (module doc), `bias_corr_time_s` the median
    /// of the gyro axes' T (the ESKF has one correlation time, the gyro's).
    /// Comments give the record, the readings and what a static record
    /// cannot show.
    pub fn toml(&self, src: &str) -> String {
        let reads: Vec<(f64, f64, Reading)> = self
            .curves
            .iter()
            .map(|c| gm_bias(c, self.tau0).unwrap_or((0.0, f64::NAN, Reading::NotSeen)))
            .collect();
        let arr = |r: std::ops::Range<usize>, k: &dyn Fn(usize) -> f64| {
            let v: Vec<String> = r.map(|i| format!("{:.4e}", k(i))).collect();
            format!("[{}]", v.join(", "))
        };
        let mut t: Vec<f64> = reads[..3].iter().map(|r| r.1).collect();
        t.sort_by(f64::total_cmp);
        let record = self.samples as f64 * self.tau0;
        let how = |r: Reading| match r {
            Reading::Fit => "Gauss–Markov fit".to_string(),
            Reading::Beyond => "T at the longest τ the record allows: LOWER BOUNDS".to_string(),
            Reading::NotSeen => {
                "no bias wander above the white noise: IEEE min/0.664, T a guess".to_string()
            }
        };
        let readings: Vec<String> = ["gx", "gy", "gz", "ax", "ay", "az"]
            .iter()
            .zip(&reads)
            .map(|(a, r)| format!("# {a}: T = {:.0} s, {}", r.1, how(r.2)))
            .collect();
        format!(
            "# navfuse allan: IMU noise fitted to {src}\n\
             # ({} samples, τ₀ = {:.4} s, record {record:.0} s; per axis x, y, z).\n\
             # Noise density: N of σ²(τ) = N²/τ + C + K²τ/3 fitted over all τ. Bias: the\n\
             # Gauss–Markov σ, T of σ²(τ) = N²/τ + σ_GM²(τ; σ, T) fitted per axis (its Allan\n\
             # peak is 0.617 σ at τ = 1.89 T); bias_corr_time_s = median gyro T.\n\
             # A {record:.0} s record shows no bias wander slower than ~{:.0} s: the bias\n\
             # instability is a LOWER BOUND of what a long run sees; record hours.\n\
             {}\n\
             # Not observable from a static record: scale factors and turn-on bias (add\n\
             # gyro_scale_ppm, accel_scale_ppm, gyro_turn_on_bias_dps, accel_turn_on_bias_mg\n\
             # from the datasheet). Rate random walk K [°/h/√h]: {} (not an ESKF state).\n\
             [filter.imu_noise]\n\
             gyro_noise_dps_rthz = {}\n\
             accel_noise_ug_rthz = {}\n\
             gyro_bias_instability_dph = {}\n\
             accel_bias_instability_ug = {}\n\
             bias_corr_time_s = {:.1}\n",
            self.samples,
            self.tau0,
            record / MIN_CLUSTERS,
            readings.join("\n"),
            arr(0..3, &|i| self.fits[i].k * R2D * 3600.0 * 60.0),
            arr(0..3, &|i| self.fits[i].n * R2D),
            arr(3..6, &|i| self.fits[i].n / G0 * 1e6),
            arr(0..3, &|i| reads[i].0 * R2D * 3600.0),
            arr(3..6, &|i| reads[i].0 / G0 * 1e6),
            t[1],
        )
    }
}

#[cfg(test)]
mod tests {
    use crate::allan::analyse_samples;
    use crate::noise_cfg::gm_allan_deviation;

    /// A static phone-grade IMU (navfuse-sim preset `phone`: Gauss–Markov
    /// bias σ 20 °/h and 100 µg, T = 100 s; noise 0.007 °/s/√Hz, 150 µg/√Hz)
    /// for one hour: the block parses back into a run configuration with the
    /// preset's noise densities within 5 % (the white-noise fit of
    /// `allan::tests`) and each bias σ within 50 %: a one-hour record holds
    /// L/2T = 18 independent stretches of a T = 100 s bias, so its σ is
    /// known to ±1/√(2·18) = ±17 % (1σ) per axis; 50 % is 3σ. T within a
    /// factor 2. (Seeds 1–4, 11 measured: gyro σ −13…+8 %, accel σ −18…+42 %,
    /// T 79–102 s.)
    #[test]
    fn simulated_phone_imu_gives_a_run_noise_block() {
        let sc = navfuse_sim::Scenario::from_toml(
            "[start]\nlat_deg = 45\nlon_deg = 7\n[imu]\nrate_hz = 100\nsubsteps = 1\n\
             preset = \"phone\"\n[[segment]]\ntype = \"hold\"\nduration_s = 3600\n",
            "t",
        )
        .unwrap();
        let run = navfuse_sim::simulate(&sc, 11, None, None).unwrap();
        let r = analyse_samples(&run.imu).unwrap();
        let block = r.toml("sim");
        println!("{block}");
        let cfg: crate::RunConfig =
            toml::from_str(&format!("[input]\nimu = \"i\"\ngnss = \"g\"\n{block}")).unwrap();
        let n = cfg.filter.imu_noise.unwrap();
        n.validate("allan", "filter.imu_noise").unwrap();
        let got = n.to_si();
        let want = crate::sensors::imu_noise_preset("phone").unwrap().noise;
        for i in 0..3 {
            for (what, x, y, tol) in [
                ("ARW", got.arw[i], want.arw[i], 0.05),
                ("VRW", got.vrw[i], want.vrw[i], 0.05),
                ("gyro bias σ", got.bg_std[i], want.bg_std[i], 0.5),
                ("accel bias σ", got.ba_std[i], want.ba_std[i], 0.5),
            ] {
                assert!((x / y - 1.0).abs() < tol, "{what} axis {i}: {x:e} vs {y:e}");
            }
        }
        let t = got.corr_time / want.corr_time;
        assert!(
            t > 0.5 && t < 2.0,
            "T {} s vs {} s",
            got.corr_time,
            want.corr_time
        );
    }

    /// The reading on exact curves: a pure Gauss–Markov curve gives σ and T
    /// back; a white-noise line falls throughout.
    #[test]
    fn exact_curves_are_read_as_designed() {
        let curve = |f: &dyn Fn(f64) -> f64| -> Vec<navfuse_sim::allan::AdevPoint> {
            (0..60)
                .map(|k| {
                    let tau = 10f64.powf(k as f64 / 10.0 - 2.0);
                    navfuse_sim::allan::AdevPoint {
                        tau,
                        adev: f(tau),
                        clusters: 1e5 / tau,
                    }
                })
                .collect()
        };
        let (s, t, r) = super::gm_bias(
            &curve(&|tau| (gm_allan_deviation(2.0, 50.0, tau).powi(2) + 1e-2 / tau).sqrt()),
            0.01,
        )
        .unwrap();
        assert_eq!(r, super::Reading::Fit);
        // The T grid has 120 steps over 5.5 decades: 11 % apart.
        assert!(
            (s / 2.0 - 1.0).abs() < 0.03 && (t / 50.0 - 1.0).abs() < 0.06,
            "{s} {t}"
        );
        let (_, _, r) = super::gm_bias(&curve(&|tau| 1e-3 / tau.sqrt()), 0.01).unwrap();
        assert_eq!(r, super::Reading::NotSeen);
    }
}
