//! `navfuse init`: a commented `navfuse run` TOML template for a platform,
//! with the platform profile's values ([`crate::profile`]) and the sensor
//! preset's datasheet numbers ([`crate::sensors`]) read from the code, never
//! copied by hand; and the tables of `docs/config.md` generated the same way
//! ([`profile_table_markdown`], [`sensor_table_markdown`]).

use crate::csv_sniff::CsvGuess;
use crate::error::{PipelineError, Result};
use crate::noise_cfg::{DatasheetNoise, G0};
use crate::profile::{Platform, NHC_ADAPT_MAX, NHC_ADAPT_MIN, PLATFORMS};
use crate::sensors::{imu_noise_preset, DEFAULT_IMU_PRESET};
use navfuse_sim::imu_model::{imu_preset, IMU_PRESETS};
use std::fmt::Write as _;

/// A number for TOML and tables: 6 significant digits, `inf` for ∞.
fn num(x: f64) -> String {
    if x.is_infinite() {
        return if x > 0.0 { "inf".into() } else { "-inf".into() };
    }
    let v: f64 = format!("{x:.5e}").parse().unwrap_or(x);
    format!("{v:?}")
}

/// A key line `key = value` with its comment aligned at column 28.
fn line(o: &mut String, commented: bool, kv: &str, comment: &str) {
    let kv = if commented {
        format!("# {kv}")
    } else {
        kv.to_string()
    };
    if comment.is_empty() {
        let _ = writeln!(o, "{kv}");
    } else {
        let _ = writeln!(o, "{kv:<28} # {comment}");
    }
}

