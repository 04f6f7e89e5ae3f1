//! `navfuse run` inputs: any of navfuse-io's IMU and GNSS readers, chosen by
//! `[input]` keys or by file extension, put on one time base, with every
//! record accounted for (read, used, skipped, rejected by reason).
//!
//! IMU: KF-GINS text (`kf-gins`) or the generic CSV reader (`csv`, with a
//! preset or a column map). GNSS: KF-GINS text (`kf-gins`), RTKLIB `.pos`
//! (`pos`), NMEA 0183 (`nmea`) or u-blox UBX NAV-PVT (`ubx`).
//!
//! Time bases are stated, never guessed silently: `[input] imu_time_base`
//! (or `[input.csv] time_base`; a counter column with `[input] imu_tag` is
//! `counter_tag`, its clock fitted on the tag file, [`crate::imu_clock`])
//! and `gnss_time_base` (checked against the format). An undeclared CSV
//! time column whose first stamp is no plausible GPS-seconds date is an
//! error naming the likely base ([`crate::run_checks`]); IMU and GNSS spans
//! that do not overlap are an error naming both.
//!
//! Time: the run works on the IMU's time base. KF-GINS files carry the GPS
//! time of week only; the other formats carry full GPS seconds. When the two
//! streams differ, the GNSS times are moved to the IMU's base (the week is
//! taken from the other stream). An optional `imu_time_offset` (seconds,
//! added to every IMU stamp: true time = stamp + offset) corrects a known
//! IMU–GNSS lag; `"auto"` estimates it with its σ and applies it only when
//! significant ([`crate::time_offset::auto_estimate`]).

use crate::csv_map::{csv_plan, CsvCfg};
use crate::error::{PipelineError, Result};
use crate::imu_clock::{clock_json, fit_counter};
use crate::resolved::csv_keys;
use crate::run_checks::{check_overlap, check_undeclared_stamp};
use crate::time_offset::{TimeOffset, TimeOffsetCfg};
use navfuse_core::types::{GnssFix, ImuSample};
use navfuse_core::Vec3;
use navfuse_io::csv_imu::{CsvAux, CsvImuReader, CsvTime};
use navfuse_io::error::RecordStats;
use navfuse_io::kfgins::{KfGinsGnssReader, KfGinsImuOptions, KfGinsImuReader};
use navfuse_io::nmea::{NmeaOptions, NmeaReader};
use navfuse_io::pos::PosReader;
use navfuse_io::timebase::TimeBase;
use navfuse_io::ubx::{UbxMessage, UbxReader};
use serde::Serialize;
use std::path::Path;

/// Seconds per GPS week.
const WEEK: f64 = 604_800.0;

/// What was read from one input file.
#[derive(Clone, Debug, Serialize)]
pub struct InputReport {
    pub file: String,
    pub format: &'static str,
    pub lines_or_messages: u64,
    /// Lines (messages) that went into a record.
    pub used: u64,
    /// Records produced (IMU samples, GNSS fixes; NMEA needs several
    /// sentences per fix).
    pub records: usize,
    pub skipped: u64,
    /// Rejected records by reason.
    pub rejected: serde_json::Map<String, serde_json::Value>,
    /// A counter clock fitted on the tag file ([`crate::imu_clock::clock_json`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub clock: Option<serde_json::Value>,
}

impl InputReport {
    pub(crate) fn new(file: &Path, format: &'static str, st: &RecordStats, records: usize) -> Self {
        InputReport {
            file: file.display().to_string(),
            format,
            records,
            lines_or_messages: st.lines,
            used: st.used,
            skipped: st.skipped,
            rejected: st
                .rejected
                .iter()
                .map(|(r, n)| (r.to_string(), serde_json::Value::from(*n)))
                .collect(),
            clock: None,
        }
    }

