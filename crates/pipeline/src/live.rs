//! The estimator side of a live session (`navfuse live`): the estimators it
//! can run ([`make_estimator`], [`kfgins_eskf`]), the driver that hands the
//! sequencer's released events to the estimator and counts what came out
//! ([`LiveDriver`]), and the JSON of a solution and of reader counts.
//! Sources, threads, sockets and the output sink stay with the caller.
//!
//! Times: GPS seconds (`t`), KF-GINS time of week inside a [`KfGinsFrame`];
//! positions geodetic (radians, metres), NED velocity, FRD body.

use crate::ToolError;
use navfuse_core::types::{Event, GnssFix, NavSolution};
use navfuse_core::Estimator;
use navfuse_io::live::{LatencyHistogram, Sequencer};
use navfuse_io::nmea::NmeaWriter;
use navfuse_io::time::week_tow;
use navfuse_io::writers::{sigma_h, TrajectoryWriter as _};
use navfuse_io::RecordStats;
use std::io::{self, Write};

/// Output formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Format {
    /// One JSON object per solution (full precision; fields in [`json_line`]).
    Json,
    /// NMEA GGA + RMC + GST + `$PNVFS` (σ, see [`pnvfs_sentence`]) per solution.
    Nmea,
}

/// The solution sink of a live session: JSON lines or NMEA, flushed after
/// every solution.
pub struct Out {
    format: Format,
    sink: Box<dyn Write>,
    /// One solution's NMEA sentences (reused).
    buf: Vec<u8>,
}

impl Out {
    /// The sink writing `format` to `sink`.
    pub fn new(format: Format, sink: Box<dyn Write>) -> Self {
        Out {
            format,
            sink,
            buf: Vec::with_capacity(512),
        }
    }

    /// Write one solution and flush.
    pub fn write(&mut self, s: &NavSolution) -> io::Result<()> {
        match self.format {
            Format::Json => self.sink.write_all(json_line(s).as_bytes())?,
            Format::Nmea => {
                self.buf.clear();
                NmeaWriter::new(&mut self.buf).write(s)?;
                self.buf.extend_from_slice(pnvfs_sentence(s).as_bytes());
                self.sink.write_all(&self.buf)?;
            }
        }
        self.sink.flush()
    }
}

/// navfuse's proprietary NMEA sentence of a solution's σ (1-σ, from the
/// estimator's covariance; empty fields when unknown), time as in GGA:
/// `$PNVFS,hhmmss.sss,σH[m],σV[m],σvN,σvE,σvD[m/s],σroll,σpitch,σyaw[deg]*CS`.
/// σN, σE, σD of the position are in the GST sentence before it.
pub fn pnvfs_sentence(s: &NavSolution) -> String {
    use std::fmt::Write as _;
    let c = navfuse_io::time::calendar_from_gps(s.t, navfuse_io::time::TimeSystem::Utc, 3);
    let mut body = format!("PNVFS,{:02}{:02}{:06.3}", c.hour, c.minute, c.second);
    let (sh, sv) = (sigma_h(s), s.std_pos_ned.z);
    let deg = s.std_rpy.map(f64::to_degrees);
    let vals = [
        sh,
        sv,
        s.std_v_n.x,
        s.std_v_n.y,
        s.std_v_n.z,
        deg.x,
        deg.y,
        deg.z,
    ];
    for (k, v) in vals.into_iter().enumerate() {
        let d = if k < 5 { 3 } else { 4 };
        if v.is_finite() {
            let _ = write!(body, ",{:.d$}", v.min(9.99e5));
        } else {
            body.push(',');
        }
    }
    format!(
        "${body}*{:02X}\r\n",
        navfuse_io::nmea::checksum(body.as_bytes())
    )
}

/// Test estimator: the last GNSS position (and its σ) at every IMU sample.
/// Its output depends on the event order, which makes it a sharp check of
/// the sequencing; it is not a navigation filter.
pub struct HoldLastFix {
    last: Option<GnssFix>,
}

impl Estimator for HoldLastFix {
    fn name(&self) -> &'static str {
        "hold"
    }
    fn push(&mut self, ev: &Event) -> Option<NavSolution> {
        match ev {
            Event::Gnss(f) => {
                self.last = Some(*f);
                None
            }
            Event::Imu(s) => self.last.map(|f| {
                let mut n = NavSolution::unknown_at(s.t);
                n.lat = f.lat;
                n.lon = f.lon;
                n.h = f.h;
                n.std_pos_ned = f.std_ned;
                n.v_n = navfuse_core::types::Vec3::repeat(f64::NAN);
                n
            }),
            _ => None,
        }
    }
}

