//! Statistics of a run against a reference baseline and the GEONET part of
//! `navfuse experiment seed003`.

use super::*;

/// RTKLIB 2.4.2 reference baseline 0759→3040 (data README).
pub const GEONET_REF: [f64; 3] = [-2022.7699, 468.6277, -2610.2896];

/// Statistics of a run against a reference baseline. Epoch numbers and the
/// fix rate count every paired epoch (rejected ones included); the RMS is
/// over the fixed epochs (`fixed` of them).
pub struct Stats {
    /// Paired epochs, and how many of them were rejected (by reason).
    pub n: usize,
    pub rejected_gdop: usize,
    pub rejected_few_sats: usize,
    pub rejected_singular: usize,
    pub fixed: usize,
    /// `fixed / n`.
    pub fix_rate: f64,
    pub first_fix_epoch: Option<usize>,
    /// First fixed epoch within 5 cm of the reference, and its ratio.
    pub first_correct_fix_epoch: Option<usize>,
    pub first_correct_fix_ratio: f64,
    /// At that epoch: the fixed baseline's error, and how far the runner-up
    /// integer candidate's baseline lies from it [m].
    pub first_correct_fix_err: f64,
    pub first_correct_fix_runner_up: f64,
    pub wrong_fixed: usize,
    /// Fixed epochs whose integers differ from the last fixed epoch's on a
    /// shared satellite pair (a wrong fix, or a slip in between).
    pub integers_unlike_last: usize,
    pub last_float_err: Vec3,
    pub last_fixed_err: Option<Vec3>,
    pub last_ratio: f64,
    /// 3D RMS of the fixed baselines against the reference [m].
    pub rms_fixed_3d: f64,
    /// 3D RMS of the float baselines of the solved epochs [m].
    pub rms_float_3d: f64,
}

/// [`Stats`] of `sum` against the `reference` baseline (ECEF, metres).
pub fn stats(sum: &Summary, reference: &Vec3) -> Stats {
    let mut st = Stats {
        n: sum.paired(),
        rejected_gdop: sum.rejected_for(RejectReason::Gdop),
        rejected_few_sats: sum.rejected_for(RejectReason::FewSatellites),
        rejected_singular: sum.rejected_for(RejectReason::Singular),
        fixed: 0,
        fix_rate: f64::NAN,
        first_fix_epoch: None,
        first_correct_fix_epoch: None,
        first_correct_fix_ratio: f64::NAN,
        first_correct_fix_err: f64::NAN,
        first_correct_fix_runner_up: f64::NAN,
        wrong_fixed: 0,
        integers_unlike_last: 0,
        last_float_err: Vec3::repeat(f64::NAN),
        last_fixed_err: None,
        last_ratio: f64::NAN,
        rms_fixed_3d: f64::NAN,
        rms_float_3d: f64::NAN,
    };
    let (mut sf, mut sfl) = (0.0, 0.0);
    for e in &sum.epochs {
        sfl += (e.float_b - reference).norm_squared();
        if let Some(b) = e.fixed_b {
            st.fixed += 1;
            st.first_fix_epoch.get_or_insert(e.epoch);
            let err = (b - reference).norm();
            // "Correct" = within 5 cm of the reference (evaluation only).
            if err < 0.05 {
                if st.first_correct_fix_epoch.is_none() {
                    st.first_correct_fix_epoch = Some(e.epoch);
                    st.first_correct_fix_ratio = e.ratio;
                    st.first_correct_fix_err = err;
                    if let Some(b2) = e.runner_up_b {
                        st.first_correct_fix_runner_up = (b2 - b).norm();
                    }
                }
            } else {
                st.wrong_fixed += 1;
            }
            sf += err * err;
        }
    }
    if let Some(last) = sum.epochs.iter().rev().find(|e| e.fixed_b.is_some()) {
        st.integers_unlike_last = sum
            .epochs
            .iter()
            .filter(|e| e.integers_agree(last) == Some(false))
            .count();
    }
    if let Some(e) = sum.epochs.last() {
        st.last_float_err = e.float_b - reference;
        st.last_fixed_err = e.fixed_b.map(|b| b - reference);
        st.last_ratio = e.ratio;
    }
    if st.fixed > 0 {
        st.rms_fixed_3d = (sf / st.fixed as f64).sqrt();
    }
    if !sum.epochs.is_empty() {
        st.rms_float_3d = (sfl / sum.epochs.len() as f64).sqrt();
    }
    if st.n > 0 {
        st.fix_rate = st.fixed as f64 / st.n as f64;
    }
    st
}