    fn reject(&mut self, reason: &str, n: u64) {
        if n > 0 {
            self.used = self.used.saturating_sub(n);
            let e = self.rejected.entry(reason).or_insert(0.into());
            *e = (e.as_u64().unwrap_or(0) + n).into();
        }
    }
}

/// Both streams on the IMU's time base.
pub struct Loaded {
    pub imu: Vec<ImuSample>,
    pub gnss: Vec<GnssFix>,
    pub imu_report: InputReport,
    pub gnss_report: InputReport,
    /// How the GNSS times were put on the IMU's base.
    pub time_base: String,
    /// Offset added to the IMU stamps [s] and how it was found.
    pub imu_time_offset: Option<(f64, String)>,
    /// Magnetometer / AHRS-yaw rows of the CSV, when `[input.csv]` names them.
    pub aux: Option<AuxSeries>,
    /// Doubts worth the user's attention (summary.json `warnings`).
    pub warnings: Vec<String>,
    /// The effective reader configuration (summary.json `resolved_input`).
    pub resolved: serde_json::Value,
    /// Odometer / heading events of a UBX log (`[input] ubx`), time order.
    pub aiding: Vec<navfuse_core::types::Event>,
    /// Raw GNSS records (`gnss_format = "raw"` or `[filter] coupling =
    /// "tight"`, [`crate::raw_input`]) on the IMU's time base; `gnss` holds
    /// their SPP fixes (`fixes` here is empty).
    pub raw: Option<crate::raw_input::RawInput>,
}

/// Magnetometer (body FRD, mounting applied) and AHRS yaw rows of a CSV IMU
/// file ([`CsvImuReader::aux`]), on the IMU's time base.
#[derive(Clone, Debug, Default)]
pub struct AuxSeries(pub Vec<CsvAux>);

impl AuxSeries {
    fn window(&self, t0: f64, t1: f64) -> &[CsvAux] {
        let r = &self.0;
        &r[r.partition_point(|a| a.t < t0)..r.partition_point(|a| a.t <= t1)]
    }

    /// Mean magnetometer vector over `[t0, t1]`.
    pub fn mean_mag(&self, t0: f64, t1: f64) -> Option<Vec3> {
        let (sum, n) = self
            .window(t0, t1)
            .iter()
            .filter_map(|a| a.mag_b)
            .fold((Vec3::zeros(), 0usize), |(s, n), m| (s + m, n + 1));
        (n > 0).then(|| sum / n as f64)
    }

    /// Circular mean of the AHRS yaw over `[t0, t1]` [rad].
    pub fn mean_yaw(&self, t0: f64, t1: f64) -> Option<f64> {
        let (s, c) = self
            .window(t0, t1)
            .iter()
            .filter_map(|a| a.yaw)
            .fold((0.0, 0.0), |(s, c), y: f64| (s + y.sin(), c + y.cos()));
        (s != 0.0 || c != 0.0).then(|| s.atan2(c))
    }
}

/// The IMU format named by `imu_format`, else by the extension (`.csv` →
/// csv, anything else → kf-gins).
fn imu_format(path: &Path, given: Option<&str>) -> Result<&'static str, String> {
    match given {
        Some("kf-gins") => Ok("kf-gins"),
        Some("csv") => Ok("csv"),
        Some(f) => Err(format!("imu_format {f:?}: expected kf-gins or csv")),
        None => Ok(if ext_is(path, &["csv"]) {
            "csv"
        } else {
            "kf-gins"
        }),
    }
}

/// The GNSS format named by `gnss_format`, else by the extension (`.pos`,
/// `.nmea`/`.nma`/`.gga`, `.ubx`; anything else → kf-gins).
fn gnss_format(path: &Path, given: Option<&str>) -> Result<&'static str, String> {
    match given {
        Some("kf-gins") => Ok("kf-gins"),
        Some("pos") => Ok("pos"),
        Some("nmea") => Ok("nmea"),
        Some("ubx") => Ok("ubx"),
        Some("raw") => Ok("raw"),
        Some(f) => Err(format!(
            "gnss_format {f:?}: expected kf-gins, pos, nmea, ubx or raw"
        )),
        None => Ok(if ext_is(path, &["pos"]) {
            "pos"
        } else if ext_is(path, &["nmea", "nma", "gga"]) {
            "nmea"
        } else if ext_is(path, &["ubx"]) {
            "ubx"
        } else if is_rinex_obs(path) {
            "raw"
        } else {
            "kf-gins"
        }),
    }
}

