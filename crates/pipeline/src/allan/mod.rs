//! Overlapping Allan deviation of a static IMU log (`navfuse allan`) with
//! fitted noise terms (`navfuse_sim::allan`: ARW/VRW N read on the slope −½
//! line at τ = 1 s, bias instability B = min σ/0.664, rate random walk K on
//! the slope +½ line at τ = 3 s).
//!
//! Input (format detected from the first line, or `--format`):
//! - `vn310`: VectorNav/INSTINCT CSV (`IMU::UncompGyro::X [rad/s]` …), raw rates;
//! - `sim`: navfuse `imu.csv` (increments, header `t_gps_s,dt_s,dtheta_x_rad,…`);
//! - `kfgins`: KF-GINS IMU text (`tow dθx dθy dθz dvx dvy dvz`).
//!
//! Writes `allan.csv` (τ and σ of the six axes), `allan_noise.toml` (the
//! fitted terms as a `[filter.imu_noise]` block in datasheet keys that a
//! `navfuse run` configuration takes as is; also to `--toml FILE`) and
//! `allan.svg` (log–log plot) to `--out`.

use crate::ToolError;
use navfuse_core::ImuSample;
use navfuse_io::csv_imu::{Col, CsvImuConfig, CsvImuReader, CsvTime, GyroUnit};
use navfuse_io::imu::ImuForm;
use navfuse_io::kfgins::{KfGinsImuOptions, KfGinsImuReader};
use navfuse_io::ReadError;
use navfuse_sim::allan::{fit, overlapping_adev, AdevPoint, NoiseFit};
use std::fmt::Write as _;
use std::path::Path;

const R2D: f64 = 180.0 / core::f64::consts::PI;
const G0: f64 = 9.806_65;

mod noise;

/// The Allan analysis of one log: six curves and fits (gyro x,y,z; accel x,y,z).
pub struct AllanResult {
    pub tau0: f64,
    pub samples: usize,
    pub curves: Vec<Vec<AdevPoint>>,
    pub fits: Vec<NoiseFit>,
}

fn detect(path: &Path) -> Result<&'static str, String> {
    let (mut r, name) = navfuse_io::open(path).map_err(|e| e.to_string())?;
    let first = match navfuse_io::text::capped_lines(&mut r).next() {
        Some(l) => l.map_err(|e| format!("{name}:1: cannot read: {e}"))?,
        None => String::new(),
    };
    Ok(if first.contains("IMU::UncompGyro") {
        "vn310"
    } else if first.contains("dtheta_x_rad") {
        "sim"
    } else {
        "kfgins"
    })
}

fn read_samples(path: &Path, format: &str) -> Result<Vec<ImuSample>, String> {
    let format = if format == "auto" {
        detect(path)?
    } else {
        format
    };
    let (r, name) = navfuse_io::open(path).map_err(|e| e.to_string())?;
    let collect = |it: &mut dyn Iterator<Item = Result<ImuSample, ReadError>>| {
        it.collect::<Result<Vec<_>, _>>().map_err(|e| e.to_string())
    };
    match format {
        "vn310" => {
            // Raw rates, rectangle rule: Δ/dt returns each sample's rate unchanged
            // (trapezoid averaging would low-pass the white noise at τ₀).
            let cfg = CsvImuConfig {
                form: ImuForm::RateRectangle,
                ..CsvImuConfig::vn310()
            };
            collect(&mut CsvImuReader::new(r, &name, cfg))
        }
        "sim" => {
            let c = |s: &str| Col::Name(s.to_string());
            let cfg = CsvImuConfig {
                gyro_unit: GyroUnit::Rad,
                form: ImuForm::Increment,
                ..CsvImuConfig::new(
                    CsvTime::Seconds(c("t_gps_s")),
                    [c("dtheta_x_rad"), c("dtheta_y_rad"), c("dtheta_z_rad")],
                    [c("dvel_x_m_s"), c("dvel_y_m_s"), c("dvel_z_m_s")],
                )
            };
            collect(&mut CsvImuReader::new(r, &name, cfg))
        }
        "kfgins" => collect(&mut KfGinsImuReader::new(
            r,
            &name,
            KfGinsImuOptions::default(),
        )),
        f => Err(format!("unknown --format '{f}' (auto, vn310, sim, kfgins)")),
    }
}

/// Read a log and run the analysis.
pub fn analyse(path: &Path, format: &str) -> Result<AllanResult, ToolError> {
    let s = read_samples(path, format)?;
    analyse_samples(&s).map_err(|e| format!("{}: {e}", path.display()).into())
}

