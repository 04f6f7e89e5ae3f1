//! Hand-written SVG plots: no font or drawing library, so the files open
//! anywhere and drop into papers.
//!
//! A [`Plot`] is axes with ticks and unit-named labels, a legend, shaded
//! x-intervals (GNSS outages), horizontal reference lines (χ² bounds) and
//! layers: lines, point sets and ±kσ bands. Long series are decimated to at
//! most two points per pixel column (its min and max, in time order), which keeps
//! every extreme visible and the files small.
//!
//! Every data series is one `<path class="series">`; the `<svg>` carries
//! `data-series` = their number, so a browser check can compare it with what
//! rendered. Bands, spans and reference lines are not series.

use std::fmt::Write as _;

/// Okabe–Ito colours (distinguishable with colour-vision deficiency),
/// in the order estimators get them.
pub const PALETTE: [&str; 7] = [
    "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#8C564B",
];

/// Marker of a point set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marker {
    Dot,
    Cross,
}

/// One layer of a plot.
#[derive(Clone, Debug)]
pub enum Layer {
    /// A polyline; NaN y (or x) breaks it. `x_sorted`: x is non-decreasing
    /// (time series), which allows per-column min/max decimation.
    Line {
        name: String,
        colour: String,
        pts: Vec<(f64, f64)>,
        width: f64,
        opacity: f64,
        x_sorted: bool,
        legend: bool,
    },
    /// Markers.
    Points {
        name: String,
        colour: String,
        pts: Vec<(f64, f64)>,
        marker: Marker,
        size: f64,
    },
    /// Filled band between `lo` and `hi` at the same `x`s (x sorted); NaN
    /// breaks it.
    Band {
        name: String,
        colour: String,
        x: Vec<f64>,
        lo: Vec<f64>,
        hi: Vec<f64>,
    },
}

/// A horizontal reference line.
#[derive(Clone, Debug)]
pub struct HLine {
    pub y: f64,
    pub colour: String,
    pub label: String,
}

/// A plot description; [`Plot::render`] turns it into SVG text.
#[derive(Clone, Debug)]
pub struct Plot {
    /// Unique within a page: used for element ids.
    pub id: String,
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub width: f64,
    pub height: f64,
    /// Same metres per pixel on both axes (track plots).
    pub equal_aspect: bool,
    /// Logarithmic y (values ≤ 0 are dropped).
    pub log_y: bool,
    /// y range from the 0.5th to the 99.5th percentile of the line values
    /// (outliers and start-up transients are clipped, not rescaled to).
    pub robust_y: bool,
    pub layers: Vec<Layer>,
    /// Shaded x-intervals and their legend label.
    pub spans: Vec<(f64, f64)>,
    pub span_label: String,
    pub hlines: Vec<HLine>,
}

impl Plot {
    pub fn new(id: &str, title: &str, x_label: &str, y_label: &str) -> Self {
        Plot {
            id: id.to_string(),
            title: title.to_string(),
            x_label: x_label.to_string(),
            y_label: y_label.to_string(),
            width: 960.0,
            height: 300.0,
            equal_aspect: false,
            log_y: false,
            robust_y: false,
            layers: Vec::new(),
            spans: Vec::new(),
            span_label: "GNSS outage".into(),
            hlines: Vec::new(),
        }
    }

    /// Number of layers drawn as `class="series"` (non-empty lines and point sets).
    pub fn series_count(&self) -> usize {
        self.layers
            .iter()
            .filter(|l| match l {
                Layer::Line { pts, .. } | Layer::Points { pts, .. } => {
                    pts.iter().any(|p| self.finite_pt(p))
                }
                Layer::Band { .. } => false,
            })
            .count()
    }

    fn ty(&self, y: f64) -> f64 {
        if self.log_y {
            if y > 0.0 {
                y.log10()
            } else {
                f64::NAN
            }
        } else {
            y
        }
    }

    fn finite_pt(&self, p: &(f64, f64)) -> bool {
        p.0.is_finite() && self.ty(p.1).is_finite()
    }

