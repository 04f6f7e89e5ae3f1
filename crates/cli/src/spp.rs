//! `navfuse spp`: single-point positions from a RINEX observation file and
//! broadcast navigation file(s), written as an RTKLIB `.pos` (models,
//! weights and options: [`navfuse_core::gnss::spp`], file handling:
//! [`navfuse_pipeline::spp`]).

use crate::fail::Fail;
use clap::Args as ClapArgs;
use navfuse_core::gnss::spp::{SppConfig, TropoModel};
use navfuse_pipeline::spp::{run_spp, SppOptions};
use std::path::PathBuf;

/// Single-point positioning (GPS L1 C/A code, broadcast ephemeris).
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// Rover observation file (RINEX 2.1x or 3.0x), or a u-blox log (`.ubx`:
    /// RXM-RAWX epochs and RXM-SFRBX ephemerides, GPS L1 C/A).
    pub obs: PathBuf,
    /// Output solution file (RTKLIB `.pos`, Q = 5 single).
    pub out: PathBuf,
    /// Navigation file(s) (RINEX 2/3); optional for a `.ubx` log, which
    /// carries its own ephemerides.
    #[arg(long)]
    pub nav: Vec<PathBuf>,
    /// Elevation mask [deg].
    #[arg(long, default_value_t = 15.0)]
    pub elev_mask_deg: f64,
    /// Troposphere: saastamoinen (1/sin El, as RTKLIB), niell (Saastamoinen
    /// zenith delays, Niell mapping) or none.
    #[arg(long, default_value = "saastamoinen")]
    pub tropo: String,
    /// Do not apply the broadcast (Klobuchar) ionosphere.
    #[arg(long)]
    pub no_iono: bool,
    /// Do not exclude faulty satellites (RAIM FDE); a failed chi-square test
    /// then rejects the epoch.
    #[arg(long)]
    pub no_raim: bool,
    /// Reject epochs whose GDOP exceeds this (RTKLIB `pos2-rejgdop` default).
    #[arg(long, default_value_t = 30.0)]
    pub max_gdop: f64,
    /// σ in the output: `residuals` (the a-priori model scaled by the file's
    /// a-posteriori variance factor, when ≥ 30 pooled degrees of freedom) or
    /// `model` (the a-priori model alone, as RTKLIB writes).
    #[arg(long, default_value = "residuals")]
    pub sigma: String,
}

pub fn run(a: Args) -> Result<(), Fail> {
    if !(0.0..90.0).contains(&a.elev_mask_deg) {
        return Err(Fail::usage(format!(
            "--elev-mask-deg must be in [0, 90), got {}",
            a.elev_mask_deg
        )));
    }
    if a.max_gdop.is_nan() || a.max_gdop <= 0.0 {
        return Err(Fail::usage(format!(
            "--max-gdop must be > 0, got {}",
            a.max_gdop
        )));
    }
    if a.nav.is_empty() && !navfuse_pipeline::spp::is_ubx(&a.obs) {
        return Err(Fail::usage(format!(
            "{}: a RINEX observation file needs --nav (only a .ubx log carries its own ephemerides)",
            a.obs.display()
        )));
    }
    let tropo = match a.tropo.as_str() {
        "saastamoinen" => TropoModel::Saastamoinen,
        "niell" => TropoModel::SaastamoinenNiell,
        "none" => TropoModel::None,
        t => {
            return Err(Fail::usage(format!(
                "--tropo must be saastamoinen, niell or none, got `{t}`"
            )))
        }
    };
    let sigma_from_residuals = match a.sigma.as_str() {
        "residuals" => true,
        "model" => false,
        s => {
            return Err(Fail::usage(format!(
                "--sigma must be residuals or model, got `{s}`"
            )))
        }
    };
    let opts = SppOptions {
        sigma_from_residuals,
        solver: SppConfig {
            elev_mask: a.elev_mask_deg.to_radians(),
            iono: !a.no_iono,
            tropo,
            raim: !a.no_raim,
            max_gdop: a.max_gdop,
            ..SppConfig::default()
        },
    };
    let sum = run_spp(&a.obs, &a.nav, &a.out, &opts)?;
    eprintln!("{}", sum.text());
    eprintln!("wrote {}", a.out.display());
    Ok(())
}
