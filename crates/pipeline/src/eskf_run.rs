//! The ESKF run of `navfuse run`, in memory: the part of the inputs used
//! (`[input] start`, `[outage]`), the filter model from `[filter]`, the
//! alignment ([`crate::align`]), the filter loop and the RTS smoother.
//! Writes nothing; [`crate::run::run`] writes its results.

use crate::align::{align, AlignModel};
use crate::check::smoothed_solution;
use crate::config::{resolve_path, RunConfig};
use crate::error::{PipelineError, Result};
use crate::input::AuxSeries;
use crate::profile::{Platform, Profile};
use crate::sensors::{imu_noise_preset, measured_white_noise, SensorNoise, DEFAULT_IMU_PRESET};
use crate::time_offset::{
    auto_estimate, default_mode, time_offset_note, AutoOffset, TimeOffset, TimeOffsetCfg,
};
use crate::yaw_bank::{run_bank, Member};
use navfuse_core::estimators::adaptive::{AdaptedNoise, AdaptiveConstraints, NisAdaptation};
use navfuse_core::estimators::consistency::NisMonitor;
use navfuse_core::estimators::eskf::{
    rts_smooth, Eskf, EskfConfig, EskfStats, InitStd, NhcConfig, UpdateLog,
};
use navfuse_core::gnss::raw::RawSat;
use navfuse_core::types::{Event, GnssFix, ImuSample, NavSolution};
use navfuse_core::Vec3;
use navfuse_io::kfgins_yaml::KfGinsConfig;
use navfuse_io::stdfile::StdRow;
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
    /// The inputs' odometer/heading events, time-ordered (`[input] ubx`).
    pub aiding: &'a [Event],
    /// `[filter] coupling = "tight"`: the raw records and their input
    /// account ([`cut_raw`]); `gnss` then holds their SPP fixes.
    pub tight: Option<TightSpan<'a>>,
    /// `[filter] coupling = "rtk"`: rover and base epochs ([`crate::rtk_run`]);
    /// `gnss` then holds the rover's SPP fixes (the alignment's).
    pub rtk: Option<&'a crate::rtk_run::RtkSpan>,
}

/// The raw records of a tightly coupled run.
pub(crate) struct TightSpan<'a> {
    pub input: &'a crate::raw_input::RawInput,
    /// Records left after the `[outage]` cut.
    pub records: Vec<RawSat>,
    /// Per-satellite counts; `cut` filled by [`cut_raw`].
    pub fed: crate::tight_run::Fed,
}

/// The records of `input` without those in the `[outage]` schedule of `cfg`
/// (the fixes' rule, [`select_span`], from the first IMU sample `t_imu0`).
pub(crate) fn cut_raw<'a>(
    cfg: &RunConfig,
    t_imu0: f64,
    input: &'a crate::raw_input::RawInput,
) -> TightSpan<'a> {
    let mut fed = crate::tight_run::Fed::default();
    let mut records = Vec::with_capacity(input.records.len());
    for r in &input.records {
        let cut = cfg.outage.as_ref().is_some_and(|o| {
            let t0 = t_imu0 + o.start;
            r.obs.t >= t0 && (r.obs.t - t0) % o.period < o.length
        });
        if cut {
            crate::tight_run::Fed::count(&mut fed.cut, r);
        } else {
            records.push(*r);
        }
    }
    // A cut may remove an epoch's last record: flag the new last ones.
    for k in 0..records.len() {
        let next_t = records.get(k + 1).map(|n| n.obs.t);
        if next_t != Some(records[k].obs.t) {
            records[k].obs.last_in_epoch = true;
        }
    }
    TightSpan {
        input,
        records,
        fed,
    }
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
    crate::run_checks::check_run_keys(cfg, imu, gnss_all)?;
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
        aiding: &[],
        tight: None,
        rtk: None,
    })
}

/// The resolved `[filter]`: the ESKF configuration, the adaptation of its
/// constraint noise, the platform profile and the sensor noise preset used.
#[derive(Clone, Debug)]
pub struct FilterSetup {
    pub eskf: EskfConfig,
    pub adaptive: AdaptiveConstraints,
    /// GNSS R inflation from the windowed NIS (`None`: off).
    pub nis_adaptation: Option<NisAdaptation>,
    /// The platform profile applied (`None`: no vehicle constraints).
    pub profile: Option<Profile>,
    /// The sensor preset the IMU noise came from, if any.
    pub sensor: Option<SensorNoise>,
    /// Where the IMU noise came from (the summary's words).
    pub noise_source: String,
}

