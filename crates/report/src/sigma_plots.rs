//! "Uncertainty" section: for every solution that carries a position σ
//! (`STEM.std` beside `STEM.nav`, a trajectory CSV, `--std`), the
//! horizontal error against ±2σ_H, the vertical error against ±2σ_V, and
//! the horizontal NEES against the χ²(2) 95 % line.
//!
//! σ_H = √(σN² + σE²) (2σ_H is the "2DRMS" radius: 95–98 % of a 2-D
//! Gaussian error, depending on its ellipticity); σ_V = σD. Horizontal NEES
//! `εN²/σN² + εE²/σE²` with the diagonal σ (the cross term is not in the σ
//! file) is χ²(2) distributed for a consistent filter (Bar-Shalom, Li &
//! Kirubarajan §5.4.2), so ~5 % of the epochs lie above χ²(2)₀.₉₅ = 5.991.
//! The σ is the nearest solution epoch's, the error that of the evaluation
//! (at the truth epochs, lever arm applied).

use super::{colour, line, nearest, width_for, Section};
use crate::svg::{HLine, Layer, Plot};
use crate::{EstimatorResult, Inputs};
use navfuse_core::kalman::chi2_quantile;
use std::fmt::Write as _;

/// The section, or `None` when no evaluated solution has a position σ.
pub(super) fn section(
    inp: &Inputs,
    results: &[EstimatorResult],
    spans: &[(f64, f64)],
    t0: f64,
) -> Option<Section> {
    let xl = "t − t₀ [s]";
    let mk = |id: &str, title: &str, y: &str| {
        let mut p = Plot::new(id, title, xl, y);
        p.height = 260.0;
        p.spans = spans.to_vec();
        p
    };
    let mut ph = mk(
        "sigma-horizontal",
        "Horizontal error with ±2σ_H",
        "horizontal error [m]",
    );
    let mut pv = mk(
        "sigma-vertical",
        "Vertical error (up) with ±2σ_V",
        "vertical error [m]",
    );
    let mut pn = mk(
        "nees-horizontal",
        "Horizontal NEES",
        "NEES (χ²(2) if consistent)",
    );
    pn.log_y = true;
    let limit = chi2_quantile(2, 0.95);
    pn.hlines.push(HLine {
        y: limit,
        colour: "#555".into(),
        label: format!("χ²(2) 95 % = {limit:.3}"),
    });
    let mut html = format!(
        "<p>Error against the solution's own 1-σ (σ_H = √(σN² + σE²), σ_V = σD; ±2σ bands). \
         Horizontal NEES εN²/σN² + εE²/σE² should exceed χ²(2) 95 % = {limit:.3} at about 5 % of \
         the epochs; far more means the filter is overconfident, far fewer that its σ is too large.</p>\
         <table class=\"stats\"><tr><th>estimator</th><th>epochs with σ</th><th>mean NEES_H</th>\
         <th>share above {limit:.3}</th><th>|ε_H| ≤ 2σ_H</th><th>|ε_V| ≤ 2σ_V</th></tr>"
    );
    let mut any = false;
    let (mut lines_h, mut lines_v, mut lines_n) = (Vec::new(), Vec::new(), Vec::new());
    for (i, (r, s)) in results.iter().zip(&inp.solutions).enumerate() {
        let Some(ev) = &r.evaluation else { continue };
        if !s.epochs.iter().any(|e| e.std_pos_ned.x.is_finite()) || s.epochs.is_empty() {
            continue;
        }
        any = true;
        let c = colour(i);
        let w = width_for(i, results.len());
        let n = ev.errors.len();
        let (mut x, mut eh, mut ev_up, mut sh, mut sv, mut nees) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        for e in &ev.errors {
            let sd = s.epochs[nearest(&s.epochs, e.t)].std_pos_ned;
            x.push(e.t - t0);
            eh.push(e.horizontal);
            ev_up.push(-e.pos_ned[2]);
            sh.push(2.0 * sd.x.hypot(sd.y));
            sv.push(2.0 * sd.z);
            nees.push((e.pos_ned[0] / sd.x).powi(2) + (e.pos_ned[1] / sd.y).powi(2));
        }
        let band = |name: String, hi: &[f64]| Layer::Band {
            name,
            colour: c.clone(),
            x: x.clone(),
            lo: hi.iter().map(|v| -v).collect(),
            hi: hi.to_vec(),
        };
        ph.layers.push(band(format!("{} ±2σ_H", r.name), &sh));
        pv.layers.push(band(format!("{} ±2σ_V", r.name), &sv));
        let pts = |v: &[f64]| x.iter().copied().zip(v.iter().copied()).collect();
        lines_h.push(line(&r.name, &c, pts(&eh), w));
        lines_v.push(line(&r.name, &c, pts(&ev_up), w));
        lines_n.push(line(&r.name, &c, pts(&nees), w));
        let fin: Vec<f64> = nees.iter().copied().filter(|v| v.is_finite()).collect();
        let m = fin.len().max(1) as f64;
        let share = |k: usize| k as f64 / m * 100.0;
        // Share [%] of the epochs with a finite bound where |error| ≤ bound.
        let inside = |e: &[f64], b: &[f64]| {
            let (k, n) = e
                .iter()
                .zip(b)
                .filter(|(e, b)| b.is_finite() && e.is_finite())
                .fold((0usize, 0usize), |(k, n), (e, b)| {
                    (k + usize::from(e.abs() <= *b), n + 1)
                });
            k as f64 / n.max(1) as f64 * 100.0
        };
        let _ = write!(
            html,
            "<tr><td>{}</td><td>{}</td><td>{:.2}</td><td>{:.1} %</td><td>{:.1} %</td><td>{:.1} %</td></tr>",
            crate::svg::esc(&r.name),
            fin.len(),
            fin.iter().sum::<f64>() / m,
            share(fin.iter().filter(|v| **v > limit).count()),
            inside(&eh, &sh),
            inside(&ev_up, &sv),
        );
    }
    if !any {
        return None;
    }
    html.push_str("</table>");
    ph.layers.extend(lines_h);
    pv.layers.extend(lines_v);
    pn.layers.extend(lines_n);
    Some(Section {
        id: "uncertainty",
        title: "Uncertainty: error against the filter's σ".into(),
        html,
        plots: vec![ph, pv, pn],
    })
}