/// The analysis of IMU increments (body axes, time order).
pub fn analyse_samples(s: &[ImuSample]) -> Result<AllanResult, ToolError> {
    if s.len() < 20 {
        return Err(format!("{} samples — too few for an Allan analysis", s.len()).into());
    }
    let mut dts: Vec<f64> = s.iter().map(|x| x.dt).collect();
    dts.sort_by(f64::total_cmp);
    let tau0 = dts[dts.len() / 2];
    let gaps = s.iter().filter(|x| (x.dt / tau0 - 1.0).abs() > 0.5).count();
    if gaps > 0 {
        eprintln!(
            "navfuse allan: {gaps} of {} intervals differ from the median {tau0:.6} s by > 50 %; \
             the analysis assumes uniform sampling",
            s.len()
        );
    }
    let mut curves = Vec::new();
    let mut fits = Vec::new();
    for axis in 0..6 {
        let y: Vec<f64> = s
            .iter()
            .map(|x| {
                if axis < 3 {
                    x.dtheta_b[axis] / x.dt
                } else {
                    x.dvel_b[axis - 3] / x.dt
                }
            })
            .collect();
        let c = overlapping_adev(&y, tau0);
        fits.push(fit(&c));
        curves.push(c);
    }
    Ok(AllanResult {
        tau0,
        samples: s.len(),
        curves,
        fits,
    })
}

impl AllanResult {
    /// Printable table in datasheet units.
    pub fn table(&self) -> String {
        let mut o = String::new();
        let _ = writeln!(
            o,
            "{} samples, τ₀ = {:.4} s, longest τ = {:.1} s",
            self.samples,
            self.tau0,
            self.curves[0].last().map_or(0.0, |p| p.tau)
        );
        let _ = writeln!(
            o,
            "axis     ARW [°/√h]   N [rad/√s]   B [°/h]  min-B [°/h]  τ_min [s]   RRW [°/h/√h]"
        );
        for (i, f) in self.fits.iter().take(3).enumerate() {
            let _ = writeln!(
                o,
                "gyro {}   {:>10.4}   {:>10.3e}   {:>7.2}  {:>11.2}  {:>9.2}   {:>12.3}",
                ["x", "y", "z"][i],
                f.n * R2D * 60.0,
                f.n,
                f.b * R2D * 3600.0,
                f.b_min * R2D * 3600.0,
                f.tau_min,
                f.k * R2D * 3600.0 * 60.0
            );
        }
        let _ = writeln!(
            o,
            "axis     VRW [m/s/√h]  N [m/s/√s]   B [mg]   min-B [mg]   τ_min [s]   RRW [mg/√h]"
        );
        for (i, f) in self.fits.iter().skip(3).enumerate() {
            let _ = writeln!(
                o,
                "accel {}  {:>10.4}   {:>10.3e}   {:>7.4}  {:>11.4}  {:>9.2}   {:>12.4}",
                ["x", "y", "z"][i],
                f.n * 60.0,
                f.n,
                f.b / G0 * 1e3,
                f.b_min / G0 * 1e3,
                f.tau_min,
                f.k / G0 * 1e3 * 60.0
            );
        }
        let _ = write!(
            o,
            "(N, B = √C/0.664, K from σ² = N²/τ + C + K²τ/3 fitted over all τ; \
             min-B = min σ/0.664 over τ with ≥ 8 clusters; K is 0 when no +½ slope is seen — a {:.0} s log cannot show it beyond τ ≈ {:.0} s)",
            self.samples as f64 * self.tau0,
            self.samples as f64 * self.tau0 / 2.0
        );
        o
    }

    /// τ [s] and σ of the six axes (rad/s, m/s²) as CSV.
    pub fn csv(&self) -> String {
        let mut o = String::from(
            "tau_s,gyro_x_rad_s,gyro_y_rad_s,gyro_z_rad_s,accel_x_m_s2,accel_y_m_s2,accel_z_m_s2\n",
        );
        for (i, p) in self.curves[0].iter().enumerate() {
            let _ = write!(o, "{:.6}", p.tau);
            for c in &self.curves {
                let _ = write!(o, ",{:.6e}", c[i].adev);
            }
            o.push('\n');
        }
        o
    }

