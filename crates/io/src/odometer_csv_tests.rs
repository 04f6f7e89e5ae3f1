use super::*;

fn read(text: &str, cfg: OdoCsvConfig) -> (Result<Vec<OdometerSample>, ReadError>, RecordStats) {
    let mut r = OdoCsvReader::new(text.as_bytes(), "w.csv", cfg);
    let v = r.by_ref().collect::<Result<Vec<_>, _>>();
    (v, r.stats().clone())
}

fn name(s: &str) -> Col {
    Col::Name(s.into())
}

#[test]
fn speed_of_an_axle_is_the_mean_of_its_wheels_with_a_reverse_column() {
    let cfg = OdoCsvConfig {
        values: vec![name("rl"), name("rr")],
        reverse: Some(name("gear_r")),
        unit: 1.0 / 3.6,
        ..OdoCsvConfig::speed(name("t"), name("rl"))
    };
    let text =
        "# wheel speeds, km/h\nt,rl,rr,gear_r\n10.0,36,36.72,0\n10.1,7.2,7.2,1\n10.1,7,7,1\n";
    let (v, st) = read(text, cfg);
    let v = v.unwrap();
    assert_eq!(v.len(), 2);
    assert!((v[0].speed_mps - 10.1).abs() < 1e-12);
    assert_eq!(v[0].dt, 0.0);
    assert!((v[1].speed_mps + 2.0).abs() < 1e-12);
    assert_eq!(st.rejected_for(REASON_TIME), 1);
    assert!(st.is_balanced(), "{st:?}");
}

#[test]
fn cumulative_distance_and_increments_give_the_interval_mean() {
    let mut cfg = OdoCsvConfig::speed(Col::Index(0), Col::Index(1));
    cfg.quantity = OdoQuantity::Distance;
    cfg.header = false;
    // 2 m in 0.1 s, then −0.5 m in 0.1 s (reversing), then a 2-s gap.
    let text = "1.0,100\n1.1,102\n1.2,101.5\n3.2,110\n3.3,111\n";
    let (v, st) = read(text, cfg.clone());
    let v = v.unwrap();
    assert_eq!(v.len(), 3);
    assert!((v[0].speed_mps - 20.0).abs() < 1e-9 && (v[0].dt - 0.1).abs() < 1e-12);
    assert!((v[1].speed_mps + 5.0).abs() < 1e-9);
    assert!((v[2].speed_mps - 10.0).abs() < 1e-9 && (v[2].t - 3.3).abs() < 1e-12);
    assert_eq!(st.rejected_for(REASON_GAP), 1);
    assert!(st.is_balanced(), "{st:?}");
    cfg.quantity = OdoQuantity::Increment;
    let (v, _) = read("1.0,5\n1.1,2\n1.2,-0.5\n", cfg);
    let v = v.unwrap();
    assert_eq!(v.len(), 2);
    assert!((v[0].speed_mps - 20.0).abs() < 1e-9);
    assert!((v[1].speed_mps + 5.0).abs() < 1e-9);
}

#[test]
fn errors_name_file_line_and_field() {
    let cfg = OdoCsvConfig::speed(name("t"), name("v"));
    let (v, _) = read("t,v\n1.0,2\n1.1,x\n", cfg.clone());
    let e = v.unwrap_err().to_string();
    assert!(
        e.contains("w.csv") && e.contains(":3") && e.contains("v"),
        "{e}"
    );
    let (v, _) = read("t,speed\n1.0,2\n", cfg.clone());
    let e = v.unwrap_err().to_string();
    assert!(e.contains("not found"), "{e}");
    let (v, _) = read("t,v\n1.0,400\n", cfg.clone());
    assert!(v.unwrap_err().to_string().contains("beyond"));
    let mut bad = cfg;
    bad.unit = 0.0;
    assert!(read("t,v\n1,2\n", bad).0.is_err());
}
