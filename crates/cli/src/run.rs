//! `navfuse run`: the ESKF on IMU/GNSS recordings with a TOML config, with
//! automatic alignment, optional outage simulation and RTS smoothing; writes
//! `solution.nav` (+ `solution_smoothed.nav`) and `summary.json`. Also holds
//! the input loading shared with `kf-gins` and `bench`.

use crate::run_input::{self, CsvCfg, InputSpec, TimeOffsetCfg};
use clap::Args as ClapArgs;
use navfuse_core::estimators::accel_dr::{AccelDr, AccelDrConfig};
use navfuse_core::estimators::eskf::{rts_smooth, Eskf, EskfConfig, ImuErrors, InitStd, UpdateLog};
use navfuse_core::estimators::pf_lc::{PfLc, PfLcConfig};
use navfuse_core::ins::align;
use navfuse_core::ins::mech::{q_bn_from_rpy, NavState};
use navfuse_core::types::{Estimator, Event, GnssFix, ImuSample, NavSolution};
use navfuse_core::Vec3;
use navfuse_io::kfgins::{KfGinsGnssReader, KfGinsImuOptions, KfGinsImuReader};
use navfuse_io::kfgins_yaml::{KfGinsConfig, KfGinsNoise};
use navfuse_io::trajectory::{create_writer, OutFormat};
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::path::PathBuf;
use std::time::Instant;

/// Run the ESKF on IMU/GNSS recordings with a TOML config.
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// TOML run configuration (paths inside are relative to it). See `RunConfig`.
    pub config: PathBuf,
    /// Output folder (default: `output` from the config, else `./navfuse-out`).
    #[arg(long)]
    pub output: Option<PathBuf>,
    /// Estimator (overrides `[filter] estimator`): eskf, pf-lc (seed 002), gps-acc (seed 004).
    #[arg(long)]
    pub estimator: Option<String>,
    /// Also write the HTML report (OUTPUT/report/index.html and SVG plots).
    #[arg(long)]
    pub report: bool,
    /// Reference trajectory for the report's errors (.nav, .pos, .csv).
    #[arg(long)]
    pub truth: Option<PathBuf>,
}

/// `navfuse run` configuration (TOML). Units: degrees, metres, seconds.
///
/// ```toml
/// [input]
/// imu = "imu.txt"            # KF-GINS IMU text (increments, body FRD), or a CSV
/// imu_format = "kf-gins"     # optional: "kf-gins" | "csv" (default from the extension)
/// imu_rate = 100.0
/// gnss = "gnss.txt"          # KF-GINS GNSS text, RTKLIB .pos, NMEA (.nmea) or UBX (.ubx)
/// gnss_format = "kf-gins"    # optional: "kf-gins" | "pos" | "nmea" | "ubx"
/// start = 243262.0           # optional, seconds (the IMU file's time base)
/// imu_time_offset = 0.0      # optional: seconds added to IMU stamps, or "auto"
///
/// [input.csv]                # for imu_format = "csv": a preset or a column map
/// preset = "drive_0708"      # "drive_0708" | "vn310", or instead:
/// # time = "t" (or week = 0, tow = 1), gyro = ["gx","gy","gz"], accel = [3, 4, 5],
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
/// estimator = "eskf"         # "eskf" | "pf-lc" | "gps-acc" (the others use their defaults)
/// preset = "enhanced"        # "kf-gins" | "enhanced" | "seed001" (eskf)
/// noise_yaml = "kf.yaml"     # optional: take the IMU noise from a KF-GINS YAML
/// # or [filter.imu_noise]: arw = [8, 8, 8], vrw, gbstd, abstd, gsstd, asstd, corrtime
/// # (KF-GINS keys and units); neither: the seed 001 preset's noise
/// lever_arm = [0.0, -0.05, 0.0]
/// smooth = true
///
/// [outage]                   # optional: cut GNSS for `length` s every `period` s from `start` s
/// start = 120.0
/// length = 30.0
/// period = 90.0
///
/// # top level, optional: extra solution formats besides solution.nav
/// formats = ["csv", "geojson", "kml", "gpx", "nmea"]
/// ```
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    pub input: InputCfg,
    #[serde(default)]
    pub init: InitCfg,
    #[serde(default)]
    pub filter: FilterCfg,
    pub outage: Option<OutageCfg>,
    pub output: Option<String>,
    /// Extra solution formats (extensions) written besides `solution.nav`.
    #[serde(default)]
    pub formats: Vec<String>,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct InputCfg {
    pub imu: String,
    /// "kf-gins" or "csv" (default: from the extension, see [`crate::run_input`]).
    pub imu_format: Option<String>,
    #[serde(default = "default_rate")]
    pub imu_rate: f64,
    /// `[input.csv]`: the generic CSV IMU reader's preset or column map.
    pub csv: Option<CsvCfg>,
    pub gnss: String,
    /// "kf-gins", "pos", "nmea" or "ubx" (default: from the extension).
    pub gnss_format: Option<String>,
    pub start: Option<f64>,
    /// Seconds added to the IMU stamps (true time = stamp + offset), or "auto".
    pub imu_time_offset: Option<TimeOffsetCfg>,
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
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FilterCfg {
    /// "eskf" (default), "pf-lc" or "gps-acc".
    #[serde(default)]
    pub estimator: Option<String>,
    #[serde(default = "default_preset")]
    pub preset: String,
    pub noise_yaml: Option<String>,
    /// `[filter.imu_noise]`: the IMU noise in KF-GINS's keys and units
    /// (arw deg/√h, vrw m/s/√h, gbstd deg/h, abstd mGal, gsstd/asstd ppm,
    /// corrtime h). Without it or `noise_yaml`: the seed 001 preset's.
    pub imu_noise: Option<KfGinsNoise>,
    #[serde(default)]
    pub lever_arm: [f64; 3],
    #[serde(default)]
    pub smooth: bool,
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
        }
    }
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

#[derive(Serialize)]
struct Summary<'a> {
    config: &'a RunConfig,
    filter: String,
    alignment: String,
    /// Per input file: records read, used, skipped, rejected by reason.
    inputs: serde_json::Value,
    imu_samples_read: usize,
    imu_samples_before_start: usize,
    gnss_fixes_read: usize,
    gnss_fixes_cut_by_outage: usize,
    /// Fixes outside the filtered IMU span (before alignment ended, after the last sample).
    gnss_fixes_outside_filter_span: usize,
    gnss_fixes_fed: usize,
    used_rejected: serde_json::Value,
    time_offset: String,
    seconds_read: f64,
    seconds_filter: f64,
    outputs: Vec<String>,
}

