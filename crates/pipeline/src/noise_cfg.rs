//! `[filter.imu_noise]`: the IMU noise of a run, written either in KF-GINS's
//! keys and units or in the units of a sensor datasheet — one form per table,
//! never a mix (a mixed table is rejected when the TOML is read, naming the
//! keys).
//!
//! KF-GINS form ([`KfGinsNoise`], per axis x, y, z): `arw` [°/√h], `vrw`
//! [m/s/√h], `gbstd` [°/h], `abstd` [mGal], `gsstd`, `asstd` [ppm],
//! `corrtime` [h].
//!
//! Datasheet form ([`DatasheetNoise`]; each value one number for all axes or
//! `[x, y, z]`):
//!
//! | key | unit | SI in the filter |
//! |---|---|---|
//! | `gyro_noise_dps_rthz` | °/s/√Hz | ARW [rad/√s] = value · π/180 (1 °/s/√Hz = 1 °/√s = 60 °/√h) |
//! | `accel_noise_ug_rthz` | µg/√Hz | VRW [m/s/√s] = value · 9.80665e-6 (1 µg/√Hz = 9.80665e-6 m/s²/√Hz = m/s/√s) |
//! | `gyro_bias_instability_dph` | °/h | Gauss–Markov σ [rad/s] = value · π/180/3600 |
//! | `accel_bias_instability_ug` | µg | Gauss–Markov σ [m/s²] = value · 9.80665e-6 |
//! | `bias_corr_time_s` | s | Gauss–Markov correlation time (gyro and accel) |
//! | `gyro_scale_ppm`, `accel_scale_ppm` | ppm | scale-factor σ = value · 1e-6 (optional, default 0: no scale error) |
//! | `gyro_turn_on_bias_dps`, `accel_turn_on_bias_mg` | °/s, mg | initial bias σ only (optional) |
//!
//! Bias instability: a datasheet's B is, per IEEE Std 952 Annex C, the
//! flat floor of the Allan deviation divided by √(2 ln 2/π) ≈ 0.664. navfuse
//! uses B itself, with no further factor, as the steady-state σ of the
//! first-order Gauss–Markov bias — the same reading as navfuse-sim's sensor
//! table ([`crate::sensors`]), so a simulated sensor and a filter naming it
//! agree. A Gauss–Markov process of σ and correlation time T has its Allan
//! peak 0.617 σ at τ ≈ 1.89 T ([`gm_allan_deviation`]), within 7 % of the
//! floor 0.664 B it stands in for.
//!
//! The noise densities are the one-sided √PSD of the rate (gyro) or specific
//! force (accel) white noise as datasheets quote them (Groves 2nd ed.
//! §4.4.3); the per-sample increment σ is density · √dt.

use crate::sensors::SensorNoise;
use navfuse_core::estimators::eskf::ImuNoise;
use navfuse_core::Vec3;
use navfuse_io::kfgins_yaml::KfGinsNoise;
use navfuse_sim::imu_model::ImuSpec;
use serde::{Deserialize, Serialize};

const D2R: f64 = core::f64::consts::PI / 180.0;
/// Standard gravity [m/s²] (the g of "µg"; ISO 80000-3).
pub const G0: f64 = 9.806_65;

/// One number for all three axes, or one per axis.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(untagged)]
pub enum Axes {
    All(f64),
    Xyz([f64; 3]),
}

impl Axes {
    /// The value of each axis x, y, z.
    pub fn xyz(self) -> [f64; 3] {
        match self {
            Axes::All(v) => [v; 3],
            Axes::Xyz(a) => a,
        }
    }
}

