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
            // `{:.P}`, byte-identical, without core's exact float formatter.
            fmt::Display::fmt(&crate::fixed_fmt::fx(self.0, self.1), f)
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
pub(crate) fn lon_deg(lon: f64) -> f64 {
    let d = lon.to_degrees();
    (d + 180.0).rem_euclid(360.0) - 180.0
}

/// Horizontal 1-σ √(σN² + σE²) [m] (NaN when unknown).
pub fn sigma_h(s: &NavSolution) -> f64 {
    s.std_pos_ned.x.hypot(s.std_pos_ned.y)
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
\"rpy_deg\":[{},{},{}],\"std_pos_ned\":[{},{},{}],\"std_v_ned\":[{},{},{}],\"std_rpy_deg\":[{},{},{}],\
\"sigma_h_m\":{},\"sigma_v_m\":{}}}}}",
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
            j(sigma_h(s), 4),
            j(s.std_pos_ned.z, 4),
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
/// coordinates `lon,lat,h`. When any epoch has a position σ, a second
/// Placemark `sigma` (no geometry) follows with `ExtendedData`: `Data`
/// `sigma_h_m` and `sigma_v_m`, whitespace-separated 1-σ horizontal
/// √(σN² + σE²) and vertical [m], the k-th value for the k-th coordinate of
/// the track (`nan` unknown; [`crate::sigma_read::read_kml_sigma`] reads them back).
pub struct KmlWriter<W: Write> {
    w: W,
    started: bool,
    sigma: Vec<[f64; 2]>,
}

impl<W: Write> KmlWriter<W> {
    pub fn new(w: W) -> Self {
        KmlWriter {
            w,
            started: false,
            sigma: Vec::new(),
        }
    }

    /// The `sigma` Placemark (see the type doc), when any σ is known.
    fn write_sigma(&mut self) -> io::Result<()> {
        if !self.sigma.iter().flatten().any(|v| v.is_finite()) {
            return Ok(());
        }
        self.w.write_all(
            b"<Placemark>\n<name>sigma</name>\n<description>1-sigma position uncertainty [m] \
of the track, one value per coordinate in order: sigma_h_m horizontal sqrt(sN^2+sE^2), \
sigma_v_m vertical; nan unknown</description>\n<ExtendedData>\n",
        )?;
        for (k, name) in ["sigma_h_m", "sigma_v_m"].iter().enumerate() {
            write!(self.w, "<Data name=\"{name}\"><value>")?;
            for (i, v) in self.sigma.iter().enumerate() {
                let sep = if i == 0 { "" } else { " " };
                write!(self.w, "{sep}{}", t(v[k], 4))?;
            }
            self.w.write_all(b"</value></Data>\n")?;
        }
        self.w.write_all(b"</ExtendedData>\n</Placemark>\n")?;
        self.sigma.clear();
        Ok(())
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
        self.sigma.push([sigma_h(s), s.std_pos_ned.z]);
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
            .write_all(b"</coordinates>\n</LineString>\n</Placemark>\n")?;
        self.write_sigma()?;
        self.w.write_all(b"</Document>\n</kml>\n")?;
        self.w.flush()
    }
}

/// GPX 1.1: one `trk`/`trkseg` with a `trkpt` per epoch (`ele` = height,
/// 1-σ horizontal/vertical [m] in `extensions` as `navfuse:sigma_h`/`sigma_v`,
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
<gpx version=\"1.1\" creator=\"navfuse\" xmlns=\"http://www.topografix.com/GPX/1/1\" \
xmlns:navfuse=\"https://navfuse.invalid/gpx/1\">\n\
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
        // 1-σ horizontal and vertical [m] (GPX 1.1 has no field for them:
        // an extension, ignored by viewers that do not know it).
        let (sh, sv) = (sigma_h(s), s.std_pos_ned.z);
        if sh.is_finite() || sv.is_finite() {
            write!(
                self.w,
                "<extensions><navfuse:sigma_h>{}</navfuse:sigma_h><navfuse:sigma_v>{}</navfuse:sigma_v></extensions>",
                t(sh, 4),
                t(sv, 4)
            )?;
        }
        self.w.write_all(b"</trkpt>\n")
    }
    fn finish(&mut self) -> io::Result<()> {
        self.start()?;
        self.w.write_all(b"</trkseg>\n</trk>\n</gpx>\n")?;
        self.w.flush()
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use navfuse_core::types::Vec3;
    use proptest::prelude::*;
    use quick_xml::events::Event;

    fn track() -> Vec<NavSolution> {
        (0..4)
            .map(|k| {
                let mut s = NavSolution::unknown_at(crate::time::gps_seconds(
                    2374,
                    243_258.5 + k as f64 * 0.25,
                ));
                s.lat = (40.0966268 + k as f64 * 1e-5).to_radians();
                s.lon = (-105.1474483 - k as f64 * 2e-5).to_radians();
                s.h = 1601.474 + k as f64;
                s.v_n = Vec3::new(1.0, -2.0, 0.25);
                if k > 0 {
                    s.rpy = Vec3::new(0.01, -0.02, 3.0);
                    s.std_pos_ned = Vec3::new(0.01, 0.02, 0.03);
                }
                s
            })
            .collect()
    }

    /// `sols` written in `fmt` to a string (test helper, also of [`crate::sigma_read`]).
    pub(crate) fn render(fmt: crate::trajectory::OutFormat, sols: &[NavSolution]) -> String {
        struct Shared(std::rc::Rc<std::cell::RefCell<Vec<u8>>>);
        impl Write for Shared {
            fn write(&mut self, b: &[u8]) -> io::Result<usize> {
                self.0.borrow_mut().extend_from_slice(b);
                Ok(b.len())
            }
            fn flush(&mut self) -> io::Result<()> {
                Ok(())
            }
        }
        let buf = std::rc::Rc::new(std::cell::RefCell::new(Vec::new()));
        let mut w = crate::trajectory::writer(Shared(buf.clone()), fmt);
        for s in sols {
            w.write(s).unwrap();
        }
        w.finish().unwrap();
        let out = String::from_utf8(buf.borrow().clone()).unwrap();
        out
    }

    #[test]
    fn geojson_is_a_feature_collection_of_points_and_a_linestring() {
        use geojson::{GeoJson, GeometryValue as Value};
        let sols = track();
        let text = render(crate::trajectory::OutFormat::GeoJson, &sols);
        let _: serde_json::Value = serde_json::from_str(&text).expect("valid JSON");
        let GeoJson::FeatureCollection(fc) = text.parse::<GeoJson>().expect("valid GeoJSON") else {
            panic!("not a FeatureCollection")
        };
        assert_eq!(fc.features.len(), sols.len() + 1);
        let mut points = 0;
        for f in &fc.features {
            match &f.geometry.as_ref().unwrap().value {
                Value::Point { coordinates: c } => {
                    let s = &sols[points];
                    assert!(
                        (c[0] - s.lon.to_degrees()).abs() < 1e-9
                            && (c[1] - s.lat.to_degrees()).abs() < 1e-9
                    );
                    assert!((c[2] - s.h).abs() < 1e-4);
                    let p = f.properties.as_ref().unwrap();
                    assert_eq!(p["gps_week"], 2374);
                    assert!(
                        (p["gps_tow"].as_f64().unwrap() - (243_258.5 + points as f64 * 0.25)).abs()
                            < 1e-6
                    );
                    assert_eq!(p["v_ned"][1].as_f64(), Some(-2.0));
                    if points == 0 {
                        assert!(p["rpy_deg"][0].is_null(), "unknown attitude → null");
                    } else {
                        assert!(
                            (p["rpy_deg"][2].as_f64().unwrap() - 3f64.to_degrees()).abs() < 1e-5
                        );
                        assert_eq!(p["std_pos_ned"][2].as_f64(), Some(0.03));
                    }
                    points += 1;
                }
                Value::LineString { coordinates: cs } => {
                    assert_eq!(cs.len(), sols.len());
                    assert!((cs[3][1] - sols[3].lat.to_degrees()).abs() < 1e-9);
                }
                v => panic!("unexpected geometry {v:?}"),
            }
        }
        assert_eq!(points, sols.len());
        // Empty and single-epoch tracks are still valid GeoJSON.
        for n in [0, 1] {
            let t = render(crate::trajectory::OutFormat::GeoJson, &sols[..n]);
            let GeoJson::FeatureCollection(fc) = t.parse::<GeoJson>().unwrap() else {
                panic!()
            };
            assert_eq!(fc.features.len(), n);
        }
    }

    type XmlSummary = (Vec<String>, Vec<Vec<(String, String)>>, Vec<String>);

    /// Parse XML fully (well-formedness, matching end tags); return
    /// (element names in order, attributes of `attr_of` elements, texts of `text_of`).
    fn xml(text: &str, attr_of: &str, text_of: &str) -> XmlSummary {
        let mut r = quick_xml::Reader::from_str(text);
        r.config_mut().trim_text(true);
        let (mut names, mut attrs, mut texts) = (vec![], vec![], vec![]);
        let mut cur = String::new();
        loop {
            match r.read_event().expect("well-formed XML") {
                Event::Start(e) | Event::Empty(e) => {
                    cur = String::from_utf8(e.name().as_ref().to_vec()).unwrap();
                    if cur == attr_of {
                        attrs.push(
                            e.attributes()
                                .map(|a| {
                                    let a = a.unwrap();
                                    (
                                        String::from_utf8(a.key.as_ref().to_vec()).unwrap(),
                                        String::from_utf8(a.value.to_vec()).unwrap(),
                                    )
                                })
                                .collect(),
                        );
                    }
                    names.push(cur.clone());
                }
                Event::Text(t) if cur == text_of => texts.push(t.unescape().unwrap().into_owned()),
                Event::Eof => break,
                _ => {}
            }
        }
        (names, attrs, texts)
    }

    #[test]
    fn kml_is_well_formed_with_absolute_linestring() {
        let sols = track();
        let text = render(crate::trajectory::OutFormat::Kml, &sols);
        assert!(text.contains("xmlns=\"http://www.opengis.net/kml/2.2\""));
        let (names, _, coords) = xml(&text, "", "coordinates");
        for n in [
            "kml",
            "Document",
            "Placemark",
            "LineString",
            "altitudeMode",
            "coordinates",
        ] {
            assert!(names.iter().any(|x| x == n), "{n} missing");
        }
        let (_, _, modes) = xml(&text, "", "altitudeMode");
        assert_eq!(modes, ["absolute"]);
        let pts: Vec<Vec<f64>> = coords[0]
            .split_whitespace()
            .map(|p| p.split(',').map(|x| x.parse().unwrap()).collect())
            .collect();
        assert_eq!(pts.len(), sols.len());
        assert!((pts[2][0] - sols[2].lon.to_degrees()).abs() < 1e-9);
        assert!((pts[2][1] - sols[2].lat.to_degrees()).abs() < 1e-9);
        assert!((pts[2][2] - sols[2].h).abs() < 1e-4);
    }

    #[test]
    fn gpx_is_well_formed_with_utc_times() {
        let sols = track();
        let text = render(crate::trajectory::OutFormat::Gpx, &sols);
        assert!(
            text.contains("version=\"1.1\"") && text.contains("http://www.topografix.com/GPX/1/1")
        );
        let (names, attrs, times) = xml(&text, "trkpt", "time");
        for n in ["gpx", "trk", "trkseg", "trkpt", "ele", "time"] {
            assert!(names.iter().any(|x| x == n), "{n} missing");
        }
        assert_eq!(attrs.len(), sols.len());
        let lat: f64 = attrs[1]
            .iter()
            .find(|a| a.0 == "lat")
            .unwrap()
            .1
            .parse()
            .unwrap();
        assert!((lat - sols[1].lat.to_degrees()).abs() < 1e-9);
        assert_eq!(times[0], "2025-07-08T19:34:00.500Z");
        assert_eq!(times[3], "2025-07-08T19:34:01.250Z");
        let (_, _, eles) = xml(&text, "", "ele");
        assert_eq!(eles[1].parse::<f64>().unwrap(), 1602.474);
    }

    #[test]
    fn geojson_and_gpx_carry_horizontal_and_vertical_sigma() {
        let sols = track();
        let g: serde_json::Value =
            serde_json::from_str(&render(crate::trajectory::OutFormat::GeoJson, &sols)).unwrap();
        let p = |k: usize, key: &str| g["features"][k]["properties"][key].clone();
        assert!(p(0, "sigma_h_m").is_null(), "unknown σ is null");
        assert_eq!(p(1, "sigma_h_m").as_f64(), Some(0.0224));
        assert_eq!(p(1, "sigma_v_m").as_f64(), Some(0.03));
        let x = render(crate::trajectory::OutFormat::Gpx, &sols);
        assert_eq!(
            x.matches("<navfuse:sigma_h>0.0224</navfuse:sigma_h>")
                .count(),
            3,
            "{x}"
        );
        assert_eq!(
            x.matches("<navfuse:sigma_v>0.0300</navfuse:sigma_v>")
                .count(),
            3
        );
        assert!(x.contains("xmlns:navfuse="));
    }

    #[test]
    fn non_finite_position_is_an_error() {
        let mut s = track()[0];
        s.lat = f64::NAN;
        for fmt in [
            crate::trajectory::OutFormat::GeoJson,
            crate::trajectory::OutFormat::Kml,
            crate::trajectory::OutFormat::Gpx,
        ] {
            let mut w = crate::trajectory::writer(io::sink(), fmt);
            assert_eq!(w.write(&s).unwrap_err().kind(), io::ErrorKind::InvalidData);
        }
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a.is_nan() && b.is_nan()) || (a - b).abs() <= tol
    }

    proptest! {
        #[test]
        fn csv_and_nav_round_trip(
            tow in 0.0f64..604_799.0, week in 1u32..3000,
            lat in -89.9f64..89.9, lon in -179.9f64..179.9, h in -500.0f64..9000.0,
            v in proptest::array::uniform3(-300.0f64..300.0),
            rpy in proptest::array::uniform3(-179.0f64..179.0),
            nan_att in any::<bool>(),
        ) {
            let mut s = NavSolution::unknown_at(crate::time::gps_seconds(week, tow));
            s.lat = lat.to_radians();
            s.lon = lon.to_radians();
            s.h = h;
            s.v_n = Vec3::from(v);
            s.rpy = if nan_att { Vec3::repeat(f64::NAN) } else { Vec3::from(rpy).map(f64::to_radians) };
            s.std_pos_ned = Vec3::new(0.1, 0.2, 0.3);
            let csv = render(crate::trajectory::OutFormat::Csv, &[s, s]);
            let back: Vec<NavSolution> = crate::navcsv::NavCsvReader::new(csv.as_bytes(), "rt.csv").map(Result::unwrap).collect();
            let nav = render(crate::trajectory::OutFormat::Nav, &[s]);
            let back2: Vec<NavSolution> = crate::kfgins::KfGinsNavReader::new(nav.as_bytes(), "rt.nav", 0).map(Result::unwrap).collect();
            prop_assert_eq!(back.len(), 2);
            for b in [&back[0], &back2[0]] {
                prop_assert!(close(b.t, s.t, 2e-6));
                prop_assert!(close(b.lat, s.lat, 1e-11) && close(b.lon, s.lon, 1e-11) && close(b.h, s.h, 1e-4));
                for k in 0..3 {
                    prop_assert!(close(b.v_n[k], s.v_n[k], 1e-4));
                    prop_assert!(close(b.rpy[k], s.rpy[k], 1e-7));
                }
            }
            prop_assert!(close(back[0].std_pos_ned.z, 0.3, 1e-9));
            prop_assert!(back[0].std_v_n.x.is_nan());
        }
    }
}
