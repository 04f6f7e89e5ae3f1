//! Tables exchanged with the Python wrapper: row-major little-endian `f64`
//! bytes plus column names (the wrapper turns them into numpy arrays and
//! pandas DataFrames without a per-element Python object). Column names
//! carry the unit (`lat_deg`, `v_n_mps`, …); angles cross in degrees,
//! everything inside Rust stays SI/radians.

use navfuse_core::types::{GnssFix, ImuSample, NavSolution};
use navfuse_core::Vec3;

/// Columns of a solution table: GPS time, IMU position (lat/lon [deg],
/// ellipsoidal height), NED velocity, roll/pitch/yaw of body FRD w.r.t. NED,
/// and the 1-σ of each (NaN where the estimator has none).
pub const SOLUTION_COLUMNS: [&str; 19] = [
    "t_s",
    "lat_deg",
    "lon_deg",
    "h_m",
    "v_n_mps",
    "v_e_mps",
    "v_d_mps",
    "roll_deg",
    "pitch_deg",
    "yaw_deg",
    "std_n_m",
    "std_e_m",
    "std_d_m",
    "std_vn_mps",
    "std_ve_mps",
    "std_vd_mps",
    "std_roll_deg",
    "std_pitch_deg",
    "std_yaw_deg",
];

/// IMU table: stamp, angle and velocity increments over `(t − dt, t]`, body FRD.
pub const IMU_COLUMNS: [&str; 8] = [
    "t_s",
    "dtheta_x_rad",
    "dtheta_y_rad",
    "dtheta_z_rad",
    "dvel_x_mps",
    "dvel_y_mps",
    "dvel_z_mps",
    "dt_s",
];

/// GNSS table: antenna fix, 1-σ NED, optional NED velocity and its 1-σ (NaN: none).
pub const GNSS_COLUMNS: [&str; 13] = [
    "t_s",
    "lat_deg",
    "lon_deg",
    "h_m",
    "std_n_m",
    "std_e_m",
    "std_d_m",
    "v_n_mps",
    "v_e_mps",
    "v_d_mps",
    "std_vn_mps",
    "std_ve_mps",
    "std_vd_mps",
];

/// Append `values` to `out` as little-endian bytes.
fn put(out: &mut Vec<u8>, values: &[f64]) {
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

/// One solution as a [`SOLUTION_COLUMNS`] row.
pub fn solution_row(s: &NavSolution) -> [f64; 19] {
    let d = |v: Vec3| [v.x.to_degrees(), v.y.to_degrees(), v.z.to_degrees()];
    let (r, sr) = (d(s.rpy), d(s.std_rpy));
    [
        s.t,
        s.lat.to_degrees(),
        s.lon.to_degrees(),
        s.h,
        s.v_n.x,
        s.v_n.y,
        s.v_n.z,
        r[0],
        r[1],
        r[2],
        s.std_pos_ned.x,
        s.std_pos_ned.y,
        s.std_pos_ned.z,
        s.std_v_n.x,
        s.std_v_n.y,
        s.std_v_n.z,
        sr[0],
        sr[1],
        sr[2],
    ]
}

/// Solutions as [`SOLUTION_COLUMNS`] bytes.
pub fn solutions_bytes(sols: &[NavSolution]) -> Vec<u8> {
    let mut out = Vec::with_capacity(sols.len() * 19 * 8);
    for s in sols {
        put(&mut out, &solution_row(s));
    }
    out
}

/// IMU samples as [`IMU_COLUMNS`] bytes.
pub fn imu_bytes(imu: &[ImuSample]) -> Vec<u8> {
    let mut out = Vec::with_capacity(imu.len() * 8 * 8);
    for s in imu {
        let (a, v) = (s.dtheta_b, s.dvel_b);
        put(&mut out, &[s.t, a.x, a.y, a.z, v.x, v.y, v.z, s.dt]);
    }
    out
}

/// GNSS fixes as [`GNSS_COLUMNS`] bytes (NaN for a missing velocity).
pub fn gnss_bytes(gnss: &[GnssFix]) -> Vec<u8> {
    let nan = Vec3::repeat(f64::NAN);
    let mut out = Vec::with_capacity(gnss.len() * 13 * 8);
    for f in gnss {
        let (v, sv) = (f.v_n.unwrap_or(nan), f.std_v_n.unwrap_or(nan));
        let s = f.std_ned;
        put(
            &mut out,
            &[
                f.t,
                f.lat.to_degrees(),
                f.lon.to_degrees(),
                f.h,
                s.x,
                s.y,
                s.z,
                v.x,
                v.y,
                v.z,
                sv.x,
                sv.y,
                sv.z,
            ],
        );
    }
    out
}

/// A row-major table received from Python: `ncols` columns of `f64`.
pub struct Table<'a> {
    /// Name used in error messages (`imu`, `gnss`, `solution`, …).
    pub name: &'a str,
    pub data: &'a [u8],
    pub ncols: usize,
}

