//! Issue 14 end to end through the binary: `navfuse run` with `[filter]
//! coupling = "tight"` on a simulated raw-GNSS drive (IMU CSV + a u-blox
//! RXM-RAWX/SFRBX log written by our encoders,
//! `navfuse_pipeline::raw_drive`): exit 0, the solution and a summary with
//! the tight account; an unknown coupling exits 2 naming the key.

use std::process::Command;

#[test]
fn navfuse_run_tight_on_a_simulated_ubx_log() {
    let dir = std::env::temp_dir().join(format!("navfuse-cli-tight-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    navfuse_pipeline::raw_drive::write_raw_drive(&dir, 3, 120.0).unwrap();
    let run = |toml: &str, out: &str| {
        Command::new(env!("CARGO_BIN_EXE_navfuse"))
            .arg("run")
            .arg(dir.join(toml))
            .arg("--output")
            .arg(dir.join(out))
            .output()
            .unwrap()
    };
    let o = run("tight.toml", "out");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("tight: pseudoranges used"), "{err}");
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out/summary.json")).unwrap())
            .unwrap();
    assert_eq!(s["filter"]["coupling"], "tight");
    let t = &s["tight_coupling"];
    assert!(
        t["total"]["pseudorange_used"].as_u64().unwrap() > 300,
        "{t}"
    );
    assert_eq!(t["total"]["observations"], t["observations"], "{t}");
    assert!(dir.join("out/solution.nav").is_file());
    let text = std::fs::read_to_string(dir.join("tight.toml")).unwrap();
    std::fs::write(
        dir.join("bad.toml"),
        text.replace("coupling = \"tight\"", "coupling = \"tigth\""),
    )
    .unwrap();
    let o = run("bad.toml", "bad");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("coupling") && err.contains("tigth"), "{err}");
    assert!(!dir.join("bad/summary.json").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
