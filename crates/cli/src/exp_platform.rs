//! `navfuse experiment generalise` and `navfuse experiment align`: thin
//! wrappers of [`navfuse_pipeline::experiments`] (the scenario definitions,
//! scores and targets live there).

use clap::Args as ClapArgs;
use navfuse_pipeline::experiments::{align_check, generalise};
use std::path::{Path, PathBuf};

#[derive(ClapArgs, Debug)]
pub struct GeneraliseArgs {
    /// Seeds per cell (even seeds static start, odd seeds moving start).
    /// 30 by default: 10 cannot resolve the 95 % coverage band (see
    /// `generalise::DEFAULT_SEEDS`).
    #[arg(long, default_value_t = generalise::DEFAULT_SEEDS)]
    pub seeds: u64,
    /// First seed.
    #[arg(long, default_value_t = 0)]
    pub seed0: u64,
    /// Trajectory length [s].
    #[arg(long, default_value_t = 600.0)]
    pub duration: f64,
    /// Cells to run: comma-separated `platform[:imu[:gnss[:offset]]]`
    /// patterns (`*` = any), e.g. `car,uav:tactical:*:0.1`. Default: the
    /// 48 of the matrix; patterns also reach the platforms outside it
    /// (`marine`: a small craft in waves).
    #[arg(long)]
    pub cells: Option<String>,
    /// True IMU time offsets [s] instead of the matrix's 0 and 0.1, comma
    /// separated (e.g. `0,0.05,-0.05,0.2,-0.2` for the time-offset check).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub offsets: Option<Vec<f64>>,
    /// Also run the default given the true time offset (the time-offset
    /// check's reference: what estimating the offset costs).
    #[arg(long)]
    pub known_offset: bool,
    /// IMU output rate [Hz] of the simulated runs (the matrix's: 100).
    #[arg(long, default_value_t = 100.0)]
    pub imu_rate: f64,
    /// GNSS output rate [Hz] of the simulated runs instead of the grades'
    /// 1 Hz (same per-fix error model, so faster fixes are more correlated).
    #[arg(long)]
    pub gnss_rate: Option<f64>,
    /// Also print one line per cell and seed (h_rms and outage drift of the
    /// three configurations, the default's alignment, yaw error, warnings);
    /// the JSON always has them (`per_seed`).
    #[arg(long)]
    pub per_seed: bool,
    /// Write the results as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

#[derive(ClapArgs, Debug)]
pub struct AlignArgs {
    /// Seeds per scenario.
    #[arg(long, default_value_t = 50)]
    pub seeds: u64,
    /// Write the shares and per-seed rows as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

fn write_json<T: serde::Serialize>(path: &Path, v: &T) -> Result<(), String> {
    let text = serde_json::to_string_pretty(v).map_err(|e| e.to_string())?;
    navfuse_io::atomic::write_atomic(path, text)
        .map_err(|e| format!("{}: cannot write: {e}", path.display()))
}

pub fn generalise(a: GeneraliseArgs) -> Result<(), String> {
    let offsets = a.offsets.as_deref().unwrap_or(&generalise::OFFSETS_S);
    let cells = match &a.cells {
        Some(p) => generalise::select_cells_in(generalise::all_platforms_with(offsets), p)
            .map_err(|e| e.to_string())?,
        None => generalise::matrix_with(offsets),
    };
    let opt = generalise::GeneraliseOptions {
        seeds: a.seeds,
        seed0: a.seed0,
        duration_s: a.duration,
        known_offset: a.known_offset,
        imu_rate_hz: a.imu_rate,
        gnss_rate_hz: a.gnss_rate,
    };
    eprintln!(
        "generalise: {} cells × {} seeds × {} configurations, {} s each",
        cells.len(),
        a.seeds,
        3 + usize::from(a.known_offset),
        a.duration
    );
    let r = generalise::run_generalise(&cells, &opt).map_err(|e| e.to_string())?;
    print!("{}", generalise::format_table(&r));
    if a.per_seed {
        print!("{}", generalise::format_per_seed(&r));
    }
    if a.known_offset {
        print!("{}", generalise::format_known_offset(&r));
    }
    if let Some(p) = &a.json {
        write_json(p, &r)?;
    }
    Ok(())
}

pub fn align(a: AlignArgs) -> Result<(), String> {
    let r = align_check::run_align_check(&align_check::scenarios(), a.seeds)
        .map_err(|e| e.to_string())?;
    print!("{}", align_check::format_summary(&r));
    if let Some(p) = &a.json {
        write_json(p, &r)?;
    }
    Ok(())
}
