//! KF-GINS text formats (i2Nav-WHU KF-GINS `fileio/`): IMU, GNSS and `.nav`.
//! Whitespace-separated, one record per line, blank lines skipped.
//!
//! - IMU: `tow Δθx Δθy Δθz Δvx Δvy Δvz [extra…]`, body FRD, Δθ [rad], Δv
//!   [m/s] (KF-GINS `imudatalen` ≥ 7; columns beyond 7 are ignored).
//! - GNSS: `tow lat lon h σN σE σD` ([deg], [m]); also a 13-column variant
//!   `… vN vE vD σvN σvE σvD` ([m/s]) with NED velocity (navfuse's extension
//!   in the same spirit; KF-GINS itself reads the first 7).
//! - `.nav`: `week tow lat lon h vN vE vD roll pitch yaw` ([deg], [m], [m/s],
//!   ZYX Euler of body FRD w.r.t. NED). KF-GINS's own output writes week
//!   `0.000000000`; the reader then uses the week given as a parameter.
//!   Attitude may be `nan` (unknown, e.g. a GNSS-only truth file): it is read
//!   as NaN, which is this type's documented "unknown". Every other field
//!   must be finite.
//!
//! Time of week + the `week` parameter give GPS seconds (`t = week·604800 +
//! tow`; week 0 = unknown, then `t` is the time of week).

use crate::error::{ReadError, RecordStats};
use crate::imu::{Assembler, ImuForm, RawImu};
use crate::text::{in_range, LineSource, Sep};
use navfuse_core::types::{GnssFix, ImuSample, NavSolution, Vec3};
use std::io::BufRead;

pub(crate) const REASON_TRUNCATED_LAST: &str = "truncated last line (no newline at end of file)";

const IMU_FIELDS: [&str; 7] = [
    "tow", "dtheta_x", "dtheta_y", "dtheta_z", "dvel_x", "dvel_y", "dvel_z",
];
const GNSS_FIELDS: [&str; 13] = [
    "tow", "lat", "lon", "h", "std_n", "std_e", "std_d", "v_n", "v_e", "v_d", "std_vn", "std_ve",
    "std_vd",
];
const NAV_FIELDS: [&str; 11] = [
    "week", "tow", "lat", "lon", "h", "v_n", "v_e", "v_d", "roll", "pitch", "yaw",
];

/// Wrap an angle [rad] to (−π, π].
pub(crate) fn wrap_pi(a: f64) -> f64 {
    use std::f64::consts::PI;
    let w = a - 2.0 * PI * ((a + PI) / (2.0 * PI)).floor();
    if w <= -PI {
        w + 2.0 * PI
    } else {
        w
    }
}

/// Read the next data line: skips blank lines; a too-short unterminated last
/// line is rejected (counted), not an error. `Ok(false)` at EOF.
pub(crate) fn next_data_line<R: BufRead>(
    src: &mut LineSource<R>,
    min_fields: usize,
    sep: Sep,
    comment: Option<u8>,
) -> Result<bool, ReadError> {
    loop {
        if !src.next_line()? {
            return Ok(false);
        }
        if src.is_blank() || comment.is_some_and(|c| src.starts_with(c)) {
            src.stats.skipped += 1;
            continue;
        }
        src.split(sep);
        if src.is_unterminated_last() && src.n_fields() < min_fields {
            src.stats.reject(REASON_TRUNCATED_LAST);
            continue;
        }
        return Ok(true);
    }
}

fn tow_field<R: BufRead>(src: &LineSource<R>, i: usize) -> Result<f64, ReadError> {
    let tow = src.f64(i, "tow")?;
    in_range(tow, 0.0, 1.0e6, "time of week").map_err(|m| src.err("tow", m))
}

fn latlon<R: BufRead>(src: &LineSource<R>, i: usize) -> Result<(f64, f64), ReadError> {
    let lat = src.f64(i, "lat")?;
    let lat = in_range(lat, -90.0, 90.0, "latitude").map_err(|m| src.err("lat", m))?;
    let lon = src.f64(i + 1, "lon")?;
    let lon = in_range(lon, -180.0, 360.0, "longitude").map_err(|m| src.err("lon", m))?;
    Ok((lat.to_radians(), wrap_pi(lon.to_radians())))
}

