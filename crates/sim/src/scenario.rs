//! Scenario files (TOML): start, sensors, motion segments.
//!
//! ```toml
//! name = "demo"
//! [start]
//! lat_deg = 30.5
//! lon_deg = 114.3
//! rpy_deg = [0, 0, 90]
//! [imu]
//! preset = "adis16465"   # or an [imu.model] table (ImuSpec)
//! rate_hz = 100
//! [gnss]
//! preset = "consumer-1hz"
//! outages = [[120, 150]]  # seconds after start
//! [[segment]]
//! type = "accelerate"
//! speed_kmh = 50
//! ```

use crate::gnss_model::{gnss_preset, GnssSpec};
use crate::imu_model::{imu_preset, ImuSpec};
use crate::trajectory::{Segment, Start};
use crate::SimError;
use serde::{Deserialize, Serialize};
use std::path::Path;

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    #[serde(default)]
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub start: Start,
    #[serde(default)]
    pub imu: ImuSection,
    #[serde(default)]
    pub gnss: GnssSection,
    #[serde(default)]
    pub segment: Vec<Segment>,
}

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ImuSection {
    pub rate_hz: f64,
    /// Internal integration steps per IMU interval.
    pub substeps: u32,
    pub preset: String,
    /// Full error specification; replaces the preset when given.
    pub model: Option<ImuSpec>,
}

impl Default for ImuSection {
    fn default() -> Self {
        ImuSection {
            rate_hz: 100.0,
            substeps: 10,
            preset: "ideal".into(),
            model: None,
        }
    }
}

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct GnssSection {
    pub preset: String,
    /// Full error specification; replaces the preset when given.
    pub model: Option<GnssSpec>,
    /// Override of the preset's rate [Hz].
    pub rate_hz: Option<f64>,
    /// Outage intervals [start, end] in seconds after the scenario start.
    pub outages: Vec<[f64; 2]>,
    /// Keep only fixes every N seconds (seed 004's "GPS every N s"); 0: all.
    pub every_s: f64,
    /// Antenna position in the body frame (FRD) w.r.t. the IMU [m].
    pub lever_arm_m: [f64; 3],
}

impl Default for GnssSection {
    fn default() -> Self {
        GnssSection {
            preset: "consumer-1hz".into(),
            model: None,
            rate_hz: None,
            outages: Vec::new(),
            every_s: 0.0,
            lever_arm_m: [0.0; 3],
        }
    }
}

impl Scenario {
    /// Parse TOML text; `origin` names the file in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, SimError> {
        toml::from_str(text).map_err(|e| SimError::Scenario(format!("{origin}: {e}")))
    }

    /// Read a scenario file: `.toml`, or a gnss-ins-sim motion-definition `.csv`.
    pub fn from_file(path: &Path) -> Result<Self, SimError> {
        let text = navfuse_io::text::read_text_capped(path, navfuse_io::text::MAX_CONFIG_BYTES)
            .map_err(|e| SimError::Io(e.to_string()))?;
        let origin = path.display().to_string();
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("csv"))
        {
            crate::motion_csv::parse(&text, &origin)
        } else {
            Self::from_toml(&text, &origin)
        }
    }

    /// The IMU spec in effect (model table, else preset).
    pub fn imu_spec(&self) -> Result<ImuSpec, SimError> {
        match &self.imu.model {
            Some(m) => Ok(m.clone()),
            None => imu_preset(&self.imu.preset),
        }
    }

    /// The GNSS spec in effect (model table, else preset; rate override applied).
    pub fn gnss_spec(&self) -> Result<GnssSpec, SimError> {
        let mut s = match &self.gnss.model {
            Some(m) => m.clone(),
            None => gnss_preset(&self.gnss.preset)?,
        };
        if let Some(r) = self.gnss.rate_hz {
            s.rate_hz = r;
        }
        Ok(s)
    }
}
