//! KF-GINS YAML configuration (i2Nav-WHU KF-GINS `kf-gins.yaml`), read
//! unchanged, plus the navfuse extension key `gnssvelpath`.
//!
//! KF-GINS units are converted to SI here (the I/O edge): `initatt` deg,
//! `initgyrbias`/`gbstd`/`initbgstd` deg/h, `initaccbias`/`abstd`/`initbastd`
//! mGal, scale factors ppm, `arw` deg/√h, `vrw` m/s/√h, `corrtime` h,
//! `initpos` lat/lon deg + height m, `antlever` m in body FRD.
//!
//! Errors name the file, line and key: an unknown key (a typo such as
//! `initattt` is never silently ignored; KF-GINS's own keys are all known),
//! a value of the wrong type or count, a missing required key. The file is
//! read with [`MAX_CONFIG_BYTES`](crate::text::MAX_CONFIG_BYTES) as its cap.

use navfuse_core::estimators::eskf::{EskfConfig, ImuErrors, ImuNoise, InitStd};
use navfuse_core::ins::mech::{q_bn_from_rpy, NavState};
use navfuse_core::Vec3;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// IMU noise block (`imunoise:`), KF-GINS units: arw [deg/√h], vrw
/// [m/s/√h], gbstd [deg/h], abstd [mGal], gsstd/asstd [ppm], corrtime [h].
#[derive(Clone, Debug, Deserialize, serde::Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct KfGinsNoise {
    pub arw: [f64; 3],
    pub vrw: [f64; 3],
    pub gbstd: [f64; 3],
    pub abstd: [f64; 3],
    pub gsstd: [f64; 3],
    pub asstd: [f64; 3],
    pub corrtime: f64,
}

impl KfGinsNoise {
    /// Every value finite and ≥ 0, `corrtime` > 0; errors name `{name}: field `{prefix}.x``.
    pub fn validate(&self, name: &str, prefix: &str) -> Result<(), String> {
        for (f, a) in [
            ("arw", self.arw),
            ("vrw", self.vrw),
            ("gbstd", self.gbstd),
            ("abstd", self.abstd),
            ("gsstd", self.gsstd),
            ("asstd", self.asstd),
        ] {
            if !a.iter().all(|v| v.is_finite() && *v >= 0.0) {
                return Err(format!(
                    "{name}: field `{prefix}.{f}` must be finite and ≥ 0, got {a:?}"
                ));
            }
        }
        if self.corrtime.is_nan() || self.corrtime <= 0.0 {
            return Err(format!(
                "{name}: field `{prefix}.corrtime` must be > 0 h, got {}",
                self.corrtime
            ));
        }
        Ok(())
    }

    /// In SI: arw rad/√s, vrw m/s/√s, Gauss–Markov σ and T in s.
    pub fn to_si(&self) -> ImuNoise {
        ImuNoise {
            arw: v3(&self.arw, D2R / 60.0),
            vrw: v3(&self.vrw, 1.0 / 60.0),
            bg_std: v3(&self.gbstd, DEG_PER_H),
            ba_std: v3(&self.abstd, MGAL),
            sg_std: v3(&self.gsstd, PPM),
            sa_std: v3(&self.asstd, PPM),
            corr_time: self.corrtime * 3600.0,
        }
    }
}

/// A KF-GINS configuration file, fields in KF-GINS's own units.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct KfGinsConfig {
    pub imupath: String,
    pub gnsspath: String,
    pub outputpath: String,
    #[serde(default = "default_imudatalen")]
    pub imudatalen: usize,
    #[serde(default = "default_imudatarate")]
    pub imudatarate: f64,
    pub starttime: f64,
    pub endtime: f64,
    pub initpos: [f64; 3],
    pub initvel: [f64; 3],
    pub initatt: [f64; 3],
    #[serde(default)]
    pub initgyrbias: [f64; 3],
    #[serde(default)]
    pub initaccbias: [f64; 3],
    #[serde(default)]
    pub initgyrscale: [f64; 3],
    #[serde(default)]
    pub initaccscale: [f64; 3],
    pub initposstd: [f64; 3],
    pub initvelstd: [f64; 3],
    pub initattstd: [f64; 3],
    /// Default: `imunoise.gbstd` (as KF-GINS).
    pub initbgstd: Option<[f64; 3]>,
    pub initbastd: Option<[f64; 3]>,
    pub initsgstd: Option<[f64; 3]>,
    pub initsastd: Option<[f64; 3]>,
    pub imunoise: KfGinsNoise,
    pub antlever: [f64; 3],
    /// navfuse extension: GNSS velocity file (SOW, vN, vE, vD, σN, σE, σD).
    pub gnssvelpath: Option<String>,
    /// Folder of the YAML file (paths are relative to it); set by [`KfGinsConfig::load`].
    #[serde(skip)]
    pub base_dir: PathBuf,
}

fn default_imudatalen() -> usize {
    7
}
fn default_imudatarate() -> f64 {
    200.0
}