/// The commented `navfuse run` template for `platform`, with the IMU noise
/// of the sensor preset `imu_preset` (default [`DEFAULT_IMU_PRESET`], the
/// conservative consumer MEMS) and, given a CSV IMU log (its path as written
/// into `[input] imu` and [`crate::csv_sniff::sniff_csv`]'s guess), an
/// `[input.csv]` column map. The text parses as a [`crate::RunConfig`].
/// Errors: an unknown or gyro-less sensor preset.
pub fn run_template(
    platform: Platform,
    imu_preset_name: Option<&str>,
    csv: Option<(&str, &CsvGuess)>,
) -> Result<String> {
    let preset = imu_preset_name.unwrap_or(DEFAULT_IMU_PRESET);
    let sensor = imu_noise_preset(preset)?;
    let spec = imu_preset(preset).map_err(|e| PipelineError::Options(e.to_string()))?;
    let p = platform.profile();
    let mut o = String::new();
    let _ = writeln!(
        o,
        "# navfuse run configuration, written by `navfuse init --platform {platform}`.\n\
         # Every key with its unit and default: docs/config.md. Paths are relative to\n\
         # this file. `#`-lines are options at their defaults; EDIT marks what you must set.\n"
    );
    line(
        &mut o,
        true,
        "output = \"navfuse-out\"",
        "output folder (default: ./navfuse-out)",
    );
    line(
        &mut o,
        true,
        "formats = [\"csv\", \"geojson\"]",
        "also csv, geojson, kml, gpx, nmea, parquet, pos besides solution.nav",
    );
    o.push_str("\n[input]\n");
    match csv {
        Some((path, g)) => {
            line(
                &mut o,
                false,
                &format!("imu = {path:?}"),
                "the CSV IMU log (map in [input.csv])",
            );
            line(&mut o, false, "imu_format = \"csv\"", "");
            match g.rate_hz {
                Some(r) => line(
                    &mut o,
                    false,
                    &format!("imu_rate = {}", num(r.round())),
                    &format!("[Hz] from the median time step ({:.6} s) — check", 1.0 / r),
                ),
                None => line(
                    &mut o,
                    false,
                    "imu_rate = 100.0",
                    "[Hz] EDIT: no time step found in the CSV",
                ),
            }
        }
        None => {
            line(
                &mut o,
                false,
                "imu = \"imu.txt\"",
                "EDIT: KF-GINS IMU text (increments, body FRD) or a CSV",
            );
            line(
                &mut o,
                true,
                "imu_format = \"kf-gins\"",
                "\"kf-gins\" | \"csv\" (default: from the extension)",
            );
            line(&mut o, false, "imu_rate = 100.0", "[Hz] nominal IMU rate");
        }
    }
    line(
        &mut o,
        false,
        "gnss = \"gnss.pos\"",
        "EDIT: KF-GINS GNSS text, RTKLIB .pos, NMEA .nmea or UBX .ubx",
    );
    line(
        &mut o,
        true,
        "gnss_format = \"pos\"",
        "\"kf-gins\" | \"pos\" | \"nmea\" | \"ubx\" (default: from the extension)",
    );
    line(
        &mut o,
        true,
        "start = 0.0",
        "[s] first IMU stamp used, IMU time base (default: the first)",
    );
    line(
        &mut o,
        true,
        "imu_time_offset = \"auto\"",
        "[s] added to IMU stamps, \"auto\" (default) or \"none\"",
    );
    line(
        &mut o,
        true,
        "imu_tag = \"imu.tag\"",
        "RTKLIB time-tag file for a counter time column",
    );
    if let Some((_, g)) = csv {
        csv_block(&mut o, g);
    }
    init_block(&mut o, p.course_is_heading, platform);
    let _ = writeln!(o, "\n[filter]");
    line(
        &mut o,
        false,
        "estimator = \"eskf\"",
        "\"eskf\" | \"pf-lc\" | \"gps-acc\"",
    );
    line(
        &mut o,
        false,
        "preset = \"enhanced\"",
        "\"kf-gins\" | \"enhanced\" | \"seed001\"",
    );
    line(
        &mut o,
        false,
        &format!("platform = \"{platform}\""),
        &format!("{}: sets NHC/ZUPT/ZARU below", PLATFORMS.join(" | ")),
    );
    line(
        &mut o,
        false,
        &format!("imu_preset = \"{preset}\""),
        &format!("{}: {}", sensor.sensor, sensor.source),
    );
    let _ = writeln!(
        o,
        "# (presets: {}; default {DEFAULT_IMU_PRESET}, the noisiest MEMS)",
        IMU_PRESETS.join(", ")
    );
    line(
        &mut o,
        true,
        "noise_yaml = \"kf.yaml\"",
        "instead: the IMU noise of a KF-GINS YAML",
    );
    line(
        &mut o,
        false,
        "lever_arm = [0.0, 0.0, 0.0]",
        "[m] EDIT: GNSS antenna from the IMU, body FRD",
    );
    line(
        &mut o,
        false,
        "smooth = false",
        "true: RTS smoother (solution_smoothed.nav)",
    );
    line(
        &mut o,
        true,
        "coupling = \"tight\"",
        "raw pseudoranges/Dopplers: [input] gnss = .ubx (RAWX+SFRBX) or .obs + nav",
    );
    match DatasheetNoise::from_spec(&spec) {
        Some(d) => {
            let _ = writeln!(o, "\n# [filter.imu_noise]          # instead of imu_preset: your sensor's datasheet ({preset} shown)");
            let one = |a: [f64; 3]| num(a[0]);
            for (k, v, c) in [
                (
                    "gyro_noise_dps_rthz",
                    one(d.gyro_noise_dps_rthz),
                    "[°/s/√Hz] (= ARW [°/√h] / 60)",
                ),
                (
                    "accel_noise_ug_rthz",
                    one(d.accel_noise_ug_rthz),
                    "[µg/√Hz]",
                ),
                (
                    "gyro_bias_instability_dph",
                    one(d.gyro_bias_instability_dph),
                    "[°/h] Gauss–Markov σ",
                ),
                (
                    "accel_bias_instability_ug",
                    one(d.accel_bias_instability_ug),
                    "[µg] Gauss–Markov σ",
                ),
                (
                    "bias_corr_time_s",
                    num(d.bias_corr_time_s),
                    "[s] Gauss–Markov correlation time",
                ),
                ("gyro_scale_ppm", one(d.gyro_scale_ppm), "[ppm]"),
                ("accel_scale_ppm", one(d.accel_scale_ppm), "[ppm]"),
                (
                    "gyro_turn_on_bias_dps",
                    one(d.gyro_turn_on_bias_dps.unwrap_or_default()),
                    "[°/s] initial bias σ",
                ),
                (
                    "accel_turn_on_bias_mg",
                    one(d.accel_turn_on_bias_mg.unwrap_or_default()),
                    "[mg] initial bias σ",
                ),
            ] {
                line(&mut o, true, &format!("{k} = {v}"), c);
            }
        }
        None => {
            let _ = writeln!(
                o,
                "\n# [filter.imu_noise]: instead of imu_preset, datasheet keys (docs/config.md)"
            );
        }
    }
    constraint_blocks(&mut o, platform);
    o.push_str(
        "\n# [outage]                   # simulate GNSS outages: `length` s every `period` s\n",
    );
    line(
        &mut o,
        true,
        "start = 120.0",
        "[s] after the first IMU sample used",
    );
    line(&mut o, true, "length = 30.0", "[s]");
    line(&mut o, true, "period = 90.0", "[s]");
    Ok(o)
}

