//! Apache Parquet tables of solutions and the update journal, so results
//! load straight into pandas, polars, DuckDB or Spark.
//!
//! Written with the `parquet` crate's low-level column writer (no Arrow, no
//! compression codec: f64 navigation values are close to incompressible and
//! every codec but snappy pulls C or a large build). One row group per
//! [`ROW_GROUP_ROWS`] rows; every column `REQUIRED`; unknown values are NaN,
//! as in the text formats. Units are in the column names (`lat_deg`,
//! `v_n_mps`, …) and the file's key-value metadata describes the table:
//! `navfuse.table` (its kind), `navfuse.frames` (frames and conventions),
//! `navfuse.columns` (JSON object: column → description with unit),
//! `navfuse.version`.
//!
//! Files are whole or absent: written to `NAME.tmp` beside the target and
//! renamed into place.

use crate::atomic::AtomicFile;
use crate::time::week_tow;
use crate::writers::{lon_deg, TrajectoryWriter};
use navfuse_core::estimators::eskf::UpdateLog;
use navfuse_core::types::NavSolution;
use parquet::basic::Type as Physical;
use parquet::data_type::{BoolType, ByteArray, ByteArrayType, DoubleType, Int32Type};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::file::writer::SerializedFileWriter;
use parquet::record::Field;
use parquet::schema::types::{ColumnPath, Type};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Rows per row group: 2²⁰ rows of ~20 f64 columns ≈ 170 MB uncompressed,
/// inside the 128 MB–1 GB row-group size the Parquet docs recommend for
/// scanners, and one group for any drive shorter than ~1.5 h at 200 Hz.
pub const ROW_GROUP_ROWS: usize = 1 << 20;

/// A Parquet read or write failure, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum ParquetOutError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: parquet: {source}")]
    Parquet {
        path: String,
        source: parquet::errors::ParquetError,
    },
    /// A table whose columns differ in length, or a file this module cannot read.
    #[error("{path}: {msg}")]
    Table { path: String, msg: String },
}

/// Values of one column.
#[derive(Clone, Debug, PartialEq)]
pub enum ColumnData {
    F64(Vec<f64>),
    I32(Vec<i32>),
    Bool(Vec<bool>),
    /// UTF-8 strings (dictionary encoded).
    Str(Vec<String>),
}

impl ColumnData {
    fn len(&self) -> usize {
        match self {
            ColumnData::F64(v) => v.len(),
            ColumnData::I32(v) => v.len(),
            ColumnData::Bool(v) => v.len(),
            ColumnData::Str(v) => v.len(),
        }
    }
}

/// One named column with its description (unit, frame) for the metadata.
#[derive(Clone, Debug, PartialEq)]
pub struct Column {
    pub name: String,
    pub doc: String,
    pub data: ColumnData,
}

impl Column {
    /// A column; `doc` states unit and frame.
    pub fn new(name: &str, doc: &str, data: ColumnData) -> Self {
        Column {
            name: name.into(),
            doc: doc.into(),
            data,
        }
    }
}

/// A table: its kind (`solution`, `journal`, `errors`, …), a note on frames
/// and conventions, and equal-length columns.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    pub kind: String,
    pub frames: String,
    pub columns: Vec<Column>,
}

impl Table {
    /// Rows (length of the first column; 0 without columns).
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, |c| c.data.len())
    }

    /// The column named `name`.
    pub fn column(&self, name: &str) -> Option<&ColumnData> {
        self.columns
            .iter()
            .find(|c| c.name == name)
            .map(|c| &c.data)
    }
}

/// Frames and conventions of [`solutions_table`].
pub const SOLUTION_FRAMES: &str = "GPS time (no leap seconds): t_gps_s = gps_week * 604800 + \
gps_tow_s. Position: WGS84 geodetic latitude/longitude [deg] (longitude in [-180, 180)) and \
ellipsoidal height [m] of the estimator's reference point (the IMU for inertial estimators). \
Velocity in the local NED frame [m/s]. Attitude: roll, pitch, yaw (ZYX Euler) of body FRD \
w.r.t. NED [deg]. std_*: 1-sigma, position and velocity in NED, attitude per axis. NaN: unknown.";

