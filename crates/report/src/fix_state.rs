//! The fix state along the track (issue 15): the RTKLIB-style quality Q of
//! each epoch of a `.pos` solution (navfuse run writes 1 fixed, 2 float,
//! 5 single, 7 dead reckoning; RTKLIB 1–6), drawn as the track coloured by
//! Q, with the share of each state.

use crate::svg::{esc, Layer, Plot};
use crate::Inputs;
use navfuse_core::geodesy::{ned_from_geodetic, Geodetic};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The quality of every epoch of one solution.
#[derive(Clone, Debug)]
pub struct QualityTrack {
    /// The solution's name (file stem).
    pub name: String,
    pub path: Option<PathBuf>,
    /// (GPS time [s], lat [rad], lon [rad], h [m], Q) in file order.
    pub epochs: Vec<(f64, f64, f64, f64, u8)>,
}

/// The states drawn, in legend order: Q, label, colour (fixed green, float
/// orange, single red, dead reckoning purple, the rest grey; ColorBrewer
/// RdYlGn/PuOr ends, distinguishable for the common colour deficiencies
/// except green/red, which the legend labels name).
const STATES: [(u8, &str, &str); 5] = [
    (1, "fixed (Q 1)", "#1a9850"),
    (2, "float (Q 2)", "#f08c00"),
    (5, "single (Q 5)", "#d73027"),
    (7, "dead reckoning (Q 7)", "#7b3294"),
    (0, "other (Q 0, 3, 4, 6)", "#8c8c8c"),
];

fn state_of(q: u8) -> usize {
    STATES
        .iter()
        .position(|s| s.0 == q && q != 0)
        .unwrap_or(STATES.len() - 1)
}

/// Read the Q column of an RTKLIB `.pos` file (lat/lon/height output);
/// `None` when every epoch's Q is 0 (no quality written).
pub fn read_pos_quality(path: &Path, name: &str) -> Result<Option<QualityTrack>, String> {
    let f = std::fs::File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let rdr =
        navfuse_io::pos::PosReader::new(std::io::BufReader::new(f), &path.display().to_string());
    let mut epochs = Vec::new();
    for r in rdr {
        let g = r.map_err(|e| e.to_string())?;
        epochs.push((g.t, g.lat, g.lon, g.h, g.quality));
    }
    if epochs.iter().all(|e| e.4 == 0) {
        return Ok(None);
    }
    Ok(Some(QualityTrack {
        name: name.to_string(),
        path: Some(path.to_path_buf()),
        epochs,
    }))
}

/// The section: one plot per quality track (the track coloured by Q, a
/// line broken where the state changes) and the share table.
pub(crate) fn section(inp: &Inputs, origin: &Geodetic) -> Option<(String, Vec<Plot>)> {
    if inp.quality.is_empty() {
        return None;
    }
    let mut html = String::from(
        "<p>Fix state of each epoch (RTKLIB quality Q of the solution's <code>.pos</code>): \
         the track coloured by state, and the share of the epochs in each state.</p>\
         <table><tr><th>solution</th><th>state</th><th>epochs</th><th>share</th></tr>",
    );
    let mut plots = Vec::new();
    for (i, qt) in inp.quality.iter().enumerate() {
        let n = qt.epochs.len().max(1);
        let mut count = [0usize; STATES.len()];
        let mut pts: Vec<Vec<(f64, f64)>> = vec![Vec::new(); STATES.len()];
        let mut prev: Option<usize> = None;
        for &(_, lat, lon, h, q) in &qt.epochs {
            let k = state_of(q);
            count[k] += 1;
            let d = ned_from_geodetic(origin, &Geodetic { lat, lon, h });
            if let Some(p) = prev.filter(|&p| p != k) {
                // Close the previous state's run at this point (no gap in
                // the drawn track) and break it.
                pts[p].push((d.y, d.x));
                pts[p].push((f64::NAN, f64::NAN));
            }
            pts[k].push((d.y, d.x));
            prev = Some(k);
        }
        let mut p = Plot::new(
            &format!("fix-state-{i}"),
            &format!("Fix state along the track: {}", qt.name),
            "east [m]",
            "north [m]",
        );
        p.equal_aspect = true;
        p.height = 560.0;
        for (k, (_, label, colour)) in STATES.iter().enumerate() {
            if count[k] == 0 {
                continue;
            }
            p.layers.push(Layer::Line {
                name: (*label).into(),
                colour: (*colour).into(),
                pts: std::mem::take(&mut pts[k]),
                width: 2.5,
                opacity: 1.0,
                x_sorted: false,
                legend: true,
            });
            let _ = write!(
                html,
                "<tr><td>{}</td><td><span style=\"color:{colour}\">■</span> {}</td><td>{}</td><td>{:.1} %</td></tr>",
                esc(&qt.name),
                esc(label),
                count[k],
                100.0 * count[k] as f64 / n as f64
            );
        }
        plots.push(p);
    }
    html.push_str("</table>");
    Some((html, plots))
}