fn csv_block(o: &mut String, g: &CsvGuess) {
    let _ = writeln!(
        o,
        "\n[input.csv]                  # guessed from the header and {} rows: CHECK every line",
        g.rows
    );
    let cols = |c: [usize; 3]| format!("[{}, {}, {}]", g.col(c[0]), g.col(c[1]), g.col(c[2]));
    line(
        o,
        false,
        &format!("time = {}", g.col(g.time.value)),
        &format!("[s] check: {}", g.time.why),
    );
    line(
        o,
        false,
        &format!("gyro = {}", cols(g.gyro.value)),
        &format!("check: {}", g.gyro.why),
    );
    line(
        o,
        false,
        &format!("accel = {}", cols(g.accel.value)),
        &format!("check: {}", g.accel.why),
    );
    line(
        o,
        false,
        &format!("gyro_unit = \"{}\"", g.gyro_unit.value),
        &format!("\"deg\" | \"rad\"; check: {}", g.gyro_unit.why),
    );
    line(
        o,
        false,
        &format!("accel_unit = \"{}\"", g.accel_unit.value),
        &format!("\"g\" | \"m/s2\"; check: {}", g.accel_unit.why),
    );
    line(
        o,
        false,
        &format!("form = \"{}\"", g.form.value),
        &format!(
            "\"rate\" | \"rate-rectangle\" | \"increment\"; {}",
            g.form.why
        ),
    );
    if g.delimiter != ',' {
        line(o, false, &format!("delimiter = {:?}", g.delimiter), "");
    }
    if !g.header {
        line(
            o,
            false,
            "header = false",
            "no column names: columns by index",
        );
    }
    if let Some(m) = g.mag {
        line(
            o,
            true,
            &format!("mag = {}", cols(m)),
            "magnetometer columns found: initial heading from them",
        );
    }
    // Body FRD at rest, level: f_b = [0, 0, −g].
    let mount = match g.f_rest {
        Some(f) if f[2] < -0.7 * G0 => {
            "sensor z down at rest (f_z ≈ −g): as FRD if x points forward".to_string()
        }
        Some(f) if f[2] > 0.7 * G0 => {
            "check: f_z ≈ +g at rest, sensor z UP: [180, 0, 0] if x points forward".to_string()
        }
        Some(f) => format!(
            "check: at rest f = [{}, {}, {}] m/s², not along z: sensor on its side",
            num(f[0]),
            num(f[1]),
            num(f[2])
        ),
        None => "sensor axes w.r.t. body FRD [deg]; the first rows are not still".to_string(),
    };
    line(o, true, "mount_rpy_deg = [0.0, 0.0, 0.0]", &mount);
}