/// Read the rover and base observation files and the navigation files.
pub fn load(
    rover: &Path,
    base: &Path,
    navs: &[PathBuf],
) -> Result<(ObsFile, ObsFile, Vec<KeplerOrbit>), ToolError> {
    let r = read_obs(rover).map_err(|e| e.to_string())?;
    let b = read_obs(base).map_err(|e| e.to_string())?;
    let mut nav = Vec::new();
    for n in navs {
        nav.extend(read_nav(n).map_err(|e| e.to_string())?);
    }
    Ok((r, b, nav))
}

/// The GEONET part of `navfuse experiment seed003`: static and kinematic,
/// L1 and L1+L2, against RTKLIB's fixed baseline; the kinematic L1+L2 run
/// also without the GDOP gate, to show what the gate changes.
pub fn geonet_part(dir: &Path) -> Result<serde_json::Value, ToolError> {
    let (rover, base, nav) = load(
        &dir.join("30400920.05o"),
        &dir.join("07590920.05o"),
        &[dir.join("07590920.05n"), dir.join("30400920.05n")],
    )?;
    let reference = Vec3::new(GEONET_REF[0], GEONET_REF[1], GEONET_REF[2]);
    let max_gdop = Opts::default().max_gdop;
    println!(
        "\nGEONET 0759 (base) → 3040 (rover), {} / {} epochs, RTKLIB reference baseline |b| = {:.4} m",
        base.epochs.len(),
        rover.epochs.len(),
        reference.norm()
    );
    println!(
        "epochs with GDOP > {max_gdop} are rejected (RTKLIB pos2-rejgdop) and count as not fixed; RMS over the fixed epochs"
    );
    println!(
        "{:>18} | {:>15} | {:>26} | {:>8} | {:>9} | {:>6} | {:>17} | {:>8} | {:>8}",
        "mode",
        "1st fix (ratio)",
        "fixed err ENU [mm] (last)",
        "|err| mm",
        "float mm",
        "ratio",
        "fixed/epochs",
        "rej.GDOP",
        "RMS3D mm"
    );
    let mut obj = serde_json::Map::new();
    for (label, kin, l2, gdop) in [
        ("static L1", false, false, max_gdop),
        ("static L1+L2", false, true, max_gdop),
        ("kin. L1", true, false, max_gdop),
        ("kin. L1+L2", true, true, max_gdop),
        ("kin. L1+L2 no gate", true, true, f64::INFINITY),
    ] {
        let opts = Opts {
            kinematic: kin,
            l2,
            max_gdop: gdop,
            ..Default::default()
        };
        let sum = process(&base, &rover, &nav, &opts)?;
        let st = stats(&sum, &reference);
        let fe = st.last_fixed_err.map(|e| enu_at(&base, &e));
        println!(
            "{:>18} | {:>15} | {:>26} | {:>8} | {:>9.1} | {:>6.1} | {:>17} | {:>8} | {:>8.1}",
            label,
            st.first_correct_fix_epoch
                .map(|k| format!("{k} ({:.2})", st.first_correct_fix_ratio))
                .unwrap_or("-".into()),
            fe.map(|e| format!("{:+.1} {:+.1} {:+.1}", e.x * 1e3, e.y * 1e3, e.z * 1e3))
                .unwrap_or("-".into()),
            st.last_fixed_err
                .map(|e| format!("{:.1}", e.norm() * 1e3))
                .unwrap_or("-".into()),
            st.last_float_err.norm() * 1e3,
            st.last_ratio,
            format!("{}/{} ({:.1} %)", st.fixed, st.n, 100.0 * st.fix_rate),
            st.rejected_gdop,
            st.rms_fixed_3d * 1e3,
        );
        let key = label
            .replace(' ', "_")
            .replace('.', "")
            .replace('+', "_")
            .to_lowercase();
        obj.insert(
            key,
            serde_json::json!({
                "epochs": st.n,
                "max_gdop": if gdop.is_finite() { Some(gdop) } else { None },
                "rejected_gdop": st.rejected_gdop,
                "rejected_few_satellites": st.rejected_few_sats,
                "rejected_singular": st.rejected_singular,
                "float_error_m": st.last_float_err.norm(),
                "fixed_error_m": st.last_fixed_err.map(|e| e.norm()),
                "fixed_error_enu_m": fe.map(|e| [e.x, e.y, e.z]),
                "ratio": st.last_ratio,
                "first_fix_epoch": st.first_fix_epoch,
                "first_correct_fix_epoch": st.first_correct_fix_epoch,
                "first_correct_fix_ratio": st.first_correct_fix_ratio,
                "first_correct_fix_error_m": st.first_correct_fix_err,
                "first_correct_fix_runner_up_m": st.first_correct_fix_runner_up,
                "fixed_epochs": st.fixed,
                "fix_rate": st.fix_rate,
                "fixed_epochs_over_5cm": st.wrong_fixed,
                "fixed_epochs_integers_unlike_last": st.integers_unlike_last,
                "rms_fixed_3d_m": st.rms_fixed_3d,
                "unpaired_epochs": sum.unpaired,
                "slips": sum.slips,
            }),
        );
    }
    // Top-level keys of the schema: static L1 for the fix, kinematic
    // L1+L2 (GDOP-gated; RMS over its fixed epochs) for the RMS.
    let s = obj.get("static_l1").cloned().unwrap_or_default();
    let s2 = obj.get("static_l1_l2").cloned().unwrap_or_default();
    let k = obj.get("kin_l1_l2").cloned().unwrap_or_default();
    let k0 = obj.get("kin_l1_l2_no_gate").cloned().unwrap_or_default();
    for (to, from, key) in [
        ("float_error_m", &s, "float_error_m"),
        ("fixed_error_m", &s, "fixed_error_m"),
        ("ratio", &s, "ratio"),
        ("first_fix_epoch", &s, "first_correct_fix_epoch"),
        ("first_fix_ratio", &s, "first_correct_fix_ratio"),
        ("first_fix_error_m", &s, "first_correct_fix_error_m"),
        ("first_fix_runner_up_m", &s, "first_correct_fix_runner_up_m"),
        ("fix_rate", &s, "fix_rate"),
        ("first_fix_epoch_l1_l2", &s2, "first_correct_fix_epoch"),
        ("fix_rate_l1_l2", &s2, "fix_rate"),
        ("max_gdop", &k, "max_gdop"),
        ("rejected_gdop", &k, "rejected_gdop"),
        ("kinematic_rms_m", &k, "rms_fixed_3d_m"),
        ("kinematic_epochs", &k, "fixed_epochs"),
        ("kinematic_fix_rate", &k, "fix_rate"),
        ("kinematic_rms_no_gate_m", &k0, "rms_fixed_3d_m"),
        ("kinematic_epochs_no_gate", &k0, "fixed_epochs"),
    ] {
        obj.insert(to.into(), from[key].clone());
    }
    obj.insert(
        "kinematic_rms_over".into(),
        "fixed epochs of kin_l1_l2 (GDOP-gated); fix rates over all paired epochs".into(),
    );
    Ok(serde_json::Value::Object(obj))
}
