//! Running every method on one data set and scoring it.

use super::*;

pub(super) fn ned_err(frame: &LocalFrame, est: &Geodetic, truth: &Geodetic) -> f64 {
    let d = frame.ned(est) - frame.ned(truth);
    (d.x * d.x + d.y * d.y).sqrt()
}

/// The ESKF (seed 001 filter, `navfuse_core::estimators::eskf`) configured
/// for an ADIS16365-grade IMU and 5 m GNSS, with the non-holonomic
/// constraint; no GNSS velocity (the fixes have none).
pub(super) fn eskf_config() -> EskfConfig {
    let mut c = EskfConfig::seed001();
    c.noise.arw = Vec3::repeat(0.08 * DEG);
    c.noise.vrw = Vec3::repeat(9e-3 * G * 0.1);
    c.noise.bg_std = Vec3::repeat(0.02 * DEG);
    c.noise.ba_std = Vec3::repeat(5e-3);
    c.gate_probability = None;
    c.use_gnss_velocity = false;
    c.nhc = Some(NhcConfig {
        std: 0.1,
        interval: 0.1,
        min_speed: 1.0,
    });
    c
}

/// Start the ESKF from the original-LC state once its yaw is known (no
/// magnetometer: the yaw comes from the GNSS course, roll/pitch and the gyro
/// bias from the static alignment of the attitude KF).
pub(super) fn start_eskf(lc: &PfLc, sol: &NavSolution) -> Box<Eskf> {
    let att = lc.attitude();
    let nav = NavState {
        lat: sol.lat,
        lon: sol.lon,
        h: sol.h,
        v_n: sol.v_n,
        q_bn: q_bn_from_rpy(&att.rpy()),
    };
    let errors = ImuErrors {
        bg: *att.gyro_bias(),
        ..Default::default()
    };
    let std = InitStd {
        pos: Vec3::new(3.0, 3.0, 5.0),
        vel: Vec3::repeat(1.0),
        att: Vec3::new(2.0 * DEG, 2.0 * DEG, 30.0 * DEG),
        bg: Vec3::repeat(0.2 * DEG),
        ba: Vec3::repeat(0.2),
        sg: Vec3::zeros(),
        sa: Vec3::zeros(),
    };
    Box::new(Eskf::new(eskf_config(), nav, errors, &std))
}

/// Errors of one fix epoch: raw, compensated, SIR, LC original, LC
/// proposed, ESKF (NaN when a method has no output yet).
pub(super) type EpochErr = [f64; 6];

/// Legend names of the [`Series`] kept for `--report`.
pub(super) const SERIES_NAMES: [&str; 5] = [
    "raw GPS",
    "compensated GPS",
    "original LC",
    "proposed LC",
    "ESKF",
];

/// The solutions one run scores, kept for `--report`: per method of
/// [`SERIES_NAMES`] the position it is scored with, and the truth at each fix.
#[derive(Default)]
pub(super) struct Series {
    pub(super) sols: [Vec<NavSolution>; 5],
    pub(super) truth: Vec<NavSolution>,
}