    /// Data ranges (x, y) after the y transform.
    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let mut xr = (f64::INFINITY, f64::NEG_INFINITY);
        let mut yr = (f64::INFINITY, f64::NEG_INFINITY);
        let grow = |r: &mut (f64, f64), v: f64| {
            if v.is_finite() {
                r.0 = r.0.min(v);
                r.1 = r.1.max(v);
            }
        };
        for l in &self.layers {
            if let Layer::Line { pts, .. } | Layer::Points { pts, .. } = l {
                for p in pts {
                    if self.finite_pt(p) {
                        grow(&mut xr, p.0);
                        grow(&mut yr, self.ty(p.1));
                    }
                }
            }
        }
        if self.robust_y {
            let mut v: Vec<f64> = self
                .layers
                .iter()
                .filter_map(|l| match l {
                    Layer::Line { pts, .. } => Some(pts),
                    _ => None,
                })
                .flatten()
                .filter(|p| self.finite_pt(p))
                .map(|p| self.ty(p.1))
                .collect();
            if v.len() > 10 {
                v.sort_by(f64::total_cmp);
                let q = |f: f64| v[((v.len() - 1) as f64 * f).round() as usize];
                let (lo, hi) = (q(0.005), q(0.995));
                let pad = 0.1 * (hi - lo).max(1e-9);
                yr = (lo - pad, hi + pad);
            }
        }
        for h in &self.hlines {
            grow(&mut yr, self.ty(h.y));
        }
        // Bands widen the y range, but at most to 1.5× the data's half span
        // around its middle (a 3σ band that explodes must not flatten the errors).
        let (mut blo, mut bhi) = (f64::INFINITY, f64::NEG_INFINITY);
        for l in &self.layers {
            if let Layer::Band { x, lo, hi, .. } = l {
                for i in 0..x.len() {
                    if x[i].is_finite() {
                        grow(&mut xr, x[i]);
                        let (a, b) = (self.ty(lo[i]), self.ty(hi[i]));
                        if a.is_finite() && b.is_finite() {
                            blo = blo.min(a);
                            bhi = bhi.max(b);
                        }
                    }
                }
            }
        }
        if blo.is_finite() {
            if yr.0.is_finite() {
                let mid = 0.5 * (yr.0 + yr.1);
                let half = (0.5 * (yr.1 - yr.0)).max(1e-9) * 1.5;
                yr.0 = yr.0.min(blo.max(mid - half));
                yr.1 = yr.1.max(bhi.min(mid + half));
            } else {
                yr = (blo, bhi);
            }
        }
        for &(a, b) in &self.spans {
            if xr.0.is_finite() {
                // Spans never widen the x range (they are context).
                let _ = (a, b);
            }
        }
        (fix_range(xr), fix_range(yr))
    }

    /// The SVG document (with `xmlns`, without an XML declaration).
    pub fn render(&self) -> String {
        let font = 13.0;
        let legend_items = self.legend_items();
        let legend_rows = legend_rows(&legend_items, self.width - 80.0, font);
        let (ml, mr, mb) = (74.0, 18.0, 46.0);
        let mt = 30.0 + 18.0 * legend_rows.len() as f64;
        let mut w = self.width;
        let mut h = self.height;
        let ((mut x0, mut x1), (mut y0, mut y1)) = self.ranges();
        let (mut pw, mut ph) = (w - ml - mr, h - mt - mb);
        if self.equal_aspect {
            // Pad the smaller extent so one metre is as long on both axes;
            // let the plot grow in height up to 1.4× its width.
            let (sx, sy) = ((x1 - x0) / pw, (y1 - y0) / ph);
            if sy > sx {
                let want_ph = ((y1 - y0) / sx).min(pw * 1.4);
                ph = want_ph.max(ph);
                h = ph + mt + mb;
            }
            let s = ((x1 - x0) / pw).max((y1 - y0) / ph);
            let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
            x0 = cx - 0.5 * s * pw;
            x1 = cx + 0.5 * s * pw;
            y0 = cy - 0.5 * s * ph;
            y1 = cy + 0.5 * s * ph;
        } else {
            let xt = nice_ticks(x0, x1, 10);
            let yt = nice_ticks(y0, y1, 6);
            if let (Some(a), Some(b)) = (yt.first(), yt.last()) {
                // Snap y to ticks when they are close: axes read better.
                let step = if yt.len() > 1 { yt[1] - yt[0] } else { 1.0 };
                if y0 - a < 0.5 * step && !self.log_y {
                    y0 = y0.min(*a);
                }
                if b - y1 < 0.5 * step && !self.log_y {
                    y1 = y1.max(*b);
                }
            }
            let _ = xt;
            // A little headroom.
            let pad = 0.03 * (y1 - y0);
            y0 -= pad;
            y1 += pad;
        }
        w = w.max(ml + mr + pw);
        pw = w - ml - mr;
        let sx = |x: f64| ml + (x - x0) / (x1 - x0) * pw;
        let sy = |y: f64| mt + (y1 - y) / (y1 - y0) * ph;
        let id = &self.id;

        let mut s = String::with_capacity(64 * 1024);
        let _ = write!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {w:.0} {h:.0}" width="{w:.0}" height="{h:.0}" font-family="DejaVu Sans, Helvetica, Arial, sans-serif" font-size="{font}" class="plot" id="{id}" data-series="{n}" data-x0="{x0}" data-x1="{x1}" data-y0="{y0}" data-y1="{y1}" data-l="{ml}" data-r="{r}" data-t="{mt}" data-b="{b}" data-logy="{logy}" data-xlabel="{xl}" data-ylabel="{yl}">"#,
            n = self.series_count(),
            r = ml + pw,
            b = mt + ph,
            logy = u8::from(self.log_y),
            xl = esc(&self.x_label),
            yl = esc(&self.y_label),
        );
        let _ = write!(
            s,
            r##"<title>{}</title><rect x="0" y="0" width="{w:.0}" height="{h:.0}" fill="#ffffff"/><defs><clipPath id="clip-{id}"><rect x="{ml}" y="{mt}" width="{pw:.1}" height="{ph:.1}"/></clipPath></defs>"##,
            esc(&self.title)
        );
        // Title.
        let _ = write!(
            s,
            r##"<text x="{ml}" y="18" font-size="15" font-weight="bold" fill="#222">{}</text>"##,
            esc(&self.title)
        );
        // Outage spans.
        let _ = write!(s, r#"<g clip-path="url(#clip-{id})">"#);
        for &(a, b) in &self.spans {
            let (pa, pb) = (sx(a.max(x0)), sx(b.min(x1)));
            if pb > pa {
                let _ = write!(
                    s,
                    r##"<rect class="span" x="{pa:.1}" y="{mt}" width="{:.1}" height="{ph:.1}" fill="#f2c14e" fill-opacity="0.22"/>"##,
                    pb - pa
                );
            }
        }
        s.push_str("</g>");
        // Grid and ticks.
        let xticks = if self.equal_aspect {
            nice_ticks(x0, x1, 8)
        } else {
            nice_ticks(x0, x1, 10)
        };
        let yticks = if self.log_y {
            log_ticks(y0, y1)
        } else {
            nice_ticks(y0, y1, 6)
        };
        s.push_str(r##"<g stroke="#e3e3e3" stroke-width="1">"##);
        for &t in &xticks {
            let _ = write!(
                s,
                r#"<line x1="{x:.1}" y1="{mt}" x2="{x:.1}" y2="{b:.1}"/>"#,
                x = sx(t),
                b = mt + ph
            );
        }
        for &t in &yticks {
            let _ = write!(
                s,
                r#"<line x1="{ml}" y1="{y:.1}" x2="{r:.1}" y2="{y:.1}"/>"#,
                y = sy(t),
                r = ml + pw
            );
        }
        s.push_str("</g>");
        // Zero line for linear axes that straddle 0.
        if !self.log_y && y0 < 0.0 && y1 > 0.0 && !self.equal_aspect {
            let _ = write!(
                s,
                r##"<line x1="{ml}" y1="{y:.1}" x2="{r:.1}" y2="{y:.1}" stroke="#9a9a9a" stroke-width="1"/>"##,
                y = sy(0.0),
                r = ml + pw
            );
        }
        let xdec = decimals(&xticks);
        let ydec = decimals(&yticks);
        s.push_str(r##"<g fill="#333" font-size="12">"##);
        for &t in &xticks {
            let _ = write!(
                s,
                r#"<text x="{x:.1}" y="{y:.1}" text-anchor="middle">{}</text>"#,
                fmt_tick(t, xdec),
                x = sx(t),
                y = mt + ph + 16.0
            );
        }
        for &t in &yticks {
            let label = if self.log_y {
                fmt_log_tick(t)
            } else {
                fmt_tick(t, ydec)
            };
            let _ = write!(
                s,
                r#"<text x="{x:.1}" y="{y:.1}" text-anchor="end">{label}</text>"#,
                x = ml - 6.0,
                y = sy(t) + 4.0
            );
        }
        s.push_str("</g>");
        // Axis labels.
        let _ = write!(
            s,
            r##"<text x="{x:.1}" y="{y:.1}" text-anchor="middle" fill="#222">{}</text>"##,
            esc(&self.x_label),
            x = ml + 0.5 * pw,
            y = h - 8.0
        );
        let _ = write!(
            s,
            r##"<text transform="translate(16 {y:.1}) rotate(-90)" text-anchor="middle" fill="#222">{}</text>"##,
            esc(&self.y_label),
            y = mt + 0.5 * ph
        );
        // Data.
        let _ = write!(s, r#"<g clip-path="url(#clip-{id})">"#);
        let tf = |p: (f64, f64)| (sx(p.0), sy(self.ty(p.1)));
        for l in &self.layers {
            if let Layer::Band {
                name,
                colour,
                x,
                lo,
                hi,
            } = l
            {
                let d = band_path(x, lo, hi, &|v| sx(v), &|v| sy(self.ty(v)), pw + ml);
                if !d.is_empty() {
                    let _ = write!(
                        s,
                        r#"<path class="band" data-name="{}" d="{d}" fill="{colour}" fill-opacity="0.13" stroke="none"/>"#,
                        esc(name)
                    );
                }
            }
        }
        for h in &self.hlines {
            let y = sy(self.ty(h.y));
            if y.is_finite() {
                let _ = write!(
                    s,
                    r#"<line class="ref" x1="{ml}" y1="{y:.1}" x2="{r:.1}" y2="{y:.1}" stroke="{c}" stroke-width="1.2" stroke-dasharray="6 4"><title>{t}</title></line>"#,
                    r = ml + pw,
                    c = h.colour,
                    t = esc(&h.label)
                );
            }
        }
        for l in &self.layers {
            match l {
                Layer::Line {
                    name,
                    colour,
                    pts,
                    width,
                    opacity,
                    x_sorted,
                    ..
                } => {
                    if !pts.iter().any(|p| self.finite_pt(p)) {
                        continue;
                    }
                    let px: Vec<(f64, f64)> = pts.iter().map(|&p| tf(p)).collect();
                    let d = line_path(&px, *x_sorted);
                    let _ = write!(
                        s,
                        r#"<path class="series" data-name="{}" d="{d}" fill="none" stroke="{colour}" stroke-width="{width}" stroke-opacity="{opacity}" stroke-linejoin="round" stroke-linecap="round"/>"#,
                        esc(name)
                    );
                }
                Layer::Points {
                    name,
                    colour,
                    pts,
                    marker,
                    size,
                } => {
                    if !pts.iter().any(|p| self.finite_pt(p)) {
                        continue;
                    }
                    let px: Vec<(f64, f64)> = pts.iter().map(|&p| tf(p)).collect();
                    let d = marker_path(&px, *marker, *size);
                    let style = match marker {
                        Marker::Dot => format!(r#"fill="{colour}" stroke="none""#),
                        Marker::Cross => {
                            format!(r#"fill="none" stroke="{colour}" stroke-width="1.6""#)
                        }
                    };
                    let _ = write!(
                        s,
                        r#"<path class="series" data-name="{}" d="{d}" {style}/>"#,
                        esc(name)
                    );
                }
                Layer::Band { .. } => {}
            }
        }
        s.push_str("</g>");
        // Frame.
        let _ = write!(
            s,
            r##"<rect x="{ml}" y="{mt}" width="{pw:.1}" height="{ph:.1}" fill="none" stroke="#555" stroke-width="1"/>"##
        );
        // Legend.
        for (row_i, row) in legend_rows.iter().enumerate() {
            let y = 30.0 + 18.0 * row_i as f64 + 6.0;
            let mut x = ml;
            for &i in row {
                let it = &legend_items[i];
                let sw = match it.kind {
                    LegendKind::Line(wd) => format!(
                        r#"<line x1="{x:.1}" y1="{y:.1}" x2="{x2:.1}" y2="{y:.1}" stroke="{c}" stroke-width="{wd}"/>"#,
                        x2 = x + 22.0,
                        c = it.colour
                    ),
                    LegendKind::Dot => format!(
                        r#"<circle cx="{cx:.1}" cy="{y:.1}" r="3.5" fill="{c}"/>"#,
                        cx = x + 11.0,
                        c = it.colour
                    ),
                    LegendKind::Cross => format!(
                        r#"<path d="M{a:.1},{b:.1}l8,8m0,-8l-8,8" stroke="{c}" stroke-width="1.6" fill="none"/>"#,
                        a = x + 7.0,
                        b = y - 4.0,
                        c = it.colour
                    ),
                    LegendKind::Fill(op) => format!(
                        r#"<rect x="{x:.1}" y="{a:.1}" width="22" height="10" fill="{c}" fill-opacity="{op}"/>"#,
                        a = y - 5.0,
                        c = it.colour
                    ),
                    LegendKind::Dash => format!(
                        r#"<line x1="{x:.1}" y1="{y:.1}" x2="{x2:.1}" y2="{y:.1}" stroke="{c}" stroke-width="1.2" stroke-dasharray="6 4"/>"#,
                        x2 = x + 22.0,
                        c = it.colour
                    ),
                };
                let _ = write!(
                    s,
                    r##"<g class="legend" data-name="{n}">{sw}<text x="{tx:.1}" y="{ty:.1}" fill="#222">{n}</text></g>"##,
                    n = esc(&it.label),
                    tx = x + 28.0,
                    ty = y + 4.5
                );
                x += legend_width(&it.label, font);
            }
        }
        s.push_str("</svg>");
        s
    }

    fn legend_items(&self) -> Vec<LegendItem> {
        let mut v: Vec<LegendItem> = Vec::new();
        let push = |v: &mut Vec<LegendItem>, it: LegendItem| {
            if !v.iter().any(|o| o.label == it.label) {
                v.push(it);
            }
        };
        for l in &self.layers {
            match l {
                Layer::Line {
                    name,
                    colour,
                    width,
                    legend,
                    opacity,
                    pts,
                    ..
                } if *legend && pts.iter().any(|p| self.finite_pt(p)) => push(
                    &mut v,
                    LegendItem {
                        label: name.clone(),
                        colour: colour.clone(),
                        kind: if *opacity < 0.6 {
                            LegendKind::Fill(*opacity)
                        } else {
                            LegendKind::Line(width.clamp(2.0, 3.0))
                        },
                    },
                ),
                Layer::Points {
                    name,
                    colour,
                    marker,
                    pts,
                    ..
                } if pts.iter().any(|p| self.finite_pt(p)) => push(
                    &mut v,
                    LegendItem {
                        label: name.clone(),
                        colour: colour.clone(),
                        kind: match marker {
                            Marker::Dot => LegendKind::Dot,
                            Marker::Cross => LegendKind::Cross,
                        },
                    },
                ),
                _ => {}
            }
        }
        // Bands: one entry (each band has its series' colour).
        let bands: Vec<&Layer> = self
            .layers
            .iter()
            .filter(|l| matches!(l, Layer::Band { x, .. } if !x.is_empty()))
            .collect();
        if let Some(Layer::Band { name, colour, .. }) = bands.first() {
            let label = if bands.len() == 1 {
                name.clone()
            } else {
                "±3σ (series colour)".to_string()
            };
            push(
                &mut v,
                LegendItem {
                    label,
                    colour: if bands.len() == 1 {
                        colour.clone()
                    } else {
                        "#888888".into()
                    },
                    kind: LegendKind::Fill(0.3),
                },
            );
        }
        for h in &self.hlines {
            push(
                &mut v,
                LegendItem {
                    label: h.label.clone(),
                    colour: h.colour.clone(),
                    kind: LegendKind::Dash,
                },
            );
        }
        if !self.spans.is_empty() {
            push(
                &mut v,
                LegendItem {
                    label: self.span_label.clone(),
                    colour: "#f2c14e".into(),
                    kind: LegendKind::Fill(0.45),
                },
            );
        }
        v
    }
}

#[derive(Clone, Copy, Debug)]
enum LegendKind {
    Line(f64),
    Dot,
    Cross,
    Fill(f64),
    Dash,
}

struct LegendItem {
    label: String,
    colour: String,
    kind: LegendKind,
}

fn legend_width(label: &str, font: f64) -> f64 {
    28.0 + 0.6 * font * label.chars().count() as f64 + 18.0
}

fn legend_rows(items: &[LegendItem], avail: f64, font: f64) -> Vec<Vec<usize>> {
    let mut rows: Vec<Vec<usize>> = Vec::new();
    let mut used = f64::INFINITY;
    for (i, it) in items.iter().enumerate() {
        let w = legend_width(&it.label, font);
        if used + w > avail {
            rows.push(Vec::new());
            used = 0.0;
        }
        rows.last_mut().expect("pushed").push(i);
        used += w;
    }
    rows
}

fn fix_range(r: (f64, f64)) -> (f64, f64) {
    if !r.0.is_finite() || !r.1.is_finite() {
        return (0.0, 1.0);
    }
    if r.1 - r.0 < 1e-12 * (1.0 + r.0.abs()) {
        let d = if r.0 == 0.0 { 1.0 } else { 0.1 * r.0.abs() };
        return (r.0 - d, r.1 + d);
    }
    r
}

/// Ticks at 1, 2, 5 × 10^k steps, about `n` of them, inside `[lo, hi]`.
pub fn nice_ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater)
        || !lo.is_finite()
        || !hi.is_finite()
    {
        return Vec::new();
    }
    let raw = (hi - lo) / n.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil();
    let last = (hi / step).floor();
    let mut v = Vec::new();
    let mut k = first;
    while k <= last && v.len() < 100 {
        let t = k * step;
        v.push(if t.abs() < step * 1e-9 { 0.0 } else { t });
        k += 1.0;
    }
    v
}

/// Integer decades in `[lo, hi]` (log10 units); at least the bounds' decades.
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let mut v: Vec<f64> = Vec::new();
    let mut k = lo.ceil();
    while k <= hi.floor() && v.len() < 40 {
        v.push(k);
        k += 1.0;
    }
    if v.len() < 2 {
        return nice_ticks(lo, hi, 4);
    }
    v
}

fn decimals(ticks: &[f64]) -> usize {
    if ticks.len() < 2 {
        return 2;
    }
    let step = (ticks[1] - ticks[0]).abs();
    if step >= 1.0 {
        0
    } else {
        (-(step.log10()).floor() as i64 + 1).clamp(0, 8) as usize
    }
}

fn fmt_tick(t: f64, dec: usize) -> String {
    let s = format!("{t:.dec$}");
    // "−" (U+2212) reads better than "-" in figures.
    match s.strip_prefix('-') {
        Some(r) if r.chars().any(|c| c != '0' && c != '.') => format!("\u{2212}{r}"),
        Some(r) => r.to_string(),
        None => s,
    }
}

fn fmt_log_tick(k: f64) -> String {
    if (k - k.round()).abs() > 1e-9 {
        return fmt_tick(10f64.powf(k), 2);
    }
    let k = k.round() as i32;
    match k {
        -2..=3 => {
            let v = 10f64.powi(k);
            if k < 0 {
                format!("{v}")
            } else {
                format!("{v:.0}")
            }
        }
        _ => format!("1e{k}"),
    }
}

/// XML text escape.
pub fn esc(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            _ => o.push(c),
        }
    }
    o
}

