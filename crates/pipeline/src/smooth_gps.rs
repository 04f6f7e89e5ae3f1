//! GNSS position smoothing on its own (`navfuse smooth-gps`): the seed 002
//! GPS position compensation (`SEEDS.md §2` eq. 5–13, the paper's "particle
//! filter") — or the SIR particle filter comparator — on any GNSS/trajectory
//! file.
//!
//! Positions are projected to the paper's small-area plane (eq. 14–15) with
//! the origin at the first record, compensated, and projected back; the
//! height, velocity and attitude columns pass through unchanged (the velocity
//! and σ are not re-estimated).

use crate::ToolError;
use navfuse_core::estimators::pf_lc::compensation::Compensator;
use navfuse_core::estimators::pf_lc::{CompensationConfig, SirConfig, SirPf};
use navfuse_core::geodesy::{Geodetic, PlanePoint, SmallAreaPlane};
use navfuse_io::trajectory::{create_writer, open_nav_source, InFormat, OutFormat};
use navfuse_io::RecordStats;
use std::path::Path;

/// Particles of the SIR method.
const N_PARTICLES: usize = 1000;

/// Smoothing method.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Method {
    /// The paper's compensation (heading-change PDF blend).
    Paper,
    /// Bootstrap SIR particle filter (CTRV model).
    Sir,
}

/// Options of [`smooth_file`] (the `navfuse smooth-gps` options after the
/// file names and formats).
#[derive(Debug, Clone)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct SmoothOptions {
    /// GPS week for time-of-week-only inputs.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 0))]
    pub gps_week: u32,
    #[cfg_attr(feature = "clap", arg(long, value_enum, default_value = "paper"))]
    pub method: Method,
    /// Compensation history span (default: the library default).
    #[cfg_attr(feature = "clap", arg(long))]
    pub span: Option<usize>,
    /// Compensation weight range.
    #[cfg_attr(feature = "clap", arg(long))]
    pub w_min: Option<f64>,
    #[cfg_attr(feature = "clap", arg(long))]
    pub w_max: Option<f64>,
    /// SIR: fix σ per horizontal axis [m].
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 5.0 / 1.1774))]
    pub sigma_m: f64,
    /// SIR: random seed.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = 2))]
    pub seed: u64,
}

/// What [`smooth_file`] did.
#[derive(Debug, Clone)]
pub struct SmoothSummary {
    /// Records written (the compensation holds back its first records).
    pub written: u64,
    /// Mean horizontal shift of the written positions [m].
    pub mean_shift_m: f64,
    /// The method's own counters (`Debug` text of its stats).
    pub method_stats: String,
    /// The reader's counts (used, rejected by reason).
    pub reader: RecordStats,
}

/// The seed 002 compensation defaults with the command-line overrides
/// applied, validated (shared with `experiment seed002`).
pub fn compensation_config(
    span: Option<usize>,
    w_min: Option<f64>,
    w_max: Option<f64>,
) -> Result<CompensationConfig, String> {
    let mut c = CompensationConfig::default();
    if let Some(s) = span {
        c.span = s;
    }
    if let Some(w) = w_min {
        c.w_min = w;
    }
    if let Some(w) = w_max {
        c.w_max = w;
    }
    c.validate()
        .map_err(|e| format!("compensation config: {e}"))?;
    Ok(c)
}

