//! A first guess of an IMU CSV's `[input.csv]` column map from its header
//! and its first rows, for `navfuse init --imu CSV`. Every guess carries the
//! reason it was made; the template marks them all "check".
//!
//! Names are matched on lower-cased alphanumeric tokens with any `[unit]`
//! or `(unit)` part set aside: time `t`, `time`, `timestamp`, `t_gps_s`,
//! `tow`…; gyro `gx`, `gyro_x`, `wx`, `omega_x`, `IMU::UncompGyro::X`,
//! `dtheta_x`…; accel `ax`, `acc_x`, `accel_x`, `f_x`, `dvel_x`…;
//! magnetometer `mx`, `mag_x`…. The first match of each axis wins.
//!
//! Units: the header's bracketed unit if any; the accelerometer's from the
//! median |f| of the rows read (gravity: ≈ 9.8 in m/s², ≈ 1 in g, ≈ g·dt in
//! increments). Gyro rates cannot be told apart at rest (Earth rate is below
//! MEMS noise in both units); only a rate above 2π (one turn per second
//! in rad/s, implausible for a vehicle) proves degrees.

use crate::error::{PipelineError, Result};
use std::path::Path;

/// Data rows read for the magnitude checks (a few seconds at 100 Hz).
const ROWS: usize = 500;
/// |f| band around g for a unit to count as recognised: ±30 % covers a
/// vehicle's accelerations and a tilted sensor around the 1 g of rest.
const G_BAND: (f64, f64) = (0.7, 1.3);
const G0: f64 = 9.806_65;

/// A guessed value with the reason for it.
#[derive(Clone, Debug, PartialEq)]
pub struct Guess<T> {
    pub value: T,
    pub why: String,
}

fn guess<T>(value: T, why: impl Into<String>) -> Guess<T> {
    Guess {
        value,
        why: why.into(),
    }
}

/// What `navfuse init` proposes for a CSV IMU log.
#[derive(Clone, Debug, PartialEq)]
pub struct CsvGuess {
    pub delimiter: char,
    /// Whether the first line names the columns.
    pub header: bool,
    /// Column names (empty without a header).
    pub names: Vec<String>,
    /// Time column (seconds) by index.
    pub time: Guess<usize>,
    /// Gyro and accelerometer x, y, z columns by index.
    pub gyro: Guess<[usize; 3]>,
    pub accel: Guess<[usize; 3]>,
    /// Magnetometer columns, when named.
    pub mag: Option<[usize; 3]>,
    /// `"deg"` or `"rad"`.
    pub gyro_unit: Guess<&'static str>,
    /// `"m/s2"` or `"g"`.
    pub accel_unit: Guess<&'static str>,
    /// `"rate"` or `"increment"`.
    pub form: Guess<&'static str>,
    /// IMU rate [Hz] from the median time step of the rows read.
    pub rate_hz: Option<f64>,
    /// Mean specific force of the rows read, in the guessed unit's m/s², when
    /// the sensor looked still (for a mounting hint).
    pub f_rest: Option<[f64; 3]>,
    /// Data rows read.
    pub rows: usize,
}