/// A RINEX observation file by its extension: `.obs`, `.rnx`, or the
/// RINEX 2 `.YYo` (two digits and `o`).
fn is_rinex_obs(path: &Path) -> bool {
    let e = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let b = e.as_bytes();
    e == "obs"
        || e == "rnx"
        || (b.len() == 3 && b[0].is_ascii_digit() && b[1].is_ascii_digit() && b[2] == b'o')
}

fn ext_is(path: &Path, exts: &[&str]) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| exts.iter().any(|x| e.eq_ignore_ascii_case(x)))
}

/// What [`read_imu`] read, and how.
struct ImuRead {
    imu: Vec<ImuSample>,
    report: InputReport,
    aux: Option<AuxSeries>,
    /// `resolved_input.imu`.
    resolved: serde_json::Value,
    warnings: Vec<String>,
}

fn read_imu(spec: &InputSpec, format: &'static str) -> Result<ImuRead, String> {
    let path = spec.imu;
    let e = |e: navfuse_io::error::ReadError| e.to_string();
    if format != "csv" {
        if let Some(b) = spec.imu_time_base.filter(|b| *b != TimeBase::GpsWeekTow) {
            return Err(format!(
                "{}: [input] imu_time_base = \"{b}\": KF-GINS IMU text carries the GPS time \
                 of week by definition (gps_week_tow)",
                path.display()
            ));
        }
        if let Some(t) = spec.imu_tag {
            return Err(format!(
                "[input] imu_tag = {:?}: a tag file times a CSV counter column \
                 ([input.csv] counter); {} is KF-GINS text with its own time of week",
                t.display().to_string(),
                path.display()
            ));
        }
        let (rdr, name) = navfuse_io::open(path).map_err(|e| e.to_string())?;
        let opt = KfGinsImuOptions {
            week: 0,
            columns: 7,
            nominal_rate_hz: Some(spec.imu_rate),
        };
        let mut r = KfGinsImuReader::new(rdr, &name, opt);
        let v = r.by_ref().collect::<Result<Vec<_>, _>>().map_err(e)?;
        let report = InputReport::new(path, format, r.stats(), v.len());
        let resolved = serde_json::json!({
            "file": path.display().to_string(), "format": format,
            "time_base": TimeBase::GpsWeekTow.name(), "columns": 7,
            "form": "increment", "nominal_rate_hz": spec.imu_rate,
        });
        return Ok(ImuRead {
            imu: v,
            report,
            aux: None,
            resolved,
            warnings: Vec::new(),
        });
    }
    let in_file = |m: PipelineError| format!("{}: {m}", path.display());
    let mut plan = csv_plan(
        &spec.csv.cloned().unwrap_or_default(),
        spec.imu_rate,
        spec.imu_time_base,
    )
    .map_err(in_file)?;
    let mut clock_report = None;
    match (&plan.counter, spec.imu_tag) {
        (Some(c), Some(tag)) => {
            let (clock, fit) = fit_counter(path, tag, &plan.cfg, c)?;
            clock_report = Some(clock_json(tag, &clock, &fit));
            plan.cfg.time = CsvTime::Counter {
                col: c.col.clone(),
                clock,
            };
        }
        (Some(_), None) => {
            return Err(format!(
                "{}: [input.csv] counter: the counter needs the log's RTKLIB time-tag file, \
                 [input] imu_tag = \"….tag\"",
                path.display()
            ))
        }
        (None, Some(t)) => {
            return Err(format!(
                "[input] imu_tag = {:?}: a tag file times a counter column, but [input.csv] \
                 of {} has none (give `counter = COL`)",
                t.display().to_string(),
                path.display()
            ))
        }
        (None, None) => {}
    }
    let (rdr, name) = navfuse_io::open(path).map_err(|e| e.to_string())?;
    let mut r = CsvImuReader::new(rdr, &name, plan.cfg.clone());
    let v = r.by_ref().collect::<Result<Vec<_>, _>>().map_err(e)?;
    let base = match (&plan.cfg.time, v.first()) {
        (CsvTime::Seconds(_), Some(s0)) => Some(check_undeclared_stamp(path, &plan.cfg, s0.t)?),
        _ => None,
    };
    let mut report = InputReport::new(path, format, r.stats(), v.len());
    report.clock = clock_report.clone();
    let aux = (!r.aux().is_empty()).then(|| AuxSeries(r.aux().to_vec()));
    let mut warnings = plan.warnings;
    warnings.extend(
        r.warnings()
            .iter()
            .map(|w| format!("{}: {w}", path.display())),
    );
    let keys = csv_keys(&plan.cfg, base, plan.counter.as_ref());
    let mut resolved = serde_json::json!({
        "file": path.display().to_string(), "format": format,
        "time_base": keys["time_base"].clone(), "preset": plan.preset,
        "nominal_rate_hz": spec.imu_rate, "csv": keys,
    });
    if let (Some(tag), Some(c)) = (spec.imu_tag, clock_report) {
        resolved["imu_tag"] = tag.display().to_string().into();
        resolved["clock_fit"] = c;
    }
    Ok(ImuRead {
        imu: v,
        report,
        aux,
        resolved,
        warnings,
    })
}