pub fn run(args: Args) -> Result<(), String> {
    let text = std::fs::read_to_string(&args.config)
        .map_err(|e| format!("{}: cannot read: {e}", args.config.display()))?;
    let cfg: RunConfig =
        toml::from_str(&text).map_err(|e| format!("{}: {e}", args.config.display()))?;
    let base = args
        .config
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    let rel = |p: &str| {
        let p = Path::new(p);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            base.join(p)
        }
    };
    let t_read = Instant::now();
    let (imu_path, gnss_path) = (rel(&cfg.input.imu), rel(&cfg.input.gnss));
    let loaded = run_input::load(&InputSpec {
        imu: &imu_path,
        imu_format: cfg.input.imu_format.as_deref(),
        imu_rate: cfg.input.imu_rate,
        csv: cfg.input.csv.as_ref(),
        gnss: &gnss_path,
        gnss_format: cfg.input.gnss_format.as_deref(),
        imu_time_offset: cfg.input.imu_time_offset.as_ref(),
    })
    .map_err(|e| format!("{}: {e}", args.config.display()))?;
    let inputs = serde_json::json!({
        "imu": loaded.imu_report,
        "gnss": loaded.gnss_report,
        "time_base": loaded.time_base,
        "imu_time_offset_applied_s": loaded.imu_time_offset.as_ref().map(|o| o.0),
        "imu_time_offset_source": loaded.imu_time_offset.as_ref().map(|o| o.1.clone()),
    });
    let applied_offset = match &loaded.imu_time_offset {
        Some((tau, how)) => format!("{tau:+.3} s, {how}"),
        None => "none".into(),
    };
    let aux = loaded.aux;
    let (imu, mut gnss) = (loaded.imu, loaded.gnss);
    let seconds_read = t_read.elapsed().as_secs_f64();
    let start = cfg.input.start.unwrap_or(f64::NEG_INFINITY);
    let i0 = imu.partition_point(|s| s.t < start);
    let imu_before_start = i0;
    let imu = &imu[i0..];
    if imu.len() < 200 {
        return Err(format!(
            "{}: fewer than 200 IMU samples after the start",
            cfg.input.imu
        ));
    }
    let n_gnss = gnss.len();
    let gnss_all = gnss.clone();
    if let Some(o) = &cfg.outage {
        if !(o.length > 0.0 && o.period >= o.length) {
            return Err(format!(
                "{}: [outage] needs length > 0 and period ≥ length",
                args.config.display()
            ));
        }
        let t0 = imu[0].t + o.start;
        gnss.retain(|g| g.t < t0 || (g.t - t0) % o.period >= o.length);
    }
    let cut = n_gnss - gnss.len();
    let out_dir = args
        .output
        .clone()
        .or(cfg.output.as_deref().map(rel))
        .unwrap_or_else(|| PathBuf::from("navfuse-out"));
    let formats = out_formats(&cfg.formats)
        .map_err(|e| format!("{}: formats: {e}", args.config.display()))?;
    let estimator = args
        .estimator
        .clone()
        .or(cfg.filter.estimator.clone())
        .unwrap_or_else(|| "eskf".into());
    if estimator != "eskf" {
        let run = OtherRun {
            cfg: &cfg,
            imu,
            gnss: &gnss,
            n_gnss,
            cut,
            seconds_read,
            out_dir: &out_dir,
            formats: &formats,
            inputs: &inputs,
            imu_before_start,
        };
        run_other(&estimator, &run)?;
        if args.report {
            run_report(&out_dir, args.truth.as_deref(), &rel(&cfg.input.gnss))?;
        }
        return Ok(());
    }

    // Filter model.
    let mut ecfg = match (&cfg.filter.noise_yaml, &cfg.filter.imu_noise) {
        (Some(_), Some(_)) => {
            return Err(format!(
                "{}: [filter] give noise_yaml or imu_noise, not both",
                args.config.display()
            ))
        }
        (Some(y), None) => KfGinsConfig::load(&rel(y))?.eskf_config(),
        (None, Some(n)) => {
            n.validate(&args.config.display().to_string(), "filter.imu_noise")?;
            EskfConfig {
                noise: n.to_si(),
                scale_factors: true,
                ..EskfConfig::seed001()
            }
        }
        (None, None) => EskfConfig::seed001(),
    };
    ecfg = match cfg.filter.preset.as_str() {
        "kf-gins" => ecfg,
        "enhanced" => crate::kf_gins::enhanced(ecfg),
        "seed001" => EskfConfig::seed001(),
        p => {
            return Err(format!(
                "{}: [filter] preset {p:?}: expected kf-gins, enhanced or seed001",
                args.config.display()
            ))
        }
    };
    ecfg.lever_arm_b = Vec3::new(
        cfg.filter.lever_arm[0],
        cfg.filter.lever_arm[1],
        cfg.filter.lever_arm[2],
    );
    if cfg.filter.smooth {
        ecfg.smoother_every = 10;
    }

    // Alignment: static calibration over the detected static window
    // (`SEEDS.md §1` eq. 1–2), heading given or from the GNSS course.
    let first = gnss.first().ok_or("no GNSS fixes")?;
    let n_static = align::initial_static_len(imu, 50, 0.15, 3.0f64.to_radians());
    let cal = align::static_calibration(&imu[..n_static.max(2)], first.lat, first.h)
        .ok_or("static calibration failed")?;
    // Heading: given, AHRS or magnetometer average over the static window,
    // or the GNSS course once moving (a MEMS gyro cannot find north).
    let source = cfg.init.heading.as_deref().unwrap_or("auto");
    let (t_s0, t_s1) = (imu[0].t - imu[0].dt, imu[n_static.max(2) - 1].t);
    let ahrs = || aux.as_ref().and_then(|a| a.mean_yaw(t_s0, t_s1));
    let mag = || {
        let m = aux.as_ref()?.mean_mag(t_s0, t_s1)?;
        let dec = cfg
            .init
            .magnetic_declination_deg
            .unwrap_or(0.0)
            .to_radians();
        align::heading_from_magnetometer(&m, cal.roll, cal.pitch, dec)
    };
    let dec_note = match cfg.init.magnetic_declination_deg {
        Some(d) => format!("declination {d:+.2}°"),
        None => "declination not given: 0 assumed".into(),
    };
    let static_heading = match (source, cfg.init.attitude) {
        ("auto", Some(a)) => Some((a[2].to_radians(), "attitude given".to_string())),
        ("auto", None) => ahrs()
            .map(|y| (y, "AHRS yaw averaged over the static window".to_string()))
            .or_else(|| {
                mag().map(|y| {
                    (y, format!("magnetometer averaged over the static window, tilt-compensated, {dec_note}"))
                })
            }),
        ("ahrs", _) => Some((
            ahrs().ok_or("[init] heading = \"ahrs\": give [input.csv] ahrs_yaw (a column with samples in the static window)")?,
            "AHRS yaw averaged over the static window".to_string(),
        )),
        ("magnetometer", _) => Some((
            mag().ok_or("[init] heading = \"magnetometer\": give [input.csv] mag columns (samples in the static window, a horizontal field)")?,
            format!("magnetometer averaged over the static window, tilt-compensated, {dec_note}"),
        )),
        ("course", _) => None,
        (h, _) => {
            return Err(format!(
                "{}: [init] heading {h:?}: expected auto, ahrs, magnetometer or course",
                args.config.display()
            ))
        }
    };
    let (mut k_start, yaw, how) = match static_heading {
        Some((y, how)) => (0usize, y, how),
        None => {
            // First pair of fixes ≥ 1 s apart with a course speed ≥ 3 m/s.
            let mut found = None;
            for w in gnss.windows(2) {
                let dt = w[1].t - w[0].t;
                if dt <= 0.0 {
                    continue;
                }
                let (rm, rn) = navfuse_core::earth::radii(w[0].lat);
                let v = Vec3::new(
                    (w[1].lat - w[0].lat) * (rm + w[0].h) / dt,
                    (w[1].lon - w[0].lon) * (rn + w[0].h) * w[0].lat.cos() / dt,
                    -(w[1].h - w[0].h) / dt,
                );
                if let Some(y) = align::heading_from_velocity(&v, 3.0) {
                    found = Some((w[1].t, y));
                    break;
                }
            }
            let (t, y) =
                found.ok_or("heading: no GNSS course ≥ 3 m/s found (give [init] attitude)")?;
            let k = imu.partition_point(|s| s.t < t);
            (
                k,
                y,
                format!(
                    "yaw from the GNSS course at t = {t:.2} ({:.1}°)",
                    y.to_degrees()
                ),
            )
        }
    };
    let bg = align::gyro_bias(&cal, yaw, first.lat);
    let (roll, pitch) = match cfg.init.attitude {
        Some(a) => (a[0].to_radians(), a[1].to_radians()),
        None => (cal.roll, cal.pitch),
    };
    let mut nav = NavState {
        q_bn: q_bn_from_rpy(&Vec3::new(roll, pitch, yaw)),
        ..Default::default()
    };
    let alignment;
    if k_start == 0 {
        let p = cfg
            .init
            .position
            .map(|p| (p[0].to_radians(), p[1].to_radians(), p[2]));
        let (lat, lon, h) = p.unwrap_or((first.lat, first.lon, first.h));
        nav.lat = lat;
        nav.lon = lon;
        nav.h = h;
        alignment = format!(
            "static window {n_static} samples: roll {:.2}°, pitch {:.2}°; {how}",
            roll.to_degrees(),
            pitch.to_degrees()
        );
    } else {
        // Start at the fix that gave the course, moving at its velocity.
        let g = gnss[gnss
            .partition_point(|g| g.t < imu[k_start].t)
            .saturating_sub(1)];
        nav.lat = g.lat;
        nav.lon = g.lon;
        nav.h = g.h;
        let prev = gnss[gnss.partition_point(|x| x.t < g.t).saturating_sub(1)];
        let dt = (g.t - prev.t).max(1e-3);
        let (rm, rn) = navfuse_core::earth::radii(g.lat);
        nav.v_n = Vec3::new(
            (g.lat - prev.lat) * (rm + g.h) / dt,
            (g.lon - prev.lon) * (rn + g.h) * g.lat.cos() / dt,
            -(g.h - prev.h) / dt,
        );
        k_start = k_start.saturating_sub(1);
        alignment = format!(
            "static window {n_static} samples: roll {:.2}°, pitch {:.2}°, gyro bias from it; {how}",
            roll.to_degrees(),
            pitch.to_degrees()
        );
    }
    let std = InitStd {
        pos: Vec3::repeat(if k_start == 0 { 0.5 } else { 1.0 }),
        vel: Vec3::repeat(if k_start == 0 { 0.1 } else { 1.0 }),
        att: Vec3::new(1.0, 1.0, 5.0).map(f64::to_radians),
        bg: Vec3::repeat(100.0f64.to_radians() / 3600.0),
        ba: Vec3::repeat(0.2),
        sg: Vec3::repeat(1e-3),
        sa: Vec3::repeat(1e-3),
    };
    let errors = ImuErrors {
        bg,
        ..Default::default()
    };
    let mut eskf = Eskf::new(ecfg, nav, errors, &std);

    std::fs::create_dir_all(&out_dir).map_err(|e| format!("{}: {e}", out_dir.display()))?;
    let t_filter = Instant::now();
    let mut g = gnss.partition_point(|x| x.t <= imu[k_start].t);
    let mut sols = Vec::with_capacity(imu.len());
    let mut records = Vec::new();
    let mut innovations = Vec::new();
    let mut gnss_fed = 0usize;
    for s in &imu[k_start..] {
        while g < gnss.len() && gnss[g].t <= s.t + 1e-3 {
            eskf.push(&Event::Gnss(gnss[g]));
            innovations.extend_from_slice(eskf.updates());
            g += 1;
            gnss_fed += 1;
        }
        if let Some(sol) = eskf.push(&Event::Imu(*s)) {
            sols.push(sol);
        }
        innovations.extend_from_slice(eskf.updates());
        if let Some(r) = eskf.take_record() {
            records.push(r);
        }
    }
    let seconds_filter = t_filter.elapsed().as_secs_f64();
    let mut outputs = Vec::new();
    outputs.extend(write_solutions(&out_dir, "solution", &sols, &formats)?);
    outputs.push(write_innovations(
        &out_dir.join("solution.innovations.csv"),
        &innovations,
    )?);
    if cfg.filter.smooth {
        let mut sm = Vec::with_capacity(records.len());
        rts_smooth(&records, |e| {
            sm.push(crate::kf_gins::check::smoothed_solution(e))
        });
        sm.reverse();
        outputs.extend(write_solutions(
            &out_dir,
            "solution_smoothed",
            &sm,
            &formats,
        )?);
    }
    let st = eskf.stats();
    let summary = Summary {
        config: &cfg,
        filter: format!("{:?}", eskf.config()),
        alignment,
        inputs,
        imu_samples_read: imu.len() + imu_before_start,
        imu_samples_before_start: imu_before_start,
        gnss_fixes_read: n_gnss,
        gnss_fixes_cut_by_outage: cut,
        gnss_fixes_outside_filter_span: n_gnss - cut - gnss_fed,
        gnss_fixes_fed: gnss_fed,
        used_rejected: serde_json::json!({
            "imu": {"used": st.imu_samples, "rejected_bad": st.imu_rejected_bad},
            "gnss_position": {"used": st.gnss_pos_used, "rejected_gate": st.gnss_pos_rejected_gate,
                "forced_after_rejections": st.gnss_pos_forced, "rejected_bad_or_late": st.gnss_rejected_bad},
            "gnss_velocity": {"used": st.gnss_vel_used, "rejected_gate": st.gnss_vel_rejected_gate},
            "height": {"used": st.height_used, "rejected_gate": st.height_rejected_gate},
            "nhc": {"used": st.nhc_used, "rejected_gate": st.nhc_rejected_gate},
            "zupt": {"used": st.zupt_used, "rejected_gate": st.zupt_rejected_gate},
            "zaru": {"used": st.zaru_used},
            "deweighted": st.deweighted,
            "singular": st.singular,
        }),
        time_offset: match estimate_time_offset(imu, &gnss_all, 0.5) {
            Some((tau, r)) => format!(
                "after the input's imu_time_offset ({applied}): a further {tau:+.3} s to add to the IMU stamps (course-rate / yaw-rate cross-correlation r = {r:.4}); reported, not applied",
                applied = applied_offset
            ),
            None => "not estimable (too little turning at speed)".into(),
        },
        seconds_read,
        seconds_filter,
        outputs,
    };
    let p = out_dir.join("summary.json");
    let json = serde_json::to_string_pretty(&summary).map_err(|e| e.to_string())?;
    std::fs::write(&p, json).map_err(|e| format!("{}: {e}", p.display()))?;
    eprintln!(
        "navfuse run: {} solutions, GNSS used {} / gated {}; {}; summary {}",
        sols.len(),
        st.gnss_pos_used,
        st.gnss_pos_rejected_gate,
        summary.alignment,
        p.display()
    );
    if args.report {
        run_report(&out_dir, args.truth.as_deref(), &rel(&cfg.input.gnss))?;
    }
    Ok(())
}