impl Table<'_> {
    /// Number of rows; an error when the byte count does not fit the columns.
    pub fn rows(&self) -> Result<usize, String> {
        let w = self.ncols * 8;
        if self.ncols == 0 || !self.data.len().is_multiple_of(w) {
            return Err(format!(
                "{}: {} bytes are not rows of {} float64 columns",
                self.name,
                self.data.len(),
                self.ncols
            ));
        }
        Ok(self.data.len() / w)
    }

    /// Row `i` (0-based).
    pub fn row(&self, i: usize) -> impl Iterator<Item = f64> + '_ {
        let w = self.ncols * 8;
        self.data[i * w..(i + 1) * w]
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8-byte chunk")))
    }

    /// Row `i` as a fixed array of its first `N` columns (`N ≤ ncols`).
    fn fixed<const N: usize>(&self, i: usize) -> [f64; N] {
        let mut a = [f64::NAN; N];
        for (o, v) in a.iter_mut().zip(self.row(i)) {
            *o = v;
        }
        a
    }

    /// An error naming row `i` (1-based, as a file line) and `field`.
    fn bad(&self, i: usize, field: &str, what: &str) -> String {
        format!("{}:{}: field `{field}`: {what}", self.name, i + 1)
    }
}

/// IMU samples from an [`IMU_COLUMNS`] table of 7 columns (then `dt` =
/// difference of consecutive stamps, the first `1 / rate_hz`, as navfuse-io's
/// readers form it) or 8 (explicit `dt_s`). Rows must be finite and
/// strictly increasing in time.
pub fn imu_from(t: &Table, rate_hz: f64) -> Result<Vec<ImuSample>, String> {
    if !(t.ncols == 7 || t.ncols == 8) {
        return Err(format!(
            "{}: expected 7 or 8 columns ({}), got {}",
            t.name,
            IMU_COLUMNS.join(", "),
            t.ncols
        ));
    }
    let n = t.rows()?;
    let mut out = Vec::with_capacity(n);
    let mut prev: Option<f64> = None;
    for i in 0..n {
        let r: [f64; 8] = t.fixed(i);
        for (k, v) in r.iter().take(t.ncols).enumerate() {
            if !v.is_finite() {
                return Err(t.bad(i, IMU_COLUMNS[k], &format!("not a finite number: {v}")));
            }
        }
        let dt = match (t.ncols, prev) {
            (8, _) => r[7],
            (_, Some(p)) => r[0] - p,
            (_, None) => 1.0 / rate_hz,
        };
        if prev.is_some_and(|p| r[0] <= p) {
            return Err(t.bad(i, "t_s", "not later than the row before"));
        }
        prev = Some(r[0]);
        out.push(ImuSample {
            t: r[0],
            dt,
            dtheta_b: Vec3::new(r[1], r[2], r[3]),
            dvel_b: Vec3::new(r[4], r[5], r[6]),
        });
    }
    Ok(out)
}

/// GNSS fixes from a [`GNSS_COLUMNS`] table of 7 columns (position) or 13
/// (with velocity; NaN velocity = none at that epoch).
pub fn gnss_from(t: &Table) -> Result<Vec<GnssFix>, String> {
    if !(t.ncols == 7 || t.ncols == 13) {
        return Err(format!(
            "{}: expected 7 or 13 columns ({}), got {}",
            t.name,
            GNSS_COLUMNS.join(", "),
            t.ncols
        ));
    }
    let n = t.rows()?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let r: [f64; 13] = t.fixed(i);
        for (k, v) in r.iter().take(7).enumerate() {
            if !v.is_finite() {
                return Err(t.bad(i, GNSS_COLUMNS[k], &format!("not a finite number: {v}")));
            }
        }
        let vel = (t.ncols == 13 && r[7..].iter().all(|v| v.is_finite()))
            .then(|| (Vec3::new(r[7], r[8], r[9]), Vec3::new(r[10], r[11], r[12])));
        out.push(GnssFix {
            t: r[0],
            lat: r[1].to_radians(),
            lon: r[2].to_radians(),
            h: r[3],
            std_ned: Vec3::new(r[4], r[5], r[6]),
            v_n: vel.map(|v| v.0),
            std_v_n: vel.map(|v| v.1),
            quality: 0,
            num_sats: 0,
        });
    }
    Ok(out)
}

/// Solutions from a [`SOLUTION_COLUMNS`] table (missing columns given as NaN
/// by the wrapper): degrees back to radians.
pub fn solutions_from(t: &Table) -> Result<Vec<NavSolution>, String> {
    if t.ncols != 19 {
        return Err(format!(
            "{}: expected the 19 solution columns, got {}",
            t.name, t.ncols
        ));
    }
    let n = t.rows()?;
    Ok((0..n)
        .map(|i| {
            let r: [f64; 19] = t.fixed(i);
            let v = |k: usize| Vec3::new(r[k], r[k + 1], r[k + 2]);
            NavSolution {
                t: r[0],
                lat: r[1].to_radians(),
                lon: r[2].to_radians(),
                h: r[3],
                v_n: v(4),
                rpy: v(7).map(f64::to_radians),
                std_pos_ned: v(10),
                std_v_n: v(13),
                std_rpy: v(16).map(f64::to_radians),
            }
        })
        .collect())
}
