//! `navfuse smooth-gps IN OUT`: the seed 002 GPS position compensation (or
//! the SIR comparator) on any GNSS/trajectory file
//! ([`navfuse_pipeline::smooth_gps`]). Formats as in `navfuse convert`.

use crate::convert::{From, To};
use clap::Args as ClapArgs;
use navfuse_pipeline::smooth_gps::{smooth_file, SmoothOptions};
use std::path::PathBuf;

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
    #[command(flatten)]
    pub opts: SmoothOptions,
}

pub fn run(args: Args) -> Result<(), String> {
    let fin = crate::convert::input_format(args.from, &args.input)?;
    let fout = crate::convert::output_format(args.to, &args.output)?;
    let s = smooth_file(&args.input, fin, &args.output, fout, &args.opts)?;
    let st = &s.reader;
    println!(
        "smooth-gps ({:?}): {} -> {}: {} records read, {} written, {} rejected by the reader; mean shift {:.3} m; {}; {st}",
        args.opts.method,
        args.input.display(),
        args.output.display(),
        st.used,
        s.written,
        st.rejected_total(),
        s.mean_shift_m,
        s.method_stats,
    );
    Ok(())
}
