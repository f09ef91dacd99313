"""Shared helpers: the real test assets (python/shared_assets.py) and temporaries left."""

import sys
from pathlib import Path

# The helpers both test folders share sit in python/, above this one.
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from shared_assets import REPO, asset  # noqa: E402

__all__ = ["REPO", "asset", "no_temporaries"]


def no_temporaries(folder: Path) -> None:
    """Nothing temporary left anywhere under ``folder``: rigfit's ``.NAME.rigfit-*`` files
    (the Rust writers'), ``.tmp`` files (rigfit.cluster's report), other dot-files."""
    left = [p for p in Path(folder).rglob("*") if p.name.startswith(".") or ".rigfit-" in p.name or p.suffix == ".tmp"]
    assert not left, left
