//! The base station of RTK/INS (issue 15, `[input] base`, `base_position`):
//! its raw observations, where it is, and which of its epochs goes with
//! each rover epoch.
//!
//! **Position** ([`BasePosition`], the summary says which was used):
//! - given: `base_position = [x, y, z]` ECEF [m], or
//!   `[lat_deg, lon_deg, h_m]` WGS-84 (told apart by magnitude: an ECEF
//!   position is ≥ 6.3·10⁶ m from the centre, a geodetic triple is not);
//!   σ 0 (the user's surveyed coordinates are taken as exact);
//! - `"header"`: the RINEX `APPROX POSITION XYZ`, σ unknown (a receiver's
//!   header is often its own SPP; GEONET writes the surveyed one);
//! - `"spp"`: the mean of the base's single-point solutions, σ from
//!   [`mean_sigma`]. A metres-off base moves the whole rover solution by
//!   the same offset (the baseline stays right; Teunissen & Montenbruck,
//!   *Handbook of GNSS* §26.1), hence the warning.
//!
//! Default (none given): the header when it holds a position, else `"spp"`.
//!
//! **Pairing** ([`pair_epochs`]): each rover epoch takes the base epoch
//! nearest in time when it is at most [`MAX_AGE_S`] away (RTKLIB's "age of
//! differential"). No interpolation of the base observations is needed: the
//! filter predicts each receiver's ranges at its own time tag from the
//! satellite states of its own records (the satellite clock and orbit at
//! each transmission time), so only the change of the unmodelled errors
//! (ionosphere, troposphere, orbit/clock residuals) over the age remains.

use crate::error::{PipelineError, Result};
use crate::raw_input::RawInput;
use navfuse_core::geodesy::{c_en, ecef_to_geodetic, geodetic_to_ecef, Geodetic};
use navfuse_core::types::GnssFix;
use navfuse_core::{Mat3, Vec3};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Largest rover − base time difference of a pair [s]. Why 10 s: the DD
/// error that grows with the age is the change of the ionosphere and of the
/// satellite orbit/clock residuals between the two epochs. A quiet
/// mid-latitude ionosphere changes by ~0.1 TECU/min (≈ 0.3 mm/s on L1,
/// 1 TECU = 0.162 m; Klobuchar 1987 diurnal model's steepest slope is of
/// this order), broadcast clocks drift a few mm over 10 s (SA off, GPS SPS
/// PS 2020 §3.4: URE rate ≤ 0.006 m/s 95 %, typically far less); over 10 s
/// both stay at the 3 mm carrier noise. RTKLIB's default `pos2-maxage` is
/// 30 s; a disturbed ionosphere (10× the quiet rate) would put 8 cm into
/// the DD at 30 s, 3 cm at 10 s.
pub const MAX_AGE_S: f64 = 10.0;

/// Correlation time of the slow SPP errors (ionosphere residual, broadcast
/// orbit/clock) [s]: the 1800 s of the simulator's ionosphere residual and
/// of [`crate::raw_input`]'s effective-dof rule.
pub const SPP_SLOW_TAU_S: f64 = 1800.0;

/// Where the base position came from.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "source")]
pub enum BasePositionSource {
    /// `base_position` given (ECEF or geodetic).
    Given,
    /// The RINEX header's `APPROX POSITION XYZ`.
    Header,
    /// The mean of the base's SPP solutions.
    AveragedSpp {
        epochs: usize,
        /// Time span of the averaged solutions [s].
        span_s: f64,
    },
}

/// What `base_position` asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BasePositionSpec {
    /// Header when it holds a position, else averaged SPP.
    Auto,
    Header,
    Spp,
    /// ECEF [m] or `[lat_deg, lon_deg, h_m]`.
    Given([f64; 3]),
}

/// The base position and its σ.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BasePosition {
    /// ECEF [m] (antenna reference point).
    pub pos_e: [f64; 3],
    /// 1-σ north, east, down [m]; NaN unknown (header), 0 given.
    pub sigma_ned_m: [f64; 3],
    #[serde(flatten)]
    pub source: BasePositionSource,
}

/// Smallest distance from the earth's centre of an ECEF position on or
/// near the surface [m] (the polar radius 6356.75 km minus 60 km of margin
/// for the deepest terrain and a misread height); every geodetic triple
/// (|lat| ≤ 90, |lon| ≤ 360, |h| < 10⁶) is far below it.
const MIN_ECEF_NORM_M: f64 = 6.3e6;
/// Largest (the equatorial radius 6378.14 km plus 120 km: above any
/// ground antenna or aircraft).
const MAX_ECEF_NORM_M: f64 = 6.5e6;