const D2R: f64 = core::f64::consts::PI / 180.0;
const DEG_PER_H: f64 = D2R / 3600.0;
const MGAL: f64 = 1e-5;
const PPM: f64 = 1e-6;

fn v3(a: &[f64; 3], k: f64) -> Vec3 {
    Vec3::new(a[0] * k, a[1] * k, a[2] * k)
}

impl KfGinsConfig {
    /// Parse YAML text; `name` names the source in errors.
    pub fn parse(text: &str, name: &str) -> Result<Self, String> {
        let c: KfGinsConfig = serde_yaml::from_str(text).map_err(|e| match e.location() {
            Some(l) => format!("{name}:{}:{}: {e}", l.line(), l.column()),
            None => format!("{name}: {e}"),
        })?;
        c.validate(name)?;
        Ok(c)
    }

    /// Read a KF-GINS YAML file; relative paths in it resolve against its folder.
    pub fn load(path: &Path) -> Result<Self, String> {
        let text = crate::text::read_text_capped(path, crate::text::MAX_CONFIG_BYTES)
            .map_err(|e| e.to_string())?;
        let mut c = Self::parse(&text, &path.display().to_string())?;
        c.base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Ok(c)
    }

    fn validate(&self, name: &str) -> Result<(), String> {
        let pos = |field: &str, a: &[f64]| -> Result<(), String> {
            if a.iter().all(|v| v.is_finite() && *v >= 0.0) {
                Ok(())
            } else {
                Err(format!(
                    "{name}: field `{field}` must be finite and ≥ 0, got {a:?}"
                ))
            }
        };
        pos("initposstd", &self.initposstd)?;
        pos("initvelstd", &self.initvelstd)?;
        pos("initattstd", &self.initattstd)?;
        self.imunoise.validate(name, "imunoise")?;
        if self.imudatalen < 7 {
            return Err(format!(
                "{name}: field `imudatalen` must be ≥ 7, got {}",
                self.imudatalen
            ));
        }
        let all_finite = self
            .initpos
            .iter()
            .chain(&self.initvel)
            .chain(&self.initatt)
            .chain(&self.antlever)
            .all(|v| v.is_finite());
        if !all_finite || self.initpos[0].abs() > 90.0 {
            return Err(format!(
                "{name}: initpos/initvel/initatt/antlever must be finite, |lat| ≤ 90°"
            ));
        }
        Ok(())
    }

