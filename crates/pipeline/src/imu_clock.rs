//! The clock of an IMU log whose time column is a device counter: fitted
//! on the log's RTKLIB time-tag file (`[input] imu_tag`) with
//! [`navfuse_io::counter_clock::fit_csv_counter`] (lower envelope of
//! counter vs receive time), checked, and reported for `summary.json`.

use crate::csv_map::CounterSpec;
use navfuse_io::counter_clock::{fit_csv_counter, ClockFit, CounterClock, CounterColumn};
use navfuse_io::csv_imu::{Col, CsvImuConfig};
use navfuse_io::tag::TagFile;
use std::path::Path;

/// Largest |rate error| of a counter against its nominal tick that is still
/// an oscillator's error rather than a wrong `counter_tick_s`: quartz is
/// within ±100 ppm, an uncalibrated MCU RC oscillator within ±10 %
/// (e.g. ATmega328P datasheet, "internal RC oscillator accuracy ±10 %"),
/// while a wrong unit is off by a factor ≥ 2 (1 ms vs 10 ms vs 1 µs).
pub const MAX_COUNTER_RATE_ERROR: f64 = 0.2;

/// Fit the counter clock of the CSV log `imu` (read with `cfg`: delimiter,
/// comment byte, header) on the time-tag file `tag`. Errors name the file
/// (and the header field of a counter given by name).
pub fn fit_counter(
    imu: &Path,
    tag: &Path,
    cfg: &CsvImuConfig,
    spec: &CounterSpec,
) -> Result<(CounterClock, ClockFit), String> {
    let index = match &spec.col {
        Col::Index(i) => *i,
        Col::Name(n) => header_index(imu, cfg, n)?,
    };
    let tagfile = TagFile::read(tag).map_err(|e| e.to_string())?;
    let col = CounterColumn {
        index,
        delimiter: cfg.delimiter,
        comment: cfg.comment,
        nominal_s_per_count: spec.tick_s,
        modulus: Some(spec.modulus),
    };
    let (clock, fit) = fit_csv_counter(imu, &col, &tagfile).map_err(|e| e.to_string())?;
    let rate_error = clock.s_per_count / spec.tick_s - 1.0;
    if rate_error.abs() > MAX_COUNTER_RATE_ERROR {
        return Err(format!(
            "{}: the counter advances {:.6} s per count against the tag file {}, \
             {:+.1} % off counter_tick_s = {} s: state the counter's tick with \
             [input.csv] counter_tick_s",
            imu.display(),
            clock.s_per_count,
            tag.display(),
            rate_error * 100.0,
            spec.tick_s
        ));
    }
    Ok((clock, fit))
}

/// 0-based index of the header field `name` (first non-blank, non-comment line).
fn header_index(imu: &Path, cfg: &CsvImuConfig, name: &str) -> Result<usize, String> {
    let (rdr, file) = navfuse_io::open(imu).map_err(|e| e.to_string())?;
    if !cfg.header {
        return Err(format!(
            "{file}:1: field `{name}`: counter column given by name but [input.csv] header = false"
        ));
    }
    for (k, line) in navfuse_io::text::capped_lines(rdr).enumerate() {
        let line = line.map_err(|e| format!("{file}:{}: I/O error: {e}", k + 1))?;
        let first = line.bytes().find(|b| !b.is_ascii_whitespace());
        if first.is_none() || first == cfg.comment {
            continue;
        }
        return line
            .split(cfg.delimiter as char)
            .position(|f| f.trim() == name)
            .ok_or_else(|| {
                format!(
                    "{file}:{}: field `{name}`: counter column not found in the header",
                    k + 1
                )
            });
    }
    Err(format!("{file}: no header line"))
}

