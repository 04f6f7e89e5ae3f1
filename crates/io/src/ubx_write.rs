//! navfuse [`Event`]s → a UBX byte stream as a u-blox dead-reckoning
//! receiver (ZED-F9R class) would send it, with the encoders of
//! [`crate::ubx`]: the inverse of [`crate::ubx_events`], for simulated
//! streams and tests.
//!
//! - IMU sample → one ESF-RAW with gyro x/y/z and accel x/y/z as rates
//!   (`Δθ/dt`, `Δv/dt`, quantised to 2⁻¹² °/s and 2⁻¹⁰ m/s² as the receiver
//!   does), stamped with the sensor time tag of the sample's end time;
//! - odometer sample (wheel 0, `dt > 0`) → an ESF-RAW single-tick word
//!   (type 10): the distance is accumulated and the absolute tick count
//!   written (bit 23 set when reversing);
//! - GNSS fix → NAV-PVT; heading → NAV-RELPOSNED (a baseline of
//!   `baseline_m` at the heading and pitch, accHeading = σ);
//! - every [`ANCHOR_PERIOD_S`] of IMU time, an ESF-MEAS with
//!   `calibTtagValid` (no data words) relating the sensor time tag to GPS
//!   time of week, and before the first event a NAV-PVT giving the date
//!   (time valid, no fix) — what [`crate::ubx_events`] needs to time ESF data.
//!
//! The sensor clock counts [`UbxStreamWriter::tick_s`] per tag from an
//! arbitrary start (close to the u32 wrap, so the wrap is exercised).

use crate::time::{calendar_from_gps, week_tow, TimeSystem};
use crate::ubx::{encode, EsfData, EsfMeas, EsfRaw, NavPvt, NavRelPosNed, UbxMessage};
use navfuse_core::types::{Event, GnssFix, HeadingFix, ImuSample, OdometerSample};
use std::io::{self, Write};

/// Seconds of sensor time between two time anchors (the 1 Hz of a
/// receiver's navigation epochs).
pub const ANCHOR_PERIOD_S: f64 = 1.0;

/// Writes events as UBX frames (see the module doc).
pub struct UbxStreamWriter<W: Write> {
    w: W,
    /// Sensor time tag count length [s].
    pub tick_s: f64,
    /// Distance per wheel tick [m].
    pub metres_per_tick: f64,
    t0: Option<f64>,
    /// Sensor time tag of the first event (default: 100 s before the u32 wrap).
    pub tag0: u32,
    next_anchor: f64,
    distance_ticks: f64,
}

fn word(data_type: u8, v: f64) -> EsfData {
    let q = v.round().clamp(-8_388_608.0, 8_388_607.0) as i32;
    EsfData {
        data_type,
        value: (q as u32) & 0x00FF_FFFF,
    }
}

impl<W: Write> UbxStreamWriter<W> {
    /// A writer with a 1 ms sensor tick and `metres_per_tick`.
    pub fn new(w: W, metres_per_tick: f64) -> Self {
        UbxStreamWriter {
            w,
            tick_s: 1e-3,
            metres_per_tick,
            t0: None,
            // 100 s before the u32 wrap at 1 ms.
            tag0: u32::MAX - 100_000,
            next_anchor: f64::NEG_INFINITY,
            distance_ticks: 0.0,
        }
    }

    fn tag(&self, t: f64) -> u32 {
        let t0 = self.t0.unwrap_or(t);
        self.tag0
            .wrapping_add(((t - t0) / self.tick_s).round() as i64 as u32)
    }

    fn put(&mut self, m: &UbxMessage) -> io::Result<()> {
        self.w.write_all(&encode(m))
    }

    /// Write one event (events in time order).
    pub fn write(&mut self, ev: &Event) -> io::Result<()> {
        let t = ev.t();
        if self.t0.is_none() {
            // The sensor clock's origin on a whole millisecond of GPS time.
            self.t0 = Some((t * 1e3).round() * 1e-3);
            let mut p = pvt(t);
            p.fix_type = 0;
            p.flags = 0;
            self.put(&UbxMessage::NavPvt(p))?;
        }
        if t >= self.next_anchor {
            let tow = week_tow(t).1;
            let ms = (tow * 1e3).round();
            // The anchor at the whole millisecond: its tag from that time.
            let t_ms = t + (ms * 1e-3 - tow);
            self.put(&UbxMessage::EsfMeas(EsfMeas {
                time_tag: self.tag(t_ms),
                flags: 0x08,
                id: 0,
                data: Vec::new(),
                calib_ttag: Some(ms as u32),
            }))?;
            self.next_anchor = t + ANCHOR_PERIOD_S;
        }
        match ev {
            Event::Imu(s) => self.imu(s),
            Event::Gnss(f) => self.put(&UbxMessage::NavPvt(fix_pvt(f))),
            Event::Odometer(o) => self.odometer(o),
            Event::Heading(h) => self.put(&UbxMessage::NavRelPosNed(relposned(h))),
            _ => Ok(()),
        }
    }

