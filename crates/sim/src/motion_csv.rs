//! gnss-ins-sim motion-definition CSV (its documented format):
//!
//! ```text
//! ini lat (deg),ini lon (deg),ini alt (m),ini vx_body (m/s),ini vy_body (m/s),ini vz_body (m/s),ini yaw (deg),ini pitch (deg),ini roll (deg)
//! 32,120,0,0,0,0,0,0,0
//! command type,yaw (deg),pitch (deg),roll (deg),vx_body (m/s),vy_body (m/s),vz_body (m/s),command duration (s),GPS visibility
//! 1,0,0,0,0,0,0,200,1
//! ```
//!
//! Command type 1: Euler-angle rates [deg/s] and body acceleration [m/s²]
//! for the duration; 2: absolute attitude and velocity; 3: relative
//! attitude and velocity; 4: absolute attitude, relative velocity;
//! 5: relative attitude, absolute velocity. Types 2–5 reach the target at
//! our limits (30°/s, 2 m/s²) and hold for the rest of the duration
//! (gnss-ins-sim uses its own mobility limits, so transitions differ).
//! "GPS visibility" 0 becomes a GNSS outage over that command.

use crate::scenario::{GnssSection, ImuSection, Scenario};
use crate::trajectory::{Segment, Start};
use crate::SimError;

fn fields(line: &str, n: usize, origin: &str, ln: usize) -> Result<Vec<f64>, SimError> {
    let v: Vec<&str> = line.split(',').map(|s| s.trim()).collect();
    if v.len() < n {
        return Err(SimError::Parse(format!(
            "{origin}:{ln}: expected {n} fields, found {}",
            v.len()
        )));
    }
    v[..n]
        .iter()
        .enumerate()
        .map(|(i, s)| {
            s.parse::<f64>().map_err(|_| {
                SimError::Parse(format!(
                    "{origin}:{ln}: field {} '{s}' is not a number",
                    i + 1
                ))
            })
        })
        .collect()
}

/// Parse a gnss-ins-sim motion definition into a scenario (default sensors).
pub fn parse(text: &str, origin: &str) -> Result<Scenario, SimError> {
    let lines: Vec<(usize, &str)> = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty())
        .collect();
    if lines.len() < 4 {
        return Err(SimError::Parse(format!(
            "{origin}: a motion definition needs a header, the initial state, a command header and ≥ 1 command"
        )));
    }
    let (ln, l) = lines[1];
    let ini = fields(l, 9, origin, ln)?;
    let start = Start {
        lat_deg: ini[0],
        lon_deg: ini[1],
        h_m: ini[2],
        v_b: [ini[3], ini[4], ini[5]],
        rpy_deg: [ini[8], ini[7], ini[6]],
        gps_week: 2300,
        tow_s: 345_600.0,
    };
    let mut segment = Vec::new();
    let mut gnss = GnssSection::default();
    let mut t = 0.0;
    for &(ln, l) in &lines[3..] {
        let c = fields(l, 9, origin, ln)?;
        let ty = c[0];
        let rpy = [c[3], c[2], c[1]];
        let v = [c[4], c[5], c[6]];
        let dur = c[7];
        if dur.is_nan() || dur < 0.0 {
            return Err(SimError::Parse(format!(
                "{origin}:{ln}: field 8 (command duration) = {dur} must be ≥ 0"
            )));
        }
        let seg = match ty as i64 {
            1 if ty == 1.0 => Segment::Rates {
                rpy_rate_deg_s: rpy,
                accel_b: v,
                duration_s: dur,
            },
            k @ 2..=5 if ty == k as f64 => Segment::Target {
                rpy_deg: rpy,
                v_b: v,
                rpy_relative: k == 3 || k == 5,
                v_relative: k == 3 || k == 4,
                duration_s: dur,
                max_rate_deg_s: 30.0,
                max_accel: 2.0,
            },
            _ => {
                return Err(SimError::Parse(format!(
                    "{origin}:{ln}: field 1 (command type) = {ty} must be 1..5"
                )))
            }
        };
        if c[8] == 0.0 {
            gnss.outages.push([t, t + dur]);
        }
        t += dur;
        segment.push(seg);
    }
    Ok(Scenario {
        name: origin.to_string(),
        description: "gnss-ins-sim motion definition".into(),
        start,
        imu: ImuSection::default(),
        gnss,
        segment,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const CSV: &str = "ini lat (deg),ini lon (deg),ini alt (m),ini vx_body (m/s),ini vy_body (m/s),ini vz_body (m/s),ini yaw (deg),ini pitch (deg),ini roll (deg)
32,120,0,0,0,0,0,0,0
command type,yaw (deg),pitch (deg),roll (deg),vx_body (m/s),vy_body (m/s),vz_body (m/s),command duration (s),GPS visibility
1,0,0,0,0,0,0,10,1
5,0,0,0,10,0,0,20,1
3,90,0,0,0,0,0,10,0
1,0,0,0,0,0,0,10,1
";

    #[test]
    fn parses_and_runs() {
        let s = parse(CSV, "m.csv").unwrap();
        assert_eq!(s.segment.len(), 4);
        assert_eq!(s.gnss.outages, vec![[30.0, 40.0]]);
        let tr = crate::trajectory::generate(&s.start, &s.segment, 100.0, 4).unwrap();
        let last = tr.truth.last().unwrap();
        // After the relative 90° yaw the car drives east at 10 m/s.
        assert!(
            (last.rpy.z.to_degrees() - 90.0).abs() < 1e-6,
            "{}",
            last.rpy.z
        );
        assert!((last.v_n.y - 10.0).abs() < 1e-6 && last.v_n.x.abs() < 1e-6);
        assert!((tr.duration() - 50.0).abs() < 1e-9);
    }

    #[test]
    fn bad_field_is_named() {
        let bad = CSV.replace("5,0,0,0,10", "5,0,x,0,10");
        let e = parse(&bad, "m.csv").unwrap_err().to_string();
        assert!(e.contains("m.csv:5") && e.contains("field 3"), "{e}");
    }
}
