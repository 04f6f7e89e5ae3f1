use super::*;
use crate::fixture::{write_fixture, ESKF_DRIFT_COEF, KFGINS_FACTOR, OUTAGES, TOW0, WEEK};

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("navfuse-report-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// (data-series, number of class="series" elements) for each <svg> of a page.
fn svg_counts(html: &str) -> Vec<(String, usize, usize)> {
    let mut out = Vec::new();
    for part in html.split("<svg ").skip(1) {
        let body = part.split("</svg>").next().unwrap();
        let attr = |k: &str| {
            let key = format!("{k}=\"");
            let i = body.find(&key).unwrap() + key.len();
            body[i..].split('"').next().unwrap().to_string()
        };
        let declared: usize = attr("data-series").parse().unwrap();
        let drawn = body.matches("class=\"series\"").count();
        out.push((attr("id"), declared, drawn));
    }
    out
}

#[test]
fn fixture_report_has_every_section_and_consistent_plots() {
    let dir = tmp("full");
    write_fixture(&dir).unwrap();
    let inp = load_run_dir(&dir, &LoadOptions::default()).unwrap();
    assert_eq!(inp.solutions.len(), 2);
    assert!(inp.truth.is_some() && inp.fixes.is_some() && inp.summary.is_some());
    assert_eq!(inp.outages.len(), 2);
    assert_eq!(inp.innovations.len(), 1);
    assert_eq!(inp.states.len(), 1);
    assert!(inp.ignored.iter().any(|s| s.contains("errors.csv")));
    // kfgins.nav has time of week only: placed in the fixture's week.
    let kf = inp.solutions.iter().find(|s| s.name == "kfgins").unwrap();
    let t_first = f64::from(WEEK) * 604_800.0 + TOW0;
    assert!(
        (kf.epochs[0].t - t_first).abs() < 1e-6,
        "{}",
        kf.epochs[0].t
    );

    let out = dir.join("report");
    let sum = write_report(&out, &inp).unwrap();
    for s in [
        "summary",
        "track",
        "position",
        "velocity",
        "attitude-error",
        "attitude",
        "states",
        "innovations",
        "outages",
        "inputs",
    ] {
        assert!(sum.sections.iter().any(|x| x == s), "section {s} missing");
    }
    let html = std::fs::read_to_string(&sum.html).unwrap();
    let counts = svg_counts(&html);
    assert_eq!(counts.len(), sum.plots.len());
    for (c, p) in counts.iter().zip(&sum.plots) {
        assert_eq!((&c.0, c.1), (&p.id, p.series));
    }
    assert_eq!(counts.len(), sum.svgs.len());
    assert!(html.contains(&format!(
        "<meta name=\"navfuse-plots\" content=\"{}\">",
        counts.len()
    )));
    for (id, declared, drawn) in &counts {
        assert_eq!(declared, drawn, "plot {id}");
        assert!(*declared > 0, "plot {id} is empty");
    }
    // Track: outage highlight, truth, fixes, two solutions.
    assert_eq!(counts.iter().find(|c| c.0 == "track").unwrap().1, 5);
    // NIS of gnss_pos: one estimator's accepted + the rejected markers.
    assert_eq!(counts.iter().find(|c| c.0 == "nis-0").unwrap().1, 2);
    // Self-contained: no external resource.
    assert!(!html.contains("<link") && !html.contains(" src="));
    let external = html
        .match_indices("http")
        .filter(|(i, _)| !html[*i..].starts_with("http://www.w3.org/2000/svg"))
        .count();
    assert_eq!(external, 0);
    assert!(!html.contains("NaN"));
    // Standalone SVGs exist, start with the XML declaration and hold the same plot.
    for p in &sum.svgs {
        let s = std::fs::read_to_string(p).unwrap();
        assert!(s.starts_with("<?xml") && s.contains("<svg xmlns"));
    }
    // The HTML stays small thanks to decimation (3000 epochs × 2 solutions here).
    assert!(html.len() < 2_000_000, "{} bytes", html.len());

    // The outage drift matches the fixture's known error model: quadratic
    // k·τ² north, 0.6·k·τ² east; the window ends at the first fix after
    // the outage (its end), so the last evaluated τ is 19.9 s.
    for (name, k) in [
        ("eskf", ESKF_DRIFT_COEF),
        ("kfgins", ESKF_DRIFT_COEF * KFGINS_FACTOR),
    ] {
        let r = sum.estimators.iter().find(|r| r.name == name).unwrap();
        let o = r.evaluation.as_ref().unwrap().outages.as_ref().unwrap();
        assert_eq!(o.outages.len(), OUTAGES.len());
        let want = k * 19.9f64.powi(2) * (1.0f64 + 0.36).sqrt();
        for x in &o.outages {
            let got = x.max_horizontal.unwrap();
            assert!((got - want).abs() < 0.2, "{name}: {got} vs {want}");
        }
    }
}

#[test]
fn sections_appear_only_with_their_data() {
    let dir = tmp("sparse");
    write_fixture(&dir).unwrap();
    for f in [
        "truth.csv",
        "gnss.csv",
        "summary.json",
        "eskf.innovations.csv",
        "eskf.states.csv",
        "kfgins.nav",
    ] {
        std::fs::remove_file(dir.join(f)).unwrap();
    }
    let inp = load_run_dir(&dir, &LoadOptions::default()).unwrap();
    let r = render(&inp, &mut |_| {}).unwrap();
    assert_eq!(r.sections, vec!["summary", "track", "attitude", "inputs"]);
    assert!(r.outages.is_empty());
    assert!(!r.html.contains("id=\"innovations\""));
}

#[test]
fn truth_from_options_and_outages_from_fix_gaps() {
    let dir = tmp("opts");
    write_fixture(&dir).unwrap();
    std::fs::remove_file(dir.join("summary.json")).unwrap();
    let truth = dir.join("truth.csv");
    let moved = dir.join("elsewhere.truth");
    std::fs::rename(&truth, &moved).unwrap();
    // `.truth` is no trajectory extension: reading it must fail clearly.
    let opt = LoadOptions {
        truth: Some(moved.clone()),
        ..Default::default()
    };
    let e = load_run_dir(&dir, &opt).unwrap_err();
    assert!(e.contains("elsewhere.truth"), "{e}");
    let csv = dir.join("ref.csv");
    std::fs::rename(&moved, &csv).unwrap();
    let inp = load_run_dir(
        &dir,
        &LoadOptions {
            truth: Some(csv.clone()),
            ..Default::default()
        },
    )
    .unwrap();
    // ref.csv is also picked up as a solution (it is a trajectory CSV in the dir).
    assert!(inp.truth.is_some());
    let r = render(&inp, &mut |_| {}).unwrap();
    assert_eq!(r.outages.len(), 2, "{:?}", r.outages);
    let t0 = f64::from(WEEK) * 604_800.0 + TOW0;
    for (o, (a, b)) in r.outages.iter().zip(OUTAGES) {
        // Gap between the last fix before (a − 1) and the first after (b):
        // start = last fix + median interval.
        assert!((o.start - (t0 + a)).abs() < 1e-6, "{o:?}");
        assert!((o.end - (t0 + b)).abs() < 1e-6, "{o:?}");
    }
}

#[test]
fn bad_innovations_name_file_line_and_field() {
    let dir = tmp("badinno");
    let p = dir.join("x.innovations.csv");
    std::fs::write(
        &p,
        "t,kind,nis,dof,accepted\n1.0,gnss_pos,2.0,3,1\n2.0,gnss_pos,abc,3,1\n",
    )
    .unwrap();
    let e = read_innovations(&p, "x").unwrap_err();
    assert!(
        e.contains("x.innovations.csv:3") && e.contains("`nis`"),
        "{e}"
    );
    std::fs::write(&p, "t,kind,nis,dof,accepted\n1.0,gnss_pos,2.0,3,maybe\n").unwrap();
    let e = read_innovations(&p, "x").unwrap_err();
    assert!(e.contains(":2") && e.contains("`accepted`"), "{e}");
    std::fs::write(&p, "t,kind,nis,accepted\n").unwrap();
    let e = read_innovations(&p, "x").unwrap_err();
    assert!(e.contains("`dof`"), "{e}");
    let ok = dir.join("y.innovations.csv");
    std::fs::write(
        &ok,
        "t,kind,nis,dof,accepted,estimator\n1,a,2,3,1,e1\n2,a,9,3,0,e2\n",
    )
    .unwrap();
    let sets = read_innovations(&ok, "y").unwrap();
    assert_eq!(sets.len(), 2);
    assert!(!sets[1].rows[0].accepted);
    let st = dir.join("s.states.csv");
    std::fs::write(&st, "t,bg_x_dph\n1,2\n2\n").unwrap();
    let e = read_states(&st, "s").unwrap_err();
    assert!(e.contains("s.states.csv:3"), "{e}");
}

#[test]
fn kfgins_output_folder_gives_sigma_and_imu_errors() {
    let dir = tmp("kfout");
    let nav =
        "0 100.0 40.0 -105.0 1600.0 1 0 0 0 0 90\n0 100.5 40.00001 -105.0 1600.0 1 0 0 0 0 90\n";
    std::fs::write(dir.join("KF_GINS_Navresult.nav"), nav).unwrap();
    let mut std_txt = String::new();
    let mut err_txt = String::new();
    for t in [100.0, 100.5] {
        std_txt.push_str(&format!("{t} 0.1 0.2 0.3 0.01 0.02 0.03 1 2 3"));
        for k in 0..12 {
            std_txt.push_str(&format!(" {}", 10 + k));
        }
        std_txt.push('\n');
        err_txt.push_str(&format!("{t} 5 6 7 100 200 300 1 2 3 4 5 6\n"));
    }
    std::fs::write(dir.join("KF_GINS_STD.txt"), &std_txt).unwrap();
    std::fs::write(dir.join("KF_GINS_IMU_ERR.txt"), &err_txt).unwrap();
    let inp = load_run_dir(&dir, &LoadOptions::default()).unwrap();
    assert_eq!(inp.solutions.len(), 1);
    assert!(inp.ignored.is_empty(), "{:?}", inp.ignored);
    let e = &inp.solutions[0].epochs[1];
    assert_eq!(e.std_pos_ned, navfuse_core::Vec3::new(0.1, 0.2, 0.3));
    assert!((e.std_rpy.z - 3f64.to_radians()).abs() < 1e-12);
    let st = &inp.states[0];
    assert_eq!(st.columns.len(), 24);
    let k = st.columns.iter().position(|c| c == "ba_y_mgal").unwrap();
    let ks = st
        .columns
        .iter()
        .position(|c| c == "std_ba_y_mgal")
        .unwrap();
    assert_eq!((st.values[1][k], st.values[1][ks]), (200.0, 14.0));
    let r = render(&inp, &mut |_| {}).unwrap();
    assert!(r.sections.iter().any(|s| s == "states"));
    // A broken STD line names file, line and column.
    std::fs::write(
        dir.join("KF_GINS_STD.txt"),
        std_txt.replace("0.2 0.3", "0.2 x"),
    )
    .unwrap();
    let e = load_run_dir(&dir, &LoadOptions::default()).unwrap_err();
    assert!(
        e.contains("KF_GINS_STD.txt:1") && e.contains("column 4"),
        "{e}"
    );
}

#[test]
fn empty_directory_is_a_clear_error() {
    let dir = tmp("empty");
    let inp = load_run_dir(&dir, &LoadOptions::default()).unwrap();
    let e = render(&inp, &mut |_| {}).err().unwrap();
    assert!(e.contains("nothing to report"), "{e}");
    let e = load_run_dir(&dir.join("nope"), &LoadOptions::default()).unwrap_err();
    assert!(e.contains("no such directory"), "{e}");
}

#[test]
fn fix_gap_outages() {
    let mut t: Vec<f64> = (0..100).map(f64::from).collect();
    t.retain(|x| !(30.0..50.0).contains(x));
    let o = outages_from_fix_gaps(&t);
    assert_eq!(
        o,
        vec![Outage {
            start: 30.0,
            end: 50.0
        }]
    );
    assert!(outages_from_fix_gaps(&[0.0, 1.0]).is_empty());
}

/// The drive_0708 outage run: KF-GINS's own result against the RTK truth,
/// with the README's outage schedule. Checks the report reproduces the
/// README's per-outage maxima (15.7, 73.1, 51.8, 12.3, 40.4 m; RMS 44.85 m).
#[test]
#[ignore = "real data: run with `cargo test --release -- --ignored`"]
fn drive_0708_kfgins_outage_report() {
    use navfuse_io::data::require;
    let kf = require("drive_0708/kfgins/kfgins_result_outage_10hz.nav");
    let truth = require("drive_0708/kfgins/truth.nav");
    let fixes = require("drive_0708/kfgins/gnss_outage.txt");
    let dir = tmp("drive0708");
    let mut inp = load_run_dir(
        &dir,
        &LoadOptions {
            truth: Some(truth),
            fixes: Some(fixes),
            solutions: vec![("KF-GINS".into(), kf)],
            ..Default::default()
        },
    )
    .unwrap();
    inp.eval.lever_arm_b = Some([0.0, -0.05, 0.0]);
    let week = (inp.truth.as_ref().unwrap().epochs[0].t / 604_800.0).floor();
    let t0 = week * 604_800.0 + 243_262.0;
    inp.outages = (0..5)
        .map(|k| Outage {
            start: t0 + 120.0 + 90.0 * f64::from(k),
            end: t0 + 150.0 + 90.0 * f64::from(k),
        })
        .collect();
    let sum = write_report(&dir.join("report"), &inp).unwrap();
    let o = sum.estimators[0]
        .evaluation
        .as_ref()
        .unwrap()
        .outages
        .as_ref()
        .unwrap();
    let got: Vec<f64> = o
        .outages
        .iter()
        .map(|x| x.max_horizontal.unwrap())
        .collect();
    let want = [15.7, 73.1, 51.8, 12.3, 40.4];
    assert_eq!(got.len(), 5, "{got:?}");
    // Compared at the truth epochs (the report's default, the README's
    // convention); README values are rounded to 0.1 m.
    for (g, w) in got.iter().zip(want) {
        assert!((g - w).abs() <= 0.05, "{got:?} vs {want:?}");
    }
    assert!((o.rms_of_max.unwrap() - 44.85).abs() <= 0.01);
    let html = std::fs::read_to_string(&sum.html).unwrap();
    for (id, declared, drawn) in svg_counts(&html) {
        assert_eq!(declared, drawn, "{id}");
        assert!(declared > 0, "{id}");
    }
}

#[test]
fn demo_layout_nav_and_csv_of_one_solution_and_two_truths() {
    // `navfuse demo` writes every solution as .nav and .csv, the truth as
    // .nav and .csv, and a run.toml.
    let dir = tmp("demo-layout");
    write_fixture(&dir).unwrap();
    std::fs::copy(dir.join("kfgins.nav"), dir.join("eskf.nav")).unwrap();
    std::fs::copy(dir.join("kfgins.nav"), dir.join("truth.nav")).unwrap();
    std::fs::write(dir.join("run.toml"), "seed = 1\n").unwrap();
    let inp = load_run_dir(&dir, &LoadOptions::default()).unwrap();
    let names: Vec<&str> = inp.solutions.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, vec!["eskf", "kfgins"]);
    assert!(inp.solutions[0]
        .path
        .as_ref()
        .unwrap()
        .ends_with("eskf.csv"));
    assert!(inp
        .ignored
        .iter()
        .any(|s| s.contains("eskf.nav") && s.contains("same solution")));
    assert!(inp
        .truth
        .as_ref()
        .unwrap()
        .path
        .as_ref()
        .unwrap()
        .ends_with("truth.nav"));
    assert!(inp.ignored.iter().any(|s| s.contains("truth.csv")));
    assert_eq!(
        inp.config_files,
        vec![("run.toml".to_string(), "seed = 1\n".to_string())]
    );
    let r = render(&inp, &mut |_| {}).unwrap();
    assert!(r.html.contains("<h3>run.toml</h3>"));
}