/// The datasheet form of `[filter.imu_noise]` (units in the key names; see
/// the module table). Per axis x, y, z of the body (FRD) frame.
#[derive(Clone, Debug, PartialEq)]
pub struct DatasheetNoise {
    /// Gyro rate noise density [°/s/√Hz].
    pub gyro_noise_dps_rthz: [f64; 3],
    /// Accelerometer noise density [µg/√Hz].
    pub accel_noise_ug_rthz: [f64; 3],
    /// Gyro bias instability [°/h] (Gauss–Markov σ).
    pub gyro_bias_instability_dph: [f64; 3],
    /// Accelerometer bias instability [µg] (Gauss–Markov σ).
    pub accel_bias_instability_ug: [f64; 3],
    /// Gauss–Markov correlation time of both biases [s].
    pub bias_corr_time_s: f64,
    /// Scale-factor σ [ppm] (0 when not given).
    pub gyro_scale_ppm: [f64; 3],
    pub accel_scale_ppm: [f64; 3],
    /// Turn-on (run-to-run) bias σ [°/s] and [mg], for the initial σ only.
    pub gyro_turn_on_bias_dps: Option<[f64; 3]>,
    pub accel_turn_on_bias_mg: Option<[f64; 3]>,
}

/// `[filter.imu_noise]`, sorted into its form when the TOML is read.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(try_from = "ImuNoiseKeys", into = "ImuNoiseKeys")]
pub enum ImuNoiseCfg {
    /// KF-GINS keys and units.
    KfGins(KfGinsNoise),
    /// Datasheet keys and units.
    Datasheet(DatasheetNoise),
}

/// `[filter.imu_noise]` as written: every key of both forms, all optional.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ImuNoiseKeys {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub arw: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vrw: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gbstd: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub abstd: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gsstd: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub asstd: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub corrtime: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gyro_noise_dps_rthz: Option<Axes>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accel_noise_ug_rthz: Option<Axes>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gyro_bias_instability_dph: Option<Axes>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accel_bias_instability_ug: Option<Axes>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bias_corr_time_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gyro_scale_ppm: Option<Axes>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accel_scale_ppm: Option<Axes>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gyro_turn_on_bias_dps: Option<Axes>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accel_turn_on_bias_mg: Option<Axes>,
}

/// Keys of the KF-GINS form, all required.
pub const KFGINS_KEYS: &[&str] = &["arw", "vrw", "gbstd", "abstd", "gsstd", "asstd", "corrtime"];
/// Required keys of the datasheet form.
pub const DATASHEET_KEYS: &[&str] = &[
    "gyro_noise_dps_rthz",
    "accel_noise_ug_rthz",
    "gyro_bias_instability_dph",
    "accel_bias_instability_ug",
    "bias_corr_time_s",
];
/// Optional keys of the datasheet form.
pub const DATASHEET_OPTIONAL_KEYS: &[&str] = &[
    "gyro_scale_ppm",
    "accel_scale_ppm",
    "gyro_turn_on_bias_dps",
    "accel_turn_on_bias_mg",
];

