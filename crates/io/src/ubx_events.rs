//! A u-blox UBX message stream → navfuse [`Event`]s (issue 17): NAV-PVT →
//! [`GnssFix`], ESF-RAW / ESF-MEAS gyro + accelerometer → [`ImuSample`]
//! (increment form), ESF wheel ticks / speed → [`OdometerSample`],
//! NAV-RELPOSNED → [`HeadingFix`].
//!
//! **Sensor time → GPS time.** ESF data carry a sensor time tag (u32, wraps),
//! not GPS time. The relation used is linear,
//! `t = t_anchor + (ttag − ttag_anchor)·tick_s`, with
//! - `tick_s` from [`UbxEventsConfig::esf_tick_s`] (default 1 ms, the unit
//!   the u-blox interface description gives ESF-MEAS `timeTag` and
//!   `calibTtag`; products whose ESF-RAW `sTtag` counts in other units need
//!   it set);
//! - the anchor from the last ESF-MEAS with `calibTtagValid`: its `timeTag`
//!   (sensor time) and `calibTtag` (the receiver's local time calibrated to
//!   GNSS, taken as GPS time of week [ms]), the GPS week from the last valid
//!   NAV-PVT (the week putting the TOW nearest that epoch).
//!
//! A sample whose time cannot be established this way — no anchor yet, no
//! NAV-PVT week yet, or more than [`MAX_EXTRAPOLATION_S`] from the anchor —
//! is rejected and counted (`REASON_NO_TIME`), never guessed. Limits: the
//! relation assumes `calibTtag` is GPS TOW and ESF-RAW and ESF-MEAS share one
//! sensor clock; neither is checked against a real F9R log yet.
//!
//! **Accounting.** Every item of every message is counted in
//! [`UbxEvents::stats`] (a [`RecordStats`] over items: one per NAV-PVT, per
//! NAV-RELPOSNED, per ESF data word, per other message): used (went into an
//! event), skipped (a type not converted: temperatures, RXM-RAWX, …) or
//! rejected by reason. The frame-level accounting stays with
//! [`crate::ubx::UbxReader`].
//!
//! Memory: fixed state only; events go to a callback (no per-message
//! allocation here).

use crate::imu::{Assembler, ImuForm, RawImu};
use crate::time::SECONDS_PER_WEEK;
use crate::ubx::{EsfData, NavRelPosNed, UbxMessage};
use crate::RecordStats;
use navfuse_core::types::{Event, HeadingFix, HeadingSource, ImuSample, OdometerSample, Vec3};
use std::f64::consts::PI;

/// Farthest a sensor time tag may lie from its anchor [s]: a ±50 ppm
/// sensor/receiver clock (a common TCXO/MEMS oscillator tolerance) drifts
/// 0.1 ms in 2 s, 1 % of a 100 Hz IMU interval; ESF-MEAS anchors come at the
/// navigation rate (≥ 1 Hz), so 2 s also tolerates one lost anchor.
pub const MAX_EXTRAPOLATION_S: f64 = 2.0;

pub const REASON_NO_TIME: &str = "ESF: sensor time not relatable to GPS time";
pub const REASON_NO_FIX: &str = "NAV-PVT: no valid 3-D fix";
pub const REASON_INCOMPLETE: &str = "ESF: incomplete gyro/accel set for a time tag";
pub const REASON_IMU_TIME: &str = "ESF: IMU time duplicate or going backwards";
pub const REASON_NO_TICK_SCALE: &str = "ESF: wheel ticks without metres_per_tick";
pub const REASON_TICK_TIME: &str = "ESF: wheel ticks duplicate or going backwards";
pub const REASON_REL_INVALID: &str = "NAV-RELPOSNED: relPos or heading not valid";
pub const REASON_REL_NO_CARRIER: &str = "NAV-RELPOSNED: no carrier-phase solution";
pub const REASON_REL_ACC: &str = "NAV-RELPOSNED: zero or invalid accuracy";
pub const REASON_NO_WEEK: &str = "no GPS week yet (no valid NAV-PVT before)";

/// Settings of the conversion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UbxEventsConfig {
    /// Length of one ESF sensor time tag count [s].
    pub esf_tick_s: f64,
    /// Distance per wheel tick [m] (vehicle/odometer calibration); `None`:
    /// tick data are rejected ([`REASON_NO_TICK_SCALE`]).
    pub metres_per_tick: Option<f64>,
    /// Nominal IMU rate [Hz] giving the first sample's interval (`None`: the
    /// first sample waits for the second, see [`crate::imu`]).
    pub imu_rate_hz: Option<f64>,
}

