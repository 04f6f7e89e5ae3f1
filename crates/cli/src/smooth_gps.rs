//! `navfuse smooth-gps IN OUT`: the seed 002 GPS position compensation
//! (`SEEDS.md §2` eq. 5–13, the paper's "particle filter") — or the SIR
//! particle filter comparator — on any GNSS/trajectory file, alone.
//!
//! Positions are projected to the paper's small-area plane (eq. 14–15) with
//! the origin at the first record, compensated, and projected back; the
//! height, velocity and attitude columns pass through unchanged (the velocity
//! and σ are not re-estimated). Formats as in `navfuse convert`.

use crate::convert::{From, To};
use clap::{Args as ClapArgs, ValueEnum};
use navfuse_core::estimators::pf_lc::compensation::Compensator;
use navfuse_core::estimators::pf_lc::{CompensationConfig, SirConfig, SirPf};
use navfuse_core::geodesy::{Geodetic, PlanePoint, SmallAreaPlane};
use navfuse_io::trajectory::{create_writer, open_nav_source, InFormat, OutFormat};
use std::path::PathBuf;

/// Particles of the SIR method.
const N_PARTICLES: usize = 1000;

/// Smoothing method.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Method {
    /// The paper's compensation (heading-change PDF blend).
    Paper,
    /// Bootstrap SIR particle filter (CTRV model).
    Sir,
}

/// Compensate GNSS positions with the seed 002 algorithm (or a SIR particle filter).
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// Input file (.pos, .nav, .csv; KF-GINS GNSS text with --from kfgins-gnss).
    pub input: PathBuf,
    /// Output file (.csv, .nav, .geojson, .kml, .gpx).
    pub output: PathBuf,
    #[arg(long, value_enum)]
    pub from: Option<From>,
    #[arg(long, value_enum)]
    pub to: Option<To>,
    /// GPS week for time-of-week-only inputs.
    #[arg(long, default_value_t = 0)]
    pub gps_week: u32,
    #[arg(long, value_enum, default_value = "paper")]
    pub method: Method,
    /// Compensation history span (default: the library default).
    #[arg(long)]
    pub span: Option<usize>,
    /// Compensation weight range.
    #[arg(long)]
    pub w_min: Option<f64>,
    #[arg(long)]
    pub w_max: Option<f64>,
    /// SIR: fix σ per horizontal axis [m].
    #[arg(long, default_value_t = 5.0 / 1.1774)]
    pub sigma_m: f64,
    /// SIR: random seed.
    #[arg(long, default_value_t = 2)]
    pub seed: u64,
}

pub fn run(args: Args) -> Result<(), String> {
    let fin = match args.from {
        Some(From::Pos) => InFormat::Pos,
        Some(From::Nav) => InFormat::Nav,
        Some(From::Csv) => InFormat::Csv,
        Some(From::KfginsGnss) => InFormat::KfGinsGnss,
        None => InFormat::from_path(&args.input).ok_or_else(|| {
            format!(
                "{}: cannot tell the input format from the extension; give --from",
                args.input.display()
            )
        })?,
    };
    let fout = match args.to {
        Some(To::Csv) => OutFormat::Csv,
        Some(To::Nav) => OutFormat::Nav,
        Some(To::Geojson) => OutFormat::GeoJson,
        Some(To::Kml) => OutFormat::Kml,
        Some(To::Gpx) => OutFormat::Gpx,
        None => OutFormat::from_path(&args.output).ok_or_else(|| {
            format!(
                "{}: cannot tell the output format from the extension; give --to",
                args.output.display()
            )
        })?,
    };
    let mut cc = CompensationConfig::default();
    if let Some(s) = args.span {
        cc.span = s;
    }
    if let Some(w) = args.w_min {
        cc.w_min = w;
    }
    if let Some(w) = args.w_max {
        cc.w_max = w;
    }
    cc.validate().map_err(|e| format!("compensation config: {e}"))?;
    if !(args.sigma_m.is_finite() && args.sigma_m > 0.0) {
        return Err(format!("--sigma-m must be > 0, got {}", args.sigma_m));
    }
    let mut comp = Compensator::new(cc);
    let mut sir: Box<SirPf<N_PARTICLES>> = Box::new(SirPf::new(SirConfig {
        sigma_meas_m: args.sigma_m,
        seed: args.seed,
        ..Default::default()
    }));
    let mut src = open_nav_source(&args.input, fin, args.gps_week).map_err(|e| e.to_string())?;
    let mut out = create_writer(&args.output, fout)
        .map_err(|e| format!("{}: cannot create: {e}", args.output.display()))?;
    let mut plane: Option<SmallAreaPlane> = None;
    let (mut written, mut shift_sum) = (0u64, 0.0f64);
    for sol in src.by_ref() {
        let mut sol = sol.map_err(|e| e.to_string())?;
        let geo = Geodetic { lat: sol.lat, lon: sol.lon, h: sol.h };
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
            .map_err(|e| format!("{}: write failed: {e}", args.output.display()))?;
        written += 1;
    }
    out.finish()
        .map_err(|e| format!("{}: write failed: {e}", args.output.display()))?;
    let st = src.stats();
    let extra = match args.method {
        Method::Paper => format!("{:?}", comp.stats()),
        Method::Sir => format!("{:?}", sir.stats()),
    };
    println!(
        "smooth-gps ({:?}): {} -> {}: {} records read, {} written, {} rejected by the reader; mean shift {:.3} m; {extra}; {st}",
        args.method,
        args.input.display(),
        args.output.display(),
        st.used,
        written,
        st.rejected_total(),
        shift_sum / written.max(1) as f64,
    );
    Ok(())
}