/// The ESKF configuration of `[filter]`.
///
/// IMU noise (exactly one source): `noise_yaml` (a KF-GINS YAML),
/// `[filter.imu_noise]`, `imu_preset` (a sensor by model), else the
/// conservative MEMS preset [`crate::sensors::DEFAULT_IMU_PRESET`]. Then the
/// model: `preset = "kf-gins"` (the plain 21-state KF-GINS model), `"enhanced"`
/// (gating + the `car` constraints unless another `platform` is named) or
/// `"seed001"` (the paper's noise and model, replacing everything). A named
/// `platform` applies its profile ([`crate::profile`]) on any preset;
/// `[filter.nhc]` / `[filter.zupt]` override single values; constraint noise is
/// learnt from the innovations with `adaptive = true` (off by default). Lever arm: body FRD [m].
pub fn filter_setup(cfg: &RunConfig, base_dir: &Path) -> Result<FilterSetup> {
    let f = &cfg.filter;
    let given = [
        f.noise_yaml.is_some(),
        f.imu_noise.is_some(),
        f.imu_preset.is_some(),
    ];
    if given.iter().filter(|g| **g).count() > 1 {
        return Err(
            cfg.err("[filter] give one IMU noise source: noise_yaml, imu_noise or imu_preset")
        );
    }
    let mut sensor = None;
    let (mut ecfg, mut noise_source) = if let Some(y) = &f.noise_yaml {
        (
            KfGinsConfig::load(&resolve_path(base_dir, y))
                .map_err(PipelineError::Input)?
                .eskf_config(),
            format!("noise_yaml {y}"),
        )
    } else if let Some(n) = &f.imu_noise {
        n.validate(&cfg.name(), "filter.imu_noise")
            .map_err(PipelineError::Input)?;
        (
            EskfConfig {
                noise: n.to_si(),
                scale_factors: true,
                ..EskfConfig::seed001()
            },
            "[filter.imu_noise]".to_string(),
        )
    } else {
        let name = f.imu_preset.as_deref().unwrap_or(DEFAULT_IMU_PRESET);
        let s = imu_noise_preset(name).map_err(|e| cfg.err(format!("[filter] {e}")))?;
        let how = if f.imu_preset.is_some() {
            "imu_preset"
        } else {
            "no noise given: the conservative MEMS default"
        };
        let src = format!("{how} {name:?} ({}; {})", s.sensor, s.source);
        let c = EskfConfig {
            noise: s.noise,
            scale_factors: true,
            ..EskfConfig::seed001()
        };
        sensor = Some(s);
        (c, src)
    };
    let platform = match (f.preset.as_str(), f.platform) {
        ("kf-gins", p) => p,
        ("enhanced", p) => Some(p.unwrap_or(Platform::Car)),
        ("seed001", p) => {
            ecfg = EskfConfig::seed001();
            noise_source = "the seed 001 preset".into();
            sensor = None;
            p
        }
        (p, _) => {
            return Err(cfg.err(format!(
                "[filter] preset {p:?}: expected kf-gins, enhanced or seed001"
            )))
        }
    };
    let mut profile = platform.map(Platform::profile);
    if let Some(pr) = &mut profile {
        override_constraints(cfg, pr)?;
        ecfg = pr.apply(ecfg);
    }
    // Adaptive constraint noise is opt-in (`adaptive = true`): NHC
    // violations of a real vehicle are dominated by constant or slowly
    // varying terms (mounting misalignment, lever from the axle), which an
    // innovation-based estimate does not see — it learns the white part and
    // makes the filter overconfident between GNSS fixes (on drive_0708 the
    // forward outage drift doubled with it). See `crate::profile`.
    let adaptive = match &profile {
        Some(pr) => {
            let full = pr.adaptive();
            let nhc = f.nhc.as_ref();
            let mut a = AdaptiveConstraints::default();
            if nhc.and_then(|n| n.adaptive) == Some(true) {
                a.nhc = full.nhc.map(|mut an| {
                    an.min_std = nhc.and_then(|n| n.min_std).unwrap_or(an.min_std);
                    an.max_std = nhc.and_then(|n| n.max_std).unwrap_or(an.max_std);
                    an
                });
            }
            if f.zupt.as_ref().and_then(|z| z.adaptive) == Some(true) {
                a.zupt = full.zupt;
                a.zaru = full.zaru;
            }
            a
        }
        None => AdaptiveConstraints::default(),
    };
    ecfg.lever_arm_b = Vec3::new(f.lever_arm[0], f.lever_arm[1], f.lever_arm[2]);
    if f.smooth {
        ecfg.smoother_every = 10;
    }
    // The NIS adaptation widens the GNSS σ where the filter's own GNSS
    // innovations say it is too small (module doc of `NisAdaptation`). It is
    // opt-in: the NIS cannot tell a too-small R from a too-small Q, and on the
    // simulated matrix (3 seeds, 600 s) widening R where the IMU model was the
    // short side cost accuracy: uav:consumer:rtk:0 h RMS 2.82 → 3.14 m,
    // pedestrian:consumer:consumer:0 3.18 → 3.79 m (other cells within 1 %).
    let nis_adaptation = f.nis_adaptation.unwrap_or(false).then(NisAdaptation::gnss);
    Ok(FilterSetup {
        eskf: ecfg,
        adaptive,
        nis_adaptation,
        profile,
        sensor,
        noise_source,
    })
}

