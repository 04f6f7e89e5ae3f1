//! Issue 17, must-show 4: a simulated u-blox byte stream (ESF-RAW IMU and
//! wheel ticks, NAV-PVT, NAV-RELPOSNED, written by our encoders through
//! `navfuse sim --ubx`) runs through `navfuse run` (`[input] ubx`) and
//! through `navfuse live --ubx` over loopback TCP, a FIFO (the serial-like
//! path) and stdin, with the same result.
//!
//! Same result means: the live outputs of the three paths are byte
//! identical, and every live solution equals the batch solution of the same
//! epoch to the batch file's printed precision (.nav: 1e-10° lat/lon,
//! 1e-4 m and m/s, 1e-6° attitude). The batch run uses the white GNSS error
//! model: the live ESKF has no record-wide GNSS error fit (the default
//! `auto` model fits σ on the whole record, which a stream cannot), so the
//! comparison fixes the model both can use. The odometer (wheel ticks) and
//! dual-antenna heading (NAV-RELPOSNED) aiding is on in both, with the
//! defaults (`[filter.odometer]`, `[filter.heading]`), and both count the
//! same aiding updates.

use std::io::Write;
use std::path::Path;
use std::process::Command;

const SCENARIO: &str = r#"
name = "ubx_drive"
description = "car: static, accelerate, cruise, two turns"
[start]
lat_deg = 40.0
lon_deg = -105.0
h_m = 1600.0
rpy_deg = [0.0, 0.0, 30.0]
[imu]
preset = "3dm-gx3-35"
rate_hz = 100
substeps = 4
[gnss]
preset = "consumer-1hz"
[[segment]]
type = "hold"
duration_s = 20
[[segment]]
type = "accelerate"
speed_kmh = 40
[[segment]]
type = "cruise"
duration_s = 20
[[segment]]
type = "turn"
rate_deg_s = 10
angle_deg = 90
[[segment]]
type = "cruise"
duration_s = 20
[[segment]]
type = "turn"
rate_deg_s = -10
angle_deg = 90
[[segment]]
type = "cruise"
duration_s = 20
"#;

fn navfuse() -> Command {
    Command::new(env!("CARGO_BIN_EXE_navfuse"))
}

const LIVE_ARGS: [&str; 6] = [
    "--ubx-metres-per-tick",
    "0.02",
    "--platform",
    "car",
    "--imu-preset",
    "3dm-gx3-35",
];

