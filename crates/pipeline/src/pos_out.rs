//! The run's RTKLIB `.pos` output (`formats = ["pos"]`): position, σ and
//! the NED cross covariances from the filter covariance
//! ([`navfuse_io::pos_writer`]), and an honest RTKLIB quality flag.
//!
//! Q of an epoch ([`rtklib_q`]): the quality the input reported for the last
//! GNSS position fix the filter accepted, when that fix is at most
//! `coast_after_s` old ([`crate::sigma::coast_after_s`]); 5 (single) when the
//! input did not report one (KF-GINS text, CSV: the weakest GNSS class is
//! the claim that cannot overstate); 7 (RTKLIB `SOLQ_DR`, dead reckoning)
//! when the epoch is coasting or the last position update was not a GNSS
//! fix (height only); 0 when the epoch has no status (`--no-std`). ns: the
//! satellites of that fix (0 when coasting). Smoothed epochs take the
//! forward filter's status at the same time: the smoother does not add
//! measurements, so an epoch inside an outage stays 7.

use crate::error::{PipelineError, Result};
use navfuse_core::estimators::consistency::EpochStatus;
use navfuse_core::types::{GnssFix, NavSolution};
use navfuse_io::pos_writer::{PosEpoch, PosWriter, Q_DR, Q_SINGLE};
use navfuse_io::stdfile::StdRow;
use std::path::Path;

/// Time tolerance when matching an update to its fix [s]: the one used when
/// feeding fixes to the filter (a fix is fed with the first IMU sample at or
/// after `fix.t − 1 ms`).
const MATCH_S: f64 = 1e-3;

/// Q and ns of an epoch at `t` with aiding `status` (module doc); `gnss`
/// sorted by time.
pub fn rtklib_q(
    t: f64,
    status: Option<&EpochStatus>,
    gnss: &[GnssFix],
    coast_after_s: f64,
) -> (u8, u8) {
    let Some(st) = status else { return (0, 0) };
    // NaN since_pos_s (never) counts as coasting too.
    if st.since_pos_s.is_nan() || st.since_pos_s > coast_after_s {
        return (Q_DR, 0);
    }
    let t_pos = t - st.since_pos_s;
    let i = gnss.partition_point(|f| f.t <= t_pos + MATCH_S);
    match i.checked_sub(1).map(|k| &gnss[k]) {
        Some(f) if t - f.t <= coast_after_s + MATCH_S => {
            let q = if (1..=6).contains(&f.quality) {
                f.quality
            } else {
                Q_SINGLE
            };
            (q, f.num_sats)
        }
        _ => (Q_DR, 0),
    }
}

/// Write `path` from `sols` and their σ rows `std` (same length, row for
/// row; empty: σ and cross terms from the solutions / unknown). `status_of`
/// gives the forward status at a time when a row has none (smoothed rows).
/// Returns the path written.
/// RTK quality ([`crate::rtk_run`]): the state of the last RTK epoch at or
/// before `t` (1 fixed, 2 float, with its satellites, ratio and age) until
/// `coast_after_s` has passed, then 7 (dead reckoning); 7 before the first.
pub fn rtk_q(e: &mut PosEpoch, t: f64, epochs: &[crate::rtk_run::RtkEpochOut], coast_after_s: f64) {
    let i = epochs.partition_point(|x| x.t <= t + 1e-9);
    match i.checked_sub(1).map(|k| &epochs[k]) {
        Some(x) if t - x.t <= coast_after_s + MATCH_S => {
            e.q = x.q;
            e.ns = x.ns;
            e.ratio = x.ratio;
            e.age_s = x.age_s;
        }
        _ => {
            e.q = Q_DR;
            e.ns = 0;
        }
    }
}

