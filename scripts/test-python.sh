#!/usr/bin/env bash
# The Python package and the Blender extension (scripts/test.sh runs this last):
# 1. a venv under target/ on CPython 3.11 with maturin, ziglang, pytest, numpy and bpy 5.0.1
#    (real Blender as a headless Python module);
# 2. the rigfit wheel (abi3, manylinux_2_28) built by maturin with zig, installed in the venv;
# 3. pytest on the package (python/tests);
# 4. the extension zip with the wheel, validated and built by Blender's own extension tool
#    (scripts/build-blender-extension.sh);
# 5. the Blender tests (python/blender_tests) under a timeout: Blender's validator on the
#    manifest and the zip; the zip installed into a temporary user resource folder, a scene
#    built, strokes fed, operators run.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
venv=$root/target/py-venv
requirements="maturin>=1.9,<2 ziglang pytest numpy bpy==5.0.1 distributed==2026.8.0"

# bpy 5.0.1 is built for CPython 3.11 only.
python=""
for candidate in python3.11 python3; do
  if command -v "$candidate" >/dev/null \
    && "$candidate" -c 'import sys, venv; sys.exit(sys.version_info[:2] != (3, 11))' 2>/dev/null; then
    python=$(command -v "$candidate")
    break
  fi
done
if [ -z "$python" ] && command -v apt-get >/dev/null; then
  echo "== installing python3.11 (apt)"
  apt-get update -qq && apt-get install -y -qq python3.11 python3.11-venv >/dev/null
  python=$(command -v python3.11 || true)
fi
[ -n "$python" ] || { echo "test-python: CPython 3.11 is needed (bpy 5.0.1 is built for it)" >&2; exit 2; }

if [ ! -x "$venv/bin/python" ] || [ "$(cat "$venv/.requirements" 2>/dev/null)" != "$requirements" ]; then
  echo "== python venv: $venv ($("$python" --version))"
  rm -rf "$venv"
  "$python" -m venv "$venv"
  # shellcheck disable=SC2086
  "$venv/bin/pip" install -q --disable-pip-version-check $requirements
  echo "$requirements" > "$venv/.requirements"
fi
export PATH="$venv/bin:$PATH"

# bpy links X11 and GL client libraries even headless; a fresh Debian machine lacks them.
bpy_so=$(echo "$venv"/lib/python3.11/site-packages/bpy/__init__.so)
if ldd "$bpy_so" | grep -q "not found" && command -v apt-get >/dev/null; then
  echo "== installing the libraries bpy links (apt)"
  apt-get update -qq && apt-get install -y -qq libx11-6 libxrender1 libxfixes3 libxi6 libxkbcommon0 \
    libxext6 libxxf86vm1 libsm6 libice6 libgl1 libegl1 >/dev/null
fi
if ldd "$bpy_so" | grep "not found"; then
  echo "test-python: bpy needs the libraries above" >&2
  exit 2
fi

echo "== wheel (maturin, manylinux_2_28): the README's install command"
scripts/install-python.sh cluster
wheel=$(ls target/wheels/rigfit-*-cp311-abi3-manylinux_2_28_x86_64.whl)

echo "== pytest (the rigfit package)"
(cd python && RIGFIT_WHEEL="$root/$wheel" timeout 900 python -m pytest -q tests)

echo "== Blender extension zip"
scripts/build-blender-extension.sh "$wheel" target/rigfit_blender.zip

echo "== Blender tests (bpy $(python -c 'import importlib.metadata as m; print(m.version("bpy"))'), headless)"
(cd python && RIGFIT_EXTENSION_ZIP="$root/target/rigfit_blender.zip" timeout 600 python -m pytest -q -p no:cacheprovider blender_tests)
