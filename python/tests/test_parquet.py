"""Parquet outputs read back with pyarrow and pandas equal the text outputs.

Runs the built `navfuse` binary (env NAVFUSE_BIN, default
target/release/navfuse in the repository) on a short simulated drive:
`navfuse sim` → `navfuse run` with `formats = ["csv", "parquet"]` and the
smoother → `navfuse eval --csv --parquet`. Each Parquet file must equal its
text twin to the printed precision (half a unit of the last printed decimal)
and carry its units/frames in the key-value metadata.
"""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

REPO = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("NAVFUSE_BIN", REPO / "target" / "release" / "navfuse"))

# 90 s: stand still, accelerate, turn, cruise — enough for alignment,
# updates of every kind and a smoother pass, small enough to run in seconds.
SCENARIO = """
name = "parquet_test"
description = "90 s car drive for the Parquet round trip"
[start]
lat_deg = 30.528
lon_deg = 114.356
h_m = 25.0
rpy_deg = [0.0, 0.0, 30.0]
[imu]
preset = "adis16465"
rate_hz = 100
substeps = 4
[gnss]
preset = "consumer-1hz"
lever_arm_m = [0.0, 0.0, -1.2]
[[segment]]
type = "hold"
duration_s = 20
[[segment]]
type = "accelerate"
speed_kmh = 40
accel = 1.5
[[segment]]
type = "turn"
rate_deg_s = 6
angle_deg = 90
[[segment]]
type = "cruise"
duration_s = 40
"""

RUN_TOML = """
formats = ["csv", "parquet"]
[input]
imu = "sim/imu.txt"
gnss = "sim/gnss.txt"
[filter]
smooth = true
"""

NAV_COLUMNS = [
    "gps_week", "gps_tow_s", "lat_deg", "lon_deg", "h_m",
    "v_n_mps", "v_e_mps", "v_d_mps", "roll_deg", "pitch_deg", "yaw_deg",
]


def navfuse(*args, cwd):
    if not BIN.is_file():
        pytest.fail(f"navfuse binary not found at {BIN}: build it (cargo build --release) or set NAVFUSE_BIN")
    r = subprocess.run([str(BIN), *map(str, args)], cwd=cwd, capture_output=True, text=True)
    assert r.returncode == 0, f"navfuse {' '.join(map(str, args))} failed:\n{r.stderr}"
    return r


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("navfuse-parquet")
    (d / "scenario.toml").write_text(SCENARIO)
    navfuse("sim", "scenario.toml", "--seed", "1", "--out", "sim", cwd=d)
    (d / "run.toml").write_text(RUN_TOML)
    navfuse("run", "run.toml", "--output", "out", cwd=d)
    out = d / "out"
    navfuse("eval", out / "solution.nav", "--truth", "sim/truth.nav",
            "--csv", out / "errors.csv", "--parquet", out / "errors.parquet", cwd=d)
    return out


def text_table(path, sep=None, skip=0):
    """Values and per-value tolerances (half the last printed decimal) of a text table."""
    rows = [line.split(sep) for line in path.read_text().splitlines()[skip:]]
    vals = np.array([[float(x) if x.strip() else np.nan for x in r] for r in rows])
    dec = np.array([[len(x.split(".")[1]) if "." in x else 0 for x in r] for r in rows])
    return vals, 0.5 * 10.0 ** (-dec.astype(float)) * (1 + 1e-9)


def assert_close(got, want, tol, what):
    both_nan = np.isnan(got) & np.isnan(want)
    bad = ~(both_nan | (np.abs(got - want) <= tol))
    assert not bad.any(), f"{what}: {bad.sum()} values differ, first at {np.argwhere(bad)[0]}"


@pytest.mark.parametrize("stem", ["solution", "solution_smoothed"])
def test_solution_parquet_equals_nav(run_dir, stem):
    nav, tol = text_table(run_dir / f"{stem}.nav")
    table = pq.read_table(run_dir / f"{stem}.parquet")
    df = pd.read_parquet(run_dir / f"{stem}.parquet")
    assert len(df) == len(nav) > 300
    assert table.schema.field("gps_week").type == "int32"
    got = df[NAV_COLUMNS].to_numpy(dtype=float)
    assert_close(got, nav, tol, f"{stem}.parquet vs .nav")
    # GPS time is week and seconds of week together, at full precision.
    np.testing.assert_array_equal(df.t_gps_s, df.gps_week * 604800.0 + df.gps_tow_s)
    # Units and frames travel with the file.
    meta = table.schema.metadata
    assert meta[b"navfuse.table"] == b"solution"
    docs = json.loads(meta[b"navfuse.columns"])
    assert set(docs) == set(df.columns) and "[deg]" in docs["lat_deg"]
    assert b"NED" in meta[b"navfuse.frames"]


def test_solution_parquet_equals_csv_sigmas(run_dir):
    csv, tol = text_table(run_dir / "solution.csv", sep=",", skip=1)
    header = (run_dir / "solution.csv").read_text().splitlines()[0].split(",")
    df = pd.read_parquet(run_dir / "solution.parquet")
    assert list(df.columns) == header
    assert_close(df.to_numpy(dtype=float), csv, tol, "solution.parquet vs .csv")
    assert np.isfinite(df.std_n_m).all() and (df.std_n_m > 0).all()


def test_journal_parquet_equals_innovations_csv(run_dir):
    csv = pd.read_csv(run_dir / "solution.innovations.csv")
    df = pd.read_parquet(run_dir / "journal.parquet")
    assert len(df) == len(csv) > 60
    assert (df.kind == csv.kind).all()
    assert (df.dof == csv.dof).all() and (df.accepted == csv.accepted.astype(bool)).all()
    np.testing.assert_allclose(df.t_gps_s, csv.t, atol=0.5e-4 * (1 + 1e-9), rtol=0)
    np.testing.assert_allclose(df.nis, csv.nis, atol=0.5e-6 * (1 + 1e-9), rtol=0)
    assert {"gnss_pos"} <= set(df.kind)


def test_errors_parquet_equals_eval_csv(run_dir):
    vals, tol = text_table(run_dir / "errors.csv", sep=",", skip=1)
    header = (run_dir / "errors.csv").read_text().splitlines()[0].split(",")
    df = pd.read_parquet(run_dir / "errors.parquet")
    assert list(df.columns) == ["t_gps_s"] + header[1:]
    assert len(df) == len(vals) > 1000
    assert_close(df.to_numpy(dtype=float), vals, tol, "errors.parquet vs errors.csv")
    meta = pq.read_schema(run_dir / "errors.parquet").metadata
    assert meta[b"navfuse.table"] == b"errors"
    # A working filter on a clean simulated drive: metre-level, not kilometres.
    assert df.horizontal_m.quantile(0.95) < 20.0
