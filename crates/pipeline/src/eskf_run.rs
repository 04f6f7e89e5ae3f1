//! The ESKF run of `navfuse run`, in memory: the part of the inputs used
//! (`[input] start`, `[outage]`), the filter model from `[filter]`, the
//! alignment ([`crate::align`]), the filter loop and the RTS smoother.
//! Writes nothing; [`crate::run::run`] writes its results.

use crate::align::align;
use crate::check::smoothed_solution;
use crate::config::{resolve_path, RunConfig};
use crate::error::{PipelineError, Result};
use crate::input::AuxSeries;
use crate::time_offset::{estimate_time_offset, time_offset_note};
use navfuse_core::estimators::eskf::{rts_smooth, Eskf, EskfConfig, EskfStats, UpdateLog};
use navfuse_core::types::{Estimator, Event, GnssFix, ImuSample, NavSolution};
use navfuse_core::Vec3;
use navfuse_io::kfgins_yaml::KfGinsConfig;
use std::path::Path;
use std::time::Instant;

/// The part of the inputs a run uses.
pub(crate) struct Span<'a> {
    /// IMU samples from `[input] start` on.
    pub imu: &'a [ImuSample],
    /// IMU samples before `[input] start`.
    pub imu_before_start: usize,
    /// Fixes left after the `[outage]` cut.
    pub gnss: Vec<GnssFix>,
    /// All fixes read.
    pub gnss_all: &'a [GnssFix],
}

impl Span<'_> {
    /// Fixes removed by the `[outage]` schedule.
    pub fn cut(&self) -> usize {
        self.gnss_all.len() - self.gnss.len()
    }
}

/// Cut the IMU at `[input] start` (at least 200 samples must remain) and the
/// GNSS by the `[outage]` schedule (from `start` s after the first IMU sample
/// used, `length` s without fixes every `period` s).
pub(crate) fn select_span<'a>(
    cfg: &RunConfig,
    imu: &'a [ImuSample],
    gnss_all: &'a [GnssFix],
) -> Result<Span<'a>> {
    let start = cfg.input.start.unwrap_or(f64::NEG_INFINITY);
    let i0 = imu.partition_point(|s| s.t < start);
    let imu = &imu[i0..];
    if imu.len() < 200 {
        return Err(PipelineError::Input(format!(
            "{}: fewer than 200 IMU samples after the start",
            cfg.input.imu
        )));
    }
    let mut gnss = gnss_all.to_vec();
    if let Some(o) = &cfg.outage {
        if !(o.length > 0.0 && o.period >= o.length) {
            return Err(cfg.err("[outage] needs length > 0 and period ≥ length"));
        }
        let t0 = imu[0].t + o.start;
        gnss.retain(|g| g.t < t0 || (g.t - t0) % o.period >= o.length);
    }
    Ok(Span {
        imu,
        imu_before_start: i0,
        gnss,
        gnss_all,
    })
}

