//! RTKLIB `.pos` solution files written from [`NavSolution`]s, in the layout
//! RTKLIB's `rnx2rtkp`/RTKPOST write (RTKLIB 2.4.x manual, appendix B
//! "Solution file format", latitude/longitude/height output): `%` header
//! lines, then per epoch
//!
//! `GPST-date GPST-time lat(deg) lon(deg) height(m) Q ns sdn sde sdu sdne sdeu sdun age ratio`
//!
//! - time: GPS time as `YYYY/MM/DD HH:MM:SS.ssssss` (6 decimals, RTKLIB's
//!   "time decimals" option; a time of week without a week reads as 1980/01/06+);
//! - height: ellipsoidal [m];
//! - sdn, sde, sdu: 1-σ north, east, up [m] (σ_up = σ_down);
//! - sdne, sdeu, sdun: RTKLIB's signed square roots of the NE, EU and UN
//!   covariances, `sign(c)·√|c|` [m] (RTKLIB `solution.c`, `sqvar`). From
//!   NED covariances: `c_ne = P_NE`, `c_eu = −P_ED`, `c_un = −P_DN` (U = −D);
//! - Q: see [`PosEpoch::q`]; ns: satellites; age [s], ratio: RTK's age of
//!   differential and ambiguity ratio ([`PosEpoch::ratio`]), 0 otherwise.
//!
//! Unknown values (NaN σ, no covariance) are written as `nan`, where RTKLIB
//! itself writes 0 — which would claim a perfectly known position.
//! [`crate::pos::PosReader`] reads the file back (σ and cross terms).

use crate::fixed_fmt::{fx0, fxw};
use crate::time::{calendar_from_gps, TimeSystem};
use crate::writers::{lon_deg, TrajectoryWriter};
use navfuse_core::types::{NavSolution, Vec3};
use std::io::{self, Write};

/// RTKLIB solution quality "fix" (RTK integer ambiguities).
pub const Q_FIX: u8 = 1;
/// RTKLIB solution quality "single" (standalone code positioning).
pub const Q_SINGLE: u8 = 5;
/// RTKLIB `SOLQ_DR` = 7, "dead reckoning" (`rtklib.h`; the `Q=…` header
/// line of RTKLIB's files lists only 1–6).
pub const Q_DR: u8 = 7;

/// What a `.pos` line carries beyond the [`NavSolution`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PosEpoch {
    /// RTKLIB quality: 1 fix, 2 float, 3 SBAS, 4 DGPS, 5 single, 6 PPP,
    /// 7 dead reckoning; 0 = no status known.
    pub q: u8,
    /// Satellites used (0 unknown).
    pub ns: u8,
    /// Position covariances off the diagonal (NE, ED, DN) [m²], NED; NaN unknown.
    pub pos_cross_ned: Vec3,
    /// Age of differential [s] and ambiguity ratio-test value (RTK; 0 when
    /// none, as RTKLIB writes them for non-RTK solutions).
    pub age_s: f32,
    pub ratio: f32,
}

impl PosEpoch {
    /// No status, no cross terms (what [`TrajectoryWriter::write`] uses).
    pub const UNKNOWN: PosEpoch = PosEpoch {
        q: 0,
        ns: 0,
        pos_cross_ned: Vec3::new(f64::NAN, f64::NAN, f64::NAN),
        age_s: 0.0,
        ratio: 0.0,
    };
}

/// RTKLIB's signed square root of a covariance: `sign(c)·√|c|` (NaN stays NaN).
pub fn signed_sqrt(c: f64) -> f64 {
    c.signum() * c.abs().sqrt()
}

/// The inverse of [`signed_sqrt`]: `sign(s)·s²`.
pub fn signed_square(s: f64) -> f64 {
    s.signum() * s * s
}

/// RTKLIB's (sdne, sdeu, sdun) [m] from NED covariances (NE, ED, DN) [m²].
pub fn rtklib_cross(pos_cross_ned: Vec3) -> [f64; 3] {
    [
        signed_sqrt(pos_cross_ned.x),
        signed_sqrt(-pos_cross_ned.y),
        signed_sqrt(-pos_cross_ned.z),
    ]
}

/// NED covariances (NE, ED, DN) [m²] from RTKLIB's (sdne, sdeu, sdun) [m].
pub fn ned_cross(sd_ne_eu_un: [f64; 3]) -> Vec3 {
    Vec3::new(
        signed_square(sd_ne_eu_un[0]),
        -signed_square(sd_ne_eu_un[1]),
        -signed_square(sd_ne_eu_un[2]),
    )
}

/// The header: the program line, the quality legend and the column names
/// ([`crate::pos::PosReader`] takes the layout from the last one).
pub const POS_HEADER: &str = "% program   : navfuse\n\
% (lat/lon/height=WGS84/ellipsoidal,Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp,7:dr,ns=# of satellites)\n\
% Q: quality of the last GNSS position fix the filter accepted, 7 (dead reckoning) once none for the coasting time, 0 unknown; nan: unknown\n\
%  GPST                      latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio\n";

/// Streaming `.pos` writer (see the module doc).
pub struct PosWriter<W: Write> {
    w: W,
    started: bool,
}

impl<W: Write> PosWriter<W> {
    pub fn new(w: W) -> Self {
        PosWriter { w, started: false }
    }

    fn start(&mut self) -> io::Result<()> {
        if !self.started {
            self.started = true;
            self.w.write_all(POS_HEADER.as_bytes())?;
        }
        Ok(())
    }