/// First, min, max, last (index, point) of one pixel column.
type Column = [(usize, (f64, f64)); 4];

/// Decimate pixel points: runs of finite points (NaN breaks a run).
/// `x_sorted`: keep the min and max of each pixel column, in time order; else drop points
/// closer than 1 px to the last kept one.
pub fn decimate(px: &[(f64, f64)], x_sorted: bool) -> Vec<Vec<(f64, f64)>> {
    let mut runs: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    let flush = |cur: &mut Vec<(f64, f64)>, runs: &mut Vec<Vec<(f64, f64)>>| {
        if !cur.is_empty() {
            runs.push(std::mem::take(cur));
        }
    };
    if x_sorted {
        // Column state: (col, first, min, max, last) with indices for order.
        let mut col: Option<(i64, Column)> = None;
        let emit = |c: &Column, cur: &mut Vec<(f64, f64)>| {
            // Min and max in time order (the column's envelope).
            let mut v: Vec<(usize, (f64, f64))> = vec![c[1], c[2]];
            v.sort_by_key(|e| e.0);
            v.dedup_by_key(|e| e.0);
            cur.extend(v.into_iter().map(|e| e.1));
        };
        for (i, &p) in px.iter().enumerate() {
            if !(p.0.is_finite() && p.1.is_finite()) {
                if let Some((_, c)) = col.take() {
                    emit(&c, &mut cur);
                }
                flush(&mut cur, &mut runs);
                continue;
            }
            let k = p.0.floor() as i64;
            match &mut col {
                Some((ck, c)) if *ck == k => {
                    if p.1 < c[1].1 .1 {
                        c[1] = (i, p);
                    }
                    if p.1 > c[2].1 .1 {
                        c[2] = (i, p);
                    }
                    c[3] = (i, p);
                }
                _ => {
                    if let Some((_, c)) = col.take() {
                        emit(&c, &mut cur);
                    }
                    col = Some((k, [(i, p); 4]));
                }
            }
        }
        if let Some((_, c)) = col.take() {
            emit(&c, &mut cur);
        }
    } else {
        for &p in px {
            if !(p.0.is_finite() && p.1.is_finite()) {
                flush(&mut cur, &mut runs);
                continue;
            }
            match cur.last() {
                Some(l) if (l.0 - p.0).hypot(l.1 - p.1) < 1.0 => {}
                _ => cur.push(p),
            }
        }
    }
    flush(&mut cur, &mut runs);
    runs
}

