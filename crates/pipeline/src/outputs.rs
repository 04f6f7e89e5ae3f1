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
        let f = std::fs::File::create(path)?;
        let mut w = std::io::BufWriter::new(f);
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
        w.flush()
    };
    write().map_err(io)?;
    Ok(path.display().to_string())
}

/// The extra output formats named in the config (by extension: csv, nav,
/// geojson, kml, gpx, nmea). An unknown name is a [`PipelineError::Options`].
pub fn out_formats(names: &[String]) -> Result<Vec<OutFormat>> {
    names
        .iter()
        .map(|n| {
            OutFormat::from_path(Path::new(&format!("x.{n}"))).ok_or_else(|| {
                PipelineError::Options(format!(
                    "unknown format {n:?} (csv, nav, geojson, kml, gpx, nmea)"
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
        let f = out_formats(&["csv".into(), "geojson".into(), "gpx".into()]).unwrap();
        assert_eq!(f, [OutFormat::Csv, OutFormat::GeoJson, OutFormat::Gpx]);
        let e = out_formats(&["shp".into()]).unwrap_err().to_string();
        assert!(e.contains("\"shp\""), "{e}");
    }
}
