//! `navfuse baseline`: carrier-phase double-difference baseline between two
//! RINEX 2 observation files (model and options:
//! [`navfuse_pipeline::experiments::baseline`]).

use crate::fail::Fail;
use clap::Args as ClapArgs;
use std::path::{Path, PathBuf};

use navfuse_core::Vec3;
use navfuse_pipeline::experiments::baseline::{
    enu_at_ecef, load, process, stats, Opts, RejectReason, Summary,
};

/// Carrier-phase baseline between two RINEX observation files.
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// Rover observation file (RINEX 2).
    #[arg(long)]
    pub rover: PathBuf,
    /// Base observation file (RINEX 2); its header position is held fixed.
    #[arg(long)]
    pub base: PathBuf,
    /// Navigation file(s) (RINEX 2/3 GPS).
    #[arg(long, required = true)]
    pub nav: Vec<PathBuf>,
    /// Kinematic rover (position re-estimated every epoch).
    #[arg(long)]
    pub kinematic: bool,
    /// Use L2 too (needs L2/P2 observables).
    #[arg(long)]
    pub l2: bool,
    /// Elevation mask [deg].
    #[arg(long, default_value_t = 15.0)]
    pub mask_deg: f64,
    /// Ratio-test threshold.
    #[arg(long, default_value_t = 3.0)]
    pub ratio: f64,
    /// Epoch pairing tolerance [s].
    #[arg(long, default_value_t = 0.02)]
    pub pair_tol: f64,
    /// Reject epochs whose GDOP exceeds this (RTKLIB `pos2-rejgdop`, default
    /// 30); rejected epochs are counted, not solved.
    #[arg(long, default_value_t = 30.0)]
    pub max_gdop: f64,
    /// Do not model the troposphere (Saastamoinen + Niell at both sites).
    #[arg(long)]
    pub no_trop: bool,
    /// Relative humidity for the tropospheric model (0: hydrostatic only).
    #[arg(long, default_value_t = 0.0)]
    pub humidity: f64,
    /// Reference baseline ECEF (dx,dy,dz) [m] to print errors against.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub reference: Option<Vec<f64>>,
    /// Solve through the RTK/INS filter's core with the INS off
    /// (`navfuse_pipeline::rtk_gnss`, the same choices) instead of this
    /// tool's own DD filter: the two agree to < 0.1 mm on GEONET.
    #[arg(long)]
    pub via_rtk: bool,
    /// Per-epoch CSV output.
    #[arg(long, short)]
    pub out: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<(), Fail> {
    if args.max_gdop.is_nan() || args.max_gdop <= 0.0 {
        return Err(Fail::usage(format!(
            "--max-gdop must be > 0, got {}",
            args.max_gdop
        )));
    }
    if !(0.0..=1.0).contains(&args.humidity) {
        return Err(Fail::usage(format!(
            "--humidity must be in 0..1, got {}",
            args.humidity
        )));
    }
    if let Some(r) = args.reference.as_ref().filter(|r| r.len() != 3) {
        return Err(Fail::usage(format!(
            "--reference needs 3 values dx,dy,dz, got {}",
            r.len()
        )));
    }
    let opts = Opts {
        kinematic: args.kinematic,
        l2: args.l2,
        mask: args.mask_deg.to_radians(),
        ratio_min: args.ratio,
        pair_tol: args.pair_tol,
        max_gdop: args.max_gdop,
        trop: !args.no_trop,
        humidity: args.humidity,
        ..Default::default()
    };
    // The base's header position (both paths hold it fixed); the RTK path
    // reads the files itself.
    let (sum, base_e) = if args.via_rtk {
        let o = navfuse_pipeline::rtk_gnss::RtkGnssOpts::from(&opts);
        let run = navfuse_pipeline::rtk_gnss::rtk_gnss_only(&args.rover, &args.base, &args.nav, &o)
            .map_err(|e| Fail::input(e.to_string()))?;
        (run.to_summary(), run.base_e)
    } else {
        let (rover, base, nav) =
            load(&args.rover, &args.base, &args.nav).map_err(|e| Fail::input(String::from(e)))?;
        let sum = process(&base, &rover, &nav, &opts).map_err(|e| Fail::input(String::from(e)))?;
        let p = base.approx_pos;
        (sum, Vec3::new(p[0], p[1], p[2]))
    };
    if sum.epochs.is_empty() {
        return Err(Fail::input(format!(
            "{} / {}: no epoch could be solved ({} paired, {} unpaired)",
            args.rover.display(),
            args.base.display(),
            sum.paired(),
            sum.unpaired
        )));
    }
    if let Some(p) = &args.out {
        write_csv(p, &sum).map_err(|e| Fail::new(crate::fail::FailureKind::Io, e))?;
    }
    let n = sum.paired();
    let nfix = sum.epochs.iter().filter(|e| e.fixed_b.is_some()).count();
    println!(
        "{} paired epochs ({} unpaired): {} solved, {} fixed ({:.1} % of paired), {} slips reset",
        n,
        sum.unpaired,
        sum.epochs.len(),
        nfix,
        100.0 * nfix as f64 / n.max(1) as f64,
        sum.slips
    );
    println!(
        "rejected: {} with GDOP > {}, {} with < 4 satellites, {} singular",
        sum.rejected_for(RejectReason::Gdop),
        args.max_gdop,
        sum.rejected_for(RejectReason::FewSatellites),
        sum.rejected_for(RejectReason::Singular)
    );
    if let Some(last) = sum.epochs.last() {
        let b = last.fixed_b.unwrap_or(last.float_b);
        println!(
            "last solved epoch {} ({}): baseline ECEF ({:+.4}, {:+.4}, {:+.4}) m, length {:.4} m, ratio {:.1}",
            last.epoch,
            if last.fixed_b.is_some() { "fixed" } else { "float" },
            b.x,
            b.y,
            b.z,
            b.norm(),
            last.ratio
        );
        let enu = enu_at_ecef(&base_e, &b);
        println!(
            "ENU at base: E {:+.4} N {:+.4} U {:+.4} m",
            enu.x, enu.y, enu.z
        );
    }
    if let Some(r) = &args.reference {
        let reference = Vec3::new(r[0], r[1], r[2]);
        let st = stats(&sum, &reference);
        println!(
            "against the reference: first fix epoch {:?}, first correct fix epoch {:?} (ratio {:.2}, error {:.1} mm, runner-up candidate {:.1} mm away), last float error {:.1} mm, last fixed error {} mm, 3D RMS over the {} fixed epochs {:.1} mm, fixed epochs > 5 cm off {}, fixed epochs with integers unlike the last fix {}",
            st.first_fix_epoch,
            st.first_correct_fix_epoch,
            st.first_correct_fix_ratio,
            st.first_correct_fix_err * 1e3,
            st.first_correct_fix_runner_up * 1e3,
            st.last_float_err.norm() * 1e3,
            st.last_fixed_err.map(|e| format!("{:.1}", e.norm() * 1e3)).unwrap_or("-".into()),
            st.fixed,
            st.rms_fixed_3d * 1e3,
            st.wrong_fixed,
            st.integers_unlike_last
        );
    }
    Ok(())
}

