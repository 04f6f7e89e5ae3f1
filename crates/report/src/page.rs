//! The page: evaluation, plots, tables and the HTML around them.

use crate::svg::{esc, HLine, Layer, Marker, Plot, PALETTE};
use crate::{outages_from_fix_gaps, EstimatorResult, Inputs, Rendered};
use navfuse_core::geodesy::{ned_from_geodetic, Geodetic};
use navfuse_core::kalman::chi2_quantile;
use navfuse_core::NavSolution;
use navfuse_eval::{evaluate, outage_metric, ErrorEpoch, Outage, Stats};
use std::fmt::Write as _;

#[path = "sigma_plots.rs"]
mod sigma_plots;

const WEEK_S: f64 = 604_800.0;
const TRUTH_COLOUR: &str = "#222222";
const FIX_COLOUR: &str = "#7f7f7f";
const REJECT_COLOUR: &str = "#E41A1C";
const OUTAGE_COLOUR: &str = "#f2c14e";
const AXES: [&str; 3] = ["north", "east", "down"];

struct Section {
    id: &'static str,
    title: String,
    /// HTML before the plots (tables, notes).
    html: String,
    plots: Vec<Plot>,
}

fn geo(s: &NavSolution) -> Geodetic {
    Geodetic {
        lat: s.lat,
        lon: s.lon,
        h: s.h,
    }
}

/// "GPS week W, TOW x s" for a GPS time.
fn gps_time(t: f64) -> String {
    let w = (t / WEEK_S).floor();
    if w > 0.0 {
        format!("GPS week {w:.0}, TOW {:.3} s", t - w * WEEK_S)
    } else {
        format!("TOW {t:.3} s")
    }
}

/// Index of the epoch of `s` nearest to `t` (s sorted by time, non-empty).
fn nearest(s: &[NavSolution], t: f64) -> usize {
    let i = s.partition_point(|x| x.t < t);
    if i == 0 {
        0
    } else if i == s.len() {
        s.len() - 1
    } else if (s[i].t - t).abs() < (t - s[i - 1].t).abs() {
        i
    } else {
        i - 1
    }
}

/// Line width of estimator `i` of `n`: earlier ones wider, so identical
/// results stay visible under later ones.
fn width_for(i: usize, n: usize) -> f64 {
    (1.2 + 0.7 * n.saturating_sub(1 + i) as f64).min(3.0)
}

fn colour(i: usize) -> String {
    PALETTE[i % PALETTE.len()].to_string()
}

fn line(name: &str, colour: &str, pts: Vec<(f64, f64)>, width: f64) -> Layer {
    Layer::Line {
        name: name.to_string(),
        colour: colour.to_string(),
        pts,
        width,
        opacity: 1.0,
        x_sorted: true,
        legend: true,
    }
}

/// Break a wrapped angle series [deg] where it jumps by more than 180°.
fn unwrap_breaks(pts: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(pts.len());
    for p in pts {
        if let Some(l) = out.last() {
            let l: &(f64, f64) = l;
            if (p.1 - l.1).abs() > 180.0 {
                out.push((p.0, f64::NAN));
            }
        }
        out.push(p);
    }
    out
}