/// `[filter.nhc]` and `[filter.zupt]` on top of the profile's constraints.
fn override_constraints(cfg: &RunConfig, pr: &mut Profile) -> Result<()> {
    let pos = |v: Option<f64>, key: &str| -> Result<Option<f64>> {
        match v {
            Some(x) if !(x.is_finite() && x >= 0.0) => {
                Err(cfg.err(format!("[filter] {key} = {x}: must be finite and ≥ 0")))
            }
            _ => Ok(v),
        }
    };
    // The NHC mounting states are opt-in: the profile's prior (a car's
    // where it has none) when asked, else none (see `crate::profile`).
    pr.nhc_mount = match cfg.filter.nhc.as_ref().and_then(|n| n.mount_states) {
        Some(true) => pr.nhc_mount.or(Platform::Car.profile().nhc_mount),
        _ => None,
    };
    if let Some(n) = &cfg.filter.nhc {
        if n.enabled == Some(false) {
            pr.nhc = None;
        } else {
            let mut c = pr.nhc.unwrap_or(NhcConfig {
                std: 0.5,
                interval: 0.1,
                min_speed: 0.5,
            });
            if let Some(m) = &mut pr.nhc_mount {
                let si = |v: [f64; 3]| Vec3::new(v[0].to_radians(), v[1].to_radians(), v[2]);
                if let Some(v) = n.mount_initial {
                    if !v.iter().all(|x| x.is_finite()) {
                        return Err(cfg.err("[filter.nhc] mount_initial must be finite"));
                    }
                    m.initial = si(v);
                }
                if let Some(v) = n.mount_std {
                    if !v.iter().all(|x| x.is_finite() && *x > 0.0) {
                        return Err(cfg.err("[filter.nhc] mount_std must be finite and > 0"));
                    }
                    m.std = si(v);
                }
            }
            c.std = pos(n.std, "nhc.std")?.unwrap_or(c.std);
            c.min_speed = pos(n.min_speed, "nhc.min_speed")?.unwrap_or(c.min_speed);
            c.interval = pos(n.interval, "nhc.interval")?.unwrap_or(c.interval);
            if c.std <= 0.0 {
                return Err(cfg.err("[filter] nhc.std must be > 0"));
            }
            pr.nhc = Some(c);
        }
    }
    if let Some(z) = &cfg.filter.zupt {
        if z.enabled == Some(false) {
            pr.zupt = None;
        } else {
            let mut c = pr.zupt.unwrap_or(
                Platform::Car
                    .profile()
                    .zupt
                    .unwrap_or_else(|| unreachable!("the car profile has a standstill detector")),
            );
            c.vel_std = pos(z.vel_std, "zupt.vel_std")?.unwrap_or(c.vel_std);
            if let Some(d) = pos(z.zaru_std_dps, "zupt.zaru_std_dps")? {
                c.zaru_std = (d > 0.0).then(|| d.to_radians());
            }
            c.max_accel_std =
                pos(z.max_accel_std, "zupt.max_accel_std")?.unwrap_or(c.max_accel_std);
            if let Some(d) = pos(z.max_gyro_std_dps, "zupt.max_gyro_std_dps")? {
                c.max_gyro_std = d.to_radians();
            }
            c.max_speed = pos(z.max_speed, "zupt.max_speed")?.unwrap_or(c.max_speed);
            if c.vel_std <= 0.0 {
                return Err(cfg.err("[filter] zupt.vel_std must be > 0"));
            }
            pr.zupt = Some(c);
        }
    }
    Ok(())
}

