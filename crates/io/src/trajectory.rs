//! Trajectory formats by name or file extension: open any trajectory reader
//! as a stream of [`NavSolution`], create any writer. Used by `navfuse
//! convert` (and by anything that needs "a trajectory file").

use crate::atomic::AtomicFile;
use crate::error::{ReadError, RecordStats};
use crate::kfgins::{KfGinsGnssReader, KfGinsNavReader};
use crate::navcsv::NavCsvReader;
use crate::pos::PosReader;
use crate::writers::{
    CsvWriter, GeoJsonWriter, GpxWriter, KfGinsNavWriter, KmlWriter, TrajectoryWriter,
};
use navfuse_core::types::{GnssFix, NavSolution, Vec3};
use std::cell::RefCell;
use std::io::BufRead;
use std::path::Path;
use std::rc::Rc;

/// Trajectory input formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InFormat {
    /// RTKLIB `.pos`.
    Pos,
    /// KF-GINS `.nav`.
    Nav,
    /// navfuse trajectory CSV.
    Csv,
    /// KF-GINS GNSS text (no extension of its own: `.txt` is ambiguous).
    KfGinsGnss,
}

/// Trajectory output formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutFormat {
    Csv,
    Nav,
    GeoJson,
    Kml,
    Gpx,
    /// NMEA 0183 GGA + RMC + GST ([`crate::nmea::NmeaWriter`]).
    Nmea,
    /// Apache Parquet table (`crate::parquet_out`, feature `parquet`).
    Parquet,
    /// RTKLIB `.pos` ([`crate::pos_writer::PosWriter`]).
    Pos,
}

fn ext(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

impl InFormat {
    /// From the extension: `.pos`, `.nav`, `.csv`.
    pub fn from_path(path: &Path) -> Option<Self> {
        match ext(path).as_str() {
            "pos" => Some(InFormat::Pos),
            "nav" => Some(InFormat::Nav),
            "csv" => Some(InFormat::Csv),
            _ => None,
        }
    }
}

impl OutFormat {
    /// From the extension: `.csv`, `.nav`, `.geojson`/`.json`, `.kml`, `.gpx`,
    /// `.nmea`, `.parquet`, `.pos`.
    pub fn from_path(path: &Path) -> Option<Self> {
        match ext(path).as_str() {
            "csv" => Some(OutFormat::Csv),
            "nav" => Some(OutFormat::Nav),
            "geojson" | "json" => Some(OutFormat::GeoJson),
            "kml" => Some(OutFormat::Kml),
            "gpx" => Some(OutFormat::Gpx),
            "nmea" => Some(OutFormat::Nmea),
            "parquet" => Some(OutFormat::Parquet),
            "pos" => Some(OutFormat::Pos),
            _ => None,
        }
    }

    /// The file extension written for this format (without the dot).
    pub fn extension(self) -> &'static str {
        match self {
            OutFormat::Csv => "csv",
            OutFormat::Nav => "nav",
            OutFormat::GeoJson => "geojson",
            OutFormat::Kml => "kml",
            OutFormat::Gpx => "gpx",
            OutFormat::Nmea => "nmea",
            OutFormat::Parquet => "parquet",
            OutFormat::Pos => "pos",
        }
    }
}

/// A GNSS fix as a navigation solution: position, σ, velocity when the fix
/// has it; unknown velocity, attitude and their σ are NaN.
pub fn nav_from_fix(f: &GnssFix) -> NavSolution {
    let mut s = NavSolution::unknown_at(f.t);
    s.lat = f.lat;
    s.lon = f.lon;
    s.h = f.h;
    s.std_pos_ned = f.std_ned;
    s.v_n = f.v_n.unwrap_or(Vec3::repeat(f64::NAN));
    s.std_v_n = f.std_v_n.unwrap_or(Vec3::repeat(f64::NAN));
    s
}

/// A stream of solutions that keeps line accounting.
pub trait NavSource: Iterator<Item = Result<NavSolution, ReadError>> {
    fn stats(&self) -> &RecordStats;
}

struct Fixes<I>(I);

macro_rules! nav_source {
    ($t:ident) => {
        impl<R: BufRead> NavSource for $t<R> {
            fn stats(&self) -> &RecordStats {
                $t::stats(self)
            }
        }
    };
}
nav_source!(KfGinsNavReader);
nav_source!(NavCsvReader);

impl<I: Iterator<Item = Result<GnssFix, ReadError>>> Iterator for Fixes<I> {
    type Item = Result<NavSolution, ReadError>;
    fn next(&mut self) -> Option<Self::Item> {
        self.0.next().map(|r| r.map(|f| nav_from_fix(&f)))
    }
}
impl<R: BufRead> NavSource for Fixes<PosReader<R>> {
    fn stats(&self) -> &RecordStats {
        self.0.stats()
    }
}
impl<R: BufRead> NavSource for Fixes<KfGinsGnssReader<R>> {
    fn stats(&self) -> &RecordStats {
        self.0.stats()
    }
}

