#!/usr/bin/env bash
# Builds the Blender extension zip with Blender's own tool: the rigfit wheel (built by maturin,
# path as $1) goes into blender/rigfit_blender/wheels/, then Blender's extension tool
# (blender_ext.py, what `blender --command extension validate|build` runs) validates the
# add-on's folder, builds the zip to $2 (default target/rigfit_blender.zip; the manifest's
# [build] paths_exclude_pattern decides what goes in) and validates the zip. Any failure exits 2
# with Blender's message. The tool comes from the `bpy` package of the `python` in PATH (the venv
# of scripts/test-python.sh), with the tag list Blender itself checks tags against.
# Install the zip with Edit > Preferences > Get Extensions > Install from Disk.
set -euo pipefail
wheel=$(realpath "${1:?usage: build-blender-extension.sh WHEEL [OUT.zip]}")
out=$(realpath -m "${2:-$(dirname "$0")/../target/rigfit_blender.zip}")
cd "$(dirname "$0")/.."
ext=blender/rigfit_blender
name=$(basename "$wheel")
fail() { echo "build-blender-extension: $*" >&2; exit 2; }

grep -q "\"./wheels/$name\"" "$ext/blender_manifest.toml" \
  || fail "$ext/blender_manifest.toml does not list wheels/$name"

# bpy's folder without importing bpy (slow, and it starts Blender).
bpy_dir=$(python -c 'import importlib.util as u; s = u.find_spec("bpy"); print(s.submodule_search_locations[0] if s else "")') \
  || fail "no python in PATH (run with the venv of scripts/test-python.sh first in PATH)"
[ -n "$bpy_dir" ] || fail "$(command -v python) has no bpy module (the venv of scripts/test-python.sh has it)"
shopt -s nullglob
tools=("$bpy_dir"/*/scripts/addons_core/bl_pkg/cli/blender_ext.py)
tags=("$bpy_dir"/*/scripts/modules/_bpy_internal/extensions/tags.py)
shopt -u nullglob
[ "${#tools[@]}" -eq 1 ] && [ "${#tags[@]}" -eq 1 ] \
  || fail "Blender's extension tool (blender_ext.py, tags.py) not found under $bpy_dir"

# Runs blender_ext.py; prints its output, or exits 2 with it.
blender_ext() {
  local output
  if ! output=$(python "${tools[0]}" "$@" --valid-tags="${tags[0]}" 2>&1); then
    fail "Blender's extension $1 failed:"$'\n'"$output"
  fi
  echo "$output"
}

rm -rf "$ext/wheels" && mkdir -p "$ext/wheels" && cp "$wheel" "$ext/wheels/"
mkdir -p "$(dirname "$out")"
blender_ext validate "$ext"
blender_ext build --source-dir "$ext" --output-filepath "$out"
blender_ext validate "$out"