/// The base of a GNSS format's times, and a declared `gnss_time_base`
/// checked against it: KF-GINS text carries the time of week; `.pos`, NMEA
/// and UBX carry calendar dates (GPST or UTC, converted by their readers),
/// i.e. absolute GPS seconds.
fn gnss_base(path: &Path, format: &str, declared: Option<TimeBase>) -> Result<TimeBase, String> {
    let own = if format == "kf-gins" {
        TimeBase::GpsWeekTow
    } else {
        TimeBase::GpsSeconds
    };
    match declared {
        Some(b) if b != own => Err(format!(
            "{}: [input] gnss_time_base = \"{b}\": {format} files carry {} by definition \
             (gnss_time_base = \"{own}\")",
            path.display(),
            if own == TimeBase::GpsWeekTow {
                "the GPS time of week"
            } else {
                "calendar dates with their time system, read as GPS seconds"
            }
        )),
        _ => Ok(own),
    }
}

/// UBX: NAV-PVT with a valid 3-D fix are used; NAV-PVT without one are
/// rejected ("NAV-PVT: no valid 3-D fix"); other message types are skipped.
fn read_ubx(path: &Path) -> Result<(Vec<GnssFix>, InputReport), String> {
    let (rdr, name) = navfuse_io::open(path).map_err(|e| e.to_string())?;
    let mut r = UbxReader::new(rdr, &name);
    let (mut fixes, mut no_fix, mut other) = (Vec::new(), 0u64, 0u64);
    for m in r.by_ref() {
        match m.map_err(|e| e.to_string())? {
            UbxMessage::NavPvt(p) => match p.to_fix() {
                Some(f) => fixes.push(f),
                None => no_fix += 1,
            },
            _ => other += 1,
        }
    }
    let mut rep = InputReport::new(path, "ubx", r.stats(), fixes.len());
    rep.reject("NAV-PVT: no valid 3-D fix", no_fix);
    rep.used = rep.used.saturating_sub(other);
    rep.skipped += other;
    Ok((fixes, rep))
}

