//! NMEA HDT / THS → [`HeadingFix`] (dual-antenna GNSS heading, issue 17).
//!
//! HDT and THS carry the true heading of the receiver's antenna baseline,
//! no time and no σ. **Time**: the UTC time of day of the last GGA / GNS /
//! RMC / ZDA sentence before it (receivers write the heading inside the
//! epoch's burst of sentences) on the last RMC / ZDA date; a heading
//! before both are known is rejected (`REASON_NO_TIME`), never guessed.
//! **σ**: neither sentence has one, so it comes from configuration
//! ([`NmeaHeadingReader::new`]'s `std_heading_rad`: the receiver's
//! datasheet heading accuracy for its baseline length). **THS mode**: only
//! `A` (autonomous) is a measurement; `E` (estimated / dead reckoning), `M`
//! (manual), `S` (simulator) and `V` (invalid) are rejected by reason.
//! Every line is counted (used = a heading produced or a time/date sentence
//! kept; skipped = blank or other valid sentences; rejected by reason).

use crate::error::{ReadError, RecordStats};
use crate::nmea::{parse_sentence, Sentence};
use crate::text::LineSource;
use navfuse_core::types::{HeadingFix, HeadingSource};
use std::f64::consts::PI;
use std::io::BufRead;

pub const REASON_NO_TIME: &str = "heading before any time of day and date";
pub const REASON_THS_E: &str = "THS mode E (estimated): not a measurement";
pub const REASON_THS_M: &str = "THS mode M (manual input): not a measurement";
pub const REASON_THS_S: &str = "THS mode S (simulator): not a measurement";
pub const REASON_THS_V: &str = "THS mode V (not valid)";
pub const REASON_TIME_BACK: &str = "heading time not increasing";

/// Streaming HDT/THS reader (see the module doc).
pub struct NmeaHeadingReader<R> {
    src: LineSource<R>,
    std_heading_rad: f64,
    sod: Option<f64>,
    date: Option<(i32, u8, u8)>,
    last_t: f64,
    last_reject: Option<ReadError>,
}

impl<R: BufRead> NmeaHeadingReader<R> {
    /// `std_heading_rad`: the configured 1-σ heading [rad] (> 0).
    pub fn new(rdr: R, file: &str, std_heading_rad: f64) -> Self {
        NmeaHeadingReader {
            src: LineSource::new(rdr, file),
            std_heading_rad,
            sod: None,
            date: None,
            last_t: f64::NEG_INFINITY,
            last_reject: None,
        }
    }

    /// Line accounting.
    pub fn stats(&self) -> &RecordStats {
        &self.src.stats
    }

    /// The last rejected line as an error naming file, line and field.
    pub fn last_rejection(&self) -> Option<&ReadError> {
        self.last_reject.as_ref()
    }

    fn reject(&mut self, reason: &'static str, field: &'static str, msg: String) {
        self.src.stats.reject(reason);
        self.last_reject = Some(ReadError::new(&self.src.file, self.src.line_no, field, msg));
    }

    /// The heading at the current epoch's time, or the reason it is none.
    fn fix(&self, hd: f64) -> Result<HeadingFix, &'static str> {
        let (Some(sod), Some(date)) = (self.sod, self.date) else {
            return Err(REASON_NO_TIME);
        };
        let t = crate::nmea::gps_of_utc_midnight(date).map_err(|_| REASON_NO_TIME)? + sod;
        if t <= self.last_t {
            return Err(REASON_TIME_BACK);
        }
        Ok(HeadingFix {
            t,
            heading_rad: if hd > PI { hd - 2.0 * PI } else { hd },
            pitch_rad: f64::NAN,
            std_heading_rad: self.std_heading_rad,
            std_pitch_rad: f64::NAN,
            baseline_m: f64::NAN,
            source: HeadingSource::DualAntenna,
        })
    }

    /// One line: `Some(fix)` for a heading, `None` otherwise.
    fn line(&mut self) -> Option<HeadingFix> {
        if self.src.is_blank() {
            self.src.stats.skipped += 1;
            return None;
        }
        let s = match parse_sentence(self.src.bytes()) {
            Ok(s) => s,
            Err(e) => {
                self.reject(e.reason, e.field, e.msg);
                return None;
            }
        };
        let hd = match s {
            Sentence::Gga(g) | Sentence::Gns(g) => {
                self.sod = Some(g.sod);
                self.src.stats.used += 1;
                return None;
            }
            Sentence::Rmc(_) | Sentence::Zda(_) => {
                let (sod, date) = s.dated_time()?;
                self.sod = Some(sod);
                self.date = Some(date);
                self.src.stats.used += 1;
                return None;
            }
            Sentence::Hdt(h) => h,
            Sentence::Ths(h, mode) => {
                let why = match mode {
                    b'A' if h.is_finite() => None,
                    b'E' => Some(REASON_THS_E),
                    b'M' => Some(REASON_THS_M),
                    b'S' => Some(REASON_THS_S),
                    _ => Some(REASON_THS_V),
                };
                if let Some(why) = why {
                    self.reject(why, "mode", format!("THS mode {}", mode as char));
                    return None;
                }
                h
            }
            _ => {
                self.src.stats.skipped += 1;
                return None;
            }
        };
        match self.fix(hd) {
            Ok(f) => {
                self.last_t = f.t;
                self.src.stats.used += 1;
                Some(f)
            }
            Err(why) => {
                self.reject(why, "time", "no usable epoch time for this heading".into());
                None
            }
        }
    }
}