/// The ESKF configuration of `[filter]` ([`filter_setup`]'s `eskf`).
pub fn filter_config(cfg: &RunConfig, base_dir: &Path) -> Result<EskfConfig> {
    filter_setup(cfg, base_dir).map(|s| s.eskf)
}

/// Everything an in-memory ESKF run produced.
#[derive(Clone, Debug)]
pub struct EskfRun {
    /// Forward solutions (IMU position, NED velocity, attitude), one per IMU sample.
    pub solutions: Vec<NavSolution>,
    /// RTS-smoothed solutions in time order (empty unless `[filter] smooth`).
    pub smoothed: Vec<NavSolution>,
    /// 1-σ and aiding status of every forward solution, row for row
    /// (empty when the caller turned σ off, [`run_eskf_span`]).
    pub std: Vec<StdRow>,
    /// 1-σ of every smoothed solution (smoothed covariance; no status).
    pub smoothed_std: Vec<StdRow>,
    /// NIS sums per measurement type (the summary's `nis_check`).
    pub nis: NisMonitor,
    /// Seconds without an update after which an epoch is coasting.
    pub coast_after_s: f64,
    /// Every measurement update tried, in order (the innovation journal).
    pub updates: Vec<UpdateLog>,
    /// Update counters.
    pub stats: EskfStats,
    /// The filter configuration used.
    pub config: EskfConfig,
    /// How the filter was aligned (the summary's `alignment`).
    pub alignment: String,
    /// The alignment method ([`crate::align::Alignment::method`]), seconds
    /// from the first IMU sample to the filter start, initial yaw σ [deg].
    pub align_method: &'static str,
    pub align_wait_s: f64,
    pub align_yaw_std_deg: f64,
    /// Warnings for the user (summary.json `warnings`).
    pub warnings: Vec<String>,
    /// The constraint noise the adaptation learnt (σ per axis).
    pub adapted: AdaptedNoise,
    /// GNSS position and velocity R scales from the NIS: (λ at the end,
    /// windows, windows that raised λ, largest λ); `None` when off.
    pub nis_adaptation: Option<[(f64, u64, u64, f64); 2]>,
    /// The platform profile applied, if any.
    pub platform: Option<Platform>,
    /// Where the IMU noise came from.
    pub noise_source: String,
    /// Which augmented states ran and how their parameters were chosen
    /// ([`crate::gnss_error`]).
    pub augmented_states: String,
    /// Their final estimates (`None`: none ran).
    pub augmented: Option<navfuse_core::estimators::eskf::AugmentedEstimate>,
    /// Residual IMU–GNSS time offset estimated on the inputs (after any
    /// offset the loading applied), with its σ ([`auto_estimate`]); reported,
    /// not applied.
    pub time_offset_estimate: AutoOffset,
    /// IMU samples given, and of them before `[input] start`.
    pub imu_samples_read: usize,
    pub imu_samples_before_start: usize,
    /// GNSS fixes given, cut by `[outage]`, and handed to the filter.
    pub gnss_fixes_read: usize,
    pub gnss_fixes_cut_by_outage: usize,
    pub gnss_fixes_fed: usize,
    /// Wall-clock seconds of the filter loop.
    pub seconds_filter: f64,
    /// The IMU time offset [s] this in-memory run applied and how
    /// ([`run_eskf`] only; file runs report it from the loading).
    pub time_offset_applied: Option<(f64, String)>,
    /// The account of the offset passes ([`crate::offset_passes`]), when
    /// the offset was found that way.
    pub time_offset_passes: Option<String>,
    /// Tight coupling: every raw record by satellite and reason, the clock
    /// (summary.json `tight_coupling`); `None` when loosely coupled.
    pub tight: Option<crate::tight_run::TightAccount>,
    /// RTK: the account (summary.json `rtk`) and the applied epochs (the
    /// `.pos` quality); `None` / empty otherwise.
    pub rtk: Option<crate::rtk_run::RtkAccount>,
    pub rtk_epochs: Vec<crate::rtk_run::RtkEpochOut>,
}

