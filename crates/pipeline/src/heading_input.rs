//! `[input] heading = "hdt.nmea"`: a dual-antenna receiver's NMEA HDT / THS
//! heading ([`navfuse_io::nmea_heading`]) for the ESKF's baseline heading
//! model (`[filter.heading]`, on by default when it is given).
//!
//! The sentences carry no σ, so `[input] heading_sigma_deg` is required:
//! the receiver's datasheet heading accuracy for its baseline length (a few
//! tenths of a degree at 1 m for F9-class receivers); there is no honest
//! default.
//! Time: the UTC time of the epoch's GGA/RMC/ZDA, converted to GPS seconds
//! by the reader, then put on the IMU's base as the GNSS times are (the
//! week from the IMU file; time of week for a KF-GINS IMU file). It is GNSS
//! time, so the IMU time offset is not applied to it.

use crate::input::{InputReport, Loaded};
use navfuse_core::types::Event;
use navfuse_io::nmea_heading::NmeaHeadingReader;
use std::path::Path;

/// Seconds per GPS week.
const WEEK: f64 = 604_800.0;

/// Read `path` (NMEA with HDT/THS and the epoch's time sentences) with the
/// configured σ `sigma_deg`, put the headings on `loaded`'s IMU time base
/// and merge them into `loaded.aiding` (time order). Returns the file's
/// report (`summary.json` `inputs.heading`).
pub fn load_heading(
    path: &Path,
    sigma_deg: Option<f64>,
    loaded: &mut Loaded,
) -> Result<InputReport, String> {
    let sigma = match sigma_deg {
        Some(s) if s.is_finite() && s > 0.0 => s.to_radians(),
        Some(s) => return Err(format!("[input] heading_sigma_deg {s}: must be > 0")),
        None => {
            return Err(
                "[input] heading needs heading_sigma_deg (HDT/THS carry no σ: the \
                        receiver's datasheet heading accuracy for its baseline)"
                    .into(),
            )
        }
    };
    let (rdr, name) = navfuse_io::open(path).map_err(|e| e.to_string())?;
    let mut r = NmeaHeadingReader::new(rdr, &name, sigma);
    let mut v = r
        .by_ref()
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    let report = InputReport::new(path, "nmea-heading", r.stats(), v.len());
    if v.is_empty() {
        let why = r
            .last_rejection()
            .map_or(String::new(), |e| format!(" (last rejected: {e})"));
        return Err(format!("{}: no HDT/THS heading{why}", path.display()));
    }
    let Some(i0) = loaded.imu.first() else {
        return Ok(report);
    };
    if i0.t < WEEK {
        for h in v.iter_mut() {
            h.t = navfuse_io::time::week_tow(h.t).1;
        }
    }
    crate::odo_input::merge_aiding(
        loaded,
        path,
        "headings",
        "",
        v.into_iter().map(Event::Heading).collect(),
    )?;
    Ok(report)
}