fn read_gnss(path: &Path, format: &'static str) -> Result<(Vec<GnssFix>, InputReport), String> {
    if format == "ubx" {
        return read_ubx(path);
    }
    let (rdr, name) = navfuse_io::open(path).map_err(|e| e.to_string())?;
    let e = |e: navfuse_io::error::ReadError| e.to_string();
    macro_rules! collect {
        ($r:expr) => {{
            let mut r = $r;
            let v = r.by_ref().collect::<Result<Vec<_>, _>>().map_err(e)?;
            let rep = InputReport::new(path, format, r.stats(), v.len());
            (v, rep)
        }};
    }
    Ok(match format {
        "pos" => collect!(PosReader::new(rdr, &name)),
        "nmea" => collect!(NmeaReader::new(rdr, &name, NmeaOptions::default())),
        _ => collect!(KfGinsGnssReader::new(rdr, &name, 0)),
    })
}

/// Puts the GNSS times on the IMU's base (see the module doc); returns how.
fn align_time_bases(imu: &[ImuSample], gnss: &mut [GnssFix]) -> String {
    let (Some(i0), Some(g0)) = (imu.first(), gnss.first()) else {
        return "no data".into();
    };
    let imu_tow = i0.t < WEEK;
    let gnss_tow = g0.t < WEEK;
    match (imu_tow, gnss_tow) {
        (true, false) => {
            for g in gnss.iter_mut() {
                g.t = navfuse_io::time::week_tow(g.t).1;
            }
            "GNSS GPS seconds → time of week (the IMU file carries the time of week)".into()
        }
        (false, true) => {
            // The week that puts the first fix nearest the first IMU sample.
            let week = ((i0.t - g0.t) / WEEK).round();
            for g in gnss.iter_mut() {
                g.t += week * WEEK;
            }
            format!("GNSS time of week + GPS week {week} (from the IMU file)")
        }
        (true, true) => "both files carry the GPS time of week".into(),
        (false, false) => "both files carry GPS seconds".into(),
    }
}

/// `[input]` as read by [`load`].
pub struct InputSpec<'a> {
    pub imu: &'a Path,
    pub imu_format: Option<&'a str>,
    pub imu_rate: f64,
    pub csv: Option<&'a CsvCfg>,
    pub gnss: &'a Path,
    pub gnss_format: Option<&'a str>,
    pub imu_time_offset: Option<&'a TimeOffsetCfg>,
    /// `[input] imu_time_base` / `gnss_time_base`: the declared bases.
    pub imu_time_base: Option<TimeBase>,
    pub gnss_time_base: Option<TimeBase>,
    /// `[input] imu_tag`: the RTKLIB time-tag file of a counter-timed CSV.
    pub imu_tag: Option<&'a Path>,
    /// `[input] ubx`: a UBX log in place of `imu` and `gnss` ([`crate::ubx_input`]).
    pub ubx: Option<&'a Path>,
    pub ubx_cfg: navfuse_io::ubx_events::UbxEventsConfig,
    /// `[input] nav`: broadcast navigation file(s) for raw observations.
    pub nav: &'a [std::path::PathBuf],
    /// Read `gnss` as raw observations (`[filter] coupling = "tight"`).
    pub raw: bool,
    /// With `raw`: the second-frequency records too (`coupling = "rtk"`).
    pub raw_second: bool,
}

/// Read both inputs, put them on the IMU's time base and apply the IMU time
/// offset. Errors ([`PipelineError::Input`]) name the file, line and field.
pub fn load(spec: &InputSpec) -> Result<Loaded> {
    load_inner(spec).map_err(PipelineError::Input)
}

