//! `navfuse run`'s TOML configuration ([`RunConfig`]); its schema is the
//! file format users write, so field names and defaults never change here.

use crate::csv_map::CsvCfg;
use crate::error::{PipelineError, Result};
use crate::noise_cfg::ImuNoiseCfg;
use crate::profile::Platform;
use crate::time_offset::TimeOffsetCfg;
use navfuse_io::timebase::TimeBase;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// `navfuse run` configuration (TOML). Units: degrees, metres, seconds.
/// Every key with its unit, default and per-platform values: `docs/config.md`;
/// `navfuse init --platform P` writes a commented template.
///
/// ```toml
/// [input]
/// imu = "imu.txt"            # KF-GINS IMU text (increments, body FRD), or a CSV
/// imu_format = "kf-gins"     # optional: "kf-gins" | "csv" (default from the extension)
/// imu_rate = 100.0
/// gnss = "gnss.txt"          # KF-GINS GNSS text, RTKLIB .pos, NMEA (.nmea) or UBX (.ubx)
/// gnss_format = "kf-gins"    # optional: "kf-gins" | "pos" | "nmea" | "ubx"
/// start = 243262.0           # optional: GPS seconds, or TOW when the IMU file has TOW only
/// imu_time_offset = 0.0      # optional: seconds added to IMU stamps, or "auto"
/// imu_time_base = "gps_seconds"  # optional: gps_week_tow | gps_seconds | gps_seconds_1970
///                            #   | unix_utc | counter_tag (with imu_tag = "imu.csv.tag")
/// gnss_time_base = "gps_seconds" # optional, checked against the GNSS format
///
/// [input.csv]                # for imu_format = "csv": a preset or a column map
/// preset = "rtklib-imu-gpst" # | "rtklib-imu-counter" | "vectornav-vn310", or instead:
/// # time = "t" (or week = 0, tow = 1, or counter = 6), time_base = "unix_utc",
/// # gyro = ["gx","gy","gz"], accel = [3, 4, 5],
/// # gyro_unit = "deg"|"rad", accel_unit = "g"|"m/s2", form = "rate"|"increment",
/// # delimiter = ",", header = true, mount_rpy_deg = [180, 0, 180]
/// # mag = ["mx", "my", "mz"], ahrs_yaw = "yaw_deg"   (initial heading sources)
///
/// [init]                     # all optional: automatic alignment otherwise
/// position = [40.09, -105.14, 1601.4]   # IMU lat, lon [deg], h [m]
/// attitude = [-1.17, -0.04, -2.89]      # roll, pitch, yaw [deg]
/// heading = "auto"           # "auto" | "ahrs" | "magnetometer" | "course"
/// magnetic_declination_deg = 8.1        # for the magnetometer heading
///
/// [filter]
/// estimator = "eskf"         # "eskf" | "pf-lc" | "gps-acc" | "cp-att" (the others use their defaults)
/// preset = "enhanced"        # "kf-gins" | "enhanced" | "seed001" (eskf)
/// noise_yaml = "kf.yaml"     # optional: take the IMU noise from a KF-GINS YAML
/// # or [filter.imu_noise]: arw = [8, 8, 8], vrw, gbstd, abstd, gsstd, asstd, corrtime
/// # (KF-GINS keys and units), or datasheet keys: gyro_noise_dps_rthz,
/// # accel_noise_ug_rthz, gyro_bias_instability_dph, accel_bias_instability_ug,
/// # bias_corr_time_s (crate::noise_cfg); neither: the seed 001 preset's noise
/// lever_arm = [0.0, -0.05, 0.0]
/// smooth = true
/// coupling = "loose"         # | "tight": raw pseudoranges/Dopplers from gnss = "x.ubx"
///                            #   (RXM-RAWX + RXM-SFRBX) or gnss = "x.obs" + nav = "brdc.nav"
///                            # | "rtk": carrier-phase DDs against [input] base = "base.obs"
///                            #   (base_position = [x,y,z] | [lat,lon,h] | "header" | "spp")
///
/// [outage]                   # optional: cut GNSS for `length` s every `period` s from `start` s
/// start = 120.0
/// length = 30.0
/// period = 90.0
///
/// # top level, optional: extra solution formats besides solution.nav
/// formats = ["csv", "geojson", "kml", "gpx", "nmea", "parquet", "pos"]
/// ```
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// `[input]`: the recordings.
    pub input: InputCfg,
    /// `[init]`: optional initial state and heading source.
    #[serde(default)]
    pub init: InitCfg,
    /// `[filter]`: estimator, model and smoothing.
    #[serde(default)]
    pub filter: FilterCfg,
    /// `[outage]`: simulated GNSS outages.
    pub outage: Option<OutageCfg>,
    /// Output folder (relative to the configuration file).
    pub output: Option<String>,
    /// Extra solution formats (extensions) written besides `solution.nav`.
    #[serde(default)]
    pub formats: Vec<String>,
    /// `[cp_att]`: multi-antenna carrier-phase attitude (seed 003,
    /// [`crate::cp_att_run`]), for `estimator = "cp-att"` or
    /// `[filter] heading_source = "cp-att"`.
    pub cp_att: Option<crate::cp_att_run::CpAttCfg>,
    /// The file this configuration was read from ([`RunConfig::from_toml_file`]),
    /// named in error messages; not part of the TOML schema.
    #[serde(skip)]
    pub source: Option<PathBuf>,
}

