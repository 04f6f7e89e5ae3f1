//! Overlapping Allan deviation and noise-term fits (IEEE Std 952-1997 App. C;
//! El-Sheimy, Hou & Niu 2008).
//!
//! For rate samples y_k at interval τ₀ with integral θ_k = τ₀ Σ y:
//! `σ²(mτ₀) = Σ_k (θ_{k+2m} − 2θ_{k+m} + θ_k)² / (2 m²τ₀² (N − 2m))`.
//!
//! Noise terms (σ² of independent processes add):
//! white rate noise N: `σ² = N²/τ` (slope −½, read at τ = 1 s → N, the ARW/VRW);
//! bias instability B: flat floor `σ ≈ 0.664 B`; rate random walk K:
//! `σ² = K² τ/3` (slope +½, read at τ = 3 s → K). We fit
//! `σ²(τ) = N²/τ + C + K²τ/3` by weighted linear least squares (relative
//! residuals weighted by the number of independent clusters, negative
//! coefficients dropped and refitted), and report B = √C/0.664 (the flat
//! floor without the white and random-walk parts) and the classic
//! B = min σ/0.664 beside it.

/// Fewest independent clusters (T/τ) for a point to count as the minimum.
pub const MIN_CLUSTERS: f64 = 8.0;

/// One point of the Allan deviation curve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdevPoint {
    pub tau: f64,
    pub adev: f64,
    /// Number of independent clusters T/τ (for weighting and error bars).
    pub clusters: f64,
}

/// Fitted noise terms of one axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseFit {
    /// White noise density N (ARW [rad/√s] or VRW [m/s/√s]).
    pub n: f64,
    /// Bias instability B = √C / 0.664 from the fitted flat term C
    /// [rad/s or m/s²]; when the fit finds no flat term, `b_min`.
    pub b: f64,
    /// Classic reading: B = min σ / 0.664, the minimum taken over τ with at
    /// least [`MIN_CLUSTERS`] independent clusters.
    pub b_min: f64,
    /// τ at that minimum [s].
    pub tau_min: f64,
    /// Rate random walk K [rad/s/√s or m/s²/√s]; 0 when not observable.
    pub k: f64,
}

/// τ values: ~`per_decade` log-spaced cluster sizes from 1 up to (N−1)/2.
fn cluster_sizes(n: usize, per_decade: usize) -> Vec<usize> {
    let max = (n.saturating_sub(1)) / 2;
    let mut out = Vec::new();
    let mut x = 1.0f64;
    let r = 10f64.powf(1.0 / per_decade as f64);
    while (x as usize) <= max {
        let m = x.round() as usize;
        if out.last() != Some(&m) && m >= 1 && m <= max {
            out.push(m);
        }
        x *= r;
    }
    out
}

/// Overlapping Allan deviation of rate samples `y` taken every `tau0` s.
pub fn overlapping_adev(y: &[f64], tau0: f64) -> Vec<AdevPoint> {
    let n = y.len();
    let mut theta = Vec::with_capacity(n + 1);
    let mut s = 0.0;
    theta.push(0.0);
    for v in y {
        s += v * tau0;
        theta.push(s);
    }
    let n1 = theta.len();
    cluster_sizes(n, 20)
        .into_iter()
        .filter(|&m| n1 > 2 * m)
        .map(|m| {
            let mut acc = 0.0;
            for k in 0..n1 - 2 * m {
                let d = theta[k + 2 * m] - 2.0 * theta[k + m] + theta[k];
                acc += d * d;
            }
            let tau = m as f64 * tau0;
            let var = acc / (2.0 * tau * tau * (n1 - 2 * m) as f64);
            AdevPoint {
                tau,
                adev: var.sqrt(),
                clusters: n as f64 / m as f64,
            }
        })
        .collect()
}

/// Weighted least squares of σ² ≈ a/τ + c + dτ with relative residuals
/// (scaled by `scale(p)`) weighted by √clusters; coefficients that come out
/// negative are dropped and the rest refitted.
fn wls(pts: &[&AdevPoint], scale: &dyn Fn(&AdevPoint) -> f64) -> [f64; 3] {
    let mut active = [true; 3];
    loop {
        let idx: Vec<usize> = (0..3).filter(|&i| active[i]).collect();
        if idx.is_empty() || pts.is_empty() {
            return [0.0; 3];
        }
        let k = idx.len();
        let mut ata = [[0.0f64; 3]; 3];
        let mut atb = [0.0f64; 3];
        for p in pts {
            let v = p.adev * p.adev;
            let w = p.clusters.sqrt() / scale(p);
            let basis = [1.0 / p.tau, 1.0, p.tau];
            let row: Vec<f64> = idx.iter().map(|&i| basis[i] * w).collect();
            for r in 0..k {
                for c in 0..k {
                    ata[r][c] += row[r] * row[c];
                }
                atb[r] += row[r] * v * w;
            }
        }
        let sol = solve(&ata, &atb, k);
        let mut coef = [0.0; 3];
        let mut neg = false;
        for (j, &i) in idx.iter().enumerate() {
            if sol[j] < 0.0 {
                active[i] = false;
                neg = true;
            } else {
                coef[i] = sol[j];
            }
        }
        if !neg {
            return coef;
        }
    }
}

