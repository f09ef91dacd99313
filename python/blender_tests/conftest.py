"""Blender tests: real Blender (the `bpy` module, headless). The extension zip is installed
into a temporary user resource folder, as a user would install it from disk; the rigfit
package imported is the wheel the extension bundles. The add-on is disabled (its classes
unregistered) before the process exits, or bpy hangs."""

import glob
import importlib
import os
import shutil
import sys
import tempfile
from pathlib import Path

USER = tempfile.mkdtemp(prefix="rigfit-blender-user-")
os.environ["BLENDER_USER_RESOURCES"] = USER

import bpy  # noqa: E402  (after BLENDER_USER_RESOURCES)
import pytest  # noqa: E402

# The helpers both test folders share sit in python/, above this one.
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from shared_assets import REPO, asset  # noqa: E402

__all__ = ["asset"]
MODULE = "bl_ext.user_default.rigfit_blender"


@pytest.fixture(scope="session")
def addon():
    """Installs and enables the extension zip; yields the add-on module."""
    zip_path = Path(os.environ.get("RIGFIT_EXTENSION_ZIP", REPO / "target" / "rigfit_blender.zip"))
    assert zip_path.exists(), f"{zip_path}: build it with scripts/build-blender-extension.sh"
    # A clean start with an undo stack, as Blender has when it opens.
    bpy.ops.wm.read_factory_settings(use_empty=True)
    result = bpy.ops.extensions.package_install_files(
        filepath=str(zip_path), repo="user_default", enable_on_install=True
    )
    assert result == {"FINISHED"}
    # The wheel the extension installed, ahead of any rigfit in the test's own environment.
    site = glob.glob(os.path.join(USER, "extensions", ".local", "lib", "python3*", "site-packages"))
    assert site, "the extension's wheel was not installed"
    sys.path.insert(0, site[0])
    sys.modules.pop("rigfit", None)
    import rigfit

    assert rigfit.__file__.startswith(USER), rigfit.__file__
    module = importlib.import_module(MODULE)
    yield module
    bpy.ops.preferences.addon_disable(module=MODULE)


def pytest_sessionfinish(session, exitstatus):
    import addon_utils

    if any(m.__name__ == MODULE for m in addon_utils.modules()) and MODULE in bpy.context.preferences.addons:
        bpy.ops.preferences.addon_disable(module=MODULE)
    shutil.rmtree(USER, ignore_errors=True)