/// The estimator named `name`.
pub fn make_estimator(name: &str) -> Result<Box<dyn Estimator>, ToolError> {
    match name {
        "hold" => Ok(Box::new(HoldLastFix { last: None })),
        "eskf" => {
            Err("the ESKF is built by aligning_eskf (self-aligning) or kfgins_eskf (YAML)".into())
        }
        other => Err(format!("unknown estimator {other:?} (available: hold, eskf)").into()),
    }
}

/// The estimator of a live session: any [`Estimator`], or the self-aligning
/// ESKF, whose realignments and warnings go to the summary.
pub enum LiveEst {
    Boxed(Box<dyn Estimator>),
    Aligning(Box<crate::live_align::AligningEskf>),
}

impl LiveEst {
    fn get(&mut self) -> &mut dyn Estimator {
        match self {
            LiveEst::Boxed(e) => e.as_mut(),
            LiveEst::Aligning(e) => e.as_mut(),
        }
    }
    pub fn name(&self) -> &'static str {
        match self {
            LiveEst::Boxed(e) => e.name(),
            LiveEst::Aligning(e) => e.name(),
        }
    }
    /// Alignments started again after a gap in the data.
    pub fn realigns(&self) -> u64 {
        match self {
            LiveEst::Boxed(_) => 0,
            LiveEst::Aligning(e) => e.realigns,
        }
    }
    /// Aiding models and update counters (the self-aligning ESKF only),
    /// as summary JSON: `{"config": …, "used_rejected": …}`.
    pub fn aiding_json(&self) -> serde_json::Value {
        match self {
            LiveEst::Boxed(_) => serde_json::Value::Null,
            LiveEst::Aligning(e) => serde_json::json!({
                "config": crate::aiding_cfg::config_json(&e.aiding_config()),
                "used_rejected": crate::aiding_cfg::stats_json(&e.aiding_stats()),
            }),
        }
    }
    /// The correlated GNSS error model the σ is reported under, and how it
    /// was chosen ([`crate::stream_sigma`]; self-aligning ESKF only).
    pub fn sigma_model(&self) -> &str {
        match self {
            LiveEst::Boxed(_) => "",
            LiveEst::Aligning(e) => &e.sigma.note,
        }
    }
    /// The estimator's warnings (alignment).
    pub fn warnings(&self) -> &[String] {
        match self {
            LiveEst::Boxed(_) => &[],
            LiveEst::Aligning(e) => &e.warnings,
        }
    }
}

/// The default live estimator: the self-aligning ESKF
/// ([`crate::live_align::AligningEskf`]) with the profile of `platform`
/// (None: no platform constraints, as `navfuse run` without a platform),
/// IMU noise from the sensor preset `imu_preset` (default: the conservative
/// MEMS preset) and the GNSS antenna at `lever_arm_b` (body FRD) [m].
/// `ubx`: the source is a UBX stream, which may carry wheel ticks / speed
/// and NAV-RELPOSNED heading: the odometer and heading models are on with
/// the defaults `navfuse run` uses for such inputs ([`crate::aiding_cfg`]).
pub fn aligning_eskf(
    platform: Option<crate::profile::Platform>,
    imu_preset: Option<&str>,
    lever_arm_b: &[f64],
    ubx: bool,
) -> Result<LiveEst, ToolError> {
    let lever_arm: [f64; 3] = lever_arm_b
        .try_into()
        .map_err(|_| ToolError("--lever-arm: expected x,y,z".into()))?;
    let filter = crate::config::FilterCfg {
        platform,
        imu_preset: imu_preset.map(str::to_string),
        lever_arm,
        ..Default::default()
    };
    let cfg = crate::config::RunConfig::for_streams(filter, None);
    let e = crate::live_align::AligningEskf::new(cfg, std::path::Path::new("."))
        .and_then(|e| e.with_aiding(ubx, ubx))
        .map_err(|e| ToolError(e.to_string()))?;
    Ok(LiveEst::Aligning(Box::new(e)))
}

/// An ESKF whose σ is reported under the correlated fix error chosen from
/// the fixes it was handed ([`crate::stream_sigma`]); solutions unchanged.
pub struct SigmaEskf {
    pub eskf: navfuse_core::estimators::eskf::Eskf,
    pub sigma: crate::stream_sigma::StreamSigma,
}