    /// Write one epoch with its quality, satellites and cross covariances.
    /// A non-finite position is an `InvalidData` error.
    pub fn write_epoch(&mut self, s: &NavSolution, e: &PosEpoch) -> io::Result<()> {
        if !(s.lat.is_finite() && s.lon.is_finite() && s.h.is_finite() && s.t.is_finite()) {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!("position or time not finite at t = {}", s.t),
            ));
        }
        self.start()?;
        let c = calendar_from_gps(s.t, TimeSystem::Gpst, 6);
        write!(
            self.w,
            "{:04}/{:02}/{:02} {:02}:{:02}:{} {} {} {} {:3} {:3}",
            c.year,
            c.month,
            c.day,
            c.hour,
            c.minute,
            fx0(c.second, 9, 6),
            fxw(s.lat.to_degrees(), 14, 9),
            fxw(lon_deg(s.lon), 14, 9),
            fxw(s.h, 10, 4),
            e.q,
            e.ns
        )?;
        let sd = s.std_pos_ned;
        let x = rtklib_cross(e.pos_cross_ned);
        for v in [sd.x, sd.y, sd.z, x[0], x[1], x[2]] {
            if v.is_finite() {
                write!(self.w, " {}", fxw(v, 8, 4))?;
            } else {
                self.w.write_all(b"      nan")?;
            }
        }
        // f32 → f64 is exact and `{:.P}` formats the exact value: same text.
        writeln!(
            self.w,
            " {} {}",
            fxw(f64::from(e.age_s), 6, 2),
            fxw(f64::from(e.ratio), 6, 1)
        )
    }
}

impl<W: Write> TrajectoryWriter for PosWriter<W> {
    fn write(&mut self, s: &NavSolution) -> io::Result<()> {
        self.write_epoch(s, &PosEpoch::UNKNOWN)
    }
    fn finish(&mut self) -> io::Result<()> {
        self.start()?;
        self.w.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pos::PosReader;

    #[test]
    fn signed_sqrt_inverts_and_flips_down_to_up() {
        for c in [0.25, -0.25, 0.0, 3.0e-6] {
            assert!((signed_square(signed_sqrt(c)) - c).abs() < 1e-15);
        }
        assert_eq!(signed_sqrt(-4.0), -2.0);
        // P_NE = 0.04, P_ED = 0.09, P_DN = −0.01 → sdne 0.2, sdeu −0.3, sdun 0.1.
        let x = rtklib_cross(Vec3::new(0.04, 0.09, -0.01));
        assert!((x[0] - 0.2).abs() < 1e-15 && (x[1] + 0.3).abs() < 1e-15);
        assert!((x[2] - 0.1).abs() < 1e-15);
        assert!((ned_cross(x) - Vec3::new(0.04, 0.09, -0.01)).abs().max() < 1e-15);
    }

    /// Write → read with [`PosReader`]: time, position, Q, ns, σ and cross
    /// terms equal to the printed decimals; unknown σ stays unknown.
    #[test]
    fn round_trip_through_the_reader() {
        let t0 = crate::time::gps_seconds(2374, 243_258.5);
        let mut sols = Vec::new();
        let mut eps = Vec::new();
        for k in 0..4 {
            let mut s = NavSolution::unknown_at(t0 + 0.005 * k as f64 + 1e-6);
            s.lat = (40.0966268 + k as f64 * 1e-6).to_radians();
            s.lon = (-105.1474483 + k as f64 * 2e-6).to_radians();
            s.h = 1601.474 + k as f64;
            if k != 3 {
                s.std_pos_ned = Vec3::new(0.012, 0.034, 1.25);
            }
            sols.push(s);
            eps.push(PosEpoch {
                q: [1, 2, 7, 0][k],
                ns: [21, 20, 0, 0][k],
                pos_cross_ned: if k < 2 {
                    Vec3::new(1.0e-4, 2.5e-3, -4.0e-4)
                } else {
                    PosEpoch::UNKNOWN.pos_cross_ned
                },
                ..PosEpoch::UNKNOWN
            });
        }
        let mut buf = Vec::new();
        let mut w = PosWriter::new(&mut buf);
        for (s, e) in sols.iter().zip(&eps) {
            w.write_epoch(s, e).unwrap();
        }
        w.finish().unwrap();
        let text = String::from_utf8(buf.clone()).unwrap();
        let l1 = text.lines().nth(5).unwrap();
        assert!(
            l1.starts_with("2025/07/08 19:34:18.505001   40.096627800 -105.147446300  1602.4740   2  20   0.0120   0.0340   1.2500   0.0100  -0.0500   0.0200"),
            "{l1}"
        );
        let mut r = PosReader::new(&buf[..], "rt.pos");
        for (k, (s, e)) in sols.iter().zip(&eps).enumerate() {
            let f = r.next().unwrap().unwrap();
            assert!((f.t - s.t).abs() < 0.5e-6 + 1e-9, "{k}");
            assert!((f.lat - s.lat).abs() < 1e-9f64.to_radians());
            assert!((f.h - s.h).abs() < 0.5e-4 + 1e-9);
            assert_eq!((f.quality, f.num_sats), (e.q, e.ns));
            let x = r.cross_ned();
            for a in 0..3 {
                let (want, got) = (s.std_pos_ned[a], f.std_ned[a]);
                assert!((want.is_nan() && got.is_nan()) || (want - got).abs() <= 0.5e-4);
                let (want, got) = (rtklib_cross(e.pos_cross_ned)[a], rtklib_cross(x)[a]);
                assert!((want.is_nan() && got.is_nan()) || (want - got).abs() <= 0.5e-4);
            }
        }
        assert!(r.next().is_none());
        assert!(r.stats().is_balanced());
    }
}
