//! Outputs whole or absent, and exit codes, end to end (runs the binary).
//!
//! `killed_run_leaves_whole_files_only`: a `navfuse run` on a simulated
//! 10-minute drive, with every output format, is SIGKILLed at delays spread
//! over its run time; after each kill every file under an output name must be
//! byte-identical to the one of a complete run (the run is deterministic, so
//! "the previous version" and "the complete new one" are the same bytes),
//! `summary.json` only present when every output it lists is, and anything
//! else only a `.…navfuse-tmp.…` leftover.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

const BIN: &str = env!("CARGO_BIN_EXE_navfuse");
const TMP_MARKER: &str = ".navfuse-tmp.";

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("navfuse-rel-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn files(d: &Path) -> BTreeMap<String, Vec<u8>> {
    let Ok(rd) = std::fs::read_dir(d) else {
        return BTreeMap::new();
    };
    rd.map(|e| e.unwrap())
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect()
}

fn navfuse(args: &[&str], cwd: &Path) -> (i32, String) {
    let o = Command::new(BIN)
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn killed_run_leaves_whole_files_only() {
    let d = dir("kill");
    let scenario = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/demo_drive.toml");
    let (rc, err) = navfuse(
        &[
            "sim",
            scenario.to_str().unwrap(),
            "--seed",
            "5",
            "--out",
            "sim",
        ],
        &d,
    );
    assert_eq!(rc, 0, "{err}");
    std::fs::write(
        d.join("sim/run.toml"),
        "formats = [\"csv\", \"geojson\", \"kml\", \"gpx\", \"nmea\", \"parquet\"]\n\
         [input]\nimu = \"imu.txt\"\ngnss = \"gnss.txt\"\n\
         [filter]\nplatform = \"car\"\nsmooth = true\n",
    )
    .unwrap();
    let t0 = Instant::now();
    let (rc, err) = navfuse(&["run", "sim/run.toml", "--output", "ref"], &d);
    let full = t0.elapsed();
    assert_eq!(rc, 0, "{err}");
    let reference = files(&d.join("ref"));
    assert!(reference.len() >= 15, "{:?}", reference.keys());
    assert!(reference.keys().all(|k| !k.contains(TMP_MARKER)));

    let n = 16;
    let (mut killed, mut partial) = (0, 0);
    for k in 0..n {
        let out = d.join(format!("kill{k}"));
        // Half the runs replace a complete previous run, half start empty.
        if k % 2 == 0 {
            std::fs::create_dir_all(&out).unwrap();
            for (name, b) in &reference {
                std::fs::write(out.join(name), b).unwrap();
            }
        }
        let mut child = Command::new(BIN)
            .args(["run", "sim/run.toml", "--output", out.to_str().unwrap()])
            .current_dir(&d)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        // From 20 % to 110 % of a full run: most kills land while writing.
        std::thread::sleep(full.mul_f64(0.2 + 0.9 * k as f64 / n as f64));
        if child.try_wait().unwrap().is_none() {
            killed += 1;
        }
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        let got = files(&out);
        let mut whole = 0;
        for (name, b) in &got {
            if name.contains(TMP_MARKER) {
                continue; // a killed writer's temporary file, never an output name
            }
            let want = reference
                .get(name)
                .unwrap_or_else(|| panic!("kill {k}: unexpected file {name}"));
            if name == "summary.json" {
                // Timings and paths differ; it must be complete JSON.
                let v: serde_json::Value = serde_json::from_slice(b)
                    .unwrap_or_else(|e| panic!("kill {k}: summary.json truncated: {e}"));
                assert!(v.get("outputs").is_some());
            } else {
                assert!(
                    b == want,
                    "kill {k}: {name} differs from the complete file ({} vs {} bytes)",
                    b.len(),
                    want.len()
                );
            }
            whole += 1;
        }
        if got.contains_key("summary.json") {
            // Written last: its presence means every output is there.
            for name in reference.keys() {
                assert!(
                    got.contains_key(name),
                    "kill {k}: summary.json without {name}"
                );
            }
        }
        if k % 2 == 1 && whole > 0 && whole < reference.len() {
            partial += 1;
        }
    }
    eprintln!(
        "{killed} of {n} runs killed before they finished, {partial} left a partial set of whole files (full run {:.2} s)",
        full.as_secs_f64()
    );
    assert!(
        killed >= n / 2,
        "only {killed} of {n} runs were killed mid-run"
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn exit_codes_and_empty_inputs() {
    let d = dir("codes");
    std::fs::write(d.join("empty.pos"), "").unwrap();
    std::fs::write(d.join("comments.pos"), "% only a header\n%\n").unwrap();
    for input in ["empty.pos", "comments.pos"] {
        let (rc, err) = navfuse(&["convert", input, "out.csv"], &d);
        assert_eq!(rc, 3, "{err}");
        assert!(
            err.contains(input) && err.contains("no usable records"),
            "{err}"
        );
        assert!(!d.join("out.csv").exists(), "no output for an empty input");
    }
    let (rc, err) = navfuse(&["convert", "empty.pos", "out.xyz"], &d);
    assert_eq!(rc, 2, "{err}");
    let (rc, err) = navfuse(&["convert", "missing.pos", "out.csv"], &d);
    assert_eq!(rc, 3, "{err}");
    assert!(err.contains("missing.pos"), "{err}");
    std::fs::write(d.join("one.pos"), "%  GPST            latitude(deg) longitude(deg) height(m) Q ns sdn(m) sde(m) sdu(m) sdne(m) sdeu(m) sdun(m) age(s) ratio\n2025/07/08 19:34:18.500 40.0966268 -105.1474483 1601.4740 1 21 0.0099 0.0099 0.0100 0.0 0.0 0.0 0.0 0.0\n").unwrap();
    let (rc, err) = navfuse(&["convert", "one.pos", "no/such/dir/out.csv"], &d);
    assert_eq!(rc, 4, "{err}");
    // A typo in the run configuration: exit 2, the key and the line named.
    std::fs::write(
        d.join("r.toml"),
        "[input]\nimu = \"a.txt\"\ngnss = \"b.txt\"\nimu_rat = 100\n",
    )
    .unwrap();
    let (rc, err) = navfuse(&["run", "r.toml"], &d);
    assert_eq!(rc, 2, "{err}");
    assert!(err.contains("imu_rat") && err.contains("line 4"), "{err}");
    // Clap's usage errors keep their 2.
    let (rc, _) = navfuse(&["convert"], &d);
    assert_eq!(rc, 2);
    let _ = std::fs::remove_dir_all(&d);
}