    /// Log–log SVG of the six curves (gyro left, accel right).
    /// The six curves as a log–log SVG plot.
    pub fn svg(&self) -> String {
        let (w, h) = (900.0, 420.0);
        let mut o = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
        );
        let colors = ["#d62728", "#2ca02c", "#1f77b4"];
        for (panel, (title, range)) in [("gyro σ(τ) [rad/s]", 0..3), ("accel σ(τ) [m/s²]", 3..6)]
            .into_iter()
            .enumerate()
        {
            let x0 = 60.0 + panel as f64 * 450.0;
            let (pw, ph, y0) = (370.0, 330.0, 40.0);
            let pts: Vec<&AdevPoint> = range.clone().flat_map(|i| self.curves[i].iter()).collect();
            let lt = |v: f64| v.log10();
            let (tmin, tmax) = (
                pts.iter()
                    .map(|p| lt(p.tau))
                    .fold(f64::INFINITY, f64::min)
                    .floor(),
                pts.iter()
                    .map(|p| lt(p.tau))
                    .fold(f64::NEG_INFINITY, f64::max)
                    .ceil(),
            );
            let (smin, smax) = (
                pts.iter()
                    .map(|p| lt(p.adev))
                    .fold(f64::INFINITY, f64::min)
                    .floor(),
                pts.iter()
                    .map(|p| lt(p.adev))
                    .fold(f64::NEG_INFINITY, f64::max)
                    .ceil(),
            );
            let sx = |t: f64| x0 + (lt(t) - tmin) / (tmax - tmin).max(1.0) * pw;
            let sy = |s: f64| y0 + ph - (lt(s) - smin) / (smax - smin).max(1.0) * ph;
            let _ = writeln!(
                o,
                "<rect x=\"{x0}\" y=\"{y0}\" width=\"{pw}\" height=\"{ph}\" fill=\"none\" stroke=\"#888\"/>\n<text x=\"{}\" y=\"25\">{title}</text>",
                x0 + 5.0
            );
            for d in tmin as i32..=tmax as i32 {
                let x = sx(10f64.powi(d));
                let _ = writeln!(
                    o,
                    "<text x=\"{x}\" y=\"{}\" text-anchor=\"middle\">1e{d} s</text>",
                    y0 + ph + 15.0
                );
            }
            for d in smin as i32..=smax as i32 {
                let y = sy(10f64.powi(d));
                let _ = writeln!(
                    o,
                    "<text x=\"{}\" y=\"{y}\" text-anchor=\"end\">1e{d}</text>",
                    x0 - 4.0
                );
            }
            for (k, i) in range.enumerate() {
                let path: Vec<String> = self.curves[i]
                    .iter()
                    .map(|p| format!("{:.1},{:.1}", sx(p.tau), sy(p.adev)))
                    .collect();
                let _ = writeln!(
                    o,
                    "<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"1.5\" points=\"{}\"/>\n<text x=\"{}\" y=\"{}\" fill=\"{}\">{}</text>",
                    colors[k],
                    path.join(" "),
                    x0 + pw - 20.0,
                    y0 + 15.0 + 14.0 * k as f64,
                    colors[k],
                    ["x", "y", "z"][k]
                );
            }
        }
        o.push_str("</svg>\n");
        o
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn simulated_static_log_round_trip() {
        // Simulate a static ideal-plus-noise log with navfuse-sim, write it,
        // read it back through the `sim` CSV path and recover the ARW/VRW.
        let sc = navfuse_sim::Scenario::from_toml(
            r#"
[start]
lat_deg = 45
lon_deg = 7
[imu]
rate_hz = 100
substeps = 1
[imu.model]
name = "white"
gyro = { arw_deg_sqrt_h = 0.5 }
accel = { vrw_m_s_sqrt_h = 0.05 }
[[segment]]
type = "hold"
duration_s = 600
"#,
            "t",
        )
        .unwrap();
        let run = navfuse_sim::simulate(&sc, 5, None, None).unwrap();
        let dir = std::env::temp_dir().join(format!("navfuse-allan-{}", std::process::id()));
        navfuse_sim::output::write_run(&run, &dir).unwrap();
        let r = analyse(&dir.join("imu.csv"), "auto").unwrap();
        for f in &r.fits[..3] {
            let arw = f.n * R2D * 60.0;
            assert!((arw / 0.5 - 1.0).abs() < 0.05, "ARW {arw}");
        }
        for f in &r.fits[3..] {
            let vrw = f.n * 60.0;
            assert!((vrw / 0.05 - 1.0).abs() < 0.05, "VRW {vrw}");
        }
        // KF-GINS text gives the same answer.
        let k = analyse(&dir.join("imu.txt"), "auto").unwrap();
        assert!((k.fits[0].n / r.fits[0].n - 1.0).abs() < 1e-3);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn vn310_static_log() {
        let p = navfuse_io::data::require("static_vn310/vn310-imu.csv");
        let r = analyse(&p, "auto").unwrap();
        println!("{}", r.table());
        assert!(r.samples > 1500 && (r.tau0 - 0.02).abs() < 1e-3);
        for f in &r.fits[..3] {
            let arw = f.n * R2D * 60.0;
            // A MEMS gyro: ARW inside (0.01, 5) °/√h (this log: 0.04–0.15).
            assert!(arw > 0.01 && arw < 5.0, "ARW {arw} °/√h");
        }
        for f in &r.fits[3..] {
            let vrw = f.n * 60.0;
            assert!(vrw > 0.001 && vrw < 0.5, "VRW {vrw} m/s/√h");
        }
    }
}