/// `solution.nav` alone: no uncertainty section; with `solution.std` beside
/// it (or given as `--std`): σ attached, the ±2σ and NEES plots drawn, and
/// the NEES of an error drawn with exactly the σ it claims (N(0, σ²) per
/// axis, seeded) is χ²(2): about 5 % above 5.991.
#[test]
fn sigma_plots_appear_with_a_std_file_and_not_without() {
    use navfuse_core::Vec3;
    use navfuse_io::stdfile::{write_std_row, StdRow};
    use navfuse_io::trajectory::OutFormat;
    let dir = tmp("sigma");
    let truth = crate::fixture::truth();
    let write = |name: &str, fmt: OutFormat, s: &[NavSolution]| {
        let mut w = navfuse_io::trajectory::create_writer(&dir.join(name), fmt).unwrap();
        for x in s {
            w.write(x).unwrap();
        }
        w.finish().unwrap();
    };
    write("truth.csv", OutFormat::Csv, &truth);
    // Errors N(0, σ²) with σ = (0.4, 0.3, 0.8) m (Box–Muller on an xorshift).
    let sd = Vec3::new(0.4, 0.3, 0.8);
    let mut st = 0x2545_f491_4f6c_dd1du64;
    let mut u = move || {
        st ^= st << 13;
        st ^= st >> 7;
        st ^= st << 17;
        ((st >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    let mut z = move || (-2.0 * u().ln()).sqrt() * (std::f64::consts::TAU * u()).cos();
    let r = 6_378_137.0;
    let sol: Vec<NavSolution> = truth
        .iter()
        .map(|t| {
            let mut s = *t;
            s.lat += sd.x * z() / r;
            s.lon += sd.y * z() / (r * t.lat.cos());
            s.h -= sd.z * z();
            s
        })
        .collect();
    write("solution.nav", OutFormat::Nav, &sol);
    let ids = |r: &Rendered| r.plots.iter().map(|p| p.0.clone()).collect::<Vec<_>>();
    let plain = render(
        &load_run_dir(&dir, &LoadOptions::default()).unwrap(),
        &mut |_| {},
    )
    .unwrap();
    assert!(!plain.sections.iter().any(|s| s == "uncertainty"));
    assert!(!ids(&plain)
        .iter()
        .any(|i| i.starts_with("sigma-") || i.starts_with("nees")));
    let mut f = Vec::new();
    for s in &sol {
        let row = StdRow {
            t: s.t,
            pos_ned: sd,
            vel_ned: Vec3::repeat(0.05),
            att_rpy: Vec3::repeat(0.01),
            bg: Vec3::zeros(),
            ba: Vec3::zeros(),
            sg: Vec3::zeros(),
            sa: Vec3::zeros(),
            pos_cross_ned: Vec3::repeat(f64::NAN),
            status: None,
        };
        write_std_row(&mut f, &row).unwrap();
    }
    let std_path = dir.join("solution.std");
    std::fs::write(&std_path, &f).unwrap();
    let inp = load_run_dir(&dir, &LoadOptions::default()).unwrap();
    assert_eq!(inp.solutions.len(), 1, "{:?}", inp.ignored);
    assert_eq!(inp.solutions[0].epochs[5].std_pos_ned, sd);
    assert!(inp.solutions[0]
        .records
        .as_ref()
        .unwrap()
        .contains("σ from solution.std"));
    let with = render(&inp, &mut |_| {}).unwrap();
    assert!(with.sections.iter().any(|s| s == "uncertainty"));
    for id in ["sigma-horizontal", "sigma-vertical", "nees-horizontal"] {
        assert!(ids(&with).iter().any(|i| i == id), "{id} missing");
    }
    assert!(with.html.contains("χ²(2) 95 % = 5.991"));
    // The table row: share of NEES above 5.991 near 5 % (3001 epochs: ±1.2 %).
    let sect = with.html.split("id=\"uncertainty\"").nth(1).unwrap();
    let row = sect.split("<td>solution</td>").nth(1).unwrap();
    let cells: Vec<&str> = row.split("<td>").skip(3).take(1).collect();
    let share: f64 = cells[0].split(' ').next().unwrap().parse().unwrap();
    assert!(
        (2.5..7.5).contains(&share),
        "NEES share above χ²(2) 95 %: {share} %"
    );
    // Explicit --std with another stem: attached to the (only) solution.
    let moved = dir.join("other.sigma");
    std::fs::rename(&std_path, &moved).unwrap();
    let opt = LoadOptions {
        std: Some(moved),
        ..Default::default()
    };
    let inp = load_run_dir(&dir, &opt).unwrap();
    assert_eq!(inp.solutions[0].epochs[0].std_pos_ned, sd);
    let _ = std::fs::remove_dir_all(&dir);
}