impl Estimator for SigmaEskf {
    fn name(&self) -> &'static str {
        self.eskf.name()
    }
    fn push(&mut self, ev: &Event) -> Option<NavSolution> {
        let sol = self.eskf.push(ev);
        if let Event::Gnss(f) = ev {
            self.sigma.observe(&mut self.eskf, f);
        }
        sol
    }
}

/// How `navfuse kf-gins` presents events to its ESKF: times as time of week,
/// IMU from `start` (inclusive), fixes after `start`, up to `end`; the first
/// solution only initialises.
#[derive(Clone, Copy, Debug)]
pub struct KfGinsFrame {
    week_s: f64,
    start: f64,
    end: f64,
}

/// The ESKF of `navfuse kf-gins` from a KF-GINS YAML.
pub fn kfgins_eskf(
    path: &std::path::Path,
    enhanced: bool,
    week: u32,
) -> Result<(Box<dyn Estimator>, KfGinsFrame), ToolError> {
    use navfuse_core::estimators::eskf::Eskf;
    let cfg = navfuse_io::kfgins_yaml::KfGinsConfig::load(path)?;
    let mut ecfg = cfg.eskf_config();
    if enhanced {
        ecfg = crate::kf_gins::enhanced(ecfg);
    }
    let eskf = Eskf::new(ecfg, cfg.init_nav(), cfg.init_errors(), &cfg.init_std());
    // `--enhanced`: σ under the correlated fix error, as `navfuse kf-gins
    // --enhanced` (chosen from the fixes streamed so far); the plain
    // KF-GINS model keeps its white σ.
    let eskf: Box<dyn Estimator> = if enhanced {
        Box::new(SigmaEskf {
            eskf,
            sigma: crate::stream_sigma::StreamSigma::new(),
        })
    } else {
        Box::new(eskf)
    };
    let end = if cfg.endtime < 0.0 {
        f64::INFINITY
    } else {
        cfg.endtime
    };
    Ok((
        eskf,
        KfGinsFrame {
            week_s: f64::from(week) * navfuse_io::time::SECONDS_PER_WEEK,
            start: cfg.starttime,
            end,
        },
    ))
}

impl KfGinsFrame {
    /// The event as kf-gins hands it over, or the reason it does not.
    pub fn map(&self, ev: &Event) -> Result<Event, &'static str> {
        match *ev {
            Event::Imu(mut s) => {
                s.t -= self.week_s;
                if s.t < self.start {
                    Err("IMU before the configured start time")
                } else if s.t > self.end {
                    Err("IMU after the configured end time")
                } else {
                    Ok(Event::Imu(s))
                }
            }
            Event::Gnss(mut f) => {
                f.t -= self.week_s;
                if f.t <= self.start {
                    Err("GNSS at/before the configured start time")
                } else {
                    Ok(Event::Gnss(f))
                }
            }
            // kf-gins mode fuses IMU + GNSS only (the KF-GINS model).
            _ => Err("not an IMU or GNSS record (kf-gins uses IMU + GNSS only)"),
        }
    }
}

/// Hands the events a [`Sequencer`] releases to the estimator (through the
/// kf-gins time window when there is one) and counts the solutions.
pub struct LiveDriver {
    pub est: LiveEst,
    frame: Option<KfGinsFrame>,
    /// kf-gins: the first solution only initialises (not written).
    first_pending: bool,
    /// Events not handed to the estimator (kf-gins time window), by reason.
    pub outside: Vec<(&'static str, u64)>,
    /// Solutions written, of them at GNSS events, and IMU samples without one.
    pub n_sol: u64,
    pub n_gnss_sol: u64,
    pub n_imu_nosol: u64,
    /// IMU line read → solution written [s].
    pub lat: LatencyHistogram,
}

impl LiveDriver {
    /// A driver of `est`; `frame`: the kf-gins time window (None: every event).
    pub fn new(est: LiveEst, frame: Option<KfGinsFrame>) -> Self {
        LiveDriver {
            est,
            frame,
            first_pending: frame.is_some(),
            outside: Vec::new(),
            n_sol: 0,
            n_gnss_sol: 0,
            n_imu_nosol: 0,
            lat: LatencyHistogram::default(),
        }
    }

