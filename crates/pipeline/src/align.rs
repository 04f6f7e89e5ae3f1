//! Initial state of the ESKF run (`navfuse run`'s alignment policy): static
//! calibration over the detected static window (`SEEDS.md §1` eq. 1–2) for
//! roll, pitch and the gyro bias; the heading given, from an AHRS yaw or
//! magnetometer column averaged over that window, or from the GNSS course
//! once moving (a MEMS gyro cannot find north). Frames: body FRD, nav NED.

use crate::config::RunConfig;
use crate::error::{PipelineError, Result};
use crate::input::AuxSeries;
use navfuse_core::estimators::eskf::{ImuErrors, InitStd};
use navfuse_core::ins::align;
use navfuse_core::ins::mech::{q_bn_from_rpy, NavState};
use navfuse_core::types::{GnssFix, ImuSample};
use navfuse_core::Vec3;

/// Where and how the ESKF starts.
#[derive(Clone, Debug)]
pub struct Alignment {
    /// Index in the IMU slice of the first sample the filter is fed.
    pub k_start: usize,
    /// Initial navigation state (IMU position, `v_n` NED, `q_bn`).
    pub nav: NavState,
    /// Initial IMU errors (gyro bias from the static window).
    pub errors: ImuErrors,
    /// Initial state standard deviations.
    pub init_std: InitStd,
    /// What was done (the summary's `alignment`).
    pub description: String,
}

/// The initial state for `imu` (already cut at `[input] start`) and the GNSS
/// fixes `gnss` (time-ordered, on the IMU's time base), following `cfg.init`.
pub fn align(
    cfg: &RunConfig,
    imu: &[ImuSample],
    gnss: &[GnssFix],
    aux: Option<&AuxSeries>,
) -> Result<Alignment> {
    // Alignment: static calibration over the detected static window
    // (`SEEDS.md §1` eq. 1–2), heading given or from the GNSS course.
    let first = gnss
        .first()
        .ok_or_else(|| PipelineError::Alignment("no GNSS fixes".into()))?;
    let n_static = align::initial_static_len(imu, 50, 0.15, 3.0f64.to_radians());
    let cal = align::static_calibration(&imu[..n_static.max(2)], first.lat, first.h)
        .ok_or_else(|| PipelineError::Alignment("static calibration failed".into()))?;
    // Heading: given, AHRS or magnetometer average over the static window,
    // or the GNSS course once moving (a MEMS gyro cannot find north).
    let source = cfg.init.heading.as_deref().unwrap_or("auto");
    let (t_s0, t_s1) = (imu[0].t - imu[0].dt, imu[n_static.max(2) - 1].t);
    let ahrs = || aux.and_then(|a| a.mean_yaw(t_s0, t_s1));
    let mag = || {
        let m = aux?.mean_mag(t_s0, t_s1)?;
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
            ahrs().ok_or_else(|| PipelineError::Alignment("[init] heading = \"ahrs\": give [input.csv] ahrs_yaw (a column with samples in the static window)".into()))?,
            "AHRS yaw averaged over the static window".to_string(),
        )),
        ("magnetometer", _) => Some((
            mag().ok_or_else(|| PipelineError::Alignment("[init] heading = \"magnetometer\": give [input.csv] mag columns (samples in the static window, a horizontal field)".into()))?,
            format!("magnetometer averaged over the static window, tilt-compensated, {dec_note}"),
        )),
        ("course", _) => None,
        (h, _) => {
            return Err(cfg.err(format!(
                "[init] heading {h:?}: expected auto, ahrs, magnetometer or course"
            )))
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
            let (t, y) = found.ok_or_else(|| {
                PipelineError::Alignment(
                    "heading: no GNSS course ≥ 3 m/s found (give [init] attitude)".into(),
                )
            })?;
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
    let description;
    if k_start == 0 {
        let p = cfg
            .init
            .position
            .map(|p| (p[0].to_radians(), p[1].to_radians(), p[2]));
        let (lat, lon, h) = p.unwrap_or((first.lat, first.lon, first.h));
        nav.lat = lat;
        nav.lon = lon;
        nav.h = h;
        description = format!(
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
        description = format!(
            "static window {n_static} samples: roll {:.2}°, pitch {:.2}°, gyro bias from it; {how}",
            roll.to_degrees(),
            pitch.to_degrees()
        );
    }
    let init_std = InitStd {
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
    Ok(Alignment {
        k_start,
        nav,
        errors,
        init_std,
        description,
    })
}