pub(crate) fn render(inp: &Inputs, progress: &mut dyn FnMut(&str)) -> Result<Rendered, String> {
    let mut notes: Vec<String> = Vec::new();
    progress("evaluating");
    let fix_t: Option<Vec<f64>> = inp
        .fixes
        .as_ref()
        .map(|f| f.epochs.iter().map(|e| e.t).collect());
    let outages: Vec<Outage> = if !inp.outages.is_empty() {
        inp.outages.clone()
    } else if let Some(ft) = &fix_t {
        let o = outages_from_fix_gaps(ft);
        if !o.is_empty() {
            notes.push(format!(
                "{} GNSS outages inferred from gaps in the GNSS fixes.",
                o.len()
            ));
        }
        o
    } else {
        Vec::new()
    };
    // Time origin: the start of the run (earliest solution epoch; the
    // truth's when there is no solution).
    let first = |ts: &mut dyn Iterator<Item = &crate::Trajectory>| {
        ts.filter_map(|t| t.epochs.first().map(|e| e.t))
            .fold(f64::INFINITY, f64::min)
    };
    let mut t0 = first(&mut inp.solutions.iter());
    if !t0.is_finite() {
        t0 = first(&mut inp.truth.iter());
    }
    if !t0.is_finite() {
        return Err("nothing to report: no solution and no truth".into());
    }
    let origin = inp
        .truth
        .as_ref()
        .or(inp.solutions.first())
        .and_then(|t| t.epochs.first())
        .map(geo)
        .expect("t0 finite implies an epoch");
    let rel = |t: f64| t - t0;
    let spans: Vec<(f64, f64)> = outages.iter().map(|o| (rel(o.start), rel(o.end))).collect();

    // Evaluate.
    let mut results: Vec<EstimatorResult> = Vec::new();
    for s in &inp.solutions {
        let evaluation = match &inp.truth {
            Some(tr) => {
                let mut ev = evaluate(&s.epochs, &tr.epochs, &inp.eval, None, fix_t.as_deref())
                    .map_err(|e| format!("evaluating {} against the truth: {e}", s.name))?;
                if ev.counts.evaluated == 0 {
                    notes.push(format!(
                        "{}: no epoch overlaps the truth (check GPS weeks / time of week).",
                        s.name
                    ));
                }
                let (lo, hi) = (
                    s.epochs.first().map_or(0.0, |e| e.t),
                    s.epochs.last().map_or(0.0, |e| e.t),
                );
                let inside: Vec<Outage> = outages
                    .iter()
                    .copied()
                    .filter(|o| o.start >= lo && o.end <= hi)
                    .collect();
                if !inside.is_empty() {
                    ev.outages = Some(outage_metric(&ev.errors, &inside, fix_t.as_deref()));
                }
                Some(ev)
            }
            None => None,
        };
        results.push(EstimatorResult {
            name: s.name.clone(),
            epochs: s.epochs.len(),
            evaluation,
        });
    }

    progress("drawing");
    let mut sections: Vec<Section> = Vec::new();
    let xl = "t − t₀ [s]";

    // --- Summary table.
    if !inp.solutions.is_empty() {
        let mut html = String::new();
        if inp.truth.is_some() {
            html.push_str(&summary_table(&results, inp));
        } else {
            html.push_str("<p class=\"note\">No truth given: errors are not available. Epochs per estimator:</p><table><tr><th>estimator</th><th>epochs</th><th>span [s]</th></tr>");
            for s in &inp.solutions {
                let (a, b) = (
                    s.epochs.first().map_or(0.0, |e| e.t),
                    s.epochs.last().map_or(0.0, |e| e.t),
                );
                let _ = write!(
                    html,
                    "<tr><td>{}</td><td>{}</td><td>{:.1} – {:.1}</td></tr>",
                    esc(&s.name),
                    s.epochs.len(),
                    rel(a),
                    rel(b)
                );
            }
            html.push_str("</table>");
        }
        sections.push(Section {
            id: "summary",
            title: "Summary".into(),
            html,
            plots: Vec::new(),
        });
    }

    // --- Track.
    {
        let enu = |e: &NavSolution| {
            let d = ned_from_geodetic(&origin, &geo(e));
            (d.y, d.x)
        };
        let mut p = Plot::new(
            "track",
            "Track (local ENU at the first epoch)",
            "east [m]",
            "north [m]",
        );
        p.equal_aspect = true;
        p.height = 620.0;
        let base = inp.truth.as_ref().or(inp.solutions.first());
        if let Some(b) = base {
            if !outages.is_empty() {
                let mut pts = Vec::new();
                for o in &outages {
                    for e in b.epochs.iter().filter(|e| o.contains(e.t)) {
                        pts.push(enu(e));
                    }
                    pts.push((f64::NAN, f64::NAN));
                }
                p.layers.push(Layer::Line {
                    name: "GNSS outage".into(),
                    colour: OUTAGE_COLOUR.into(),
                    pts,
                    width: 12.0,
                    opacity: 0.5,
                    x_sorted: false,
                    legend: true,
                });
            }
        }
        for (i, s) in inp.solutions.iter().enumerate() {
            p.layers.push(Layer::Line {
                name: s.name.clone(),
                colour: colour(i),
                pts: s.epochs.iter().map(enu).collect(),
                width: width_for(i, inp.solutions.len()),
                opacity: 1.0,
                x_sorted: false,
                legend: true,
            });
        }
        if let Some(tr) = &inp.truth {
            p.layers.push(Layer::Line {
                name: "truth".into(),
                colour: TRUTH_COLOUR.into(),
                pts: tr.epochs.iter().map(enu).collect(),
                width: 1.0,
                opacity: 1.0,
                x_sorted: false,
                legend: true,
            });
        }
        if let Some(f) = &inp.fixes {
            p.layers.push(Layer::Points {
                name: "GNSS fixes".into(),
                colour: FIX_COLOUR.into(),
                pts: f.epochs.iter().map(enu).collect(),
                marker: Marker::Dot,
                size: 1.8,
            });
        }
        let mut html = format!(
            "<p>Origin: lat {:.7}°, lon {:.7}°, h {:.2} m. Truth drawn on top (thin black); shaded: the track during GNSS outages.</p>",
            origin.lat.to_degrees(),
            origin.lon.to_degrees(),
            origin.h
        );
        if !outages.is_empty() {
            html.push_str(&outage_list(&outages, t0));
        }
        sections.push(Section {
            id: "track",
            title: "Track".into(),
            html,
            plots: vec![p],
        });
    }

    // --- Fix state along the track (solutions with a quality column).
    if let Some((html, plots)) = crate::fix_state::section(inp, &origin) {
        sections.push(Section {
            id: "fix-state",
            title: "Fix state along the track".into(),
            html,
            plots,
        });
    }

    // --- Position error, velocity error, attitude error.
    if inp.truth.is_some() && !inp.solutions.is_empty() {
        let mut plots = Vec::new();
        let mut ph = Plot::new(
            "err-horizontal",
            "Horizontal position error",
            xl,
            "horizontal error [m]",
        );
        ph.spans = spans.clone();
        for (i, r) in results.iter().enumerate() {
            if let Some(ev) = &r.evaluation {
                ph.layers.push(line(
                    &r.name,
                    &colour(i),
                    ev.errors.iter().map(|e| (rel(e.t), e.horizontal)).collect(),
                    width_for(i, results.len()),
                ));
            }
        }
        plots.push(ph);
        for (k, ax) in AXES.iter().enumerate() {
            plots.push(error_plot(
                &format!("err-pos-{ax}"),
                &format!("Position error, {ax}"),
                &format!("{ax} error [m]"),
                inp,
                &results,
                &spans,
                t0,
                |e| Some(e.pos_ned[k]),
                |s| s.std_pos_ned[k],
                1.0,
            ));
        }
        sections.push(Section {
            id: "position",
            title: "Position error (solution − truth) with ±3σ".into(),
            html: format!(
                "<p>NED at the truth point{}. Bands: ±3σ of the filter covariance, where the solution carries it.</p>",
                match inp.eval.lever_arm_b {
                    Some(l) => format!(", solution moved by the lever arm ({}, {}, {}) m FRD", l[0], l[1], l[2]),
                    None => String::new(),
                }
            ),
            plots,
        });
        sections.extend(sigma_plots::section(inp, &results, &spans, t0));
        let has_vel = results
            .iter()
            .filter_map(|r| r.evaluation.as_ref())
            .any(|ev| ev.errors.iter().any(|e| e.vel_ned.is_some()));
        if has_vel {
            let plots = (0..3)
                .map(|k| {
                    let ax = AXES[k];
                    error_plot(
                        &format!("err-vel-{ax}"),
                        &format!("Velocity error, {ax}"),
                        &format!("v_{} error [m/s]", &ax[..1]),
                        inp,
                        &results,
                        &spans,
                        t0,
                        |e| e.vel_ned.map(|v| v[k]),
                        |s| s.std_v_n[k],
                        1.0,
                    )
                })
                .collect();
            sections.push(Section {
                id: "velocity",
                title: "Velocity error with ±3σ".into(),
                html: String::new(),
                plots,
            });
        }
        let has_att = results
            .iter()
            .filter_map(|r| r.evaluation.as_ref())
            .any(|ev| ev.errors.iter().any(|e| e.att_rpy.is_some()));
        if has_att {
            let names = ["roll", "pitch", "yaw"];
            let plots = (0..3)
                .map(|k| {
                    error_plot(
                        &format!("err-att-{}", names[k]),
                        &format!("Attitude error, {}", names[k]),
                        &format!("{} error [deg]", names[k]),
                        inp,
                        &results,
                        &spans,
                        t0,
                        |e| e.att_rpy.map(|v| v[k]),
                        |s| s.std_rpy[k],
                        180.0 / std::f64::consts::PI,
                    )
                })
                .collect();
            sections.push(Section {
                id: "attitude-error",
                title: "Attitude error with ±3σ".into(),
                html: String::new(),
                plots,
            });
        }
    }

    // --- Attitude.
    let any_att = inp
        .solutions
        .iter()
        .any(|s| s.epochs.iter().any(|e| e.rpy.iter().all(|a| a.is_finite())));
    if any_att {
        let names = ["roll", "pitch", "yaw"];
        let mut plots = Vec::new();
        for (k, name) in names.iter().enumerate() {
            let mut p = Plot::new(
                &format!("att-{name}"),
                &format!("Attitude: {name}"),
                xl,
                &format!("{name} [deg]"),
            );
            p.height = 240.0;
            p.spans = spans.clone();
            if let Some(tr) = &inp.truth {
                if tr.epochs.iter().any(|e| e.rpy[k].is_finite()) {
                    p.layers.push(line(
                        "truth",
                        TRUTH_COLOUR,
                        unwrap_breaks(
                            tr.epochs
                                .iter()
                                .map(|e| (rel(e.t), e.rpy[k].to_degrees()))
                                .collect(),
                        ),
                        1.2,
                    ));
                }
            }
            for (i, s) in inp.solutions.iter().enumerate() {
                p.layers.push(line(
                    &s.name,
                    &colour(i),
                    unwrap_breaks(
                        s.epochs
                            .iter()
                            .map(|e| (rel(e.t), e.rpy[k].to_degrees()))
                            .collect(),
                    ),
                    width_for(i, inp.solutions.len()),
                ));
            }
            plots.push(p);
        }
        sections.push(Section {
            id: "attitude",
            title: "Attitude (roll, pitch, yaw; ZYX, body FRD w.r.t. NED)".into(),
            html: String::new(),
            plots,
        });
    }

    // --- States (biases, time offset).
    if !inp.states.is_empty() {
        sections.push(states_section(inp, &spans, t0));
    }

    // --- Innovations.
    if inp.innovations.iter().any(|s| !s.rows.is_empty()) {
        sections.push(innovations_section(inp, &spans, t0));
    }

    // --- Outage table.
    if results
        .iter()
        .any(|r| r.evaluation.as_ref().is_some_and(|e| e.outages.is_some()))
    {
        // Right after the summary: the drift table is what outage runs are judged by.
        let at = sections
            .iter()
            .position(|s| s.id == "summary")
            .map_or(0, |i| i + 1);
        sections.insert(
            at,
            Section {
                id: "outages",
                title: "GNSS outages: maximum horizontal drift".into(),
                html: outage_table(&results, t0),
                plots: Vec::new(),
            },
        );
    }

    // --- Inputs and configuration.
    sections.push(Section {
        id: "inputs",
        title: "Inputs and run configuration".into(),
        html: inputs_html(inp, &results, &notes),
        plots: Vec::new(),
    });

    progress("assembling the page");
    Ok(assemble(inp, sections, results, outages, notes, t0))
}

