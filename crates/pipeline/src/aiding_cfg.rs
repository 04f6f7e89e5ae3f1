//! `[filter.odometer]`, `[filter.heading]`, `[filter.mag]`: the ESKF's
//! aiding sensors of issue 17 (models in `navfuse_core::measurements`,
//! docs/aiding.md) resolved against what the inputs carry. A model is on by
//! default when the inputs carry its events (odometer: UBX wheel ticks /
//! speed; heading: UBX NAV-RELPOSNED or `heading_source = "cp-att"`) and
//! off with `enabled = false`; the magnetometer only with `enabled = true`.

use crate::config::RunConfig;
use crate::error::Result;
use navfuse_core::estimators::eskf::{AidingConfig, AidingStats, NhcConfig};
use navfuse_core::measurements::heading::HeadingConfig;
use navfuse_core::measurements::magnetometer::MagConfig;
use navfuse_core::measurements::odometer::OdometerConfig;
use navfuse_core::types::{Event, HeadingFix};
use navfuse_core::Vec3;
use serde::{Deserialize, Serialize};

/// 1-σ of one wheel-speed sample when the source gives none [m/s]: one
/// tick of a ~2 cm/tick ABS encoder over a 0.1 s sample is 0.2 m/s, uniform
/// quantisation σ = 0.2/√12 ≈ 0.06 m/s, plus tyre deflection and suspension
/// motion at the wheel (a few cm/s): 0.1 m/s.
const ODO_STD_MPS: f64 = 0.1;
/// Initial 1-σ of the odometer scale error: tyre pressure and wear change
/// the rolling radius by ~1 %, and the nominal distance per tick differs
/// from the effective rolling radius by another ~1 %: 2 %.
const ODO_SCALE_STD: f64 = 0.02;
/// Random-walk PSD of the scale [1/s]: tyre warm-up changes the radius by a
/// few 0.1 % within the first half hour; √(1e-9 · 3600 s) = 0.19 % per hour.
const ODO_SCALE_RW_PSD: f64 = 1e-9;
/// Largest |sample − filter time| [s]: events are fed before the IMU sample
/// that follows them, so they lie within one IMU interval (≤ 10 ms at
/// 100 Hz); 20 ms allows two (the same tolerance as the heading's).
const ODO_MAX_AGE_S: f64 = navfuse_core::estimators::eskf::MAX_LAG_S;
/// Heading σ floor [deg]: receivers' formal σ ignores multipath; a few mm
/// of carrier multipath on a 1.5 m baseline is σ_ψ = σ_φ·√2/L ≈ 3 mm·1.41/1.5 m
/// ≈ 0.16°: 0.2°.
const HEADING_FLOOR_DEG: f64 = 0.2;
/// Magnetometer white noise [T]: MEMS magnetometers (BMM150, LIS3MDL,
/// IIS2MDC datasheets) show 0.3–0.5 µT rms at 10–100 Hz output rates.
const MAG_STD_T: f64 = 0.5e-6;
/// Hard/soft-iron calibration residual: a field calibration leaves 1–3 % of
/// the field (Gebre-Egziabher et al. 2006): 2 %.
const MAG_CALIB_RESIDUAL: f64 = 0.02;
/// Minimum time between magnetometer updates [s] (MagConfig's rationale).
const MAG_INTERVAL_S: f64 = 0.1;

/// `[filter.odometer]` (all keys optional).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OdometerCfg {
    /// Default: on when the inputs carry odometer events.
    pub enabled: Option<bool>,
    /// Wheel (vehicle) reference point from the IMU, body FRD [m].
    pub lever_arm_m: Option<[f64; 3]>,
    /// 1-σ of a speed sample when the source gives none [m/s].
    pub sigma_mps: Option<f64>,
    /// Initial 1-σ of the scale factor (0.01 = 1 %).
    pub scale_sigma: Option<f64>,
}

