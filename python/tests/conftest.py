"""Shared fixtures: the real data (NAVFUSE_DATA, default ../shared/data
relative to the repository) and the CLI binary (NAVFUSE_BIN, default
target/release/navfuse). Missing either fails the test loudly: never a skip."""

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def data_dir() -> Path:
    d = Path(os.environ.get("NAVFUSE_DATA", REPO.parent / "shared" / "data"))
    if not (d / "drive_0708" / "kfgins" / "kf-gins_outage.yaml").is_file():
        pytest.fail(f"real data missing: {d}/drive_0708/kfgins/kf-gins_outage.yaml "
                    "(set NAVFUSE_DATA to the shared data folder)")
    return d


@pytest.fixture(scope="session")
def cli() -> Path:
    b = Path(os.environ.get("NAVFUSE_BIN", REPO / "target" / "release" / "navfuse"))
    if not b.is_file():
        pytest.fail(f"navfuse CLI missing: {b} (cargo build --release -p navfuse-cli, "
                    "or set NAVFUSE_BIN)")
    return b