#[allow(clippy::too_many_arguments)]
fn error_plot(
    id: &str,
    title: &str,
    y_label: &str,
    inp: &Inputs,
    results: &[EstimatorResult],
    spans: &[(f64, f64)],
    t0: f64,
    value: impl Fn(&ErrorEpoch) -> Option<f64>,
    sigma: impl Fn(&NavSolution) -> f64,
    scale: f64,
) -> Plot {
    let mut p = Plot::new(id, title, "t − t₀ [s]", y_label);
    p.height = 260.0;
    p.spans = spans.to_vec();
    let mut lines = Vec::new();
    for (i, (r, s)) in results.iter().zip(&inp.solutions).enumerate() {
        let Some(ev) = &r.evaluation else { continue };
        let pts: Vec<(f64, f64)> = ev
            .errors
            .iter()
            .map(|e| (e.t - t0, value(e).map_or(f64::NAN, |v| v * scale)))
            .collect();
        if !pts.iter().any(|p| p.1.is_finite()) {
            continue;
        }
        let sig: Vec<f64> = ev
            .errors
            .iter()
            .map(|e| 3.0 * sigma(&s.epochs[nearest(&s.epochs, e.t)]) * scale)
            .collect();
        if sig.iter().any(|v| v.is_finite()) {
            p.layers.push(Layer::Band {
                name: format!("{} ±3σ", r.name),
                colour: colour(i),
                x: pts.iter().map(|p| p.0).collect(),
                lo: sig.iter().map(|v| -v).collect(),
                hi: sig.clone(),
            });
        }
        lines.push(line(&r.name, &colour(i), pts, width_for(i, results.len())));
    }
    p.layers.extend(lines);
    p
}