    /// A path from the file, resolved against the YAML's folder.
    pub fn resolve(&self, p: &str) -> PathBuf {
        let p = Path::new(p);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.base_dir.join(p)
        }
    }

    /// Initial navigation state (SI).
    pub fn init_nav(&self) -> NavState {
        NavState {
            lat: self.initpos[0] * D2R,
            lon: self.initpos[1] * D2R,
            h: self.initpos[2],
            v_n: v3(&self.initvel, 1.0),
            q_bn: q_bn_from_rpy(&v3(&self.initatt, D2R)),
        }
    }

    /// Initial IMU errors (SI).
    pub fn init_errors(&self) -> ImuErrors {
        ImuErrors {
            bg: v3(&self.initgyrbias, DEG_PER_H),
            ba: v3(&self.initaccbias, MGAL),
            sg: v3(&self.initgyrscale, PPM),
            sa: v3(&self.initaccscale, PPM),
        }
    }

    /// Initial 1-σ (SI); missing sensor-error σ default to the noise block's.
    pub fn init_std(&self) -> InitStd {
        let n = &self.imunoise;
        InitStd {
            pos: v3(&self.initposstd, 1.0),
            vel: v3(&self.initvelstd, 1.0),
            att: v3(&self.initattstd, D2R),
            bg: v3(&self.initbgstd.unwrap_or(n.gbstd), DEG_PER_H),
            ba: v3(&self.initbastd.unwrap_or(n.abstd), MGAL),
            sg: v3(&self.initsgstd.unwrap_or(n.gsstd), PPM),
            sa: v3(&self.initsastd.unwrap_or(n.asstd), PPM),
        }
    }

    /// IMU noise (SI): arw rad/√s, vrw m/s/√s, Gauss–Markov σ and T in s.
    pub fn noise(&self) -> ImuNoise {
        self.imunoise.to_si()
    }

    /// The KF-GINS model as an ESKF configuration: 21 states, GNSS position
    /// (and velocity if `gnssvelpath` is given), no gate, no vehicle constraints.
    pub fn eskf_config(&self) -> EskfConfig {
        EskfConfig {
            noise: self.noise(),
            lever_arm_b: v3(&self.antlever, 1.0),
            scale_factors: true,
            gate_probability: None,
            gnss_force_after: 0,
            gate_deweight_factor: 1.0,
            use_gnss_velocity: self.gnssvelpath.is_some(),
            position_until: None,
            nhc: None,
            zupt: None,
            smoother_every: 0,
            aiding: Default::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const YAML: &str = r#"
imupath: "imu.txt"
gnsspath: "gnss.txt"
outputpath: "out"
imudatalen: 7
imudatarate: 100
starttime: 100.0
endtime: -1
initpos: [ 30.0, 114.0, 20.0 ]
initvel: [ 0, 0, 0 ]
initatt: [ 1.0, 2.0, 90.0 ]
initgyrbias: [ 3600, 0, 0 ]
initaccbias: [ 1000, 0, 0 ]
initgyrscale: [ 0, 0, 0 ]
initaccscale: [ 0, 0, 0 ]
initposstd: [ 0.1, 0.1, 0.2 ]
initvelstd: [ 0.05, 0.05, 0.05 ]
initattstd: [ 0.5, 0.5, 1.0 ]
imunoise:
  arw: [ 0.24, 0.24, 0.24 ]
  vrw: [ 0.24, 0.24, 0.24 ]
  gbstd: [ 50.0, 50.0, 50.0 ]
  abstd: [ 250.0, 250.0, 250.0 ]
  gsstd: [ 1000.0, 1000.0, 1000.0 ]
  asstd: [ 1000.0, 1000.0, 1000.0 ]
  corrtime: 1.0
antlever: [ 0.1, -0.2, -0.3 ]
"#;

    #[test]
    fn parses_and_converts_units() {
        let c = KfGinsConfig::parse(YAML, "t.yaml").unwrap();
        assert_eq!(c.imudatarate, 100.0);
        assert!(c.gnssvelpath.is_none());
        let e = c.init_errors();
        assert!((e.bg.x - D2R).abs() < 1e-15, "3600 deg/h = 1 deg/s");
        assert!((e.ba.x - 0.01).abs() < 1e-15, "1000 mGal = 0.01 m/s²");
        let n = c.noise();
        assert!((n.arw.x - 0.24 * D2R / 60.0).abs() < 1e-18);
        assert_eq!(n.corr_time, 3600.0);
        // Missing initbgstd falls back to gbstd.
        assert!((c.init_std().bg.x - 50.0 * DEG_PER_H).abs() < 1e-18);
        let nav = c.init_nav();
        assert!((nav.rpy().z - 90.0 * D2R).abs() < 1e-12);
        assert!((nav.lat - 30.0 * D2R).abs() < 1e-15);
    }

    #[test]
    fn errors_name_file_line_and_field() {
        let bad = YAML.replace("initvel: [ 0, 0, 0 ]", "initvel: [ 0, 0 ]");
        let e = KfGinsConfig::parse(&bad, "t.yaml").unwrap_err();
        assert!(e.starts_with("t.yaml:") && e.contains("initvel"), "{e}");
        let bad = YAML.replace("  corrtime: 1.0", "  corrtime: 0");
        let e = KfGinsConfig::parse(&bad, "t.yaml").unwrap_err();
        assert!(e.contains("corrtime"), "{e}");
        let bad = YAML.replace("antlever: [ 0.1, -0.2, -0.3 ]\n", "");
        let e = KfGinsConfig::parse(&bad, "t.yaml").unwrap_err();
        assert!(e.contains("antlever"), "{e}");
    }

    /// The line of the key: 1 + the lines before it in the text.
    fn line_of(text: &str, key: &str) -> usize {
        1 + text[..text.find(key).unwrap()].matches('\n').count()
    }

    #[test]
    fn unknown_key_and_wrong_type_name_key_and_line() {
        let bad = YAML.replace("initatt:", "initattt:");
        let e = KfGinsConfig::parse(&bad, "t.yaml").unwrap_err();
        let l = line_of(&bad, "initattt");
        assert!(
            e.starts_with(&format!("t.yaml:{l}:")) && e.contains("unknown field `initattt`"),
            "{e}"
        );
        let bad = YAML.replace("  corrtime: 1.0", "  corrtime: one hour");
        let e = KfGinsConfig::parse(&bad, "t.yaml").unwrap_err();
        let l = line_of(&bad, "corrtime");
        assert!(
            e.starts_with(&format!("t.yaml:{l}:")) && e.contains("corrtime"),
            "{e}"
        );
        let e = KfGinsConfig::load(Path::new("/nonexistent/kf.yaml")).unwrap_err();
        assert!(
            e.contains("/nonexistent/kf.yaml") && e.contains("cannot open"),
            "{e}"
        );
    }

    #[test]
    #[ignore = "real data: run with `cargo test --release -- --ignored`"]
    fn reads_the_drive_0708_configs() {
        for f in ["kf-gins_full.yaml", "kf-gins_outage.yaml"] {
            let p = crate::data::require(&format!("drive_0708/kfgins/{f}"));
            let c = KfGinsConfig::load(&p).unwrap();
            assert!(c.resolve(&c.imupath).exists());
            assert!(c.resolve(&c.gnsspath).exists());
            assert_eq!(c.starttime, 243262.0);
        }
    }
}