fn std_field<R: BufRead>(
    src: &LineSource<R>,
    i: usize,
    name: &'static str,
) -> Result<f64, ReadError> {
    let v = src.f64(i, name)?;
    if v < 0.0 {
        return Err(src.err(name, format!("standard deviation {v} is negative")));
    }
    Ok(v)
}

/// Options of the KF-GINS IMU reader.
#[derive(Clone, Copy, Debug)]
pub struct KfGinsImuOptions {
    /// GPS week of the time-of-week stamps (0 = unknown).
    pub week: u32,
    /// Columns per line (KF-GINS `imudatalen`, ≥ 7). Lines must have exactly this many.
    pub columns: usize,
    /// Nominal rate [Hz] giving the first sample's `dt`; `None` = use the first interval.
    pub nominal_rate_hz: Option<f64>,
}

impl Default for KfGinsImuOptions {
    fn default() -> Self {
        KfGinsImuOptions {
            week: 0,
            columns: 7,
            nominal_rate_hz: None,
        }
    }
}

/// Streaming KF-GINS IMU text reader → [`ImuSample`] (see [`crate::imu`] for the `dt` rule).
pub struct KfGinsImuReader<R> {
    src: LineSource<R>,
    opt: KfGinsImuOptions,
    asm: Assembler,
    done: bool,
}

impl<R: BufRead> KfGinsImuReader<R> {
    pub fn new(rdr: R, file: &str, opt: KfGinsImuOptions) -> Self {
        KfGinsImuReader {
            src: LineSource::new(rdr, file),
            opt,
            asm: Assembler::new(ImuForm::Increment, opt.nominal_rate_hz),
            done: false,
        }
    }

    /// Line accounting so far (complete after the iterator returned `None`).
    pub fn stats(&self) -> &RecordStats {
        &self.src.stats
    }

    fn read_raw(&mut self) -> Result<Option<RawImu>, ReadError> {
        let ncol = self.opt.columns.max(7);
        if !next_data_line(&mut self.src, ncol, Sep::Whitespace, None)? {
            return Ok(None);
        }
        let s = &self.src;
        if s.n_fields() < ncol && s.n_fields() >= 7 {
            return Err(s.err(
                "<extra>",
                format!(
                    "missing (line has {} columns, imudatalen = {ncol})",
                    s.n_fields()
                ),
            ));
        }
        if s.n_fields() > ncol {
            return Err(s.err(
                format!("<column {}>", ncol + 1),
                format!(
                    "unexpected extra column (line has {} columns, expected {ncol})",
                    s.n_fields()
                ),
            ));
        }
        s.expect_fields(&IMU_FIELDS, true)?;
        let tow = tow_field(s, 0)?;
        let mut v = [0.0; 6];
        for (k, x) in v.iter_mut().enumerate() {
            *x = s.f64(k + 1, IMU_FIELDS[k + 1])?;
        }
        Ok(Some(RawImu {
            t: crate::time::gps_seconds(self.opt.week, tow),
            week: self.opt.week,
            tow,
            gyro: Vec3::new(v[0], v[1], v[2]),
            acc: Vec3::new(v[3], v[4], v[5]),
        }))
    }
}

impl<R: BufRead> Iterator for KfGinsImuReader<R> {
    type Item = Result<ImuSample, ReadError>;
    fn next(&mut self) -> Option<Self::Item> {
        imu_next(self)
    }
}

/// Access to the iterator state of an IMU reader (for [`imu_next`]).
pub(crate) trait ImuSource {
    fn read_raw(&mut self) -> Result<Option<RawImu>, ReadError>;
    fn stats_mut(&mut self) -> &mut RecordStats;
    fn asm(&mut self) -> &mut Assembler;
    fn done_mut(&mut self) -> &mut bool;
}

