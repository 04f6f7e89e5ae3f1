//! Read the position σ back from navfuse's own GeoJSON, GPX and KML
//! ([`crate::writers`]): one `(σ_h, σ_v)` [m] per epoch, in order, NaN
//! where the file says unknown. (CSV: [`crate::navcsv`]; RTKLIB `.pos`:
//! [`crate::pos::PosReader`]; σ files: [`crate::stdfile`]; Parquet:
//! [`crate::parquet_out::read_table`].) σ_h = √(σN² + σE²), σ_v = σD.
//!
//! Errors name the file (`name`), the element or feature, and the value.

/// A number as written by the writers: decimals or `nan`.
fn num(x: &str, name: &str, what: &str) -> Result<f64, String> {
    x.trim()
        .parse::<f64>()
        .map_err(|_| format!("{name}: {what}: not a number: {x:?}"))
}

/// KML: the `sigma` Placemark's `sigma_h_m` / `sigma_v_m` lists; empty when
/// the document has none (no σ was known).
pub fn read_kml_sigma(kml: &str, name: &str) -> Result<Vec<(f64, f64)>, String> {
    let values = |data: &str| -> Result<Option<Vec<f64>>, String> {
        let open = format!("<Data name=\"{data}\"><value>");
        let Some(a) = kml.find(&open).map(|a| a + open.len()) else {
            return Ok(None);
        };
        let b = kml[a..]
            .find("</value>")
            .ok_or_else(|| format!("{name}: Data {data}: no </value>"))?;
        kml[a..a + b]
            .split_whitespace()
            .enumerate()
            .map(|(i, x)| num(x, name, &format!("Data {data} value {}", i + 1)))
            .collect::<Result<Vec<f64>, String>>()
            .map(Some)
    };
    match (values("sigma_h_m")?, values("sigma_v_m")?) {
        (Some(h), Some(v)) if h.len() == v.len() => Ok(h.into_iter().zip(v).collect()),
        (None, None) => Ok(Vec::new()),
        (h, v) => Err(format!(
            "{name}: sigma_h_m has {} values, sigma_v_m {}",
            h.map_or(0, |x| x.len()),
            v.map_or(0, |x| x.len())
        )),
    }
}

/// GPX: `navfuse:sigma_h` / `navfuse:sigma_v` of every `trkpt` (NaN for a
/// point without them).
pub fn read_gpx_sigma(gpx: &str, name: &str) -> Result<Vec<(f64, f64)>, String> {
    let tag = |pt: &str, t: &str, k: usize| -> Result<f64, String> {
        let open = format!("<navfuse:{t}>");
        let Some(a) = pt.find(&open).map(|a| a + open.len()) else {
            return Ok(f64::NAN);
        };
        let b = pt[a..]
            .find('<')
            .ok_or_else(|| format!("{name}: trkpt {k}: unterminated navfuse:{t}"))?;
        num(&pt[a..a + b], name, &format!("trkpt {k} navfuse:{t}"))
    };
    gpx.split("<trkpt ")
        .skip(1)
        .enumerate()
        .map(|(i, pt)| {
            let pt = pt.split("</trkpt>").next().unwrap_or(pt);
            Ok((tag(pt, "sigma_h", i + 1)?, tag(pt, "sigma_v", i + 1)?))
        })
        .collect()
}

