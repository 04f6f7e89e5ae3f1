//! The run's output files: solutions in every requested format and the
//! innovation journal.

use crate::error::{PipelineError, Result};
use navfuse_core::estimators::eskf::UpdateLog;
use navfuse_core::types::NavSolution;
use navfuse_io::trajectory::{create_writer, OutFormat};
use std::path::Path;

/// Every measurement update the ESKF tried (`t,kind,nis,dof,accepted`), the
/// report's innovation monitor input. Returns the path written.
pub fn write_innovations(path: &Path, log: &[UpdateLog]) -> Result<String> {
    use std::io::Write as _;
    let io = PipelineError::io(path, "");
    let write = || -> std::io::Result<()> {
        let mut w = navfuse_io::atomic::AtomicFile::create(path)?;
        writeln!(w, "t,kind,nis,dof,accepted")?;
        for u in log {
            writeln!(
                w,
                "{:.4},{},{:.6},{},{}",
                u.t,
                u.kind.name(),
                u.nis,
                u.dof,
                u.accepted as u8
            )?;
        }
        w.commit()
    };
    write().map_err(io)?;
    Ok(path.display().to_string())
}

/// The journal of an RTK run: [`write_innovations`]'s rows and columns,
/// then one `rtk_fix` row per applied RTK epoch (after the updates of the
/// same filter time), with columns added at the end (empty in the other
/// rows): `n_fixed`, `ratio`, `success_rate`, `decision` (`fixed`,
/// `fixed_partial`, `no_ambiguities`, `rejected_too_few`,
/// `rejected_success_rate`, `rejected_ratio`, `rejected_lambda`: the reason
/// the last, smallest subset tried failed), `resets_loss_of_lock`,
/// `resets_ins_slip`, `resets_reference`, `ambiguities_new`,
/// `ambiguities_freed`. In an `rtk_fix` row `nis` is `nan` (no innovation),
/// `dof` the number of DD ambiguities offered to LAMBDA and `accepted`
/// whether the epoch was fixed. Returns the path written.
pub fn write_innovations_rtk(
    path: &Path,
    log: &[UpdateLog],
    rtk: &[crate::rtk_run::RtkEpochOut],
) -> Result<String> {
    use std::io::Write as _;
    let io = PipelineError::io(path, "");
    let write = || -> std::io::Result<()> {
        let mut w = navfuse_io::atomic::AtomicFile::create(path)?;
        writeln!(
            w,
            "t,kind,nis,dof,accepted,n_fixed,ratio,success_rate,decision,resets_loss_of_lock,\
             resets_ins_slip,resets_reference,ambiguities_new,ambiguities_freed"
        )?;
        let mut k = 0;
        let rtk_row = |w: &mut navfuse_io::atomic::AtomicFile, e: &crate::rtk_run::RtkEpochOut| {
            let r = e.resets;
            writeln!(
                w,
                "{:.4},rtk_fix,nan,{},{},{},{:.3},{:.6},{},{},{},{},{},{}",
                e.t,
                e.n_candidates,
                e.decision.is_fixed() as u8,
                e.n_fixed,
                e.ratio,
                e.success_rate,
                e.decision.name(),
                r.loss_of_lock,
                r.ins_slip,
                r.reference,
                r.rises,
                r.sets
            )
        };
        for u in log {
            while k < rtk.len() && rtk[k].t < u.t {
                rtk_row(&mut w, &rtk[k])?;
                k += 1;
            }
            writeln!(
                w,
                "{:.4},{},{:.6},{},{},,,,,,,,,",
                u.t,
                u.kind.name(),
                u.nis,
                u.dof,
                u.accepted as u8
            )?;
        }
        for e in &rtk[k..] {
            rtk_row(&mut w, e)?;
        }
        w.commit()
    };
    write().map_err(io)?;
    Ok(path.display().to_string())
}

/// The update journal as a Parquet table
/// ([`navfuse_io::parquet_out::journal_table`]: `t_gps_s`, `kind`, `nis`,
/// `dof`, `accepted`), written whole or not at all. Returns the path written.
pub fn write_journal_parquet(path: &Path, log: &[UpdateLog]) -> Result<String> {
    navfuse_io::parquet_out::write_journal(path, log)
        .map_err(|e| PipelineError::Output(e.to_string()))?;
    Ok(path.display().to_string())
}

/// The extra output formats named in the config (by extension: csv, nav,
/// geojson, kml, gpx, nmea, parquet, pos). An unknown name is a [`PipelineError::Options`].
pub fn out_formats(names: &[String]) -> Result<Vec<OutFormat>> {
    names
        .iter()
        .map(|n| {
            OutFormat::from_path(Path::new(&format!("x.{n}"))).ok_or_else(|| {
                PipelineError::Options(format!(
                    "unknown format {n:?} (csv, nav, geojson, kml, gpx, nmea, parquet, pos)"
                ))
            })
        })
        .collect()
}

