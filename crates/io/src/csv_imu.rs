//! Generic CSV IMU reader with a column map, units, rate or increment form
//! and a mounting rotation; presets for the project's real recordings.
//!
//! - Columns by header name or by 0-based index; time from one seconds
//!   column (`week·604800 + value`, with [`CsvImuConfig::week`]) or from GPS
//!   week + time-of-week columns.
//! - Units: gyro deg/s or rad/s (deg or rad in increment form), accel g
//!   (standard gravity 9.80665 m/s²) or m/s² (g·s or m/s in increment form).
//! - Rate form is integrated to increments by the rule of [`crate::imu`]
//!   (trapezoid by default); the first sample's `dt` likewise.
//! - Mounting: `mount_rpy_deg` = roll, pitch, yaw (ZYX) of the IMU sensor
//!   axes relative to the vehicle body FRD axes. The reader forms
//!   `c_sb = dcm_from_euler(rpy)` (the same convention as `c_bn` from the
//!   vehicle attitude, with n → body and b → sensor), so
//!   `f_b = c_sb · f_s` and `Δθ_b = c_sb · Δθ_s`: sensor vectors are
//!   rotated into the body frame.
//! - Lines starting with the comment byte (default `#`) and blank lines are
//!   skipped; rows whose time equals or precedes the last accepted one are
//!   rejected (`duplicate time`, `time going backwards`); with
//!   `reject_repeated_values`, a row whose six sensor values repeat the
//!   previous row exactly is rejected as `repeated values` (a logger
//!   re-sending its last sample, as in drive_0708). Fields are not quoted.

use crate::counter_clock::{CounterClock, CounterUnwrap};
use crate::error::{ReadError, RecordStats};
use crate::imu::{Assembler, ImuForm, RawImu};
use crate::kfgins::{imu_next, next_data_line, ImuSource};
use crate::text::{LineSource, Sep};
use crate::timebase::{check_stamp, now_gps_seconds, Plausibility, TimeBase};
use navfuse_core::types::{ImuSample, Mat3, Vec3};
use std::io::BufRead;

/// Standard gravity [m/s²] for accelerometers in g.
pub const G0: f64 = 9.80665;
pub(crate) const REASON_REPEATED: &str = "repeated values (duplicate row)";

/// A column: by header name or 0-based index.
#[derive(Clone, Debug, PartialEq)]
pub enum Col {
    Name(String),
    Index(usize),
}

impl From<usize> for Col {
    fn from(i: usize) -> Col {
        Col::Index(i)
    }
}
impl From<&str> for Col {
    fn from(s: &str) -> Col {
        Col::Name(s.to_string())
    }
}

/// Where the time comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum CsvTime {
    /// Seconds; `t = week·604800 + value` with [`CsvImuConfig::week`].
    Seconds(Col),
    /// GPS week and time of week [s].
    WeekTow { week: Col, tow: Col },
    /// One column in any [`TimeBase`] (the week of `gps_week_tow` from
    /// [`CsvImuConfig::week`]); the first stamp is checked with
    /// [`crate::timebase::check_stamp`]: an implausible one is an error
    /// naming the likely base, a doubtful one a [`CsvImuReader::warnings`] entry.
    Based { col: Col, base: TimeBase },
    /// A device counter (unwrapped across its modulus) mapped to GPS time by
    /// a clock, e.g. from [`crate::counter_clock::fit_csv_counter`].
    Counter { col: Col, clock: CounterClock },
}

/// Per-reader state of the time column: counter unwrapping, the first-stamp check.
#[derive(Debug, Default)]
struct StampState {
    unwrap: CounterUnwrap,
    checked: bool,
    warnings: Vec<String>,
}

impl StampState {
    /// GPS seconds of the raw stamp of a [`CsvTime::Based`] / [`CsvTime::Counter`] column.
    fn gps(&mut self, time: &CsvTime, raw: f64, week: u32) -> Result<f64, String> {
        match time {
            CsvTime::Based { base, .. } => {
                if !self.checked {
                    self.checked = true;
                    match check_stamp(*base, raw, Some(week), now_gps_seconds()) {
                        Plausibility::Ok => {}
                        Plausibility::Warning(w) => self.warnings.push(w),
                        Plausibility::Error(e) => return Err(e),
                    }
                }
                base.to_gps_seconds(raw, Some(week))
            }
            CsvTime::Counter { clock, .. } => {
                if !raw.is_finite() || raw < 0.0 {
                    return Err(format!("counter {raw} is negative or not finite"));
                }
                Ok(clock.gps_seconds(self.unwrap.unwrap(raw, clock.modulus)))
            }
            CsvTime::Seconds(_) | CsvTime::WeekTow { .. } => {
                Ok(crate::time::gps_seconds(week, raw))
            }
        }
    }
}