/// Fit N, B, K to an Allan deviation curve (see module doc).
pub fn fit(curve: &[AdevPoint]) -> NoiseFit {
    let pts: Vec<&AdevPoint> = curve
        .iter()
        .filter(|p| p.adev > 0.0 && p.clusters >= 2.0)
        .collect();
    // First pass relative to the observations, then re-weighted relative to
    // the fitted model (observation-relative weights bias the fit low).
    let c1 = wls(&pts, &|p: &AdevPoint| p.adev * p.adev);
    let model = |p: &AdevPoint| (c1[0] / p.tau + c1[1] + c1[2] * p.tau).max(1e-3 * p.adev * p.adev);
    let coef = wls(&pts, &model);
    let min = curve
        .iter()
        .filter(|p| p.adev > 0.0 && p.clusters >= MIN_CLUSTERS)
        .min_by(|a, b| a.adev.total_cmp(&b.adev))
        .copied()
        .unwrap_or(AdevPoint {
            tau: f64::NAN,
            adev: f64::NAN,
            clusters: 0.0,
        });
    let b_min = min.adev / 0.664;
    NoiseFit {
        n: coef[0].sqrt(),
        b: if coef[1] > 0.0 {
            coef[1].sqrt() / 0.664
        } else {
            b_min
        },
        b_min,
        tau_min: min.tau,
        k: (3.0 * coef[2]).sqrt(),
    }
}

