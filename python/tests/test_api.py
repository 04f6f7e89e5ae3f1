"""The Python API on simulated data and on bad input (no real data needed)."""

import numpy as np
import pandas as pd
import pytest

import navfuse
import navfuse.fleet


@pytest.fixture(scope="module")
def car():
    return navfuse.simulate("car", 7, duration_s=180.0)


def test_results_are_dataframes_with_unit_columns(car):
    assert isinstance(car.imu, pd.DataFrame)
    assert list(car.imu.columns) == navfuse.IMU_COLUMNS
    assert list(car.gnss.columns) == navfuse.GNSS_COLUMNS
    assert list(car.truth.columns) == navfuse.SOLUTION_COLUMNS
    for c in ["lat_deg", "v_n_mps", "roll_deg", "std_n_m", "t_s"]:
        assert c in navfuse.SOLUTION_COLUMNS
    # 180 s at 100 Hz; 1 Hz fixes minus the outage windows (none start before 120+60 s).
    assert len(car.imu) == 18000
    assert 150 <= len(car.gnss) <= 181


def test_simulated_car_runs_in_memory_and_scores_within_gnss_accuracy(car):
    cfg = navfuse.fleet.sim_config(car, "car")
    r = navfuse.run(cfg, imu=car.imu, gnss=car.gnss)
    assert isinstance(r.summary, dict) and r.summary["solutions"] == len(r.solution)
    assert r.output_dir is None
    ev = navfuse.evaluate(r, car, outages=car.outages)
    assert list(ev.errors.columns) == navfuse.EVAL_COLUMNS
    h = ev.summary["summary"]["horizontal"]
    # Consumer single-point GNSS (~1.5–3 m 1-σ horizontal): a filter that
    # works stays within a few metres; a broken one drifts by tens.
    assert h["rms"] < 5.0, h
    assert ev.summary["counts"]["evaluated"] > 0.9 * len(r.solution)


def test_simulation_is_deterministic_in_the_seed():
    a = navfuse.simulate("uav", 3, duration_s=30.0)
    b = navfuse.simulate("uav", 3, duration_s=30.0)
    c = navfuse.simulate("uav", 4, duration_s=30.0)
    assert a.imu.equals(b.imu) and a.gnss.equals(b.gnss)
    assert not a.imu.equals(c.imu)


def test_streaming_push_equals_batch_process(tmp_path, car):
    yaml = _kfgins_yaml(tmp_path, car)
    batch_eskf = navfuse.Eskf(yaml)
    batch = batch_eskf.process(car.imu, car.gnss)
    e = navfuse.Eskf(yaml)
    gn = car.gnss.to_numpy()
    # As process: fixes at or before the first IMU stamp (the start) are not fed.
    g0 = g = int(np.searchsorted(gn[:, 0], car.imu.t_s.iloc[0], side="right"))
    rows = []
    for s in car.imu.itertuples(index=False):
        while g < len(gn) and gn[g, 0] <= s.t_s + 1e-3:
            e.push_gnss(gn[g, 0], gn[g, 1], gn[g, 2], gn[g, 3], gn[g, 4:7])
            g += 1
        out = e.push_imu(s.t_s, [s.dtheta_x_rad, s.dtheta_y_rad, s.dtheta_z_rad],
                         [s.dvel_x_mps, s.dvel_y_mps, s.dvel_z_mps], s.dt_s)
        if out is not None:
            rows.append(out.to_numpy())
    assert np.array_equal(np.array(rows), batch.to_numpy(), equal_nan=True)
    assert e.stats["gnss_pos_used"] == g - g0 == batch_eskf.stats["gnss_pos_used"]


def _kfgins_yaml(folder, sim):
    """A KF-GINS YAML starting at the simulated truth (files unused by Eskf)."""
    t0 = sim.truth.iloc[1]
    y = folder / "sim.yaml"
    y.write_text(
        "imupath: imu.txt\ngnsspath: gnss.txt\noutputpath: out\nimudatalen: 7\n"
        f"imudatarate: 100\nstarttime: {sim.imu.t_s.iloc[0]}\nendtime: -1\n"
        f"initpos: [{t0.lat_deg}, {t0.lon_deg}, {t0.h_m}]\n"
        f"initvel: [{t0.v_n_mps}, {t0.v_e_mps}, {t0.v_d_mps}]\n"
        f"initatt: [{t0.roll_deg}, {t0.pitch_deg}, {t0.yaw_deg}]\n"
        "initgyrbias: [0, 0, 0]\ninitaccbias: [0, 0, 0]\ninitgyrscale: [0, 0, 0]\n"
        "initaccscale: [0, 0, 0]\ninitposstd: [0.1, 0.1, 0.1]\ninitvelstd: [0.1, 0.1, 0.1]\n"
        "initattstd: [0.5, 0.5, 1.0]\nimunoise:\n  arw: [0.2, 0.2, 0.2]\n  vrw: [0.2, 0.2, 0.2]\n"
        "  gbstd: [10, 10, 10]\n  abstd: [500, 500, 500]\n  gsstd: [1000, 1000, 1000]\n"
        "  asstd: [1000, 1000, 1000]\n  corrtime: 1.0\n"
        f"antlever: [{sim.lever_arm_m[0]}, {sim.lever_arm_m[1]}, {sim.lever_arm_m[2]}]\n")
    return y


def test_errors_are_navfuse_errors_with_file_line_field(tmp_path):
    log = navfuse.fleet.corrupt_log(str(tmp_path))
    with pytest.raises(navfuse.NavfuseError) as e:
        navfuse.run(log.config, output=tmp_path / "out")
    assert f"{tmp_path / 'imu.txt'}:3: field `dtheta_z`: not a number" in str(e.value)
    with pytest.raises(navfuse.NavfuseError, match="missing column"):
        navfuse.run({"input": {"imu": "a", "gnss": "b"}}, imu=pd.DataFrame({"t_s": [1.0]}),
                    gnss=np.zeros((1, 7)))
    with pytest.raises(navfuse.NavfuseError, match=r"none\.yaml:0: field `<file>`: cannot open"):
        navfuse.kf_gins(tmp_path / "none.yaml")
    bad = {"input": {"imu": "a", "gnss": "b"}, "filter": {"preset": "nope"}, "typo": 1}
    with pytest.raises(navfuse.NavfuseError, match="typo"):
        navfuse.run(bad)


def test_cli_prints_the_same_error_text(cli, tmp_path):
    import subprocess

    log = navfuse.fleet.corrupt_log(str(tmp_path))
    p = subprocess.run([str(cli), "run", log.config, "--output", str(tmp_path / "o")],
                       capture_output=True, text=True)
    assert p.returncode != 0
    with pytest.raises(navfuse.NavfuseError) as e:
        navfuse.run(log.config, output=tmp_path / "o2")
    assert str(e.value) in p.stderr, (str(e.value), p.stderr)
