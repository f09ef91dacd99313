"""The real test assets, shared by both test folders' conftest.py (python/tests and
python/blender_tests): RIGFIT_DATA, or ../shared/data beside the repository."""

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def asset(rel: str) -> Path:
    """Path of a real test asset; fails the test with how to get it when it is missing."""
    root = Path(os.environ.get("RIGFIT_DATA", REPO.parent / "shared" / "data"))
    path = root / rel
    if not path.exists():
        pytest.fail(f"test asset {path} is missing: set RIGFIT_DATA or run scripts/fetch-data.sh")
    return path