    /// Release whatever may go at `nows` [s since the start]; `secs_now`
    /// gives the current time on the same clock (for the latency), `write`
    /// writes a solution.
    pub fn release(
        &mut self,
        seq: &mut Sequencer,
        nows: f64,
        secs_now: &dyn Fn() -> f64,
        write: &mut dyn FnMut(&NavSolution) -> io::Result<()>,
    ) -> Result<(), ToolError> {
        let (est, frame, outside) = (&mut self.est, self.frame, &mut self.outside);
        while let Some((ev, arr)) = seq.pop(nows) {
            let ev = match frame.map(|f| f.map(&ev)) {
                None => ev,
                Some(Ok(e)) => e,
                Some(Err(why)) => {
                    match outside.iter_mut().find(|o| o.0 == why) {
                        Some(o) => o.1 += 1,
                        None => outside.push((why, 1)),
                    }
                    continue;
                }
            };
            let sol = est.get().push(&ev);
            if sol.is_some() && self.first_pending && matches!(ev, Event::Imu(_)) {
                // kf-gins: the first sample only initialises (not written).
                self.first_pending = false;
                self.n_imu_nosol += 1;
                continue;
            }
            match sol {
                Some(sol) => {
                    write(&sol).map_err(|e| format!("output: {e}"))?;
                    self.n_sol += 1;
                    match ev {
                        Event::Imu(_) => self.lat.add(secs_now() - arr),
                        Event::Gnss(_) => self.n_gnss_sol += 1,
                        _ => {}
                    }
                }
                None => {
                    if matches!(ev, Event::Imu(_)) {
                        self.n_imu_nosol += 1;
                    }
                }
            }
        }
        Ok(())
    }

