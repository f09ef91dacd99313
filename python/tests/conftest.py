"""Shared helpers: the real test assets (RIGFIT_DATA, or ../shared/data beside the repository)."""

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def no_temporaries(folder: Path) -> None:
    """Nothing temporary left anywhere under ``folder``: rigfit's ``.NAME.rigfit-*`` files
    (the Rust writers'), ``.tmp`` files (rigfit.cluster's report), other dot-files."""
    left = [p for p in Path(folder).rglob("*") if p.name.startswith(".") or ".rigfit-" in p.name or p.suffix == ".tmp"]
    assert not left, left


def asset(rel: str) -> Path:
    root = Path(os.environ.get("RIGFIT_DATA", REPO.parent / "shared" / "data"))
    path = root / rel
    if not path.exists():
        pytest.fail(f"test asset {path} is missing: set RIGFIT_DATA or run scripts/fetch-data.sh")
    return path
