"""CI-sized fleet on a local 2-CPU Ray cluster (loopback, no dashboard):
a few short simulated drives and one corrupt log."""

import pandas as pd
import pyarrow.parquet as pq
import pytest

import navfuse
import navfuse.fleet as fleet


@pytest.fixture(scope="module")
def ray_local():
    import ray

    fleet.init_local(2)
    yield ray
    ray.shutdown()


def test_fleet_completes_every_good_log_and_reports_the_corrupt_one(ray_local, tmp_path):
    logs = fleet.drive_logs(5, minutes=1.0) + [fleet.corrupt_log(str(tmp_path / "bad"))]
    rep = fleet.run_fleet(logs, str(tmp_path / "out"), max_retries=1)
    assert sorted(r["log"] for r in rep.completed) == sorted(l.id for l in logs[:5])
    assert len(rep.failures) == 1
    f = rep.failures[0]
    assert f["log"] == "corrupt" and f["attempts"] == 2
    assert f"{tmp_path / 'bad' / 'imu.txt'}:3: field `dtheta_z`" in f["error"]
    summary = pd.read_parquet(tmp_path / "out" / "summary.parquet")
    # 6000 IMU samples each; solutions from the end of the alignment on (the
    # static start holds 10–20 s, then heading needs motion).
    assert len(summary) == 5 and (summary["solutions"] > 2000).all()
    # Consumer GNSS: each simulated drive within a few metres of the truth.
    assert (summary["horizontal_rms_m"] < 10.0).all(), summary["horizontal_rms_m"]
    failures = pq.read_table(tmp_path / "out" / "failures.parquet").to_pandas()
    assert list(failures["log"]) == ["corrupt"]
    # A worker's Parquet solutions equal the same drive run here.
    log = logs[0]
    sim = navfuse.simulate(log.platform, log.seed, duration_s=log.duration_s)
    here = navfuse.run(fleet.sim_config(sim, log.platform), imu=sim.imu, gnss=sim.gnss)
    there = pd.read_parquet(tmp_path / "out" / "solutions" / f"{log.id}.parquet")
    pd.testing.assert_frame_equal(there, here.solution, check_exact=True)