fn load_inner(spec: &InputSpec) -> Result<Loaded, String> {
    if let Some(path) = spec.ubx {
        return load_ubx(spec, path);
    }
    if spec.imu.as_os_str().is_empty() || spec.gnss.as_os_str().is_empty() {
        return Err("[input]: `imu` and `gnss` (or `ubx`) are required".into());
    }
    let imu_fmt = imu_format(spec.imu, spec.imu_format)?;
    let gnss_fmt = match (spec.raw, spec.gnss_format) {
        (true, None | Some("raw")) => "raw",
        (true, Some(f)) => {
            return Err(format!(
                "[input] gnss_format = {f:?}: [filter] coupling = \"tight\" reads raw \
                 observations (a .ubx log with RXM-RAWX, or RINEX observations + nav); \
                 give gnss_format = \"raw\" or leave it out"
            ))
        }
        (false, f) => gnss_format(spec.gnss, f)?,
    };
    if !spec.nav.is_empty() && gnss_fmt != "raw" {
        return Err(format!(
            "[input] nav: broadcast ephemerides go with raw observations \
             ([filter] coupling = \"tight\" or gnss_format = \"raw\"); {} is read as {gnss_fmt}",
            spec.gnss.display()
        ));
    }
    let gnss_base = gnss_base(spec.gnss, gnss_fmt, spec.gnss_time_base)?;
    let ImuRead {
        imu,
        report: imu_report,
        aux,
        resolved: imu_resolved,
        mut warnings,
    } = read_imu(spec, imu_fmt)?;
    let (mut gnss, gnss_report, mut raw) = if gnss_fmt == "raw" {
        let mut r = crate::raw_input::load_raw_with(spec.gnss, spec.nav, spec.raw_second)
            .map_err(|e| e.to_string())?;
        let mut fixes = std::mem::take(&mut r.fixes);
        if !spec.raw {
            // Loosely coupled on its own single-point fixes.
            crate::raw_input::loose_fix_sigma(&mut fixes, &r);
        }
        (fixes, r.report.clone(), Some(r))
    } else {
        let (g, r) = read_gnss(spec.gnss, gnss_fmt)?;
        (g, r, None)
    };
    gnss.sort_by(|a, b| a.t.total_cmp(&b.t));
    let time_base = align_time_bases(&imu, &mut gnss);
    if let (Some(r), Some(i0)) = (&mut raw, imu.first()) {
        // The fixes' rule, record by record (module documentation).
        if i0.t < WEEK {
            for x in r.records.iter_mut() {
                x.obs.t = navfuse_io::time::week_tow(x.obs.t).1;
            }
        }
    }
    if gnss.is_empty() {
        if let Some(r) = &raw {
            return Err(format!(
                "{}: no epoch gave a single-point solution (the alignment's position source)\n{}",
                spec.gnss.display(),
                r.spp.text()
            ));
        }
    }
    warnings.extend(check_overlap(spec.imu, &imu, spec.gnss, &gnss)?);
    // Default `auto`: estimated with its σ, applied only when significant.
    let mut l = finish_load(
        spec,
        imu,
        gnss,
        (imu_report, gnss_report),
        time_base,
        aux,
        warnings,
        imu_resolved,
        gnss_fmt,
        gnss_base.name(),
    )?;
    l.raw = raw;
    Ok(l)
}

/// `[input] ubx`: both streams (and the aiding events) from one log.
fn load_ubx(spec: &InputSpec, path: &Path) -> Result<Loaded, String> {
    if !(spec.imu.as_os_str().is_empty() && spec.gnss.as_os_str().is_empty()) {
        return Err("[input] ubx replaces `imu` and `gnss`: give one or the other".into());
    }
    let log = crate::ubx_input::read_ubx_log(path, spec.ubx_cfg)?;
    let file = path.display().to_string();
    let resolved = serde_json::json!({"file": file, "format": "ubx",
        "esf_tick_s": spec.ubx_cfg.esf_tick_s, "metres_per_tick": spec.ubx_cfg.metres_per_tick});
    let warnings = check_overlap(path, &log.imu, path, &log.gnss)?
        .into_iter()
        .collect();
    let mut l = finish_load(
        spec,
        log.imu,
        log.gnss,
        (log.imu_report, log.gnss_report),
        "one receiver clock (UBX log)".into(),
        None,
        warnings,
        resolved.clone(),
        "ubx",
        "gps_seconds",
    )?;
    l.aiding = log.aiding;
    Ok(l)
}