/// Shared iterator step of the IMU readers: read records, feed the
/// assembler, count used/rejected, stop after the first error.
pub(crate) fn imu_next<T: ImuSource>(this: &mut T) -> Option<Result<ImuSample, ReadError>> {
    if *this.done_mut() {
        return None;
    }
    if let Some(q) = this.asm().take_queued() {
        this.stats_mut().used += 1;
        return Some(Ok(q));
    }
    loop {
        match this.read_raw() {
            Err(e) => {
                *this.done_mut() = true;
                return Some(Err(e));
            }
            Ok(None) => {
                *this.done_mut() = true;
                if let Some(reason) = this.asm().finish() {
                    this.stats_mut().reject(reason);
                }
                return None;
            }
            Ok(Some(raw)) => match this.asm().push(raw) {
                Err(reason) => this.stats_mut().reject(reason),
                Ok(None) => {}
                Ok(Some(s)) => {
                    this.stats_mut().used += 1;
                    return Some(Ok(s));
                }
            },
        }
    }
}

impl<R: BufRead> ImuSource for KfGinsImuReader<R> {
    fn read_raw(&mut self) -> Result<Option<RawImu>, ReadError> {
        KfGinsImuReader::read_raw(self)
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

/// Streaming KF-GINS GNSS text reader (7 or 13 columns) → [`GnssFix`].
///
/// The column count is taken from the first data line and then required
/// on every line. Quality and satellite count are 0 (unknown).
pub struct KfGinsGnssReader<R> {
    src: LineSource<R>,
    week: u32,
    columns: Option<usize>,
    done: bool,
}

impl<R: BufRead> KfGinsGnssReader<R> {
    /// `week`: GPS week of the time-of-week stamps (0 = unknown).
    pub fn new(rdr: R, file: &str, week: u32) -> Self {
        KfGinsGnssReader {
            src: LineSource::new(rdr, file),
            week,
            columns: None,
            done: false,
        }
    }

    pub fn stats(&self) -> &RecordStats {
        &self.src.stats
    }

    fn read(&mut self) -> Result<Option<GnssFix>, ReadError> {
        if !next_data_line(
            &mut self.src,
            self.columns.unwrap_or(7),
            Sep::Whitespace,
            None,
        )? {
            return Ok(None);
        }
        let s = &self.src;
        let ncol = match self.columns {
            Some(n) => n,
            None if s.n_fields() >= 13 => 13,
            None => 7,
        };
        s.expect_fields(&GNSS_FIELDS[..ncol], false)?;
        self.columns = Some(ncol);
        let tow = tow_field(s, 0)?;
        let (lat, lon) = latlon(s, 1)?;
        let h = s.f64(3, "h")?;
        let std_ned = Vec3::new(
            std_field(s, 4, "std_n")?,
            std_field(s, 5, "std_e")?,
            std_field(s, 6, "std_d")?,
        );
        let (v_n, std_v_n) = if ncol == 13 {
            (
                Some(Vec3::new(
                    s.f64(7, "v_n")?,
                    s.f64(8, "v_e")?,
                    s.f64(9, "v_d")?,
                )),
                Some(Vec3::new(
                    std_field(s, 10, "std_vn")?,
                    std_field(s, 11, "std_ve")?,
                    std_field(s, 12, "std_vd")?,
                )),
            )
        } else {
            (None, None)
        };
        Ok(Some(GnssFix {
            t: crate::time::gps_seconds(self.week, tow),
            lat,
            lon,
            h,
            std_ned,
            v_n,
            std_v_n,
            quality: 0,
            num_sats: 0,
        }))
    }
}

impl<R: BufRead> Iterator for KfGinsGnssReader<R> {
    type Item = Result<GnssFix, ReadError>;
    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = self.read();
        crate::text::record_step(r, &mut self.done, &mut self.src.stats)
    }
}

/// Streaming KF-GINS `.nav` reader → [`NavSolution`] (uncertainties NaN = unknown).
pub struct KfGinsNavReader<R> {
    src: LineSource<R>,
    week: u32,
    done: bool,
}

impl<R: BufRead> KfGinsNavReader<R> {
    /// `week`: used when a line's week is 0 (KF-GINS's own output).
    pub fn new(rdr: R, file: &str, week: u32) -> Self {
        KfGinsNavReader {
            src: LineSource::new(rdr, file),
            week,
            done: false,
        }
    }

