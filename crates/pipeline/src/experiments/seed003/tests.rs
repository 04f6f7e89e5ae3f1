use super::*;

/// Real data: `navfuse experiment seed003` end to end (small), JSON schema
/// of issue 7 and its key claims.
#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn seed003_end_to_end_json() {
    let alm = navfuse_io::data::require("gnss/almanac/yuma_week1011.alm");
    let rinex = navfuse_io::data::require("gnss/rinex/07590920.05o");
    let json = std::env::temp_dir().join(format!("seed003_{}.json", std::process::id()));
    run(Options {
        lambda_seed0: 5000,
        smoother_lag: 3,
        att_order: 2,
        seeds: 2,
        epochs: 200,
        after: 150,
        lambda_runs: 5,
        almanac: Some(alm),
        rinex_dir: Some(rinex.parent().unwrap().to_path_buf()),
        skip_geonet: false,
        json: Some(json.clone()),
        plots: None,
    })
    .unwrap();
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    for noise in ["2mm", "0.5mm"] {
        for a in ["pitch_deg", "roll_deg", "yaw_deg"] {
            let x = v["table1"][noise][a].as_f64().unwrap();
            assert!(x > 0.0 && x < 1.0, "{noise} {a} {x}");
        }
    }
    assert_eq!(v["lambda"]["runs"], 5);
    assert_eq!(v["lambda"]["wrong_fixes"], 0);
    assert_eq!(v["lambda"]["fixed_within_3_epochs"], 5);
    // Joint fixed-DD attitude and its filter beat per-epoch Wahba; the
    // smoother beats the filter.
    let l = &v["lambda"];
    for a in ["pitch", "roll", "yaw"] {
        let g = |k: &str| l[k][a].as_f64().unwrap();
        assert!(g("rms_after_fix_deg") < g("rms_after_fix_wahba_deg"), "{a}");
        assert!(
            g("rms_after_fix_joint_ls_deg") < g("rms_after_fix_wahba_deg"),
            "{a}"
        );
        assert!(
            g("rms_after_fix_smoothed_deg") < g("rms_after_fix_deg"),
            "{a}"
        );
    }
    assert!(v["geonet"]["fixed_error_m"].as_f64().unwrap() < 0.01);
    assert!(v["geonet"]["fix_rate"].as_f64().unwrap() >= 0.95);
    std::fs::remove_file(&json).ok();
}
