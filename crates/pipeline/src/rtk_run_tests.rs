use crate::config::RunConfig;
use std::path::Path;

fn run_err(toml: &str) -> String {
    let cfg: RunConfig = toml::from_str(toml).unwrap();
    match crate::run::run(&cfg, Path::new("/nonexistent"), &Default::default()) {
        Ok(_) => panic!("ran"),
        Err(e) => e.to_string(),
    }
}

const HEAD: &str = "[input]\nimu = \"imu.csv\"\ngnss = \"rover.ubx\"\n";

#[test]
fn rtk_without_base_is_an_error_naming_the_key() {
    let e = run_err(&format!("{HEAD}[filter]\ncoupling = \"rtk\"\n"));
    assert!(e.contains("[input] base"), "{e}");
}

#[test]
fn base_without_rtk_is_an_error() {
    let e = run_err(&format!(
        "{HEAD}base = \"b.obs\"\n[filter]\ncoupling = \"tight\"\n"
    ));
    assert!(e.contains("coupling = \"rtk\""), "{e}");
    let e = run_err(&format!("{HEAD}base_position = \"header\"\n"));
    assert!(e.contains("base_position"), "{e}");
}

#[test]
fn rinex_base_without_nav_is_an_error_naming_nav() {
    let e = run_err(&format!(
        "{HEAD}base = \"base.obs\"\n[filter]\ncoupling = \"rtk\"\nsmooth = false\n"
    ));
    assert!(e.contains("[input] nav") && e.contains("base"), "{e}");
}

#[test]
fn bad_base_position_is_an_error() {
    for bp in ["\"headr\"", "[95.0, 10.0, 0.0]", "[1.0e7, 0.0, 0.0]"] {
        let e = run_err(&format!(
            "{HEAD}base = \"base.obs\"\nbase_position = {bp}\n[filter]\ncoupling = \"rtk\"\n"
        ));
        assert!(e.contains("base_position"), "{bp}: {e}");
    }
}

#[test]
fn rtk_refuses_the_smoother() {
    let e = run_err(&format!(
        "{HEAD}base = \"base.obs\"\n[filter]\ncoupling = \"rtk\"\nsmooth = true\n"
    ));
    assert!(e.contains("smooth"), "{e}");
}

/// A base whose epochs are nowhere near the rover's (the GEONET 2005 base
/// against the simulated drive): an input error saying so.
#[test]
#[ignore = "real data: NAVFUSE_DATA=… cargo test --release -p navfuse-pipeline rtk_run -- --ignored"]
fn base_without_overlapping_epochs_is_an_error() {
    let base = navfuse_io::data::require("gnss/rinex/07590920.05o");
    let nav = navfuse_io::data::require("gnss/rinex/07590920.05n");
    let dir = crate::test_dir("rtk-no-overlap");
    crate::raw_drive::write_raw_drive(&dir, 1, 300.0).unwrap();
    let t = std::fs::read_to_string(dir.join("tight.toml"))
        .unwrap()
        .replace("coupling = \"tight\"", "coupling = \"rtk\"\nsmooth = false")
        .replace(
            "gnss = \"raw.ubx\"\n",
            &format!(
                "gnss = \"raw.ubx\"\nbase = {:?}\nnav = {:?}\n",
                base.display().to_string(),
                nav.display().to_string()
            ),
        );
    std::fs::write(dir.join("rtk.toml"), t).unwrap();
    let e = crate::run_tests::run_to(&dir.join("rtk.toml"), &dir.join("out")).unwrap_err();
    assert!(e.contains("do not overlap"), "{e}");
}