fn stat_cells(s: &Option<Stats>, scale: f64, dec: usize) -> String {
    match s {
        Some(s) => format!(
            "<td>{:.dec$}</td><td>{:.dec$}</td><td>{:.dec$}</td>",
            s.rms * scale,
            s.max_abs * scale,
            s.p95_abs * scale
        ),
        None => "<td>—</td><td>—</td><td>—</td>".into(),
    }
}

fn summary_table(results: &[EstimatorResult], inp: &Inputs) -> String {
    let mut h = String::from("<table class=\"stats\"><tr><th rowspan=\"2\">error</th>");
    for r in results {
        let _ = write!(h, "<th colspan=\"3\">{}</th>", esc(&r.name));
    }
    h.push_str("</tr><tr>");
    for _ in results {
        h.push_str("<th>RMS</th><th>max</th><th>p95</th>");
    }
    h.push_str("</tr>");
    let deg = 180.0 / std::f64::consts::PI;
    type Get = fn(&navfuse_eval::Summary) -> Option<Stats>;
    let rows: [(&str, Get, f64, usize); 12] = [
        ("horizontal [m]", |s| s.horizontal, 1.0, 3),
        ("vertical [m]", |s| s.vertical, 1.0, 3),
        ("north [m]", |s| s.north, 1.0, 3),
        ("east [m]", |s| s.east, 1.0, 3),
        ("down [m]", |s| s.down, 1.0, 3),
        ("velocity horizontal [m/s]", |s| s.vel_horizontal, 1.0, 3),
        ("v north [m/s]", |s| s.vel_north, 1.0, 3),
        ("v east [m/s]", |s| s.vel_east, 1.0, 3),
        ("v down [m/s]", |s| s.vel_down, 1.0, 3),
        ("roll [deg]", |s| s.roll, deg, 3),
        ("pitch [deg]", |s| s.pitch, deg, 3),
        ("yaw [deg]", |s| s.yaw, deg, 3),
    ];
    for (name, get, scale, dec) in rows {
        let any = results.iter().any(|r| {
            r.evaluation
                .as_ref()
                .is_some_and(|e| get(&e.summary).is_some())
        });
        if !any {
            continue;
        }
        let _ = write!(h, "<tr><td>{name}</td>");
        for r in results {
            let s = r.evaluation.as_ref().and_then(|e| get(&e.summary));
            h.push_str(&stat_cells(&s, scale, dec));
        }
        h.push_str("</tr>");
    }
    if results
        .iter()
        .any(|r| r.evaluation.as_ref().is_some_and(|e| e.outages.is_some()))
    {
        h.push_str("<tr><td>outage drift: RMS / max of per-outage max [m]</td>");
        for r in results {
            match r.evaluation.as_ref().and_then(|e| e.outages.as_ref()) {
                Some(o) => {
                    let f = |v: Option<f64>| v.map_or("—".into(), |x| format!("{x:.2}"));
                    let _ = write!(
                        h,
                        "<td>{}</td><td>{}</td><td></td>",
                        f(o.rms_of_max),
                        f(o.max_of_max)
                    );
                }
                None => h.push_str("<td>—</td><td>—</td><td></td>"),
            }
        }
        h.push_str("</tr>");
    }
    h.push_str("<tr><td>epochs evaluated / in file</td>");
    for r in results {
        let (ev, n) = (
            r.evaluation.as_ref().map_or(0, |e| e.counts.evaluated),
            r.epochs,
        );
        let _ = write!(h, "<td colspan=\"3\">{ev} / {n}</td>");
    }
    h.push_str("</tr></table>");
    let _ = write!(
        h,
        "<p class=\"note\">Errors are solution − truth at the {} (max gap {} s); max and p95 are of |error|.</p>",
        match inp.eval.align {
            navfuse_eval::Align::AtSolution => "solution epochs (truth interpolated)",
            navfuse_eval::Align::AtReference => "truth epochs (solutions interpolated, the same instants for every estimator)",
        },
        inp.eval.max_gap
    );
    h
}

