//! A simulated run as the UBX byte stream of a u-blox dead-reckoning
//! receiver with a dual-antenna heading (issue 17), written with
//! [`navfuse_io::ubx_write::UbxStreamWriter`]: the measured IMU (ESF-RAW),
//! the GNSS fixes (NAV-PVT), a single-tick odometer at 10 Hz from the true
//! forward speed (ESF-RAW type 10) and the true heading and pitch of a
//! 1 m fore–aft antenna baseline at every fix (NAV-RELPOSNED).
//!
//! The odometer and heading carry no simulated error beyond the stream's
//! quantisation (one wheel tick; 1e-5° of heading); their stated σ is
//! [`HEADING_STD_RAD`]. They exist to test readers and plumbing, not to
//! judge the aiding models.

use crate::{SimError, SimRun};
use navfuse_core::types::{Event, HeadingFix, HeadingSource, OdometerSample};
use navfuse_io::ubx_write::UbxStreamWriter;
use std::path::Path;

/// Odometer output interval in IMU samples (10 Hz at 100 Hz, the rate a
/// ZED-F9R takes wheel ticks at).
const ODO_EVERY: usize = 10;
/// Stated heading σ [rad]: 0.3°, the order a 1 m baseline with a fixed
/// carrier solution reaches (u-blox ZED-F9P moving base, 1 m).
pub const HEADING_STD_RAD: f64 = 0.3 * std::f64::consts::PI / 180.0;
/// Antenna baseline [m].
const BASELINE_M: f64 = 1.0;

/// The run's events for the stream, time ordered (IMU, odometer, GNSS,
/// heading at equal times).
pub fn ubx_events(run: &SimRun) -> Vec<Event> {
    let truth = &run.traj.truth;
    let at = |t: f64| {
        let k = truth
            .partition_point(|e| e.t < t - 1e-9)
            .min(truth.len() - 1);
        truth[k]
    };
    let mut ev: Vec<Event> = run.events();
    for (k, s) in run.imu.iter().enumerate() {
        if (k + 1) % ODO_EVERY == 0 {
            let e = at(s.t);
            let (p, y) = (e.rpy.y, e.rpy.z);
            // Forward body speed: first row of C_bn applied to v_n (ZYX).
            let v_x = p.cos() * (y.cos() * e.v_n.x + y.sin() * e.v_n.y) - p.sin() * e.v_n.z;
            ev.push(Event::Odometer(OdometerSample {
                t: s.t,
                dt: s.dt * ODO_EVERY as f64,
                speed_mps: v_x,
                std_mps: 0.0,
                wheel: 0,
            }));
        }
    }
    for f in &run.gnss {
        let e = at(f.t);
        ev.push(Event::Heading(HeadingFix {
            t: f.t,
            heading_rad: e.rpy.z,
            pitch_rad: e.rpy.y,
            std_heading_rad: HEADING_STD_RAD,
            std_pitch_rad: HEADING_STD_RAD,
            baseline_m: BASELINE_M,
            source: HeadingSource::DualAntenna,
        }));
    }
    let rank = |e: &Event| match e {
        Event::Imu(_) => 0,
        Event::Odometer(_) => 1,
        Event::Gnss(_) => 2,
        _ => 3,
    };
    ev.sort_by(|a, b| a.t().total_cmp(&b.t()).then(rank(a).cmp(&rank(b))));
    ev
}

/// Write the run's UBX stream to `path` ([`ubx_events`]); `metres_per_tick`
/// is the odometer's distance per tick [m].
pub fn write_ubx(run: &SimRun, path: &Path, metres_per_tick: f64) -> Result<(), SimError> {
    let mut w = UbxStreamWriter::new(Vec::new(), metres_per_tick);
    for e in ubx_events(run) {
        w.write(&e).map_err(|e| SimError::Io(e.to_string()))?;
    }
    navfuse_io::atomic::write_atomic(path, w.into_inner())
        .map_err(|e| SimError::Io(format!("{}: {e}", path.display())))
}