/// (key, given) pairs of one form.
type Present = Vec<(&'static str, bool)>;

impl ImuNoiseKeys {
    /// (key, present) of the KF-GINS form, then of the datasheet form.
    fn present(&self) -> (Present, Present) {
        let k = vec![
            ("arw", self.arw.is_some()),
            ("vrw", self.vrw.is_some()),
            ("gbstd", self.gbstd.is_some()),
            ("abstd", self.abstd.is_some()),
            ("gsstd", self.gsstd.is_some()),
            ("asstd", self.asstd.is_some()),
            ("corrtime", self.corrtime.is_some()),
        ];
        let d = vec![
            ("gyro_noise_dps_rthz", self.gyro_noise_dps_rthz.is_some()),
            ("accel_noise_ug_rthz", self.accel_noise_ug_rthz.is_some()),
            (
                "gyro_bias_instability_dph",
                self.gyro_bias_instability_dph.is_some(),
            ),
            (
                "accel_bias_instability_ug",
                self.accel_bias_instability_ug.is_some(),
            ),
            ("bias_corr_time_s", self.bias_corr_time_s.is_some()),
            ("gyro_scale_ppm", self.gyro_scale_ppm.is_some()),
            ("accel_scale_ppm", self.accel_scale_ppm.is_some()),
            (
                "gyro_turn_on_bias_dps",
                self.gyro_turn_on_bias_dps.is_some(),
            ),
            (
                "accel_turn_on_bias_mg",
                self.accel_turn_on_bias_mg.is_some(),
            ),
        ];
        (k, d)
    }
}

fn names(keys: &[(&'static str, bool)], present: bool) -> Vec<&'static str> {
    keys.iter()
        .filter(|(_, p)| *p == present)
        .map(|(k, _)| *k)
        .collect()
}

impl TryFrom<ImuNoiseKeys> for ImuNoiseCfg {
    type Error = String;

    /// The form of the keys given: all seven KF-GINS keys, or the five
    /// required datasheet keys (plus optional ones); errors name the
    /// missing or mixed keys.
    fn try_from(k: ImuNoiseKeys) -> Result<Self, String> {
        let (kf, ds) = k.present();
        let (kf_given, ds_given) = (names(&kf, true), names(&ds, true));
        let missing = |form: &str, keys: Vec<&str>| {
            format!(
                "[filter.imu_noise] {form} form: missing `{}`",
                keys.join("`, `")
            )
        };
        match (kf_given.is_empty(), ds_given.is_empty()) {
            (false, false) => Err(format!(
                "[filter.imu_noise]: KF-GINS keys (`{}`) and datasheet keys (`{}`) mixed; \
                 write one form",
                kf_given.join("`, `"),
                ds_given.join("`, `")
            )),
            (true, true) => Err(format!(
                "[filter.imu_noise] is empty: give the KF-GINS keys `{}` or the datasheet keys `{}`",
                KFGINS_KEYS.join("`, `"),
                DATASHEET_KEYS.join("`, `")
            )),
            (false, true) => match (k.arw, k.vrw, k.gbstd, k.abstd, k.gsstd, k.asstd, k.corrtime) {
                (Some(arw), Some(vrw), Some(gbstd), Some(abstd), Some(gsstd), Some(asstd), Some(c)) => {
                    Ok(ImuNoiseCfg::KfGins(KfGinsNoise {
                        arw,
                        vrw,
                        gbstd,
                        abstd,
                        gsstd,
                        asstd,
                        corrtime: c,
                    }))
                }
                _ => Err(missing("KF-GINS", names(&kf, false))),
            },
            (true, false) => match (
                k.gyro_noise_dps_rthz,
                k.accel_noise_ug_rthz,
                k.gyro_bias_instability_dph,
                k.accel_bias_instability_ug,
                k.bias_corr_time_s,
            ) {
                (Some(gn), Some(an), Some(gb), Some(ab), Some(tc)) => {
                    let zero = Axes::All(0.0);
                    Ok(ImuNoiseCfg::Datasheet(DatasheetNoise {
                        gyro_noise_dps_rthz: gn.xyz(),
                        accel_noise_ug_rthz: an.xyz(),
                        gyro_bias_instability_dph: gb.xyz(),
                        accel_bias_instability_ug: ab.xyz(),
                        bias_corr_time_s: tc,
                        gyro_scale_ppm: k.gyro_scale_ppm.unwrap_or(zero).xyz(),
                        accel_scale_ppm: k.accel_scale_ppm.unwrap_or(zero).xyz(),
                        gyro_turn_on_bias_dps: k.gyro_turn_on_bias_dps.map(Axes::xyz),
                        accel_turn_on_bias_mg: k.accel_turn_on_bias_mg.map(Axes::xyz),
                    }))
                }
                _ => Err(missing(
                    "datasheet",
                    names(&ds[..DATASHEET_KEYS.len()], false),
                )),
            },
        }
    }
}

impl From<ImuNoiseCfg> for ImuNoiseKeys {
    fn from(c: ImuNoiseCfg) -> Self {
        match c {
            ImuNoiseCfg::KfGins(n) => ImuNoiseKeys {
                arw: Some(n.arw),
                vrw: Some(n.vrw),
                gbstd: Some(n.gbstd),
                abstd: Some(n.abstd),
                gsstd: Some(n.gsstd),
                asstd: Some(n.asstd),
                corrtime: Some(n.corrtime),
                ..Default::default()
            },
            ImuNoiseCfg::Datasheet(d) => ImuNoiseKeys {
                gyro_noise_dps_rthz: Some(Axes::Xyz(d.gyro_noise_dps_rthz)),
                accel_noise_ug_rthz: Some(Axes::Xyz(d.accel_noise_ug_rthz)),
                gyro_bias_instability_dph: Some(Axes::Xyz(d.gyro_bias_instability_dph)),
                accel_bias_instability_ug: Some(Axes::Xyz(d.accel_bias_instability_ug)),
                bias_corr_time_s: Some(d.bias_corr_time_s),
                gyro_scale_ppm: Some(Axes::Xyz(d.gyro_scale_ppm)),
                accel_scale_ppm: Some(Axes::Xyz(d.accel_scale_ppm)),
                gyro_turn_on_bias_dps: d.gyro_turn_on_bias_dps.map(Axes::Xyz),
                accel_turn_on_bias_mg: d.accel_turn_on_bias_mg.map(Axes::Xyz),
                ..Default::default()
            },
        }
    }
}

fn v3(a: &[f64; 3], k: f64) -> Vec3 {
    Vec3::new(a[0] * k, a[1] * k, a[2] * k)
}

fn max3(v: Vec3) -> f64 {
    v.x.max(v.y).max(v.z)
}

impl DatasheetNoise {
    /// The datasheet keys of a navfuse-sim sensor spec (the table behind
    /// `imu_preset`): noise densities from ARW/VRW (÷ 60), the Gauss–Markov
    /// σ and the gyro's correlation time (the ESKF has one, the gyro's, as
    /// [`crate::sensors::imu_noise_preset`]), scale σ, turn-on σ. `None` for
    /// an accelerometer-only spec or one without a Gauss–Markov bias.
    pub fn from_spec(spec: &ImuSpec) -> Option<DatasheetNoise> {
        let g = spec.gyro.as_ref()?;
        let a = &spec.accel;
        (g.bias_tau_s > 0.0).then(|| DatasheetNoise {
            gyro_noise_dps_rthz: [g.arw_deg_sqrt_h / 60.0; 3],
            accel_noise_ug_rthz: [a.vrw_m_s_sqrt_h / 60.0 / G0 * 1e6; 3],
            gyro_bias_instability_dph: [g.bias_instability_deg_h; 3],
            accel_bias_instability_ug: [a.bias_instability_mg * 1e3; 3],
            bias_corr_time_s: g.bias_tau_s,
            gyro_scale_ppm: [g.scale_ppm; 3],
            accel_scale_ppm: [a.scale_ppm; 3],
            gyro_turn_on_bias_dps: Some([g.bias_deg_h / 3600.0; 3]),
            accel_turn_on_bias_mg: Some([a.bias_mg; 3]),
        })
    }

    /// Every value finite and ≥ 0, `bias_corr_time_s` finite and > 0;
    /// errors name `{name}: field `{prefix}.{key}``.
    pub fn validate(&self, name: &str, prefix: &str) -> Result<(), String> {
        let on = [0.0; 3];
        for (f, a) in [
            ("gyro_noise_dps_rthz", self.gyro_noise_dps_rthz),
            ("accel_noise_ug_rthz", self.accel_noise_ug_rthz),
            ("gyro_bias_instability_dph", self.gyro_bias_instability_dph),
            ("accel_bias_instability_ug", self.accel_bias_instability_ug),
            ("gyro_scale_ppm", self.gyro_scale_ppm),
            ("accel_scale_ppm", self.accel_scale_ppm),
            (
                "gyro_turn_on_bias_dps",
                self.gyro_turn_on_bias_dps.unwrap_or(on),
            ),
            (
                "accel_turn_on_bias_mg",
                self.accel_turn_on_bias_mg.unwrap_or(on),
            ),
        ] {
            if !a.iter().all(|v| v.is_finite() && *v >= 0.0) {
                return Err(format!(
                    "{name}: field `{prefix}.{f}` must be finite and ≥ 0, got {a:?}"
                ));
            }
        }
        let t = self.bias_corr_time_s;
        if !(t.is_finite() && t > 0.0) {
            return Err(format!(
                "{name}: field `{prefix}.bias_corr_time_s` must be finite and > 0 s, got {t}"
            ));
        }
        Ok(())
    }

    /// In SI (conversions of the module table): ARW rad/√s, VRW m/s/√s,
    /// Gauss–Markov σ rad/s and m/s², scale σ fraction, T s.
    pub fn to_si(&self) -> ImuNoise {
        ImuNoise {
            arw: v3(&self.gyro_noise_dps_rthz, D2R),
            vrw: v3(&self.accel_noise_ug_rthz, 1e-6 * G0),
            bg_std: v3(&self.gyro_bias_instability_dph, D2R / 3600.0),
            ba_std: v3(&self.accel_bias_instability_ug, 1e-6 * G0),
            sg_std: v3(&self.gyro_scale_ppm, 1e-6),
            sa_std: v3(&self.accel_scale_ppm, 1e-6),
            corr_time: self.bias_corr_time_s,
        }
    }
}

impl ImuNoiseCfg {
    /// Values valid for the filter (finite, ≥ 0; correlation time > 0);
    /// errors name `{name}: field `{prefix}.{key}``.
    pub fn validate(&self, name: &str, prefix: &str) -> Result<(), String> {
        match self {
            ImuNoiseCfg::KfGins(n) => n.validate(name, prefix),
            ImuNoiseCfg::Datasheet(d) => d.validate(name, prefix),
        }
    }

    /// The ESKF's process noise in SI (body FRD axes): the KF-GINS form
    /// exactly as [`KfGinsNoise::to_si`], the datasheet form by
    /// [`DatasheetNoise::to_si`].
    pub fn to_si(&self) -> ImuNoise {
        match self {
            ImuNoiseCfg::KfGins(n) => n.to_si(),
            ImuNoiseCfg::Datasheet(d) => d.to_si(),
        }
    }

    /// The noise with the initial σ of the error states, like a sensor
    /// preset ([`crate::sensors::imu_noise_preset`]); the initial σ is the
    /// largest axis. Initial bias σ: √(turn-on² + instability²) when the
    /// turn-on bias is given, else the instability σ (KF-GINS's default
    /// `initbgstd = gbstd`); initial scale σ: the scale σ.
    pub fn sensor_noise(&self) -> SensorNoise {
        let noise = self.to_si();
        let (form, bg0, ba0) = match self {
            ImuNoiseCfg::KfGins(_) => ("KF-GINS keys", 0.0, 0.0),
            ImuNoiseCfg::Datasheet(d) => (
                "datasheet keys",
                d.gyro_turn_on_bias_dps.map_or(0.0, |a| max3(v3(&a, D2R))),
                d.accel_turn_on_bias_mg
                    .map_or(0.0, |a| max3(v3(&a, 1e-3 * G0))),
            ),
        };
        SensorNoise {
            preset: "[filter.imu_noise]".into(),
            sensor: "as configured".into(),
            source: format!("[filter.imu_noise] in {form}"),
            init_bg_std: bg0.hypot(max3(noise.bg_std)),
            init_ba_std: ba0.hypot(max3(noise.ba_std)),
            init_sg_std: max3(noise.sg_std),
            init_sa_std: max3(noise.sa_std),
            noise,
        }
    }
}

/// Allan deviation at averaging time `tau` [s] of a first-order
/// Gauss–Markov process of steady-state σ `sigma` and correlation time `t`
/// [s]: σ_A²(τ) = (2σ²T/τ)·[1 − (T/2τ)(3 − 4e^{−τ/T} + e^{−2τ/T})]
/// (IEEE Std 952 Annex C; El-Sheimy et al. 2008, IEEE T-IM 57(1) eq. 15).
/// Peaks at ≈ 0.617 σ for τ ≈ 1.89 T.
pub fn gm_allan_deviation(sigma: f64, t: f64, tau: f64) -> f64 {
    let x = tau / t;
    let b = 1.0 - (3.0 - 4.0 * (-x).exp() + (-2.0 * x).exp()) / (2.0 * x);
    (2.0 * sigma * sigma * t / tau * b).max(0.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::RunConfig;

    fn parse(block: &str) -> Result<RunConfig, String> {
        toml::from_str(&format!(
            "[input]\nimu = \"i\"\ngnss = \"g\"\n[filter.imu_noise]\n{block}"
        ))
        .map_err(|e| e.to_string())
    }

    fn noise(block: &str) -> ImuNoiseCfg {
        parse(block).unwrap().filter.imu_noise.unwrap()
    }

    const KFGINS: &str = "arw = [0.24, 0.24, 0.3]\nvrw = [0.24, 0.24, 0.24]\n\
        gbstd = [50.0, 50.0, 50.0]\nabstd = [250.0, 250.0, 250.0]\n\
        gsstd = [1000.0, 1000.0, 1000.0]\nasstd = [1000.0, 1000.0, 1000.0]\ncorrtime = 1.0\n";

    #[test]
    fn kf_gins_keys_give_the_same_noise_as_before() {
        let n = noise(KFGINS);
        let before: KfGinsNoise = toml::from_str(KFGINS).unwrap();
        assert_eq!(n, ImuNoiseCfg::KfGins(before.clone()));
        assert_eq!(n.to_si(), before.to_si());
        n.validate("run.toml", "filter.imu_noise").unwrap();
        // KF-GINS's initial bias σ defaults to gbstd.
        assert_eq!(n.sensor_noise().init_bg_std, before.to_si().bg_std.x);
    }

    #[test]
    fn datasheet_keys_convert_by_hand_computed_numbers() {
        let n = noise(
            "gyro_noise_dps_rthz = 0.0025\naccel_noise_ug_rthz = [60.0, 60.0, 100.0]\n\
             gyro_bias_instability_dph = 2.0\naccel_bias_instability_ug = 3.6\n\
             bias_corr_time_s = 500.0\ngyro_scale_ppm = 1000\naccel_scale_ppm = 500\n\
             gyro_turn_on_bias_dps = 0.2\naccel_turn_on_bias_mg = 25.0\n",
        );
        n.validate("run.toml", "filter.imu_noise").unwrap();
        let s = n.to_si();
        // 0.0025 °/s/√Hz = 0.15 °/√h = 4.3633e-5 rad/√s.
        assert!((s.arw.x - 4.363_323_1e-5).abs() < 1e-12, "{}", s.arw.x);
        assert!((s.arw.x * 60.0 / D2R - 0.15).abs() < 1e-12);
        // 60 µg/√Hz = 5.88399e-4 m/s/√s; z: 100 µg/√Hz = 9.80665e-4.
        assert!((s.vrw.x - 5.883_99e-4).abs() < 1e-12, "{}", s.vrw.x);
        assert!((s.vrw.z - 9.806_65e-4).abs() < 1e-12);
        // 2 °/h = 9.6963e-6 rad/s; 3.6 µg = 3.530394e-5 m/s².
        assert!(
            (s.bg_std.y - 9.696_273_6e-6).abs() < 1e-13,
            "{}",
            s.bg_std.y
        );
        assert!((s.ba_std.z - 3.530_394e-5).abs() < 1e-12);
        assert_eq!((s.sg_std.x, s.sa_std.x, s.corr_time), (1e-3, 5e-4, 500.0));
        // Initial bias σ: turn-on 0.2 °/s = 3.4907e-3 rad/s ⊕ 9.70e-6;
        // 25 mg = 0.24517 m/s² ⊕ 3.5e-5.
        let sn = n.sensor_noise();
        assert!(
            (sn.init_bg_std - 3.490_672e-3).abs() < 1e-8,
            "{}",
            sn.init_bg_std
        );
        assert!(
            (sn.init_ba_std - 0.245_166_3).abs() < 1e-6,
            "{}",
            sn.init_ba_std
        );
        // Optional keys default: no scale error, initial σ = instability.
        let m = noise(
            "gyro_noise_dps_rthz = 0.0025\naccel_noise_ug_rthz = 60\n\
             gyro_bias_instability_dph = 2.0\naccel_bias_instability_ug = 3.6\n\
             bias_corr_time_s = 500.0\n",
        );
        assert_eq!(m.to_si().sg_std, Vec3::zeros());
        assert_eq!(m.sensor_noise().init_bg_std, s.bg_std.x);
        // Round trip through the TOML writer keeps the form and the numbers.
        let back: ImuNoiseCfg = toml::from_str(&toml::to_string(&n).unwrap()).unwrap();
        assert_eq!(back, n);
    }

    #[test]
    fn mixed_missing_and_bad_keys_are_rejected_by_name() {
        let e = parse(&format!("{KFGINS}gyro_noise_dps_rthz = 0.01\n")).unwrap_err();
        assert!(
            e.contains("mixed") && e.contains("`arw`") && e.contains("`gyro_noise_dps_rthz`"),
            "{e}"
        );
        let e = parse("gyro_noise_dps_rthz = 0.01\naccel_noise_ug_rthz = 60\n").unwrap_err();
        assert!(
            e.contains("missing `gyro_bias_instability_dph`, `accel_bias_instability_ug`, `bias_corr_time_s`"),
            "{e}"
        );
        let e = parse("arw = [1.0, 1.0, 1.0]\n").unwrap_err();
        assert!(e.contains("KF-GINS form: missing `vrw`"), "{e}");
        let e = parse("gyro_noise = 0.01\n").unwrap_err();
        assert!(e.contains("gyro_noise"), "{e}");
        let e = parse("").unwrap_err();
        assert!(e.contains("empty"), "{e}");
        let n = noise(
            "gyro_noise_dps_rthz = 0.01\naccel_noise_ug_rthz = -60\n\
             gyro_bias_instability_dph = 2\naccel_bias_instability_ug = 3\nbias_corr_time_s = 100\n",
        );
        let e = n.validate("run.toml", "filter.imu_noise").unwrap_err();
        assert!(e.contains("`filter.imu_noise.accel_noise_ug_rthz`"), "{e}");
        let n = noise(
            "gyro_noise_dps_rthz = 0.01\naccel_noise_ug_rthz = 60\n\
             gyro_bias_instability_dph = 2\naccel_bias_instability_ug = 3\nbias_corr_time_s = 0\n",
        );
        let e = n.validate("run.toml", "filter.imu_noise").unwrap_err();
        assert!(e.contains("bias_corr_time_s"), "{e}");
    }

    #[test]
    fn sensor_presets_in_datasheet_keys_give_the_preset_noise() {
        let mut n = 0;
        for p in navfuse_sim::imu_model::IMU_PRESETS {
            let spec = navfuse_sim::imu_model::imu_preset(p).unwrap();
            let Some(d) = DatasheetNoise::from_spec(&spec) else {
                continue;
            };
            n += 1;
            let cfg = ImuNoiseCfg::Datasheet(d);
            cfg.validate(p, "imu_noise").unwrap();
            let (mine, theirs) = (
                cfg.sensor_noise(),
                crate::sensors::imu_noise_preset(p).unwrap(),
            );
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1e-30);
            let (x, y) = (mine.noise, theirs.noise);
            for (a, b) in [
                (x.arw.x, y.arw.x),
                (x.vrw.y, y.vrw.y),
                (x.bg_std.z, y.bg_std.z),
                (x.ba_std.x, y.ba_std.x),
                (x.sg_std.x, y.sg_std.x),
                (x.sa_std.x, y.sa_std.x),
                (x.corr_time, y.corr_time),
                (mine.init_bg_std, theirs.init_bg_std),
                (mine.init_ba_std, theirs.init_ba_std),
            ] {
                assert!(close(a, b), "{p}: {a} vs {b}");
            }
        }
        assert!(n >= 4, "{n} presets compared");
    }

    #[test]
    fn gauss_markov_allan_peak_is_0_617_sigma_at_1_89_t() {
        let (tau, peak) = (1..4000)
            .map(|i| i as f64 * 0.001)
            .map(|x| (x, gm_allan_deviation(1.0, 1.0, x)))
            .fold((0.0, 0.0), |b, p| if p.1 > b.1 { p } else { b });
        assert!(
            (peak - 0.6174).abs() < 1e-3 && (tau - 1.89).abs() < 0.01,
            "{peak} at {tau}"
        );
        // Short τ: rate random walk σ√(2τ/3T); long τ: white √(2σ²T/τ).
        assert!((gm_allan_deviation(1.0, 1.0, 1e-3) / (2e-3f64 / 3.0).sqrt() - 1.0).abs() < 1e-3);
        assert!((gm_allan_deviation(1.0, 1.0, 1e4) / (2e-4f64).sqrt() - 1.0).abs() < 1e-3);
    }
}