/// Path data in relative moves between coordinates rounded to 0.1 px:
/// short numbers, no accumulated rounding; consecutive horizontal (or
/// vertical) steps are merged.
struct PathEnc {
    d: String,
    prev: Option<(i64, i64)>,
    pending: Option<(i64, i64)>,
    open: bool,
}

impl PathEnc {
    fn new() -> Self {
        PathEnc {
            d: String::new(),
            prev: None,
            pending: None,
            open: false,
        }
    }

    fn num(&mut self, v: i64) {
        if v < 0 {
            self.d.push('-');
        }
        let a = v.unsigned_abs();
        let _ = write!(self.d, "{}", a / 10);
        if !a.is_multiple_of(10) {
            let _ = write!(self.d, ".{}", a % 10);
        }
    }

    fn flush(&mut self) {
        if let Some((dx, dy)) = self.pending.take() {
            if !self.d.ends_with('l') {
                self.d.push(' ');
            }
            self.num(dx);
            self.d.push(',');
            self.num(dy);
        }
    }

    fn move_to(&mut self, p: (f64, f64)) {
        self.end_run();
        let q = ((p.0 * 10.0).round() as i64, (p.1 * 10.0).round() as i64);
        self.d.push('M');
        self.num(q.0);
        self.d.push(',');
        self.num(q.1);
        self.d.push('l');
        self.prev = Some(q);
        self.open = true;
    }