/// `[filter.heading]` (all keys optional).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct HeadingCfg {
    /// Default: on when the inputs carry heading events.
    pub enabled: Option<bool>,
    /// Baseline azimuth in the body frame, from +x towards +y [deg].
    pub yaw_offset_deg: Option<f64>,
    /// Baseline elevation above the body x–y plane, up positive [deg].
    pub pitch_offset_deg: Option<f64>,
    /// Floor of the heading/pitch 1-σ [deg].
    pub sigma_floor_deg: Option<f64>,
    /// Use the baseline pitch when the fix carries one (default true).
    pub use_pitch: Option<bool>,
}

/// `[filter.mag]`: magnetometer heading (off unless `enabled = true`).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MagCfg {
    pub enabled: Option<bool>,
    /// Per-axis white noise 1-σ [µT].
    pub sigma_ut: Option<f64>,
    /// Date of the run for the WMM [decimal year] (required when enabled).
    pub decimal_year: Option<f64>,
    /// Hard/soft-iron calibration residual (0.02 = 2 %).
    pub calib_residual: Option<f64>,
}

/// The inputs' odometer/heading events (`ubx`, time-ordered) merged in time
/// order with the `heading_source` fixes.
pub(crate) fn merge_aids(ubx: &[Event], heads: Vec<HeadingFix>) -> Vec<Event> {
    let mut v: Vec<Event> = ubx.to_vec();
    v.extend(heads.into_iter().map(Event::Heading));
    v.sort_by(|a, b| a.t().total_cmp(&b.t()));
    v
}

/// The [`AidingConfig`] of `cfg` for the events `aids`; `nhc`: the filter's
/// NHC (its σ is used for the odometer's NHC rows at the wheel).
pub(crate) fn resolve(
    cfg: &RunConfig,
    aids: &[Event],
    nhc: Option<NhcConfig>,
) -> Result<AidingConfig> {
    let has = |p: fn(&Event) -> bool| aids.iter().any(p);
    resolve_for(
        cfg,
        has(|e| matches!(e, Event::Odometer(_))),
        has(|e| matches!(e, Event::Heading(_))),
        nhc,
    )
}

/// The [`AidingConfig`] of `cfg` for inputs that carry odometer events
/// (`has_odometer`) and heading events (`has_heading`): the defaults of
/// [`resolve`] without the events at hand (a live source).
pub(crate) fn resolve_for(
    cfg: &RunConfig,
    has_odometer: bool,
    has_heading: bool,
    nhc: Option<NhcConfig>,
) -> Result<AidingConfig> {
    let f = &cfg.filter;
    let pos = |x: f64, key: &str| -> Result<f64> {
        if x.is_finite() && x > 0.0 {
            Ok(x)
        } else {
            Err(cfg.err(format!("[filter] {key} = {x}: must be finite and > 0")))
        }
    };
    let o = f.odometer.clone().unwrap_or_default();
    let odometer = if o.enabled.unwrap_or(has_odometer) {
        let l = o.lever_arm_m.unwrap_or([0.0; 3]);
        if !l.iter().all(|x| x.is_finite()) {
            return Err(cfg.err("[filter.odometer] lever_arm_m must be finite"));
        }
        Some(OdometerConfig {
            lever_arm_b: Vec3::from(l),
            std_mps: pos(o.sigma_mps.unwrap_or(ODO_STD_MPS), "odometer.sigma_mps")?,
            scale_std: pos(
                o.scale_sigma.unwrap_or(ODO_SCALE_STD),
                "odometer.scale_sigma",
            )?,
            scale_rw_psd: ODO_SCALE_RW_PSD,
            nhc_std: nhc.map(|n| n.std),
            max_age_s: ODO_MAX_AGE_S,
        })
    } else {
        None
    };
    let h = f.heading.clone().unwrap_or_default();
    let cp_att = f.heading_source == Some(crate::cp_att_run::HeadingSourceCfg::CpAtt);
    let heading = if h.enabled.unwrap_or(has_heading) {
        let (yaw, pitch) = (
            h.yaw_offset_deg.unwrap_or(0.0),
            h.pitch_offset_deg.unwrap_or(0.0),
        );
        if cp_att && (yaw != 0.0 || pitch != 0.0) {
            return Err(cfg.err(
                "[filter.heading] yaw/pitch_offset_deg must stay 0 with heading_source = \
                 \"cp-att\" (its heading is already the body x axis)",
            ));
        }
        let c = HeadingConfig {
            mount_yaw_rad: yaw.to_radians(),
            mount_pitch_rad: pitch.to_radians(),
            std_floor_rad: h.sigma_floor_deg.unwrap_or(HEADING_FLOOR_DEG).to_radians(),
            use_pitch: h.use_pitch.unwrap_or(true),
        };
        if !c.is_valid() {
            return Err(cfg.err("[filter.heading] offsets must be finite, sigma_floor_deg ≥ 0"));
        }
        Some(c)
    } else {
        None
    };
    let m = f.mag.clone().unwrap_or_default();
    let mag = if m.enabled == Some(true) {
        let Some(year) = m.decimal_year else {
            return Err(cfg.err("[filter.mag] decimal_year is required (the WMM date)"));
        };
        let c = MagConfig {
            std_t: pos(m.sigma_ut.map_or(MAG_STD_T, |s| s * 1e-6), "mag.sigma_ut")?,
            decimal_year: year,
            calib_residual: m.calib_residual.unwrap_or(MAG_CALIB_RESIDUAL),
            interval_s: MAG_INTERVAL_S,
        };
        if !c.is_valid() {
            return Err(cfg.err("[filter.mag] decimal_year finite, calib_residual ≥ 0"));
        }
        Some(c)
    } else {
        None
    };
    Ok(AidingConfig {
        odometer,
        heading,
        mag,
    })
}

