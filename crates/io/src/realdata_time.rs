//! Real-data tests of the time-tag reader and the counter clock on
//! drive_0708 (ignored by default; `cargo test -p navfuse-io --release -- --ignored`).

use crate::counter_clock::{fit_csv_counter, CounterClock, CounterColumn};
use crate::data::require;
use crate::tag::{TagFile, TagLayout};
use crate::time::week_tow;
use std::io::BufRead;

/// Counters of `imu_1934.csv` and TOWs of `imu_1934_gpst.csv` (which drops
/// the raw file's first and last line: upstream `skip_header=1, skip_footer=1`).
fn counters_and_copy_tows() -> (Vec<f64>, Vec<f64>) {
    let read = |rel: &str| -> Vec<String> {
        let f = std::fs::File::open(require(rel)).unwrap();
        std::io::BufReader::new(f)
            .lines()
            .map(Result::unwrap)
            .collect()
    };
    let raw: Vec<f64> = read("drive_0708/imu_1934.csv")
        .iter()
        .map(|l| l.rsplit(',').next().unwrap().trim().parse().unwrap())
        .collect();
    let tows: Vec<f64> = read("drive_0708/imu_1934_gpst.csv")
        .iter()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    assert_eq!(
        raw.len(),
        tows.len() + 2,
        "the copy drops the first and last raw line"
    );
    (raw[1..raw.len() - 1].to_vec(), tows)
}

/// max |Δ|, RMS Δ of `clock` against the copy's TOW [s].
fn compare(clock: &CounterClock, c: &[f64], tows: &[f64]) -> (f64, f64, Vec<f64>) {
    let d: Vec<f64> = c
        .iter()
        .zip(tows)
        .map(|(&c, &tow)| week_tow(clock.gps_seconds(c)).1 - tow)
        .collect();
    let max = d.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let rms = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
    (max, rms, d)
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn drive_counter_clock_against_the_convenience_copy() {
    let tag = TagFile::read(&require("drive_0708/imu_1934.csv.tag")).unwrap();
    assert_eq!(tag.layout, TagLayout::PLAIN);
    assert_eq!(tag.version, "TIMETAG RTKLIB demo5");
    assert_eq!(tag.records.len(), 37_632);
    let (w, tow0) = week_tow(tag.start_gps_s);
    assert_eq!(w, 2374);
    assert!((tow0 - 243_261.854).abs() < 1e-6, "{tow0}");
    let (clock, fit) = fit_csv_counter(
        &require("drive_0708/imu_1934.csv"),
        &CounterColumn::ms_u32(6),
        &tag,
    )
    .unwrap();
    let (c, tows) = counters_and_copy_tows();
    let (max, rms, d) = compare(&clock, &c, &tows);
    eprintln!(
        "fit: drift {:.2} ± {:.2} ppm, σ {:.2} ms, latency median {:.1} ms p99 {:.1} ms, {} pairs, {} blocks, crlf {}",
        clock.drift_ppm(), fit.drift_sigma_ppm, fit.sigma_s * 1e3, fit.latency_median_s * 1e3,
        fit.latency_p99_s * 1e3, fit.pairs, fit.blocks, fit.crlf_stripped
    );
    eprintln!(
        "vs copy: max |Δ| {:.3} ms, RMS {:.3} ms, Δ first {:.3} ms, Δ last {:.3} ms",
        max * 1e3,
        rms * 1e3,
        d[0] * 1e3,
        d[d.len() - 1] * 1e3
    );
    // The copy's own method: first kept line at the tag start, last kept line at the last tick.
    let last_tick = tag.records.last().unwrap().0 as f64 * 1e-3;
    let two = CounterClock::from_two_points(
        c[0],
        tag.start_gps_s,
        c[c.len() - 1],
        tag.start_gps_s + last_tick,
        1e-3,
        None,
    );
    let (max2, rms2, _) = compare(&two, &c, &tows);
    eprintln!(
        "two-point (upstream) map: drift {:.1} ppm, max |Δ| {:.4} ms, RMS {:.4} ms",
        two.drift_ppm(),
        max2 * 1e3,
        rms2 * 1e3
    );
    // The copy is the two-point map to its 4-decimal rounding (≤ 0.05 ms).
    assert!(max2 < 0.051e-3, "{max2}");
    // Physics: a crystal counter is within ±100 ppm; the envelope pins it to ~0.1 ppm.
    assert!(
        clock.drift_ppm().abs() < 100.0 && fit.drift_sigma_ppm < 1.0,
        "{fit:?}"
    );
    assert!(
        fit.crlf_stripped,
        "the tag counts \\r\\n line ends the stored file lacks"
    );
    // The whole difference to the copy is the difference of the two lines
    // (the copy pins its first line to the file-open time, 131 ms before any
    // byte arrived, and its last line to the last receive tick): residual ≤ rounding.
    let worst = c
        .iter()
        .zip(&d)
        .map(|(&c, &dd)| (dd - (clock.gps_seconds(c) - two.gps_seconds(c))).abs())
        .fold(0.0, f64::max);
    assert!(worst < 0.051e-3, "{worst}");
    // Our first line lies below its receive tick (146 ms) and above the first record's tick less one 15.6 ms tick.
    assert!((0.131 - 0.016..0.146).contains(&d[0]), "{}", d[0]);
    assert!(max < 0.2, "{max}");
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn drive_raw_log_reads_through_the_counter_clock() {
    use crate::csv_imu::{AccelUnit, Col, CsvImuConfig, CsvImuReader, CsvTime};
    let tag = TagFile::read(&require("drive_0708/imu_1934.csv.tag")).unwrap();
    let (clock, _) = fit_csv_counter(
        &require("drive_0708/imu_1934.csv"),
        &CounterColumn::ms_u32(6),
        &tag,
    )
    .unwrap();
    let cfg = CsvImuConfig {
        header: false,
        columns: Some(7),
        accel_unit: AccelUnit::G,
        reject_repeated_values: true,
        ..CsvImuConfig::new(
            CsvTime::Counter {
                col: Col::Index(6),
                clock,
            },
            [3.into(), 4.into(), 5.into()],
            [0.into(), 1.into(), 2.into()],
        )
    };
    let (r, n) = crate::open(&require("drive_0708/imu_1934.csv")).unwrap();
    let mut rd = CsvImuReader::new(r, &n, cfg);
    let v: Vec<_> = rd.by_ref().map(Result::unwrap).collect();
    let st = rd.stats();
    eprintln!("imu_1934.csv via counter clock: {st}");
    assert_eq!(st.lines, 54_860);
    assert!(st.is_balanced() && v.len() > 53_000, "{st}");
    assert!((v[0].t - clock.gps_seconds(261_906.0)).abs() < 1e-9);
    assert!(v.windows(2).all(|w| w[1].t > w[0].t));
}
