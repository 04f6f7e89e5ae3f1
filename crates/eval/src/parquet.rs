//! The per-epoch error series as a Parquet table (feature `parquet`): the
//! columns of `navfuse eval --csv`, for pandas/polars/DuckDB/Spark.

use crate::ErrorEpoch;
use navfuse_io::parquet_out::{write_table, Column, ColumnData, ParquetOutError, Table};
use std::path::Path;

/// Frames and conventions of [`errors_table`].
pub const ERROR_FRAMES: &str = "Errors are solution minus reference. t_gps_s: GPS time [s] of \
the compared epoch. Position error in the local NED frame at the reference point [m]; \
horizontal = sqrt(north^2 + east^2), vertical = |down|. Velocity error NED [m/s]. Attitude \
error roll/pitch/yaw (ZYX, body FRD w.r.t. NED) [deg] wrapped to (-180, 180]. NaN: unknown \
(velocity or attitude missing in either series).";

/// The error series as a table: `t_gps_s`, `north_m`, `east_m`, `down_m`,
/// `horizontal_m`, `vertical_m`, `vel_north_mps`, `vel_east_mps`,
/// `vel_down_mps`, `roll_deg`, `pitch_deg`, `yaw_deg` (NaN where the error
/// is `None`). Radians become degrees here.
pub fn errors_table(errors: &[ErrorEpoch]) -> Table {
    let col = |name: &str, doc: &str, g: &dyn Fn(&ErrorEpoch) -> f64| {
        Column::new(name, doc, ColumnData::F64(errors.iter().map(g).collect()))
    };
    let nan3 = [f64::NAN; 3];
    let vel = |e: &ErrorEpoch| e.vel_ned.unwrap_or(nan3);
    let att = |e: &ErrorEpoch| e.att_rpy.unwrap_or(nan3).map(f64::to_degrees);
    let mut columns = vec![col("t_gps_s", "GPS time [s]", &|e| e.t)];
    let axes = ["north", "east", "down"];
    for (i, a) in axes.iter().enumerate() {
        let doc = format!("position error {a} (NED) [m]");
        columns.push(col(&format!("{a}_m"), &doc, &|e| e.pos_ned[i]));
    }
    columns.push(col("horizontal_m", "horizontal position error [m]", &|e| {
        e.horizontal
    }));
    columns.push(col(
        "vertical_m",
        "vertical position error |down| [m]",
        &|e| e.vertical,
    ));
    for (i, a) in axes.iter().enumerate() {
        let doc = format!("velocity error {a} (NED) [m/s]");
        columns.push(col(&format!("vel_{a}_mps"), &doc, &|e| vel(e)[i]));
    }
    for (i, a) in ["roll", "pitch", "yaw"].iter().enumerate() {
        let doc = format!("{a} error [deg]");
        columns.push(col(&format!("{a}_deg"), &doc, &|e| att(e)[i]));
    }
    Table {
        kind: "errors".into(),
        frames: ERROR_FRAMES.into(),
        columns,
    }
}

/// Write [`errors_table`] of `errors` to `path` (whole or absent).
pub fn write_errors(path: &Path, errors: &[ErrorEpoch]) -> Result<(), ParquetOutError> {
    write_table(path, &errors_table(errors))
}

#[cfg(test)]
mod tests {
    use super::*;
    use navfuse_io::parquet_out::read_table;

    #[test]
    fn errors_round_trip_with_unknown_velocity_as_nan() {
        let errors: Vec<ErrorEpoch> = (0..5)
            .map(|i| ErrorEpoch {
                t: 10.0 + i as f64,
                pos_ned: [1.0, -2.0, 0.5 * i as f64],
                horizontal: 5f64.sqrt(),
                vertical: 0.5 * i as f64,
                vel_ned: (i != 2).then_some([0.1, 0.2, 0.3]),
                att_rpy: Some([0.0, 0.0, std::f64::consts::FRAC_PI_2]),
            })
            .collect();
        let p = std::env::temp_dir().join(format!("navfuse-eval-{}.parquet", std::process::id()));
        write_errors(&p, &errors).unwrap();
        let t = read_table(&p).unwrap();
        std::fs::remove_file(&p).unwrap();
        assert_eq!(
            (t.kind.as_str(), t.rows(), t.columns.len()),
            ("errors", 5, 12)
        );
        let f = |n: &str| match t.column(n) {
            Some(ColumnData::F64(v)) => v.clone(),
            other => panic!("{n}: {other:?}"),
        };
        assert_eq!(f("down_m"), [0.0, 0.5, 1.0, 1.5, 2.0]);
        let ve = f("vel_east_mps");
        assert!(ve[2].is_nan() && ve[3] == 0.2, "{ve:?}");
        assert!(f("yaw_deg").iter().all(|y| (y - 90.0).abs() < 1e-12));
    }
}