fn outage_list(outages: &[Outage], t0: f64) -> String {
    let mut h = format!("<p>{} GNSS outages (t − t₀ [s]): ", outages.len());
    for (i, o) in outages.iter().enumerate() {
        if i > 0 {
            h.push_str(", ");
        }
        let _ = write!(h, "{:.1}–{:.1}", o.start - t0, o.end - t0);
    }
    h.push_str(".</p>");
    h
}

fn outage_table(results: &[EstimatorResult], t0: f64) -> String {
    let with: Vec<(&EstimatorResult, &navfuse_eval::OutageReport)> = results
        .iter()
        .filter_map(|r| {
            r.evaluation
                .as_ref()
                .and_then(|e| e.outages.as_ref())
                .map(|o| (r, o))
        })
        .collect();
    let mut h = String::from(
        "<table class=\"stats\"><tr><th>#</th><th>start [s]</th><th>end [s]</th><th>length [s]</th>",
    );
    for (r, _) in &with {
        let _ = write!(h, "<th>{} max horiz. [m]</th><th>at [s]</th>", esc(&r.name));
    }
    h.push_str("</tr>");
    // Rows by the first estimator's outages (all share the schedule; an
    // estimator with a shorter span may lack some).
    let mut all: Vec<(f64, f64)> = with
        .iter()
        .flat_map(|(_, o)| o.outages.iter().map(|x| (x.start, x.end)))
        .collect();
    all.sort_by(|a, b| a.0.total_cmp(&b.0));
    all.dedup();
    for (k, (s, e)) in all.iter().enumerate() {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{:.1}</td><td>{:.1}</td><td>{:.1}</td>",
            k + 1,
            s - t0,
            e - t0,
            e - s
        );
        for (_, o) in &with {
            match o.outages.iter().find(|x| x.start == *s && x.end == *e) {
                Some(x) => {
                    let _ = write!(
                        h,
                        "<td>{}</td><td>{}</td>",
                        x.max_horizontal.map_or("—".into(), |v| format!("{v:.2}")),
                        x.t_max.map_or("—".into(), |v| format!("{:.1}", v - t0))
                    );
                }
                None => h.push_str("<td>—</td><td>—</td>"),
            }
        }
        h.push_str("</tr>");
    }
    h.push_str("<tr><td colspan=\"4\"><b>RMS of the maxima</b></td>");
    for (_, o) in &with {
        let _ = write!(
            h,
            "<td><b>{}</b></td><td></td>",
            o.rms_of_max.map_or("—".into(), |v| format!("{v:.2}"))
        );
    }
    h.push_str("</tr></table><p class=\"note\">Each outage is scored from its start to the first GNSS fix after it (or its end without a fixes file).</p>");
    h
}

/// Axis tokens of a state column name `QUANTITY_AXIS_UNIT`.
const AXIS_TOKENS: [&str; 9] = ["x", "y", "z", "n", "e", "d", "r", "p", "h"];

fn unit_label(u: &str) -> String {
    match u {
        "dph" => "°/h".into(),
        "degph" => "°/h".into(),
        "mg" => "mg".into(),
        "mgal" => "mGal".into(),
        "ug" => "µg".into(),
        "s" => "s".into(),
        "ms" => "ms".into(),
        "m" => "m".into(),
        "mps" => "m/s".into(),
        "mps2" => "m/s²".into(),
        "radps" => "rad/s".into(),
        "deg" => "°".into(),
        "rad" => "rad".into(),
        "ppm" => "ppm".into(),
        other => other.into(),
    }
}

/// (group key, quantity, axis, unit) of a state column.
fn split_state_col(c: &str) -> (String, String, Option<String>, String) {
    let parts: Vec<&str> = c.split('_').collect();
    if parts.len() >= 3 && AXIS_TOKENS.contains(&parts[parts.len() - 2]) {
        let q = parts[..parts.len() - 2].join("_");
        let u = parts[parts.len() - 1].to_string();
        (
            format!("{q}_{u}"),
            q,
            Some(parts[parts.len() - 2].into()),
            u,
        )
    } else if parts.len() >= 2 {
        let q = parts[..parts.len() - 1].join("_");
        let u = parts[parts.len() - 1].to_string();
        (c.to_string(), q, None, u)
    } else {
        (c.to_string(), c.to_string(), None, String::new())
    }
}

fn quantity_title(q: &str) -> String {
    match q {
        "bg" => "Gyro bias".into(),
        "ba" => "Accelerometer bias".into(),
        "sg" => "Gyro scale factor".into(),
        "sa" => "Accelerometer scale factor".into(),
        "td" | "dt" | "time_offset" => "Time offset".into(),
        other => other.replace('_', " "),
    }
}