    pub fn stats(&self) -> &RecordStats {
        &self.src.stats
    }

    fn read(&mut self) -> Result<Option<NavSolution>, ReadError> {
        if !next_data_line(&mut self.src, 11, Sep::Whitespace, None)? {
            return Ok(None);
        }
        let s = &self.src;
        s.expect_fields(&NAV_FIELDS, false)?;
        let w = s.f64(0, "week")?;
        if w < 0.0 || w.fract() != 0.0 || w > 1.0e5 {
            return Err(s.err(
                "week",
                format!("not a GPS week number: {:?}", s.text(0, "week")?),
            ));
        }
        let week = if w == 0.0 { self.week } else { w as u32 };
        let tow = tow_field(s, 1)?;
        let (lat, lon) = latlon(s, 2)?;
        let h = s.f64(4, "h")?;
        let v_n = Vec3::new(s.f64(5, "v_n")?, s.f64(6, "v_e")?, s.f64(7, "v_d")?);
        let mut rpy = Vec3::zeros();
        for k in 0..3 {
            let a = s.f64_or_nan(8 + k, NAV_FIELDS[8 + k])?;
            rpy[k] = a.to_radians();
        }
        rpy.z = wrap_pi(rpy.z);
        let mut sol = NavSolution::unknown_at(crate::time::gps_seconds(week, tow));
        sol.lat = lat;
        sol.lon = lon;
        sol.h = h;
        sol.v_n = v_n;
        sol.rpy = rpy;
        Ok(Some(sol))
    }
}

impl<R: BufRead> Iterator for KfGinsNavReader<R> {
    type Item = Result<NavSolution, ReadError>;
    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = self.read();
        crate::text::record_step(r, &mut self.done, &mut self.src.stats)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{assert_err, collect, token_lines};
    use proptest::prelude::*;

    const IMU: &str = "243261.66 1e-5 2e-5 3e-5 1e-4 2e-3 -9.8e-2\n\
                       243261.67 1e-5 2e-5 3e-5 1e-4 2e-3 -9.8e-2\n\
                       243261.68 1e-5 2e-5 3e-5 1e-4 2e-3 -9.8e-2\n";

    fn imu(data: &[u8]) -> Result<Vec<ImuSample>, ReadError> {
        let opt = KfGinsImuOptions {
            week: 2374,
            ..Default::default()
        };
        collect(KfGinsImuReader::new(data, "imu.txt", opt))
    }
    fn gnss(data: &[u8]) -> Result<Vec<GnssFix>, ReadError> {
        collect(KfGinsGnssReader::new(data, "gnss.txt", 2374))
    }
    fn nav(data: &[u8]) -> Result<Vec<NavSolution>, ReadError> {
        collect(KfGinsNavReader::new(data, "x.nav", 2374))
    }
    /// Replace field `k` (0-based) of line `l` (0-based) of `text`.
    fn with_field(text: &str, l: usize, k: usize, v: &[u8]) -> Vec<u8> {
        crate::testutil::with_field(text, None, l, k, v)
    }

    #[test]
    fn imu_reads_increments_and_first_dt() {
        let v = imu(IMU.as_bytes()).unwrap();
        assert_eq!(v.len(), 3);
        assert_eq!(v[0].t, 2374.0 * 604800.0 + 243261.66);
        assert!((v[0].dt - 0.01).abs() < 1e-6 && (v[1].dt - 0.01).abs() < 1e-6);
        assert_eq!(v[2].dvel_b.z, -9.8e-2);
        assert_eq!(v[1].dtheta_b.y, 2e-5);
        let opt = KfGinsImuOptions {
            nominal_rate_hz: Some(200.0),
            ..Default::default()
        };
        let v = collect(KfGinsImuReader::new(IMU.as_bytes(), "imu.txt", opt)).unwrap();
        assert_eq!((v[0].t, v[0].dt), (243261.66, 0.005));
    }