/// Gyro unit: per second in rate form, plain angle in increment form.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GyroUnit {
    Deg,
    Rad,
}

/// Accelerometer unit: g or m/s² in rate form (g·s or m/s in increment form).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AccelUnit {
    G,
    Si,
}

/// Configuration of [`CsvImuReader`].
#[derive(Clone, Debug, PartialEq)]
pub struct CsvImuConfig {
    /// Field separator byte.
    pub delimiter: u8,
    /// Comment marker (first non-blank byte of a skipped line).
    pub comment: Option<u8>,
    /// The first non-comment line names the columns; data lines must then
    /// have as many fields as the header.
    pub header: bool,
    /// Exact field count required on data lines when there is no header.
    pub columns: Option<usize>,
    pub time: CsvTime,
    /// GPS week for [`CsvTime::Seconds`] (0 = unknown / already absolute).
    pub week: u32,
    /// Gyro x, y, z columns (sensor axes).
    pub gyro: [Col; 3],
    /// Accelerometer x, y, z columns (sensor axes).
    pub accel: [Col; 3],
    pub gyro_unit: GyroUnit,
    pub accel_unit: AccelUnit,
    pub form: ImuForm,
    /// Roll, pitch, yaw [deg] of the sensor axes w.r.t. the vehicle body FRD (None = aligned).
    pub mount_rpy_deg: Option<[f64; 3]>,
    /// A further small misalignment [deg] applied after the mounting
    /// rotation: `c_sb = dcm_from_euler(misalign) · dcm_from_euler(mount)`.
    pub misalign_rpy_deg: Option<[f64; 3]>,
    /// Reject a row whose six values equal the previous row's.
    pub reject_repeated_values: bool,
    /// Nominal rate [Hz] for the first sample's `dt` (None = first interval).
    pub nominal_rate_hz: Option<f64>,
    /// Magnetometer x, y, z columns (sensor axes, any unit), read beside
    /// each sample into [`CsvImuReader::aux`] with the mounting applied.
    pub mag: Option<[Col; 3]>,
    /// A column of an AHRS's own yaw [deg], read into [`CsvImuReader::aux`] [rad].
    pub yaw_deg: Option<Col>,
}

/// Extra values of one data row (see [`CsvImuConfig::mag`],
/// [`CsvImuConfig::yaw_deg`]): magnetometer in body FRD (mounting applied,
/// unit of the file), yaw [rad]; `t` in GPS seconds like the samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CsvAux {
    pub t: f64,
    pub mag_b: Option<Vec3>,
    pub yaw: Option<f64>,
}

impl CsvImuConfig {
    /// A comma-separated file with a header line naming the columns (or
    /// indices), rates in deg/s and m/s² (trapezoid rule), sensor axes = body
    /// FRD, no extra columns; change the other fields with struct update.
    pub fn new(time: CsvTime, gyro: [Col; 3], accel: [Col; 3]) -> Self {
        CsvImuConfig {
            delimiter: b',',
            comment: Some(b'#'),
            header: true,
            columns: None,
            time,
            week: 0,
            gyro,
            accel,
            gyro_unit: GyroUnit::Deg,
            accel_unit: AccelUnit::Si,
            form: ImuForm::RateTrapezoid,
            mount_rpy_deg: None,
            misalign_rpy_deg: None,
            reject_repeated_values: false,
            nominal_rate_hz: None,
            mag: None,
            yaw_deg: None,
        }
    }

