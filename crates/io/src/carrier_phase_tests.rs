use super::*;
use crate::testutil::{assert_err, collect, token_lines};
use proptest::prelude::*;

const CSV: &str = "# two satellites, two baselines\n\
t_gps_s,prn,last_in_epoch,los_e,los_n,los_u,sigma_m,sd1_m,sd2_m\n\
1000.5,12,0,0.6,0.0,0.8,0.002,0.5,-12.25\n\
1000.5,7,1,0.0,0.6,0.8,0.002,0.25,3.5\n";

fn read(d: &[u8]) -> Result<Vec<CarrierPhaseSat>, ReadError> {
    collect(CpCsvReader::new(d, "cp.csv"))
}

fn with_line3(v: &str) -> Vec<u8> {
    CSV.replace("1000.5,7,1,0.0,0.6,0.8,0.002,0.25,3.5", v)
        .into_bytes()
}

#[test]
fn reads_rows_and_accounts_for_every_line() {
    let mut r = CpCsvReader::new(CSV.as_bytes(), "cp.csv");
    let v: Vec<CarrierPhaseSat> = r.by_ref().map(Result::unwrap).collect();
    assert_eq!(v.len(), 2);
    assert_eq!(
        (v[0].prn, v[0].n_baselines, v[0].last_in_epoch),
        (12, 2, false)
    );
    assert_eq!(v[1].sd_phase_m, [0.25, 3.5, 0.0, 0.0]);
    assert_eq!(v[1].los_enu, Vec3::new(0.0, 0.6, 0.8));
    assert!(v[1].last_in_epoch);
    assert_eq!(r.n_baselines(), Some(2));
    assert!(r.stats().is_balanced());
    assert_eq!((r.stats().skipped, r.stats().used), (2, 2));
}

/// Writer → reader is exact (shortest round-trip floats).
#[test]
fn written_file_reads_back_bit_for_bit() {
    let recs: Vec<CarrierPhaseSat> = (0..9)
        .map(|i| {
            let a = 0.37 * i as f64 + 0.1;
            CarrierPhaseSat {
                t: 1.2e9 + (i / 3) as f64 * 0.1,
                prn: 1 + i as u8,
                n_baselines: 3,
                last_in_epoch: i % 3 == 2,
                los_enu: Vec3::new(a.cos() * 0.6, a.sin() * 0.6, 0.8).normalize(),
                sigma_m: 0.002 / (i as f64 + 1.0),
                sd_phase_m: [1e5 / 3.0 * a, -a.exp(), std::f64::consts::PI * a, 0.0],
            }
        })
        .collect();
    let mut w = CpCsvWriter::new(Vec::new(), 3).unwrap();
    for r in &recs {
        w.write(r).unwrap();
    }
    let bytes = w.into_inner();
    assert_eq!(read(&bytes).unwrap(), recs);
}

#[test]
fn bad_rows_name_file_line_and_field() {
    assert_err(
        read(&with_line3("1000.5,7,1,0.0,0.6,0.8,0.002,0.25")),
        "cp.csv",
        4,
        "sd2_m",
    );
    assert_err(
        read(&with_line3("1000.5,7,1,0.0,0.6,0.8,0.002,0.25,3.5,1")),
        "cp.csv",
        4,
        "<column 10>",
    );
    assert_err(
        read(&with_line3("1000.4,7,1,0.0,0.6,0.8,0.002,0.25,3.5")),
        "cp.csv",
        4,
        "t_gps_s",
    );
    assert_err(
        read(&with_line3("1000.5,12,1,0.0,0.6,0.8,0.002,0.25,3.5")),
        "cp.csv",
        4,
        "prn",
    );
    assert_err(
        read(&with_line3("1000.5,7.5,1,0.0,0.6,0.8,0.002,0.25,3.5")),
        "cp.csv",
        4,
        "prn",
    );
    assert_err(
        read(&with_line3("1000.5,0,1,0.0,0.6,0.8,0.002,0.25,3.5")),
        "cp.csv",
        4,
        "prn",
    );
    assert_err(
        read(&with_line3("1000.5,7,2,0.0,0.6,0.8,0.002,0.25,3.5")),
        "cp.csv",
        4,
        "last_in_epoch",
    );
    assert_err(
        read(&with_line3("1000.5,7,1,0.0,0.6,0.9,0.002,0.25,3.5")),
        "cp.csv",
        4,
        "los_e",
    );
    assert_err(
        read(&with_line3("1000.5,7,1,0.0,0.6,0.8,0,0.25,3.5")),
        "cp.csv",
        4,
        "sigma_m",
    );
    assert_err(
        read(&with_line3("1000.5,7,1,0.0,0.6,0.8,0.002,nan,3.5")),
        "cp.csv",
        4,
        "sd1_m",
    );
    assert_err(
        read(&with_line3("1000.5,7,1,0.0,0.6,0.8,0.002,0.25,x")),
        "cp.csv",
        4,
        "sd2_m",
    );
    // Header: wrong name, too few or too many columns.
    let h = CSV.replace("los_n", "los_x");
    assert_err(read(h.as_bytes()), "cp.csv", 2, "<header>");
    let h = CSV.replace(",sd1_m,sd2_m", "");
    assert_err(read(h.as_bytes()), "cp.csv", 2, "<header>");
    let h = CSV.replace("sd2_m", "sd2_m,sd3_m,sd4_m,sd5_m");
    assert_err(read(h.as_bytes()), "cp.csv", 2, "<header>");
}

/// The same PRN in a new epoch at the same time stamp (after a
/// `last_in_epoch` row) is fine; within an epoch it is not.
#[test]
fn prn_repeats_only_across_epochs() {
    let ok = format!("{CSV}1000.5,12,1,0.6,0.0,0.8,0.002,0.5,-12.25\n");
    assert_eq!(read(ok.as_bytes()).unwrap().len(), 3);
    let bad = CSV.replace("1000.5,12,0,", "1000.5,7,0,");
    assert_err(read(bad.as_bytes()), "cp.csv", 4, "prn");
}

proptest! {
    #[test]
    fn never_panics(data in proptest::collection::vec(any::<u8>(), 0..300), lines in token_lines()) {
        let _ = read(&data);
        let d = [b"t_gps_s,prn,last_in_epoch,los_e,los_n,los_u,sigma_m,sd1_m\n".as_slice(), &lines].concat();
        let mut r = CpCsvReader::new(&d[..], "x");
        if r.by_ref().all(|x| x.is_ok()) {
            prop_assert!(r.stats().is_balanced());
        }
    }
}