impl EskfRun {
    /// The summary's `time_offset` text, given the offset the input loading
    /// applied (τ [s] and how), if any.
    pub fn time_offset_text(&self, applied: Option<&(f64, String)>) -> String {
        let note = time_offset_note(&self.time_offset_estimate, applied);
        match &self.time_offset_passes {
            Some(p) => format!("{note}; {p}"),
            None => note,
        }
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
    // The in-memory path applies `[input] imu_time_offset` itself (the file
    // path does it while loading, `crate::input::load`).
    let mode = match &cfg.input.imu_time_offset {
        None => default_mode(cfg),
        Some(TimeOffsetCfg::Seconds(s)) => TimeOffset::parse(&s.to_string())?,
        Some(TimeOffsetCfg::Named(n)) => TimeOffset::parse(n)?,
    };
    // With GNSS velocities the offset comes from filter passes, which assume
    // nothing about course and heading (`crate::offset_passes`, every
    // platform); without them the course estimate, where the course follows
    // the heading ([`crate::offset_passes::serves`]).
    let passes = match (&cfg.input.imu_time_offset, mode) {
        (None, _) | (_, TimeOffset::Auto) => crate::offset_passes::serves(gnss),
        _ => false,
    };
    if passes {
        let (retimed, latency) = crate::time_offset::latency_corrected(gnss);
        let gnss = retimed.as_deref().unwrap_or(gnss);
        let mut run = |imu: &[ImuSample]| {
            let span = select_span(cfg, imu, gnss)?;
            run_eskf_span(cfg, base_dir, &span, aux, true)
        };
        let p = crate::offset_passes::run_with_offset_passes(imu, gnss, &mut run)?;
        let note = crate::offset_passes::latency_note(latency) + &p.note;
        let mut r = match (
            &p.applied,
            crate::offset_passes::course_fallback(cfg, imu, gnss)?,
        ) {
            (None, Some((tau, how))) => {
                let shifted: Vec<ImuSample> = imu
                    .iter()
                    .map(|s| ImuSample { t: s.t + tau, ..*s })
                    .collect();
                let mut r = run(&shifted)?;
                r.time_offset_applied = Some((tau, how));
                r
            }
            _ => {
                let mut r = p.run;
                r.time_offset_applied = p.applied;
                r
            }
        };
        r.time_offset_passes = Some(note);
        return Ok(r);
    }
    let shifted: Vec<ImuSample>;
    let mut applied = None;
    let decided = if mode == TimeOffset::Auto {
        let mut run = |imu: &[ImuSample]| {
            let span = select_span(cfg, imu, gnss)?;
            run_eskf_span(cfg, base_dir, &span, aux, false)
        };
        crate::offset_passes::decide_positions_only(imu, gnss, &mut run)?.0
    } else {
        mode.resolve(imu, gnss)?
    };
    let imu = match decided {
        Some((tau, how)) => {
            shifted = imu
                .iter()
                .map(|s| ImuSample { t: s.t + tau, ..*s })
                .collect();
            applied = Some((tau, how));
            &shifted[..]
        }
        None => imu,
    };
    let span = select_span(cfg, imu, gnss)?;
    let mut r = run_eskf_span(cfg, base_dir, &span, aux, true)?;
    r.time_offset_applied = applied;
    Ok(r)
}

/// Switch the filter to tight coupling. Not inlined: the filter is moved
/// by value here, and that copy must not enlarge [`run_eskf_span`]'s stack
/// frame (it runs on 2 MiB worker threads in the experiments).
#[inline(never)]
fn make_tight(cfg: &RunConfig, eskf: &mut Eskf) -> Result<()> {
    *eskf = eskf
        .clone()
        .with_tight_coupling(crate::tight_run::tight_config())
        .map_err(|e| cfg.err(format!("[filter] coupling = \"tight\": {e}")))?;
    #[cfg(test)]
    if crate::tight_run::diag::KEEP_PRIOR.with(|c| c.get()) {
        return Ok(());
    }
    eskf.forget_position_prior(crate::tight_run::POSITION_PRIOR_RESET_M);
    Ok(())
}

/// Switch the filter to RTK (after the alignment, as [`make_tight`]).
#[inline(never)]
fn make_rtk(
    cfg: &RunConfig,
    eskf: &mut Eskf,
    rc: navfuse_core::estimators::eskf::RtkConfig,
) -> Result<()> {
    *eskf = eskf
        .clone()
        .with_rtk(rc)
        .map_err(|e| cfg.err(format!("[filter] coupling = \"rtk\": {e}")))?;
    Ok(())
}

/// [`run_eskf`] on a selected span; `with_std`: keep the σ rows of every
/// solution ([`EskfRun::std`]).
///
/// Not inlined: its frame holds several ESKFs (≈ 100 kB each) while they are
/// built; inlined into the offset passes' callers once per call site it
/// took 2.1 MB of stack (measured with `RUST_MIN_STACK`), past the 2 MiB
/// of rayon's and the test harness's threads; out of line, 1.2–1.5 MB.
#[inline(never)]
pub(crate) fn run_eskf_span(
    cfg: &RunConfig,
    base_dir: &Path,
    span: &Span,
    aux: Option<&AuxSeries>,
    with_std: bool,
) -> Result<EskfRun> {
    let mut setup = filter_setup(cfg, base_dir)?;
    // Noise from a sensor preset (datasheet, quiet bench) is raised to the
    // white noise the recording shows (vibration), never lowered.
    if setup.sensor.is_some() {
        if let Some((g, a)) = measured_white_noise(span.imu) {
            let n = &mut setup.eskf.noise;
            if g > n.arw.max() || a > n.vrw.max() {
                setup.noise_source += &format!(
                    "; white noise raised to the level the recording shows (vibration): \
                     ARW {:.3}°/√h, VRW {:.4} m/s/√h measured, datasheet {:.3}°/√h, {:.4} m/s/√h",
                    g.to_degrees() * 60.0,
                    a * 60.0,
                    n.arw.max().to_degrees() * 60.0,
                    n.vrw.max() * 60.0
                );
                n.arw = n.arw.map(|x| x.max(g));
                n.vrw = n.vrw.map(|x| x.max(a));
            }
        }
    }
    // `[filter] heading_source` and the inputs' aiding events, time-ordered.
    let aids =
        crate::aiding_cfg::merge_aids(span.aiding, crate::cp_att_run::heading_aids(cfg, base_dir)?);
    let mut ecfg = setup.eskf;
    ecfg.aiding = crate::aiding_cfg::resolve(cfg, &aids, ecfg.nhc)?;
    let (imu, gnss) = (span.imu, &span.gnss[..]);
    let model = AlignModel {
        noise: &ecfg.noise,
        sensor: setup.sensor.as_ref(),
        profile: setup.profile.as_ref(),
        lever_arm_b: ecfg.lever_arm_b,
    };
    let mut a = align(cfg, imu, gnss, aux, &model)?;
    let tight = span.tight.as_ref();
    let rtk = span.rtk;
    let raw_coupled = tight.is_some() || rtk.is_some();
    let (aug, augmented_states) = if raw_coupled {
        // The fix-error states model a receiver's position solution; the
        // tight filter weights each satellite instead.
        for (key, given) in [
            ("[filter.gnss_error]", cfg.filter.gnss_error.is_some()),
            (
                "[filter] time_offset_state",
                cfg.filter.time_offset_state.is_some(),
            ),
        ] {
            if given {
                return Err(cfg.err(format!(
                    "{key} is for loosely coupled fixes; [filter] coupling = \"{}\" \
                     carries no augmented states (remove the key or use coupling = \"loose\")",
                    if rtk.is_some() { "rtk" } else { "tight" }
                )));
            }
        }
        (
            Default::default(),
            if rtk.is_some() {
                "none (RTK: the satellites' errors cancel in the double differences)"
            } else {
                "none (tight coupling: each satellite's slowly varying error is a consider \
                 state of the tight filter)"
            }
            .to_string(),
        )
    } else {
        let (mut aug, mut how) = crate::gnss_error::augmented_states(cfg, gnss)?;
        // Set by `override_constraints` only when asked for.
        aug.nhc_mount = setup
            .profile
            .as_ref()
            .filter(|p| p.nhc.is_some())
            .and_then(|p| p.nhc_mount);
        if let Some(m) = aug.nhc_mount {
            how += &format!(
                "{}NHC mounting states estimated from pitch {:.2} ± {:.2}°, yaw {:.2} ± {:.2}°, \
                 forward lever {:.2} ± {:.2} m",
                if how.is_empty() { "" } else { "; " },
                m.initial.x.to_degrees(),
                m.std.x.to_degrees(),
                m.initial.y.to_degrees(),
                m.std.y.to_degrees(),
                m.initial.z,
                m.std.z
            );
        }
        (aug, how)
    };
    let new_eskf = |nav, errors, std: &InitStd| {
        let e = Eskf::new(ecfg, nav, errors, std);
        if a.tilt_from_force {
            e.with_tilt_from_force()
        } else {
            e
        }
        .with_adaptive_noise(setup.adaptive)
        .map_err(|e| cfg.err(format!("[filter] adaptive constraint noise: {e:?}")))?
        .with_augmented_states(aug)
        .map_err(|e| cfg.err(format!("[filter] augmented states: {e}")))
        .and_then(|e| match setup.nis_adaptation {
            None => Ok(e),
            Some(n) => e
                .with_nis_adaptation(n)
                .ok_or_else(|| cfg.err("[filter] nis_adaptation: invalid settings")),
        })
    };
    let k_start = a.k_start;
    let t_filter = Instant::now();
    let coast_after_s = crate::sigma::coast_after_s(gnss);
    let t_track = imu[k_start].t;
    let g0 = gnss.partition_point(|x| x.t <= imu[k_start].t);
    let cap = imu.len() - k_start;
    let (mut m, k_next, mut g, mut gnss_fed) = if a.hypotheses.len() > 1 {
        // Members reserve 10 s of solutions (most are dropped within seconds).
        let dt = imu[k_start].dt.max(1e-4);
        let cap = cap.min((10.0 / dt) as usize + 1);
        let members = a
            .hypotheses
            .iter()
            .map(|h| {
                let mut m = Member::new(new_eskf(h.nav, h.errors, &h.std)?, cap).tracking(
                    t_track,
                    coast_after_s,
                    with_std,
                );
                m.score = h.neg_ln_prior;
                Ok(m)
            })
            .collect::<Result<Vec<_>>>()?;
        let b = run_bank(members, imu, gnss, k_start, g0, a.bank_gate);
        a.description += &format!("; {}", b.description);
        // The initial yaw σ of the member that won, not the mixture's.
        if let Some(s) = b.winner.sols.first() {
            a.yaw_std = s.std_rpy.z;
        }
        (b.winner, b.k_next, b.g_next, b.gnss_fed)
    } else {
        (
            Member::new(new_eskf(a.nav, a.errors, &a.init_std)?, cap).tracking(
                t_track,
                coast_after_s,
                with_std,
            ),
            k_start,
            g0,
            0,
        )
    };
    // Tight coupling from the end of the alignment on: the alignment (and
    // a yaw bank) used the SPP fixes of the same epochs.
    if tight.is_some() {
        make_tight(cfg, &mut m.eskf)?;
        g = gnss.len();
    }
    if let Some(r) = rtk {
        // A yaw bank was aided by the single-point fixes, whose errors are
        // correlated over minutes (atmosphere, multipath) but were weighted
        // as white: its position σ is then far below its error. Before the
        // carrier phase ties the ambiguities to that position, its σ is
        // raised to the last fix's own (measured: a walker's bank handed
        // over 2 m E / 3 m U off with decimetre σ, and the RTK float took
        // minutes to recover and never fixed; `rtk_run_tests`).
        if gnss_fed > 0 {
            if let Some(f) = gnss[..g].last() {
                let added = m.eskf.floor_position_std(&f.std_ned);
                if added.max() > 0.0 {
                    a.description += &format!(
                        "; at the switch to RTK the position σ raised to the last \
                         single-point fix's ({:.2}, {:.2}, {:.2} m N, E, D)",
                        f.std_ned.x, f.std_ned.y, f.std_ned.z
                    );
                }
            }
        }
        make_rtk(cfg, &mut m.eskf, r.cfg)?;
        g = gnss.len();
    }
    // σ under a correlated fix error from here on (the bank's decisions
    // above used the filter's own σ; the solutions are unchanged). Not with
    // tight coupling (its gain follows the 21-state update only).
    let sigma = if raw_coupled {
        crate::gnss_error::SigmaModels::default()
    } else {
        crate::gnss_error::sensitivity_model(cfg, gnss, Some(imu))
    };
    if let Some(sm) = sigma.forward {
        m.eskf
            .start_sensitivity(sm)
            .map_err(|e| cfg.err(format!("[filter.gnss_error] sensitivity: {e}")))?;
    }
    if let Some(sm) = sigma.smoothed {
        // The smoothed σ's correlated part (a no-op without the smoother).
        m.eskf
            .start_smoother_sensitivity(sm)
            .map_err(|e| cfg.err(format!("[filter.gnss_error] smoothed sensitivity: {e}")))?;
    }
    let sens_how = sigma.how;
    let augmented_states = if sens_how.is_empty() {
        augmented_states
    } else {
        format!("{augmented_states}; {sens_how}")
    };
    // Aiding events from the start of the remaining IMU span on (those
    // during a yaw bank are not used), merged with the fixes in time order.
    // A bank that ran to the end of the data leaves no IMU sample: every
    // event is then before the (empty) rest.
    let t_next = imu.get(k_next).map_or(f64::INFINITY, |s| s.t - s.dt);
    let mut fed = tight.map(|t| t.fed.clone());
    let merged: Vec<Event>;
    let heads = match (tight, &mut fed) {
        (Some(ti), Some(fed)) => {
            let mut v = aids.clone();
            for r in &ti.records {
                if r.obs.t <= t_next {
                    crate::tight_run::Fed::count(&mut fed.before, r);
                } else {
                    crate::tight_run::Fed::count(&mut fed.fed, r);
                    v.push(Event::RawGnss(*r));
                }
            }
            // Stable: at equal times the aiding events, then the records
            // in their epoch order.
            v.sort_by(|a, b| a.t().total_cmp(&b.t()));
            merged = v;
            &merged
        }
        _ => &aids,
    };
    let mut h = heads.partition_point(|x| x.t() <= t_next);
    let mut driver = rtk.map(|r| crate::rtk_run::RtkDriver::new(r, t_next, coast_after_s));
    for s in &imu[k_next..] {
        let mut g1 = g;
        while g < gnss.len() && gnss[g].t <= s.t + 1e-3 {
            g += 1;
        }
        gnss_fed += g - g1;
        while h < heads.len() && heads[h].t() <= s.t {
            while g1 < g && gnss[g1].t <= heads[h].t() {
                m.aid(&Event::Gnss(gnss[g1]));
                g1 += 1;
            }
            m.aid(&heads[h]);
            h += 1;
        }
        m.step(&gnss[g1..g], s);
        if let Some(d) = &mut driver {
            d.after_imu(&mut m, s.t, s.dt);
        }
    }
    let (rtk_account, rtk_epochs) = match driver {
        Some(d) => (Some(d.account(&m.eskf)), d.out),
        None => (None, Vec::new()),
    };
    let tight_account = match (tight, &fed, m.eskf.tight_stats()) {
        (Some(ti), Some(fed), Some(st)) => {
            Some(crate::tight_run::account(ti.input, fed, st, m.eskf.clock()))
        }
        _ => None,
    };
    let (eskf, sols, records, innovations) = (m.eskf, m.sols, m.records, m.innovations);
    let (std, nis) = (m.std, m.nis);
    let seconds_filter = t_filter.elapsed().as_secs_f64();
    let mut smoothed = Vec::new();
    let mut smoothed_std = Vec::new();
    if cfg.filter.smooth {
        smoothed.reserve(records.len());
        rts_smooth(&records, eskf.last_record_covariance(), |e| {
            if with_std {
                smoothed_std.push(crate::sigma::std_row(e.t, &e.p_diag, e.p_pos_cross, None));
            }
            smoothed.push(smoothed_solution(e));
        });
        smoothed.reverse();
        smoothed_std.reverse();
    }
    Ok(EskfRun {
        solutions: sols,
        smoothed,
        std,
        smoothed_std,
        nis,
        coast_after_s,
        updates: innovations,
        stats: *eskf.stats(),
        config: *eskf.config(),
        alignment: a.description,
        align_method: a.method,
        align_wait_s: a.wait_s,
        align_yaw_std_deg: a.yaw_std.to_degrees(),
        warnings: a.warnings,
        adapted: eskf.adapted_noise(),
        nis_adaptation: eskf.nis_adaptation(),
        platform: setup.profile.map(|p| p.platform),
        noise_source: setup.noise_source,
        augmented_states,
        augmented: eskf.augmented(),
        time_offset_estimate: auto_estimate(imu, span.gnss_all),
        imu_samples_read: imu.len() + span.imu_before_start,
        imu_samples_before_start: span.imu_before_start,
        gnss_fixes_read: span.gnss_all.len(),
        gnss_fixes_cut_by_outage: span.cut(),
        gnss_fixes_fed: gnss_fed,
        seconds_filter,
        time_offset_applied: None,
        time_offset_passes: None,
        tight: tight_account,
        rtk: rtk_account,
        rtk_epochs,
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
        let imu = crate::level_imu(t0, 6000, dt, g);
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