/// Open a trajectory reader over `rdr` (`name` labels errors).
pub fn nav_source<R: BufRead + 'static>(
    rdr: R,
    name: &str,
    fmt: InFormat,
    gps_week: u32,
) -> Box<dyn NavSource> {
    match fmt {
        InFormat::Pos => Box::new(Fixes(PosReader::new(rdr, name))),
        InFormat::Nav => Box::new(KfGinsNavReader::new(rdr, name, gps_week)),
        InFormat::Csv => Box::new(NavCsvReader::new(rdr, name)),
        InFormat::KfGinsGnss => Box::new(Fixes(KfGinsGnssReader::new(rdr, name, gps_week))),
    }
}

/// Open the trajectory file `path`.
pub fn open_nav_source(
    path: &Path,
    fmt: InFormat,
    gps_week: u32,
) -> Result<Box<dyn NavSource>, ReadError> {
    let (rdr, name) = crate::open(path)?;
    Ok(nav_source(rdr, &name, fmt, gps_week))
}

/// A writer of `fmt` over any `Write`.
pub fn writer<W: std::io::Write + 'static>(w: W, fmt: OutFormat) -> Box<dyn TrajectoryWriter> {
    match fmt {
        OutFormat::Csv => Box::new(CsvWriter::new(w)),
        OutFormat::Nav => Box::new(KfGinsNavWriter::new(w)),
        OutFormat::GeoJson => Box::new(GeoJsonWriter::new(w)),
        OutFormat::Kml => Box::new(KmlWriter::new(w)),
        OutFormat::Gpx => Box::new(GpxWriter::new(w)),
        OutFormat::Nmea => Box::new(crate::nmea::NmeaWriter::new(w)),
        OutFormat::Pos => Box::new(crate::pos_writer::PosWriter::new(w)),
        #[cfg(feature = "parquet")]
        OutFormat::Parquet => Box::new(crate::parquet_out::ParquetTrajectoryWriter::new(w)),
        #[cfg(not(feature = "parquet"))]
        OutFormat::Parquet => Box::new(NoParquet),
    }
}

/// Stands in for the Parquet writer when the `parquet` feature is off.
#[cfg(not(feature = "parquet"))]
struct NoParquet;

#[cfg(not(feature = "parquet"))]
impl TrajectoryWriter for NoParquet {
    fn write(&mut self, _: &NavSolution) -> std::io::Result<()> {
        Err(std::io::Error::new(
            std::io::ErrorKind::Unsupported,
            "Parquet output needs navfuse-io's `parquet` feature",
        ))
    }
    fn finish(&mut self) -> std::io::Result<()> {
        self.write(&NavSolution::default())
    }
}

/// Create a writer of `fmt` on `path`, written whole or not at all: the
/// file appears under its name only when `finish` succeeds (an
/// [`AtomicFile`](crate::atomic::AtomicFile)); dropped unfinished or after an
/// error, nothing is left and a previous version stays intact.
/// Parquet is written whole at `finish` too (same helper).
pub fn create_writer(path: &Path, fmt: OutFormat) -> std::io::Result<Box<dyn TrajectoryWriter>> {
    #[cfg(feature = "parquet")]
    if fmt == OutFormat::Parquet {
        return Ok(Box::new(
            crate::parquet_out::ParquetTrajectoryWriter::create(path),
        ));
    }
    let file = Rc::new(RefCell::new(AtomicFile::create(path)?));
    Ok(Box::new(Committing {
        inner: writer(SharedFile(file.clone()), fmt),
        file,
    }))
}

/// The [`AtomicFile`] shared between a format writer (which owns its sink)
/// and [`Committing`] (which commits it after the writer's `finish`).
struct SharedFile(Rc<RefCell<AtomicFile>>);

impl std::io::Write for SharedFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.borrow_mut().write(buf)
    }
    fn write_all(&mut self, buf: &[u8]) -> std::io::Result<()> {
        self.0.borrow_mut().write_all(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.0.borrow_mut().flush()
    }
}

/// A format writer whose `finish` also commits the file.
struct Committing {
    inner: Box<dyn TrajectoryWriter>,
    file: Rc<RefCell<AtomicFile>>,
}

impl TrajectoryWriter for Committing {
    fn write(&mut self, s: &NavSolution) -> std::io::Result<()> {
        self.inner.write(s)
    }
    fn finish(&mut self) -> std::io::Result<()> {
        self.inner.finish()?;
        self.file.borrow_mut().commit()
    }
}