impl BasePositionSpec {
    /// Parse a `base_position` given as three numbers (see the module doc).
    pub fn from_triple(v: [f64; 3]) -> std::result::Result<Self, String> {
        if v.iter().any(|x| !x.is_finite()) {
            return Err(format!("base_position {v:?}: not finite"));
        }
        let norm = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if norm >= MIN_ECEF_NORM_M {
            if norm > MAX_ECEF_NORM_M {
                return Err(format!(
                    "base_position {v:?}: {norm:.0} m from the earth's centre is not on the \
                     ground; give ECEF [x, y, z] in metres or [lat_deg, lon_deg, h_m]"
                ));
            }
            return Ok(BasePositionSpec::Given(v));
        }
        if v[0].abs() > 90.0 || v[1].abs() > 360.0 || v[2].abs() > 1e5 {
            return Err(format!(
                "base_position {v:?}: neither ECEF metres (|r| ≥ 6300 km) nor \
                 [lat_deg, lon_deg, h_m] (|lat| ≤ 90°, |lon| ≤ 360°, |h| ≤ 100 km)"
            ));
        }
        let g = Geodetic {
            lat: v[0].to_radians(),
            lon: v[1].to_radians(),
            h: v[2],
        };
        let e = geodetic_to_ecef(&g);
        Ok(BasePositionSpec::Given([e.x, e.y, e.z]))
    }

    /// Parse `"header"`, `"spp"` or `"auto"`.
    pub fn from_word(s: &str) -> std::result::Result<Self, String> {
        match s {
            "auto" => Ok(BasePositionSpec::Auto),
            "header" => Ok(BasePositionSpec::Header),
            "spp" => Ok(BasePositionSpec::Spp),
            _ => Err(format!(
                "base_position = {s:?}: give \"header\", \"spp\", \"auto\", ECEF [x, y, z] [m] \
                 or [lat_deg, lon_deg, h_m]"
            )),
        }
    }
}

/// σ of the mean of a slowly varying error: variance factor of the mean of
/// a first-order Gauss–Markov series of correlation time `tau_s` over
/// `span_s` relative to one sample, `g = (2τ/T)[1 − (τ/T)(1 − e^{−T/τ})]`
/// (Papoulis, *Probability, Random Variables and Stochastic Processes*,
/// the variance of a time average; g → 1 for T ≪ τ, 2τ/T for T ≫ τ).
pub fn mean_variance_factor(span_s: f64, tau_s: f64) -> f64 {
    if span_s.is_nan() || tau_s.is_nan() || span_s <= 0.0 || tau_s <= 0.0 {
        return 1.0;
    }
    let r = tau_s / span_s;
    (2.0 * r * (1.0 - r * (1.0 - (-span_s / tau_s).exp()))).clamp(0.0, 1.0)
}

/// Mean position of SPP fixes (ECEF) and its 1-σ NED: per axis
/// `σ² = mean(σ_fix²) · g(T, τ) + s²/n`, the fixes' own σ (their slow
/// satellite and ionosphere budget) averaged only as far as the span covers
/// its correlation time ([`mean_variance_factor`], [`SPP_SLOW_TAU_S`]),
/// plus the scatter's white share. `None` without fixes.
pub fn mean_sigma(fixes: &[GnssFix]) -> Option<(Vec3, Vec3, f64)> {
    let n = fixes.len();
    if n == 0 {
        return None;
    }
    let pos: Vec<Vec3> = fixes
        .iter()
        .map(|f| {
            geodetic_to_ecef(&Geodetic {
                lat: f.lat,
                lon: f.lon,
                h: f.h,
            })
        })
        .collect();
    let mean = pos.iter().fold(Vec3::zeros(), |a, p| a + p) / n as f64;
    let g0 = ecef_to_geodetic(&mean);
    let c: Mat3 = c_en(g0.lat, g0.lon);
    let mut scatter = Vec3::zeros();
    let mut own = Vec3::zeros();
    for (p, f) in pos.iter().zip(fixes) {
        let d = c * (p - mean);
        scatter += d.component_mul(&d);
        own += f.std_ned.component_mul(&f.std_ned);
    }
    let span = fixes.last().map_or(0.0, |l| l.t) - fixes[0].t;
    let g = mean_variance_factor(span, SPP_SLOW_TAU_S);
    let nn = n as f64;
    let var = own / nn * g + scatter / (nn * (nn - 1.0).max(1.0));
    Some((mean, var.map(f64::sqrt), span))
}

