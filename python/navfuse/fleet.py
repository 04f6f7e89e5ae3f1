"""Fleets of logs on Ray: one Ray task per log, results as Parquet.

A *log* is a run configuration (``Log.config``: a TOML path, run with
``navfuse.run``) or a simulated drive (``Log.platform`` + ``Log.seed``:
``navfuse.simulate`` then an in-memory ``navfuse.run`` with the platform
profile and the simulated IMU model, scored with ``navfuse.evaluate``).
``run_fleet`` submits one task per log (``max_retries``: a task that raises
or whose worker dies is run again up to that many times), collects results
as they finish, and never lets one bad log stop the batch: it is reported in
``FleetReport.failures`` with the error text (``file:line: field ...``).

Output folder: ``summary.parquet`` (one row per completed log),
``failures.parquet`` (one row per failed log) and, per log,
``solutions/<log id>.parquet`` (written by the worker itself, so solutions
never travel through the driver; on a multi-node cluster ``out_dir`` must
be storage every node reaches, see docs/python.md).

Measurement: ``python -m navfuse.fleet bench --drives 200 --minutes 10``.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Optional, Sequence

PLATFORMS = ("car", "robot", "pedestrian", "uav")


@dataclass(frozen=True)
class Log:
    """One unit of fleet work: ``config`` (a run TOML path) or a simulated
    drive (``platform``, ``seed``, ``duration_s``). ``id`` names its outputs."""

    id: str
    config: Optional[str] = None
    platform: Optional[str] = None
    seed: int = 0
    duration_s: float = 600.0


@dataclass
class FleetReport:
    """``completed``: summary rows; ``failures``: ``{"log", "error", "attempts"}``
    rows; ``seconds``: wall time from submission to the last result;
    ``workers``: CPUs of the Ray cluster."""

    completed: list = field(default_factory=list)
    failures: list = field(default_factory=list)
    seconds: float = 0.0
    workers: int = 0

    @property
    def logs_per_second(self) -> float:
        n = len(self.completed) + len(self.failures)
        return n / self.seconds if self.seconds > 0 else 0.0


def sim_config(sim: Any, platform: str) -> dict:
    """The run configuration a user writes who knows only the platform and
    the IMU model (``[filter] platform`` + ``imu_preset``) and the antenna
    lever arm; alignment, time offset and noise are left to the pipeline."""
    return {
        "input": {"imu": "sim", "gnss": "sim", "imu_rate": sim.imu_rate_hz},
        "filter": {"platform": platform, "imu_preset": sim.imu_preset,
                   "lever_arm": list(sim.lever_arm_m)},
    }


def process_log(log: Log, out_dir: str, solution_every: int = 1) -> dict:
    """Run one log and write its solutions to ``out_dir/solutions/<id>.parquet``
    (every ``solution_every``-th row). Returns its summary row. Raises
    ``navfuse.NavfuseError`` on bad input."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    import navfuse

    t0 = time.perf_counter()
    row: dict = {"log": log.id, "platform": log.platform or "", "seed": log.seed}
    if log.config is not None:
        res = navfuse.run(log.config, output=os.path.join(out_dir, "runs", log.id))
        row["source"] = log.config
    elif log.platform is not None:
        sim = navfuse.simulate(log.platform, log.seed, duration_s=log.duration_s)
        res = navfuse.run(sim_config(sim, log.platform), imu=sim.imu, gnss=sim.gnss)
        ev = navfuse.evaluate(res, sim, outages=sim.outages).summary
        hor = ev["summary"].get("horizontal") or {}
        out = ev.get("outages") or {}
        row.update({
            "source": sim.description,
            "horizontal_rms_m": hor.get("rms", float("nan")),
            "horizontal_max_m": hor.get("max_abs", float("nan")),
            "outage_rms_of_max_m": out.get("rms_of_max") or float("nan"),
            "outages": len(sim.outages),
        })
    else:
        raise navfuse.NavfuseError(f"log {log.id}: neither a config nor a platform")
    sol = res.solution.iloc[::max(1, solution_every)]
    sol_dir = Path(out_dir, "solutions")
    sol_dir.mkdir(parents=True, exist_ok=True)
    pq.write_table(pa.Table.from_pandas(sol, preserve_index=False), sol_dir / f"{log.id}.parquet")
    row.update({
        "solutions": len(res.solution),
        "alignment": str(res.summary.get("alignment", "")),
        "seconds": time.perf_counter() - t0,
    })
    return row


def _error_text(e: BaseException) -> str:
    cause = getattr(e, "cause", None)  # ray.exceptions.RayTaskError wraps the raised error
    if cause is not None:
        return f"{type(cause).__name__}: {cause}"
    return f"{type(e).__name__}: {e}"