/// Per-epoch CSV: solved and rejected epochs in time order (`status` fixed,
/// float or `rejected_<reason>`; a rejected epoch has empty baselines).
fn write_csv(p: &Path, sum: &Summary) -> Result<(), String> {
    use std::io::Write;
    let mut w =
        navfuse_io::atomic::AtomicFile::create(p).map_err(|e| format!("{}: {e}", p.display()))?;
    let io = |e: std::io::Error| format!("{}: {e}", p.display());
    writeln!(
        w,
        "epoch,gps_time_s,status,n_sats,pdop,gdop,float_dx,float_dy,float_dz,fixed_dx,fixed_dy,fixed_dz,ratio"
    )
    .map_err(io)?;
    let mut rows: Vec<(usize, String)> = Vec::with_capacity(sum.paired());
    for e in &sum.epochs {
        let fixed = e
            .fixed_b
            .map(|f| format!("{:.4},{:.4},{:.4}", f.x, f.y, f.z))
            .unwrap_or(",,".into());
        rows.push((
            e.epoch,
            format!(
                "{},{:.3},{},{},{:.2},{:.2},{:.4},{:.4},{:.4},{},{:.2}",
                e.epoch,
                e.t,
                if e.fixed_b.is_some() {
                    "fixed"
                } else {
                    "float"
                },
                e.n_sats,
                e.pdop,
                e.gdop,
                e.float_b.x,
                e.float_b.y,
                e.float_b.z,
                fixed,
                e.ratio
            ),
        ));
    }
    for r in &sum.rejected {
        rows.push((
            r.epoch,
            format!(
                "{},{:.3},rejected_{},{},,{:.2},,,,,,,",
                r.epoch,
                r.t,
                r.reason.label(),
                r.n_sats,
                r.gdop
            ),
        ));
    }
    rows.sort_by_key(|r| r.0);
    for (_, line) in rows {
        writeln!(w, "{line}").map_err(io)?;
    }
    w.commit().map_err(io)
}
