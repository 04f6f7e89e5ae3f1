//! Per-seed time series of one cell (an ignored test, printed): yaw error
//! and σ, horizontal error of the default and its variants (`honesty_diag`
//! tweaks, plus `truthinit` = the oracle's initial state with the default's
//! everything else, `trueyaw` = only the true heading given), to find what makes a seed of a cell go wrong.
//!
//! `DIAG_CELL=uav:consumer:consumer:0 DIAG_SEEDS=1,3 DIAG_VARIANTS=default,truthinit
//! cargo test --release -p navfuse-pipeline uav_diag -- --ignored --nocapture`
//! (`DIAG_EVERY` s between rows, `DIAG_UNTIL` s after motion start,
//! `DIAG_GNSS_RATE` Hz instead of the grade's 1 Hz,
//! `DIAG_TRUTH` prints the first 25 s of true yaw and velocity,
//! `DIAG_IDEAL` = `experiment rtk --ideal-imu`'s comma list,
//! `gyro-misalignment`, `accel-misalignment`, `g-sensitivity`, removes
//! those simulated IMU terms, which the 21-state filter does not model). Each row gives,
//! per variant, the yaw error and σ, the horizontal error, the z-gyro bias
//! σ, the roll error, the pitch error / σ and the horizontal velocity error.
//!
//! Findings on uav:consumer:consumer:0 (main's 10-seed cell: default 8.78 m
//! h RMS against the oracle's 3.79 m):
//! - One seed carries it: seed 3, default 25.3 m, oracle 6.58 m, and the
//!   default given the oracle's initial state (`truthinit`) 6.67 m, so the
//!   alignment is the cause, not the GNSS error model or the time offset.
//!   The other moving-start (odd) seeds are 1.1–1.4× the oracle.
//! - Mechanism (bank debug prints, seed 3, true z-gyro bias −0.65°/s
//!   against the consumer turn-on σ 0.5°/s): the yaw is unobservable in the
//!   first 9 s of cruise, every member drifts by the unestimated bias; at
//!   the first acceleration the members started 7.5° and 12.5° off the
//!   truth (hypotheses −110° and −90°, truth −102.5°) reach one yaw with z-bias
//!   estimates −0.44 and +0.17°/s: each split its yaw error between ψ₀ and
//!   b·t (not separable from one manoeuvre). They merge on yaw alone
//!   (`yaw_bank::prune`), and the merge keeps the member whose updates
//!   moved its yaw least; that count includes the correction undoing the
//!   unestimated drift, which the right member needs, so the −90° member is
//!   kept (score 2.7 worse). Its bias error (0.8°/s) drifts the yaw 24° in
//!   the next 30 s of straight cruise (σ 5.4°: 4.5σ) and wrecks the
//!   following outage (135 m against 30 m).
//! - Tried, and measured on fresh seeds 10–39 (not landed, each makes some
//!   cell worse): the yaw correction measured with the member's current bias
//!   estimate (seed 3: 18.5 m; uav:consumer:rtk:0 1.509 → 1.554 m,
//!   pedestrian:consumer:consumer:0 2.944 → 3.013 m); keeping the member
//!   of larger posterior (score + prior misfit at its implied start yaw and
//!   bias; seed 3: 9.7 m; uav:consumer:consumer:0.1 3.93 → 4.72 m); merging
//!   only members whose z-gyro bias also agrees within σ (seed 3: 9.7 m;
//!   uav:consumer:consumer:0 4.215 → 4.196, :0.1 3.926 → 3.862,
//!   pedestrian:consumer:consumer:0 2.944 → 2.899, but uav:consumer:rtk:0
//!   1.509 → 1.561 m from one seed, 19: 1.22 → 2.46 m). The bank's member
//!   choice is a hard decision on ambiguous evidence; any rule moves single
//!   seeds both ways. A fix has to remove the ambiguity (e.g. re-run the
//!   winner from the bank start with the yaw and bias it resolved, or hold
//!   the bank until a second manoeuvre separates ψ₀ from b), not reorder it.
//! - Re-running the winner from the bank start was tried (2026-11-28, not
//!   landed): start yaw = its hypothesis plus the yaw its updates moved it,
//!   yaw σ 5°, bias at the prior, up to three passes while the moved yaw
//!   exceeds 5°. It mends marine:consumer:consumer:0 seed 1 (6.82 → 3.60 m,
//!   the true heading gives 3.05 m), but on the 12 marine cells × 10 seeds it
//!   moves 21 of the 120 seed runs, both ways (marine:consumer:consumer:0.1 6.78 → 7.25 m,
//!   seed 4 5.0 → 7.9 m; marine:consumer:rtk:0 seed 7 1.16 → 1.72 m), and
//!   keeping the re-run only when its ½ΣNIS since the yaw became observable is
//!   lower does not sort them (0.1: 6.78 → 7.25 m again). With a consumer IMU
//!   (x/y gyro turn-on biases up to 1.7°/s) the yaw the updates applied also
//!   carries the member's tilt and bias errors, so it is no estimate of ψ₀.
//! - Seed 3 again, with the pitch columns: the default starts at pitch
//!   −2.0° (σ 1.3°): the in-motion force-pair tilt holds the −42 mg
//!   x-accelerometer turn-on bias (−2.4°), as it must. The error stays at
//!   −2.5° for 115 s while its σ falls to 0.38° by 43 s (while the yaw
//!   drifts to −19° at σ 6°), 0.16° by 63 s and 0.10° by 113 s (25σ); the
//!   oracle's initial state (`truthinit`) has it at 0.1° by 13 s. The
//!   updates that shrank it were linearised about a yaw up to 3.4σ from the
//!   truth, and the manoeuvre at 50 s spent its evidence on the yaw (−22° →
//!   −1°), not on the tilt/bias split. The 90° turn at
//!   115 s turns the pitch error into a roll error the bias no longer
//!   cancels (0.5 m/s² uncompensated), just before the 30 s outage: 170 m.
//!   With the unmodelled IMU axes removed (`DIAG_IDEAL=gyro-misalignment,accel-misalignment,g-sensitivity`)
//!   `truthinit` drops from 6.67 to 2.42 m but the default stays at 36.7 m:
//!   the gap is the start's yaw, not the IMU model.
//! - Widening the winner's covariance instead (not landed): when its yaw
//!   moved more than 5° from its hypothesis, add that move² to the yaw
//!   variance and (move / bank span)² to the z-gyro bias variance. Seeds
//!   0–9 of the 36 pedestrian / uav / marine cells: sum of default h RMS
//!   77.18 → 75.44 m, ≤ 1.2 × oracle 28 → 30 (pedestrian:consumer:consumer:0
//!   3.11 → 2.59 m, uav:consumer:consumer:0 10.52 → 9.13 m), but
//!   marine:consumer:rtk:0 +6.4 %. Fresh seeds 10–29: uav −0.15 %, marine
//!   −1.7 % but ≤ 1.2 × oracle 10 → 8 (marine:industrial:consumer's outage
//!   drift 6.11 → 6.35 m against 6.29). With the bias share bounded by the
//!   bias prior (an industrial gyro cannot have absorbed 0.3°/s), fresh
//!   seeds 30–49 of the marine cells: +3.3 %, industrial:rtk:0.1 +37 %.
//! - Those marine seeds 30–49 found an alignment defect: on seeds 30 and 48
//!   the oracle (true initial state and noise) with the tactical IMU and
//!   RTK turns by 0.6°/s in yaw and 0.3°/s in roll and pitch from the first
//!   second (18.6° in 12 s on seed 48) at σ 0.1°, 18 m off after 15 s with
//!   the fixes present; the KF-GINS model given the true start is 11 m h RMS
//!   (`DIAG_CELL=marine:tactical:rtk:0 DIAG_SEEDS=48
//!   DIAG_VARIANTS=default,oracle`). Not the simulator: free-inertial
//!   integration of the ideal IMU follows the truth to 4·10⁻⁷ rad there.
//!   The alignment takes "static window 1.0 s (roll/pitch, gyro bias)":
//!   the moored boat rolls in waves within `initial_static_len`'s 3°/s gyro
//!   std, the mean rate over 1 s of a 4–8 s wave becomes the gyro bias
//!   (0.1–0.6°/s) with a σ of ARW/√T and the in-run stability, and the
//!   oracle (position, velocity, attitude given) takes the same bias.
//!   Mended by a stationarity test of the window (`align::drift_chi2`: χ²
//!   of four segment means of rate and force against their noise and the
//!   bias change the sensor allows, 10⁻⁶ per axis). Seeds 30, 36 and 48 of
//!   every marine cell align in motion now: 34 of 36 seed runs better
//!   (tactical:rtk:0 seed 48 47.5 → 0.24 m, its oracle 19.4 → 0.22 m), 2
//!   worse (phone IMU + consumer GNSS seed 36, 3.4 → 22.1 m at τ = 0: its
//!   bank resolves 78° off, the hand-over defect above). Seeds 10–29 (the
//!   README's marine row) and drive_0708 are unchanged. Of the matrix's
//!   first 5 seeds (240 seed runs) 6 changed, all robot seed 2 at τ = 0.1 s,
//!   whose 20.0 s window reached into the start of motion and is cut to
//!   19.5 s: default within 0.05 %, the KF-GINS model +0.0–0.5 %.
//! - Where the UAV τ = 0 cells' gap to the KF-GINS model (given the true
//!   initial state) lies, uav:tactical:consumer:0 and uav:industrial:rtk:0,
//!   seeds 0–5 (2026-11-28, a variant written ad hoc, not kept):
//!   - Restarting the default from its own RTS-smoothed first state
//!     (position, velocity, attitude and their σ) does not close it:
//!     tactical:consumer 2.36/2.47/2.35/2.19/2.12/2.42 m → 2.37/2.47/2.32/
//!     2.10/2.11/2.40 m, `truthinit` 2.32/2.40/2.15/2.12/1.79/2.39 m;
//!     industrial:rtk 0.32/0.40/0.23/0.29/0.39/0.29 → 0.36/0.39/0.24/0.31/
//!     0.39/0.30 m. The smoothed start yaw has σ 0.6–5°: with consumer
//!     GNSS the yaw is learnt over minutes, not in the first 60 s.
//!   - `truthinit` with attitude σ 0.1°, 0.5° or 1.5° gives 2.15/2.15/2.15 m
//!     (seed 2) and 1.79/1.82/1.83 m (seed 4): the oracle's edge is its true
//!     yaw, not its tight σ. Seed 4 at 62 s: yaw error 0.41° (σ 0.19°)
//!     against `truthinit`'s 0.09° (σ 0.10°), within 2σ, so an information
//!     gap, not an inconsistency.
//!   - Found on the way and mended: the static window's gyro bias kept the
//!     whole earth rate when the yaw came after the window (z 7.6°/h off at
//!     30° N). The corrected mean (`align::BiasPrior`) moves the UAV
//!     cells by −0.1 to +1.0 % (5 seeds; +1.0 %: industrial:rtk) and
//!     leaves the 30-seed counts as they were (≤ 1.2 × oracle 48/48,
//!     ≤ KF-GINS 43/48).

