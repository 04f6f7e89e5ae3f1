//! navfuse-io: streaming readers and writers. Units and frame conversions
//! happen here and nowhere else; errors name file, line and field
//! ([`ReadError`]), and every reader accounts for every input line
//! ([`RecordStats`]).

pub mod csv_imu;
pub mod data;
pub mod error;
pub mod imu;
pub mod kfgins;
pub mod live;
pub mod navcsv;
pub mod nmea;
pub mod pos;
pub mod text;
pub mod time;
pub mod trajectory;
pub mod ubx;
pub mod writers;

#[cfg(test)]
mod testutil;

pub use error::{ReadError, RecordStats};

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
