"""Type stubs of the compiled extension ``navfuse._navfuse`` (crates/py).

Tables cross as row-major little-endian float64 ``bytes`` whose columns are
the ``*_COLUMNS`` lists; the public wrappers in ``navfuse`` turn them into
numpy arrays and pandas DataFrames. Every function raises ``NavfuseError``.
"""

from typing import Optional

class NavfuseError(Exception):
    """Bad input (naming file, line and field), configuration, alignment or
    estimator failure: the text the ``navfuse`` CLI prints."""

SOLUTION_COLUMNS: list[str]
IMU_COLUMNS: list[str]
GNSS_COLUMNS: list[str]
EVAL_COLUMNS: list[str]

class Eskf:
    def __init__(self, yaml: str, enhanced: bool = False) -> None: ...
    def push_imu(self, t: float, dtheta_b: list[float], dvel_b: list[float],
                 dt: Optional[float] = None) -> Optional[list[float]]: ...
    def push_gnss(self, t: float, lat_deg: float, lon_deg: float, h_m: float,
                  std_ned_m: list[float], v_n_mps: Optional[list[float]] = None,
                  std_v_n_mps: Optional[list[float]] = None) -> None: ...
    def _process(self, imu: bytes, imu_cols: int, gnss: bytes, gnss_cols: int) -> bytes: ...
    def _stats(self) -> str: ...

def kf_gins(yaml: str, enhanced: bool = False, smooth: bool = False,
            output: Optional[str] = None, platform: Optional[str] = None,
            time_offset: Optional[str] = None) -> dict: ...
def run_file(path: str, output: Optional[str] = None,
             estimator: Optional[str] = None) -> dict: ...
def run_json(json: str, base_dir: str, output: Optional[str] = None,
             estimator: Optional[str] = None, imu: Optional[tuple[bytes, int]] = None,
             gnss: Optional[tuple[bytes, int]] = None) -> dict: ...
def evaluate(solution: bytes, truth: bytes,
             outages: Optional[list[tuple[float, float]]] = None) -> tuple[str, bytes]: ...
def simulate(scenario: str, seed: int, duration_s: float = 600.0,
             imu_grade: Optional[str] = None, gnss_grade: Optional[str] = None,
             static_start: bool = True, imu_time_offset_s: float = 0.0) -> dict: ...