    /// `drive_0708/imu_1934_gpst.csv`: no header (its column list is a `#`
    /// comment), `gps_week,gps_tow_s,acc_x_g,acc_y_g,acc_z_g,gyro_x_dps,
    /// gyro_y_dps,gyro_z_dps`; rates in g and deg/s; sensor axes rotated
    /// roll 180°, yaw 180° from the vehicle FRD (upstream configuration, see
    /// `data/README.md`; at rest this turns the +1 g z reading into −1 g),
    /// then the upstream misalignment [0, −6.79, 5.35]° (`misalign_rpy_deg`).
    /// Checked on the first 3 s at rest: the mean specific force becomes
    /// (−0.01, 0.30, −9.93) m/s², the same direction as `kfgins/imu.txt`
    /// (−0.00, 0.20, −10.2), which was prepared with the upstream
    /// conventions (so this confirms the composition order, not the values).
    /// Set `misalign_rpy_deg: None` for the pure axis flip. ~2 % repeated
    /// rows are rejected.
    pub fn drive_0708() -> Self {
        CsvImuConfig {
            delimiter: b',',
            comment: Some(b'#'),
            header: false,
            columns: Some(8),
            time: CsvTime::WeekTow {
                week: Col::Index(0),
                tow: Col::Index(1),
            },
            week: 0,
            accel: [Col::Index(2), Col::Index(3), Col::Index(4)],
            gyro: [Col::Index(5), Col::Index(6), Col::Index(7)],
            gyro_unit: GyroUnit::Deg,
            accel_unit: AccelUnit::G,
            form: ImuForm::RateTrapezoid,
            mount_rpy_deg: Some([180.0, 0.0, 180.0]),
            misalign_rpy_deg: Some([0.0, -6.79, 5.35]),
            reject_repeated_values: true,
            nominal_rate_hz: None,
            mag: None,
            yaw_deg: None,
        }
    }

    /// `static_vn310/vn310-imu.csv` (INSTINCT export, VectorNav VN-310, 50 Hz):
    /// time from `Time::GpsWeek` (full week; `GpsWeek` is the 10-bit week) and
    /// `GpsTow [s]`; the uncompensated rates `IMU::UncompGyro::* [rad/s]` and
    /// `IMU::UncompAccel::* [m/s^2]`, already in the VN-310 body frame (FRD,
    /// z ≈ −9.8 m/s² at rest), integrated by the trapezoid rule.
    pub fn vn310() -> Self {
        let c = |s: &str| Col::Name(s.to_string());
        CsvImuConfig {
            delimiter: b',',
            comment: Some(b'#'),
            header: true,
            columns: None,
            time: CsvTime::WeekTow {
                week: c("Time::GpsWeek"),
                tow: c("GpsTow [s]"),
            },
            week: 0,
            gyro: [
                c("IMU::UncompGyro::X [rad/s]"),
                c("IMU::UncompGyro::Y [rad/s]"),
                c("IMU::UncompGyro::Z [rad/s]"),
            ],
            accel: [
                c("IMU::UncompAccel::X [m/s^2]"),
                c("IMU::UncompAccel::Y [m/s^2]"),
                c("IMU::UncompAccel::Z [m/s^2]"),
            ],
            gyro_unit: GyroUnit::Rad,
            accel_unit: AccelUnit::Si,
            form: ImuForm::RateTrapezoid,
            mount_rpy_deg: None,
            misalign_rpy_deg: None,
            reject_repeated_values: false,
            nominal_rate_hz: None,
            mag: None,
            yaw_deg: None,
        }
    }
}

/// Columns a row can use: time (2 slots), gyro 3, accel 3, magnetometer 3, yaw.
const MAX_COLS: usize = 12;

/// Resolved column indices (the first `n` of time ×2, gyro, accel, then the
/// configured magnetometer and yaw); with field names.
#[derive(Debug)]
struct Resolved {
    idx: [usize; MAX_COLS],
    names: [String; MAX_COLS],
    n: usize,
    week_tow: bool,
    ncols: Option<usize>,
}

/// Streaming generic CSV IMU reader → [`ImuSample`] (body frame).
pub struct CsvImuReader<R> {
    src: LineSource<R>,
    cfg: CsvImuConfig,
    c_sb: Option<Mat3>,
    res: Option<Resolved>,
    prev_vals: Option<[f64; 6]>,
    asm: Assembler,
    done: bool,
    aux: Vec<CsvAux>,
    stamp: StampState,
}

const DEFAULT_NAMES: [&str; MAX_COLS] = [
    "time", "tow", "gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z", "mag_x", "mag_y",
    "mag_z", "yaw",
];

impl<R: BufRead> CsvImuReader<R> {
    pub fn new(rdr: R, file: &str, cfg: CsvImuConfig) -> Self {
        let dcm = |r: [f64; 3]| {
            navfuse_core::attitude::dcm_from_euler(&Vec3::new(
                r[0].to_radians(),
                r[1].to_radians(),
                r[2].to_radians(),
            ))
        };
        let c_sb = match (cfg.mount_rpy_deg, cfg.misalign_rpy_deg) {
            (None, None) => None,
            (m, a) => Some(a.map_or(Mat3::identity(), dcm) * m.map_or(Mat3::identity(), dcm)),
        };
        CsvImuReader {
            src: LineSource::new(rdr, file),
            asm: Assembler::new(cfg.form, cfg.nominal_rate_hz),
            cfg,
            c_sb,
            res: None,
            prev_vals: None,
            done: false,
            aux: Vec::new(),
            stamp: StampState::default(),
        }
    }

