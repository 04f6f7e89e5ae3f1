//! `navfuse live` end to end over loopback TCP: the CI-sized soak
//! (`navfuse experiment soak`, ≤ 60 s wall). The replay server drops the
//! IMU and the GNSS connection twice mid-stream; live reconnects, realigns
//! after the gap between passes, is stopped by SIGTERM, exits 0, and every
//! line sent is accounted for in its summary; its solutions carry σ.

use std::process::Command;

#[test]
fn soak_over_tcp_with_drops_and_sigterm() {
    let dir = std::env::temp_dir().join(format!("navfuse-soak-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let sol = dir.join("solutions.jsonl");
    let t0 = std::time::Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_navfuse"))
        .args([
            "experiment",
            "soak",
            "--recordings",
            "demo",
            "--hours",
            "0.3",
        ])
        .args([
            "--speed",
            "40",
            "--drops",
            "2",
            "--sample-every",
            "5",
            "--out",
        ])
        .arg(&dir)
        .arg("--solutions")
        .arg(&sol)
        .output()
        .expect("run navfuse");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let log = std::fs::read_to_string(dir.join("live.stderr")).unwrap_or_default();
    assert!(
        out.status.success(),
        "{stdout}\n{}\nlive:\n{log}",
        String::from_utf8_lossy(&out.stderr)
    );
    eprintln!("{stdout}{log}({:.1} s wall)", t0.elapsed().as_secs_f64());
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("soak.json")).unwrap()).unwrap();
    assert_eq!(r["accounted"], true);
    assert_eq!(r["live_exit_ok"], true);
    assert_eq!(r["reconnects_seen"]["imu"], 2, "{log}");
    assert_eq!(r["reconnects_seen"]["nmea"], 2, "{log}");
    assert!(r["realigns"].as_u64().unwrap() >= 1, "{log}");
    assert!(log.contains("stopped by SIGTERM"), "{log}");
    // Solutions stream with σ from the ESKF covariance.
    let text = std::fs::read_to_string(&sol).unwrap();
    let n = text.lines().count() as u64;
    assert_eq!(Some(n), r["solutions"].as_u64());
    let last: serde_json::Value = serde_json::from_str(text.lines().last().unwrap()).unwrap();
    for k in [
        "sn", "sh", "sv", "svn", "sve", "svd", "sroll", "spitch", "syaw",
    ] {
        let v = last[k].as_f64().unwrap_or(f64::NAN);
        assert!(v.is_finite() && v > 0.0, "{k} = {}", last[k]);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// SIGINT while the IMU source (stdin) is still open: live uses what has
/// arrived, prints its summary and exits 0.
#[test]
fn sigint_ends_with_summary_and_exit_0() {
    use std::io::Write;
    use std::process::Stdio;
    let mut child = Command::new(env!("CARGO_BIN_EXE_navfuse"))
        .args([
            "live",
            "--gps-week",
            "2374",
            "--gnss",
            "none",
            "--estimator",
            "hold",
        ])
        .args(["--out", "/dev/null"])
        .stdin(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run navfuse live");
    let mut stdin = child.stdin.take().unwrap();
    for k in 0..500 {
        writeln!(stdin, "{:.3} 0 0 0 0 0 -0.098", 243_300.0 + 0.01 * k as f64).unwrap();
    }
    stdin.flush().unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let pid = child.id().to_string();
    assert!(Command::new("kill")
        .args(["-INT", &pid])
        .status()
        .unwrap()
        .success());
    let out = child.wait_with_output().unwrap();
    drop(stdin);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{:?}\n{err}", out.status);
    assert!(err.contains("stopped by SIGINT"), "{err}");
    assert!(err.contains("IMU input: 500 lines: 500 used"), "{err}");
}
