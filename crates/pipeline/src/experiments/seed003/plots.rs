//! CSVs and SVG charts for the paper's figs. 4–6.

use super::*;
use navfuse_io::atomic::AtomicFile;

/// CSVs for the paper's figs. 4–6 (seed 1000, 2 mm): attitude error,
/// ambiguity error with √P, and the ambiguity of the first risen satellite.
pub(super) fn write_plots(
    dir: &std::path::Path,
    base: &SceneConfig,
    orbits: &[navfuse_core::gnss::KeplerOrbit],
) -> Result<(), String> {
    use std::io::Write;
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let cfg = SceneConfig {
        seed: 1000,
        ..base.clone()
    };
    let scene = simulate(&cfg, orbits);
    let run = run_scene(
        &scene,
        &cfg,
        CpAttConfig::default(),
        Some(FixConfig::default()),
    );
    let io = |p: &std::path::Path, e: std::io::Error| format!("{}: {e}", p.display());
    let mut fig4: [Vec<(f64, f64)>; 3] = [Vec::new(), Vec::new(), Vec::new()];
    for (k, r) in run.rows.iter().enumerate() {
        for (i, a) in [1usize, 0, 2].iter().enumerate() {
            let e = wrap_deg((r.rpy_float[*a] - r.rpy_true[*a]).to_degrees());
            if e.is_finite() {
                fig4[i].push((k as f64, e));
            }
        }
    }
    write_svg(
        &dir.join("fig4_attitude_error.svg"),
        "Fig. 4 — float attitude error (2 mm, 10 s epochs)",
        "epoch",
        "deg",
        &[("pitch", &fig4[0]), ("roll", &fig4[1]), ("yaw", &fig4[2])],
        Some((-2.0, 2.0)),
    )?;
    let p4 = dir.join("fig4_attitude_error.csv");
    let mut w = AtomicFile::create(&p4).map_err(|e| io(&p4, e))?;
    writeln!(w, "epoch,pitch_err_deg,roll_err_deg,yaw_err_deg,pitch_fixed_err_deg,roll_fixed_err_deg,yaw_fixed_err_deg").map_err(|e| io(&p4, e))?;
    for (k, r) in run.rows.iter().enumerate() {
        let e = |v: f64, t: f64| wrap_deg((v - t).to_degrees());
        let fx = r.rpy_fixed.unwrap_or(navfuse_core::Vec3::repeat(f64::NAN));
        writeln!(
            w,
            "{k},{:.5},{:.5},{:.5},{:.5},{:.5},{:.5}",
            e(r.rpy_float.y, r.rpy_true.y),
            e(r.rpy_float.x, r.rpy_true.x),
            e(r.rpy_float.z, r.rpy_true.z),
            e(fx.y, r.rpy_true.y),
            e(fx.x, r.rpy_true.x),
            e(fx.z, r.rpy_true.z)
        )
        .map_err(|e| io(&p4, e))?;
    }
    w.commit().map_err(|e| io(&p4, e))?;
    let mut e5 = Vec::new();
    let mut sd5 = Vec::new();
    let mut msd5 = Vec::new();
    for (k, r) in run.rows.iter().enumerate() {
        if r.amb_err0.is_finite() {
            e5.push((k as f64, r.amb_err0));
            sd5.push((k as f64, r.amb_sd0));
            msd5.push((k as f64, -r.amb_sd0));
        }
    }
    write_svg(
        &dir.join("fig5_ambiguity_error.svg"),
        "Fig. 5 — first DD ambiguity error of baseline 1 with ±√P",
        "epoch",
        "m",
        &[("error", &e5), ("+√P", &sd5), ("−√P", &msd5)],
        Some((-0.5, 0.5)),
    )?;
    let p5 = dir.join("fig5_ambiguity_error.csv");
    let mut w = AtomicFile::create(&p5).map_err(|e| io(&p5, e))?;
    writeln!(w, "epoch,prn_a,prn_b,err_m,sqrt_p_m").map_err(|e| io(&p5, e))?;
    for (k, r) in run.rows.iter().enumerate() {
        for (pa, pb, e, sd) in &r.amb {
            writeln!(w, "{k},{pa},{pb},{e:.6},{sd:.6}").map_err(|e| io(&p5, e))?;
        }
    }
    w.commit().map_err(|e| io(&p5, e))?;
    // Fig. 6: the first satellite that rises after the start.
    let first: Vec<u8> = scene[0].epoch.prn[..scene[0].epoch.n_sats].to_vec();
    let mut seen = first.clone();
    let mut risen = None;
    for (k, s) in scene.iter().enumerate() {
        for &p in &s.epoch.prn[..s.epoch.n_sats] {
            if !seen.contains(&p) {
                risen = Some((k, p));
                break;
            }
        }
        if risen.is_some() {
            break;
        }
        seen.extend_from_slice(&s.epoch.prn[..s.epoch.n_sats]);
    }
    let p6 = dir.join("fig6_rising_satellite.csv");
    let mut w = AtomicFile::create(&p6).map_err(|e| io(&p6, e))?;
    writeln!(w, "epoch,prn_rising,prn_other,err_m,sqrt_p_m").map_err(|e| io(&p6, e))?;
    if let Some((k0, prn)) = risen {
        let mut e6 = Vec::new();
        let mut s6 = Vec::new();
        for (k, r) in run.rows.iter().enumerate().skip(k0) {
            if let Some((_, _, e, sd)) = r.amb.iter().find(|x| x.0 == prn || x.1 == prn) {
                e6.push((k as f64, *e));
                s6.push((k as f64, *sd));
            }
        }
        write_svg(
            &dir.join("fig6_rising_satellite.svg"),
            &format!("Fig. 6 — ambiguity error of PRN {prn} after it rises (epoch {k0})"),
            "epoch",
            "m",
            &[("error", &e6), ("√P", &s6)],
            None,
        )?;
        for (k, r) in run.rows.iter().enumerate().skip(k0) {
            if let Some((pa, pb, e, sd)) = r.amb.iter().find(|x| x.0 == prn || x.1 == prn) {
                let other = if *pa == prn { *pb } else { *pa };
                writeln!(w, "{k},{prn},{other},{e:.6},{sd:.6}").map_err(|e| io(&p6, e))?;
            }
        }
        println!("\nplots: {} (PRN {prn} rises at epoch {k0})", dir.display());
    } else {
        println!(
            "\nplots: {} (no satellite rises in this run)",
            dir.display()
        );
    }
    w.commit().map_err(|e| io(&p6, e))
}

