"""navfuse.kf_gins and navfuse.Eskf.process against the CLI on drive_0708
(real data: fails when it is missing)."""

import resource
import subprocess
import time

import numpy as np

import navfuse


def _cpu(who):
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def _cli_run(cli, yaml, out):
    """(wall, CPU) seconds of one CLI run; CPU is the child's user + system."""
    c, t = _cpu(resource.RUSAGE_CHILDREN), time.perf_counter()
    subprocess.run([str(cli), "kf-gins", str(yaml), "--output", str(out)], check=True,
                   capture_output=True)
    return time.perf_counter() - t, _cpu(resource.RUSAGE_CHILDREN) - c


def _py_run(yaml, out):
    """(wall, CPU, result) of one navfuse.kf_gins call, CPU of this process."""
    c, t = _cpu(resource.RUSAGE_SELF), time.perf_counter()
    r = navfuse.kf_gins(yaml, output=out)
    return time.perf_counter() - t, _cpu(resource.RUSAGE_SELF) - c, r


def test_kf_gins_matches_the_cli_and_costs_at_most_10_percent_more(cli, data_dir, tmp_path):
    yaml = data_dir / "drive_0708" / "kfgins" / "kf-gins_outage.yaml"
    # Best of seven each, alternated, on CPU time (user + system). One run is
    # ~0.1 s: on wall time a scheduler hiccup is 10 %, and best-of-three wall
    # time failed CI once at 1.15 on a loaded 2-core runner while the same
    # build measured 0.88-0.99 on an idle one (CPU ratio 0.90-0.92 there).
    # Then the ratio of the best-of-seven CPU times failed CI at 1.118, and
    # the same build gave 1.007, 1.167 and, over four trials of 11 pairs,
    # 0.99-1.16 on an idle machine whose CPU time per run drifted between
    # 0.16 and 0.37 s: the two minima come from different moments. The
    # statistic is now the median of the ratios of adjacent pairs (each CLI
    # run against the Python call right after it), which the drift cancels
    # out of: 0.99-1.05 over the same four trials, but 0.95-1.10 with 11
    # pairs in the test itself; so 25 pairs after one warm-up pair (page
    # faults and first-call set-up of both sides), not scored.
    w_cli, w_py, t_cli, t_py = [], [], [], []
    for k in range(26):
        w, c = _cli_run(cli, yaml, tmp_path / f"cli{k}")
        w_cli.append(w)
        t_cli.append(c)
        w, c, r = _py_run(yaml, tmp_path / f"py{k}")
        w_py.append(w)
        t_py.append(c)
    for name in ["KF_GINS_Navresult.nav", "KF_GINS_IMU_ERR.txt", "KF_GINS_STD.txt"]:
        a = (tmp_path / "cli0" / name).read_bytes()
        b = (tmp_path / "py0" / name).read_bytes()
        assert a == b, f"{name} differs between the CLI and navfuse.kf_gins"
    # The DataFrame is the written trajectory before formatting: against the
    # CLI's .nav it differs only by the file's rounding.
    nav = np.loadtxt(tmp_path / "cli0" / "KF_GINS_Navresult.nav")
    sol = r.solution
    assert len(sol) == len(nav)
    assert np.array_equal(np.round(sol["t_s"].to_numpy(), 3), np.round(nav[:, 1], 3))
    dlat = np.abs(sol["lat_deg"].to_numpy() - nav[:, 2]).max()
    dh = np.abs(sol["h_m"].to_numpy() - nav[:, 4]).max()
    print(f"DataFrame vs CLI .nav: max |Δlat| {dlat:.2e} deg, max |Δh| {dh:.2e} m")
    assert dlat < 1e-8 and dh < 1e-3
    t_cli, t_py, w_cli, w_py = t_cli[1:], t_py[1:], w_cli[1:], w_py[1:]
    ratio = float(np.median(np.array(t_py) / np.array(t_cli)))
    print(f"CPU time: CLI {min(t_cli):.3f} s, navfuse.kf_gins {min(t_py):.3f} s (best of 25), "
          f"median paired ratio {ratio:.3f}, ratio of the best {min(t_py) / min(t_cli):.3f} "
          f"(wall {np.median(np.array(w_py) / np.array(w_cli)):.3f})")
    assert ratio <= 1.10, f"Python overhead {100 * (ratio - 1):.1f} % > 10 %"


def test_eskf_process_on_numpy_arrays_equals_kf_gins(data_dir, tmp_path):
    folder = data_dir / "drive_0708" / "kfgins"
    yaml = folder / "kf-gins_outage.yaml"
    ref = navfuse.kf_gins(yaml, output=tmp_path).solution
    imu = np.loadtxt(folder / "imu.txt")
    gnss = np.loadtxt(folder / "gnss_outage.txt")
    got = navfuse.Eskf(yaml).process(imu, gnss)
    # kf_gins writes from the second IMU sample on (the first initialises).
    got = got.iloc[1:].reset_index(drop=True)
    assert got.shape == ref.shape
    diff = np.nanmax(np.abs(got.to_numpy() - ref.to_numpy()))
    print(f"Eskf.process vs kf_gins: max difference {diff}")
    assert diff == 0.0


def test_kf_gins_smoothed_frame_carries_the_smoothed_sigma(data_dir, tmp_path):
    """The smoothed DataFrame has the RTS covariance's σ (it had NaN): finite
    and positive, and on average not above the forward σ (smoothing only adds
    information)."""
    yaml = data_dir / "drive_0708" / "kfgins" / "kf-gins_outage.yaml"
    r = navfuse.kf_gins(yaml, smooth=True, output=tmp_path)
    sm, fw = r.smoothed, r.solution
    assert len(sm) > 1000
    for c in ["std_n_m", "std_e_m", "std_d_m", "std_vn_mps", "std_yaw_deg"]:
        assert np.isfinite(sm[c]).all() and (sm[c] > 0).all(), c
    for c in ["std_n_m", "std_e_m", "std_d_m"]:
        assert sm[c].mean() <= fw[c].mean(), c