/// Every measurement update the ESKF tried (`t,kind,nis,dof,accepted`), the
/// report's innovation monitor input.
fn write_innovations(path: &Path, log: &[UpdateLog]) -> Result<String, String> {
    use std::io::Write as _;
    let io = |e: std::io::Error| format!("{}: {e}", path.display());
    let f = std::fs::File::create(path).map_err(io)?;
    let mut w = std::io::BufWriter::new(f);
    writeln!(w, "t,kind,nis,dof,accepted").map_err(io)?;
    for u in log {
        writeln!(
            w,
            "{:.4},{},{:.6},{},{}",
            u.t,
            u.kind.name(),
            u.nis,
            u.dof,
            u.accepted as u8
        )
        .map_err(io)?;
    }
    w.flush().map_err(io)?;
    Ok(path.display().to_string())
}

/// The extra output formats named in the config (by extension: csv, nav,
/// geojson, kml, gpx, nmea).
fn out_formats(names: &[String]) -> Result<Vec<OutFormat>, String> {
    names
        .iter()
        .map(|n| {
            OutFormat::from_path(Path::new(&format!("x.{n}")))
                .ok_or_else(|| format!("unknown format {n:?} (csv, nav, geojson, kml, gpx, nmea)"))
        })
        .collect()
}

/// Write `STEM.nav` (KF-GINS layout, always) and `STEM.<ext>` for every extra
/// format; returns the paths written.
fn write_solutions(
    dir: &Path,
    stem: &str,
    sols: &[NavSolution],
    formats: &[OutFormat],
) -> Result<Vec<String>, String> {
    let mut written = Vec::new();
    let mut all = vec![OutFormat::Nav];
    all.extend(formats.iter().copied().filter(|f| *f != OutFormat::Nav));
    for fmt in all {
        let p = dir.join(format!("{stem}.{}", fmt.extension()));
        let io = |e: std::io::Error| format!("{}: {e}", p.display());
        let mut w = create_writer(&p, fmt).map_err(io)?;
        for s in sols {
            w.write(s).map_err(io)?;
        }
        w.finish().map_err(io)?;
        written.push(p.display().to_string());
    }
    Ok(written)
}