/// The solutions as a table: the rows of the `.nav` (week, seconds of week,
/// position, NED velocity, attitude) plus GPS time and the 1-σ columns, in
/// the same units and names as the navfuse trajectory CSV
/// ([`crate::writers::CSV_HEADER`]). Radians become degrees here.
pub fn solutions_table(sols: &[NavSolution]) -> Table {
    let f = |g: &dyn Fn(&NavSolution) -> f64| ColumnData::F64(sols.iter().map(g).collect());
    let d = f64::to_degrees;
    let week = sols.iter().map(|s| week_tow(s.t).0 as i32).collect();
    let mut columns = vec![
        Column::new("t_gps_s", "GPS time [s]", f(&|s| s.t)),
        Column::new("gps_week", "GPS week", ColumnData::I32(week)),
        Column::new(
            "gps_tow_s",
            "GPS seconds of week [s]",
            f(&|s| week_tow(s.t).1),
        ),
        Column::new("lat_deg", "WGS84 latitude [deg]", f(&|s| d(s.lat))),
        Column::new("lon_deg", "WGS84 longitude [deg]", f(&|s| lon_deg(s.lon))),
        Column::new("h_m", "ellipsoidal height [m]", f(&|s| s.h)),
    ];
    let axes = [("n", "north"), ("e", "east"), ("d", "down")];
    for (i, (a, name)) in axes.iter().enumerate() {
        let doc = format!("velocity {name} (NED) [m/s]");
        columns.push(Column::new(&format!("v_{a}_mps"), &doc, f(&|s| s.v_n[i])));
    }
    let rpy = ["roll", "pitch", "yaw"];
    for (i, a) in rpy.iter().enumerate() {
        let doc = format!("{a}, body FRD w.r.t. NED (ZYX) [deg]");
        columns.push(Column::new(&format!("{a}_deg"), &doc, f(&|s| d(s.rpy[i]))));
    }
    for (i, (a, name)) in axes.iter().enumerate() {
        let doc = format!("1-sigma position {name} [m]");
        let c = f(&|s| s.std_pos_ned[i]);
        columns.push(Column::new(&format!("std_{a}_m"), &doc, c));
    }
    for (i, (a, name)) in axes.iter().enumerate() {
        let doc = format!("1-sigma velocity {name} [m/s]");
        let c = f(&|s| s.std_v_n[i]);
        columns.push(Column::new(&format!("std_v{a}_mps"), &doc, c));
    }
    for (i, a) in rpy.iter().enumerate() {
        let doc = format!("1-sigma {a} [deg]");
        let c = f(&|s| d(s.std_rpy[i]));
        columns.push(Column::new(&format!("std_{a}_deg"), &doc, c));
    }
    Table {
        kind: "solution".into(),
        frames: SOLUTION_FRAMES.into(),
        columns,
    }
}

/// Every measurement update the ESKF tried (the rows of `innovations.csv`):
/// time, kind (`gnss_pos`, `gnss_vel`, `height`, `zupt`, `zaru`, `nhc`),
/// normalised innovation squared νᵀS⁻¹ν, its degrees of freedom and whether
/// the χ² gate accepted it.
pub fn journal_table(log: &[UpdateLog]) -> Table {
    let columns = vec![
        Column::new(
            "t_gps_s",
            "filter time of the update, GPS [s]",
            ColumnData::F64(log.iter().map(|u| u.t).collect()),
        ),
        Column::new(
            "kind",
            "update: gnss_pos, gnss_vel, height, zupt, zaru, nhc",
            ColumnData::Str(log.iter().map(|u| u.kind.name().to_string()).collect()),
        ),
        Column::new(
            "nis",
            "normalised innovation squared with the unscaled R [-]",
            ColumnData::F64(log.iter().map(|u| u.nis).collect()),
        ),
        Column::new(
            "dof",
            "measurement dimension (chi-square degrees of freedom)",
            ColumnData::I32(log.iter().map(|u| u.dof as i32).collect()),
        ),
        Column::new(
            "accepted",
            "applied (true) or rejected by the chi-square gate (false)",
            ColumnData::Bool(log.iter().map(|u| u.accepted).collect()),
        ),
    ];
    Table {
        kind: "journal".into(),
        frames: "GPS time [s]; NIS is dimensionless, compare with chi-square(dof) bounds.".into(),
        columns,
    }
}

/// Write [`solutions_table`] of `sols` to `path`.
pub fn write_solutions(path: &Path, sols: &[NavSolution]) -> Result<(), ParquetOutError> {
    write_table(path, &solutions_table(sols))
}

/// Write [`journal_table`] of `log` to `path`.
pub fn write_journal(path: &Path, log: &[UpdateLog]) -> Result<(), ParquetOutError> {
    write_table(path, &journal_table(log))
}

