//! Parquet round trips: read back with the parquet crate's reader, equal to
//! the solutions and to the `.nav` text to its printed precision.

use super::*;
use crate::writers::{KfGinsNavWriter, TrajectoryWriter};
use navfuse_core::estimators::eskf::UpdateKind;
use navfuse_core::types::Vec3;

fn tmp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("navfuse-pq-{}-{name}", std::process::id()))
}

/// Solutions over a week rollover, with a longitude past 180°, negative yaw
/// and unknown attitude/σ on some epochs.
fn sols() -> Vec<NavSolution> {
    (0..25)
        .map(|i| {
            let mut s = NavSolution::unknown_at(2_300.0 * 604_800.0 - 1.0 + 0.2 * i as f64);
            s.lat = (30.5 + 1e-7 * i as f64).to_radians();
            s.lon = (179.999_999 + 1e-6 * i as f64).to_radians();
            s.h = 20.123_456 - 0.01 * i as f64;
            s.v_n = Vec3::new(1.0 + i as f64 * 0.1, -2.5, 0.012_345);
            if i % 3 != 0 {
                s.rpy = Vec3::new(0.01, -0.02, (-170.0 + 20.0 * i as f64).to_radians());
                s.std_pos_ned = Vec3::new(0.1, 0.2, 0.3);
                s.std_v_n = Vec3::new(0.01, 0.02, 0.03);
                s.std_rpy = Vec3::new(1e-3, 2e-3, 3e-3);
            }
            s
        })
        .collect()
}

fn f64s<'a>(t: &'a Table, name: &str) -> &'a [f64] {
    match t.column(name) {
        Some(ColumnData::F64(v)) => v,
        other => panic!("column {name}: {other:?}"),
    }
}