impl RunConfig {
    /// A configuration for IMU/GNSS streams handed over in memory (the
    /// live ESKF, `kf-gins --align`): no files, no `[init]`, `filter` as
    /// given; `source` names it in error messages.
    pub fn for_streams(filter: FilterCfg, source: Option<PathBuf>) -> RunConfig {
        RunConfig {
            input: InputCfg {
                imu: "-".into(),
                imu_format: None,
                imu_rate: default_rate(),
                csv: None,
                gnss: "-".into(),
                gnss_format: None,
                start: None,
                imu_time_offset: None,
                imu_tag: None,
                imu_time_base: None,
                gnss_time_base: None,
                ubx: None,
                ubx_metres_per_tick: None,
                ubx_esf_tick_s: None,
                carrier_phase: None,
                odometer: None,
                odometer_csv: None,
                heading: None,
                heading_sigma_deg: None,
                nav: None,
                base: None,
                base_position: None,
            },
            init: InitCfg::default(),
            filter,
            outage: None,
            output: None,
            formats: Vec::new(),
            cp_att: None,
            source,
        }
    }

    /// Read and parse a TOML run configuration. Errors: `FILE: cannot read: …`
    /// ([`PipelineError::Io`]) or `FILE: <TOML error naming the key>`
    /// ([`PipelineError::Config`]).
    pub fn from_toml_file(path: &Path) -> Result<RunConfig> {
        let text = read_config_text(path)?;
        let mut cfg: RunConfig = toml::from_str(&text).map_err(|e| PipelineError::Config {
            file: path.display().to_string(),
            msg: e.to_string(),
        })?;
        cfg.source = Some(path.to_path_buf());
        Ok(cfg)
    }

    /// The name used for this configuration in messages: its file, else `run config`.
    pub fn name(&self) -> String {
        self.source
            .as_ref()
            .map_or_else(|| "run config".into(), |p| p.display().to_string())
    }

    /// A [`PipelineError::Config`] naming this configuration.
    pub(crate) fn err(&self, msg: impl Into<String>) -> PipelineError {
        PipelineError::Config {
            file: self.name(),
            msg: msg.into(),
        }
    }
}

