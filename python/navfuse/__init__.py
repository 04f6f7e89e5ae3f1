"""navfuse: GNSS/INS navigation from Python.

The Rust pipeline of the ``navfuse`` CLI as a library: ``run`` (a run
configuration, TOML path or dict), ``kf_gins`` (a KF-GINS YAML), the
streaming ``Eskf``, the simulator ``simulate`` and the evaluator
``evaluate``. Results are pandas DataFrames whose column names carry the unit
(``t_s``, ``lat_deg``, ``v_n_mps``, ``roll_deg``...); summaries are dicts.
Frames: body FRD, navigation NED; GPS time (or time of week) in seconds.
The GIL is released while Rust runs. Every error is a ``NavfuseError``
whose text is what the CLI prints (``file:line: field ...``).

    import navfuse
    r = navfuse.kf_gins("kf-gins.yaml", output="out")
    r.solution[["t_s", "lat_deg", "lon_deg", "h_m"]]
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Optional, Sequence, Union

import numpy as np
import pandas as pd

from . import _navfuse
from ._tables import (EVAL_COLUMNS, GNSS_COLUMNS, IMU_COLUMNS, SOLUTION_COLUMNS, frame,
                      gnss_table, imu_table, solution_table)

NavfuseError = _navfuse.NavfuseError

__all__ = [
    "NavfuseError", "Result", "Simulation", "Evaluation", "Eskf", "run", "kf_gins",
    "simulate", "evaluate", "SOLUTION_COLUMNS", "IMU_COLUMNS", "GNSS_COLUMNS", "EVAL_COLUMNS",
]

PathLike = Union[str, "os.PathLike[str]"]


@dataclass
class Result:
    """What a run produced.

    ``solution``: forward solutions (IMU point), columns ``SOLUTION_COLUMNS``;
    ``smoothed``: RTS-smoothed solutions (empty unless smoothing was asked);
    ``summary``: the run's summary (``summary.json`` for file runs) as a dict;
    ``output_dir``: the folder written (None for in-memory runs);
    ``outputs``: the files written there.
    """

    solution: pd.DataFrame
    smoothed: pd.DataFrame
    summary: dict
    output_dir: Optional[Path] = None
    outputs: list = field(default_factory=list)


def _result(d: Mapping[str, Any], summary: dict) -> Result:
    out = d.get("output_dir")
    return Result(
        solution=frame(d["solution"], SOLUTION_COLUMNS),
        smoothed=frame(d["smoothed"], SOLUTION_COLUMNS),
        summary=summary,
        output_dir=Path(out) if out is not None else None,
        outputs=list(d.get("outputs", [])),
    )


def run(config: Union[PathLike, Mapping[str, Any]], output: Optional[PathLike] = None, *,
        imu: Any = None, gnss: Any = None, base_dir: Optional[PathLike] = None,
        estimator: Optional[str] = None) -> Result:
    """Do what ``navfuse run CONFIG`` does and return the solutions.

    ``config``: a TOML file path, or a dict with the same schema (``[input]``,
    ``[init]``, ``[filter]``, ``[outage]``, ``output``, ``formats``; see
    docs/config.md), whose paths are relative to ``base_dir`` (default: the
    current folder). ``output``: the output folder (default: the config's
    ``output``, else ``./navfuse-out``). ``estimator``: ``eskf``, ``pf-lc``
    or ``gps-acc`` overriding ``[filter] estimator``.

    With ``imu`` and ``gnss`` (DataFrames with ``IMU_COLUMNS`` /
    ``GNSS_COLUMNS`` names, or arrays in that column order) and a dict
    config, the ESKF runs in memory on them (``[input] imu``/``gnss`` then
    only name the data in messages) and nothing is written.
    """
    out = os.fspath(output) if output is not None else None
    if isinstance(config, Mapping):
        base = os.fspath(base_dir) if base_dir is not None else os.getcwd()
        if (imu is None) != (gnss is None):
            raise NavfuseError("run: give both imu and gnss, or neither")
        if imu is not None and out is not None:
            raise NavfuseError("run: an in-memory run (imu/gnss arrays) writes no output folder")
        d = _navfuse.run_json(json.dumps(dict(config)), base, out, estimator,
                              imu_table(imu) if imu is not None else None,
                              gnss_table(gnss) if gnss is not None else None)
    else:
        if imu is not None or gnss is not None:
            raise NavfuseError("run: imu/gnss arrays need a dict config")
        d = _navfuse.run_file(os.fspath(config), out, estimator)
    return _result(d, json.loads(d["summary"]))


def kf_gins(yaml: PathLike, enhanced: bool = False, smooth: bool = False,
            output: Optional[PathLike] = None, *, platform: Optional[str] = None,
            time_offset: Optional[str] = None) -> Result:
    """Do what ``navfuse kf-gins YAML`` does: run an unmodified KF-GINS
    configuration, write KF-GINS's files (``KF_GINS_Navresult.nav``,
    ``KF_GINS_IMU_ERR.txt``, ``KF_GINS_STD.txt``; with ``smooth`` also
    ``KF_GINS_Navresult_smoothed.nav``) into ``output`` (default: the YAML's
    ``outputpath``, as the CLI) and return the solutions (from the second IMU
    sample on, as written). ``enhanced``: the car profile (NHC, ZUPT/ZARU, χ²
    gating); ``platform``: another profile; ``time_offset``: seconds,
    ``auto`` or ``none`` added to the IMU stamps.
    ``summary``: ``{"stats": update counters, "time_offset_s": applied or None}``.
    """
    out = os.fspath(output) if output is not None else None
    d = _navfuse.kf_gins(os.fspath(yaml), enhanced, smooth, out, platform, time_offset)
    return _result(d, {"stats": json.loads(d["stats"]), "time_offset_s": d["time_offset_s"]})


class Eskf:
    """Streaming ESKF (21 states: position, velocity, attitude, gyro/accel
    bias and scale factor; the KF-GINS model of navfuse-core), configured
    from a KF-GINS YAML: model, noise, initial state and σ, start/end time.
    ``enhanced`` adds the car profile as ``navfuse kf-gins --enhanced``.

    ``push_imu``/``push_gnss`` feed one measurement each (in time order);
    ``process`` runs whole arrays with the GIL released, in KF-GINS's order.
    """

    def __init__(self, yaml: PathLike, enhanced: bool = False) -> None:
        self._inner = _navfuse.Eskf(os.fspath(yaml), enhanced)

    def push_imu(self, t: float, dtheta_b: Sequence[float], dvel_b: Sequence[float],
                 dt: Optional[float] = None) -> Optional[pd.Series]:
        """One IMU sample: stamp ``t`` [s], angle increment ``dtheta_b``
        [rad], velocity increment ``dvel_b`` [m/s] over ``(t - dt, t]``, body
        FRD (``dt`` default: since the last sample; the first 1/rate).
        Returns the solution (a Series indexed by ``SOLUTION_COLUMNS``) or None."""
        row = self._inner.push_imu(float(t), [float(v) for v in dtheta_b],
                                   [float(v) for v in dvel_b], dt)
        return None if row is None else pd.Series(row, index=SOLUTION_COLUMNS)

    def push_gnss(self, t: float, lat_deg: float, lon_deg: float, h_m: float,
                  std_ned_m: Sequence[float], v_n_mps: Optional[Sequence[float]] = None,
                  std_v_n_mps: Optional[Sequence[float]] = None) -> None:
        """One GNSS fix at the antenna: time [s], latitude/longitude [deg],
        ellipsoidal height [m], 1-σ north/east/down [m]; optional NED velocity
        [m/s] and its 1-σ."""
        self._inner.push_gnss(float(t), float(lat_deg), float(lon_deg), float(h_m),
                              [float(v) for v in std_ned_m],
                              None if v_n_mps is None else [float(v) for v in v_n_mps],
                              None if std_v_n_mps is None else [float(v) for v in std_v_n_mps])

    def process(self, imu: Any, gnss: Any) -> pd.DataFrame:
        """Run whole recordings: ``imu`` rows ``t_s, dtheta_{x,y,z}_rad,
        dvel_{x,y,z}_mps[, dt_s]`` (without ``dt_s``: the difference of
        consecutive stamps, the first 1/rate, as navfuse's readers form it),
        ``gnss`` rows ``t_s, lat_deg, lon_deg, h_m, std_{n,e,d}_m`` (+ NED
        velocity and σ), as DataFrames or arrays. IMU from the first sample at
        or after the start time to the end time; each fix after the start is
        applied before the first IMU sample within 1 ms after it (the order
        of ``navfuse kf-gins``). Returns the solutions (``SOLUTION_COLUMNS``)."""
        i, ni = imu_table(imu)
        g, ng = gnss_table(gnss)
        return frame(self._inner._process(i, ni, g, ng), SOLUTION_COLUMNS)

    @property
    def stats(self) -> dict:
        """Update counters (GNSS used/gated, NHC, ZUPT, ...)."""
        return json.loads(self._inner._stats())


@dataclass
class Simulation:
    """A simulated run: ``imu`` (``IMU_COLUMNS``, stamps = true time − τ),
    ``gnss`` (``GNSS_COLUMNS``, antenna, outages removed), ``truth``
    (``SOLUTION_COLUMNS`` at the IMU epochs, σ columns 0), ``outages``
    (``[start, end)`` GPS s), ``description``, ``imu_rate_hz``,
    ``imu_time_offset_s`` (τ), ``lever_arm_m`` (GNSS antenna, body FRD
    [m]), ``imu_preset`` (the simulated IMU model)."""

    imu: pd.DataFrame
    gnss: pd.DataFrame
    truth: pd.DataFrame
    outages: list
    description: str
    imu_rate_hz: float
    imu_time_offset_s: float
    lever_arm_m: tuple = (0.0, 0.0, 0.0)
    imu_preset: str = ""


def simulate(scenario: Union[str, PathLike], seed: int, *, duration_s: float = 600.0,
             imu_grade: Optional[str] = None, gnss_grade: Optional[str] = None,
             static_start: bool = True, imu_time_offset_s: float = 0.0) -> Simulation:
    """Simulate ``scenario`` with ``seed`` (deterministic): a platform name
    (``car``, ``robot``, ``pedestrian``, ``uav``: a random, physically
    plausible trajectory drawn from the seed, 30 s GNSS outages every 120 s
    from 120 s) or a scenario TOML path. Platform options: ``duration_s``,
    ``imu_grade`` (``consumer``, ``industrial``, ``tactical``),
    ``gnss_grade`` (``rtk``, ``consumer``), ``static_start``,
    ``imu_time_offset_s`` (τ: IMU stamped τ early)."""
    d = _navfuse.simulate(os.fspath(scenario), int(seed), float(duration_s), imu_grade,
                          gnss_grade, static_start, float(imu_time_offset_s))
    return Simulation(
        imu=frame(d["imu"], IMU_COLUMNS),
        gnss=frame(d["gnss"], GNSS_COLUMNS),
        truth=frame(d["truth"], SOLUTION_COLUMNS),
        outages=[tuple(w) for w in d["outages"]],
        description=d["description"],
        imu_rate_hz=d["imu_rate_hz"],
        imu_time_offset_s=d["imu_time_offset_s"],
        lever_arm_m=tuple(d["lever_arm_m"]),
        imu_preset=d["imu_preset"],
    )


@dataclass
class Evaluation:
    """``errors``: solution − reference per epoch (``EVAL_COLUMNS``: NED
    position [m] at the reference point, horizontal, |down|, NED velocity
    [m/s], roll/pitch/yaw [deg]); ``summary``: counts, statistics per
    quantity and (with outages) the per-outage maximum horizontal error."""

    errors: pd.DataFrame
    summary: dict


def evaluate(solution: Any, truth: Any,
             outages: Optional[Sequence[Sequence[float]]] = None) -> Evaluation:
    """Errors of ``solution`` against ``truth`` at the solution epochs (truth
    interpolated linearly in time; epochs outside it or in gaps > 1 s
    excluded and counted). Both: DataFrames with ``SOLUTION_COLUMNS`` names
    (at least ``t_s, lat_deg, lon_deg, h_m``), arrays in that order, or a
    ``Result`` (its ``solution``) / ``Simulation`` (its ``truth``).
    ``outages``: ``[start, end)`` windows [s] for the outage metric."""
    def table(x: Any, name: str) -> bytes:
        if isinstance(x, Result):
            x = x.solution
        elif isinstance(x, Simulation):
            x = x.truth
        return solution_table(x, name)

    wins = None if outages is None else [(float(a), float(b)) for a, b in outages]
    s, e = _navfuse.evaluate(table(solution, "solution"), table(truth, "truth"), wins)
    return Evaluation(errors=frame(e, EVAL_COLUMNS), summary=json.loads(s))