impl CsvGuess {
    /// The column's name for the TOML (header name, else its index).
    pub fn col(&self, i: usize) -> String {
        match self.names.get(i) {
            Some(n) => format!("{n:?}"),
            None => i.to_string(),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Gyro,
    Accel,
    Mag,
}

/// Split a header name into (lower-case tokens without the unit, unit text).
fn tokens(name: &str) -> (Vec<String>, String) {
    let lower = name.to_lowercase();
    let (mut base, mut unit) = (String::new(), String::new());
    let mut depth = 0;
    for ch in lower.chars() {
        match ch {
            '[' | '(' => depth += 1,
            ']' | ')' => depth -= 1,
            _ if depth > 0 => unit.push(ch),
            _ => base.push(ch),
        }
    }
    let t = base
        .split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|s| !s.is_empty())
        .map(str::to_string)
        .collect();
    (t, unit)
}

/// Tokens without trailing unit words (`dtheta_x_rad`, `gyro_x_dps`), and
/// the unit: the bracketed text, else those words joined by `/`.
fn split_unit(name: &str) -> (Vec<String>, String) {
    let (mut t, mut unit) = tokens(name);
    let mut words = Vec::new();
    while t.len() > 1
        && matches!(
            t.last().map(String::as_str),
            Some("rad" | "deg" | "dps" | "s" | "m" | "s2" | "mps2" | "g" | "rads" | "ms2")
        )
    {
        words.extend(t.pop());
    }
    if unit.is_empty() {
        words.reverse();
        unit = words.join("/");
    }
    (t, unit)
}

/// The sensor and axis a column name stands for.
fn classify(name: &str) -> Option<(Kind, usize)> {
    let (mut t, _) = split_unit(name);
    let last = t.pop()?;
    let axis = |s: &str| match s {
        "x" => Some(0),
        "y" => Some(1),
        "z" => Some(2),
        _ => None,
    };
    let (stem, ax) = match axis(&last) {
        Some(a) => (t.concat(), a),
        None => {
            let (head, tail) = last.split_at(last.len().checked_sub(1)?);
            (t.concat() + head, axis(tail)?)
        }
    };
    let has = |subs: &[&str]| subs.iter().any(|s| stem.contains(s));
    let kind = if stem == "m" || has(&["mag"]) {
        Kind::Mag
    } else if matches!(stem.as_str(), "g" | "w" | "wb" | "omega")
        || has(&["gyr", "angvel", "angular", "dtheta", "rot"])
    {
        Kind::Gyro
    } else if matches!(stem.as_str(), "a" | "f" | "fb") || has(&["acc", "dvel", "force", "linear"])
    {
        Kind::Accel
    } else {
        return None;
    };
    Some((kind, ax))
}

fn is_time(name: &str) -> bool {
    let (t, _) = tokens(name);
    if t.iter().any(|s| s.contains("week")) {
        return false;
    }
    t.first().is_some_and(|f| {
        matches!(
            f.as_str(),
            "t" | "time" | "timestamp" | "stamp" | "tow" | "gpstow" | "gpstime" | "sec" | "seconds"
        )
    }) || t.iter().any(|s| s.contains("time"))
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

/// Guess the `[input.csv]` map of the CSV IMU log `path` (see the module
/// doc). Errors: the file cannot be read, or has no line with ≥ 7 fields.
pub fn sniff_csv(path: &Path) -> Result<CsvGuess> {
    let file = std::fs::File::open(path).map_err(PipelineError::io(path, "cannot read: "))?;
    let mut lines = Vec::new();
    for l in navfuse_io::text::capped_lines(std::io::BufReader::new(file)) {
        let l = l.map_err(PipelineError::io(path, "cannot read: "))?;
        let s = l.trim();
        if s.is_empty() || s.starts_with('#') {
            continue;
        }
        lines.push(l);
        if lines.len() > ROWS {
            break;
        }
    }
    let first = lines.first().ok_or_else(|| {
        PipelineError::Input(format!(
            "{}: no data lines to guess a column map from",
            path.display()
        ))
    })?;
    let delimiter = [',', ';', '\t']
        .into_iter()
        .max_by_key(|d| first.matches(*d).count())
        .unwrap_or(',');
    let split =
        |l: &str| -> Vec<String> { l.split(delimiter).map(|s| s.trim().to_string()).collect() };
    let head = split(first);
    if head.len() < 7 {
        return Err(PipelineError::Input(format!(
            "{}:1: {} fields split at {delimiter:?}; an IMU CSV needs time, 3 gyro and 3 accel columns",
            path.display(),
            head.len()
        )));
    }
    let header = head.iter().any(|f| f.parse::<f64>().is_err());
    let names = if header { head.clone() } else { Vec::new() };
    let rows: Vec<Vec<f64>> = lines[usize::from(header)..]
        .iter()
        .map(|l| {
            split(l)
                .iter()
                .map(|f| f.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .filter(|r: &Vec<f64>| r.len() == head.len())
        .collect();

    let mut cols: [[Option<usize>; 3]; 3] = [[None; 3]; 3];
    for (i, n) in names.iter().enumerate() {
        if let Some((k, a)) = classify(n) {
            cols[k as usize][a].get_or_insert(i);
        }
    }
    let full = |c: [Option<usize>; 3]| Some([c[0]?, c[1]?, c[2]?]);
    let time = match names.iter().position(|n| is_time(n)) {
        Some(i) => guess(i, format!("named {:?}", names[i])),
        None => guess(0, "no time-like name: the first column assumed"),
    };
    let gyro = match full(cols[Kind::Gyro as usize]) {
        Some(c) => guess(c, "matched by name"),
        None => guess([1, 2, 3], "NOT FOUND by name: columns 1–3 assumed"),
    };
    let accel = match full(cols[Kind::Accel as usize]) {
        Some(c) => guess(c, "matched by name"),
        None => guess([4, 5, 6], "NOT FOUND by name: columns 4–6 assumed"),
    };
    let mag = full(cols[Kind::Mag as usize]);

    let col = |i: usize| rows.iter().map(move |r| r[i]);
    let dt = median(
        col(time.value)
            .zip(col(time.value).skip(1))
            .map(|(a, b)| b - a)
            .filter(|d| d.is_finite() && *d > 0.0)
            .collect(),
    );
    let norm = |c: [usize; 3]| -> Vec<f64> {
        rows.iter()
            .map(|r| (r[c[0]].powi(2) + r[c[1]].powi(2) + r[c[2]].powi(2)).sqrt())
            .filter(|v| v.is_finite())
            .collect()
    };
    let f_med = median(norm(accel.value));
    let unit_of = |c: usize| names.get(c).map(|n| split_unit(n).1).unwrap_or_default();
    let (a_unit, g_unit) = (unit_of(accel.value[0]), unit_of(gyro.value[0]));
    let in_band = |x: f64, g: f64| x > G_BAND.0 * g && x < G_BAND.1 * g;
    let (accel_unit, form) = match (f_med, dt) {
        (Some(f), _) if in_band(f, G0) => (
            guess("m/s2", format!("median |f| = {f:.3} ≈ g in m/s²")),
            guess("rate", "|f| ≈ g per sample, not g·dt"),
        ),
        (Some(f), _) if in_band(f, 1.0) => (
            guess("g", format!("median |f| = {f:.4} ≈ 1 g")),
            guess("rate", "|f| ≈ 1 g per sample, not g·dt"),
        ),
        (Some(f), Some(d)) if in_band(f / d, G0) || in_band(f / d, 1.0) => (
            if in_band(f / d, G0) {
                guess(
                    "m/s2",
                    format!("median |Δv| = {f:.5} ≈ g·dt in m/s (dt {d:.6} s)"),
                )
            } else {
                guess("g", format!("median |Δv| = {f:.6} ≈ 1 g·dt (dt {d:.6} s)"))
            },
            guess("increment", "|Δv| ≈ g·dt: increments"),
        ),
        _ => {
            let g = a_unit.trim() == "g";
            (
                guess(
                    if g { "g" } else { "m/s2" },
                    format!(
                        "no gravity-sized |f| in the rows read; {}",
                        if a_unit.is_empty() {
                            "the reader's default".into()
                        } else {
                            format!("header unit [{a_unit}]")
                        }
                    ),
                ),
                guess("rate", "the reader's default"),
            )
        }
    };
    let per_s = if form.value == "increment" {
        dt.unwrap_or(1.0)
    } else {
        1.0
    };
    let w_max = norm(gyro.value).into_iter().fold(0.0, f64::max) / per_s;
    let gyro_unit = if g_unit.contains("rad") {
        guess("rad", format!("header unit [{g_unit}]"))
    } else if g_unit.contains("deg") || g_unit.contains('°') || g_unit.contains("dps") {
        guess("deg", format!("header unit [{g_unit}]"))
    } else if w_max > std::f64::consts::TAU {
        guess(
            "deg",
            format!("|ω| reaches {w_max:.1}: more than one turn per second in rad/s"),
        )
    } else {
        guess(
            "deg",
            "cannot tell deg from rad at these rates (|ω| ≤ 2π); the reader's default",
        )
    };
    // Still if the accelerometer norm varies by < 2 % of g over the rows
    // read (an idling car shakes by ~1 %, walking by ~20 %).
    let a = &accel.value;
    let scale = if accel_unit.value == "g" { G0 } else { 1.0 } / per_s;
    let fs = norm(*a);
    let mean = fs.iter().sum::<f64>() / fs.len().max(1) as f64;
    let sd = (fs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / fs.len().max(1) as f64).sqrt();
    let still = fs.len() > 10 && sd * scale < 0.02 * G0;
    let f_rest = still.then(|| {
        let m =
            |i: usize| col(a[i]).filter(|v| v.is_finite()).sum::<f64>() / rows.len() as f64 * scale;
        [m(0), m(1), m(2)]
    });
    Ok(CsvGuess {
        delimiter,
        header,
        names,
        time,
        gyro,
        accel,
        mag,
        gyro_unit,
        accel_unit,
        form,
        rate_hz: dt.map(|d| 1.0 / d),
        f_rest,
        rows: rows.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_names_of_common_loggers_are_classified() {
        for (n, k, a) in [
            ("gx", Kind::Gyro, 0),
            ("gyro_y", Kind::Gyro, 1),
            ("wz", Kind::Gyro, 2),
            ("IMU::UncompGyro::X [rad/s]", Kind::Gyro, 0),
            ("dtheta_z_rad", Kind::Gyro, 2),
            ("omega_y", Kind::Gyro, 1),
            ("ax", Kind::Accel, 0),
            ("acc_y", Kind::Accel, 1),
            ("AccelZ (m/s^2)", Kind::Accel, 2),
            ("dvel_x_m_s", Kind::Accel, 0),
            ("mag_z", Kind::Mag, 2),
            ("mx", Kind::Mag, 0),
        ] {
            assert_eq!(classify(n), Some((k, a)), "{n}");
        }
        for n in ["t", "time", "Timestamp", "t_gps_s", "GpsTow [s]"] {
            assert!(is_time(n), "{n}");
        }
        for n in ["temperature", "x", "status", "Time::GpsWeek"] {
            assert_eq!(classify(n), None, "{n}");
        }
        assert!(!is_time("Time::GpsWeek"));
        assert_eq!(split_unit("dtheta_x_rad").1, "rad");
        assert_eq!(split_unit("gyro_x_rad_s").1, "rad/s");
        assert_eq!(split_unit("IMU::UncompGyro::X [rad/s]").1, "rad/s");
    }

    #[test]
    fn a_still_sensor_in_g_and_deg_s_is_recognised() {
        let d = crate::test_dir("sniff");
        let p = d.join("imu.csv");
        let mut s = String::from("timestamp;gyr_x;gyr_y;gyr_z;acc_x;acc_y;acc_z;temp\n");
        for k in 0..300 {
            let e = if k % 2 == 0 { 0.001 } else { -0.001 };
            s += &format!(
                "{:.2};{e};0.02;-0.01;0.01;{e};1.0;25\n",
                100.0 + k as f64 * 0.01
            );
        }
        std::fs::write(&p, s).unwrap();
        let g = sniff_csv(&p).unwrap();
        assert_eq!((g.delimiter, g.header, g.rows), (';', true, 300));
        assert_eq!(
            (g.time.value, g.gyro.value, g.accel.value),
            (0, [1, 2, 3], [4, 5, 6])
        );
        assert_eq!((g.accel_unit.value, g.form.value), ("g", "rate"));
        assert!(
            g.gyro_unit.why.contains("cannot tell"),
            "{}",
            g.gyro_unit.why
        );
        assert!((g.rate_hz.unwrap() - 100.0).abs() < 1e-6);
        // Sensor z up: f_z ≈ +g at rest.
        assert!((g.f_rest.unwrap()[2] - G0).abs() < 1e-9);
        let _ = std::fs::remove_dir_all(&d);
    }
}
