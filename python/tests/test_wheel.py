"""The wheel as a user installs it: into a fresh virtual environment (its numpy from the
package index), imported there, its stubs and its cluster module in place, a take run."""

import os
import subprocess
import sys
import venv
from pathlib import Path

import pytest

WHEEL = os.environ.get("RIGFIT_WHEEL")


@pytest.mark.skipif(not WHEEL, reason="RIGFIT_WHEEL names the wheel to install (scripts/test-python.sh sets it)")
def test_the_wheel_installs_into_a_fresh_venv_and_works_there(tmp_path):
    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=True)
    python = env_dir / "bin" / "python"
    install = subprocess.run(
        [python, "-m", "pip", "install", "-q", "--disable-pip-version-check", WHEEL],
        capture_output=True, text=True, timeout=600,
    )
    assert install.returncode == 0, install.stderr
    script = """
import json, pathlib, sys, tempfile
import numpy as np
import rigfit
assert rigfit.__file__.startswith(sys.prefix), rigfit.__file__
package = pathlib.Path(rigfit.__file__).parent
assert (package / "__init__.pyi").exists() and (package / "py.typed").exists()
assert (package / "cluster.py").exists()
skeleton = rigfit.Skeleton(["root", "tip"], [None, 0], [[0, 0, 0], [0, 1, 0]], [[0, 0, 0, 1]] * 2)
strokes, _ = rigfit.draw_strokes(skeleton, noise=0.0, min_chain_length=0.0)
result = rigfit.solve_pose(skeleton, [[[0, 0, 0], [1, 0, 0]]])
assert np.allclose(result.positions[1], [1, 0, 0], atol=1e-3), result.positions
try:
    rigfit.run_take({"command": "pose", "rig": "missing.glb", "strokes": "s.json"})
except rigfit.RigfitError as e:
    assert "missing.glb" in str(e), e
else:
    raise AssertionError("a missing rig is an error")
print("ok", rigfit.__version__)
"""
    run = subprocess.run([python, "-c", script], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith("ok "), run.stdout
    # Not the test environment's own rigfit.
    assert sys.prefix != str(env_dir)
