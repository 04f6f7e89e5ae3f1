//! Tests of the CSV IMU reader's time bases and counter column.

use crate::counter_clock::CounterClock;
use crate::csv_imu::{AccelUnit, Col, CsvImuConfig, CsvImuReader, CsvTime, GyroUnit};
use crate::testutil::{assert_err, collect};
use crate::time::gps_seconds;
use crate::timebase::TimeBase;

fn cfg(time: CsvTime) -> CsvImuConfig {
    CsvImuConfig {
        header: false,
        accel_unit: AccelUnit::Si,
        gyro_unit: GyroUnit::Rad,
        ..CsvImuConfig::new(
            time,
            [1.into(), 2.into(), 3.into()],
            [4.into(), 5.into(), 6.into()],
        )
    }
}

#[test]
fn unix_utc_column_gets_the_leap_seconds() {
    // 2025-07-08 19:34:00.5 UTC = week 2374 TOW 243258.5 GPST.
    let u = 20_277.0 * 86_400.0 + 19.0 * 3600.0 + 34.0 * 60.0 + 0.5;
    let data = format!("{u},0,0,0,0,0,-9.8\n{},0,0,0,0,0,-9.8\n", u + 0.01);
    let c = cfg(CsvTime::Based {
        col: Col::Index(0),
        base: TimeBase::UnixUtc,
    });
    let mut r = CsvImuReader::new(data.as_bytes(), "imu.csv", c);
    let v: Vec<_> = r.by_ref().map(Result::unwrap).collect();
    assert_eq!(v[0].t, gps_seconds(2374, 243_258.5));
    assert!(r.warnings().is_empty() && r.stats().is_balanced());
}

#[test]
fn a_1970_based_column_declared_as_gps_seconds_is_an_error_at_its_line() {
    let data = "# t\n1752003279.25,0,0,0,0,0,-9.8\n";
    let c = cfg(CsvTime::Based {
        col: Col::Index(0),
        base: TimeBase::GpsSeconds,
    });
    let e = assert_err(
        collect(CsvImuReader::new(data.as_bytes(), "imu.csv", c)),
        "imu.csv",
        2,
        "time",
    );
    assert!(e.msg.contains("gps_seconds_1970"), "{e}");
}

#[test]
fn tow_column_without_week_warns() {
    let data = "100.0,0,0,0,0,0,-9.8\n100.01,0,0,0,0,0,-9.8\n";
    let c = cfg(CsvTime::Based {
        col: Col::Index(0),
        base: TimeBase::GpsWeekTow,
    });
    let mut r = CsvImuReader::new(data.as_bytes(), "imu.csv", c);
    assert_eq!(r.by_ref().count(), 2);
    assert_eq!(r.warnings().len(), 1, "{:?}", r.warnings());
}

#[test]
fn counter_column_is_mapped_and_unwrapped() {
    let m = 4_294_967_296.0;
    let clock = CounterClock {
        modulus: Some(m),
        ..CounterClock::from_two_points(0.0, 1000.0, 1000.0, 1001.0, 1e-3, None)
    };
    let data = "4294967286,0,0,0,0,0,-9.8\n4294967296,0,0,0,0,0,-9.8\n10,0,0,0,0,0,-9.8\n";
    // 4294967296 is outside u32 but still a number: the reader takes it as given.
    let c = cfg(CsvTime::Counter {
        col: Col::Index(0),
        clock,
    });
    let v = collect(CsvImuReader::new(data.as_bytes(), "imu.csv", c.clone())).unwrap();
    assert_eq!(v.len(), 3);
    assert!(
        (v[2].t - (1000.0 + (m + 10.0) * 1e-3)).abs() < 1e-6,
        "{}",
        v[2].t
    );
    assert!((v[2].dt - 0.01).abs() < 1e-6, "{}", v[2].dt);
    assert_err(
        collect(CsvImuReader::new(&b"-5,0,0,0,0,0,0\n"[..], "imu.csv", c)),
        "imu.csv",
        1,
        "time",
    );
}