/// One plot per estimator and quantity (x, y, z in the first three colours),
/// ±3σ bands from `std_` columns. The y range ignores the first 0.5 % and the
/// last 0.5 % of the values (start-up transients would flatten the rest).
fn states_section(inp: &Inputs, spans: &[(f64, f64)], t0: f64) -> Section {
    let mut plots = Vec::new();
    for s in &inp.states {
        let mut groups: Vec<(String, String, String)> = Vec::new(); // key, quantity, unit
        for c in &s.columns {
            if c.starts_with("std_") {
                continue;
            }
            let (k, q, _, u) = split_state_col(c);
            if !groups.iter().any(|g| g.0 == k) {
                groups.push((k, q, u));
            }
        }
        for (key, q, u) in &groups {
            let mut p = Plot::new(
                &format!("state-{}", plots.len()),
                &format!("{}: {} [{}]", s.estimator, quantity_title(q), unit_label(u)),
                "t − t₀ [s]",
                &format!("{} [{}]", q, unit_label(u)),
            );
            p.height = 240.0;
            p.spans = spans.to_vec();
            p.robust_y = true;
            let mut lines = Vec::new();
            for (k, c) in s.columns.iter().enumerate() {
                if c.starts_with("std_") {
                    continue;
                }
                let (kk, _, axis, _) = split_state_col(c);
                if &kk != key {
                    continue;
                }
                let name = axis.clone().unwrap_or_else(|| q.clone());
                let col = colour(lines.len());
                let pts: Vec<(f64, f64)> =
                    s.t.iter()
                        .zip(&s.values)
                        .map(|(t, v)| (t - t0, v[k]))
                        .collect();
                if let Some(j) = s.columns.iter().position(|x| *x == format!("std_{c}")) {
                    p.layers.push(Layer::Band {
                        name: format!("{name} ±3σ"),
                        colour: col.clone(),
                        x: pts.iter().map(|p| p.0).collect(),
                        lo: s
                            .values
                            .iter()
                            .zip(&pts)
                            .map(|(v, p)| p.1 - 3.0 * v[j])
                            .collect(),
                        hi: s
                            .values
                            .iter()
                            .zip(&pts)
                            .map(|(v, p)| p.1 + 3.0 * v[j])
                            .collect(),
                    });
                }
                lines.push(line(&name, &col, pts, 1.4));
            }
            p.layers.extend(lines);
            plots.push(p);
        }
    }
    Section {
        id: "states",
        title: "Estimated IMU errors and time offset".into(),
        html: String::new(),
        plots,
    }
}

fn innovations_section(inp: &Inputs, spans: &[(f64, f64)], t0: f64) -> Section {
    let mut kinds: Vec<String> = Vec::new();
    for s in &inp.innovations {
        for r in &s.rows {
            if !kinds.contains(&r.kind) {
                kinds.push(r.kind.clone());
            }
        }
    }
    let est_colour = |name: &str| -> String {
        match inp.solutions.iter().position(|s| s.name == name) {
            Some(i) => colour(i),
            None => colour(
                inp.solutions.len()
                    + inp
                        .innovations
                        .iter()
                        .position(|s| s.estimator == name)
                        .unwrap_or(0),
            ),
        }
    };
    let mut html = String::from("<table class=\"stats\"><tr><th>estimator</th><th>kind</th><th>dof</th><th>updates</th><th>accepted</th><th>rejected</th><th>mean NIS (accepted)</th><th>in 95% χ² interval</th></tr>");
    let mut plots = Vec::new();
    for (ki, kind) in kinds.iter().enumerate() {
        // The most common dof of this kind sets the bounds.
        let mut dofs: Vec<usize> = inp
            .innovations
            .iter()
            .flat_map(|s| s.rows.iter().filter(|r| &r.kind == kind).map(|r| r.dof))
            .collect();
        dofs.sort_unstable();
        let dof = mode(&dofs).unwrap_or(1);
        let (lo, hi) = (chi2_quantile(dof, 0.025), chi2_quantile(dof, 0.975));
        let mut p = Plot::new(
            &format!("nis-{ki}"),
            &format!("NIS of {kind} updates (dof {dof})"),
            "t − t₀ [s]",
            "NIS [-] (log scale)",
        );
        p.log_y = true;
        p.height = 280.0;
        p.spans = spans.to_vec();
        p.hlines.push(HLine {
            y: lo,
            colour: "#555".into(),
            label: format!("χ²({dof}) 2.5% / 97.5%"),
        });
        p.hlines.push(HLine {
            y: hi,
            colour: "#555".into(),
            label: format!("χ²({dof}) 2.5% / 97.5%"),
        });
        let mut rejected_pts = Vec::new();
        for s in &inp.innovations {
            let rows: Vec<_> = s.rows.iter().filter(|r| &r.kind == kind).collect();
            if rows.is_empty() {
                continue;
            }
            let acc: Vec<_> = rows.iter().filter(|r| r.accepted).collect();
            let n_rej = rows.len() - acc.len();
            let mean = if acc.is_empty() {
                f64::NAN
            } else {
                acc.iter().map(|r| r.nis).sum::<f64>() / acc.len() as f64
            };
            let inside = rows
                .iter()
                .filter(|r| {
                    let (a, b) = (chi2_quantile(r.dof, 0.025), chi2_quantile(r.dof, 0.975));
                    r.nis >= a && r.nis <= b
                })
                .count();
            let _ = write!(
                html,
                "<tr><td>{}</td><td>{}</td><td>{dof}</td><td>{}</td><td>{}</td><td>{n_rej}</td><td>{}</td><td>{:.1} %</td></tr>",
                esc(&s.estimator),
                esc(kind),
                rows.len(),
                acc.len(),
                if mean.is_finite() { format!("{mean:.2} (expect {dof})") } else { "—".into() },
                100.0 * inside as f64 / rows.len() as f64
            );
            p.layers.push(Layer::Points {
                name: format!("{} accepted", s.estimator),
                colour: est_colour(&s.estimator),
                pts: acc.iter().map(|r| (r.t - t0, r.nis)).collect(),
                marker: Marker::Dot,
                size: 1.8,
            });
            rejected_pts.extend(
                rows.iter()
                    .filter(|r| !r.accepted)
                    .map(|r| (r.t - t0, r.nis)),
            );
        }
        if !rejected_pts.is_empty() {
            p.layers.push(Layer::Points {
                name: "rejected".into(),
                colour: REJECT_COLOUR.into(),
                pts: rejected_pts,
                marker: Marker::Cross,
                size: 4.0,
            });
        }
        plots.push(p);
    }
    html.push_str("</table>");
    Section {
        id: "innovations",
        title: "Innovations: NIS with χ² bounds, rejected updates".into(),
        html,
        plots,
    }
}