/// The ESKF configuration of `[filter]`: the IMU noise from `noise_yaml`,
/// `imu_noise` (KF-GINS units) or the seed 001 preset, then the preset
/// (`kf-gins`, `enhanced` = [`crate::kf_gins::enhanced`], `seed001`), the
/// lever arm (body FRD, m) and the smoother.
pub fn filter_config(cfg: &RunConfig, base_dir: &Path) -> Result<EskfConfig> {
    let mut ecfg = match (&cfg.filter.noise_yaml, &cfg.filter.imu_noise) {
        (Some(_), Some(_)) => {
            return Err(cfg.err("[filter] give noise_yaml or imu_noise, not both"));
        }
        (Some(y), None) => KfGinsConfig::load(&resolve_path(base_dir, y))
            .map_err(PipelineError::Input)?
            .eskf_config(),
        (None, Some(n)) => {
            n.validate(&cfg.name(), "filter.imu_noise")
                .map_err(PipelineError::Input)?;
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
            return Err(cfg.err(format!(
                "[filter] preset {p:?}: expected kf-gins, enhanced or seed001"
            )))
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
    Ok(ecfg)
}

/// Everything an in-memory ESKF run produced.
#[derive(Clone, Debug)]
pub struct EskfRun {
    /// Forward solutions (IMU position, NED velocity, attitude), one per IMU sample.
    pub solutions: Vec<NavSolution>,
    /// RTS-smoothed solutions in time order (empty unless `[filter] smooth`).
    pub smoothed: Vec<NavSolution>,
    /// Every measurement update tried, in order (the innovation journal).
    pub updates: Vec<UpdateLog>,
    /// Update counters.
    pub stats: EskfStats,
    /// The filter configuration used.
    pub config: EskfConfig,
    /// How the filter was aligned (the summary's `alignment`).
    pub alignment: String,
    /// Residual IMU–GNSS time offset estimated on the inputs: τ [s] to add to
    /// the IMU stamps and the correlation r ([`estimate_time_offset`], ±0.5 s);
    /// reported, not applied.
    pub time_offset_estimate: Option<(f64, f64)>,
    /// IMU samples given, and of them before `[input] start`.
    pub imu_samples_read: usize,
    pub imu_samples_before_start: usize,
    /// GNSS fixes given, cut by `[outage]`, and handed to the filter.
    pub gnss_fixes_read: usize,
    pub gnss_fixes_cut_by_outage: usize,
    pub gnss_fixes_fed: usize,
    /// Wall-clock seconds of the filter loop.
    pub seconds_filter: f64,
}

impl EskfRun {
    /// The summary's `time_offset` text, given the offset the input loading
    /// applied (τ [s] and how), if any.
    pub fn time_offset_text(&self, applied: Option<&(f64, String)>) -> String {
        time_offset_note(self.time_offset_estimate, applied)
    }
}

/// Run `navfuse run`'s ESKF in memory, writing nothing: `imu` (increments,
/// body FRD) and `gnss` (antenna fixes) time-ordered on one time base (as
/// [`crate::input::load`] returns them), `aux` the optional magnetometer /
/// AHRS-yaw rows for the heading. Applies `[input] start`, `[outage]`,
/// `[init]` and `[filter]` of `cfg` (`noise_yaml` relative to `base_dir`).
pub fn run_eskf(
    cfg: &RunConfig,
    base_dir: &Path,
    imu: &[ImuSample],
    gnss: &[GnssFix],
    aux: Option<&AuxSeries>,
) -> Result<EskfRun> {
    let span = select_span(cfg, imu, gnss)?;
    run_eskf_span(cfg, base_dir, &span, aux)
}

/// [`run_eskf`] on a selected span.
pub(crate) fn run_eskf_span(
    cfg: &RunConfig,
    base_dir: &Path,
    span: &Span,
    aux: Option<&AuxSeries>,
) -> Result<EskfRun> {
    let ecfg = filter_config(cfg, base_dir)?;
    let (imu, gnss) = (span.imu, &span.gnss[..]);
    let a = align(cfg, imu, gnss, aux)?;
    let mut eskf = Eskf::new(ecfg, a.nav, a.errors, &a.init_std);
    let k_start = a.k_start;
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
    let mut smoothed = Vec::new();
    if cfg.filter.smooth {
        smoothed.reserve(records.len());
        rts_smooth(&records, |e| smoothed.push(smoothed_solution(e)));
        smoothed.reverse();
    }
    Ok(EskfRun {
        solutions: sols,
        smoothed,
        updates: innovations,
        stats: *eskf.stats(),
        config: *eskf.config(),
        alignment: a.description,
        time_offset_estimate: estimate_time_offset(imu, span.gnss_all, 0.5),
        imu_samples_read: imu.len() + span.imu_before_start,
        imu_samples_before_start: span.imu_before_start,
        gnss_fixes_read: span.gnss_all.len(),
        gnss_fixes_cut_by_outage: span.cut(),
        gnss_fixes_fed: gnss_fed,
        seconds_filter,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 60 s level drive north at 5 m/s (100 Hz IMU with gravity only, 1 Hz
    /// exact fixes) run in memory in the KF-GINS model with a 10 s outage
    /// and the smoother: the
    /// fixes are all accounted for (fed, cut, outside the filtered span), the
    /// smoothed epochs come in time order and the end is on the truth.
    #[test]
    fn run_eskf_in_memory_accounts_for_every_fix_and_ends_on_the_truth() {
        let (lat0, lon0, h) = (40.0f64.to_radians(), -105.0f64.to_radians(), 1600.0);
        let (rm, _) = navfuse_core::earth::radii(lat0);
        let (t0, v, g, dt) = (1000.0, 5.0, 9.8, 0.01);
        let imu: Vec<ImuSample> = (1..=6000)
            .map(|k| ImuSample {
                t: t0 + k as f64 * dt,
                dt,
                dtheta_b: Vec3::zeros(),
                dvel_b: Vec3::new(0.0, 0.0, -g * dt),
            })
            .collect();
        let gnss: Vec<GnssFix> = (0..=60)
            .map(|k| GnssFix {
                t: t0 + k as f64,
                lat: lat0 + v * k as f64 / (rm + h),
                lon: lon0,
                h,
                std_ned: Vec3::new(0.5, 0.5, 1.0),
                ..Default::default()
            })
            .collect();
        let cfg: RunConfig = toml::from_str(
            "[input]\nimu = \"mem\"\ngnss = \"mem\"\n[filter]\npreset = \"kf-gins\"\nsmooth = true\n\
             [outage]\nstart = 20.0\nlength = 10.0\nperiod = 100.0\n",
        )
        .unwrap();
        let r = run_eskf(&cfg, Path::new("."), &imu, &gnss, None).unwrap();
        assert_eq!(r.gnss_fixes_read, 61);
        assert_eq!(r.gnss_fixes_cut_by_outage, 10, "fixes 21…30 s");
        assert!(r.gnss_fixes_fed > 40, "{}", r.gnss_fixes_fed);
        assert!(r.gnss_fixes_fed + r.gnss_fixes_cut_by_outage <= 61);
        assert!(
            r.smoothed.len() > 100,
            "{} smoothed epochs",
            r.smoothed.len()
        );
        assert!(r.smoothed.windows(2).all(|w| w[0].t < w[1].t), "time order");
        assert!(r.alignment.contains("GNSS course"), "{}", r.alignment);
        let last = r.solutions.last().unwrap();
        let dn = (last.lat - lat0) * (rm + h) - v * (last.t - t0);
        assert!(
            dn.abs() < 0.5 && ((last.lon - lon0) * rm).abs() < 0.5,
            "{dn}"
        );
        // Too few samples after `[input] start`: an input error naming the file.
        let mut late = cfg.clone();
        late.input.start = Some(t0 + 59.0);
        let e = run_eskf(&late, Path::new("."), &imu, &gnss, None).unwrap_err();
        assert_eq!(
            e.to_string(),
            "mem: fewer than 200 IMU samples after the start"
        );
    }
}