/// The fit for `summary.json` (input report and `resolved_input`): the map
/// `t_gps = t_ref + s_per_count·(counter − c_ref)`, the counter's rate error
/// against its nominal tick [ppm] with its σ, the scatter of the envelope
/// and the receive latency above it [ms].
pub fn clock_json(tag: &Path, clock: &CounterClock, fit: &ClockFit) -> serde_json::Value {
    serde_json::json!({
        "tag": tag.display().to_string(),
        "c_ref": clock.c_ref,
        "t_ref_gps_s": clock.t_ref,
        "s_per_count": clock.s_per_count,
        "nominal_s_per_count": clock.nominal_s_per_count,
        "modulus": clock.modulus,
        "drift_ppm": clock.drift_ppm(),
        "drift_sigma_ppm": fit.drift_sigma_ppm,
        "sigma_ms": fit.sigma_s * 1e3,
        "latency_median_ms": fit.latency_median_s * 1e3,
        "latency_p99_ms": fit.latency_p99_s * 1e3,
        "pairs": fit.pairs,
        "blocks": fit.blocks,
        "crlf_stripped": fit.crlf_stripped,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use navfuse_io::csv_imu::CsvTime;
    use navfuse_io::tag::{encode, TagLayout};
    use std::fmt::Write as _;

    /// A 100 Hz log `t,gx,…,az,ms` whose ms counter runs 200 ppm slow, and a
    /// tag file receiving every line 5 ms after its sample on a 1 ms tick.
    fn log_and_tag(dir: &Path, tick_scale: f64) -> (std::path::PathBuf, std::path::PathBuf) {
        let mut csv = String::from("gx,gy,gz,ax,ay,az,ms\n");
        let mut records = Vec::new();
        let t0 = 1_435_000_000.0;
        for k in 0..6000u32 {
            let c = 1000 + 10 * k;
            let _ = writeln!(csv, "0,0,0,0,0,-9.8,{}", (c as f64 * tick_scale) as u64);
            let t = (c - 1000) as f64 * 1e-3 * (1.0 + 200e-6) + 0.005;
            records.push(((t * 1e3).floor() as u32, csv.len() as u64));
        }
        let tag = TagFile {
            version: "TIMETAG RTKLIB demo5".into(),
            tick_f: 0,
            start_gps_s: t0,
            records,
            layout: TagLayout::PLAIN,
        };
        let (p, q) = (dir.join("imu.csv"), dir.join("imu.csv.tag"));
        std::fs::write(&p, csv).unwrap();
        std::fs::write(&q, encode(&tag)).unwrap();
        (p, q)
    }

    #[test]
    fn counter_by_header_name_is_fitted_and_a_wrong_tick_is_an_error() {
        let dir = crate::test_dir("imu-clock");
        let (p, q) = log_and_tag(&dir, 1.0);
        let cfg = CsvImuConfig::new(
            CsvTime::Seconds(Col::Index(0)),
            [0.into(), 1.into(), 2.into()],
            [3.into(), 4.into(), 5.into()],
        );
        let spec = CounterSpec {
            col: Col::Name("ms".into()),
            tick_s: 1e-3,
            modulus: 2f64.powi(32),
        };
        let (clock, fit) = fit_counter(&p, &q, &cfg, &spec).unwrap();
        assert!((clock.drift_ppm() - 200.0).abs() < 2.0, "{clock:?}");
        // First sample: receive time − 5 ms latency, floored to the 1 ms tick.
        let t0 = clock.gps_seconds(1000.0) - 1_435_000_000.0;
        assert!((0.004..=0.0051).contains(&t0), "{t0}");
        assert!(fit.latency_median_s < 0.002, "{fit:?}");
        let j = clock_json(&q, &clock, &fit);
        assert!((j["drift_ppm"].as_f64().unwrap() - 200.0).abs() < 2.0);
        // A 10 µs counter declared as milliseconds runs 100× fast: error.
        let (p, q) = log_and_tag(&dir, 100.0);
        let e = fit_counter(&p, &q, &cfg, &spec).unwrap_err();
        assert!(e.contains("counter_tick_s"), "{e}");
        let e = fit_counter(
            &p,
            &q,
            &cfg,
            &CounterSpec {
                col: Col::Name("cnt".into()),
                ..spec
            },
        )
        .unwrap_err();
        assert!(e.contains("imu.csv:1: field `cnt`"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