/// GeoJSON: `sigma_h_m` / `sigma_v_m` of every Point feature (`null` → NaN).
pub fn read_geojson_sigma(json: &str, name: &str) -> Result<Vec<(f64, f64)>, String> {
    let v: serde_json::Value =
        serde_json::from_str(json).map_err(|e| format!("{name}:{}: {e}", e.line()))?;
    let feats = v["features"]
        .as_array()
        .ok_or_else(|| format!("{name}: no features array"))?;
    let get = |f: &serde_json::Value, k: usize, key: &str| -> Result<f64, String> {
        match &f["properties"][key] {
            serde_json::Value::Null => Ok(f64::NAN),
            x => x
                .as_f64()
                .ok_or_else(|| format!("{name}: feature {k}: {key}: not a number: {x}")),
        }
    };
    feats
        .iter()
        .enumerate()
        .filter(|(_, f)| f["geometry"]["type"] == "Point")
        .map(|(k, f)| Ok((get(f, k + 1, "sigma_h_m")?, get(f, k + 1, "sigma_v_m")?)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::OutFormat;
    use crate::writers::sigma_h;
    use crate::writers::tests::render;
    use navfuse_core::types::{NavSolution, Vec3};

    /// Four epochs: σ unknown, then three different σ.
    fn track() -> Vec<NavSolution> {
        (0..4)
            .map(|k| {
                let mut s = NavSolution::unknown_at(crate::time::gps_seconds(
                    2374,
                    243_258.5 + k as f64 * 0.25,
                ));
                s.lat = (40.0966268 + k as f64 * 1e-5).to_radians();
                s.lon = (-105.1474483 - k as f64 * 2e-5).to_radians();
                s.h = 1601.474 + k as f64;
                if k > 0 {
                    s.std_pos_ned = Vec3::new(0.011 * k as f64, 0.023, 0.5 + k as f64);
                }
                s
            })
            .collect()
    }

    fn same(back: &[(f64, f64)], sols: &[NavSolution], tol: f64) {
        assert_eq!(back.len(), sols.len());
        for (b, s) in back.iter().zip(sols) {
            for (x, y) in [(b.0, sigma_h(s)), (b.1, s.std_pos_ned.z)] {
                assert!(
                    (x.is_nan() && y.is_nan()) || (x - y).abs() <= tol,
                    "{x} vs {y}"
                );
            }
        }
    }

    /// Every writer with σ → its reader: equal to the printed 4 decimals.
    #[test]
    fn geojson_gpx_kml_csv_sigma_read_back() {
        let sols = track();
        let tol = 0.5e-4 + 1e-12;
        same(
            &read_geojson_sigma(&render(OutFormat::GeoJson, &sols), "x.geojson").unwrap(),
            &sols,
            tol,
        );
        same(
            &read_gpx_sigma(&render(OutFormat::Gpx, &sols), "x.gpx").unwrap(),
            &sols,
            tol,
        );
        let kml = render(OutFormat::Kml, &sols);
        same(&read_kml_sigma(&kml, "x.kml").unwrap(), &sols, tol);
        // Well-formed with the sigma Placemark, the track unchanged before it.
        let mut r = quick_xml::Reader::from_str(&kml);
        while !matches!(
            r.read_event().expect("well-formed"),
            quick_xml::events::Event::Eof
        ) {}
        assert!(kml.contains("</Placemark>\n<Placemark>\n<name>sigma</name>"));
        // Without any σ: no sigma Placemark, the document as before.
        let bare: Vec<NavSolution> = sols[..1].to_vec();
        let kml0 = render(OutFormat::Kml, &bare);
        assert!(!kml0.contains("sigma"), "{kml0}");
        assert!(read_kml_sigma(&kml0, "x.kml").unwrap().is_empty());
        // CSV: σ per axis.
        let csv = render(OutFormat::Csv, &sols);
        let back: Vec<NavSolution> = crate::navcsv::NavCsvReader::new(csv.as_bytes(), "x.csv")
            .map(Result::unwrap)
            .collect();
        let pairs: Vec<(f64, f64)> = back.iter().map(|b| (sigma_h(b), b.std_pos_ned.z)).collect();
        same(&pairs, &sols, 1e-4);
        // A bad value is named.
        let bad = kml.replacen("<value>nan ", "<value>x ", 1);
        let e = read_kml_sigma(&bad, "x.kml").unwrap_err();
        assert!(e.contains("x.kml: Data sigma_h_m value 1"), "{e}");
    }
}