fn init_block(o: &mut String, course_is_heading: bool, platform: Platform) {
    o.push_str("\n[init]                       # all optional: automatic alignment otherwise\n");
    line(
        o,
        true,
        "position = [0.0, 0.0, 0.0]",
        "IMU lat, lon [deg], h [m]",
    );
    line(
        o,
        true,
        "attitude = [0.0, 0.0, 0.0]",
        "roll, pitch, yaw [deg]",
    );
    line(o, true, "heading_deg = 0.0", "[deg] initial yaw only");
    line(
        o,
        true,
        "heading = \"auto\"",
        &format!(
            "\"auto\" | \"ahrs\" | \"magnetometer\" | \"course\" ({platform}: GNSS course {} the heading)",
            if course_is_heading { "is" } else { "is NOT" }
        ),
    );
    line(
        o,
        true,
        "magnetic_declination_deg = 0.0",
        "[deg, east +] for the magnetometer heading",
    );
    line(
        o,
        true,
        "velocity = [0.0, 0.0, 0.0]",
        "[m/s] NED (default: 0 at rest, else GNSS)",
    );
    line(
        o,
        true,
        "position_std_m = 1.0",
        "[m] 1-σ (default: the start fix's σ)",
    );
    line(
        o,
        true,
        "velocity_std_m_s = 0.1",
        "[m/s] 1-σ (default: from the GNSS velocity σ)",
    );
    line(
        o,
        true,
        "attitude_std_deg = [1.0, 1.0, 5.0]",
        "[deg] 1-σ (default: from the alignment)",
    );
}

fn constraint_blocks(o: &mut String, platform: Platform) {
    let p = platform.profile();
    match p.nhc {
        Some(n) => {
            let _ = writeln!(o, "\n# [filter.nhc]                # profile `{platform}` values; uncomment to override");
            line(
                o,
                true,
                "enabled = true",
                "false: no non-holonomic constraint",
            );
            line(
                o,
                true,
                &format!("std = {}", num(n.std)),
                "[m/s] 1-σ lateral/vertical body velocity",
            );
            line(
                o,
                true,
                &format!("min_speed = {}", num(n.min_speed)),
                "[m/s] applied above this speed",
            );
            line(
                o,
                true,
                &format!("interval = {}", num(n.interval)),
                "[s] between updates",
            );
            line(
                o,
                true,
                "adaptive = false",
                "learn σ from the innovations within:",
            );
            line(
                o,
                true,
                &format!("min_std = {}", num(NHC_ADAPT_MIN)),
                "[m/s]",
            );
            line(
                o,
                true,
                &format!("max_std = {}", num(NHC_ADAPT_MAX)),
                "[m/s]",
            );
            line(
                o,
                true,
                "mount_states = false",
                "estimate mounting pitch/yaw and the lever to the rear axle",
            );
        }
        None => {
            let _ = writeln!(o, "\n# [filter.nhc]                # profile `{platform}`: no NHC (the platform slips sideways)");
        }
    }
    match p.zupt {
        Some(z) => {
            let _ = writeln!(o, "\n# [filter.zupt]               # profile `{platform}` values; uncomment to override");
            line(o, true, "enabled = true", "false: no ZUPT/ZARU");
            line(
                o,
                true,
                &format!("vel_std = {}", num(z.vel_std)),
                "[m/s] zero-velocity 1-σ",
            );
            let zaru = z.zaru_std.map_or(0.0, f64::to_degrees);
            line(
                o,
                true,
                &format!("zaru_std_dps = {}", num(zaru)),
                "[°/s] zero-rate 1-σ; 0: no ZARU",
            );
            line(
                o,
                true,
                &format!("max_accel_std = {}", num(z.max_accel_std)),
                "[m/s²] standstill: std |f| below …",
            );
            line(
                o,
                true,
                &format!("max_gyro_std_dps = {}", num(z.max_gyro_std.to_degrees())),
                "[°/s] … gyro std below …",
            );
            line(
                o,
                true,
                &format!("max_speed = {}", num(z.max_speed)),
                "[m/s] … and speed below",
            );
            line(
                o,
                true,
                "adaptive = false",
                "learn the ZUPT/ZARU σ from the innovations",
            );
        }
        None => {
            let _ = writeln!(
                o,
                "\n# [filter.zupt]               # profile `{platform}`: no standstill updates"
            );
        }
    }
}