    fn imu(&mut self, s: &ImuSample) -> io::Result<()> {
        let tag = self.tag(s.t);
        let w = s.dtheta_b / s.dt;
        let f = s.dvel_b / s.dt;
        let g = |x: f64| x.to_degrees() * 4096.0;
        let a = |x: f64| x * 1024.0;
        let data = [
            word(14, g(w.x)),
            word(13, g(w.y)),
            word(5, g(w.z)),
            word(16, a(f.x)),
            word(17, a(f.y)),
            word(18, a(f.z)),
        ]
        .map(|d| (d, tag))
        .to_vec();
        self.put(&UbxMessage::EsfRaw(EsfRaw { data }))
    }

    fn odometer(&mut self, o: &OdometerSample) -> io::Result<()> {
        if o.wheel != 0 || o.dt <= 0.0 {
            return Ok(());
        }
        self.distance_ticks += (o.speed_mps * o.dt).abs() / self.metres_per_tick;
        let count = (self.distance_ticks.floor() as u64 & 0x7F_FFFF) as u32;
        let dir = if o.speed_mps < 0.0 { 0x80_0000 } else { 0 };
        let d = EsfData {
            data_type: 10,
            value: count | dir,
        };
        let tag = self.tag(o.t);
        self.put(&UbxMessage::EsfRaw(EsfRaw {
            data: vec![(d, tag)],
        }))
    }

    /// The underlying writer.
    pub fn into_inner(self) -> W {
        self.w
    }
}

/// NAV-PVT with the date and time of GPS time `t` (valid date and time).
fn pvt(t: f64) -> NavPvt {
    let c = calendar_from_gps(t, TimeSystem::Utc, 3);
    let sec = c.second.floor();
    NavPvt {
        itow_ms: (week_tow(t).1 * 1e3).round() as u32,
        year: c.year as u16,
        month: c.month,
        day: c.day,
        hour: c.hour,
        min: c.minute,
        sec: sec as u8,
        valid: 0x07,
        nano_ns: ((c.second - sec) * 1e9).round() as i32,
        ..Default::default()
    }
}

fn fix_pvt(f: &GnssFix) -> NavPvt {
    let v = f.v_n.unwrap_or_default();
    let sv = f.std_v_n.map_or(0.0, |s| s.mean());
    NavPvt {
        fix_type: 3,
        // gnssFixOK, then carrSoln fixed (1) / float (2) / diffSoln (4).
        flags: match f.quality {
            1 => 0x81,
            2 => 0x41,
            4 => 0x03,
            _ => 0x01,
        },
        num_sv: f.num_sats,
        lat_e7: (f.lat.to_degrees() * 1e7).round() as i32,
        lon_e7: (f.lon.to_degrees() * 1e7).round() as i32,
        height_mm: (f.h * 1e3).round() as i32,
        h_acc_mm: (f.std_ned.x.hypot(f.std_ned.y) * 1e3).round() as u32,
        v_acc_mm: (f.std_ned.z * 1e3).round() as u32,
        vel_n_mms: (v.x * 1e3).round() as i32,
        vel_e_mms: (v.y * 1e3).round() as i32,
        vel_d_mms: (v.z * 1e3).round() as i32,
        s_acc_mms: (sv * 1e3).round() as u32,
        ..pvt(f.t)
    }
}

fn relposned(h: &HeadingFix) -> NavRelPosNed {
    let l = if h.baseline_m.is_finite() {
        h.baseline_m
    } else {
        1.0
    };
    let p = if h.pitch_rad.is_finite() {
        h.pitch_rad
    } else {
        0.0
    };
    let (n, e, d) = (
        l * p.cos() * h.heading_rad.cos(),
        l * p.cos() * h.heading_rad.sin(),
        -l * p.sin(),
    );
    // cm part + 0.1 mm part, as the receiver splits them.
    let split = |x: f64| {
        let cm = (x * 100.0).trunc();
        (cm as i32, ((x * 1e4) - cm * 100.0).round() as i8)
    };
    let (nc, nh) = split(n);
    let (ec, eh) = split(e);
    let (dc, dh) = split(d);
    let (lc, lh) = split(l);
    let hdg = h.heading_rad.to_degrees().rem_euclid(360.0);
    // Horizontal accuracies with √(accN² + accE²)/L = σ_heading.
    let acc = h.std_heading_rad * l * p.cos() / std::f64::consts::SQRT_2 * 1e4;
    let sp = if h.std_pitch_rad.is_finite() {
        h.std_pitch_rad
    } else {
        h.std_heading_rad
    };
    NavRelPosNed {
        version: 1,
        itow_ms: (week_tow(h.t).1 * 1e3).round() as u32,
        rel_pos_n_cm: nc,
        rel_pos_e_cm: ec,
        rel_pos_d_cm: dc,
        rel_pos_length_cm: lc,
        rel_pos_heading_e5: (hdg * 1e5).round() as i32,
        rel_pos_hp_n: nh,
        rel_pos_hp_e: eh,
        rel_pos_hp_d: dh,
        rel_pos_hp_length: lh,
        acc_n: acc.round() as u32,
        acc_e: acc.round() as u32,
        acc_d: (sp * l * p.cos() * 1e4).round() as u32,
        acc_length: acc.round() as u32,
        acc_heading_e5: (h.std_heading_rad.to_degrees() * 1e5).round() as u32,
        // gnssFixOK, diffSoln, relPosValid, carrSoln fixed, relPosHeadingValid.
        flags: 0x1 | 0x2 | 0x4 | (2 << 3) | (1 << 8),
        ..Default::default()
    }
}