    pub fn stats(&self) -> &RecordStats {
        &self.src.stats
    }

    /// The magnetometer / yaw values of the rows read so far (empty unless
    /// [`CsvImuConfig::mag`] or [`CsvImuConfig::yaw_deg`] is set).
    pub fn aux(&self) -> &[CsvAux] {
        &self.aux
    }

    /// Doubts about the time stamps (e.g. a time of week without a week).
    pub fn warnings(&self) -> &[String] {
        &self.stamp.warnings
    }

    fn cols(&self) -> Vec<&Col> {
        let mut v = Vec::with_capacity(8);
        match &self.cfg.time {
            CsvTime::Seconds(c)
            | CsvTime::Based { col: c, .. }
            | CsvTime::Counter { col: c, .. } => {
                v.push(c);
                v.push(c);
            }
            CsvTime::WeekTow { week, tow } => {
                v.push(week);
                v.push(tow);
            }
        }
        v.extend(self.cfg.gyro.iter());
        v.extend(self.cfg.accel.iter());
        if let Some(m) = &self.cfg.mag {
            v.extend(m.iter());
        }
        v.extend(self.cfg.yaw_deg.iter());
        v
    }

    /// Resolve the column map, from the header line when there is one.
    fn resolve(&self, header: bool) -> Result<Resolved, ReadError> {
        let s = &self.src;
        let week_tow = matches!(self.cfg.time, CsvTime::WeekTow { .. });
        let mut idx = [0usize; MAX_COLS];
        let mut names: [String; MAX_COLS] = Default::default();
        let cols = self.cols();
        let n = cols.len();
        for (k, c) in cols.into_iter().enumerate() {
            let default = if k == 0 && week_tow {
                "week"
            } else if k == 8 && self.cfg.mag.is_none() {
                "yaw"
            } else {
                DEFAULT_NAMES[k]
            };
            match c {
                Col::Index(i) => {
                    idx[k] = *i;
                    names[k] = if header {
                        s.text(*i, "<header>").unwrap_or(default).to_string()
                    } else {
                        default.to_string()
                    };
                }
                Col::Name(n) => {
                    if !header {
                        return Err(s.err(
                            n.clone(),
                            "column given by name but the configuration has no header line",
                        ));
                    }
                    let mut found = None;
                    for i in 0..s.n_fields() {
                        if s.text(i, "<header>")? == n {
                            found = Some(i);
                            break;
                        }
                    }
                    idx[k] =
                        found.ok_or_else(|| s.err(n.clone(), "column not found in the header"))?;
                    names[k] = n.clone();
                }
            }
        }
        Ok(Resolved {
            idx,
            names,
            n,
            week_tow,
            ncols: if header {
                Some(s.n_fields())
            } else {
                self.cfg.columns
            },
        })
    }