/// A base station read for RTK.
#[derive(Clone, Debug)]
pub struct BaseStation {
    /// Its raw records (receiver time tags) and SPP fixes.
    pub raw: RawInput,
    pub position: BasePosition,
    /// Doubts for summary.json `warnings`.
    pub warnings: Vec<String>,
}

/// Read the base's observations (`.ubx`, or RINEX with `nav`) and settle
/// its position by `spec` (module documentation; a UBX log has no header).
pub fn load_base(obs: &Path, nav: &[PathBuf], spec: BasePositionSpec) -> Result<BaseStation> {
    load_base_with(obs, nav, spec, false)
}

/// [`load_base`], with `second_frequency` the second-frequency records too
/// (GPS L2, Galileo E5b, BeiDou B2I of a RINEX file or a UBX log,
/// [`crate::raw_input::raw_from_obs_with`]).
pub fn load_base_with(
    obs: &Path,
    nav: &[PathBuf],
    spec: BasePositionSpec,
    second_frequency: bool,
) -> Result<BaseStation> {
    let ubx = crate::spp::is_ubx(obs);
    if !ubx && nav.is_empty() {
        return Err(PipelineError::Input(format!(
            "{}: a RINEX base needs broadcast ephemerides: give [input] nav",
            obs.display()
        )));
    }
    let (o, g, n) = crate::spp::load(obs, nav)?;
    let format = if ubx { "ubx-raw" } else { "rinex-obs" };
    let raw = crate::raw_input::raw_from_obs_with(&o, &g, &n, obs, format, second_frequency)?;
    let header = if ubx { [0.0; 3] } else { o.approx_pos };
    let (position, warnings) = settle_position(&raw.fixes, header, spec)
        .map_err(|e| PipelineError::Input(format!("{}: {e}", obs.display())))?;
    Ok(BaseStation {
        raw,
        position,
        warnings,
    })
}

/// The position rule of [`load_base`] on fixes and a header already read.
pub fn settle_position(
    fixes: &[GnssFix],
    header: [f64; 3],
    spec: BasePositionSpec,
) -> std::result::Result<(BasePosition, Vec<String>), String> {
    let header_ok = {
        let n = (header[0].powi(2) + header[1].powi(2) + header[2].powi(2)).sqrt();
        (MIN_ECEF_NORM_M..=MAX_ECEF_NORM_M).contains(&n)
    };
    let mut warnings = Vec::new();
    let spp = || -> std::result::Result<BasePosition, String> {
        let (m, s, span) = mean_sigma(fixes).ok_or_else(|| {
            "base position: no single-point solution to average (give base_position)".to_string()
        })?;
        Ok(BasePosition {
            pos_e: [m.x, m.y, m.z],
            sigma_ned_m: [s.x, s.y, s.z],
            source: BasePositionSource::AveragedSpp {
                epochs: fixes.len(),
                span_s: span,
            },
        })
    };
    let pos = match spec {
        BasePositionSpec::Given(v) => BasePosition {
            pos_e: v,
            sigma_ned_m: [0.0; 3],
            source: BasePositionSource::Given,
        },
        BasePositionSpec::Header | BasePositionSpec::Auto if header_ok => BasePosition {
            pos_e: header,
            sigma_ned_m: [f64::NAN; 3],
            source: BasePositionSource::Header,
        },
        BasePositionSpec::Header => {
            return Err(format!(
                "base_position = \"header\": the header's APPROX POSITION XYZ {header:?} is \
                 not a position on the ground"
            ))
        }
        BasePositionSpec::Auto | BasePositionSpec::Spp => spp()?,
    };
    if let BasePositionSource::AveragedSpp { epochs, span_s } = pos.source {
        let h = pos.sigma_ned_m[0].hypot(pos.sigma_ned_m[1]);
        warnings.push(format!(
            "base position from the mean of {epochs} single-point solutions over {span_s:.0} s \
             (σ horizontal {h:.2} m): the rover's absolute position carries that offset \
             (its position relative to the base does not); give the surveyed base_position"
        ));
    }
    Ok((pos, warnings))
}

/// Which base epoch each rover epoch uses.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Pairing {
    /// Per rover epoch: the base epoch index, `None` when none is within
    /// the age limit.
    #[serde(skip)]
    pub base_of: Vec<Option<usize>>,
    /// Rover epochs without a base epoch (no differential update).
    pub rover_unpaired: usize,
    /// Base epochs no rover epoch used.
    pub base_unused: usize,
    /// Largest |rover − base| time difference of a pair [s].
    pub max_age_s: f64,
}