fn same(a: f64, b: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

#[test]
fn solutions_round_trip_equal_to_the_nav_text() {
    let sols = sols();
    let p = tmp("sol.parquet");
    // Three row groups of at most 10 rows: the reader joins them in order.
    write_table_grouped(&p, &solutions_table(&sols), 10).unwrap();
    let t = read_table(&p).unwrap();
    std::fs::remove_file(&p).unwrap();
    let want = solutions_table(&sols);
    for (a, b) in t.columns.iter().zip(&want.columns) {
        assert_eq!((&a.name, &a.doc), (&b.name, &b.doc));
        match (&a.data, &b.data) {
            (ColumnData::F64(x), ColumnData::F64(y)) => {
                assert!(x.len() == y.len() && x.iter().zip(y).all(|(p, q)| same(*p, *q)))
            }
            (x, y) => assert_eq!(x, y),
        }
    }
    assert_eq!((t.kind.as_str(), t.rows()), ("solution", 25));
    assert!(t.frames.contains("NED"), "{}", t.frames);
    assert_eq!(t.columns.len(), 21);
    assert!(t.columns.iter().all(|c| !c.doc.is_empty()));

    let mut nav = Vec::new();
    let mut w = KfGinsNavWriter::new(&mut nav);
    sols.iter().for_each(|s| w.write(s).unwrap());
    w.finish().unwrap();
    // The table's columns are the CSV's; the .nav's are gps_week … yaw_deg.
    let csv: Vec<&str> = crate::writers::CSV_HEADER.split(',').collect();
    assert!(t
        .columns
        .iter()
        .map(|c| c.name.as_str())
        .eq(csv.iter().copied()));
    let names = &csv[1..12];
    let weeks = match t.column("gps_week") {
        Some(ColumnData::I32(v)) => v.clone(),
        other => panic!("{other:?}"),
    };
    assert_eq!((weeks[0], weeks[24]), (2299, 2300), "week rollover");
    for (i, line) in std::str::from_utf8(&nav).unwrap().lines().enumerate() {
        for (k, tok) in line.split_whitespace().enumerate() {
            let want: f64 = tok.parse().unwrap();
            let got = if k == 0 {
                weeks[i] as f64
            } else {
                f64s(&t, names[k])[i]
            };
            // Half a unit of the last printed decimal (+ the f64 rounding of it).
            let decimals = tok.split('.').nth(1).map_or(0, str::len);
            let tol = 0.5 * 10f64.powi(-(decimals as i32)) * (1.0 + 1e-9);
            assert!(
                same(got, want) || (got - want).abs() <= tol,
                "row {i} {}: parquet {got} vs .nav {tok}",
                names[k]
            );
        }
    }
    // Full precision, not the text's: exactly the solution's values.
    let lat = f64s(&t, "lat_deg");
    assert!(sols.iter().zip(lat).all(|(s, l)| *l == s.lat.to_degrees()));
    let t_gps = f64s(&t, "t_gps_s");
    assert!(sols.iter().zip(t_gps).all(|(s, x)| *x == s.t));
    assert!(f64s(&t, "lon_deg")
        .iter()
        .all(|l| (-180.0..180.0).contains(l)));
    assert!(f64s(&t, "std_yaw_deg")[0].is_nan() && f64s(&t, "roll_deg")[0].is_nan());
}

#[test]
fn journal_round_trip_with_kinds_and_gate_flags() {
    let kinds = [UpdateKind::GnssPosition, UpdateKind::Zupt, UpdateKind::Nhc];
    let log: Vec<UpdateLog> = (0..7)
        .map(|i| UpdateLog {
            t: 100.0 + i as f64,
            kind: kinds[i % 3],
            nis: 0.5 * i as f64,
            dof: [3u8, 3, 2][i % 3],
            accepted: i != 4,
        })
        .collect();
    let p = tmp("journal.parquet");
    write_journal(&p, &log).unwrap();
    let t = read_table(&p).unwrap();
    std::fs::remove_file(&p).unwrap();
    assert_eq!(t, journal_table(&log));
    assert_eq!(t.kind, "journal");
    match t.column("kind") {
        Some(ColumnData::Str(k)) => assert_eq!(&k[..3], ["gnss_pos", "zupt", "nhc"]),
        other => panic!("{other:?}"),
    }
    match t.column("accepted") {
        Some(ColumnData::Bool(a)) => assert_eq!(a.iter().filter(|a| !**a).count(), 1),
        other => panic!("{other:?}"),
    }
}

#[test]
fn empty_table_is_a_readable_file_with_the_schema() {
    let p = tmp("empty.parquet");
    write_solutions(&p, &[]).unwrap();
    let t = read_table(&p).unwrap();
    std::fs::remove_file(&p).unwrap();
    assert_eq!((t.rows(), t.columns.len()), (0, 21));
}

#[test]
fn ragged_table_and_missing_dir_fail_naming_the_file_and_leave_nothing() {
    let p = tmp("ragged.parquet");
    let t = Table {
        kind: "x".into(),
        frames: String::new(),
        columns: vec![
            Column::new("a", "", ColumnData::F64(vec![1.0, 2.0])),
            Column::new("b", "", ColumnData::I32(vec![1])),
        ],
    };
    let e = write_table(&p, &t).unwrap_err().to_string();
    assert!(
        e.contains("ragged.parquet") && e.contains("column b has 1 rows"),
        "{e}"
    );
    assert!(!p.exists());
    let q = tmp("no-such-dir").join("sol.parquet");
    let e = write_solutions(&q, &sols()).unwrap_err().to_string();
    assert!(e.contains("no-such-dir"), "{e}");
    let e = read_table(&tmp("absent.parquet")).unwrap_err().to_string();
    assert!(e.contains("absent.parquet"), "{e}");
}

#[test]
fn failed_rename_leaves_no_temp_and_success_replaces_whole() {
    // A directory where the file should go: the rename fails after writing.
    let p = tmp("dir.parquet");
    std::fs::create_dir_all(&p).unwrap();
    let e = write_solutions(&p, &sols()).unwrap_err().to_string();
    assert!(e.contains("dir.parquet"), "{e}");
    let mut tmp_name = p.clone().into_os_string();
    tmp_name.push(".tmp");
    let tmp_name = PathBuf::from(tmp_name);
    assert!(!tmp_name.exists(), "temp left behind");
    std::fs::remove_dir(&p).unwrap();
    // An old file is replaced by the new table, and no temp remains.
    std::fs::write(&p, b"old").unwrap();
    write_solutions(&p, &sols()[..3]).unwrap();
    assert_eq!(read_table(&p).unwrap().rows(), 3);
    assert!(!tmp_name.exists());
    std::fs::remove_file(&p).unwrap();
}