    #[test]
    fn imu_counts_duplicates_and_cut_last_line() {
        let data = format!("{IMU}{}\n243261.69 1e-5 2e-5", IMU.lines().nth(1).unwrap());
        let mut r = KfGinsImuReader::new(data.as_bytes(), "imu.txt", KfGinsImuOptions::default());
        assert_eq!(r.by_ref().count(), 3);
        let st = r.stats();
        assert_eq!(st.rejected_for(crate::imu::REASON_BACKWARDS), 1);
        assert_eq!(st.rejected_for(REASON_TRUNCATED_LAST), 1);
        assert!(st.is_balanced(), "{st}");
    }

    #[test]
    fn imu_corruptions_name_file_line_field() {
        assert_err(
            imu(b"243261.66 1e-5 2e-5 3e-5 1e-4 2e-3 -9.8e-2\n243261.67 1e-5 2e-5\n"),
            "imu.txt",
            2,
            "dtheta_z",
        );
        assert_err(
            imu(&with_field(IMU, 1, 2, b"1.2.3")),
            "imu.txt",
            2,
            "dtheta_y",
        );
        let e = assert_err(
            imu(&with_field(IMU, 2, 6, b"-9.8e-2 7")),
            "imu.txt",
            3,
            "<column 8>",
        );
        assert!(e.msg.contains("8 columns"));
        let e = assert_err(imu(&with_field(IMU, 0, 4, b"nan")), "imu.txt", 1, "dvel_x");
        assert!(e.msg.contains("finite"));
        assert_err(
            imu(&with_field(IMU, 2, 6, b"-9.\xff8")),
            "imu.txt",
            3,
            "dvel_z",
        );
        assert_err(imu(&with_field(IMU, 1, 0, b"-5")), "imu.txt", 2, "tow");
        // imudatalen 8: the 8th column is accepted and ignored, 7 is then short.
        let opt = KfGinsImuOptions {
            columns: 8,
            ..Default::default()
        };
        let eight = with_field(IMU, 0, 6, b"-9.8e-2 1");
        let r = collect(KfGinsImuReader::new(&eight[..], "imu.txt", opt));
        assert_err(r, "imu.txt", 2, "<extra>");
    }

    const GNSS: &str = "243262.999 40.0966268 -105.1474484 1601.468 0.02 0.02 0.03\n\
                        243263.999 40.0966268 -105.1474483 1601.473 0.02 0.02 0.03\n";

    #[test]
    fn gnss_reads_7_and_13_columns() {
        let v = gnss(GNSS.as_bytes()).unwrap();
        assert_eq!(v.len(), 2);
        assert!((v[0].lat.to_degrees() - 40.0966268).abs() < 1e-12);
        assert!((v[0].lon.to_degrees() + 105.1474484).abs() < 1e-12);
        assert_eq!((v[1].h, v[1].std_ned.z, v[1].v_n), (1601.473, 0.03, None));
        let v = gnss(b"10 1 2 3 0.1 0.2 0.3 1.5 -2.5 0.5 0.05 0.05 0.1\n").unwrap();
        assert_eq!(v[0].v_n, Some(Vec3::new(1.5, -2.5, 0.5)));
        assert_eq!(v[0].std_v_n, Some(Vec3::new(0.05, 0.05, 0.1)));
        // Column count is fixed by the first line.
        let mixed = format!("10 1 2 3 0.1 0.2 0.3 1.5 -2.5 0.5 0.05 0.05 0.1\n{GNSS}");
        assert_err(gnss(mixed.as_bytes()), "gnss.txt", 2, "v_n");
    }