/// A minimal line chart as SVG (one polyline per series).
pub(super) fn write_svg(
    path: &std::path::Path,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[(&str, &Vec<(f64, f64)>)],
    yrange: Option<(f64, f64)>,
) -> Result<(), String> {
    let (w, h, ml, mr, mt, mb) = (800.0, 400.0, 60.0, 110.0, 30.0, 40.0);
    let pts = series.iter().flat_map(|(_, v)| v.iter());
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for &(x, y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if let Some((a, b)) = yrange {
        y0 = a;
        y1 = b;
    }
    if !x0.is_finite() || !x1.is_finite() || x1 <= x0 {
        x0 = 0.0;
        x1 = 1.0;
    }
    if !y0.is_finite() || !y1.is_finite() || y1 <= y0 {
        y0 = -1.0;
        y1 = 1.0;
    }
    let sx = |x: f64| ml + (x - x0) / (x1 - x0) * (w - ml - mr);
    let sy = |y: f64| mt + (1.0 - (y.clamp(y0, y1) - y0) / (y1 - y0)) * (h - mt - mb);
    let colors = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd"];
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"12\">\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
         <text x=\"{}\" y=\"18\" text-anchor=\"middle\">{title}</text>\n\
         <rect x=\"{ml}\" y=\"{mt}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n",
        w / 2.0,
        w - ml - mr,
        h - mt - mb
    );
    for k in 0..=4 {
        let y = y0 + (y1 - y0) * k as f64 / 4.0;
        let x = x0 + (x1 - x0) * k as f64 / 4.0;
        svg += &format!(
            "<text x=\"{}\" y=\"{}\" text-anchor=\"end\">{:.3}</text>\n<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{:.0}</text>\n",
            ml - 4.0,
            sy(y) + 4.0,
            y,
            sx(x),
            h - mb + 16.0,
            x
        );
    }
    svg += &format!(
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{xlabel}</text>\n<text x=\"14\" y=\"{}\" transform=\"rotate(-90 14 {})\" text-anchor=\"middle\">{ylabel}</text>\n",
        ml + (w - ml - mr) / 2.0,
        h - 6.0,
        h / 2.0,
        h / 2.0
    );
    if y0 < 0.0 && y1 > 0.0 {
        svg += &format!(
            "<line x1=\"{ml}\" x2=\"{}\" y1=\"{}\" y2=\"{}\" stroke=\"#aaa\"/>\n",
            w - mr,
            sy(0.0),
            sy(0.0)
        );
    }
    for (i, (name, v)) in series.iter().enumerate() {
        let c = colors[i % colors.len()];
        let pts: Vec<String> = v
            .iter()
            .map(|&(x, y)| format!("{:.1},{:.1}", sx(x), sy(y)))
            .collect();
        svg += &format!(
            "<polyline fill=\"none\" stroke=\"{c}\" stroke-width=\"1\" points=\"{}\"/>\n\
             <text x=\"{}\" y=\"{}\" fill=\"{c}\">{name}</text>\n",
            pts.join(" "),
            w - mr + 8.0,
            mt + 16.0 * (i as f64 + 1.0)
        );
    }
    svg += "</svg>\n";
    navfuse_io::atomic::write_atomic(path, svg).map_err(|e| format!("{}: {e}", path.display()))
}