/// Run every method on `ds` and score it; keep the scored solutions in
/// `keep` when given.
pub(super) fn run_methods(
    ds: &DataSet,
    cfg: &PfLcConfig,
    sir_seed: u64,
    mut keep: Option<&mut Series>,
) -> Scores {
    let first_fix = ds.events.iter().find_map(|e| match e {
        Event::Gnss(f) => Some(*f),
        _ => None,
    });
    let Some(first_fix) = first_fix else {
        return Scores::default();
    };
    let origin = Geodetic {
        lat: first_fix.lat,
        lon: first_fix.lon,
        h: first_fix.h,
    };
    let frame = LocalFrame::new(origin);
    let plane = SmallAreaPlane::new(origin);
    let mut comp = Compensator::new(cfg.compensation);
    let mut sir: Box<SirPf<N_PARTICLES>> = Box::new(SirPf::new(SirConfig {
        seed: sir_seed,
        ..Default::default()
    }));
    let mut lc_o = PfLc::new(PfLcConfig {
        input: GpsInput::Raw,
        ..*cfg
    });
    let mut lc_p = PfLc::new(PfLcConfig {
        input: GpsInput::Compensated,
        ..*cfg
    });
    let mut eskf: Option<Box<Eskf>> = None;
    // The ESKF applies a fix at the next IMU sample: score it there.
    let mut eskf_pending: Option<usize> = None;
    let mut errs: Vec<EpochErr> = Vec::with_capacity(ds.truth.len());
    let mut times: Vec<f64> = Vec::with_capacity(ds.truth.len());
    let to_geo = |s: &NavSolution| Geodetic {
        lat: s.lat,
        lon: s.lon,
        h: s.h,
    };
    for ev in &ds.events {
        let so = lc_o.push(ev);
        let sp = lc_p.push(ev);
        if let Some(f) = eskf.as_mut() {
            f.push(ev);
        }
        match ev {
            Event::Imu(_) => {
                if let (Some(k), Some(f)) = (eskf_pending.take(), eskf.as_ref()) {
                    let s = f.solution();
                    errs[k][5] = ned_err(&frame, &to_geo(&s), &ds.truth[k]);
                    if let Some(r) = keep.as_deref_mut() {
                        r.sols[4].push(s);
                    }
                }
            }
            Event::Gnss(f) => {
                let k = errs.len();
                let truth = ds.truth[k];
                let geo = Geodetic {
                    lat: f.lat,
                    lon: f.lon,
                    h: f.h,
                };
                let p = plane.forward(&geo);
                let back = |n: f64, e: f64| plane.inverse(&PlanePoint { north: n, east: e }, f.h);
                let mut e = [f64::NAN; 6];
                e[0] = ned_err(&frame, &geo, &truth);
                let at = |g: &Geodetic| navfuse_report::build::position_at(f.t, g.lat, g.lon, g.h);
                if let Some(r) = keep.as_deref_mut() {
                    r.truth.push(at(&truth));
                    r.sols[0].push(at(&geo));
                }
                if let Some(c) = comp.push(f.t, p.north, p.east) {
                    let g = back(c.north, c.east);
                    e[1] = ned_err(&frame, &g, &truth);
                    if let Some(r) = keep.as_deref_mut() {
                        r.sols[1].push(at(&g));
                    }
                }
                if let Some(s) = sir.push(f.t, p.north, p.east) {
                    e[2] = ned_err(&frame, &back(s[0], s[1]), &truth);
                }
                if let Some(so) = so {
                    e[3] = ned_err(&frame, &to_geo(&so), &truth);
                    if let Some(r) = keep.as_deref_mut() {
                        r.sols[2].push(so);
                    }
                    if eskf.is_none()
                        && lc_o.attitude().stats().course_updates >= ESKF_START_COURSES
                    {
                        eskf = Some(start_eskf(&lc_o, &so));
                    }
                }
                if let Some(sp) = sp {
                    e[4] = ned_err(&frame, &to_geo(&sp), &truth);
                    if let Some(r) = keep.as_deref_mut() {
                        r.sols[3].push(sp);
                    }
                }
                if eskf.is_some() {
                    eskf_pending = Some(k);
                }
                errs.push(e);
                times.push(f.t);
            }
            _ => {}
        }
    }
    // Common epochs: after the warm-up and once every method has an output.
    let nc = ds.corners.len();
    let mut sums = [0.0f64; 6];
    let mut n = 0usize;
    let mut csum = vec![[0.0f64; 3]; nc];
    let mut cn = vec![0usize; nc];
    for (e, &t) in errs.iter().zip(times.iter()) {
        if t < first_fix.t + WARMUP_S || e.iter().any(|x| !x.is_finite()) {
            continue;
        }
        for (a, b) in sums.iter_mut().zip(e.iter()) {
            *a += b;
        }
        n += 1;
        for (i, &(t0, t1)) in ds.corners.iter().enumerate() {
            if t >= t0 && t <= t1 + CORNER_TAIL_S {
                csum[i][0] += e[0];
                csum[i][1] += e[3];
                csum[i][2] += e[4];
                cn[i] += 1;
            }
        }
    }
    let nf = n.max(1) as f64;
    Scores {
        raw: sums[0] / nf,
        comp: sums[1] / nf,
        sir: sums[2] / nf,
        lc_orig: sums[3] / nf,
        lc_prop: sums[4] / nf,
        eskf: sums[5] / nf,
        epochs: n,
        corners: csum
            .iter()
            .zip(cn.iter())
            .map(|(s, &c)| {
                // A corner with no scored epoch (before every method started) is NaN.
                let c = if c == 0 { f64::NAN } else { c as f64 };
                [s[0] / c, s[1] / c, s[2] / c]
            })
            .collect(),
        pv_gated: lc_o.pv().stats().gated + lc_p.pv().stats().gated,
        comp_reanchored: lc_p.compensator().stats().reanchored,
        course_resets: lc_o.attitude().stats().course_resets
            + lc_p.attitude().stats().course_resets,
        sir_reinits: sir.stats().reinits,
    }
}

pub(super) fn average(runs: &[Scores]) -> Scores {
    let n = runs.len().max(1) as f64;
    let nc = runs.first().map_or(0, |r| r.corners.len());
    let mut out = Scores {
        corners: vec![[0.0; 3]; nc],
        ..Default::default()
    };
    for r in runs {
        out.raw += r.raw / n;
        out.comp += r.comp / n;
        out.sir += r.sir / n;
        out.lc_orig += r.lc_orig / n;
        out.lc_prop += r.lc_prop / n;
        out.eskf += r.eskf / n;
        out.epochs += r.epochs;
        out.pv_gated += r.pv_gated;
        out.comp_reanchored += r.comp_reanchored;
        out.course_resets += r.course_resets;
        out.sir_reinits += r.sir_reinits;
    }
    // Corners: mean over the runs in which the corner was scored.
    for (i, o) in out.corners.iter_mut().enumerate() {
        let ok: Vec<&[f64; 3]> = runs
            .iter()
            .filter_map(|r| r.corners.get(i))
            .filter(|c| c.iter().all(|x| x.is_finite()))
            .collect();
        for j in 0..3 {
            o[j] = if ok.is_empty() {
                f64::NAN
            } else {
                ok.iter().map(|c| c[j]).sum::<f64>() / ok.len() as f64
            };
        }
    }
    out
}

/// Sample standard deviation of one score over the runs.
pub(super) fn spread(runs: &[Scores], f: impl Fn(&Scores) -> f64) -> f64 {
    let n = runs.len() as f64;
    if n < 2.0 {
        return f64::NAN;
    }
    let m = runs.iter().map(&f).sum::<f64>() / n;
    (runs.iter().map(|r| (f(r) - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
}
