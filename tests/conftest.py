"""Shared pytest fixtures.

Golden data from other implementations (PASS selftests, measured characteristics, a gr-rfid
waveform) is read from ``../shared/reference-data`` relative to the project root, or from the
folder named by ``RFSIM_REFERENCE_DATA``. Tests that need it skip cleanly when it is absent.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

PROJECT_ROOT = Path(__file__).resolve().parents[1]


def _reference_data_dir() -> Path:
    env = os.environ.get("RFSIM_REFERENCE_DATA")
    if env:
        return Path(env)
    return PROJECT_ROOT.parent / "shared" / "reference-data"


@pytest.fixture(scope="session")
def reference_data() -> Path:
    """Folder of external golden data; skips the test when it is not there."""
    path = _reference_data_dir()
    if not path.is_dir():
        pytest.skip(f"reference data not found at {path} (set RFSIM_REFERENCE_DATA)")
    return path


@pytest.fixture(scope="session")
def project_root() -> Path:
    return PROJECT_ROOT
