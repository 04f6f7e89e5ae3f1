//! Trajectory writers: [`NavSolution`] → CSV, KF-GINS `.nav`, GeoJSON, KML
//! 2.2, GPX 1.1. Streaming (one `write` per epoch, `finish` at the end);
//! radians inside become degrees here.
//!
//! Unknown values (NaN) are written as `nan` in the text formats and as
//! `null` in GeoJSON. Heights are ellipsoidal (WGS84) everywhere: KML's
//! `absolute` altitude and GPX's `ele` nominally mean height above mean sea
//! level, so a viewer shows the track higher by the geoid undulation (about
//! −17 m in Colorado → 17 m too high); no geoid model is applied.

use crate::time::{iso8601_utc, week_tow, SECONDS_PER_WEEK};
use navfuse_core::types::NavSolution;
use std::fmt;
use std::io::{self, Write};

/// A sink of navigation solutions.
pub trait TrajectoryWriter {
    /// Write one epoch.
    fn write(&mut self, s: &NavSolution) -> io::Result<()>;
    /// Close the document (footers) and flush. Call once, after the last `write`.
    fn finish(&mut self) -> io::Result<()>;
}

/// Fixed-decimals number that prints NaN as `nan` (or `null` with `json`).
struct F(f64, usize, bool);

impl fmt::Display for F {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.is_finite() {
            write!(f, "{:.*}", self.1, self.0)
        } else if self.2 {
            f.write_str("null")
        } else if self.0.is_nan() {
            f.write_str("nan")
        } else {
            write!(f, "{}", self.0)
        }
    }
}

fn t(x: f64, d: usize) -> F {
    F(x, d, false)
}
fn j(x: f64, d: usize) -> F {
    F(x, d, true)
}

fn bad(what: &str, s: &NavSolution) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        format!(
            "{what} is not finite at t = {} (lat {}, lon {}, h {})",
            s.t, s.lat, s.lon, s.h
        ),
    )
}

fn check_pos(s: &NavSolution) -> io::Result<()> {
    if s.lat.is_finite() && s.lon.is_finite() && s.h.is_finite() {
        Ok(())
    } else {
        Err(bad("position", s))
    }
}

/// Longitude in degrees wrapped to [−180, 180).
fn lon_deg(lon: f64) -> f64 {
    let d = lon.to_degrees();
    (d + 180.0).rem_euclid(360.0) - 180.0
}

/// Column header of [`CsvWriter`] (units in the names).
pub const CSV_HEADER: &str =
    "t_gps_s,gps_week,gps_tow_s,lat_deg,lon_deg,h_m,v_n_mps,v_e_mps,v_d_mps,\
roll_deg,pitch_deg,yaw_deg,std_n_m,std_e_m,std_d_m,std_vn_mps,std_ve_mps,std_vd_mps,\
std_roll_deg,std_pitch_deg,std_yaw_deg";

/// CSV with a header naming units; one line per epoch.
pub struct CsvWriter<W: Write> {
    w: W,
    started: bool,
}

impl<W: Write> CsvWriter<W> {
    pub fn new(w: W) -> Self {
        CsvWriter { w, started: false }
    }
}

impl<W: Write> TrajectoryWriter for CsvWriter<W> {
    fn write(&mut self, s: &NavSolution) -> io::Result<()> {
        if !self.started {
            writeln!(self.w, "{CSV_HEADER}")?;
            self.started = true;
        }
        let (week, tow) = week_tow(s.t);
        let (r, sp, sr) = (
            s.rpy.map(f64::to_degrees),
            s.std_pos_ned,
            s.std_rpy.map(f64::to_degrees),
        );
        writeln!(
            self.w,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            t(s.t, 6),
            week,
            t(tow, 6),
            t(s.lat.to_degrees(), 10),
            t(lon_deg(s.lon), 10),
            t(s.h, 4),
            t(s.v_n.x, 4),
            t(s.v_n.y, 4),
            t(s.v_n.z, 4),
            t(r.x, 6),
            t(r.y, 6),
            t(r.z, 6),
            t(sp.x, 4),
            t(sp.y, 4),
            t(sp.z, 4),
            t(s.std_v_n.x, 4),
            t(s.std_v_n.y, 4),
            t(s.std_v_n.z, 4),
            t(sr.x, 6),
            t(sr.y, 6),
            t(sr.z, 6),
        )
    }
    fn finish(&mut self) -> io::Result<()> {
        if !self.started {
            writeln!(self.w, "{CSV_HEADER}")?;
            self.started = true;
        }
        self.w.flush()
    }
}

