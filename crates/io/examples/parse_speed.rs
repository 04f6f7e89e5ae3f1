//! Parse speed of the streaming readers on the real drive_0708 files.
//! `cargo run -p navfuse-io --release --example parse_speed [-- ROUNDS [imu]]`
//! (`imu`: only the KF-GINS imu.txt)
//! Prints wall time per pass (best and median); on a loaded machine compare
//! with the process CPU time (`time`), which divides by ROUNDS·files.

use navfuse_io::csv_imu::{CsvImuConfig, CsvImuReader};
use navfuse_io::data::require;
use navfuse_io::kfgins::{KfGinsImuOptions, KfGinsImuReader};
use navfuse_io::pos::PosReader;
use std::time::Instant;

/// Consume a reader, panicking on the first error; the record count.
fn drain<T, E: std::fmt::Display, I: Iterator<Item = Result<T, E>>>(it: I) -> usize {
    let mut n = 0;
    for s in it {
        if let Err(e) = s {
            panic!("{e}");
        }
        n += 1;
    }
    n
}

fn time<F: FnMut() -> usize>(name: &str, rounds: usize, mut f: F) {
    let mut t = Vec::with_capacity(rounds);
    let mut n = 0;
    for _ in 0..rounds {
        let t0 = Instant::now();
        n = f();
        t.push(t0.elapsed().as_secs_f64() * 1e3);
    }
    t.sort_by(f64::total_cmp);
    println!(
        "{name}: {n} records, best {:.1} ms, median {:.1} ms over {rounds} passes",
        t[0],
        t[rounds / 2]
    );
}

fn main() {
    let rounds: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(20);
    let only = std::env::args().nth(2).unwrap_or_default();
    let imu = require("drive_0708/kfgins/imu.txt");
    time("kfgins imu.txt", rounds, || {
        let (r, n) = navfuse_io::open(&imu).unwrap();
        let opt = KfGinsImuOptions {
            week: 2374,
            ..Default::default()
        };
        drain(KfGinsImuReader::new(r, &n, opt))
    });
    if only == "imu" {
        return;
    }
    let csv = require("drive_0708/imu_1934_gpst.csv");
    let cfg = CsvImuConfig {
        mount_rpy_deg: None,
        ..CsvImuConfig::drive_0708()
    };
    time("imu_1934_gpst.csv", rounds, || {
        let (r, n) = navfuse_io::open(&csv).unwrap();
        drain(CsvImuReader::new(r, &n, cfg.clone()))
    });
    let pos = require("drive_0708/gnss_1934_sf.pos");
    time("gnss_1934_sf.pos", rounds, || {
        let (r, n) = navfuse_io::open(&pos).unwrap();
        drain(PosReader::new(r, &n))
    });
}
