"""Tables between numpy/pandas and the Rust extension: row-major float64
bytes with named, unit-suffixed columns (``lat_deg``, ``v_n_mps``, ...)."""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
import pandas as pd

from . import _navfuse

SOLUTION_COLUMNS: list[str] = list(_navfuse.SOLUTION_COLUMNS)
IMU_COLUMNS: list[str] = list(_navfuse.IMU_COLUMNS)
GNSS_COLUMNS: list[str] = list(_navfuse.GNSS_COLUMNS)
EVAL_COLUMNS: list[str] = list(_navfuse.EVAL_COLUMNS)


def frame(data: bytes | bytearray, columns: Sequence[str]) -> pd.DataFrame:
    """A DataFrame from row-major float64 ``data`` with ``columns``. A
    ``bytearray`` (fresh from the extension, referenced nowhere else) is
    wrapped without a copy; immutable ``bytes`` are copied so the frame is
    writable."""
    arr = np.frombuffer(data, dtype="<f8").reshape(-1, len(columns))
    return pd.DataFrame(arr, columns=list(columns), copy=not isinstance(data, bytearray))


def _matrix(x: Any, columns: Sequence[str], required: int, optional_groups: Sequence[int],
            name: str, fill: bool = False) -> tuple[bytes, int]:
    """(bytes, ncols) of ``x``: a DataFrame (columns by name: the first
    ``required`` of ``columns``, then each optional group if all of it is
    present; ``fill`` puts NaN for missing optional columns instead) or a 2-D
    array whose columns are in ``columns`` order."""
    if isinstance(x, pd.DataFrame):
        missing = [c for c in columns[:required] if c not in x.columns]
        if missing:
            raise _navfuse.NavfuseError(f"{name}: missing column(s) {', '.join(missing)}")
        use = list(columns[:required])
        k = required
        for g in optional_groups:
            grp = list(columns[k:k + g])
            if all(c in x.columns for c in grp):
                use += grp
            elif fill:
                use += grp
            else:
                break
            k += g
        cols = [x[c].to_numpy(dtype=np.float64) if c in x.columns
                else np.full(len(x), np.nan) for c in use]
        arr = np.column_stack(cols) if cols else np.empty((0, 0))
    else:
        arr = np.asarray(x, dtype=np.float64)
        if arr.ndim != 2:
            raise _navfuse.NavfuseError(f"{name}: expected a 2-D array, got {arr.ndim}-D")
        if fill and arr.shape[1] < len(columns):
            pad = np.full((arr.shape[0], len(columns) - arr.shape[1]), np.nan)
            arr = np.hstack([arr, pad])
    arr = np.ascontiguousarray(arr, dtype="<f8")
    return arr.tobytes(), arr.shape[1]


def imu_table(x: Any) -> tuple[bytes, int]:
    """IMU rows ``t_s, dtheta_{x,y,z}_rad, dvel_{x,y,z}_mps[, dt_s]``."""
    return _matrix(x, IMU_COLUMNS, 7, [1], "imu")


def gnss_table(x: Any) -> tuple[bytes, int]:
    """GNSS rows ``t_s, lat_deg, lon_deg, h_m, std_{n,e,d}_m[, v_*_mps, std_v{n,e,d}_mps]``."""
    return _matrix(x, GNSS_COLUMNS, 7, [6], "gnss")


def solution_table(x: Any, name: str) -> bytes:
    """A 19-column solution table (missing columns NaN)."""
    data, n = _matrix(x, SOLUTION_COLUMNS, 4, [3, 3, 3, 3, 3, 3], name, fill=True)
    if n != len(SOLUTION_COLUMNS):
        raise _navfuse.NavfuseError(f"{name}: expected up to {len(SOLUTION_COLUMNS)} columns, got {n}")
    return data