/// `p` as given when absolute, else relative to `base_dir` (the folder of
/// the configuration file).
pub fn resolve_path(base_dir: &Path, p: &str) -> PathBuf {
    let p = Path::new(p);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        base_dir.join(p)
    }
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct InputCfg {
    /// IMU file (empty with `ubx`).
    #[serde(default)]
    pub imu: String,
    /// "kf-gins" or "csv" (default: from the extension, see [`crate::input`]).
    pub imu_format: Option<String>,
    #[serde(default = "default_rate")]
    pub imu_rate: f64,
    /// `[input.csv]`: the generic CSV IMU reader's preset or column map.
    pub csv: Option<CsvCfg>,
    /// GNSS file (empty with `ubx`).
    #[serde(default)]
    pub gnss: String,
    /// "kf-gins", "pos", "nmea" or "ubx" (default: from the extension).
    pub gnss_format: Option<String>,
    /// First IMU stamp used [s] on the run's time axis: GPS seconds since
    /// 1980 when the IMU file has absolute time (whatever its time base),
    /// the time of week when it has only that (KF-GINS text); must lie
    /// inside the IMU span (an error says which base the file uses).
    pub start: Option<f64>,
    /// Seconds added to the IMU stamps (true time = stamp + offset), `"auto"`
    /// (estimated with its σ, applied only when significant; the default) or
    /// `"none"`.
    pub imu_time_offset: Option<TimeOffsetCfg>,
    /// RTKLIB time-tag file (`.tag`) of the IMU log, for a CSV whose time
    /// column is a device counter (`[input.csv] counter`).
    pub imu_tag: Option<String>,
    /// The time base of the IMU file's stamps: `gps_week_tow`,
    /// `gps_seconds` (since 1980-01-06), `gps_seconds_1970` (GPS time
    /// counted from 1970, RTKLIB), `unix_utc`, `counter_tag` (a counter +
    /// `imu_tag`). KF-GINS text is `gps_week_tow` by definition; for a CSV
    /// this is `[input.csv] time_base`. Undeclared: an implausible first
    /// stamp is an error naming the likely base.
    pub imu_time_base: Option<TimeBase>,
    /// The time base of the GNSS file: `gps_week_tow` for KF-GINS text,
    /// `gps_seconds` for `.pos`/NMEA/UBX (calendar dates); checked, not converted.
    pub gnss_time_base: Option<TimeBase>,
    /// A u-blox UBX log as the source of IMU, GNSS, wheel ticks and heading
    /// in place of `imu` and `gnss` ([`crate::ubx_input`]).
    pub ubx: Option<String>,
    /// With `ubx`: distance per wheel tick [m].
    pub ubx_metres_per_tick: Option<f64>,
    /// With `ubx`: the ESF sensor time tag unit [s] (default 0.001).
    pub ubx_esf_tick_s: Option<f64>,
    /// Multi-antenna carrier-phase records (CSV, `navfuse_io::carrier_phase`)
    /// for CP-ATT ([`crate::cp_att_run`]).
    pub carrier_phase: Option<String>,
    /// Wheel speed / odometer CSV ([`crate::odo_input`]), with its column
    /// map `[input.odometer_csv]`.
    pub odometer: Option<String>,
    pub odometer_csv: Option<crate::odo_input::OdoCsvCfg>,
    /// NMEA HDT/THS dual-antenna heading ([`crate::heading_input`]) and its
    /// 1-σ [deg] (required with it: the sentences carry none).
    pub heading: Option<String>,
    pub heading_sigma_deg: Option<f64>,
    /// Broadcast navigation file (RINEX 2 or 3) for a raw GNSS input: `gnss`
    /// a RINEX observation file read as raw pseudoranges/Dopplers
    /// ([`crate::raw_input`]); a `.ubx` log carries its own ephemerides.
    pub nav: Option<String>,
    /// RTK base station observations (RINEX with `nav`, or `.ubx`), for
    /// `[filter] coupling = "rtk"` ([`crate::rtk_run`], [`crate::base_station`]).
    pub base: Option<String>,
    /// The base position: `[x, y, z]` ECEF [m], `[lat_deg, lon_deg, h_m]`,
    /// `"header"`, `"spp"` or `"auto"` (default: the header's when it holds
    /// one, else averaged SPP; [`crate::base_station`]).
    pub base_position: Option<BasePositionCfg>,
}

/// `[input] base_position`: three numbers or a word.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(untagged)]
pub enum BasePositionCfg {
    Triple([f64; 3]),
    Word(String),
}

impl BasePositionCfg {
    /// The position rule it names ([`crate::base_station::BasePositionSpec`]).
    pub fn spec(&self) -> std::result::Result<crate::base_station::BasePositionSpec, String> {
        use crate::base_station::BasePositionSpec;
        match self {
            BasePositionCfg::Triple(v) => BasePositionSpec::from_triple(*v),
            BasePositionCfg::Word(w) => BasePositionSpec::from_word(w),
        }
    }
}

fn default_rate() -> f64 {
    100.0
}

