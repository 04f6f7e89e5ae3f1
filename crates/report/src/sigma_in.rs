//! σ files beside the solutions: `STEM.std` (navfuse's σ file,
//! [`navfuse_io::stdfile`]) gives the solution read from `STEM.nav` (or
//! `STEM.pos`/`STEM.csv`) its position, velocity and attitude σ; `--std
//! FILE` ([`crate::LoadOptions::std`]) names one explicitly.

use crate::Trajectory;
use std::path::{Path, PathBuf};

fn stem_lower(p: &Path) -> String {
    p.file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

/// Attach each σ file of `found` (from the run directory) to the solution
/// of the same file stem, and `explicit` to the solution of its stem or
/// else the first solution. A found file without a matching solution is
/// listed in `ignored`; an explicit one that matches no epoch is an error.
pub(crate) fn attach_std_files(
    sols: &mut [Trajectory],
    found: &[PathBuf],
    explicit: Option<&Path>,
    ignored: &mut Vec<String>,
) -> Result<(), String> {
    let mut todo: Vec<(&Path, bool)> = found.iter().map(|p| (p.as_path(), false)).collect();
    if let Some(p) = explicit {
        todo.retain(|(f, _)| stem_lower(f) != stem_lower(p));
        todo.push((p, true));
    }
    for (p, is_explicit) in todo {
        let st = stem_lower(p);
        let i = sols
            .iter()
            .position(|s| s.path.as_deref().is_some_and(|q| stem_lower(q) == st))
            .or(if is_explicit && !sols.is_empty() {
                Some(0)
            } else {
                None
            });
        let Some(i) = i else {
            ignored.push(format!(
                "{} (σ file without a solution of the same name)",
                p.display()
            ));
            continue;
        };
        let rows = navfuse_io::stdfile::read_std_file(p).map_err(|e| e.to_string())?;
        let n = navfuse_io::stdfile::attach_std(&mut sols[i].epochs, &rows);
        if n == 0 {
            let msg = format!(
                "{}: no line's time matches an epoch of {}",
                p.display(),
                sols[i].name
            );
            if is_explicit {
                return Err(msg);
            }
            ignored.push(msg);
            continue;
        }
        let note = format!(
            "; σ from {} at {n} epochs",
            p.file_name().unwrap_or_default().to_string_lossy()
        );
        match sols[i].records.as_mut() {
            Some(r) => r.push_str(&note),
            None => sols[i].records = Some(note[2..].to_string()),
        }
    }
    Ok(())
}