    fn read_raw(&mut self) -> Result<Option<RawImu>, ReadError> {
        let sep = Sep::Byte(self.cfg.delimiter);
        loop {
            let min = self.res.as_ref().map_or(0, |r| r.ncols.unwrap_or(0));
            if !next_data_line(&mut self.src, min, sep, self.cfg.comment)? {
                return Ok(None);
            }
            if self.res.is_none() {
                let r = self.resolve(self.cfg.header)?;
                self.res = Some(r);
                if self.cfg.header {
                    self.src.stats.skipped += 1;
                    continue;
                }
            }
            let r = self.res.as_ref().expect("resolved");
            let s = &self.src;
            let n = s.n_fields();
            let used = &r.idx[..r.n];
            let need = used.iter().max().map_or(0, |m| m + 1);
            match r.ncols {
                Some(c) if n != c => {
                    let field = if n < c {
                        used.iter()
                            .position(|&i| i == n)
                            .map_or_else(|| format!("<column {}>", n + 1), |k| r.names[k].clone())
                    } else {
                        format!("<column {}>", c + 1)
                    };
                    return Err(s.err(field, format!("line has {n} columns, expected {c}")));
                }
                _ if n < need => {
                    let k = used.iter().position(|&i| i >= n).unwrap_or(0);
                    return Err(s.err(
                        r.names[k].clone(),
                        format!("missing (line has {n} columns)"),
                    ));
                }
                _ => {}
            }
            let t = if r.week_tow {
                let w = s.f64_named(r.idx[0], &r.names[0])?;
                if w < 0.0 || w.fract() != 0.0 || w > 1.0e5 {
                    return Err(s.err(r.names[0].clone(), format!("not a GPS week number: {w}")));
                }
                let tow = s.f64_named(r.idx[1], &r.names[1])?;
                if !(0.0..=1.0e6).contains(&tow) {
                    return Err(s.err(
                        r.names[1].clone(),
                        format!("time of week {tow} outside [0, 1e6]"),
                    ));
                }
                (w as u32, tow)
            } else {
                (self.cfg.week, s.f64_named(r.idx[0], &r.names[0])?)
            };
            let (mut week, mut tow) = t;
            let t = match &self.cfg.time {
                CsvTime::Seconds(_) | CsvTime::WeekTow { .. } => {
                    crate::time::gps_seconds(week, tow)
                }
                time => {
                    let t = self
                        .stamp
                        .gps(time, tow, week)
                        .map_err(|m| s.err(r.names[0].clone(), m))?;
                    (week, tow) = crate::time::week_tow(t);
                    t
                }
            };
            let mut v = [0.0; 6];
            for (k, x) in v.iter_mut().enumerate() {
                *x = s.f64_named(r.idx[2 + k], &r.names[2 + k])?;
            }
            if self.cfg.reject_repeated_values && self.prev_vals == Some(v) {
                self.src.stats.reject(REASON_REPEATED);
                continue;
            }
            self.prev_vals = Some(v);
            let gs = match self.cfg.gyro_unit {
                GyroUnit::Deg => std::f64::consts::PI / 180.0,
                GyroUnit::Rad => 1.0,
            };
            let as_ = match self.cfg.accel_unit {
                AccelUnit::G => G0,
                AccelUnit::Si => 1.0,
            };
            let mut gyro = Vec3::new(v[0], v[1], v[2]) * gs;
            let mut acc = Vec3::new(v[3], v[4], v[5]) * as_;
            let rot = |x: Vec3| self.c_sb.as_ref().map_or(x, |c| c * x);
            if r.n > 8 {
                let f = |k: usize| s.f64_named(r.idx[k], &r.names[k]);
                let (mag_b, k_yaw) = match self.cfg.mag {
                    Some(_) => (Some(rot(Vec3::new(f(8)?, f(9)?, f(10)?))), 11),
                    None => (None, 8),
                };
                let yaw = match self.cfg.yaw_deg {
                    Some(_) => Some(f(k_yaw)?.to_radians()),
                    None => None,
                };
                self.aux.push(CsvAux { t, mag_b, yaw });
            }
            if let Some(c) = &self.c_sb {
                gyro = c * gyro;
                acc = c * acc;
            }
            return Ok(Some(RawImu {
                t,
                week,
                tow,
                gyro,
                acc,
            }));
        }
    }
}

impl<R: BufRead> ImuSource for CsvImuReader<R> {
    fn read_raw(&mut self) -> Result<Option<RawImu>, ReadError> {
        CsvImuReader::read_raw(self)
    }
    fn stats_mut(&mut self) -> &mut RecordStats {
        &mut self.src.stats
    }
    fn asm(&mut self) -> &mut Assembler {
        &mut self.asm
    }
    fn done_mut(&mut self) -> &mut bool {
        &mut self.done
    }
}