/// KF-GINS `.nav`: `week tow lat lon h vN vE vD roll pitch yaw` ([deg], [m],
/// [m/s]), whitespace separated; unknown attitude as `nan`.
pub struct KfGinsNavWriter<W: Write> {
    w: W,
}

impl<W: Write> KfGinsNavWriter<W> {
    pub fn new(w: W) -> Self {
        KfGinsNavWriter { w }
    }
}

impl<W: Write> TrajectoryWriter for KfGinsNavWriter<W> {
    fn write(&mut self, s: &NavSolution) -> io::Result<()> {
        let (week, tow) = week_tow(s.t);
        let r = s.rpy.map(f64::to_degrees);
        writeln!(
            self.w,
            "{} {} {} {} {} {} {} {} {} {} {}",
            week,
            t(tow, 6),
            t(s.lat.to_degrees(), 10),
            t(lon_deg(s.lon), 10),
            t(s.h, 4),
            t(s.v_n.x, 4),
            t(s.v_n.y, 4),
            t(s.v_n.z, 4),
            t(r.x, 6),
            t(r.y, 6),
            t(r.z, 6),
        )
    }
    fn finish(&mut self) -> io::Result<()> {
        self.w.flush()
    }
}

/// GeoJSON (RFC 7946) FeatureCollection: one Point Feature per epoch with
/// properties, then one LineString Feature of the whole track (omitted when
/// there are fewer than 2 epochs, as a LineString needs two positions).
/// Coordinates are `[lon, lat, h]` ([deg], [deg], ellipsoidal [m]).
pub struct GeoJsonWriter<W: Write> {
    w: W,
    n: usize,
    track: Vec<[f64; 3]>,
}

impl<W: Write> GeoJsonWriter<W> {
    pub fn new(w: W) -> Self {
        GeoJsonWriter {
            w,
            n: 0,
            track: Vec::new(),
        }
    }
}

impl<W: Write> TrajectoryWriter for GeoJsonWriter<W> {
    fn write(&mut self, s: &NavSolution) -> io::Result<()> {
        check_pos(s)?;
        if self.n == 0 {
            self.w
                .write_all(b"{\"type\":\"FeatureCollection\",\"features\":[\n")?;
        } else {
            self.w.write_all(b",\n")?;
        }
        self.n += 1;
        let (lat, lon) = (s.lat.to_degrees(), lon_deg(s.lon));
        self.track.push([lon, lat, s.h]);
        let (week, tow) = week_tow(s.t);
        let (r, sr) = (s.rpy.map(f64::to_degrees), s.std_rpy.map(f64::to_degrees));
        let (sp, sv, v) = (s.std_pos_ned, s.std_v_n, s.v_n);
        write!(
            self.w,
            "{{\"type\":\"Feature\",\"geometry\":{{\"type\":\"Point\",\"coordinates\":[{},{},{}]}},\
\"properties\":{{\"t\":{},\"gps_week\":{},\"gps_tow\":{},\"h\":{},\"v_ned\":[{},{},{}],\
\"rpy_deg\":[{},{},{}],\"std_pos_ned\":[{},{},{}],\"std_v_ned\":[{},{},{}],\"std_rpy_deg\":[{},{},{}]}}}}",
            j(lon, 10),
            j(lat, 10),
            j(s.h, 4),
            j(s.t, 6),
            week,
            j(tow, 6),
            j(s.h, 4),
            j(v.x, 4),
            j(v.y, 4),
            j(v.z, 4),
            j(r.x, 6),
            j(r.y, 6),
            j(r.z, 6),
            j(sp.x, 4),
            j(sp.y, 4),
            j(sp.z, 4),
            j(sv.x, 4),
            j(sv.y, 4),
            j(sv.z, 4),
            j(sr.x, 6),
            j(sr.y, 6),
            j(sr.z, 6),
        )
    }