fn schema(t: &Table) -> parquet::errors::Result<Type> {
    let fields = t.columns.iter().map(|c| {
        let (phys, logical) = match c.data {
            ColumnData::F64(_) => (Physical::DOUBLE, None),
            ColumnData::I32(_) => (Physical::INT32, None),
            ColumnData::Bool(_) => (Physical::BOOLEAN, None),
            ColumnData::Str(_) => (
                Physical::BYTE_ARRAY,
                Some(parquet::basic::LogicalType::String),
            ),
        };
        Type::primitive_type_builder(&c.name, phys)
            .with_repetition(parquet::basic::Repetition::REQUIRED)
            .with_logical_type(logical)
            .build()
            .map(Arc::new)
    });
    Type::group_type_builder(&format!("navfuse_{}", t.kind))
        .with_fields(fields.collect::<parquet::errors::Result<_>>()?)
        .build()
}

fn properties(t: &Table, group_rows: usize) -> WriterProperties {
    let docs: serde_json::Map<String, serde_json::Value> = t
        .columns
        .iter()
        .map(|c| (c.name.clone(), c.doc.clone().into()))
        .collect();
    let kv = |k: &str, v: String| KeyValue::new(k.to_string(), v);
    let mut b = WriterProperties::builder()
        .set_created_by(format!("navfuse {}", env!("CARGO_PKG_VERSION")))
        .set_max_row_group_row_count(Some(group_rows))
        // Dictionaries only pay for repeated values (the journal's `kind`).
        .set_dictionary_enabled(false)
        .set_key_value_metadata(Some(vec![
            kv("navfuse.table", t.kind.clone()),
            kv("navfuse.frames", t.frames.clone()),
            kv(
                "navfuse.columns",
                serde_json::Value::Object(docs).to_string(),
            ),
            kv("navfuse.version", env!("CARGO_PKG_VERSION").into()),
        ]));
    for c in &t.columns {
        if matches!(c.data, ColumnData::Str(_)) {
            b = b.set_column_dictionary_enabled(ColumnPath::from(c.name.as_str()), true);
        }
    }
    b.build()
}

/// Encode `t` into `out`; returns `out` (not flushed).
fn encode<W: Write + Send>(out: W, t: &Table, group_rows: usize) -> parquet::errors::Result<W> {
    let props = Arc::new(properties(t, group_rows));
    let mut w = SerializedFileWriter::new(out, Arc::new(schema(t)?), props)?;
    let n = t.rows();
    // An empty table still gets one (empty) row group: readers see the schema.
    for g in 0..n.div_ceil(group_rows).max(1) {
        let r = g * group_rows..n.min((g + 1) * group_rows);
        let mut rg = w.next_row_group()?;
        for c in &t.columns {
            let mut cw = rg
                .next_column()?
                .ok_or_else(|| parquet::errors::ParquetError::General("schema ended".into()))?;
            match &c.data {
                ColumnData::F64(v) => {
                    cw.typed::<DoubleType>()
                        .write_batch(&v[r.clone()], None, None)?;
                }
                ColumnData::I32(v) => {
                    cw.typed::<Int32Type>()
                        .write_batch(&v[r.clone()], None, None)?;
                }
                ColumnData::Bool(v) => {
                    cw.typed::<BoolType>()
                        .write_batch(&v[r.clone()], None, None)?;
                }
                ColumnData::Str(v) => {
                    let b: Vec<ByteArray> =
                        v[r.clone()].iter().map(|s| s.as_str().into()).collect();
                    cw.typed::<ByteArrayType>().write_batch(&b, None, None)?;
                }
            }
            cw.close()?;
        }
        rg.close()?;
    }
    w.into_inner()
}

fn write_file(file: &mut AtomicFile, t: &Table, group_rows: usize) -> parquet::errors::Result<()> {
    let out = encode(file, t, group_rows)?;
    out.flush()?;
    Ok(())
}

/// Write `t` to `path`, whole or absent ([`AtomicFile`]).
/// Columns must all have the same length.
pub fn write_table(path: &Path, t: &Table) -> Result<(), ParquetOutError> {
    write_table_grouped(path, t, ROW_GROUP_ROWS)
}

/// [`write_table`] with `group_rows` rows per row group (≥ 1).
pub(crate) fn write_table_grouped(
    path: &Path,
    t: &Table,
    group_rows: usize,
) -> Result<(), ParquetOutError> {
    let name = path.display().to_string();
    if let Some(c) = t.columns.iter().find(|c| c.data.len() != t.rows()) {
        return Err(ParquetOutError::Table {
            path: name,
            msg: format!(
                "column {} has {} rows, expected {}",
                c.name,
                c.data.len(),
                t.rows()
            ),
        });
    }
    let io = |source| ParquetOutError::Io {
        path: name.clone(),
        source,
    };
    let mut file = AtomicFile::create(path).map_err(io)?;
    write_file(&mut file, t, group_rows.max(1)).map_err(|source| ParquetOutError::Parquet {
        path: name.clone(),
        source,
    })?;
    file.commit().map_err(io)
}