/// Write `STEM.nav` (KF-GINS layout, always) and `STEM.<ext>` for every extra
/// format in `dir`; returns the paths written.
pub fn write_solutions(
    dir: &Path,
    stem: &str,
    sols: &[NavSolution],
    formats: &[OutFormat],
) -> Result<Vec<String>> {
    let mut written = Vec::new();
    let mut all = vec![OutFormat::Nav];
    all.extend(formats.iter().copied().filter(|f| *f != OutFormat::Nav));
    for fmt in all {
        let p = dir.join(format!("{stem}.{}", fmt.extension()));
        let write = || -> std::io::Result<()> {
            let mut w = create_writer(&p, fmt)?;
            for s in sols {
                w.write(s)?;
            }
            w.finish()
        };
        write().map_err(PipelineError::io(&p, ""))?;
        written.push(p.display().to_string());
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn out_formats_by_extension_and_unknown_named() {
        let f = out_formats(&["csv".into(), "geojson".into(), "parquet".into()]).unwrap();
        assert_eq!(f, [OutFormat::Csv, OutFormat::GeoJson, OutFormat::Parquet]);
        let e = out_formats(&["shp".into()]).unwrap_err().to_string();
        assert!(e.contains("\"shp\""), "{e}");
    }

    /// `formats = ["parquet"]` with the smoother: `solution.parquet` and
    /// `solution_smoothed.parquet` equal their `.nav` to the printed decimals,
    /// `journal.parquet` holds the rows of `solution.innovations.csv`.
    #[test]
    fn parquet_outputs_equal_the_nav_and_the_innovations() {
        use navfuse_io::parquet_out::{read_table, ColumnData};
        let dir = crate::test_dir("run-parquet");
        crate::run_tests::write_north_drive(&dir);
        let toml = "formats = [\"parquet\"]\n[input]\nimu = \"imu.txt\"\ngnss = \"gnss.txt\"\n\
                    [filter]\nsmooth = true\n";
        std::fs::write(dir.join("run.toml"), toml).unwrap();
        let out = dir.join("out");
        crate::run_tests::run_to(&dir.join("run.toml"), &out).unwrap();
        for stem in ["solution", "solution_smoothed"] {
            let t = read_table(&out.join(format!("{stem}.parquet"))).unwrap();
            let nav = std::fs::read_to_string(out.join(format!("{stem}.nav"))).unwrap();
            assert_eq!(t.rows(), nav.lines().count(), "{stem}");
            assert!(t.rows() > 300, "{stem}: {} rows", t.rows());
            // .nav columns and their printed decimals (KfGinsNavWriter).
            let cols = [
                ("gps_tow_s", 6),
                ("lat_deg", 10),
                ("lon_deg", 10),
                ("h_m", 4),
                ("v_n_mps", 4),
                ("v_e_mps", 4),
                ("v_d_mps", 4),
                ("roll_deg", 6),
                ("pitch_deg", 6),
                ("yaw_deg", 6),
            ];
            for (i, line) in nav.lines().enumerate() {
                let v: Vec<f64> = line
                    .split_whitespace()
                    .map(|x| x.parse().unwrap())
                    .collect();
                match t.column("gps_week") {
                    Some(ColumnData::I32(w)) => assert_eq!(w[i] as f64, v[0]),
                    other => panic!("{other:?}"),
                }
                for (k, (name, dec)) in cols.iter().enumerate() {
                    let Some(ColumnData::F64(c)) = t.column(name) else {
                        panic!("{stem}: no column {name}")
                    };
                    let tol = 0.5 * 10f64.powi(-dec) * (1.0 + 1e-9);
                    let ok = (c[i] - v[k + 1]).abs() <= tol || (c[i].is_nan() && v[k + 1].is_nan());
                    assert!(ok, "{stem} row {i} {name}: {} vs .nav {}", c[i], v[k + 1]);
                }
            }
        }
        // σ columns: the σ file's position σ, row for row (9 decimals there).
        for stem in ["solution", "solution_smoothed"] {
            let t = read_table(&out.join(format!("{stem}.parquet"))).unwrap();
            let std = navfuse_io::stdfile::read_std_file(&out.join(format!("{stem}.std"))).unwrap();
            assert_eq!(std.len(), t.rows(), "{stem}");
            for (k, name) in ["std_n_m", "std_e_m", "std_d_m"].iter().enumerate() {
                let Some(ColumnData::F64(c)) = t.column(name) else {
                    panic!("{stem}: no column {name}")
                };
                for (i, r) in std.iter().enumerate() {
                    let d = (c[i] - r.pos_ned[k]).abs();
                    assert!(
                        d <= 0.5e-9 + 1e-12 && c[i] > 0.0,
                        "{stem} {name} row {i}: {} vs {}",
                        c[i],
                        r.pos_ned[k]
                    );
                }
            }
        }
        let j = read_table(&out.join("journal.parquet")).unwrap();
        let csv = std::fs::read_to_string(out.join("solution.innovations.csv")).unwrap();
        assert_eq!(j.rows(), csv.lines().count() - 1);
        assert!(j.rows() >= 60, "{} updates", j.rows());
        let Some(ColumnData::Str(kinds)) = j.column("kind") else {
            panic!("no kind column")
        };
        for (k, line) in kinds.iter().zip(csv.lines().skip(1)) {
            assert_eq!(Some(k.as_str()), line.split(',').nth(1));
        }
        let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
        assert!(summary.contains("journal.parquet"), "outputs listed");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