    fn finish(&mut self) -> io::Result<()> {
        if self.n == 0 {
            self.w
                .write_all(b"{\"type\":\"FeatureCollection\",\"features\":[")?;
        }
        if self.track.len() >= 2 {
            self.w.write_all(
                b",\n{\"type\":\"Feature\",\"geometry\":{\"type\":\"LineString\",\"coordinates\":[",
            )?;
            for (k, c) in self.track.iter().enumerate() {
                if k > 0 {
                    self.w.write_all(b",")?;
                }
                write!(self.w, "[{},{},{}]", j(c[0], 10), j(c[1], 10), j(c[2], 4))?;
            }
            self.w
                .write_all(b"]},\"properties\":{\"name\":\"track\"}}")?;
        }
        self.w.write_all(b"\n]}\n")?;
        self.track.clear();
        self.w.flush()
    }
}

/// KML 2.2: one Placemark with a LineString, `altitudeMode` absolute,
/// coordinates `lon,lat,h`.
pub struct KmlWriter<W: Write> {
    w: W,
    started: bool,
}

impl<W: Write> KmlWriter<W> {
    pub fn new(w: W) -> Self {
        KmlWriter { w, started: false }
    }
    fn start(&mut self) -> io::Result<()> {
        if !self.started {
            self.started = true;
            self.w.write_all(
                b"<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n\
<kml xmlns=\"http://www.opengis.net/kml/2.2\">\n<Document>\n<name>navfuse trajectory</name>\n\
<Placemark>\n<name>track</name>\n<LineString>\n<altitudeMode>absolute</altitudeMode>\n<coordinates>\n",
            )?;
        }
        Ok(())
    }
}

impl<W: Write> TrajectoryWriter for KmlWriter<W> {
    fn write(&mut self, s: &NavSolution) -> io::Result<()> {
        check_pos(s)?;
        self.start()?;
        writeln!(
            self.w,
            "{},{},{}",
            t(lon_deg(s.lon), 10),
            t(s.lat.to_degrees(), 10),
            t(s.h, 4)
        )
    }
    fn finish(&mut self) -> io::Result<()> {
        self.start()?;
        self.w
            .write_all(b"</coordinates>\n</LineString>\n</Placemark>\n</Document>\n</kml>\n")?;
        self.w.flush()
    }
}

/// GPX 1.1: one `trk`/`trkseg` with a `trkpt` per epoch (`ele` = height,
/// `time` in UTC ISO-8601 with ms). `time` is left out when the GPS week is
/// unknown (t < one week, i.e. time of week only).
pub struct GpxWriter<W: Write> {
    w: W,
    started: bool,
}

impl<W: Write> GpxWriter<W> {
    pub fn new(w: W) -> Self {
        GpxWriter { w, started: false }
    }
    fn start(&mut self) -> io::Result<()> {
        if !self.started {
            self.started = true;
            self.w.write_all(
                b"<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n\
<gpx version=\"1.1\" creator=\"navfuse\" xmlns=\"http://www.topografix.com/GPX/1/1\">\n\
<trk>\n<name>navfuse trajectory</name>\n<trkseg>\n",
            )?;
        }
        Ok(())
    }
}

impl<W: Write> TrajectoryWriter for GpxWriter<W> {
    fn write(&mut self, s: &NavSolution) -> io::Result<()> {
        check_pos(s)?;
        self.start()?;
        write!(
            self.w,
            "<trkpt lat=\"{}\" lon=\"{}\"><ele>{}</ele>",
            t(s.lat.to_degrees(), 10),
            t(lon_deg(s.lon), 10),
            t(s.h, 4)
        )?;
        if s.t.is_finite() && s.t >= SECONDS_PER_WEEK {
            write!(self.w, "<time>{}</time>", iso8601_utc(s.t))?;
        }
        self.w.write_all(b"</trkpt>\n")
    }
    fn finish(&mut self) -> io::Result<()> {
        self.start()?;
        self.w.write_all(b"</trkseg>\n</trk>\n</gpx>\n")?;
        self.w.flush()
    }
}