/// Inputs of a run of an estimator other than the ESKF.
struct OtherRun<'a> {
    cfg: &'a RunConfig,
    imu: &'a [ImuSample],
    gnss: &'a [GnssFix],
    n_gnss: usize,
    cut: usize,
    seconds_read: f64,
    out_dir: &'a Path,
    formats: &'a [OutFormat],
    inputs: &'a serde_json::Value,
    imu_before_start: usize,
}

/// Run PF-LC (seed 002) or GPS-ACC (seed 004) with their default
/// configurations over the time-ordered events (a fix goes before the first
/// IMU sample ending at or after it); they initialise
/// themselves from GNSS. Writes the solutions and `summary.json`.
fn run_other(name: &str, r: &OtherRun) -> Result<(), String> {
    let (mut est, config): (Box<dyn Estimator>, String) = match name {
        "pf-lc" => {
            let c = PfLcConfig::default();
            (Box::new(PfLc::new(c)), format!("{c:?}"))
        }
        "gps-acc" => {
            let c = AccelDrConfig::rate_scaled();
            (Box::new(AccelDr::new(c)), format!("{c:?}"))
        }
        other => {
            return Err(format!(
                "estimator {other:?}: expected eskf, pf-lc or gps-acc"
            ))
        }
    };
    std::fs::create_dir_all(r.out_dir).map_err(|e| format!("{}: {e}", r.out_dir.display()))?;
    let t_filter = Instant::now();
    let mut sols = Vec::with_capacity(r.imu.len());
    let mut g = r.gnss.partition_point(|x| x.t < r.imu[0].t - r.imu[0].dt);
    let mut gnss_fed = 0usize;
    for s in r.imu {
        // Strict time order: a fix goes before the first IMU sample ending at
        // or after it (these estimators do not split IMU intervals).
        while g < r.gnss.len() && r.gnss[g].t <= s.t {
            if let Some(sol) = est.push(&Event::Gnss(r.gnss[g])) {
                sols.push(sol);
            }
            gnss_fed += 1;
            g += 1;
        }
        if let Some(sol) = est.push(&Event::Imu(*s)) {
            sols.push(sol);
        }
    }
    let seconds_filter = t_filter.elapsed().as_secs_f64();
    let outputs = write_solutions(r.out_dir, "solution", &sols, r.formats)?;
    let summary = serde_json::json!({
        "config": r.cfg,
        "estimator": est.name(),
        "filter": config,
        "inputs": r.inputs,
        "imu_samples_read": r.imu.len() + r.imu_before_start,
        "imu_samples_before_start": r.imu_before_start,
        "gnss_fixes_read": r.n_gnss,
        "gnss_fixes_cut_by_outage": r.cut,
        "gnss_fixes_outside_imu_span": r.n_gnss - r.cut - gnss_fed,
        "used_rejected": {"imu_fed": r.imu.len(), "gnss_fed": gnss_fed},
        "solutions": sols.len(),
        "seconds_read": r.seconds_read,
        "seconds_filter": seconds_filter,
        "outputs": outputs,
    });
    let p = r.out_dir.join("summary.json");
    let json = serde_json::to_string_pretty(&summary).map_err(|e| e.to_string())?;
    std::fs::write(&p, json).map_err(|e| format!("{}: {e}", p.display()))?;
    eprintln!(
        "navfuse run: {} ({}) {} solutions from {} IMU samples and {gnss_fed} GNSS fixes; summary {}",
        est.name(),
        name,
        sols.len(),
        r.imu.len(),
        p.display()
    );
    Ok(())
}

/// The HTML report of a run folder (solutions, summary), with the GNSS input
/// as the fixes and an optional reference.
fn run_report(out_dir: &Path, truth: Option<&Path>, gnss: &Path) -> Result<(), String> {
    let opt = navfuse_report::LoadOptions {
        truth: truth.map(Path::to_path_buf),
        fixes: Some(gnss.to_path_buf()),
        ..Default::default()
    };
    let mut inp = navfuse_report::load_run_dir(out_dir, &opt)?;
    inp.title = format!("navfuse run — {}", out_dir.display());
    let sum = navfuse_report::write_report(&out_dir.join("report"), &inp)?;
    eprintln!("report: {}", sum.html.display());
    Ok(())
}

/// Which IMU time offset a run applies (true time = IMU stamp + τ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TimeOffset {
    None,
    /// Estimated by [`estimate_time_offset`] (±0.5 s).
    Auto,
    Seconds(f64),
}

impl TimeOffset {
    /// `none`, `auto` or a number of seconds (finite, |τ| < 10 s).
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "none" => Ok(TimeOffset::None),
            "auto" => Ok(TimeOffset::Auto),
            _ => s
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && v.abs() < 10.0)
                .map(TimeOffset::Seconds)
                .ok_or_else(|| {
                    format!("time offset {s:?}: expected seconds (|τ| < 10), auto or none")
                }),
        }
    }

    /// The offset [s] and how it was found; an error when `Auto` finds no
    /// estimate (too little turning at speed).
    pub fn resolve(
        self,
        imu: &[ImuSample],
        gnss: &[GnssFix],
    ) -> Result<Option<(f64, String)>, String> {
        match self {
            TimeOffset::None => Ok(None),
            TimeOffset::Seconds(s) => Ok(Some((s, "given".into()))),
            TimeOffset::Auto => estimate_time_offset(imu, gnss, 0.5)
                .map(|(tau, r)| {
                    Some((
                        tau,
                        format!("estimated by course-rate / yaw-rate cross-correlation (r = {r:.4})"),
                    ))
                })
                .ok_or_else(|| {
                    "time offset auto: no estimate (needs ≥ 30 turning GNSS course pairs at ≥ 3 m/s)"
                        .into()
                }),
        }
    }
}