impl<R: BufRead> Iterator for CsvImuReader<R> {
    type Item = Result<ImuSample, ReadError>;
    fn next(&mut self) -> Option<Self::Item> {
        imu_next(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{assert_err, collect, token_lines};
    use proptest::prelude::*;

    fn drive_unmounted() -> CsvImuConfig {
        CsvImuConfig {
            mount_rpy_deg: None,
            misalign_rpy_deg: None,
            ..CsvImuConfig::drive_0708()
        }
    }

    #[test]
    fn mounting_rotates_sensor_vectors_into_body() {
        // Sensor yawed +90° w.r.t. the body: its x axis points to body right (+y).
        let data = "0,1,0,0,0.5,0,0\n0.01,1,0,0,0.5,0,0\n";
        let cfg = CsvImuConfig {
            columns: None,
            time: CsvTime::Seconds(Col::Index(0)),
            gyro: [4.into(), 5.into(), 6.into()],
            accel: [1.into(), 2.into(), 3.into()],
            accel_unit: AccelUnit::Si,
            gyro_unit: GyroUnit::Rad,
            mount_rpy_deg: Some([0.0, 0.0, 90.0]),
            misalign_rpy_deg: None,
            reject_repeated_values: false,
            ..CsvImuConfig::drive_0708()
        };
        let v = read(data.as_bytes(), cfg).unwrap();
        let (f, w) = (v[1].dvel_b / v[1].dt, v[1].dtheta_b / v[1].dt);
        assert!((f - Vec3::new(0.0, 1.0, 0.0)).norm() < 1e-12, "{f}");
        assert!((w - Vec3::new(0.0, 0.5, 0.0)).norm() < 1e-12, "{w}");
        // drive_0708 preset: roll 180°, yaw 180° flips x and z; +1 g up-reading → −g in FRD.
        let flip = CsvImuConfig {
            misalign_rpy_deg: None,
            ..CsvImuConfig::drive_0708()
        };
        let v = read(DRIVE.as_bytes(), flip).unwrap();
        let f = v[1].dvel_b / v[1].dt;
        let raw = Vec3::new(0.123, 0.0325, 0.999) * G0; // trapezoid mean of rows 1–2
        assert!((f - Vec3::new(-raw.x, raw.y, -raw.z)).norm() < 1e-9, "{f}");
    }
    #[test]
    fn magnetometer_and_yaw_columns_go_to_aux_with_the_mounting() {
        let data = "t,wx,wy,wz,ax,ay,az,mx,my,mz,yaw\n\
                    0,0,0,0,0,0,-9.8,20,0,45,30\n\
                    0.01,0,0,0,0,0,-9.8,20,0,45,31\n";
        let cfg = CsvImuConfig {
            header: true,
            columns: None,
            time: CsvTime::Seconds("t".into()),
            gyro: ["wx".into(), "wy".into(), "wz".into()],
            accel: ["ax".into(), "ay".into(), "az".into()],
            accel_unit: AccelUnit::Si,
            gyro_unit: GyroUnit::Rad,
            mount_rpy_deg: Some([0.0, 0.0, 90.0]),
            misalign_rpy_deg: None,
            reject_repeated_values: false,
            mag: Some(["mx".into(), "my".into(), "mz".into()]),
            yaw_deg: Some("yaw".into()),
            ..CsvImuConfig::drive_0708()
        };
        let mut r = CsvImuReader::new(data.as_bytes(), "imu.csv", cfg.clone());
        assert_eq!(r.by_ref().map(Result::unwrap).count(), 2);
        let a = r.aux();
        assert_eq!(a.len(), 2);
        // Sensor x is body right: the 20-unit x reading becomes body +y.
        let m = a[1].mag_b.unwrap();
        assert!((m - Vec3::new(0.0, 20.0, 45.0)).norm() < 1e-12, "{m}");
        assert!((a[1].yaw.unwrap() - 31f64.to_radians()).abs() < 1e-15);
        assert_eq!(a[1].t, 0.01);
        // A bad magnetometer field is an error naming its column.
        let bad = data.replace(",45,31", ",x,31");
        let e = read(bad.as_bytes(), cfg).unwrap_err();
        assert_eq!((e.line, &*e.field), (3, "mz"), "{e}");
    }

    const DRIVE: &str =
        "# gps_week,gps_tow_s,acc_x_g,acc_y_g,acc_z_g,gyro_x_dps,gyro_y_dps,gyro_z_dps\n\
2374,243261.9850,0.115,0.036,0.985,0.099,-0.679,0.237\n\
2374,243261.9950,0.131,0.029,1.013,-0.809,2.922,0.015\n\
2374,243262.0040,0.131,0.029,1.013,-0.809,2.922,0.015\n\
2374,243262.0150,0.125,0.028,0.990,-0.786,2.953,0.137\n";

    fn read(data: &[u8], cfg: CsvImuConfig) -> Result<Vec<ImuSample>, ReadError> {
        collect(CsvImuReader::new(data, "imu.csv", cfg))
    }

    /// Replace field `k` of data line `l` (0-based, counting every line).
    fn with_field(text: &str, l: usize, k: usize, v: &[u8]) -> Vec<u8> {
        crate::testutil::with_field(text, Some(','), l, k, v)
    }

    #[test]
    fn drive_layout_units_trapezoid_and_repeated_rows() {
        let mut r = CsvImuReader::new(DRIVE.as_bytes(), "imu.csv", drive_unmounted());
        let v: Vec<ImuSample> = r.by_ref().map(Result::unwrap).collect();
        assert_eq!(v.len(), 3, "the repeated row is dropped");
        let st = r.stats();
        assert_eq!(
            (st.skipped, st.used, st.rejected_for(REASON_REPEATED)),
            (1, 3, 1)
        );
        assert!(st.is_balanced());
        assert_eq!(v[0].t, 2374.0 * 604800.0 + 243261.985);
        // Interval after the dropped row spans 0.995 → 0.015 = 0.02 s.
        assert!((v[2].dt - 0.02).abs() < 1e-9);
        let dt = v[2].dt;
        let want_ax = 0.5 * (0.131 + 0.125) * G0 * dt;
        assert!((v[2].dvel_b.x - want_ax).abs() < 1e-12);
        let want_gz = 0.5 * (0.015 + 0.137f64).to_radians() * dt;
        assert!((v[2].dtheta_b.z - want_gz).abs() < 1e-15);
        // First sample: rectangle over the first interval.
        assert!((v[0].dvel_b.z - 0.985 * G0 * v[0].dt).abs() < 1e-12);
    }

    #[test]
    fn duplicate_and_backward_times_are_counted() {
        let data = "0.00,1,2,3,4,5,6\n0.01,1,2,3,4,5,6.5\n0.01,1,2,3,4,5,7\n0.005,1,2,3,4,5,8\n0.02,1,2,3,4,5,9\n";
        let cfg = CsvImuConfig {
            header: false,
            columns: None,
            time: CsvTime::Seconds(Col::Index(0)),
            week: 0,
            gyro: [1.into(), 2.into(), 3.into()],
            accel: [4.into(), 5.into(), 6.into()],
            gyro_unit: GyroUnit::Rad,
            accel_unit: AccelUnit::Si,
            form: ImuForm::RateRectangle,
            reject_repeated_values: false,
            nominal_rate_hz: Some(100.0),
            ..CsvImuConfig::drive_0708()
        };
        let mut r = CsvImuReader::new(
            data.as_bytes(),
            "imu.csv",
            CsvImuConfig {
                mount_rpy_deg: None,
                misalign_rpy_deg: None,
                ..cfg
            },
        );
        let v: Vec<ImuSample> = r.by_ref().map(Result::unwrap).collect();
        assert_eq!(v.len(), 3);
        assert_eq!(v[0].dt, 0.01, "nominal rate");
        assert!(
            (v[2].dvel_b.z - 9.0 * 0.01).abs() < 1e-12,
            "rectangle: end-of-interval value"
        );
        assert_eq!(r.stats().rejected_for(crate::imu::REASON_DUP_TIME), 1);
        assert_eq!(r.stats().rejected_for(crate::imu::REASON_BACKWARDS), 1);
        assert!(r.stats().is_balanced());
    }

    #[test]
    fn increment_form_by_header_names_with_seconds_column() {
        let data = "# increments\ntime_s,dax,day,daz,dvx,dvy,dvz\n100.00,0.5,0,0,0.01,0,-0.098\n100.02,0,1.0,0,0.02,0,-0.196\n";
        let n = |s: &str| Col::Name(s.to_string());
        let cfg = CsvImuConfig {
            header: true,
            columns: None,
            time: CsvTime::Seconds(n("time_s")),
            week: 2374,
            gyro: [n("dax"), n("day"), n("daz")],
            accel: [n("dvx"), n("dvy"), n("dvz")],
            gyro_unit: GyroUnit::Deg,
            accel_unit: AccelUnit::Si,
            form: ImuForm::Increment,
            mount_rpy_deg: None,
            misalign_rpy_deg: None,
            reject_repeated_values: false,
            ..CsvImuConfig::drive_0708()
        };
        let v = read(data.as_bytes(), cfg.clone()).unwrap();
        assert_eq!(v.len(), 2);
        assert_eq!(v[1].t, 2374.0 * 604800.0 + 100.02);
        assert!(
            (v[0].dtheta_b.x - 0.5f64.to_radians()).abs() < 1e-15,
            "deg → rad, passed through"
        );
        assert_eq!(v[1].dvel_b.z, -0.196);
        assert!((v[0].dt - 0.02).abs() < 1e-12);
        // A name map without a header line is a configuration error at line 1.
        let no_hdr = CsvImuConfig {
            header: false,
            ..cfg
        };
        assert_err(read(b"1,2,3,4,5,6,7\n", no_hdr), "imu.csv", 1, "time_s");
    }

    const VN_HDR: &str = "Time [s],GpsCycle,GpsWeek,GpsTow [s],IMU::UncompAccel::X [m/s^2],IMU::UncompAccel::Y [m/s^2],\
IMU::UncompAccel::Z [m/s^2],IMU::UncompGyro::X [rad/s],IMU::UncompGyro::Y [rad/s],IMU::UncompGyro::Z [rad/s],Time::GpsWeek\n";
    const VN: &str = "0,2,255,403575.847627,0.098480731,0.30079985,-9.7986994,0.000011909131,0.0018414459,-0.00043417249,2303\n\
0.02,2,255,403575.867627,0.095162369,0.29370984,-9.8008289,0.00006294495,0.0018579793,0.0003588438,2303\n";

    #[test]
    fn vn310_preset_by_header_names() {
        let data = format!("{VN_HDR}{VN}");
        let v = read(data.as_bytes(), CsvImuConfig::vn310()).unwrap();
        assert_eq!(v.len(), 2);
        assert_eq!(
            v[0].t,
            2303.0 * 604800.0 + 403575.847627,
            "full week from Time::GpsWeek"
        );
        let dt = v[1].dt;
        assert!((dt - 0.02).abs() < 1e-9);
        assert!((v[1].dvel_b.z - 0.5 * (-9.7986994 - 9.8008289) * dt).abs() < 1e-12);
        assert!((v[1].dtheta_b.y - 0.5 * (0.0018414459 + 0.0018579793) * dt).abs() < 1e-15);
        // A missing named column is an error naming it.
        let bad = VN_HDR.replace("Time::GpsWeek", "Week");
        assert_err(
            read(format!("{bad}{VN}").as_bytes(), CsvImuConfig::vn310()),
            "imu.csv",
            1,
            "Time::GpsWeek",
        );
    }

    #[test]
    fn corruptions_name_file_line_field() {
        let cfg = drive_unmounted;
        assert_err(
            read(b"2374,243261.9850,0.115,0.036\n", cfg()),
            "imu.csv",
            1,
            "acc_z",
        );
        assert_err(
            read(&with_field(DRIVE, 2, 5, b"-0.8.09"), cfg()),
            "imu.csv",
            3,
            "gyro_x",
        );
        assert_err(
            read(&with_field(DRIVE, 1, 7, b"0.237,1"), cfg()),
            "imu.csv",
            2,
            "<column 9>",
        );
        assert_err(
            read(&with_field(DRIVE, 4, 3, b"NaN"), cfg()),
            "imu.csv",
            5,
            "acc_y",
        );
        assert_err(
            read(&with_field(DRIVE, 2, 6, b"\xff2.922"), cfg()),
            "imu.csv",
            3,
            "gyro_y",
        );
        assert_err(
            read(&with_field(DRIVE, 1, 0, b"2374.5"), cfg()),
            "imu.csv",
            2,
            "week",
        );
        // With a header the field is named by the header.
        let vn = format!("{VN_HDR}{VN}");
        assert_err(
            read(&with_field(&vn, 2, 6, b"nan"), CsvImuConfig::vn310()),
            "imu.csv",
            3,
            "IMU::UncompAccel::Z [m/s^2]",
        );
        assert_err(
            read(&with_field(&vn, 1, 8, b"\x80"), CsvImuConfig::vn310()),
            "imu.csv",
            2,
            "IMU::UncompGyro::Y [rad/s]",
        );
        let short = format!("{VN_HDR}0,2,255,403575.847627,0.098\n");
        assert_err(
            read(short.as_bytes(), CsvImuConfig::vn310()),
            "imu.csv",
            2,
            "IMU::UncompAccel::Y [m/s^2]",
        );
    }

    proptest! {
        #[test]
        fn never_panics(data in proptest::collection::vec(any::<u8>(), 0..400), lines in token_lines()) {
            let with_hdr = [VN_HDR.as_bytes(), &lines].concat();
            for (d, cfg) in [(&data, drive_unmounted()), (&lines, drive_unmounted()), (&with_hdr, CsvImuConfig::vn310()), (&lines, CsvImuConfig::vn310())] {
                let mut r = CsvImuReader::new(&d[..], "imu.csv", cfg);
                if r.by_ref().all(|x| x.is_ok()) {
                    prop_assert!(r.stats().is_balanced());
                }
            }
        }
    }
}