impl<R: BufRead> Iterator for NmeaHeadingReader<R> {
    type Item = Result<HeadingFix, ReadError>;
    fn next(&mut self) -> Option<Self::Item> {
        loop {
            match self.src.next_line() {
                Ok(true) => {
                    if let Some(f) = self.line() {
                        return Some(Ok(f));
                    }
                }
                Ok(false) => return None,
                Err(e) => return Some(Err(e)),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nmea::checksum;
    use crate::time::{gps_from_calendar, Calendar, TimeSystem};

    fn s(body: &str) -> String {
        format!("${body}*{:02X}\r\n", checksum(body.as_bytes()))
    }

    #[test]
    fn hdt_and_ths_at_the_epoch_time_with_modes_counted() {
        let mut text = String::new();
        text += &s("GPHDT,10.0,T"); // before any time: rejected
        text += &s("GPRMC,120000.00,A,4000.0000,N,10500.0000,W,0.0,0.0,010125,,,A");
        text += &s("GPHDT,350.0,T");
        text += &s("GPGGA,120001.00,4000.0000,N,10500.0000,W,1,10,0.9,1600.0,M,0.0,M,,");
        text += &s("GPTHS,90.5,A");
        text += &s("GPGGA,120002.00,4000.0000,N,10500.0000,W,1,10,0.9,1600.0,M,0.0,M,,");
        text += &s("GPTHS,91.0,E");
        text += &s("GPTHS,,V");
        text += &s("GPTHS,92.0,S");
        text += &s("GPTHS,93.0,X");
        text += "\n$GPHDT,1.0,T*00\n";
        let mut r = NmeaHeadingReader::new(text.as_bytes(), "h.nmea", 0.01);
        let got: Vec<HeadingFix> = r.by_ref().map(|x| x.unwrap()).collect();
        assert_eq!(got.len(), 2);
        let c = Calendar {
            year: 2025,
            month: 1,
            day: 1,
            hour: 12,
            minute: 0,
            second: 0.0,
        };
        let t0 = gps_from_calendar(&c, TimeSystem::Utc).unwrap();
        assert!((got[0].t - t0).abs() < 1e-6);
        assert!((got[0].heading_rad + 10f64.to_radians()).abs() < 1e-12);
        assert!((got[1].t - t0 - 1.0).abs() < 1e-6);
        assert!((got[1].heading_rad - 90.5f64.to_radians()).abs() < 1e-12);
        assert_eq!(got[1].std_heading_rad, 0.01);
        assert!(got[1].pitch_rad.is_nan());
        let st = r.stats();
        assert!(st.is_balanced(), "{st}");
        assert_eq!(st.rejected_for(REASON_NO_TIME), 1);
        assert_eq!(st.rejected_for(REASON_THS_E), 1);
        assert_eq!(st.rejected_for(REASON_THS_V), 1);
        assert_eq!(st.rejected_for(REASON_THS_S), 1);
        assert_eq!(st.rejected_for(crate::nmea::REASON_MALFORMED), 1);
        assert_eq!(st.rejected_for(crate::nmea::REASON_CHECKSUM), 1);
        assert_eq!(st.skipped, 1);
    }
}
