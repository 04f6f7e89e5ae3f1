//! `navfuse convert` end to end: runs the binary.

use std::path::{Path, PathBuf};
use std::process::Command;

fn navfuse(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_navfuse"))
        .args(args)
        .output()
        .expect("run navfuse");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("navfuse-convert-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

const POS: &str = "%  GPST            latitude(deg) longitude(deg) height(m) Q ns sdn(m) sde(m) sdu(m) sdne(m) sdeu(m) sdun(m) age(s) ratio\n\
2025/07/08 19:34:18.500 40.0966268 -105.1474483 1601.4740 1 21 0.0099 0.0099 0.0100 0.0 0.0 0.0 0.0 0.0\n\
2025/07/08 19:34:18.750 40.0966270 -105.1474480 1601.4760 2 20 0.0099 0.0099 0.0100 0.0 0.0 0.0 0.0 0.0\n";

/// Check a GeoJSON/KML/GPX/nav file of `n` epochs is valid.
fn check_output(p: &Path, n: usize) {
    let text = std::fs::read_to_string(p).unwrap();
    match p.extension().unwrap().to_str().unwrap() {
        "geojson" => {
            let geojson::GeoJson::FeatureCollection(fc) =
                text.parse::<geojson::GeoJson>().expect("GeoJSON")
            else {
                panic!("not a FeatureCollection")
            };
            assert_eq!(fc.features.len(), n + 1);
        }
        "kml" | "gpx" => {
            let mut r = quick_xml::Reader::from_str(&text);
            let (mut pts, mut coords) = (0, 0);
            loop {
                match r.read_event().expect("well-formed XML") {
                    quick_xml::events::Event::Start(e) => match e.name().as_ref() {
                        b"trkpt" => pts += 1,
                        b"coordinates" => coords += 1,
                        _ => {}
                    },
                    quick_xml::events::Event::Text(t) if coords == 1 && pts == 0 => {
                        pts = t.unescape().unwrap().split_whitespace().count();
                    }
                    quick_xml::events::Event::Eof => break,
                    _ => {}
                }
            }
            assert_eq!(pts, n, "{}", p.display());
        }
        "nav" => {
            assert_eq!(text.lines().count(), n);
            assert!(text.lines().all(|l| l.split_whitespace().count() == 11));
        }
        e => panic!("{e}"),
    }
}

#[test]
fn converts_pos_by_extension_and_reports_counts() {
    let input = tmp("small.pos");
    std::fs::write(&input, POS).unwrap();
    for ext in ["geojson", "kml", "gpx", "nav"] {
        let out = tmp(&format!("small.{ext}"));
        let (ok, stdout, stderr) =
            navfuse(&["convert", input.to_str().unwrap(), out.to_str().unwrap()]);
        assert!(ok, "{stderr}");
        assert!(
            stdout.contains("2 records read, 2 written, 0 rejected"),
            "{stdout}"
        );
        check_output(&out, 2);
    }
}

#[test]
fn errors_name_file_line_and_field() {
    let input = tmp("bad.pos");
    std::fs::write(&input, POS.replace("1601.4760", "16O1.476")).unwrap();
    let (ok, _, stderr) = navfuse(&[
        "convert",
        input.to_str().unwrap(),
        tmp("bad.kml").to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(
        stderr.contains("bad.pos:3: field `height(m)`: not a number"),
        "{stderr}"
    );
    let (ok, _, stderr) = navfuse(&[
        "convert",
        input.to_str().unwrap(),
        tmp("x.unknown").to_str().unwrap(),
    ]);
    assert!(!ok && stderr.contains("--to"), "{stderr}");
    let gnss = tmp("gnss.txt");
    std::fs::write(
        &gnss,
        "243262.999 40.0966268 -105.1474484 1601.468 0.02 0.02 0.03\n",
    )
    .unwrap();
    let (ok, _, stderr) = navfuse(&[
        "convert",
        gnss.to_str().unwrap(),
        tmp("g.gpx").to_str().unwrap(),
    ]);
    assert!(!ok && stderr.contains("--from"), "{stderr}");
    let (ok, stdout, stderr) = navfuse(&[
        "convert",
        gnss.to_str().unwrap(),
        tmp("g.gpx").to_str().unwrap(),
        "--from",
        "kfgins-gnss",
        "--gps-week",
        "2374",
    ]);
    assert!(ok, "{stderr}");
    assert!(stdout.contains("1 records read, 1 written"));
    let gpx = std::fs::read_to_string(tmp("g.gpx")).unwrap();
    assert!(
        gpx.contains("<time>2025-07-08T19:34:04.999Z</time>"),
        "{gpx}"
    );
}

#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn converts_real_pos_to_every_format() {
    let input = navfuse_io::data::require("drive_0708/gnss_1934_sf.pos");
    for ext in ["geojson", "kml", "gpx", "nav", "csv"] {
        let out = tmp(&format!("drive.{ext}"));
        let (ok, stdout, stderr) =
            navfuse(&["convert", input.to_str().unwrap(), out.to_str().unwrap()]);
        assert!(ok, "{stderr}");
        assert!(
            stdout.contains("2197 records read, 2197 written, 0 rejected"),
            "{stdout}"
        );
        if ext != "csv" {
            check_output(&out, 2197);
        }
    }
    // Round trip through the CSV back to .nav equals the direct .nav.
    let (ok, _, stderr) = navfuse(&[
        "convert",
        tmp("drive.csv").to_str().unwrap(),
        tmp("drive2.nav").to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    assert_eq!(
        std::fs::read_to_string(tmp("drive.nav")).unwrap(),
        std::fs::read_to_string(tmp("drive2.nav")).unwrap()
    );
}