/// The IMU time offset and the report of a load.
#[allow(clippy::too_many_arguments)]
fn finish_load(
    spec: &InputSpec,
    mut imu: Vec<ImuSample>,
    gnss: Vec<GnssFix>,
    (imu_report, gnss_report): (InputReport, InputReport),
    time_base: String,
    mut aux: Option<AuxSeries>,
    warnings: Vec<String>,
    imu_resolved: serde_json::Value,
    gnss_fmt: &str,
    gnss_base: &str,
) -> Result<Loaded, String> {
    let mode = match spec.imu_time_offset {
        // A UBX log's streams share the receiver clock.
        None if spec.ubx.is_some() => Ok(TimeOffset::None),
        None => Ok(TimeOffset::Auto),
        Some(TimeOffsetCfg::Seconds(s)) => TimeOffset::parse(&s.to_string()),
        Some(TimeOffsetCfg::Named(n)) => TimeOffset::parse(n),
    }
    .map_err(|e| format!("[input] imu_time_offset: {e}"))?;
    let imu_time_offset = mode
        .resolve(&imu, &gnss)
        .map_err(|e| format!("[input] imu_time_offset: {e}"))?;
    if let Some((tau, _)) = imu_time_offset {
        for s in imu.iter_mut() {
            s.t += tau;
        }
        if let Some(a) = &mut aux {
            a.0.iter_mut().for_each(|x| x.t += tau);
        }
    }
    let resolved = serde_json::json!({
        "imu": imu_resolved,
        "gnss": {"file": spec.ubx.unwrap_or(spec.gnss).display().to_string(), "format": gnss_fmt,
                 "time_base": gnss_base},
        "joined": time_base,
        "imu_time_offset_s": imu_time_offset.as_ref().map(|o| o.0),
    });
    Ok(Loaded {
        imu,
        gnss,
        imu_report,
        gnss_report,
        time_base,
        imu_time_offset,
        aux,
        warnings,
        resolved,
        aiding: Vec::new(),
        raw: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_from_extension_and_keys() {
        let p = Path::new;
        assert_eq!(imu_format(p("a.csv"), None).unwrap(), "csv");
        assert_eq!(imu_format(p("a.txt"), None).unwrap(), "kf-gins");
        assert_eq!(imu_format(p("a.dat"), Some("csv")).unwrap(), "csv");
        assert!(imu_format(p("a"), Some("xsens"))
            .unwrap_err()
            .contains("xsens"));
        assert_eq!(gnss_format(p("a.POS"), None).unwrap(), "pos");
        assert_eq!(gnss_format(p("a.nmea"), None).unwrap(), "nmea");
        assert_eq!(gnss_format(p("a.ubx"), None).unwrap(), "ubx");
        assert_eq!(gnss_format(p("gnss.txt"), None).unwrap(), "kf-gins");
        assert!(gnss_format(p("a"), Some("rinex"))
            .unwrap_err()
            .contains("rinex"));
    }

    #[test]
    fn gnss_time_of_week_moves_to_the_imu_week_and_back() {
        let week = 2374.0;
        let imu = [ImuSample {
            t: week * WEEK + 604_790.0,
            ..Default::default()
        }];
        // Fixes after the week rollover keep increasing.
        let mut g = [5.0, 15.0].map(|t| GnssFix {
            t,
            ..Default::default()
        });
        let how = align_time_bases(&imu, &mut g);
        assert_eq!(g[0].t, (week + 1.0) * WEEK + 5.0, "{how}");
        let imu_tow = [ImuSample {
            t: 243_000.0,
            ..Default::default()
        }];
        let mut g = [GnssFix {
            t: week * WEEK + 243_001.0,
            ..Default::default()
        }];
        align_time_bases(&imu_tow, &mut g);
        assert_eq!(g[0].t, 243_001.0);
    }
}