#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct InitCfg {
    pub position: Option<[f64; 3]>,
    pub attitude: Option<[f64; 3]>,
    /// Initial heading source: "auto" (default: the given attitude, else the
    /// AHRS yaw column, else the magnetometer columns of `[input.csv]`, else
    /// the GNSS course once moving), "ahrs", "magnetometer" or "course".
    pub heading: Option<String>,
    /// Magnetic declination [deg, east positive] for the magnetometer heading.
    pub magnetic_declination_deg: Option<f64>,
    /// Initial yaw only [deg] (roll and pitch still from levelling or the
    /// in-motion alignment).
    pub heading_deg: Option<f64>,
    /// Initial NED velocity of the IMU [m/s] (default: 0 at rest, else the
    /// GNSS velocity at the start).
    pub velocity: Option<[f64; 3]>,
    /// 1-σ of the initial position [m] (default: the start fix's σ).
    pub position_std_m: Option<f64>,
    /// 1-σ of the initial velocity [m/s] (default: from the GNSS velocity σ).
    pub velocity_std_m_s: Option<f64>,
    /// 1-σ of the initial roll, pitch, yaw [deg] (default: from the alignment).
    pub attitude_std_deg: Option<[f64; 3]>,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FilterCfg {
    /// "eskf" (default), "pf-lc", "gps-acc" or "cp-att" (carrier-phase
    /// attitude alone, `[input] carrier_phase` + `[cp_att]`).
    #[serde(default)]
    pub estimator: Option<String>,
    #[serde(default = "default_preset")]
    pub preset: String,
    pub noise_yaml: Option<String>,
    /// `[filter.imu_noise]`: the IMU noise in KF-GINS's keys and units
    /// (arw deg/√h, vrw m/s/√h, gbstd deg/h, abstd mGal, gsstd/asstd ppm,
    /// corrtime h) or in datasheet keys ([`crate::noise_cfg`]). Without it
    /// or `noise_yaml`: the seed 001 preset's.
    pub imu_noise: Option<ImuNoiseCfg>,
    #[serde(default)]
    pub lever_arm: [f64; 3],
    #[serde(default)]
    pub smooth: bool,
    /// Platform profile (`car`, `robot`, `pedestrian`, `uav`, `marine`,
    /// `static`): sets NHC/ZUPT/ZARU and the alignment policy
    /// ([`crate::profile`]). Default: `car` with `preset = "enhanced"`, none
    /// (no constraints) with `kf-gins`/`seed001`.
    pub platform: Option<Platform>,
    /// IMU noise from a sensor preset by model (datasheet numbers and source
    /// in [`crate::sensors`]), e.g. `"adis16465"`.
    pub imu_preset: Option<String>,
    /// `[filter.nhc]`: overrides of the profile's non-holonomic constraint.
    pub nhc: Option<NhcCfg>,
    /// `[filter.zupt]`: overrides of the profile's standstill updates.
    pub zupt: Option<ZuptCfg>,
    /// `[filter.gnss_error]`: white or Gauss–Markov GNSS position error
    /// ([`crate::gnss_error`]).
    pub gnss_error: Option<crate::gnss_error::GnssErrorCfg>,
    /// Estimate the IMU–GNSS time offset as a filter state: `true`, `false`
    /// or `"auto"` (on for platforms whose course does not follow the
    /// heading, uav and marine); default false.
    pub time_offset_state: Option<crate::gnss_error::BoolOrAuto>,
    /// Inflate the GNSS position/velocity R from the windowed NIS, bounded
    /// and never below the reported σ
    /// ([`navfuse_core::estimators::adaptive::NisAdaptation`]); default off
    /// (it cost accuracy where the IMU model, not R, was too small).
    pub nis_adaptation: Option<bool>,
    /// Heading aiding of the ESKF: `"none"` (default) or `"cp-att"` (the
    /// attitude of CP-ATT on `[input] carrier_phase`, [`crate::cp_att_run`]).
    pub heading_source: Option<crate::cp_att_run::HeadingSourceCfg>,
    /// `[filter.odometer]`, `[filter.heading]`, `[filter.mag]` ([`crate::aiding_cfg`]).
    pub odometer: Option<crate::aiding_cfg::OdometerCfg>,
    pub heading: Option<crate::aiding_cfg::HeadingCfg>,
    pub mag: Option<crate::aiding_cfg::MagCfg>,
    /// GNSS coupling of the ESKF: `"loose"` (default: position/velocity
    /// fixes) or `"tight"` (each satellite's pseudorange and Doppler from a
    /// raw `.ubx` log or RINEX observations + `[input] nav`, [`crate::raw_input`]).
    pub coupling: Option<String>,
}

/// `[filter] coupling`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coupling {
    Loose,
    Tight,
    /// Carrier-phase double differences against `[input] base` ([`crate::rtk_run`]).
    Rtk,
}

