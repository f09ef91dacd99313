"""The extension as Blender itself checks it: Blender's extension tool (bpy's blender_ext.py,
what `blender --command extension validate` runs, with Blender's tag list) on the add-on's
folder and on the zip scripts/build-blender-extension.sh built with it. Run as a subprocess:
the tool is a plain script, and this process's bpy stays as conftest set it up."""

import importlib.util
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SOURCE = REPO / "blender" / "rigfit_blender"


def blender_tool(rel: str) -> Path:
    bpy_dir = Path(importlib.util.find_spec("bpy").submodule_search_locations[0])
    found = sorted(bpy_dir.glob(f"*/scripts/{rel}"))
    assert len(found) == 1, f"{rel} under {bpy_dir}: {found}"
    return found[0]


def blender_ext(*args: str) -> subprocess.CompletedProcess:
    tool = blender_tool("addons_core/bl_pkg/cli/blender_ext.py")
    tags = blender_tool("modules/_bpy_internal/extensions/tags.py")
    return subprocess.run(
        [sys.executable, str(tool), *args, f"--valid-tags={tags}"],
        capture_output=True, text=True, timeout=120,
    )


def extension_zip() -> Path:
    path = Path(os.environ.get("RIGFIT_EXTENSION_ZIP", REPO / "target" / "rigfit_blender.zip"))
    assert path.exists(), f"{path}: build it with scripts/build-blender-extension.sh"
    return path


def with_tagline(tmp_path: Path, tagline: str) -> Path:
    """A copy of the add-on's folder whose manifest has this tagline."""
    copy = tmp_path / "rigfit_blender"
    shutil.copytree(SOURCE, copy, ignore=shutil.ignore_patterns("wheels", "__pycache__"))
    manifest = copy / "blender_manifest.toml"
    text, n = re.subn(r'(?m)^tagline = ".*"$', f'tagline = "{tagline}"', manifest.read_text())
    assert n == 1
    manifest.write_text(text)
    return copy


def test_the_source_folder_passes_blenders_validator():
    result = blender_ext("validate", str(SOURCE))
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_built_zip_passes_blenders_validator():
    result = blender_ext("validate", str(extension_zip()))
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_zip_holds_the_addon_and_the_wheel_and_nothing_else():
    with zipfile.ZipFile(extension_zip()) as z:
        names = set(z.namelist())
    wheels = {n for n in names if n.startswith("wheels/")}
    assert wheels == {"wheels/rigfit-0.1.0-cp311-abi3-manylinux_2_28_x86_64.whl"}
    assert names - wheels == {p.name for p in SOURCE.glob("*") if p.is_file() and not p.name.startswith(".")}


@pytest.mark.parametrize(
    "tagline, error",
    [
        ("a" * 64, None),
        ("a" * 65, "a value no longer than 64 characters expected, found 65"),
        ("Pose armatures from strokes.", "must not end with punctuation"),
    ],
    ids=["64 characters", "65 characters", "trailing punctuation"],
)
def test_blenders_validator_checks_the_tagline(tmp_path, tagline, error):
    result = blender_ext("validate", str(with_tagline(tmp_path, tagline)))
    output = result.stdout + result.stderr
    if error is None:
        assert result.returncode == 0, output
    else:
        assert result.returncode != 0, output
        assert 'key "tagline" invalid' in output and error in output, output
