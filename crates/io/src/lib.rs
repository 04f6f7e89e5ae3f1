//! navfuse-io: streaming readers and writers. Units and frame conversions
//! happen here and nowhere else; errors name file, line and field
//! ([`ReadError`]: `FILE:LINE: field `NAME`: what is wrong`), and every
//! reader accounts for every input line ([`RecordStats`]).
//!
//! Readers are iterators over a `BufRead` (one reused line buffer, no
//! per-line allocation) yielding `Result<Record, ReadError>`; the first
//! error ends the stream, and no byte input makes them panic (proptested).
//!
//! - [`kfgins`]: KF-GINS IMU, GNSS and `.nav` text → `ImuSample`, `GnssFix`, `NavSolution`
//! - [`pos`]: RTKLIB `.pos` → `GnssFix` (with NED velocity)
//! - [`csv_imu`]: generic CSV IMU with column map, units, mounting; presets
//! - [`carrier_phase`]: multi-antenna carrier-phase CSV ↔ `CarrierPhaseSat` (reader and writer)
//! - [`navcsv`]: navfuse trajectory CSV → `NavSolution`
//! - [`imu`]: the rules turning stamped records into intervals (`dt`, integration)
//! - [`atomic`]: every output file written whole or not at all (temp + fsync + rename)
//! - [`writers`]: CSV, KF-GINS `.nav`, GeoJSON, KML, GPX
//! - [`pos_writer`]: RTKLIB `.pos` with σ, cross covariances and quality
//! - [`parquet_out`] (feature `parquet`, default): Parquet tables of solutions and the update journal
//! - [`trajectory`]: formats by name/extension (used by `navfuse convert`)
//! - [`nmea_heading`]: NMEA HDT / THS → dual-antenna `HeadingFix` (σ from configuration)
//! - [`ubx_events`]: a UBX stream (NAV-PVT, ESF-RAW/MEAS, NAV-RELPOSNED) → IMU, GNSS, odometer, heading events
//! - [`ubx_write`]: events → a UBX stream (simulated receivers, tests)
//! - [`time`]: GPS week/TOW ↔ GPS seconds ↔ GPST/UTC calendar

pub mod atomic;
pub mod beidou_d1d2;
pub mod carrier_phase;
pub mod counter_clock;
pub mod csv_imu;
pub mod data;
pub mod error;
pub mod fixed_fmt;
pub mod galileo_inav;
pub mod glonass_str;
pub mod gps_lnav;
pub mod imu;
pub mod kfgins;
pub mod kfgins_yaml;
pub mod live;
pub mod live_source;
pub mod live_stats;
pub mod live_ubx;
pub mod navcsv;
pub mod nmea;
pub mod nmea_heading;
pub mod odometer_csv;
#[cfg(feature = "parquet")]
pub mod parquet_out;
pub mod pos;
pub mod pos_writer;
pub mod rinex;
pub mod rinex_glonass;
pub mod rinex_nav3;
pub mod rinex_write;
pub mod sigma_read;
pub mod stdfile;
pub mod tag;
pub mod text;
pub mod time;
pub mod timebase;
pub mod trajectory;
pub mod ubx;
pub mod ubx_events;
#[cfg(test)]
mod ubx_events_tests;
pub mod ubx_gnss;
pub mod ubx_write;
pub mod writers;
pub mod yuma;

#[cfg(test)]
mod csv_time_tests;
#[cfg(test)]
mod realdata;
#[cfg(test)]
mod realdata_time;
#[cfg(test)]
mod testutil;

pub use error::{FailureKind, ReadError, RecordStats};

use std::fs::File;
use std::io::BufReader;
use std::path::Path;
use std::sync::Arc;

/// Open `path` for a reader: a buffered reader and the name errors will use.
pub fn open(path: &Path) -> Result<(BufReader<File>, String), ReadError> {
    let name = path.display().to_string();
    match File::open(path) {
        Ok(f) => Ok((BufReader::with_capacity(1 << 16, f), name)),
        Err(e) => Err(ReadError::new(
            &Arc::from(name.as_str()),
            0,
            "<file>",
            format!("cannot open: {e}"),
        )),
    }
}