def run_fleet(logs: Sequence[Log], out_dir: str, *, max_retries: int = 2,
              solution_every: int = 1) -> FleetReport:
    """Run ``logs`` on the connected Ray cluster (call ``ray.init`` first:
    ``init_local`` for this machine, ``ray.init(address="auto")`` on a
    cluster), one task per log (1 CPU each). Writes ``summary.parquet`` and
    ``failures.parquet`` into ``out_dir``; returns the report."""
    import pandas as pd
    import ray

    Path(out_dir).mkdir(parents=True, exist_ok=True)
    task = ray.remote(num_cpus=1, max_retries=max_retries, retry_exceptions=True)(process_log)
    t0 = time.perf_counter()
    pending = {task.remote(log, out_dir, solution_every): log for log in logs}
    rep = FleetReport(workers=int(ray.cluster_resources().get("CPU", 0)))
    while pending:
        done, _ = ray.wait(list(pending), num_returns=1)
        for ref in done:
            log = pending.pop(ref)
            try:
                rep.completed.append(ray.get(ref))
            except Exception as e:  # reported per log; the batch goes on
                rep.failures.append({"log": log.id, "error": _error_text(e),
                                     "attempts": max_retries + 1, **_log_fields(log)})
    rep.seconds = time.perf_counter() - t0
    pd.DataFrame(rep.completed).to_parquet(Path(out_dir, "summary.parquet"), index=False)
    pd.DataFrame(rep.failures, columns=["log", "error", "attempts", "config", "platform",
                                        "seed", "duration_s"]).to_parquet(
        Path(out_dir, "failures.parquet"), index=False)
    return rep


def _log_fields(log: Log) -> dict:
    d = asdict(log)
    d.pop("id")
    return d


def init_local(num_cpus: int) -> None:
    """A local Ray cluster of ``num_cpus`` workers on the loopback interface,
    no dashboard, no usage reporting."""
    import ray

    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    ray.init(num_cpus=num_cpus, include_dashboard=False, _node_ip_address="127.0.0.1",
             log_to_driver=False, configure_logging=False)


def corrupt_log(folder: str) -> Log:
    """A run configuration whose IMU file has a non-number on line 3 (the
    deliberately corrupt log of the benchmark and its test)."""
    d = Path(folder)
    d.mkdir(parents=True, exist_ok=True)
    rows = [f"{100 + 0.01 * k:.2f} 0 0 0 0 0 -0.098" for k in range(1, 400)]
    rows[2] = "100.03 0 0 zero 0 0 -0.098"
    (d / "imu.txt").write_text("\n".join(rows) + "\n")
    (d / "gnss.txt").write_text("".join(
        f"{100 + k} 30.5 114.3 25.0 0.5 0.5 1.0\n" for k in range(0, 4)))
    (d / "run.toml").write_text('[input]\nimu = "imu.txt"\ngnss = "gnss.txt"\n'
                                'imu_rate = 100.0\n')
    return Log(id="corrupt", config=str(d / "run.toml"))


def drive_logs(n: int, minutes: float) -> list:
    """``n`` simulated drives, platforms in turn, seed = index."""
    return [Log(id=f"{PLATFORMS[i % 4]}-{i:04d}", platform=PLATFORMS[i % 4], seed=i,
                duration_s=60.0 * minutes) for i in range(n)]


def bench(drives: int, minutes: float, workers: Sequence[int], out: str,
          max_retries: int = 2, solution_every: int = 100) -> dict:
    """``drives`` logs (``drives − 1`` simulated drives + 1 corrupt log)
    with each worker count of ``workers``; returns drives/s per count and
    the scaling of the last count over the first."""
    import ray

    rates = {}
    reports = {}
    for w in workers:
        d = Path(out, f"workers-{w}")
        logs = drive_logs(drives - 1, minutes) + [corrupt_log(str(d / "corrupt"))]
        init_local(w)
        try:
            # Warm-up: start the workers and import navfuse in each before timing.
            ray.get([ray.remote(num_cpus=1)(_warm).remote() for _ in range(w)])
            rep = run_fleet(logs, str(d), max_retries=max_retries,
                            solution_every=solution_every)
        finally:
            ray.shutdown()
        rates[w] = len(rep.completed) / rep.seconds
        reports[w] = rep
        print(f"{w} worker(s): {len(rep.completed)} completed, {len(rep.failures)} failed "
              f"in {rep.seconds:.1f} s: {rates[w]:.3f} drives/s", flush=True)
        for f in rep.failures:
            print(f"  failed after {f['attempts']} attempts: {f['log']}: {f['error']}", flush=True)
    first, last = workers[0], workers[-1]
    scaling = rates[last] / rates[first]
    print(f"scaling {last} vs {first} worker(s): {scaling:.2f}x", flush=True)
    return {"rates": rates, "scaling": scaling, "reports": reports}


def _warm() -> int:
    import navfuse  # noqa: F401

    return os.getpid()


def main(argv: Optional[Sequence[str]] = None) -> int:
    p = argparse.ArgumentParser(prog="python -m navfuse.fleet")
    sub = p.add_subparsers(dest="cmd", required=True)
    b = sub.add_parser("bench", help="simulated drives on a local Ray cluster, 1 and 2 workers")
    b.add_argument("--drives", type=int, default=200, help="logs per run (one is corrupt)")
    b.add_argument("--minutes", type=float, default=10.0, help="length of each drive")
    b.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    b.add_argument("--out", default=None, help="output folder (default: a temporary one)")
    b.add_argument("--solution-every", type=int, default=100,
                   help="keep every n-th solution in the Parquet files (100: 1 Hz)")
    a = p.parse_args(argv)
    out = a.out or tempfile.mkdtemp(prefix="navfuse-fleet-")
    print(f"output: {out}", flush=True)
    bench(a.drives, a.minutes, a.workers, out, solution_every=a.solution_every)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
