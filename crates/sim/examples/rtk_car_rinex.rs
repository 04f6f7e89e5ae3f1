//! A simulated car with an IMU and a dual-frequency multi-GNSS rover + base
//! pair, written as the files `navfuse run` (`coupling = "rtk"`), `navfuse
//! baseline` and RTKLIB `rnx2rtkp` read (issue 15, must-show 4, the speed
//! comparison of `tools/rtk_speed.sh`):
//! - `OUT/rover.obs`, `OUT/base.obs` (RINEX 3.04; the base's true position
//!   in its header), `OUT/nav.rnx` (the broadcast GPS, Galileo, BeiDou
//!   records that generated the scene): [`navfuse_sim::rtk_scene`] at 1 Hz,
//!   GPS L1 C/A + L2C, Galileo E1 + E5b, BeiDou B1I + B2I, default error
//!   model, no cycle slips, the base 5 km north, 2 km east, 20 m above the
//!   car's start;
//! - `OUT/imu.csv` (+ `imu.txt`, `gnss.*`, `truth.*` of
//!   [`navfuse_sim::output::write_run`]): the car of
//!   [`navfuse_sim::platform`] (static start, consumer MEMS, 100 Hz);
//! - `OUT/rtk.toml`: the `navfuse run` configuration (RTK coupling, its
//!   lever arm, `.pos` output, no smoother).
//!
//! The files are those of [`navfuse_sim::rtk_car::write_rtk_car`], the
//! writer of the pipeline test `simulated_car_rtk_run_fixes_and_writes_quality`,
//! here with Galileo and BeiDou and the length chosen on the command line
//! (nothing tuned on results).
//! Usage: cargo run --release -p navfuse-sim --example rtk_car_rinex -- OUT [SEED] [SECONDS]

use navfuse_sim::rtk_car::{write_rtk_car, RtkCarOptions};

fn arg<T: std::str::FromStr>(a: Option<String>, default: T, name: &str) -> T
where
    T::Err: std::fmt::Display,
{
    match a.map(|s| s.parse::<T>()) {
        None => default,
        Some(Ok(v)) => v,
        Some(Err(e)) => {
            eprintln!("{name}: {e}");
            std::process::exit(2);
        }
    }
}

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(out) = args.next() else {
        eprintln!("usage: rtk_car_rinex OUT_DIR [SEED] [SECONDS]");
        std::process::exit(2);
    };
    let seed: u64 = arg(args.next(), 1, "SEED");
    let duration: f64 = arg(args.next(), 3600.0, "SECONDS");
    let dir = std::path::Path::new(&out);
    let o = RtkCarOptions {
        seed,
        duration_s: duration,
        slip_rate: 0.0,
        multi_gnss: true,
        platform: navfuse_sim::platform::Platform::Car,
        profile: None,
    };
    let car = write_rtk_car(dir, &o).unwrap_or_else(|e| {
        eprintln!("{}: {e}", dir.display());
        std::process::exit(1);
    });
    let recs = |v: &[navfuse_sim::raw_gnss::RawTruthEpoch]| {
        v.iter().map(|e| e.epoch.n).sum::<usize>() as f64 / v.len().max(1) as f64
    };
    let b = car.base_e;
    println!(
        "{}: {} epochs, {:.1} rover and {:.1} base records per epoch, {} IMU samples, base {:.4} {:.4} {:.4}",
        dir.display(),
        car.scene.rover.len(),
        recs(&car.scene.rover),
        recs(&car.scene.base),
        car.sim.imu.len(),
        b.x,
        b.y,
        b.z
    );
}