/// Solve the k×k system by Gaussian elimination with partial pivoting.
fn solve(a: &[[f64; 3]; 3], b: &[f64; 3], k: usize) -> [f64; 3] {
    let mut m = [[0.0f64; 4]; 3];
    for r in 0..k {
        for c in 0..k {
            m[r][c] = a[r][c];
        }
        m[r][3] = b[r];
    }
    for col in 0..k {
        let p = (col..k)
            .max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))
            .unwrap_or(col);
        m.swap(col, p);
        let d = m[col][col];
        if d.abs() < 1e-300 {
            return [0.0; 3];
        }
        for r in 0..k {
            if r != col {
                let f = m[r][col] / d;
                let pivot = m[col];
                for (x, p) in m[r].iter_mut().zip(pivot.iter()).skip(col) {
                    *x -= f * p;
                }
            }
        }
    }
    let mut x = [0.0; 3];
    for r in 0..k {
        x[r] = m[r][3] / m[r][r];
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha12Rng;
    use rand_distr::StandardNormal;

    /// White rate noise of density n plus a rate random walk of density k at `1/dt` Hz, `secs` long.
    fn simulate(n: f64, k: f64, secs: f64, dt: f64, seed: u64) -> Vec<f64> {
        let mut r = ChaCha12Rng::seed_from_u64(seed);
        let mut rw = 0.0;
        (0..(secs / dt) as usize)
            .map(|_| {
                rw += k * dt.sqrt() * r.sample::<f64, _>(StandardNormal);
                rw + n / dt.sqrt() * r.sample::<f64, _>(StandardNormal)
            })
            .collect()
    }

    #[test]
    fn white_noise_adev_slope() {
        // σ(τ) = N/√τ for white noise.
        let y = simulate(0.01, 0.0, 600.0, 0.01, 3);
        let c = overlapping_adev(&y, 0.01);
        let p = c.iter().find(|p| (p.tau - 1.0).abs() < 0.2).unwrap();
        assert!((p.adev * p.tau.sqrt() / 0.01 - 1.0).abs() < 0.05, "{p:?}");
    }

    #[test]
    fn recovers_arw_and_rrw_within_10_percent() {
        // A 20-hour static 10 Hz log: ARW 1e-3 rad/√s (3.4°/√h), RRW
        // 1e-4 rad/s/√s (slopes cross at τ = √3·N/K ≈ 17 s). A random walk's
        // Allan estimates are strongly correlated across τ, so K from a 2-hour
        // log scatters by ±20 % between seeds; 20 h brings that under 10 %.
        // Checked over several seeds so the pass is not one lucky draw.
        let (n, k) = (1e-3, 1e-4);
        for seed in [1, 2, 3, 4, 5, 6] {
            let y = simulate(n, k, 72_000.0, 0.1, seed);
            let f = fit(&overlapping_adev(&y, 0.1));
            eprintln!(
                "seed {seed}: N {:.4e} ({:+.1} %), K {:.4e} ({:+.1} %)",
                f.n,
                (f.n / n - 1.0) * 100.0,
                f.k,
                (f.k / k - 1.0) * 100.0
            );
            assert!(
                (f.n / n - 1.0).abs() < 0.10,
                "seed {seed}: N {} vs {n}",
                f.n
            );
            assert!(
                (f.k / k - 1.0).abs() < 0.10,
                "seed {seed}: K {} vs {k}",
                f.k
            );
        }
    }

    /// Flicker (1/f) rate noise of bias-instability coefficient `b`, made as a
    /// sum of first-order Gauss–Markov processes with log-spaced correlation
    /// times (`per_decade` per decade over [t_lo, t_hi]): with n = per_decade/ln 10
    /// processes per e-fold, each of variance σ² = B²/(2π n), the one-sided PSD
    /// Σ 4σ²T/(1 + (2πfT)²) ≈ nσ²/f = B²/(2π f), IEEE 952's bias-instability PSD.
    fn flicker(b: f64, n_white: f64, secs: f64, dt: f64, seed: u64) -> Vec<f64> {
        let (t_lo, t_hi, per_decade) = (0.1f64, 1e5f64, 4.0);
        let k = ((t_hi / t_lo).log10() * per_decade).round() as usize + 1;
        let n = per_decade / 10f64.ln();
        let sig = b / (core::f64::consts::PI * n).sqrt();
        let taus: Vec<f64> = (0..k)
            .map(|i| t_lo * 10f64.powf(i as f64 / per_decade))
            .collect();
        let mut r = ChaCha12Rng::seed_from_u64(seed);
        let mut x: Vec<f64> = taus
            .iter()
            .map(|_| sig * r.sample::<f64, _>(StandardNormal))
            .collect();
        let phis: Vec<(f64, f64)> = taus
            .iter()
            .map(|t| {
                let phi = (-dt / t).exp();
                (phi, sig * (1.0 - phi * phi).sqrt())
            })
            .collect();
        (0..(secs / dt) as usize)
            .map(|_| {
                let mut y = n_white / dt.sqrt() * r.sample::<f64, _>(StandardNormal);
                for (xi, (phi, q)) in x.iter_mut().zip(&phis) {
                    *xi = *xi * phi + q * r.sample::<f64, _>(StandardNormal);
                    y += *xi;
                }
                y
            })
            .collect()
    }

    #[test]
    fn recovers_arw_and_bias_instability_within_10_percent() {
        // Issue 4 must-show 2: a simulated static 2-hour log (10 Hz) with ARW
        // N = 3e-5 rad/√s (0.10°/√h) and bias instability B = 2e-5 rad/s
        // (4.1°/h): the flicker floor starts at τ ≈ (N/0.664B)² ≈ 5 s, so many
        // well-averaged points show it. Flicker noise is slow: one 2-hour
        // realisation of it can sit 20 % off its average level, so the test
        // asks for N within 10 % in every one of 20 realisations and B within
        // 10 % in at least 18 of them (measured: 19 of 20, worst −19 %).
        let (n, b) = (3e-5, 2e-5);
        let mut b_ok = 0;
        for seed in 11..31 {
            let y = flicker(b, n, 7200.0, 0.1, seed);
            let c = overlapping_adev(&y, 0.1);
            let f = fit(&c);
            eprintln!(
                "seed {seed}: N {:.4e} ({:+.1} %), B {:.4e} ({:+.1} %), min-B {:.4e} ({:+.1} %) at τ {:.0} s",
                f.n,
                (f.n / n - 1.0) * 100.0,
                f.b,
                (f.b / b - 1.0) * 100.0,
                f.b_min,
                (f.b_min / b - 1.0) * 100.0,
                f.tau_min
            );
            assert!(
                (f.n / n - 1.0).abs() < 0.10,
                "seed {seed}: N {} vs {n}",
                f.n
            );
            b_ok += usize::from((f.b / b - 1.0).abs() < 0.10);
        }
        assert!(
            b_ok >= 18,
            "B within 10 % in only {b_ok} of 20 realisations"
        );
    }
}
