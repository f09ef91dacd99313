"""Shared helpers: the real test assets (RIGFIT_DATA, or ../shared/data beside the repository)."""

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def asset(rel: str) -> Path:
    root = Path(os.environ.get("RIGFIT_DATA", REPO.parent / "shared" / "data"))
    path = root / rel
    if not path.exists():
        pytest.fail(f"test asset {path} is missing: set RIGFIT_DATA or run scripts/fetch-data.sh")
    return path
