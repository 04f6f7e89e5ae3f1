//! Write the simulated 1 h, 1 Hz GPS + Galileo + BeiDou log of
//! [`navfuse_sim::multi_gnss`] as RINEX 3.04 files: `OUT/sim.obs`,
//! `OUT/sim.nav` and the truth `OUT/truth.csv` (receiver tag [GPS s],
//! ECEF x, y, z [m], receiver clock bias [s]).
//! With `--glonass` (after SEED) the GLONASS constellation is added.
//! Usage: cargo run --release -p navfuse-sim --example multi_gnss_rinex -- OUT [SEED] [--glonass]

use navfuse_sim::multi_gnss::{simulate_multi, MultiGnssConfig};
use std::fmt::Write as _;

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(out) = args.next() else {
        eprintln!("usage: multi_gnss_rinex OUT_DIR [SEED]");
        std::process::exit(2);
    };
    let seed = match args.next().map(|s| s.parse::<u64>()) {
        None => 1,
        Some(Ok(s)) => s,
        Some(Err(e)) => {
            eprintln!("SEED: {e}");
            std::process::exit(2);
        }
    };
    let glonass = args.next().is_some_and(|a| a == "--glonass");
    let dir = std::path::Path::new(&out);
    let log = simulate_multi(&MultiGnssConfig {
        seed,
        glonass,
        ..Default::default()
    });
    let mut truth = String::from("tag_s,x_m,y_m,z_m,clock_bias_s\n");
    for ((t, p), b) in log.tags.iter().zip(&log.truth_e).zip(&log.clock_bias_s) {
        let _ = writeln!(truth, "{t:.7},{:.4},{:.4},{:.4},{b:.12e}", p.x, p.y, p.z);
    }
    let write = |name: &str, text: String| {
        let p = dir.join(name);
        if let Err(e) = std::fs::create_dir_all(dir).and_then(|_| std::fs::write(&p, text)) {
            eprintln!("{}: {e}", p.display());
            std::process::exit(1);
        }
    };
    write("sim.obs", log.obs_text());
    write("sim.nav", log.nav_text());
    write("truth.csv", truth);
    let n: usize = log.gnss.epochs.iter().map(Vec::len).sum();
    let count = |s: char| {
        log.gnss
            .epochs
            .iter()
            .flatten()
            .filter(|x| x.0 == s)
            .count() as f64
            / log.gnss.epochs.len() as f64
    };
    println!(
        "{}: {} epochs, {:.1} satellites per epoch (G {:.1}, E {:.1}, C {:.1}, R {:.1}), max {}",
        dir.display(),
        log.tags.len(),
        n as f64 / log.tags.len() as f64,
        count('G'),
        count('E'),
        count('C'),
        count('R'),
        log.gnss.epochs.iter().map(Vec::len).max().unwrap_or(0)
    );
}