    #[test]
    fn gnss_corruptions_name_file_line_field() {
        assert_err(
            gnss(b"243262.999 40.0966268 -105.1474484 1601.468 0.02\n"),
            "gnss.txt",
            1,
            "std_e",
        );
        assert_err(gnss(&with_field(GNSS, 1, 1, b"4O.1")), "gnss.txt", 2, "lat");
        assert_err(
            gnss(&with_field(GNSS, 1, 6, b"0.03 9")),
            "gnss.txt",
            2,
            "<column 8>",
        );
        assert_err(gnss(&with_field(GNSS, 0, 3, b"NaN")), "gnss.txt", 1, "h");
        assert_err(
            gnss(&with_field(GNSS, 1, 2, b"\xc3\x28")),
            "gnss.txt",
            2,
            "lon",
        );
        assert_err(gnss(&with_field(GNSS, 0, 1, b"91")), "gnss.txt", 1, "lat");
        assert_err(
            gnss(&with_field(GNSS, 0, 4, b"-0.1")),
            "gnss.txt",
            1,
            "std_n",
        );
    }

    const NAV: &str = "2374 243258.499 40.0966268 -105.1474483 1601.474 0.0 0.0 -0.008 nan nan nan\n\
                       0.000000000 243262.014636 40.096626788 -105.147447742 1601.461 0.0004 -0.0001 -0.0023 -1.1778 -0.0584 357.1121\n";

    #[test]
    fn nav_reads_nan_attitude_and_week_zero() {
        let v = nav(NAV.as_bytes()).unwrap();
        assert_eq!(v.len(), 2);
        assert!(v[0].rpy.iter().all(|a| a.is_nan()));
        assert_eq!(v[1].t, 2374.0 * 604800.0 + 243262.014636);
        assert!(
            (v[1].rpy.z.to_degrees() - (357.1121 - 360.0)).abs() < 1e-9,
            "yaw wrapped"
        );
        assert!((v[1].rpy.x.to_degrees() + 1.1778).abs() < 1e-12);
        assert_eq!(v[0].v_n.z, -0.008);
        assert!(v[0].std_pos_ned.x.is_nan());
    }

    #[test]
    fn nav_corruptions_name_file_line_field() {
        assert_err(
            nav(b"2374 243258.499 40.0966268 -105.1474483 1601.474 0.0 0.0\n"),
            "x.nav",
            1,
            "v_d",
        );
        assert_err(nav(&with_field(NAV, 1, 5, b"0.0004e")), "x.nav", 2, "v_n");
        assert_err(
            nav(&with_field(NAV, 0, 10, b"nan nan")),
            "x.nav",
            1,
            "<column 12>",
        );
        assert_err(nav(&with_field(NAV, 0, 4, b"nan")), "x.nav", 1, "h");
        assert_err(nav(&with_field(NAV, 1, 9, b"\x80")), "x.nav", 2, "pitch");
        assert_err(nav(&with_field(NAV, 0, 0, b"2374.5")), "x.nav", 1, "week");
        assert_err(nav(&with_field(NAV, 0, 8, b"inf")), "x.nav", 1, "roll");
    }

    proptest! {
        #[test]
        fn never_panics_on_bytes(data in proptest::collection::vec(any::<u8>(), 0..400)) {
            let _ = imu(&data);
            let _ = gnss(&data);
            let _ = nav(&data);
        }

        #[test]
        fn never_panics_on_token_lines(data in token_lines()) {
            for opt in [KfGinsImuOptions::default(), KfGinsImuOptions { columns: 9, nominal_rate_hz: Some(100.0), week: 1 }] {
                let mut r = KfGinsImuReader::new(&data[..], "imu.txt", opt);
                if r.by_ref().all(|x| x.is_ok()) {
                    prop_assert!(r.stats().is_balanced());
                }
            }
            let mut g = KfGinsGnssReader::new(&data[..], "g", 0);
            if g.by_ref().all(|x| x.is_ok()) {
                prop_assert!(g.stats().is_balanced());
            }
            let mut n = KfGinsNavReader::new(&data[..], "n", 0);
            if n.by_ref().all(|x| x.is_ok()) {
                prop_assert!(n.stats().is_balanced());
            }
        }
    }
}