/// The per-profile table of `docs/config.md`, from [`Platform::profile`].
pub fn profile_table_markdown() -> String {
    let mut o = String::from(
        "| platform | NHC σ [m/s] | NHC min speed [m/s] | NHC interval [s] | ZUPT σ [m/s] | ZARU σ [°/s] | rest: std \\|f\\| < [m/s²] | rest: gyro std < [°/s] | rest: \\|mean f − g\\| < [m/s²] | rest: speed < [m/s] | window [samples] | course = heading | max accel [m/s²] |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let dash = || "—".to_string();
    for name in PLATFORMS {
        let p = name.parse::<Platform>().map(Platform::profile);
        let Ok(p) = p else { continue };
        let (ns, nm, ni) = p.nhc.map_or((dash(), dash(), dash()), |n| {
            (num(n.std), num(n.min_speed), num(n.interval))
        });
        let z = p.zupt.map_or(
            [dash(), dash(), dash(), dash(), dash(), dash(), dash()],
            |z| {
                [
                    num(z.vel_std),
                    z.zaru_std.map_or(dash(), |s| num(s.to_degrees())),
                    num(z.max_accel_std),
                    num(z.max_gyro_std.to_degrees()),
                    num(z.max_accel_dev),
                    num(z.max_speed),
                    z.window.to_string(),
                ]
            },
        );
        let _ = writeln!(
            o,
            "| `{name}` | {ns} | {nm} | {ni} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            z[0],
            z[1],
            z[2],
            z[3],
            z[4],
            z[5],
            z[6],
            if p.course_is_heading { "yes" } else { "no" },
            num(p.max_accel)
        );
    }
    o
}

/// The sensor preset table of `docs/config.md`, in datasheet keys, from
/// navfuse-sim's preset table.
pub fn sensor_table_markdown() -> String {
    let mut o = String::from(
        "| `imu_preset` | sensor | gyro noise [°/s/√Hz] | accel noise [µg/√Hz] | gyro bias instability [°/h] | accel bias instability [µg] | corr. time [s] | gyro / accel scale [ppm] | turn-on bias [°/s] / [mg] | source |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
    );
    for name in IMU_PRESETS {
        let Ok(s) = imu_preset(name) else { continue };
        let a = &s.accel;
        let accel_n = num(a.vrw_m_s_sqrt_h / 60.0 / G0 * 1e6);
        let row = match &s.gyro {
            Some(g) => format!(
                "{} | {accel_n} | {} | {} | {} | {} / {} | {} / {}",
                num(g.arw_deg_sqrt_h / 60.0),
                num(g.bias_instability_deg_h),
                num(a.bias_instability_mg * 1e3),
                if g.bias_tau_s > 0.0 {
                    num(g.bias_tau_s)
                } else {
                    "— (random walk)".into()
                },
                num(g.scale_ppm),
                num(a.scale_ppm),
                num(g.bias_deg_h / 3600.0),
                num(a.bias_mg)
            ),
            None => format!(
                "no gyro (refused by `imu_preset`) | {accel_n} | — | {} | — | — / {} | — / {}",
                num(a.bias_instability_mg * 1e3),
                num(a.scale_ppm),
                num(a.bias_mg)
            ),
        };
        let _ = writeln!(o, "| `{name}` | {} | {row} | {} |", s.name, s.source);
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::RunConfig;
    use crate::csv_sniff::sniff_csv;

    fn docs() -> String {
        let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/config.md");
        std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
    }

    #[test]
    fn every_platform_template_parses_and_shows_its_profile() {
        for name in PLATFORMS {
            let platform: Platform = name.parse().unwrap();
            let t = run_template(platform, None, None).unwrap();
            let cfg: RunConfig = toml::from_str(&t).unwrap_or_else(|e| panic!("{name}: {e}\n{t}"));
            assert_eq!(cfg.filter.platform, Some(platform));
            assert_eq!(cfg.filter.imu_preset.as_deref(), Some(DEFAULT_IMU_PRESET));
            // Uncommenting every `# key = …` and `# [table]` line gives the
            // profile's own values.
            let un: String = t
                .lines()
                .map(|l| match l.strip_prefix("# ") {
                    Some(r)
                        if r.starts_with('[')
                            || r.split('#').next().unwrap_or("").contains(" = ") =>
                    {
                        r
                    }
                    _ => l,
                })
                .collect::<Vec<_>>()
                .join("\n");
            let p = platform.profile();
            let full: RunConfig = toml::from_str(&un).unwrap_or_else(|e| {
                panic!("{name}: the template with every `# key` line uncommented: {e}\n{un}")
            });
            if let Some(n) = p.nhc {
                let c = full.filter.nhc.as_ref().unwrap();
                assert_eq!(
                    (c.std, c.min_speed),
                    (Some(n.std), Some(n.min_speed)),
                    "{name}"
                );
            }
            if let Some(z) = p.zupt {
                let c = full.filter.zupt.as_ref().unwrap();
                assert_eq!(
                    (c.vel_std, c.max_speed),
                    (Some(z.vel_std), Some(z.max_speed)),
                    "{name}"
                );
                assert_eq!(c.max_accel_std, Some(z.max_accel_std), "{name}");
            }
            assert!(
                full.filter.imu_noise.is_some() && full.outage.is_some(),
                "{name}"
            );
            assert_eq!(p.nhc.is_some(), t.contains("\n# std = "), "{name}");
        }
        let t = run_template(Platform::Car, Some("adis16465"), None).unwrap();
        assert!(
            t.contains("imu_preset = \"adis16465\"") && t.contains("gyro_noise_dps_rthz = 0.0025"),
            "{t}"
        );
        let e = run_template(Platform::Car, Some("mma7260q"), None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("no gyro"), "{e}");
    }

    #[test]
    fn a_csv_log_gets_a_column_map_the_run_accepts() {
        let d = crate::test_dir("template");
        let p = d.join("log.csv");
        let mut s = String::from("time,ax,ay,az,gx,gy,gz,mx,my,mz\n");
        for k in 0..200 {
            let n = if k % 2 == 0 { 0.003 } else { -0.003 };
            s += &format!(
                "{},{n},0.01,-9.80,0.001,{n},0.0,20,1,40\n",
                5.0 + k as f64 * 0.005
            );
        }
        std::fs::write(&p, s).unwrap();
        let g = sniff_csv(&p).unwrap();
        let t = run_template(Platform::Robot, None, Some(("log.csv", &g))).unwrap();
        let cfg: RunConfig = toml::from_str(&t).unwrap_or_else(|e| panic!("{e}\n{t}"));
        assert_eq!(cfg.input.imu, "log.csv");
        assert_eq!(cfg.input.imu_rate, 200.0);
        let c = cfg.input.csv.as_ref().unwrap();
        assert_eq!(c.accel_unit.as_deref(), Some("m/s2"));
        let csv = crate::csv_map::csv_config(c, cfg.input.imu_rate).unwrap();
        assert_eq!(csv.accel[2], navfuse_io::csv_imu::Col::Name("az".into()));
        assert_eq!(csv.gyro[0], navfuse_io::csv_imu::Col::Name("gx".into()));
        assert!(t.contains("# mag = [\"mx\", \"my\", \"mz\"]"), "{t}");
        assert!(t.contains("sensor z down"), "{t}");
        // The whole log reads through the proposed map.
        let r = navfuse_io::csv_imu::CsvImuReader::new(
            std::io::BufReader::new(std::fs::File::open(&p).unwrap()),
            "log.csv",
            csv,
        );
        assert_eq!(r.filter(Result::is_ok).count(), 200, "one sample per row");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn docs_config_md_has_the_generated_tables_and_every_template_key() {
        let doc = docs();
        assert!(
            doc.contains(&profile_table_markdown()),
            "docs/config.md: the profile table differs from profile.rs; paste:\n{}",
            profile_table_markdown()
        );
        assert!(
            doc.contains(&sensor_table_markdown()),
            "docs/config.md: the sensor table differs from the presets; paste:\n{}",
            sensor_table_markdown()
        );
        let t = run_template(Platform::Car, None, None).unwrap();
        for l in t.lines() {
            let l = l.trim_start_matches("# ");
            if let Some((k, _)) = l.split_once(" = ") {
                let k = k.trim();
                assert!(
                    doc.contains(&format!("`{k}`")),
                    "docs/config.md lacks the key `{k}`"
                );
            }
        }
    }
}