/// [`TrajectoryWriter`] for Parquet (`navfuse convert x.nav x.parquet`,
/// `formats = ["parquet"]`): buffers the solutions, writes
/// [`solutions_table`] at `finish` — to a path via [`write_solutions`]
/// (whole or absent), or encoded in memory and copied to any `Write`.
pub struct ParquetTrajectoryWriter {
    sols: Vec<NavSolution>,
    sink: Sink,
}

enum Sink {
    Path(PathBuf),
    Write(Box<dyn Write>),
}

impl ParquetTrajectoryWriter {
    /// Write `path` at `finish`.
    pub fn create(path: &Path) -> Self {
        ParquetTrajectoryWriter {
            sols: Vec::new(),
            sink: Sink::Path(path.into()),
        }
    }

    /// Write the encoded file into `w` at `finish`.
    pub fn new<W: Write + 'static>(w: W) -> Self {
        ParquetTrajectoryWriter {
            sols: Vec::new(),
            sink: Sink::Write(Box::new(w)),
        }
    }
}

impl TrajectoryWriter for ParquetTrajectoryWriter {
    fn write(&mut self, s: &NavSolution) -> std::io::Result<()> {
        self.sols.push(*s);
        Ok(())
    }
    fn finish(&mut self) -> std::io::Result<()> {
        let t = solutions_table(&self.sols);
        match &mut self.sink {
            Sink::Path(p) => write_table(p, &t).map_err(std::io::Error::other),
            Sink::Write(w) => {
                let bytes =
                    encode(Vec::new(), &t, ROW_GROUP_ROWS).map_err(std::io::Error::other)?;
                w.write_all(&bytes)?;
                w.flush()
            }
        }
    }
}

/// Read a flat table of DOUBLE, INT32, BOOLEAN and UTF-8 columns (what
/// [`write_table`] writes) back, with `kind` and `frames` from the metadata
/// (empty when absent) and the column descriptions from `navfuse.columns`.
pub fn read_table(path: &Path) -> Result<Table, ParquetOutError> {
    let name = path.display().to_string();
    let pq = |source| ParquetOutError::Parquet {
        path: name.clone(),
        source,
    };
    let file = std::fs::File::open(path).map_err(|source| ParquetOutError::Io {
        path: name.clone(),
        source,
    })?;
    let reader = SerializedFileReader::new(file).map_err(pq)?;
    let meta = reader.metadata().file_metadata();
    let kv = |k: &str| {
        meta.key_value_metadata()
            .and_then(|v| v.iter().find(|e| e.key == k))
            .and_then(|e| e.value.clone())
            .unwrap_or_default()
    };
    let docs: serde_json::Value =
        serde_json::from_str(&kv("navfuse.columns")).unwrap_or(serde_json::Value::Null);
    let mut columns: Vec<Column> = Vec::new();
    for c in meta.schema_descr().columns() {
        let data = match c.physical_type() {
            Physical::DOUBLE => ColumnData::F64(Vec::new()),
            Physical::INT32 => ColumnData::I32(Vec::new()),
            Physical::BOOLEAN => ColumnData::Bool(Vec::new()),
            Physical::BYTE_ARRAY => ColumnData::Str(Vec::new()),
            p => {
                return Err(ParquetOutError::Table {
                    path: name,
                    msg: format!("column {}: unsupported type {p:?}", c.name()),
                })
            }
        };
        let doc = docs[c.name()].as_str().unwrap_or("");
        columns.push(Column::new(c.name(), doc, data));
    }
    for row in reader.get_row_iter(None).map_err(pq)? {
        let row = row.map_err(pq)?;
        for ((_, f), c) in row.get_column_iter().zip(columns.iter_mut()) {
            match (f, &mut c.data) {
                (Field::Double(x), ColumnData::F64(v)) => v.push(*x),
                (Field::Int(x), ColumnData::I32(v)) => v.push(*x),
                (Field::Bool(x), ColumnData::Bool(v)) => v.push(*x),
                (Field::Str(x), ColumnData::Str(v)) => v.push(x.clone()),
                (f, _) => {
                    return Err(ParquetOutError::Table {
                        path: name,
                        msg: format!("column {}: unexpected value {f}", c.name),
                    })
                }
            }
        }
    }
    Ok(Table {
        kind: kv("navfuse.table"),
        frames: kv("navfuse.frames"),
        columns,
    })
}

#[cfg(test)]
#[path = "parquet_tests.rs"]
mod tests;