use super::generalise::{cell_options, select_cells};
use super::score::{h_error_ne, motion_start};
use super::{run_variant, set_true_init, variant_config, wrap_pi, Variant};
use navfuse_sim::platform::platform_run;

#[test]
#[ignore]
fn uav_diag() {
    let cell =
        select_cells(&std::env::var("DIAG_CELL").unwrap_or("uav:consumer:consumer:0".into()))
            .unwrap()[0];
    let seeds: Vec<u64> = std::env::var("DIAG_SEEDS")
        .unwrap_or("3".into())
        .split(',')
        .map(|s| s.parse().unwrap())
        .collect();
    let variants: Vec<String> = std::env::var("DIAG_VARIANTS")
        .unwrap_or("default,truthinit,oracle".into())
        .split(',')
        .map(String::from)
        .collect();
    let every: f64 = std::env::var("DIAG_EVERY").map_or(20.0, |s| s.parse().unwrap());
    for &seed in &seeds {
        let mut opt = cell_options(&cell, seed, 600.0);
        opt.gnss_rate_hz = std::env::var("DIAG_GNSS_RATE")
            .ok()
            .map(|s| s.parse().unwrap());
        if let Ok(t) = std::env::var("DIAG_IDEAL") {
            let ideal_imu = t
                .split(',')
                .map(|s| s.parse().unwrap_or_else(|e| panic!("DIAG_IDEAL {e}")))
                .collect();
            opt.imu_ideal = super::rtk::Options {
                ideal_imu,
                ..Default::default()
            }
            .imu_ideal();
        }
        let pr = platform_run(cell.platform, seed, &opt).unwrap();
        let t_move = motion_start(&pr.run.traj).unwrap();
        println!(
            "seed {seed}: gyro turn-on bias {:.3?} °/h, accel {:.3?} mg, init rpy {:.2?}°, v {:.2?}",
            pr.gyro_turn_on_bias.map(|x| x.to_degrees() * 3600.0),
            pr.accel_turn_on_bias.map(|x| x / 9.80665e-3),
            pr.init.rpy.map(|x| x.to_degrees()),
            pr.init.v_n
        );
        for tt in 0..if std::env::var("DIAG_TRUTH").is_ok() {
            25
        } else {
            0
        } {
            let tr = pr.run.traj.at(pr.run.traj.truth[0].t + tt as f64);
            println!(
                "  truth t+{tt}: yaw {:.1} v {:.1?}",
                tr.rpy.z.to_degrees(),
                tr.v_n
            );
        }
        let mut runs = Vec::new();
        for v in &variants {
            let base = if v.starts_with("oracle") {
                Variant::Oracle
            } else {
                Variant::Default
            };
            let mut cfg = variant_config(base, &pr);
            let mut tw = v
                .trim_start_matches("oracle")
                .trim_start_matches('+')
                .to_string();
            if tw.contains("truthinit") {
                set_true_init(&mut cfg, &pr);
                tw = tw.replace("truthinit", "").trim_matches('+').to_string();
            }
            if tw.contains("trueyaw") {
                // Only the heading given (the true one, 1° σ): no bank.
                cfg.init.heading_deg = Some(pr.init.rpy.z.to_degrees());
                tw = tw.replace("trueyaw", "").trim_matches('+').to_string();
            }
            super::honesty_diag::tweak(&tw, &mut cfg);
            let r = run_variant(&cfg, &pr).unwrap();
            let t0 = t_move + super::generalise::SCORE_AFTER_MOTION_S;
            let (mut e2, mut n) = (0.0, 0);
            for s in r.solutions.iter().filter(|x| x.t >= t0) {
                let (en, ee) = h_error_ne(s.lat, s.lon, &pr.run.traj.at(s.t));
                e2 += en * en + ee * ee;
                n += 1;
            }
            println!(
                "  {v:<20} h_rms {:.2} m, align {} wait {:.1} s, tau {:?}, {} | {}",
                (e2 / n as f64).sqrt(),
                r.align_method,
                r.align_wait_s,
                r.time_offset_applied,
                r.augmented_states,
                r.alignment
            );
            runs.push(r);
        }
        println!(
            "  t-t_move  [yaw err° / yawσ° / h err m / z-gyro bias σ °/h / roll err° / pitch err°/σ° / |dv_h| m/s] per variant   (o = outage)"
        );
        let until: f64 = std::env::var("DIAG_UNTIL").map_or(f64::INFINITY, |s| s.parse().unwrap());
        let t_end = runs[0].solutions.last().unwrap().t.min(t_move + until);
        let mut t = pr.run.traj.truth[0].t.max(runs[0].solutions[0].t);
        while t <= t_end {
            let tr = pr.run.traj.at(t);
            let out = pr.outages.iter().any(|o| t >= o[0] && t < o[1]);
            let mut line = format!(
                "  {:7.1}{} v {:5.1} ψ {:6.1}",
                t - t_move,
                if out { "o" } else { " " },
                tr.v_n.norm(),
                tr.rpy.z.to_degrees()
            );
            for r in &runs {
                let k = r
                    .solutions
                    .partition_point(|s| s.t < t)
                    .min(r.solutions.len() - 1);
                let s = &r.solutions[k];
                let (en, ee) = h_error_ne(s.lat, s.lon, &tr);
                let ysd = r.std.get(k).map_or(f64::NAN, |x| x.att_rpy.z.to_degrees());
                let bsd = r
                    .std
                    .get(k)
                    .map_or(f64::NAN, |x| x.bg.z.to_degrees() * 3600.0);
                let psd = r.std.get(k).map_or(f64::NAN, |x| x.att_rpy.y.to_degrees());
                line += &format!(
                    " | {:6.2} {:5.2} {:6.2} {:6.0} r {:5.2} p {:5.2}/{:4.2} dv {:5.2}",
                    wrap_pi(s.rpy.z - tr.rpy.z).to_degrees(),
                    ysd,
                    (en * en + ee * ee).sqrt(),
                    bsd,
                    wrap_pi(s.rpy.x - tr.rpy.x).to_degrees(),
                    wrap_pi(s.rpy.y - tr.rpy.y).to_degrees(),
                    psd,
                    (s.v_n - tr.v_n).xy().norm()
                );
            }
            println!("{line}");
            t += every;
        }
    }
}

/// A run whose data end while the yaw bank still holds several members
/// (a 10 s moving-start walk with consumer GNSS: the yaw is not resolved
/// yet) ends with the bank's best member instead of indexing past the
/// last IMU sample.
#[test]
fn run_ending_inside_the_yaw_bank_does_not_panic() {
    use navfuse_sim::platform::{GnssGrade, ImuGrade, Platform, PlatformOptions};
    let opt = PlatformOptions {
        duration_s: 10.0,
        static_start: false,
        imu: ImuGrade::Consumer,
        gnss: GnssGrade::Consumer,
        ..Default::default()
    };
    let pr = platform_run(Platform::Pedestrian, 1, &opt).unwrap();
    let r = run_variant(&variant_config(Variant::Default, &pr), &pr)
        .expect("a run ending inside the bank yields its best member");
    assert!(
        r.alignment.contains("not resolved (the data ended"),
        "the scenario must end inside the bank: {}",
        r.alignment
    );
    assert!(!r.solutions.is_empty() && r.solutions.iter().all(|s| s.lat.is_finite()));
}