fn mode(sorted: &[usize]) -> Option<usize> {
    let mut best: Option<(usize, usize)> = None;
    let mut i = 0;
    while i < sorted.len() {
        let j = sorted[i..].iter().take_while(|x| **x == sorted[i]).count();
        match best {
            Some(b) if b.1 >= j => {}
            _ => best = Some((sorted[i], j)),
        }
        i += j;
    }
    best.map(|b| b.0)
}

fn flatten_json(prefix: &str, v: &serde_json::Value, out: &mut Vec<(String, String)>) {
    match v {
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                let p = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten_json(&p, x, out);
            }
        }
        serde_json::Value::Array(a) if a.iter().any(|x| x.is_object()) && a.len() <= 20 => {
            for (i, x) in a.iter().enumerate() {
                flatten_json(&format!("{prefix}[{i}]"), x, out);
            }
        }
        other => {
            let mut s = other.to_string();
            if s.len() > 300 {
                s.truncate(300);
                s.push('…');
            }
            out.push((prefix.to_string(), s));
        }
    }
}

fn inputs_html(inp: &Inputs, results: &[EstimatorResult], notes: &[String]) -> String {
    let mut h = String::new();
    for n in notes {
        let _ = write!(h, "<p class=\"note\">{}</p>", esc(n));
    }
    h.push_str("<table><tr><th>role</th><th>name</th><th>file</th><th>records</th></tr>");
    let row = |h: &mut String, role: &str, t: &crate::Trajectory| {
        let _ = write!(
            h,
            "<tr><td>{role}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&t.name),
            t.path
                .as_ref()
                .map_or("(in memory)".into(), |p| esc(&p.display().to_string())),
            esc(t
                .records
                .as_deref()
                .unwrap_or(&format!("{} epochs", t.epochs.len())))
        );
    };
    for s in &inp.solutions {
        row(&mut h, "solution", s);
    }
    if let Some(t) = &inp.truth {
        row(&mut h, "truth", t);
    }
    if let Some(t) = &inp.fixes {
        row(&mut h, "GNSS fixes", t);
    }
    for s in &inp.innovations {
        let _ = write!(
            h,
            "<tr><td>innovations</td><td>{}</td><td>{}</td><td>{} updates</td></tr>",
            esc(&s.estimator),
            s.path
                .as_ref()
                .map_or(String::new(), |p| esc(&p.display().to_string())),
            s.rows.len()
        );
    }
    for s in &inp.states {
        let _ = write!(
            h,
            "<tr><td>states</td><td>{}</td><td>{}</td><td>{} epochs × {} columns</td></tr>",
            esc(&s.estimator),
            s.path
                .as_ref()
                .map_or(String::new(), |p| esc(&p.display().to_string())),
            s.t.len(),
            s.columns.len()
        );
    }
    h.push_str("</table>");
    if results.iter().any(|r| r.evaluation.is_some()) {
        h.push_str("<h3>Evaluation accounting</h3><table><tr><th>estimator</th><th>epochs</th><th>evaluated</th><th>before truth</th><th>after truth</th><th>in truth gap</th><th>invalid</th></tr>");
        for r in results {
            if let Some(e) = &r.evaluation {
                let c = &e.counts;
                let _ = write!(
                    h,
                    "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                    esc(&r.name),
                    c.epochs,
                    c.evaluated,
                    c.before_span,
                    c.after_span,
                    c.in_gap,
                    c.invalid
                );
            }
        }
        h.push_str("</table>");
    }
    if !inp.ignored.is_empty() {
        h.push_str("<p class=\"note\">Ignored: ");
        h.push_str(&esc(&inp.ignored.join("; ")));
        h.push_str("</p>");
    }
    for (name, text) in &inp.config_files {
        let _ = write!(
            h,
            "<h3>{}</h3><pre class=\"cfg\">{}</pre>",
            esc(name),
            esc(text)
        );
    }
    if let Some(s) = &inp.summary {
        let mut kv = Vec::new();
        flatten_json("", s, &mut kv);
        h.push_str("<h3>summary.json</h3><table class=\"kv\">");
        for (k, v) in kv.iter().take(400) {
            let _ = write!(
                h,
                "<tr><td>{}</td><td><code>{}</code></td></tr>",
                esc(k),
                esc(v)
            );
        }
        h.push_str("</table>");
    }
    h
}