pub fn write_pos(
    path: &Path,
    sols: &[NavSolution],
    std: &[StdRow],
    forward: &[StdRow],
    gnss: &[GnssFix],
    coast_after_s: f64,
    rtk: Option<&[crate::rtk_run::RtkEpochOut]>,
) -> Result<String> {
    let write = || -> std::io::Result<()> {
        // Whole or absent: a temp file beside `path`, renamed on success.
        let mut f = navfuse_io::atomic::AtomicFile::create(path)?;
        let mut w = PosWriter::new(std::io::BufWriter::with_capacity(1 << 16, &mut f));
        for (k, s) in sols.iter().enumerate() {
            let row = std.get(k).filter(|r| (r.t - s.t).abs() <= 1e-6);
            let status = row.and_then(|r| r.status).or_else(|| {
                let i = forward.partition_point(|r| r.t < s.t - 1e-6);
                forward
                    .get(i)
                    .filter(|r| (r.t - s.t).abs() <= 1e-6)
                    .and_then(|r| r.status)
            });
            let (q, ns) = rtklib_q(s.t, status.as_ref(), gnss, coast_after_s);
            let mut e = PosEpoch {
                q,
                ns,
                pos_cross_ned: row.map_or(PosEpoch::UNKNOWN.pos_cross_ned, |r| r.pos_cross_ned),
                ..PosEpoch::UNKNOWN
            };
            if let Some(ep) = rtk {
                rtk_q(&mut e, s.t, ep, coast_after_s);
            }
            w.write_epoch(s, &e)?;
        }
        navfuse_io::writers::TrajectoryWriter::finish(&mut w)?;
        drop(w);
        f.commit()
    };
    write().map_err(PipelineError::io(path, ""))?;
    Ok(path.display().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use navfuse_core::estimators::eskf::UpdateKind;

    fn fix(t: f64, quality: u8, num_sats: u8) -> GnssFix {
        GnssFix {
            t,
            quality,
            num_sats,
            ..Default::default()
        }
    }

    #[test]
    fn q_is_the_last_fix_quality_then_dead_reckoning() {
        let gnss = [fix(10.0, 1, 21), fix(11.0, 2, 19), fix(12.0, 0, 0)];
        let st = |since: f64| EpochStatus {
            aid: Some(UpdateKind::GnssPosition),
            since_pos_s: since,
            gated_10s: 0,
        };
        // 0.3 s after the float fix at 11 s (update logged 0.5 ms after it).
        assert_eq!(rtklib_q(11.3, Some(&st(0.2995)), &gnss, 2.5), (2, 19));
        assert_eq!(rtklib_q(10.2, Some(&st(0.2)), &gnss, 2.5), (1, 21));
        // Quality not reported by the input → single.
        assert_eq!(rtklib_q(12.1, Some(&st(0.1)), &gnss, 2.5), (Q_SINGLE, 0));
        // Coasting.
        assert_eq!(rtklib_q(14.0, Some(&st(3.0)), &gnss, 2.5), (Q_DR, 0));
        // Last position update a height (no fix near it, last fix too old).
        let g2 = [fix(10.0, 1, 21)];
        assert_eq!(rtklib_q(13.0, Some(&st(0.5)), &g2, 2.5), (Q_DR, 0));
        assert_eq!(rtklib_q(13.0, None, &g2, 2.5), (0, 0));
    }

    /// A run with `formats = ["pos"]` and the smoother: `solution.pos` reads
    /// back with the io reader, row for row equal to `solution.nav`/`.std`
    /// to the printed decimals, every fixed epoch Q 5 (the KF-GINS GNSS text
    /// reports no quality), cross terms present and within Cauchy–Schwarz.
    #[test]
    fn run_writes_pos_that_reads_back() {
        let dir = crate::test_dir("run-pos");
        crate::run_tests::write_north_drive(&dir);
        let toml = "formats = [\"pos\"]\n[input]\nimu = \"imu.txt\"\ngnss = \"gnss.txt\"\n\
                    [filter]\nsmooth = true\n";
        std::fs::write(dir.join("run.toml"), toml).unwrap();
        let out = dir.join("out");
        crate::run_tests::run_to(&dir.join("run.toml"), &out).unwrap();
        for stem in ["solution", "solution_smoothed"] {
            let std = navfuse_io::stdfile::read_std_file(&out.join(format!("{stem}.std"))).unwrap();
            let p = out.join(format!("{stem}.pos"));
            let mut r = navfuse_io::pos::PosReader::new(
                std::io::BufReader::new(std::fs::File::open(&p).unwrap()),
                "solution.pos",
            );
            let mut n = 0;
            let mut q5 = 0;
            while let Some(f) = r.next() {
                let f = f.unwrap();
                let s = &std[n];
                assert!((f.t - s.t).abs() < 1e-6, "{stem} row {n}");
                for a in 0..3 {
                    assert!(
                        (f.std_ned[a] - s.pos_ned[a]).abs() <= 0.5e-4 + 1e-9,
                        "{stem} {n}"
                    );
                }
                let x = r.cross_ned();
                assert!(x.iter().all(|v| v.is_finite()), "{stem} {n}: {x}");
                // |sdne| ≤ √(sdn·sde) up to the printed decimals.
                let sd = f.std_ned;
                assert!(x.x.abs() <= sd.x * sd.y + 1e-3, "{stem} {n}: {x} {sd}");
                q5 += usize::from(f.quality == Q_SINGLE);
                n += 1;
            }
            assert_eq!(n, std.len(), "{stem}");
            assert!(q5 > n / 2, "{stem}: {q5} of {n} epochs Q 5");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
