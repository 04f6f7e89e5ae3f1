//! Reader of navfuse's trajectory CSV (the layout [`crate::writers::CsvWriter`]
//! writes: header of unit-named columns, see [`crate::writers::CSV_HEADER`]).
//!
//! Columns are found by header name, in any order. Required: `lat_deg`,
//! `lon_deg`, `h_m` and either `t_gps_s` or `gps_week` + `gps_tow_s`. Every
//! other column is optional; missing or `nan` values are NaN ("unknown"),
//! position and time must be finite. Lines starting with `#` are comments.

use crate::error::{ReadError, RecordStats};
use crate::kfgins::{next_data_line, wrap_pi};
use crate::text::{in_range, LineSource, Sep};
use navfuse_core::types::NavSolution;
use std::io::BufRead;

const COLS: [&str; 21] = [
    "t_gps_s",
    "gps_week",
    "gps_tow_s",
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

/// Streaming reader of navfuse trajectory CSV → [`NavSolution`].
pub struct NavCsvReader<R> {
    src: LineSource<R>,
    idx: Option<([Option<usize>; 21], usize)>,
    done: bool,
}

impl<R: BufRead> NavCsvReader<R> {
    pub fn new(rdr: R, file: &str) -> Self {
        NavCsvReader {
            src: LineSource::new(rdr, file),
            idx: None,
            done: false,
        }
    }

    pub fn stats(&self) -> &RecordStats {
        &self.src.stats
    }

    fn read(&mut self) -> Result<Option<NavSolution>, ReadError> {
        loop {
            let min = self.idx.map_or(0, |i| i.1);
            if !next_data_line(&mut self.src, min, Sep::Byte(b','), Some(b'#'))? {
                return Ok(None);
            }
            if self.idx.is_some() {
                break;
            }
            // Header line.
            let s = &self.src;
            let mut idx = [None; 21];
            for i in 0..s.n_fields() {
                let name = s.text(i, "<header>")?;
                if let Some(k) = COLS.iter().position(|c| *c == name) {
                    idx[k] = Some(i);
                }
            }
            for k in [3, 4, 5] {
                if idx[k].is_none() {
                    return Err(s.err(COLS[k], "required column missing from the header"));
                }
            }
            if idx[0].is_none() && (idx[1].is_none() || idx[2].is_none()) {
                return Err(s.err(
                    "t_gps_s",
                    "header needs `t_gps_s` or `gps_week` and `gps_tow_s`",
                ));
            }
            let n = s.n_fields();
            self.src.stats.skipped += 1;
            self.idx = Some((idx, n));
        }
        let s = &self.src;
        let (idx, n) = self.idx.expect("header read");
        if s.n_fields() != n {
            let field = if s.n_fields() < n {
                idx.iter()
                    .position(|c| *c == Some(s.n_fields()))
                    .map_or_else(
                        || format!("<column {}>", s.n_fields() + 1),
                        |k| COLS[k].to_string(),
                    )
            } else {
                format!("<column {}>", n + 1)
            };
            return Err(s.err(
                field,
                format!("line has {} columns, the header has {n}", s.n_fields()),
            ));
        }
        let req = |k: usize| s.f64(idx[k].expect("checked"), COLS[k]);
        let opt = |k: usize| match idx[k] {
            Some(i) => s.f64_or_nan(i, COLS[k]),
            None => Ok(f64::NAN),
        };
        let t = match idx[0] {
            Some(i) => s.f64(i, COLS[0])?,
            None => req(1)? * crate::time::SECONDS_PER_WEEK + req(2)?,
        };
        let lat = in_range(req(3)?, -90.0, 90.0, "latitude").map_err(|m| s.err(COLS[3], m))?;
        let lon = in_range(req(4)?, -180.0, 360.0, "longitude").map_err(|m| s.err(COLS[4], m))?;
        let mut sol = NavSolution::unknown_at(t);
        sol.lat = lat.to_radians();
        sol.lon = wrap_pi(lon.to_radians());
        sol.h = req(5)?;
        for a in 0..3 {
            sol.v_n[a] = opt(6 + a)?;
            sol.rpy[a] = opt(9 + a)?.to_radians();
            sol.std_pos_ned[a] = opt(12 + a)?;
            sol.std_v_n[a] = opt(15 + a)?;
            sol.std_rpy[a] = opt(18 + a)?.to_radians();
        }
        sol.rpy.z = wrap_pi(sol.rpy.z);
        Ok(Some(sol))
    }
}

impl<R: BufRead> Iterator for NavCsvReader<R> {
    type Item = Result<NavSolution, ReadError>;
    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = self.read();
        crate::text::record_step(r, &mut self.done, &mut self.src.stats)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{assert_err, collect, token_lines};
    use proptest::prelude::*;

    const CSV: &str = "# comment\nt_gps_s,lat_deg,lon_deg,h_m,yaw_deg\n\
1436038458.5,40.0966268,-105.1474483,1601.474,nan\n\
1436038458.75,40.0966269,-105.1474484,1601.475,190.0\n";

    fn read(d: &[u8]) -> Result<Vec<NavSolution>, ReadError> {
        collect(NavCsvReader::new(d, "traj.csv"))
    }
    fn line2(v: &str) -> Vec<u8> {
        CSV.replace("1436038458.75,40.0966269,-105.1474484,1601.475,190.0", v)
            .into_bytes()
    }

    #[test]
    fn reads_columns_by_name_with_optional_ones_unknown() {
        let mut r = NavCsvReader::new(CSV.as_bytes(), "traj.csv");
        let v: Vec<NavSolution> = r.by_ref().map(Result::unwrap).collect();
        assert_eq!(v.len(), 2);
        assert!(v[0].rpy.z.is_nan() && v[1].v_n.x.is_nan());
        assert!((v[1].rpy.z.to_degrees() + 170.0).abs() < 1e-9, "wrapped");
        assert_eq!((r.stats().skipped, r.stats().used), (2, 2));
        assert_err(read(b"t_gps_s,lat_deg,h_m\n"), "traj.csv", 1, "lon_deg");
    }

    #[test]
    fn corruptions_name_file_line_field() {
        assert_err(
            read(&line2("1436038458.75,40.0966269,-105.1")),
            "traj.csv",
            4,
            "h_m",
        );
        assert_err(
            read(&line2("1436038458.75,40.09.66269,-105.1474484,1601.475,1")),
            "traj.csv",
            4,
            "lat_deg",
        );
        assert_err(
            read(&line2("1436038458.75,40.0966269,-105.1474484,1601.475,1,2")),
            "traj.csv",
            4,
            "<column 6>",
        );
        assert_err(
            read(&line2("1436038458.75,40.0966269,nan,1601.475,1")),
            "traj.csv",
            4,
            "lon_deg",
        );
        let mut b = line2("1436038458.75,40.0966269,-105.1474484,1601.4\u{1}75,1");
        let i = b.iter().position(|&c| c == 1).unwrap();
        b[i] = 0xff;
        assert_err(read(&b), "traj.csv", 4, "h_m");
    }

    proptest! {
        #[test]
        fn never_panics(data in proptest::collection::vec(any::<u8>(), 0..300), lines in token_lines()) {
            let _ = read(&data);
            let d = [b"t_gps_s,lat_deg,lon_deg,h_m\n".as_slice(), &lines].concat();
            let mut r = NavCsvReader::new(&d[..], "x");
            if r.by_ref().all(|x| x.is_ok()) {
                prop_assert!(r.stats().is_balanced());
            }
        }
    }
}