fn live(ubx: &str, out: &Path, summary: &Path, stdin: Option<&Path>) {
    let mut c = navfuse();
    c.args(["live", "--ubx", ubx, "--reconnect-for", "0"])
        .args(LIVE_ARGS)
        .arg("--out")
        .arg(out)
        .arg("--summary-json")
        .arg(summary);
    if let Some(p) = stdin {
        c.stdin(std::fs::File::open(p).unwrap());
    }
    let o = c.output().unwrap();
    assert!(
        o.status.success(),
        "live {ubx}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn ubx_stream_through_run_and_live_gives_the_same_solution() {
    let dir = std::env::temp_dir().join(format!("navfuse-ubx-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("sc.toml"), SCENARIO).unwrap();
    let log = dir.join("log.ubx");
    let o = navfuse()
        .args(["sim", "--seed", "7", "--out"])
        .arg(dir.join("sim"))
        .arg(dir.join("sc.toml"))
        .arg("--ubx")
        .arg(&log)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "sim: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let bytes = std::fs::read(&log).unwrap();

    // Batch.
    std::fs::write(
        dir.join("run.toml"),
        "[input]\nubx = \"log.ubx\"\nubx_metres_per_tick = 0.02\n[filter]\nplatform = \"car\"\n\
         imu_preset = \"3dm-gx3-35\"\n[filter.gnss_error]\nmodel = \"white\"\n",
    )
    .unwrap();
    let o = navfuse()
        .args(["run", "--output"])
        .arg(dir.join("out"))
        .arg(dir.join("run.toml"))
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "run: {}",
        String::from_utf8_lossy(&o.stderr)
    );

    // Live over TCP: a one-connection replay server on loopback.
    let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = l.local_addr().unwrap();
    let b2 = bytes.clone();
    let server = std::thread::spawn(move || {
        let (mut s, _) = l.accept().unwrap();
        s.write_all(&b2).unwrap();
    });
    let (tcp, tcp_sum) = (dir.join("tcp.jsonl"), dir.join("tcp.json"));
    live(&format!("tcp:{addr}"), &tcp, &tcp_sum, None);
    server.join().unwrap();

    // Live over a FIFO (what a serial device looks like to a reader).
    let fifo = dir.join("fifo");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let f2 = fifo.clone();
    let writer = std::thread::spawn(move || {
        let mut f = std::fs::OpenOptions::new().write(true).open(&f2).unwrap();
        f.write_all(&bytes).unwrap();
    });
    let (via_fifo, fifo_sum) = (dir.join("fifo.jsonl"), dir.join("fifo.json"));
    live(fifo.to_str().unwrap(), &via_fifo, &fifo_sum, None);
    writer.join().unwrap();
    // And stdin.
    let (via_stdin, stdin_sum) = (dir.join("stdin.jsonl"), dir.join("stdin.json"));
    live("-", &via_stdin, &stdin_sum, Some(&log));

    let read = |p: &Path| std::fs::read_to_string(p).unwrap();
    let live_out = read(&tcp);
    assert_eq!(live_out, read(&via_fifo), "TCP and FIFO differ");
    assert_eq!(live_out, read(&via_stdin), "TCP and stdin differ");

    // Every live solution against the batch one of the same epoch.
    let mut batch = std::collections::HashMap::new();
    for l in read(&dir.join("out/solution.nav")).lines() {
        let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
        batch.insert((v[1] * 1e3).round() as i64, v);
    }
    let (mut n, mut max) = (0, [0f64; 9]);
    for l in live_out.lines() {
        let j: serde_json::Value = serde_json::from_str(l).unwrap();
        let key = (j["tow"].as_f64().unwrap() * 1e3).round() as i64;
        let b = batch
            .get(&key)
            .unwrap_or_else(|| panic!("live epoch {key} ms not in the batch output"));
        let names = ["lat", "lon", "h", "vn", "ve", "vd", "roll", "pitch", "yaw"];
        for (k, name) in names.iter().enumerate() {
            max[k] = max[k].max((j[name].as_f64().unwrap() - b[k + 2]).abs());
        }
        n += 1;
    }
    println!("{n} common epochs of {} batch; max |live − batch| lat,lon [°], h [m], v [m/s], rpy [°]: {max:?}", batch.len());
    assert!(
        n + 1 >= batch.len() && n > 5000,
        "{n} live epochs vs {} batch",
        batch.len()
    );
    let tol = [6e-11, 6e-11, 6e-5, 6e-5, 6e-5, 6e-5, 6e-7, 6e-7, 6e-7];
    for k in 0..9 {
        assert!(max[k] <= tol[k], "component {k}: {} > {}", max[k], tol[k]);
    }

    // The same records reached both: IMU samples, fixes, aiding events.
    let sum: serde_json::Value = serde_json::from_str(&read(&tcp_sum)).unwrap();
    let run: serde_json::Value =
        serde_json::from_str(&read(&dir.join("out/summary.json"))).unwrap();
    assert_eq!(sum["imu_in"], run["inputs"]["imu"]["records"]);
    assert_eq!(sum["gnss_in"], run["inputs"]["gnss"]["records"]);
    assert_eq!(sum["imu_late"], 0);
    assert_eq!(sum["gnss_late"], 0);
    assert_eq!(sum["ubx_heading_events"], run["inputs"]["gnss"]["records"]);
    assert!(sum["ubx_odometer_events"].as_u64().unwrap() > 1000);
    assert_eq!(
        sum["ubx_odometer_events"],
        run["inputs"]["ubx_aiding_events"]["odometer"]
    );
    assert_eq!(sum["imu"]["rejected"]["NAV-PVT: no valid 3-D fix"], 1);
    // Aiding fused on both sides, the same updates.
    assert_eq!(sum["aid_late"], 0);
    let (la, ba) = (
        &sum["aiding"]["used_rejected"],
        &run["used_rejected"]["aiding"],
    );
    println!("aiding updates: live {la}, batch {ba}");
    assert!(la["odometer"]["used"].as_u64().unwrap() > 500, "{la}");
    assert!(la["heading"]["used"].as_u64().unwrap() > 50, "{la}");
    assert_eq!(la, ba);
    assert_eq!(sum["aiding"]["config"], run["filter"]["aiding"]);
    let _ = std::fs::remove_dir_all(&dir);
}