    fn line_to(&mut self, p: (f64, f64)) {
        let q = ((p.0 * 10.0).round() as i64, (p.1 * 10.0).round() as i64);
        let Some(o) = self.prev else {
            return self.move_to(p);
        };
        let (dx, dy) = (q.0 - o.0, q.1 - o.1);
        if dx == 0 && dy == 0 {
            return;
        }
        match &mut self.pending {
            Some(pd)
                if (pd.1 == 0 && dy == 0 && pd.0.signum() == dx.signum())
                    || (pd.0 == 0 && dx == 0 && pd.1.signum() == dy.signum()) =>
            {
                pd.0 += dx;
                pd.1 += dy;
            }
            _ => {
                self.flush();
                self.pending = Some((dx, dy));
            }
        }
        self.prev = Some(q);
    }

    fn end_run(&mut self) {
        self.flush();
        if self.open && self.d.ends_with('l') {
            self.d.push_str("0.1,0"); // a lone point still draws (round cap)
        }
        self.open = false;
    }

    fn close(&mut self) {
        self.flush();
        self.d.push('Z');
        self.open = false;
    }

    fn finish(mut self) -> String {
        self.end_run();
        self.d
    }
}

fn line_path(px: &[(f64, f64)], x_sorted: bool) -> String {
    let mut e = PathEnc::new();
    for run in decimate(px, x_sorted) {
        for (i, p) in run.iter().enumerate() {
            if i == 0 {
                e.move_to(*p);
            } else {
                e.line_to(*p);
            }
        }
    }
    e.finish()
}

