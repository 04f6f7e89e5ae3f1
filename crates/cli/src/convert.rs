//! `navfuse convert`: any trajectory reader → any trajectory writer.
//!
//! Formats come from the extensions (`.pos`, `.nav`, `.csv` in;
//! `.csv`, `.nav`, `.geojson`/`.json`, `.kml`, `.gpx` out) or from
//! `--from`/`--to`. KF-GINS GNSS text needs `--from kfgins-gnss`. Prints one
//! summary line: records read, written, rejected (with reasons).

use crate::fail::Fail;
use clap::{Args as ClapArgs, ValueEnum};
use navfuse_io::trajectory::{create_writer, open_nav_source, InFormat, OutFormat};
use std::path::PathBuf;

/// Input format names.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum From {
    /// RTKLIB .pos solution
    Pos,
    /// KF-GINS .nav
    Nav,
    /// navfuse trajectory CSV
    Csv,
    /// KF-GINS GNSS text (TOW lat lon h σN σE σD [vN vE vD σvN σvE σvD])
    KfginsGnss,
}

/// Output format names.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum To {
    Csv,
    Nav,
    Geojson,
    Kml,
    Gpx,
    /// NMEA 0183 (GGA, RMC, GST); GNSS inputs keep their quality and satellite count
    Nmea,
    /// RTKLIB .pos: σ from the input where it has them; Q 0 and cross terms
    /// `nan` (a trajectory file has no aiding status or covariance)
    Pos,
}

/// Convert between trajectory file formats (format from extension or given).
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// Input trajectory file.
    pub input: PathBuf,
    /// Output file.
    pub output: PathBuf,
    /// Input format (default: from the extension).
    #[arg(long, value_enum)]
    pub from: Option<From>,
    /// Output format (default: from the extension).
    #[arg(long, value_enum)]
    pub to: Option<To>,
    /// GPS week for time-of-week-only inputs (KF-GINS text; .nav lines with week 0).
    #[arg(long, default_value_t = 0)]
    pub gps_week: u32,
}

/// The input format: as given, else from the file's extension.
pub fn input_format(from: Option<From>, path: &std::path::Path) -> Result<InFormat, String> {
    Ok(match from {
        Some(From::Pos) => InFormat::Pos,
        Some(From::Nav) => InFormat::Nav,
        Some(From::Csv) => InFormat::Csv,
        Some(From::KfginsGnss) => InFormat::KfGinsGnss,
        None => InFormat::from_path(path).ok_or_else(|| {
            format!(
                "{}: cannot tell the input format from the extension; give --from (pos, nav, csv, kfgins-gnss)",
                path.display()
            )
        })?,
    })
}

/// The output format: as given, else from the file's extension.
pub fn output_format(to: Option<To>, path: &std::path::Path) -> Result<OutFormat, String> {
    Ok(match to {
        Some(To::Csv) => OutFormat::Csv,
        Some(To::Nav) => OutFormat::Nav,
        Some(To::Geojson) => OutFormat::GeoJson,
        Some(To::Kml) => OutFormat::Kml,
        Some(To::Gpx) => OutFormat::Gpx,
        Some(To::Nmea) => OutFormat::Nmea,
        Some(To::Pos) => OutFormat::Pos,
        None => OutFormat::from_path(path).ok_or_else(|| {
            format!(
                "{}: cannot tell the output format from the extension; give --to (csv, nav, geojson, kml, gpx, nmea, pos)",
                path.display()
            )
        })?,
    })
}

pub fn run(args: Args) -> Result<(), Fail> {
    let fin = input_format(args.from, &args.input).map_err(Fail::usage)?;
    let fout = output_format(args.to, &args.output).map_err(Fail::usage)?;
    if fout == OutFormat::Nmea && matches!(fin, InFormat::Pos | InFormat::KfGinsGnss) {
        return fixes_to_nmea(&args, fin);
    }
    let mut src = open_nav_source(&args.input, fin, args.gps_week)?;
    let werr = Fail::io(&args.output);
    let mut out = create_writer(&args.output, fout).map_err(Fail::io(&args.output))?;
    let mut written = 0u64;
    for sol in src.by_ref() {
        out.write(&sol?).map_err(Fail::io(&args.output))?;
        written += 1;
    }
    if written == 0 {
        return Err(no_records(&args.input, src.stats()));
    }
    out.finish().map_err(werr)?;
    let st = src.stats();
    println!(
        "convert: {} ({fin:?}) -> {} ({fout:?}): {} records read, {} written, {} rejected; {}",
        args.input.display(),
        args.output.display(),
        st.used,
        written,
        st.rejected_total(),
        st
    );
    Ok(())
}

/// An input that gave no record: an error naming the file and its counts
/// (never an empty output with exit 0).
fn no_records(input: &std::path::Path, st: &navfuse_io::RecordStats) -> Fail {
    Fail::input(format!("{}: no usable records ({st})", input.display()))
}

/// GNSS fixes → NMEA keeping each fix's quality and satellite count (the
/// trajectory path would lose them).
fn fixes_to_nmea(args: &Args, fin: InFormat) -> Result<(), Fail> {
    use navfuse_io::kfgins::KfGinsGnssReader;
    use navfuse_io::pos::PosReader;
    let (rdr, name) = navfuse_io::open(&args.input)?;
    let (n, st) = match fin {
        InFormat::Pos => write_nmea(PosReader::new(rdr, &name), PosReader::stats, args)?,
        _ => write_nmea(
            KfGinsGnssReader::new(rdr, &name, args.gps_week),
            KfGinsGnssReader::stats,
            args,
        )?,
    };
    println!(
        "convert: {} ({fin:?}) -> {} (Nmea): {} records read, {n} written, {} rejected; {st}",
        args.input.display(),
        args.output.display(),
        st.used,
        st.rejected_total(),
    );
    Ok(())
}

/// Stream the fixes of `src` to the NMEA output; no fix is an error and
/// leaves no output. Returns the count written and the reader's accounting.
fn write_nmea<R>(
    mut src: R,
    stats: impl Fn(&R) -> &navfuse_io::RecordStats,
    args: &Args,
) -> Result<(u64, navfuse_io::RecordStats), Fail>
where
    R: Iterator<Item = Result<navfuse_core::types::GnssFix, navfuse_io::ReadError>>,
{
    use navfuse_io::writers::TrajectoryWriter;
    let werr = |e: std::io::Error| Fail::io(&args.output)(e);
    let mut f = navfuse_io::atomic::AtomicFile::create(&args.output).map_err(werr)?;
    let mut w = navfuse_io::nmea::NmeaWriter::new(&mut f);
    let mut n = 0u64;
    for fix in src.by_ref() {
        w.write_fix(&fix?).map_err(werr)?;
        n += 1;
    }
    if n == 0 {
        return Err(no_records(&args.input, stats(&src)));
    }
    w.finish().map_err(werr)?;
    f.commit().map_err(werr)?;
    Ok((n, stats(&src).clone()))
}