/// IMU–GNSS time offset by cross-correlation of the GNSS course rate with the
/// IMU yaw rate (body z gyro, FRD: both positive turning right), over
/// intervals between consecutive fixes (thinned to ~1 s) with speed ≥ 3 m/s;
/// robust to GNSS outliers (velocity changes beyond 1 g skipped, then pairs
/// beyond 5 robust σ of the gyro agreement dropped and the scan repeated). Returns the
/// offset `τ` [s] to add to the IMU stamps (best in ±`max_lag`, 5 ms steps)
/// and the correlation coefficient there. `None` without enough turning data.
pub fn estimate_time_offset(
    imu: &[ImuSample],
    gnss: &[GnssFix],
    max_lag: f64,
) -> Option<(f64, f64)> {
    // Cumulative z-angle for O(1) interval means.
    let mut cum = Vec::with_capacity(imu.len() + 1);
    cum.push(0.0);
    for s in imu {
        cum.push(cum.last().copied().unwrap_or(0.0) + s.dtheta_b.z);
    }
    let angle_at = |t: f64| -> Option<f64> {
        let k = imu.partition_point(|s| s.t < t);
        if k == 0 || k >= imu.len() {
            return None;
        }
        let s = &imu[k];
        let frac = 1.0 - (s.t - t) / s.dt;
        Some(cum[k] + frac.clamp(0.0, 1.0) * s.dtheta_b.z)
    };
    // Fixes about 1 s apart (faster GNSS is thinned: the course from fixes a
    // quarter second apart is mostly noise).
    let mut thinned: Vec<GnssFix> = Vec::with_capacity(gnss.len());
    for g in gnss {
        if thinned.last().is_none_or(|l| g.t - l.t >= 0.95) {
            thinned.push(*g);
        }
    }
    // Course at each fix from the neighbouring fixes, then course rate.
    // A triple whose velocity change needs more than 1 g is skipped: no car
    // does that, a GNSS outlier does.
    let mut pairs = Vec::new();
    for w in thinned.windows(3) {
        let vel = |a: &GnssFix, b: &GnssFix| {
            let (rm, rn) = navfuse_core::earth::radii(a.lat);
            let dt = b.t - a.t;
            let dn = (b.lat - a.lat) * (rm + a.h);
            let de = (b.lon - a.lon) * (rn + a.h) * a.lat.cos();
            (dn / dt, de / dt, dt)
        };
        let (n0, e0, dt0) = vel(&w[0], &w[1]);
        let (n1, e1, dt1) = vel(&w[1], &w[2]);
        let (v0, v1) = (n0.hypot(e0), n1.hypot(e1));
        if v0 < 3.0 || v1 < 3.0 || !(0.5..2.0).contains(&dt0) || !(0.5..2.0).contains(&dt1) {
            continue;
        }
        if (n1 - n0).hypot(e1 - e0) > 9.81 * 0.5 * (dt0 + dt1) {
            continue;
        }
        let mut d = e1.atan2(n1) - e0.atan2(n0);
        d -= std::f64::consts::TAU * (d / std::f64::consts::TAU).round();
        // Course change between the interval midpoints.
        let (ta, tb) = (0.5 * (w[0].t + w[1].t), 0.5 * (w[1].t + w[2].t));
        pairs.push((ta, tb, d));
    }
    // IMU stamp + τ = true time  ⇒  IMU angle over [ta − τ, tb − τ].
    let imu_angle = |ta: f64, tb: f64, tau: f64| -> Option<f64> {
        Some(angle_at(tb - tau)? - angle_at(ta - tau)?)
    };
    let scan = |pairs: &[(f64, f64, f64)]| -> Option<(f64, f64)> {
        if pairs.len() < 30 {
            return None;
        }
        let mut best: Option<(f64, f64)> = None;
        let steps = (max_lag / 0.005).round() as i64;
        for i in -steps..=steps {
            let tau = i as f64 * 0.005;
            let (mut sx, mut sy, mut sxx, mut syy, mut sxy, mut n) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
            for &(ta, tb, d) in pairs {
                let Some(g) = imu_angle(ta, tb, tau) else {
                    continue;
                };
                sx += d;
                sy += g;
                sxx += d * d;
                syy += g * g;
                sxy += d * g;
                n += 1.0;
            }
            if n < 30.0 {
                continue;
            }
            let cov = sxy / n - sx * sy / (n * n);
            let r = cov / ((sxx / n - (sx / n).powi(2)) * (syy / n - (sy / n).powi(2))).sqrt();
            if best.is_none_or(|(_, br)| r > br) {
                best = Some((tau, r));
            }
        }
        best
    };
    let (tau, _) = scan(&pairs)?;
    // Second pass without the pairs whose course change disagrees with the
    // gyro by more than 5 robust σ (median absolute deviation) at that τ.
    let resid: Vec<f64> = pairs
        .iter()
        .map(|&(ta, tb, d)| imu_angle(ta, tb, tau).map_or(f64::INFINITY, |g| d - g))
        .collect();
    let mut sorted: Vec<f64> = resid.iter().copied().filter(|e| e.is_finite()).collect();
    sorted.sort_by(f64::total_cmp);
    let med = *sorted.get(sorted.len() / 2)?;
    let mut dev: Vec<f64> = sorted.iter().map(|e| (e - med).abs()).collect();
    dev.sort_by(f64::total_cmp);
    let limit = (5.0 * 1.4826 * dev[dev.len() / 2]).max(1e-3);
    let kept: Vec<(f64, f64, f64)> = pairs
        .iter()
        .zip(&resid)
        .filter(|(_, e)| (*e - med).abs() <= limit)
        .map(|(p, _)| *p)
        .collect();
    scan(&kept)
}

/// Time-ordered inputs of one run.
pub struct RunInput {
    pub imu: Vec<ImuSample>,
    pub gnss: Vec<GnssFix>,
}

fn read(path: &Path) -> Result<String, String> {
    std::fs::read_to_string(path).map_err(|e| format!("{}: cannot read: {e}", path.display()))
}

fn fields<const N: usize>(
    line: &str,
    name: &Path,
    ln: usize,
    names: &[&str; N],
) -> Result<[f64; N], String> {
    let mut out = [0.0; N];
    let mut it = line.split_ascii_whitespace();
    for (i, o) in out.iter_mut().enumerate() {
        let s = it
            .next()
            .ok_or_else(|| format!("{}:{}: field `{}`: missing", name.display(), ln, names[i]))?;
        *o = s
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| {
                format!(
                    "{}:{}: field `{}`: not a finite number: {s:?}",
                    name.display(),
                    ln,
                    names[i]
                )
            })?;
    }
    Ok(out)
}

/// KF-GINS IMU text via navfuse-io (`dt` from consecutive stamps, the first
/// from the nominal rate; duplicates/bad lines rejected and counted there).
pub fn read_kfgins_imu(path: &Path, rate: f64, columns: usize) -> Result<Vec<ImuSample>, String> {
    let (rdr, name) = navfuse_io::open(path).map_err(|e| e.to_string())?;
    let opt = KfGinsImuOptions {
        week: 0,
        columns,
        nominal_rate_hz: Some(rate),
    };
    KfGinsImuReader::new(rdr, &name, opt)
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())
}

/// KF-GINS GNSS text (`tow lat lon h σN σE σD`, optionally + velocity) via navfuse-io.
pub fn read_kfgins_gnss(path: &Path) -> Result<Vec<GnssFix>, String> {
    let (rdr, name) = navfuse_io::open(path).map_err(|e| e.to_string())?;
    KfGinsGnssReader::new(rdr, &name, 0)
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())
}

/// navfuse's GNSS velocity file: `tow vN vE vD σvN σvE σvD` ([m/s]); merged into
/// the fixes of the same epoch (±1 ms).
pub fn merge_gnss_velocity(path: &Path, fixes: &mut [GnssFix]) -> Result<usize, String> {
    let text = read(path)?;
    const N: [&str; 7] = ["tow", "v_n", "v_e", "v_d", "std_vn", "std_ve", "std_vd"];
    let mut merged = 0;
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let f = fields(line, path, i + 1, &N)?;
        let k = fixes.partition_point(|g| g.t < f[0] - 1e-3);
        if k < fixes.len() && (fixes[k].t - f[0]).abs() <= 1e-3 {
            fixes[k].v_n = Some(Vec3::new(f[1], f[2], f[3]));
            fixes[k].std_v_n = Some(Vec3::new(f[4], f[5], f[6]));
            merged += 1;
        }
    }
    Ok(merged)
}