fn marker_path(px: &[(f64, f64)], marker: Marker, size: f64) -> String {
    let mut d = String::new();
    let mut last: Option<(f64, f64)> = None;
    for &p in px {
        if !(p.0.is_finite() && p.1.is_finite()) {
            continue;
        }
        if let Some(l) = last {
            if (l.0 - p.0).hypot(l.1 - p.1) < 0.4 * size {
                continue;
            }
        }
        last = Some(p);
        let r = size;
        match marker {
            Marker::Dot => {
                let _ = write!(
                    d,
                    "M{:.1},{:.1}a{r},{r} 0 1,0 {d2},0a{r},{r} 0 1,0 -{d2},0",
                    p.0 - r,
                    p.1,
                    d2 = 2.0 * r
                );
            }
            Marker::Cross => {
                let _ = write!(
                    d,
                    "M{:.1},{:.1}l{d2},{d2}m0,-{d2}l-{d2},{d2}",
                    p.0 - r,
                    p.1 - r,
                    d2 = 2.0 * r
                );
            }
        }
    }
    d
}

/// Band polygons: runs of finite (x, lo, hi); per pixel column the lowest lo
/// and highest hi.
fn band_path(
    x: &[f64],
    lo: &[f64],
    hi: &[f64],
    sx: &dyn Fn(f64) -> f64,
    sy: &dyn Fn(f64) -> f64,
    _right: f64,
) -> String {
    let mut d = PathEnc::new();
    let mut run: Vec<(f64, f64, f64)> = Vec::new(); // (px, py_hi, py_lo)
    let flush = |run: &mut Vec<(f64, f64, f64)>, d: &mut PathEnc| {
        if run.len() >= 2 {
            d.move_to((run[0].0, run[0].1));
            for p in &run[1..] {
                d.line_to((p.0, p.1));
            }
            for p in run.iter().rev() {
                d.line_to((p.0, p.2));
            }
            d.close();
        }
        run.clear();
    };
    for i in 0..x.len() {
        let (px, a, b) = (sx(x[i]), sy(hi[i]), sy(lo[i]));
        if !(px.is_finite() && a.is_finite() && b.is_finite()) {
            flush(&mut run, &mut d);
            continue;
        }
        match run.last_mut() {
            Some(l) if l.0.floor() == px.floor() => {
                // Screen y grows downwards: hi is the smaller pixel y.
                l.1 = l.1.min(a);
                l.2 = l.2.max(b);
            }
            _ => run.push((px, a, b)),
        }
    }
    flush(&mut run, &mut d);
    d.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_nice_and_inside() {
        let t = nice_ticks(-3.2, 17.9, 6);
        assert_eq!(t, vec![0.0, 5.0, 10.0, 15.0]);
        let t = nice_ticks(0.013, 0.087, 5);
        assert!(t.iter().all(|v| (0.013..=0.087).contains(v)));
        assert!(t.len() >= 3);
        assert!(nice_ticks(1.0, 1.0, 5).is_empty());
    }

    #[test]
    fn decimation_keeps_extremes_and_bounds_size() {
        // 100 000 samples over 500 px of a sine with one spike.
        let n = 100_000;
        let mut px: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let x = 500.0 * i as f64 / n as f64;
                (x, 100.0 + 50.0 * (x / 20.0).sin())
            })
            .collect();
        px[54_321].1 = -999.0;
        let runs = decimate(&px, true);
        assert_eq!(runs.len(), 1);
        let r = &runs[0];
        assert!(r.len() <= 2 * 501, "{}", r.len());
        assert!(r.iter().any(|p| p.1 == -999.0), "spike lost");
        let ymax = px.iter().map(|p| p.1).fold(f64::MIN, f64::max);
        assert!(r.iter().any(|p| p.1 == ymax));
        // NaN breaks the line into two runs.
        px[10].1 = f64::NAN;
        assert_eq!(decimate(&px, true).len(), 2);
    }

    #[test]
    fn series_count_matches_rendered_paths() {
        let mut p = Plot::new("t1", "Test", "t [s]", "e [m]");
        p.layers.push(Layer::Line {
            name: "a".into(),
            colour: PALETTE[0].into(),
            pts: (0..50).map(|i| (i as f64, (i as f64).sin())).collect(),
            width: 1.5,
            opacity: 1.0,
            x_sorted: true,
            legend: true,
        });
        p.layers.push(Layer::Points {
            name: "b".into(),
            colour: PALETTE[1].into(),
            pts: vec![(1.0, 0.5), (2.0, f64::NAN)],
            marker: Marker::Cross,
            size: 3.0,
        });
        // All-NaN layer: not drawn, not counted.
        p.layers.push(Layer::Line {
            name: "c".into(),
            colour: PALETTE[2].into(),
            pts: vec![(1.0, f64::NAN)],
            width: 1.5,
            opacity: 1.0,
            x_sorted: true,
            legend: true,
        });
        p.layers.push(Layer::Band {
            name: "±3σ".into(),
            colour: PALETTE[0].into(),
            x: vec![0.0, 10.0, 20.0],
            lo: vec![-1.0, -2.0, -3.0],
            hi: vec![1.0, 2.0, 3.0],
        });
        p.spans.push((5.0, 8.0));
        let s = p.render();
        assert_eq!(p.series_count(), 2);
        assert!(s.contains(r#"data-series="2""#));
        assert_eq!(s.matches(r#"class="series""#).count(), 2);
        assert_eq!(s.matches(r#"class="band""#).count(), 1);
        assert_eq!(s.matches(r#"class="span""#).count(), 1);
        assert!(!s.contains("NaN") && !s.contains("inf"));
    }

    #[test]
    fn escapes_markup() {
        assert_eq!(esc("a<b & \"c\""), "a&lt;b &amp; &quot;c&quot;");
    }
}
