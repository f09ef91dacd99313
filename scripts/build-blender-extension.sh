#!/usr/bin/env bash
# Builds the Blender extension zip: the rigfit wheel (built by maturin, path as $1) goes into
# blender/rigfit_blender/wheels/, then the add-on is zipped to $2 (default
# target/rigfit_blender.zip). Install it with Edit > Preferences > Get Extensions > Install
# from Disk.
set -euo pipefail
wheel=$(realpath "${1:?usage: build-blender-extension.sh WHEEL [OUT.zip]}")
out=$(realpath -m "${2:-$(dirname "$0")/../target/rigfit_blender.zip}")
cd "$(dirname "$0")/.."
ext=blender/rigfit_blender
name=$(basename "$wheel")
grep -q "\"./wheels/$name\"" "$ext/blender_manifest.toml" \
  || { echo "build-blender-extension: $ext/blender_manifest.toml does not list wheels/$name" >&2; exit 2; }
rm -rf "$ext/wheels" && mkdir -p "$ext/wheels" && cp "$wheel" "$ext/wheels/"
mkdir -p "$(dirname "$out")"
python3 - "$ext" "$out" <<'PY'
import pathlib, sys, zipfile
src, out = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
    for p in sorted(src.rglob("*")):
        if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".zip" and not p.name.startswith("."):
            z.write(p, p.relative_to(src).as_posix())
print(f"wrote {out}")
PY