const CSS: &str = r#"
body{font-family:"DejaVu Sans",Helvetica,Arial,sans-serif;margin:0;color:#222;background:#f6f6f4}
header{background:#1f3b57;color:#fff;padding:14px 24px}
header h1{margin:0 0 4px 0;font-size:22px}
header p{margin:2px 0;font-size:13px;color:#dbe6f0}
nav{padding:6px 24px;background:#e9edf1;font-size:13px;position:sticky;top:0;z-index:2;border-bottom:1px solid #cfd6dd}
nav a{margin-right:14px;color:#1f3b57;text-decoration:none}
main{padding:8px 24px 40px 24px;max-width:1010px}
section{background:#fff;border:1px solid #ddd;border-radius:4px;margin:14px 0;padding:8px 16px 12px 16px}
h2{font-size:18px;margin:6px 0 8px 0;color:#1f3b57}
h3{font-size:15px;margin:12px 0 6px 0}
table{border-collapse:collapse;font-size:13px;margin:6px 0}
th,td{border:1px solid #d5d5d5;padding:3px 8px;text-align:right}
th{background:#f0f2f4}
td:first-child{text-align:left}
table.kv td{text-align:left}
.note{font-size:12px;color:#555}
pre.cfg{font-size:12px;background:#f7f7f7;border:1px solid #ddd;padding:6px;max-height:420px;overflow:auto}
svg.plot{display:block;width:100%;height:auto;margin:8px 0}
.legend{cursor:pointer}
.legend.off{opacity:.35}
#readout{position:fixed;pointer-events:none;background:rgba(255,255,255,.92);border:1px solid #888;font-size:12px;padding:2px 6px;display:none;z-index:3}
"#;

/// Hover readout (data coordinates) and legend click to hide a series.
const SCRIPT: &str = r#"
(function(){
  var ro=document.getElementById('readout');
  document.querySelectorAll('svg.plot').forEach(function(svg){
    var d=svg.dataset, l=+d.l, r=+d.r, t=+d.t, b=+d.b;
    var x0=+d.x0, x1=+d.x1, y0=+d.y0, y1=+d.y1, logy=d.logy==='1';
    svg.addEventListener('mousemove',function(ev){
      var pt=svg.createSVGPoint(); pt.x=ev.clientX; pt.y=ev.clientY;
      var m=svg.getScreenCTM(); if(!m){return;}
      var p=pt.matrixTransform(m.inverse());
      if(p.x<l||p.x>r||p.y<t||p.y>b){ro.style.display='none';return;}
      var x=x0+(p.x-l)/(r-l)*(x1-x0), y=y1-(p.y-t)/(b-t)*(y1-y0);
      if(logy){y=Math.pow(10,y);}
      ro.textContent=d.xlabel+' = '+x.toPrecision(6)+',  '+d.ylabel+' = '+y.toPrecision(4);
      ro.style.left=(ev.clientX+14)+'px'; ro.style.top=(ev.clientY+10)+'px'; ro.style.display='block';
    });
    svg.addEventListener('mouseleave',function(){ro.style.display='none';});
    svg.querySelectorAll('g.legend').forEach(function(g){
      g.addEventListener('click',function(){
        var off=g.classList.toggle('off');
        svg.querySelectorAll('[data-name]').forEach(function(e){
          if(e!==g && (e.dataset.name===g.dataset.name || e.dataset.name===g.dataset.name+' ±3σ')){
            e.style.display=off?'none':'';
          }
        });
      });
    });
  });
  document.body.setAttribute('data-script-ok','1');
})();
"#;

fn assemble(
    inp: &Inputs,
    sections: Vec<Section>,
    estimators: Vec<EstimatorResult>,
    outages: Vec<Outage>,
    notes: Vec<String>,
    t0: f64,
) -> Rendered {
    let mut svgs = Vec::new();
    let mut plots = Vec::new();
    let n_plots: usize = sections.iter().map(|s| s.plots.len()).sum();
    let mut h = String::with_capacity(1 << 20);
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><meta name=\"navfuse-plots\" content=\"{n_plots}\"><title>{}</title><style>{CSS}</style></head><body>",
        esc(&inp.title)
    );
    let names: Vec<String> = inp.solutions.iter().map(|s| s.name.clone()).collect();
    let _ = write!(
        h,
        "<header><h1>{}</h1><p>t₀ = {} · estimators: {} · truth: {} · generated by navfuse {}</p></header>",
        esc(&inp.title),
        gps_time(t0),
        if names.is_empty() { "none".into() } else { esc(&names.join(", ")) },
        if inp.truth.is_some() { "yes" } else { "no" },
        env!("CARGO_PKG_VERSION")
    );
    h.push_str("<nav>");
    for s in &sections {
        let _ = write!(h, "<a href=\"#{}\">{}</a>", s.id, esc(&s.title));
    }
    h.push_str("</nav><main>");
    for s in &sections {
        let _ = write!(
            h,
            "<section id=\"{}\"><h2>{}</h2>{}",
            s.id,
            esc(&s.title),
            s.html
        );
        for p in &s.plots {
            let doc = p.render();
            plots.push((p.id.clone(), p.series_count()));
            h.push_str(&doc);
            svgs.push((format!("{}.svg", p.id), doc));
        }
        h.push_str("</section>");
    }
    let _ = writeln!(
        h,
        "</main><div id=\"readout\"></div><script>{SCRIPT}</script></body></html>"
    );
    Rendered {
        html: h,
        svgs,
        plots,
        sections: sections.iter().map(|s| s.id.to_string()).collect(),
        estimators,
        outages,
        notes,
    }
}