    /// After the IMU input ended and its queue emptied: the remaining GNSS
    /// fixes (if any) go to the estimator too.
    pub fn finish(
        &mut self,
        seq: &mut Sequencer,
        write: &mut dyn FnMut(&NavSolution) -> io::Result<()>,
    ) -> Result<(), ToolError> {
        seq.end_gnss();
        while let Some((ev, _)) = seq.pop(f64::INFINITY) {
            if self.frame.is_some() {
                // kf-gins hands no fix over after the last IMU sample.
                continue;
            }
            if let Some(sol) = self.est.get().push(&ev) {
                write(&sol).map_err(|e| format!("output: {e}"))?;
                self.n_sol += 1;
                self.n_gnss_sol += 1;
            }
        }
        Ok(())
    }
}

/// `x` with `d` decimals, `null` when not finite (JSON).
pub fn jnum(x: f64, d: usize) -> String {
    if x.is_finite() {
        format!("{x:.d$}")
    } else {
        "null".into()
    }
}

/// One solution as a JSON line. Fields: `t` GPS time [s], `week`, `tow`;
/// `lat`, `lon` [deg], `h` ellipsoidal [m]; `vn`, `ve`, `vd` [m/s];
/// `roll`, `pitch`, `yaw` [deg] (ZYX, body FRD w.r.t. NED); 1-σ from the
/// estimator's covariance: position `sn`, `se`, `sd` [m], horizontal `sh`
/// and vertical `sv` [m] ([`sigma_h`]: √(σN² + σE²); `sv` = `sd`), velocity `svn`, `sve`, `svd`
/// [m/s], attitude `sroll`, `spitch`, `syaw` [deg]. Unknown values are `null`.
pub fn json_line(s: &NavSolution) -> String {
    let (w, tow) = week_tow(s.t);
    let (sh, sv) = (sigma_h(s), s.std_pos_ned.z);
    let deg = s.std_rpy.map(f64::to_degrees);
    format!(
        "{{\"t\":{},\"week\":{w},\"tow\":{},\"lat\":{},\"lon\":{},\"h\":{},\"vn\":{},\"ve\":{},\"vd\":{},\"roll\":{},\"pitch\":{},\"yaw\":{},\"sn\":{},\"se\":{},\"sd\":{},\"sh\":{},\"sv\":{},\"svn\":{},\"sve\":{},\"svd\":{},\"sroll\":{},\"spitch\":{},\"syaw\":{}}}\n",
        jnum(s.t, 6),
        jnum(tow, 6),
        jnum(s.lat.to_degrees(), 11),
        jnum(s.lon.to_degrees(), 11),
        jnum(s.h, 5),
        jnum(s.v_n.x, 5),
        jnum(s.v_n.y, 5),
        jnum(s.v_n.z, 5),
        jnum(s.rpy.x.to_degrees(), 6),
        jnum(s.rpy.y.to_degrees(), 6),
        jnum(s.rpy.z.to_degrees(), 6),
        jnum(s.std_pos_ned.x, 5),
        jnum(s.std_pos_ned.y, 5),
        jnum(s.std_pos_ned.z, 5),
        jnum(sh, 5),
        jnum(sv, 5),
        jnum(s.std_v_n.x, 5),
        jnum(s.std_v_n.y, 5),
        jnum(s.std_v_n.z, 5),
        jnum(deg.x, 5),
        jnum(deg.y, 5),
        jnum(deg.z, 5),
    )
}

/// Reader counts as JSON: lines, used, skipped, rejected by reason.
pub fn stats_json(s: &RecordStats) -> String {
    let rej: Vec<String> = s
        .rejected
        .iter()
        .map(|(r, n)| format!("{}:{n}", serde_json::to_string(r).unwrap_or_default()))
        .collect();
    format!(
        "{{\"lines\":{},\"used\":{},\"skipped\":{},\"rejected\":{{{}}}}}",
        s.lines,
        s.used,
        s.skipped,
        rej.join(",")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hold_estimator_follows_event_order() {
        let mut e = make_estimator("hold").unwrap();
        let imu = |t| {
            Event::Imu(navfuse_core::types::ImuSample {
                t,
                dt: 0.01,
                ..Default::default()
            })
        };
        assert!(e.push(&imu(1.0)).is_none());
        let f = GnssFix {
            t: 1.0,
            lat: 0.5,
            h: 7.0,
            ..Default::default()
        };
        assert!(e.push(&Event::Gnss(f)).is_none());
        let s = e.push(&imu(1.01)).unwrap();
        assert_eq!((s.t, s.lat, s.h), (1.01, 0.5, 7.0));
        assert!(make_estimator("nope").is_err());
    }

    #[test]
    fn json_line_is_json() {
        let s = NavSolution::unknown_at(1_435_000_000.25);
        let v: serde_json::Value = serde_json::from_str(json_line(&s).trim()).unwrap();
        assert_eq!(v["week"], 2372);
        assert!(v["roll"].is_null());
        assert!(v["syaw"].is_null());
    }

    /// σ fields in JSON and in `$PNVFS` come from the solution's covariance
    /// diagonal: σH = √(σN² + σE²), attitude in degrees.
    #[test]
    fn sigma_fields_in_json_and_nmea() {
        use navfuse_core::types::Vec3;
        let mut s = NavSolution::unknown_at(1_435_000_000.25);
        s.lat = 0.7;
        s.lon = -1.8;
        s.h = 1600.0;
        s.v_n = Vec3::new(1.0, 2.0, 0.0);
        s.rpy = Vec3::zeros();
        s.std_pos_ned = Vec3::new(0.3, 0.4, 0.5);
        s.std_v_n = Vec3::new(0.01, 0.02, 0.03);
        s.std_rpy = Vec3::new(0.001, 0.002, 0.01);
        let v: serde_json::Value = serde_json::from_str(json_line(&s).trim()).unwrap();
        assert!((v["sh"].as_f64().unwrap() - 0.5).abs() < 1e-9);
        assert!((v["sv"].as_f64().unwrap() - 0.5).abs() < 1e-9);
        assert!((v["sve"].as_f64().unwrap() - 0.02).abs() < 1e-9);
        assert!((v["syaw"].as_f64().unwrap() - 0.01f64.to_degrees()).abs() < 1e-5);
        let mut out = Out::new(Format::Nmea, Box::new(io::sink()));
        out.write(&s).unwrap();
        let p = pnvfs_sentence(&s);
        let body = &p[1..p.find('*').unwrap()];
        let f: Vec<&str> = body.split(',').collect();
        assert_eq!(f[0], "PNVFS");
        assert_eq!(&f[2..6], ["0.500", "0.500", "0.010", "0.020"]);
        assert_eq!(f[9], "0.5730");
        let cs = u8::from_str_radix(&p[p.find('*').unwrap() + 1..][..2], 16).unwrap();
        assert_eq!(cs, navfuse_io::nmea::checksum(body.as_bytes()));
        // The writer's GGA/RMC/GST precede it; unknown σ give empty fields.
        let u = pnvfs_sentence(&NavSolution::unknown_at(1_435_000_000.25));
        assert!(u.contains(",,,,,,,,*"), "{u}");
    }
}