/// Pair rover epoch times with the nearest base epoch time at most
/// `max_age_s` away (both sorted ascending, GPS seconds; module doc).
pub fn pair_epochs(rover_t: &[f64], base_t: &[f64], max_age_s: f64) -> Pairing {
    let mut out = Pairing {
        base_of: Vec::with_capacity(rover_t.len()),
        ..Default::default()
    };
    let mut used = vec![false; base_t.len()];
    let mut j = 0usize;
    for &t in rover_t {
        while j + 1 < base_t.len() && (base_t[j + 1] - t).abs() <= (base_t[j] - t).abs() {
            j += 1;
        }
        match base_t.get(j) {
            Some(&b) if (b - t).abs() <= max_age_s => {
                out.base_of.push(Some(j));
                used[j] = true;
                out.max_age_s = out.max_age_s.max((b - t).abs());
            }
            _ => {
                out.base_of.push(None);
                out.rover_unpaired += 1;
            }
        }
    }
    out.base_unused = used.iter().filter(|u| !**u).count();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fix(t: f64, lat_deg: f64, h: f64, s: f64) -> GnssFix {
        GnssFix {
            t,
            lat: lat_deg.to_radians(),
            lon: 139.0f64.to_radians(),
            h,
            std_ned: Vec3::new(s, s, 2.0 * s),
            v_n: None,
            std_v_n: None,
            quality: 5,
            num_sats: 8,
        }
    }

    #[test]
    fn position_triples_told_apart_and_bad_ones_refused() {
        let ecef = [-3_961_904.0, 3_348_993.9, 3_698_211.5];
        assert_eq!(
            BasePositionSpec::from_triple(ecef),
            Ok(BasePositionSpec::Given(ecef))
        );
        // Geodetic → the same point as its ECEF conversion.
        let BasePositionSpec::Given(e) =
            BasePositionSpec::from_triple([35.7, 139.7, 40.0]).unwrap()
        else {
            panic!()
        };
        let g = ecef_to_geodetic(&Vec3::new(e[0], e[1], e[2]));
        assert!((g.lat.to_degrees() - 35.7).abs() < 1e-9 && (g.h - 40.0).abs() < 1e-6);
        for bad in [
            [1.0e7, 0.0, 0.0],    // in orbit
            [3.0e6, 0.0, 0.0],    // inside the earth, not geodetic either
            [95.0, 10.0, 0.0],    // latitude > 90°
            [f64::NAN, 0.0, 0.0], // not finite
        ] {
            let e = BasePositionSpec::from_triple(bad).unwrap_err();
            assert!(e.contains("base_position"), "{e}");
        }
        assert!(BasePositionSpec::from_word("headr").is_err());
    }

    #[test]
    fn mean_variance_factor_limits() {
        assert!((mean_variance_factor(1.0, 1800.0) - 1.0).abs() < 1e-3);
        let long = mean_variance_factor(1800.0 * 1000.0, 1800.0);
        assert!((long * 1000.0 / 2.0 - 1.0).abs() < 1e-2, "{long}");
        assert_eq!(mean_variance_factor(0.0, 1800.0), 1.0);
    }

    #[test]
    fn averaged_spp_sigma_does_not_shrink_below_the_slow_error_on_a_short_file() {
        // 600 fixes over 10 min, scatter 0.5 m, each fix σ 2 m: the slow
        // part of that σ is not averaged away in 10 min (g ≈ 0.9).
        let fixes: Vec<GnssFix> = (0..600)
            .map(|i| {
                let d = if i % 2 == 0 { 0.5 } else { -0.5 };
                fix(i as f64, 35.0 + d / 111_000.0, 40.0, 2.0)
            })
            .collect();
        let (pos, s) = settle_position(&fixes, [0.0; 3], BasePositionSpec::Auto).unwrap();
        assert!(matches!(
            pos.source,
            BasePositionSource::AveragedSpp { epochs: 600, .. }
        ));
        assert!(s.len() == 1 && s[0].contains("single-point"), "{s:?}");
        assert!(
            pos.sigma_ned_m[0] > 1.8 && pos.sigma_ned_m[0] < 2.0,
            "{:?}",
            pos.sigma_ned_m
        );
        let g = ecef_to_geodetic(&Vec3::from(pos.pos_e));
        assert!((g.lat.to_degrees() - 35.0).abs() * 111_000.0 < 0.01);
    }

    #[test]
    fn header_used_when_present_and_refused_when_asked_for_but_empty() {
        let header = [-3_961_904.0, 3_348_993.9, 3_698_211.5];
        let (p, w) = settle_position(&[], header, BasePositionSpec::Auto).unwrap();
        assert_eq!(
            (p.source, p.pos_e, w.len()),
            (BasePositionSource::Header, header, 0)
        );
        let e = settle_position(&[], [0.0; 3], BasePositionSpec::Header).unwrap_err();
        assert!(e.contains("APPROX POSITION"), "{e}");
        let e = settle_position(&[], [0.0; 3], BasePositionSpec::Auto).unwrap_err();
        assert!(e.contains("no single-point solution"), "{e}");
    }

    #[test]
    fn pairing_takes_the_nearest_base_epoch_within_the_age() {
        // Rover 5 Hz over 0–3 s, base 1 Hz with tags 9 ms late and a gap at
        // 2 s; age limit 0.25 s.
        let rover: Vec<f64> = (0..=15).map(|i| i as f64 * 0.2).collect();
        let base = [0.009, 1.009, 3.009, 4.009];
        let p = pair_epochs(&rover, &base, 0.25);
        assert_eq!(p.base_of[0], Some(0));
        assert_eq!(p.base_of[1], Some(0)); // 0.2 s: 0.191 from base 0
        assert_eq!(p.base_of[2], None); // 0.4 s: 0.391 away
        assert_eq!(p.base_of[5], Some(1)); // 1.0 s
        assert_eq!(p.base_of[10], None); // 2.0 s: no base epoch
        assert_eq!(p.base_of[15], Some(2)); // 3.0 s
        assert_eq!(p.base_unused, 1); // 4.009
        assert_eq!(
            p.rover_unpaired,
            p.base_of.iter().filter(|b| b.is_none()).count()
        );
        assert!((p.max_age_s - 0.209).abs() < 1e-9, "{}", p.max_age_s);
    }

    /// Real data: the GEONET pair (`gnss/rinex`, 30 s, one hour). The base's
    /// averaged SPP lies within 3 σ of its surveyed header position (header
    /// good to decimetres, data README); every rover epoch pairs with a base
    /// epoch at most 0.05 s away (the tags drift by ~9 ms).
    #[test]
    #[ignore = "real data: cargo test --release -p navfuse-pipeline -- --ignored"]
    fn geonet_base_position_and_pairing() {
        let obs = navfuse_io::data::require("gnss/rinex/07590920.05o");
        let nav = navfuse_io::data::require("gnss/rinex/07590920.05n");
        let rover_obs = navfuse_io::data::require("gnss/rinex/30400920.05o");
        let nav = [nav];
        let b = load_base(&obs, &nav, BasePositionSpec::Auto).unwrap();
        assert_eq!(b.position.source, BasePositionSource::Header);
        let s = load_base(&obs, &nav, BasePositionSpec::Spp).unwrap();
        let BasePositionSource::AveragedSpp { epochs, span_s } = s.position.source else {
            panic!("{:?}", s.position.source)
        };
        let h = Vec3::from(b.position.pos_e);
        let d = ecef_to_geodetic(&h);
        let dn = c_en(d.lat, d.lon) * (Vec3::from(s.position.pos_e) - h);
        let sig = s.position.sigma_ned_m;
        let sig_h = (sig[0] * sig[0] + sig[1] * sig[1]).sqrt();
        eprintln!(
            "GEONET 0759: mean of {epochs} SPP over {span_s:.0} s − header = \
             N {:.2} E {:.2} D {:.2} m, σ NED {:.2} {:.2} {:.2} m",
            dn.x, dn.y, dn.z, sig[0], sig[1], sig[2]
        );
        assert!(dn.xy().norm() < 3.0 * sig_h + 0.3, "{dn:?} vs σ_h {sig_h}");
        let rover = crate::raw_input::load_raw(&rover_obs, &nav).unwrap();
        let times = |r: &RawInput| {
            let mut t: Vec<f64> = r.records.iter().map(|x| x.obs.t).collect();
            t.dedup();
            t
        };
        let p = pair_epochs(&times(&rover), &times(&b.raw), MAX_AGE_S);
        eprintln!(
            "pairing: rover unpaired {}, base unused {}, max age {:.3} s",
            p.rover_unpaired, p.base_unused, p.max_age_s
        );
        assert_eq!(p.rover_unpaired, 0);
        assert!(p.max_age_s < 0.05, "{}", p.max_age_s);
    }
}