/// The resolved aiding configuration (SI units) for `summary.json`.
pub(crate) fn config_json(a: &AidingConfig) -> serde_json::Value {
    let l = |v: &Vec3| [v.x, v.y, v.z];
    serde_json::json!({
        "odometer": a.odometer.map(|o| serde_json::json!({
            "lever_arm_b_m": l(&o.lever_arm_b), "std_m_s": o.std_mps, "scale_std": o.scale_std,
            "scale_rw_psd_per_s": o.scale_rw_psd, "nhc_std_m_s": o.nhc_std, "max_age_s": o.max_age_s,
        })),
        "heading": a.heading.map(|h| serde_json::json!({
            "mount_yaw_rad": h.mount_yaw_rad, "mount_pitch_rad": h.mount_pitch_rad,
            "std_floor_rad": h.std_floor_rad, "use_pitch": h.use_pitch,
        })),
        "mag": a.mag.map(|m| serde_json::json!({
            "std_t": m.std_t, "decimal_year": m.decimal_year,
            "calib_residual": m.calib_residual, "interval_s": m.interval_s,
        })),
    })
}

/// The aiding counters (used / gated / bad per sensor) for `summary.json`.
pub(crate) fn stats_json(s: &AidingStats) -> serde_json::Value {
    serde_json::json!({
        "odometer": {"used": s.odometer_used, "rejected_gate": s.odometer_rejected_gate,
            "rejected_bad": s.odometer_rejected_bad},
        "heading": {"used": s.heading_used, "rejected_gate": s.heading_rejected_gate,
            "rejected_bad": s.heading_rejected_bad},
        "mag": {"used": s.mag_used, "rejected_gate": s.mag_rejected_gate,
            "disturbed": s.mag_disturbed, "rejected_bad": s.mag_rejected_bad},
    })
}

/// Add the counters of `b` to `a` (a live session's filters).
pub(crate) fn add_stats(a: &mut AidingStats, b: &AidingStats) {
    a.odometer_used += b.odometer_used;
    a.odometer_rejected_gate += b.odometer_rejected_gate;
    a.odometer_rejected_bad += b.odometer_rejected_bad;
    a.heading_used += b.heading_used;
    a.heading_rejected_gate += b.heading_rejected_gate;
    a.heading_rejected_bad += b.heading_rejected_bad;
    a.mag_used += b.mag_used;
    a.mag_rejected_gate += b.mag_rejected_gate;
    a.mag_disturbed += b.mag_disturbed;
    a.mag_rejected_bad += b.mag_rejected_bad;
}