/// All inputs named by a KF-GINS configuration.
pub fn read_kfgins(cfg: &KfGinsConfig) -> Result<RunInput, String> {
    let imu = read_kfgins_imu(&cfg.resolve(&cfg.imupath), cfg.imudatarate, cfg.imudatalen)?;
    let mut gnss = read_kfgins_gnss(&cfg.resolve(&cfg.gnsspath))?;
    if let Some(v) = &cfg.gnssvelpath {
        merge_gnss_velocity(&cfg.resolve(v), &mut gnss)?;
    }
    Ok(RunInput { imu, gnss })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `navfuse run CONFIG --output OUT` with the config's estimator.
    fn run_to(config: &Path, out: &Path) -> Result<(), String> {
        run(Args {
            config: config.to_path_buf(),
            output: Some(out.to_path_buf()),
            estimator: None,
            report: false,
            truth: None,
        })
    }

    /// [`run_to`], then its `solution.nav` (GPS week `week` for TOW-only
    /// lines) and `summary.json`.
    fn run_and_read(config: &Path, out: &Path, week: u32) -> (Vec<NavSolution>, serde_json::Value) {
        run_to(config, out).unwrap();
        let (sols, _) =
            crate::eval::read_trajectory(&out.join("solution.nav"), week, false).unwrap();
        let summary =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap())
                .unwrap();
        (sols, summary)
    }

    #[test]
    fn out_formats_by_extension_and_unknown_named() {
        let f = out_formats(&["csv".into(), "geojson".into(), "gpx".into()]).unwrap();
        assert_eq!(f, [OutFormat::Csv, OutFormat::GeoJson, OutFormat::Gpx]);
        let e = out_formats(&["shp".into()]).unwrap_err();
        assert!(e.contains("\"shp\""), "{e}");
    }

    /// A 60 s drive north at 5 m/s in KF-GINS text (level, 100 Hz IMU with
    /// gravity only, 1 Hz fixes), run with `--estimator` pf-lc and gps-acc:
    /// every estimator writes its solutions in the extra formats and a
    /// summary naming it and accounting for every fix.
    #[test]
    fn run_other_estimators_write_solutions_and_summary() {
        use std::fmt::Write as _;
        let dir = crate::test_dir("run-other");
        let (lat0, lon0, h) = (40.0f64.to_radians(), -105.0f64.to_radians(), 1600.0);
        let (rm, _) = navfuse_core::earth::radii(lat0);
        let (t0, v, g) = (1000.0, 5.0, 9.8);
        let mut imu = String::new();
        for k in 1..=6000 {
            let t = t0 + k as f64 * 0.01;
            let _ = writeln!(imu, "{t:.3} 0 0 0 0 0 {:.6}", -g * 0.01);
        }
        let mut gnss = String::new();
        for k in 0..=60 {
            let t = t0 + k as f64;
            let lat = lat0 + v * (t - t0) / (rm + h);
            let _ = writeln!(
                gnss,
                "{t:.3} {:.9} {:.9} {h:.3} 0.5 0.5 1.0",
                lat.to_degrees(),
                lon0.to_degrees()
            );
        }
        std::fs::write(dir.join("imu.txt"), imu).unwrap();
        std::fs::write(dir.join("gnss.txt"), gnss).unwrap();
        std::fs::write(
            dir.join("run.toml"),
            "formats = [\"csv\", \"geojson\"]\n[input]\nimu = \"imu.txt\"\ngnss = \"gnss.txt\"\n",
        )
        .unwrap();
        for name in ["pf-lc", "gps-acc"] {
            let out = dir.join(name);
            run(Args {
                config: dir.join("run.toml"),
                output: Some(out.clone()),
                estimator: Some(name.into()),
                report: false,
                truth: None,
            })
            .unwrap();
            for f in [
                "solution.nav",
                "solution.csv",
                "solution.geojson",
                "summary.json",
            ] {
                assert!(out.join(f).exists(), "{name}: {f}");
            }
            let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
            assert!(
                summary.contains(&format!("\"estimator\": \"{name}\"")),
                "{summary}"
            );
            assert!(summary.contains("\"gnss_fed\": 61"), "{summary}");
            let nav = std::fs::read_to_string(out.join("solution.nav")).unwrap();
            assert!(
                nav.lines().count() > 1000,
                "{name}: {} lines",
                nav.lines().count()
            );
        }
        let e = run(Args {
            config: dir.join("run.toml"),
            output: Some(dir.join("x")),
            estimator: Some("kalman-magic".into()),
            report: false,
            truth: None,
        })
        .unwrap_err();
        assert!(e.contains("kalman-magic"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The same 60 s drive north (level, 5 m/s) as KF-GINS text (time of
    /// week) and as a generic CSV IMU in rates (GPS seconds, header, own
    /// column names) with NMEA fixes: the two ESKF runs must agree and the
    /// summary must account for every line of each file. The CSV with UBX
    /// NAV-PVT fixes (which carry velocity) must end on the truth.
    #[test]
    fn csv_imu_with_nmea_or_ubx_gnss_runs_like_kfgins_text() {
        use navfuse_io::nmea::NmeaWriter;
        use std::fmt::Write as _;
        let dir = crate::test_dir("run-csv");
        let week = 2374.0;
        let (lat0, lon0, h) = (40.0f64.to_radians(), -105.0f64.to_radians(), 1600.0);
        let (rm, _) = navfuse_core::earth::radii(lat0);
        let (tow0, v, g, dt) = (243_000.0, 5.0, 9.8, 0.01);
        let (mut imu_txt, mut imu_csv) = (String::new(), String::from("t,wx,wy,wz,fx,fy,fz\n"));
        // Zero-mean vibration, so that the IMU does not look parked; the
        // text file holds the trapezoid increments of the CSV's rates.
        let rates = |k: i32| {
            let t = k as f64 * dt;
            let s = |hz: f64| (std::f64::consts::TAU * hz * t).sin();
            [
                0.02 * s(3.0),
                0.0,
                0.0,
                0.3 * s(5.0),
                0.0,
                -g + 0.5 * s(7.0),
            ]
        };
        for k in 1..=6000 {
            let tow = tow0 + k as f64 * dt;
            let (r0, r1) = (rates(k - 1), rates(k));
            let inc: Vec<String> = (0..6)
                .map(|i| format!("{:.9}", 0.5 * (r0[i] + r1[i]) * dt))
                .collect();
            let _ = writeln!(imu_txt, "{tow:.3} {}", inc.join(" "));
            let r: Vec<String> = r1.iter().map(|x| format!("{x:.9}")).collect();
            let _ = writeln!(imu_csv, "{:.3},{}", week * 604_800.0 + tow, r.join(","));
        }
        let (mut gnss_txt, mut nmea, mut ubx) = (String::new(), Vec::new(), Vec::new());
        {
            let mut w = NmeaWriter::new(&mut nmea);
            for k in 0..=60 {
                let tow = tow0 + k as f64;
                let lat = lat0 + v * (tow - tow0) / (rm + h);
                // The same fix as UBX NAV-PVT (UTC calendar, 1e-7°, mm, mm/s).
                let c = navfuse_io::time::calendar_from_gps(
                    week * 604_800.0 + tow,
                    navfuse_io::time::TimeSystem::Utc,
                    3,
                );
                let pvt = navfuse_io::ubx::NavPvt {
                    itow_ms: (tow * 1e3).round() as u32,
                    year: c.year as u16,
                    month: c.month,
                    day: c.day,
                    hour: c.hour,
                    min: c.minute,
                    sec: c.second.floor() as u8,
                    nano_ns: ((c.second - c.second.floor()) * 1e9).round() as i32,
                    valid: 0x07,
                    fix_type: 3,
                    flags: 0x01,
                    num_sv: 9,
                    lat_e7: (lat.to_degrees() * 1e7).round() as i32,
                    lon_e7: (lon0.to_degrees() * 1e7).round() as i32,
                    height_mm: (h * 1e3) as i32,
                    h_acc_mm: 707,
                    v_acc_mm: 1000,
                    vel_n_mms: (v * 1e3) as i32,
                    s_acc_mms: 200,
                    ..Default::default()
                };
                ubx.extend(navfuse_io::ubx::encode(
                    &navfuse_io::ubx::UbxMessage::NavPvt(pvt),
                ));
                let _ = writeln!(
                    gnss_txt,
                    "{tow:.3} {:.9} {:.9} {h:.3} 0.5 0.5 1.0",
                    lat.to_degrees(),
                    lon0.to_degrees()
                );
                w.write_fix(&GnssFix {
                    t: week * 604_800.0 + tow,
                    lat,
                    lon: lon0,
                    h,
                    std_ned: Vec3::new(0.5, 0.5, 1.0),
                    quality: 1,
                    num_sats: 9,
                    ..Default::default()
                })
                .unwrap();
            }
        }
        std::fs::write(dir.join("imu.txt"), imu_txt).unwrap();
        std::fs::write(dir.join("gnss.txt"), gnss_txt).unwrap();
        std::fs::write(dir.join("imu.csv"), imu_csv).unwrap();
        std::fs::write(dir.join("gnss.nmea"), nmea).unwrap();
        std::fs::write(dir.join("gnss.ubx"), ubx).unwrap();
        std::fs::write(
            dir.join("txt.toml"),
            "[input]\nimu = \"imu.txt\"\ngnss = \"gnss.txt\"\n",
        )
        .unwrap();
        std::fs::write(
            dir.join("csv.toml"),
            "[input]\nimu = \"imu.csv\"\ngnss = \"gnss.nmea\"\n[input.csv]\ntime = \"t\"\n\
             gyro = [\"wx\", \"wy\", \"wz\"]\naccel = [4, 5, 6]\ngyro_unit = \"rad\"\n",
        )
        .unwrap();
        let last = |name: &str| -> (NavSolution, serde_json::Value) {
            let (sols, summary) =
                run_and_read(&dir.join(format!("{name}.toml")), &dir.join(name), 0);
            (*sols.last().unwrap(), summary)
        };
        std::fs::write(
            dir.join("ubx.toml"),
            std::fs::read_to_string(dir.join("csv.toml"))
                .unwrap()
                .replace("gnss.nmea", "gnss.ubx"),
        )
        .unwrap();
        let (a, _) = last("txt");
        let (b, sb) = last("csv");
        // UBX NAV-PVT (with velocity, which the other two files lack).
        let (u, su) = last("ubx");
        assert_eq!(su["inputs"]["gnss"]["format"], "ubx");
        assert_eq!(su["inputs"]["gnss"]["records"], 61);
        let truth_n = v * (u.t - week * 604_800.0 - tow0);
        let dn_u = (u.lat - lat0) * (rm + h) - truth_n;
        assert!(
            dn_u.abs() < 0.5 && ((u.lon - lon0) * rm).abs() < 0.5,
            "UBX end {dn_u} m"
        );
        let inputs = &sb["inputs"];
        assert_eq!(inputs["imu"]["format"], "csv");
        assert_eq!(inputs["gnss"]["format"], "nmea");
        assert_eq!(inputs["imu"]["used"], 6000);
        assert_eq!(inputs["gnss"]["records"], 61);
        assert_eq!(inputs["gnss"]["used"], 3 * 61, "GGA, RMC and GST per fix");
        assert_eq!(inputs["time_base"], "both files carry GPS seconds");
        // Every fix is either fed to the filter or outside its span.
        let fed = sb["gnss_fixes_fed"].as_u64().unwrap();
        let outside = sb["gnss_fixes_outside_filter_span"].as_u64().unwrap();
        assert_eq!(fed + outside, 61, "{sb}");
        assert!(fed > 50, "{sb}");
        // Same end point (NMEA keeps ~0.1 mm of latitude, GPS seconds ~1e-7 s).
        assert!(
            (b.t - week * 604_800.0 - a.t).abs() < 1e-3,
            "{} {}",
            a.t,
            b.t
        );
        let dn = (b.lat - a.lat) * rm;
        let de = (b.lon - a.lon) * rm * lat0.cos();
        eprintln!(
            "end points differ by {:.5} m; GNSS position updates {}",
            dn.hypot(de),
            sb["used_rejected"]["gnss_position"]
        );
        assert!(
            dn.hypot(de) < 0.01,
            "end points differ by {dn:.4} N {de:.4} E m; {}",
            dir.display()
        );
        let truth_n = v * (a.t - tow0);
        assert!(((a.lat - lat0) * (rm + h) - truth_n).abs() < 0.5);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A parked car (yaw 123°, rolled 2°) with a magnetometer in its CSV
    /// and static fixes: the GNSS course can never give a heading, the
    /// tilt-compensated magnetometer mean (with the declination) does, and
    /// so does an AHRS yaw column; the summary says which was used.
    #[test]
    fn static_start_takes_the_heading_from_the_magnetometer_or_ahrs() {
        use navfuse_core::attitude::dcm_from_euler;
        use std::fmt::Write as _;
        let dir = crate::test_dir("run-mag");
        let (yaw, roll, dec) = (
            123.0f64.to_radians(),
            2.0f64.to_radians(),
            8.0f64.to_radians(),
        );
        let c_bn = dcm_from_euler(&Vec3::new(roll, 0.0, yaw));
        // Field in NED: magnetic north is `dec` east of true north.
        let (bh, bz) = (21.0, 45.0);
        let m_n = Vec3::new(bh * dec.cos(), bh * dec.sin(), bz);
        let m_b = c_bn.transpose() * m_n;
        let g = navfuse_core::earth::gravity(40f64.to_radians(), 1600.0);
        let f_b = c_bn.transpose() * Vec3::new(0.0, 0.0, -g);
        let w_b = c_bn.transpose()
            * Vec3::new(
                navfuse_core::earth::OMEGA_IE * 40f64.to_radians().cos(),
                0.0,
                -navfuse_core::earth::OMEGA_IE * 40f64.to_radians().sin(),
            );
        let mut csv = String::from("t,gx,gy,gz,ax,ay,az,mx,my,mz,yaw\n");
        for k in 1..=3000 {
            let t = 2374.0 * 604_800.0 + 1000.0 + k as f64 * 0.01;
            let _ = writeln!(
                csv,
                "{t:.3},{},{},{},{},{},{},{},{},{},{}",
                w_b.x, w_b.y, w_b.z, f_b.x, f_b.y, f_b.z, m_b.x, m_b.y, m_b.z, 123.0
            );
        }
        let mut gnss = String::new();
        for k in 0..=30 {
            let _ = writeln!(
                gnss,
                "{:.3} 40.0 -105.0 1600.0 0.5 0.5 1.0",
                1000.0 + k as f64
            );
        }
        std::fs::write(dir.join("imu.csv"), csv).unwrap();
        std::fs::write(dir.join("gnss.txt"), gnss).unwrap();
        let toml = |heading: &str| {
            format!(
                "[input]\nimu = \"imu.csv\"\ngnss = \"gnss.txt\"\n[input.csv]\ntime = \"t\"\n\
                 gyro = [\"gx\", \"gy\", \"gz\"]\naccel = [\"ax\", \"ay\", \"az\"]\ngyro_unit = \"rad\"\n\
                 mag = [\"mx\", \"my\", \"mz\"]\nahrs_yaw = \"yaw\"\n\
                 [init]\nheading = \"{heading}\"\nmagnetic_declination_deg = 8.0\n"
            )
        };
        for (heading, expect) in [
            ("magnetometer", "magnetometer"),
            ("ahrs", "AHRS"),
            ("auto", "AHRS"),
        ] {
            std::fs::write(dir.join("run.toml"), toml(heading)).unwrap();
            let (sols, summary) = run_and_read(&dir.join("run.toml"), &dir.join(heading), 0);
            let how = summary["alignment"].as_str().unwrap();
            assert!(how.contains(expect), "{heading}: {how}");
            let first = sols.first().unwrap();
            let d = (first.rpy.z - yaw).to_degrees();
            assert!(
                d.abs() < 0.2,
                "{heading}: yaw {} vs 123",
                first.rpy.z.to_degrees()
            );
            assert!(
                (first.rpy.x - roll).abs().to_degrees() < 0.2,
                "{heading}: roll"
            );
        }
        // Without a magnetometer or AHRS a parked start has no heading: said so.
        std::fs::write(dir.join("run.toml"), toml("course")).unwrap();
        let e = run_to(&dir.join("run.toml"), &dir.join("course")).unwrap_err();
        assert!(e.contains("no GNSS course"), "{e}");
        // The IMU noise in KF-GINS units is checked like KF-GINS's YAML.
        let noise = "[filter.imu_noise]\narw = [-1.0, 1.0, 1.0]\nvrw = [1.0, 1.0, 1.0]\n\
                     gbstd = [5.0, 5.0, 5.0]\nabstd = [300.0, 300.0, 300.0]\ngsstd = [0.0, 0.0, 0.0]\n\
                     asstd = [0.0, 0.0, 0.0]\ncorrtime = 1.0\n";
        let both = format!(
            "[filter]\nnoise_yaml = \"kf.yaml\"\n{}",
            noise.replace("-1.0", "1.0")
        );
        for (extra, expect) in [
            (noise.to_string(), "filter.imu_noise.arw"),
            (both, "not both"),
        ] {
            std::fs::write(
                dir.join("run.toml"),
                format!("{}{extra}", toml("magnetometer")),
            )
            .unwrap();
            let e = run_to(&dir.join("run.toml"), &dir.join("noise")).unwrap_err();
            assert!(e.contains(expect), "{e}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The parked VN-310 (INSTINCT data): no motion, so only the
    /// magnetometer can give the heading. Its calibrated `IMU::Mag` columns
    /// start the ESKF at the first sample; the solution stays on the GNSS
    /// mean position and the heading stays where the magnetometer put it.
    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn parked_vn310_starts_from_its_magnetometer() {
        let imu = navfuse_io::data::require("static_vn310/vn310-imu.csv");
        let gnss_csv = navfuse_io::data::require("static_vn310/vn310-gnss.csv");
        let dir = crate::test_dir("run-vn310");
        // The receiver's fixes as KF-GINS GNSS text (TOW, lat, lon, h, σNED).
        let text = std::fs::read_to_string(&gnss_csv).unwrap();
        let mut lines = text.lines();
        let head: Vec<&str> = lines.next().unwrap().split(',').collect();
        let col = |n: &str| head.iter().position(|h| *h == n).unwrap();
        let cols = [
            "GpsTow [s]",
            "GNSS1::PosLla::latitude [deg]",
            "GNSS1::PosLla::longitude [deg]",
            "GNSS1::PosLla::altitude [m]",
            "GNSS1::PosU::N [m]",
            "GNSS1::PosU::E [m]",
            "GNSS1::PosU::D [m]",
        ]
        .map(col);
        let mut gnss = String::new();
        let (mut lat_sum, mut lon_sum, mut n) = (0.0, 0.0, 0.0);
        for l in lines {
            let f: Vec<&str> = l.split(',').collect();
            let row: Vec<&str> = cols.iter().map(|&k| f[k]).collect();
            lat_sum += row[1].parse::<f64>().unwrap();
            lon_sum += row[2].parse::<f64>().unwrap();
            n += 1.0;
            gnss.push_str(&row.join(" "));
            gnss.push('\n');
        }
        std::fs::write(dir.join("gnss.txt"), gnss).unwrap();
        std::fs::write(
            dir.join("run.toml"),
            format!(
                "[input]\nimu = {:?}\nimu_rate = 50.0\ngnss = \"gnss.txt\"\n[input.csv]\npreset = \"vn310\"\n\
                 mag = [\"IMU::Mag::X [Gauss]\", \"IMU::Mag::Y [Gauss]\", \"IMU::Mag::Z [Gauss]\"]\n",
                imu.display().to_string()
            ),
        )
        .unwrap();
        let (sols, summary) = run_and_read(&dir.join("run.toml"), &dir.join("out"), 0);
        let how = summary["alignment"].as_str().unwrap();
        assert!(how.contains("magnetometer"), "{how}");
        assert!(sols.len() > 1500, "{} solutions", sols.len());
        let (lat0, lon0) = ((lat_sum / n).to_radians(), (lon_sum / n).to_radians());
        let (rm, rn) = navfuse_core::earth::radii(lat0);
        let yaw0 = sols[0].rpy.z;
        for s in &sols {
            let d = ((s.lat - lat0) * rm).hypot((s.lon - lon0) * rn * lat0.cos());
            assert!(d < 2.0, "t {}: {d:.2} m from the GNSS mean", s.t);
            let dy = (s.rpy.z - yaw0 + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            assert!(dy.abs() < 1f64.to_radians(), "t {}: yaw moved {dy}", s.t);
        }
        eprintln!(
            "VN-310 parked: magnetometer heading {:.2}°",
            yaw0.to_degrees()
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// drive_0708 from the raw CSV IMU (preset, duplicates rejected, offset
    /// estimated) and the 4 Hz RTKLIB .pos must give what the prepared
    /// KF-GINS `imu.txt` gives with the same .pos: the generic path loses
    /// nothing against the hand-made file.
    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn raw_csv_drive_matches_the_prepared_kfgins_file() {
        let imu_csv = navfuse_io::data::require("drive_0708/imu_1934_gpst.csv");
        let imu_txt = navfuse_io::data::require("drive_0708/kfgins/imu.txt");
        let pos = navfuse_io::data::require("drive_0708/gnss_1934_sf.pos");
        let dir = crate::test_dir("run-raw");
        let q = |p: &Path| format!("{:?}", p.display().to_string());
        std::fs::write(
            dir.join("csv.toml"),
            format!(
                "[input]\nimu = {}\ngnss = {}\nimu_time_offset = \"auto\"\n[input.csv]\npreset = \"drive_0708\"\n\
                 [filter]\nlever_arm = [0.0, -0.05, 0.0]\n",
                q(&imu_csv),
                q(&pos)
            ),
        )
        .unwrap();
        std::fs::write(
            dir.join("txt.toml"),
            format!(
                "[input]\nimu = {}\ngnss = {}\n[filter]\nlever_arm = [0.0, -0.05, 0.0]\n",
                q(&imu_txt),
                q(&pos)
            ),
        )
        .unwrap();
        let (reference, _) = crate::eval::read_trajectory(&pos, 0, false).unwrap();
        let rms = |name: &str| -> (f64, serde_json::Value) {
            let (mut sols, summary) =
                run_and_read(&dir.join(format!("{name}.toml")), &dir.join(name), 2374);
            for s in sols.iter_mut() {
                if s.t < 604_800.0 {
                    s.t += 2374.0 * 604_800.0;
                }
            }
            let cfg = navfuse_eval::EvalConfig {
                lever_arm_b: Some([0.0, -0.05, 0.0]),
                ..Default::default()
            };
            let ev = navfuse_eval::evaluate(&sols, &reference, &cfg, None, None).unwrap();
            (ev.summary.horizontal.unwrap().rms, summary)
        };
        let (rms_txt, _) = rms("txt");
        let (rms_csv, s) = rms("csv");
        eprintln!("horizontal RMS vs the .pos: raw CSV {rms_csv:.4} m, imu.txt {rms_txt:.4} m");
        let tau = s["inputs"]["imu_time_offset_applied_s"].as_f64().unwrap();
        assert!((tau + 0.2).abs() < 0.03, "estimated IMU offset {tau}");
        let imu = &s["inputs"]["imu"];
        assert_eq!(imu["used"], 53_720);
        let rejected: u64 = imu["rejected"]
            .as_object()
            .unwrap()
            .values()
            .map(|v| v.as_u64().unwrap())
            .sum();
        assert_eq!(
            imu["used"].as_u64().unwrap() + imu["skipped"].as_u64().unwrap() + rejected,
            imu["lines_or_messages"].as_u64().unwrap()
        );
        assert!(
            rms_csv < 0.06 && (rms_csv - rms_txt).abs() < 0.005,
            "{rms_csv} vs {rms_txt}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn time_offset_estimate_recovers_a_shift() {
        let cfg = KfGinsConfig::load(&navfuse_io::data::require(
            "drive_0708/kfgins/kf-gins_full.yaml",
        ))
        .unwrap();
        let input = read_kfgins(&cfg).unwrap();
        let (tau0, r0) = estimate_time_offset(&input.imu, &input.gnss, 0.5).unwrap();
        // imu.txt already has its −0.2 s applied: the residual is small.
        assert!(tau0.abs() <= 0.03 && r0 > 0.99, "residual {tau0} r {r0}");
        for shift in [0.15, -0.1] {
            let shifted: Vec<ImuSample> = input
                .imu
                .iter()
                .map(|s| ImuSample {
                    t: s.t + shift,
                    ..*s
                })
                .collect();
            let (tau, _) = estimate_time_offset(&shifted, &input.gnss, 0.5).unwrap();
            assert!(
                (tau - (tau0 - shift)).abs() < 0.011,
                "shift {shift}: estimated {tau}"
            );
        }
    }

    #[test]
    fn run_config_rejects_unknown_keys_with_the_field() {
        let e = toml::from_str::<RunConfig>("[input]\nimu = \"a\"\ngnss = \"b\"\nbogus = 1\n")
            .unwrap_err();
        assert!(e.to_string().contains("bogus"), "{e}");
        let c: RunConfig = toml::from_str("[input]\nimu = \"a\"\ngnss = \"b\"\n").unwrap();
        assert_eq!(c.filter.preset, "enhanced");
        assert_eq!(c.input.imu_rate, 100.0);
    }
}