impl RunConfig {
    /// `[filter] coupling` (default loose); an unknown value is a
    /// configuration error naming the key.
    pub fn coupling(&self) -> Result<Coupling> {
        match self.filter.coupling.as_deref() {
            None | Some("loose") => Ok(Coupling::Loose),
            Some("tight") => Ok(Coupling::Tight),
            Some("rtk") => Ok(Coupling::Rtk),
            Some(c) => Err(self.err(format!(
                "[filter] coupling = {c:?}: expected \"loose\", \"tight\" or \"rtk\""
            ))),
        }
    }
}

impl Default for FilterCfg {
    fn default() -> Self {
        FilterCfg {
            estimator: None,
            preset: default_preset(),
            noise_yaml: None,
            imu_noise: None,
            lever_arm: [0.0; 3],
            smooth: false,
            platform: None,
            imu_preset: None,
            nhc: None,
            zupt: None,
            gnss_error: None,
            time_offset_state: None,
            nis_adaptation: None,
            heading_source: None,
            odometer: None,
            heading: None,
            mag: None,
            coupling: None,
        }
    }
}

/// `[filter.nhc]`: non-holonomic constraint overrides (body lateral and
/// vertical velocity = 0 ± `std`). Unset keys keep the profile's values.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NhcCfg {
    /// `false` switches the constraint off.
    pub enabled: Option<bool>,
    /// 1-σ [m/s] (the start value when adaptive).
    pub std: Option<f64>,
    /// Apply only above this speed [m/s].
    pub min_speed: Option<f64>,
    /// Minimum time between updates [s].
    pub interval: Option<f64>,
    /// Learn σ from the innovations within [`min_std`, `max_std`] (default
    /// false: real NHC violations are time-correlated, see `eskf_run`).
    pub adaptive: Option<bool>,
    pub min_std: Option<f64>,
    pub max_std: Option<f64>,
    /// Estimate the mounting pitch/yaw and the forward offset from the
    /// non-holonomic point as states (default `false`; the prior σ are the
    /// profile's, a car's where it has none).
    pub mount_states: Option<bool>,
    /// Initial mounting pitch [deg], yaw [deg] and forward lever [m] of the
    /// mounting states (default 0, 0, 0).
    pub mount_initial: Option<[f64; 3]>,
    /// Their 1-σ, same units (default: the profile's prior).
    pub mount_std: Option<[f64; 3]>,
}

/// `[filter.zupt]`: standstill detection and zero-velocity/-rate update
/// overrides. Unset keys keep the profile's values.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ZuptCfg {
    /// `false` switches ZUPT and ZARU off.
    pub enabled: Option<bool>,
    /// Zero-velocity 1-σ [m/s].
    pub vel_std: Option<f64>,
    /// Zero-rate 1-σ [deg/s]; 0 switches ZARU off.
    pub zaru_std_dps: Option<f64>,
    /// Detector: std of |f| over the window below this [m/s²] …
    pub max_accel_std: Option<f64>,
    /// … gyro std below this [deg/s] …
    pub max_gyro_std_dps: Option<f64>,
    /// … and the filter speed below this [m/s].
    pub max_speed: Option<f64>,
    /// Learn the ZUPT/ZARU σ from the innovations.
    pub adaptive: Option<bool>,
}

fn default_preset() -> String {
    "enhanced".into()
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct OutageCfg {
    /// Seconds after the first IMU sample used.
    pub start: f64,
    pub length: f64,
    pub period: f64,
}
/// A configuration file's text, at most
/// [`MAX_CONFIG_BYTES`](navfuse_io::text::MAX_CONFIG_BYTES) long with no
/// line over [`MAX_LINE_BYTES`](navfuse_io::text::MAX_LINE_BYTES): an
/// unopenable file is [`PipelineError::Io`], an oversized or non-UTF-8 one
/// [`PipelineError::Config`] naming the line.
pub(crate) fn read_config_text(path: &Path) -> Result<String> {
    use navfuse_io::text::{read_text_capped, MAX_CONFIG_BYTES};
    read_text_capped(path, MAX_CONFIG_BYTES).map_err(|e| match e.kind() {
        navfuse_io::FailureKind::Io => PipelineError::Io {
            path: path.to_path_buf(),
            what: "",
            source: std::io::Error::other(e.msg),
        },
        _ => PipelineError::Config {
            file: path.display().to_string(),
            msg: if e.line > 0 {
                format!("line {}: {}", e.line, e.msg)
            } else {
                e.msg
            },
        },
    })
}