impl Default for UbxEventsConfig {
    fn default() -> Self {
        UbxEventsConfig {
            esf_tick_s: 1e-3,
            metres_per_tick: None,
            imu_rate_hz: None,
        }
    }
}

/// ESF data types used here (u-blox interface description, "ESF data types").
const T_GYRO_Z: u8 = 5;
const T_WHEEL_FL: u8 = 6;
const T_WHEEL_SINGLE: u8 = 10;
const T_SPEED: u8 = 11;
const T_GYRO_Y: u8 = 13;
const T_GYRO_X: u8 = 14;
const T_ACC_X: u8 = 16;
const T_ACC_Z: u8 = 18;

/// The six IMU channels of one sensor time tag being collected.
#[derive(Clone, Copy, Default)]
struct ImuSet {
    ttag: u32,
    /// gyro x, y, z [rad/s], accel x, y, z [m/s²].
    v: [f64; 6],
    have: u8,
    words: u8,
}

/// Channel index (0..6) of an IMU data type.
fn imu_channel(t: u8) -> Option<usize> {
    match t {
        T_GYRO_X => Some(0),
        T_GYRO_Y => Some(1),
        T_GYRO_Z => Some(2),
        T_ACC_X..=T_ACC_Z => Some(usize::from(t - T_ACC_X) + 3),
        _ => None,
    }
}

/// Streaming UBX → events converter (see the module doc).
pub struct UbxEvents {
    cfg: UbxEventsConfig,
    /// GPS time [s] of the last valid NAV-PVT (gives the week).
    last_pvt_t: Option<f64>,
    /// (sensor ttag, GPS week, TOW [s]) of the anchor.
    anchor: Option<(u32, u32, f64)>,
    set: Option<ImuSet>,
    asm: Assembler,
    /// Per wheel type 6..=10: last (tick count, GPS time).
    ticks: [Option<(u32, f64)>; 5],
    last_speed_t: f64,
    stats: RecordStats,
}

impl UbxEvents {
    pub fn new(cfg: UbxEventsConfig) -> Self {
        UbxEvents {
            cfg,
            last_pvt_t: None,
            anchor: None,
            set: None,
            asm: Assembler::new(ImuForm::RateTrapezoid, cfg.imu_rate_hz),
            ticks: [None; 5],
            last_speed_t: f64::NEG_INFINITY,
            stats: RecordStats::default(),
        }
    }

    /// Item accounting (see the module doc).
    pub fn stats(&self) -> &RecordStats {
        &self.stats
    }

    fn count(&mut self, r: Result<(), &'static str>) {
        self.stats.lines += 1;
        match r {
            Ok(()) => self.stats.used += 1,
            Err(why) => self.stats.reject(why),
        }
    }

    fn skip(&mut self, n: u64) {
        self.stats.lines += n;
        self.stats.skipped += n;
    }

    /// The GPS week putting `tow` [s] nearest the last NAV-PVT.
    fn week_for(&self, tow: f64) -> Option<u32> {
        let t = self.last_pvt_t?;
        let w = ((t - tow) / SECONDS_PER_WEEK).round();
        (w >= 0.0 && w < f64::from(u32::MAX)).then_some(w as u32)
    }

    /// GPS (week, TOW) of a sensor time tag.
    fn sensor_time(&self, ttag: u32) -> Option<(u32, f64)> {
        let (a_tag, week, tow) = self.anchor?;
        let d = f64::from(ttag.wrapping_sub(a_tag) as i32) * self.cfg.esf_tick_s;
        // A NaN (from a NaN tick) fails the test too: no time.
        (d.abs() <= MAX_EXTRAPOLATION_S).then_some((week, tow + d))
    }