/// Smooth the positions of `input` (format `fin`) into `output` (format
/// `fout`); positions geodetic (radians, metres), GPS time [s].
pub fn smooth_file(
    input: &Path,
    fin: InFormat,
    output: &Path,
    fout: OutFormat,
    args: &SmoothOptions,
) -> Result<SmoothSummary, ToolError> {
    let cc = compensation_config(args.span, args.w_min, args.w_max)?;
    if !(args.sigma_m.is_finite() && args.sigma_m > 0.0) {
        return Err(format!("--sigma-m must be > 0, got {}", args.sigma_m).into());
    }
    let mut comp = Compensator::new(cc);
    let mut sir: Box<SirPf<N_PARTICLES>> = Box::new(SirPf::new(SirConfig {
        sigma_meas_m: args.sigma_m,
        seed: args.seed,
        ..Default::default()
    }));
    let mut src = open_nav_source(input, fin, args.gps_week).map_err(|e| e.to_string())?;
    let mut out = create_writer(output, fout)
        .map_err(|e| format!("{}: cannot create: {e}", output.display()))?;
    let mut plane: Option<SmallAreaPlane> = None;
    let (mut written, mut shift_sum) = (0u64, 0.0f64);
    for sol in src.by_ref() {
        let mut sol = sol.map_err(|e| e.to_string())?;
        let geo = Geodetic {
            lat: sol.lat,
            lon: sol.lon,
            h: sol.h,
        };
        let pl = *plane.get_or_insert_with(|| SmallAreaPlane::new(geo));
        let p = pl.forward(&geo);
        let q = match args.method {
            Method::Paper => comp.push(sol.t, p.north, p.east).map(|c| [c.north, c.east]),
            Method::Sir => sir.push(sol.t, p.north, p.east),
        };
        let Some([n, e]) = q else { continue };
        shift_sum += ((n - p.north).powi(2) + (e - p.east).powi(2)).sqrt();
        let g = pl.inverse(&PlanePoint { north: n, east: e }, sol.h);
        sol.lat = g.lat;
        sol.lon = g.lon;
        out.write(&sol)
            .map_err(|e| format!("{}: write failed: {e}", output.display()))?;
        written += 1;
    }
    out.finish()
        .map_err(|e| format!("{}: write failed: {e}", output.display()))?;
    let extra = match args.method {
        Method::Paper => format!("{:?}", comp.stats()),
        Method::Sir => format!("{:?}", sir.stats()),
    };
    Ok(SmoothSummary {
        written,
        mean_shift_m: shift_sum / written.max(1) as f64,
        method_stats: extra,
        reader: src.stats().clone(),
    })
}
#[cfg(test)]
mod tests {
    use super::*;
    use navfuse_core::estimators::pf_lc::rng::SplitMix64;
    use navfuse_core::geodesy::LocalFrame;

    /// Noisy KF-GINS GNSS text of a straight 5 m/s drive; returns (path, truth origin).
    fn write_fixture(dir: &std::path::Path) -> (std::path::PathBuf, Geodetic) {
        let o = Geodetic::from_degrees(40.0, -105.0, 1600.0);
        let frame = LocalFrame::new(o);
        let mut rng = SplitMix64::new(4);
        let mut text = String::new();
        for k in 0..400 {
            let t = 1000.0 + k as f64 * 0.25;
            let d = navfuse_core::Vec3::new(
                5.0 * (t - 1000.0) + 2.0 * rng.normal(),
                2.0 * rng.normal(),
                0.0,
            );
            let g = frame.geodetic_from_ned(&d);
            text += &format!(
                "{t:.3} {:.9} {:.9} {:.3} 2.0 2.0 3.0\n",
                g.lat.to_degrees(),
                g.lon.to_degrees(),
                g.h
            );
        }
        let p = dir.join("gnss.txt");
        std::fs::write(&p, text).unwrap();
        (p, o)
    }

    #[test]
    fn smooths_a_noisy_straight_drive_and_rejects_bad_args() {
        let dir = std::env::temp_dir().join(format!("navfuse_smooth_gps_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (input, o) = write_fixture(&dir);
        let frame = LocalFrame::new(o);
        let out = dir.join("out.csv");
        let args = |method| SmoothOptions {
            gps_week: 2374,
            method,
            span: None,
            w_min: None,
            w_max: None,
            sigma_m: 2.0,
            seed: 1,
        };
        for method in [Method::Paper, Method::Sir] {
            smooth_file(
                &input,
                InFormat::KfGinsGnss,
                &out,
                OutFormat::Csv,
                &args(method),
            )
            .unwrap();
            let text = std::fs::read_to_string(&out).unwrap();
            let mut src = open_nav_source(&out, navfuse_io::trajectory::InFormat::Csv, 0).unwrap();
            let mut err = 0.0;
            let mut n = 0;
            for s in src.by_ref() {
                let s = s.unwrap();
                let d = frame.ned(&Geodetic {
                    lat: s.lat,
                    lon: s.lon,
                    h: s.h,
                });
                if n > 20 {
                    // Cross-track error only: the along-track truth needs the time.
                    err += d.y.abs();
                }
                n += 1;
            }
            assert_eq!(n, 400, "{method:?}: {text:.200}");
            // Raw cross-track mean |N(0, 2)| = 1.6 m; smoothing must do better.
            let mean = err / (n - 21) as f64;
            assert!(mean < 1.3, "{method:?}: mean cross-track {mean}");
        }
        let mut bad = args(Method::Paper);
        bad.w_min = Some(2.0);
        let e = smooth_file(&input, InFormat::KfGinsGnss, &out, OutFormat::Csv, &bad).unwrap_err();
        assert!(e.to_string().contains("w_min"));
        std::fs::remove_dir_all(&dir).ok();
    }
}