    /// Convert one message, handing each event to `out` (time order within
    /// the message; across messages as the receiver sent them).
    pub fn push(&mut self, m: &UbxMessage, out: &mut dyn FnMut(Event)) {
        match m {
            UbxMessage::NavPvt(p) => {
                if let Some(t) = p.gps_time() {
                    self.last_pvt_t = Some(t);
                }
                match p.to_fix() {
                    Some(f) => {
                        self.count(Ok(()));
                        out(Event::Gnss(f));
                    }
                    None => self.count(Err(REASON_NO_FIX)),
                }
            }
            UbxMessage::NavRelPosNed(r) => {
                let h = self.heading(r);
                self.count(h.map(|h| out(Event::Heading(h))));
            }
            UbxMessage::EsfMeas(e) => {
                if let Some(c) = e.calib_ttag {
                    let tow = f64::from(c) * 1e-3;
                    if let Some(w) = self.week_for(tow) {
                        self.anchor = Some((e.time_tag, w, tow));
                    }
                }
                for d in &e.data {
                    self.word(*d, e.time_tag, out);
                }
                self.flush_set(out);
            }
            UbxMessage::EsfRaw(r) => {
                for (d, tag) in &r.data {
                    self.word(*d, *tag, out);
                }
            }
            UbxMessage::RxmRawx(_) | UbxMessage::RxmSfrbx(_) => self.skip(1),
        }
    }

    /// At the end of the stream: count what is still held back.
    pub fn finish(&mut self, out: &mut dyn FnMut(Event)) {
        self.flush_set(out);
        if let Some(why) = self.asm.finish() {
            // The held record's six words were counted used; move them.
            self.stats.used = self.stats.used.saturating_sub(6);
            for _ in 0..6 {
                self.stats.reject(why);
            }
        }
    }

    fn word(&mut self, d: EsfData, ttag: u32, out: &mut dyn FnMut(Event)) {
        if let Some(ch) = imu_channel(d.data_type) {
            if self.set.is_some_and(|s| s.ttag != ttag) {
                self.flush_set(out);
            }
            let s = self.set.get_or_insert(ImuSet {
                ttag,
                ..Default::default()
            });
            s.v[ch] = d.si().unwrap_or(f64::NAN);
            s.have |= 1 << ch;
            s.words += 1;
            if s.have == 0x3F {
                self.flush_set(out);
            }
            return;
        }
        let r = match d.data_type {
            T_WHEEL_FL..=T_WHEEL_SINGLE => self.wheel_ticks(d, ttag, out),
            T_SPEED => self.speed(d, ttag, out),
            _ => {
                self.skip(1);
                return;
            }
        };
        self.count(r);
    }

    /// Emit (or reject) the IMU set being collected.
    fn flush_set(&mut self, out: &mut dyn FnMut(Event)) {
        let Some(s) = self.set.take() else { return };
        let n = u64::from(s.words);
        let r = if s.have != 0x3F || s.words != 6 {
            Err(REASON_INCOMPLETE)
        } else if let Some((week, tow)) = self.sensor_time(s.ttag) {
            self.imu(week, tow, &s.v, out)
        } else {
            Err(REASON_NO_TIME)
        };
        for _ in 0..n {
            self.count(r);
        }
    }

    fn imu(
        &mut self,
        week: u32,
        tow: f64,
        v: &[f64; 6],
        out: &mut dyn FnMut(Event),
    ) -> Result<(), &'static str> {
        let raw = RawImu {
            t: crate::time::gps_seconds(week, tow),
            week,
            tow,
            gyro: Vec3::new(v[0], v[1], v[2]),
            acc: Vec3::new(v[3], v[4], v[5]),
        };
        match self.asm.push(raw) {
            Ok(s) => {
                let mut emit = |s: ImuSample| out(Event::Imu(s));
                s.into_iter().for_each(&mut emit);
                self.asm.take_queued().into_iter().for_each(&mut emit);
                Ok(())
            }
            Err(crate::imu::REASON_DUP_TIME | crate::imu::REASON_BACKWARDS) => Err(REASON_IMU_TIME),
            Err(why) => Err(why),
        }
    }

    /// Wheel ticks (types 6–10): bits 0–22 an absolute tick count (wraps at
    /// 2²³), bit 23 the direction (1 backwards). Speed = Δticks·metres_per_tick
    /// / Δt over the interval since the previous count of the same wheel;
    /// the first count of a wheel only starts the interval (used).
    fn wheel_ticks(
        &mut self,
        d: EsfData,
        ttag: u32,
        out: &mut dyn FnMut(Event),
    ) -> Result<(), &'static str> {
        let m_per_tick = self.cfg.metres_per_tick.ok_or(REASON_NO_TICK_SCALE)?;
        let (week, tow) = self.sensor_time(ttag).ok_or(REASON_NO_TIME)?;
        let t = crate::time::gps_seconds(week, tow);
        let k = usize::from(d.data_type - T_WHEEL_FL);
        let count = d.value & 0x7F_FFFF;
        let backwards = d.value & 0x80_0000 != 0;
        let prev = self.ticks[k];
        if let Some((_, t0)) = prev {
            if t <= t0 {
                return Err(REASON_TICK_TIME);
            }
        }
        self.ticks[k] = Some((count, t));
        let Some((c0, t0)) = prev else { return Ok(()) };
        let dn = f64::from(count.wrapping_sub(c0) & 0x7F_FFFF);
        let dt = t - t0;
        let v = dn * m_per_tick / dt;
        out(Event::Odometer(OdometerSample {
            t,
            dt,
            speed_mps: if backwards { -v } else { v },
            // Quantisation: one tick in dt, uniform → σ = tick/(dt·√12).
            std_mps: m_per_tick / (dt * 12f64.sqrt()),
            // FL, FR, RL, RR → wheels 1..4; the single-tick odometer → 0.
            wheel: if d.data_type == T_WHEEL_SINGLE {
                0
            } else {
                d.data_type - T_WHEEL_FL + 1
            },
        }));
        Ok(())
    }

    /// Speed (type 11): signed 24-bit, 1e-3 m/s per LSB, instantaneous.
    fn speed(
        &mut self,
        d: EsfData,
        ttag: u32,
        out: &mut dyn FnMut(Event),
    ) -> Result<(), &'static str> {
        let (week, tow) = self.sensor_time(ttag).ok_or(REASON_NO_TIME)?;
        let t = crate::time::gps_seconds(week, tow);
        if t <= self.last_speed_t {
            return Err(REASON_TICK_TIME);
        }
        self.last_speed_t = t;
        out(Event::Odometer(OdometerSample {
            t,
            dt: 0.0,
            speed_mps: f64::from(d.signed()) * 1e-3,
            std_mps: 0.0,
            wheel: 0,
        }));
        Ok(())
    }

    /// NAV-RELPOSNED → heading of the base→rover baseline. Flags (u-blox F9):
    /// bit 2 relPosValid, bits 3–4 carrSoln (1 float, 2 fixed), bit 8
    /// relPosHeadingValid. σ_heading = max(accHeading, √(accN² + accE²)/L_h)
    /// with `L_h` the horizontal baseline: the receiver's accHeading can be
    /// optimistic on a float solution, the geometric bound comes from the
    /// same message's position accuracies. Pitch = atan2(−D, L_h), σ = accD/L_h.
    fn heading(&self, r: &NavRelPosNed) -> Result<HeadingFix, &'static str> {
        if r.flags & (1 << 2) == 0 || r.flags & (1 << 8) == 0 {
            return Err(REASON_REL_INVALID);
        }
        if (r.flags >> 3) & 3 == 0 {
            return Err(REASON_REL_NO_CARRIER);
        }
        let tow = f64::from(r.itow_ms) * 1e-3;
        let week = self.week_for(tow).ok_or(REASON_NO_WEEK)?;
        let ned = r.rel_pos_ned_m();
        let lh = ned.x.hypot(ned.y);
        let acc_h = (f64::from(r.acc_heading_e5) * 1e-5).to_radians();
        let acc_ne = (f64::from(r.acc_n).hypot(f64::from(r.acc_e))) * 1e-4;
        let std_h = acc_h.max(acc_ne / lh);
        if !(std_h > 0.0 && std_h.is_finite()) {
            return Err(REASON_REL_ACC);
        }
        let mut hd = r.heading();
        while hd > PI {
            hd -= 2.0 * PI;
        }
        while hd <= -PI {
            hd += 2.0 * PI;
        }
        let length = f64::from(r.rel_pos_length_cm) * 1e-2 + f64::from(r.rel_pos_hp_length) * 1e-4;
        Ok(HeadingFix {
            t: crate::time::gps_seconds(week, tow),
            heading_rad: hd,
            pitch_rad: (-ned.z).atan2(lh),
            std_heading_rad: std_h,
            std_pitch_rad: f64::from(r.acc_d) * 1e-4 / lh,
            baseline_m: length,
            source: HeadingSource::DualAntenna,
        })
    }
}
