#!/usr/bin/env bash
# Do two builds write the same outputs? For refactors that must not change results.
#
#   scripts/compare-builds.sh OLD_REV [NEW_REV]     (NEW_REV: the working tree by default)
#
# Builds `rigfit` at both (release; OLD in a temporary git worktree under target/compare/),
# makes the ground-truth inputs once with NEW's examples (the posing suites' strokes: 50
# cases, every chain drawn and one limb dropped plus a stray; the four tracking sequences of
# the accuracy suites, 60 frames each; BCN_Epileptic and Testwuson scan sequences, 10
# frames), runs one job file of every take through both builds' `rigfit batch` (pose with
# both methods, track, surface), and compares every output: rigs and meshes byte for byte,
# reports without their timings and to 12 significant digits (the surface tracker's rms and
# sigma are parallel sums whose last bits vary run to run). Exit status 0 when all are identical; 1 with the files
# that differ. Both revisions need `rigfit batch`.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
old=${1:?usage: compare-builds.sh OLD_REV [NEW_REV]}
new=${2:-}
work=$root/target/compare
. scripts/test-data.sh
mkdir -p "$work"

# build REV NAME [CARGO BUILD ARGS...]: the folder of a release build of REV's `rigfit` (the
# working tree when REV is empty), plus what the extra arguments name.
build() {
  local rev=$1 name=$2 src target
  shift 2
  if [ -z "$rev" ]; then
    src=$root
    target=$root/target
  else
    src=$work/$name-src
    target=$work/$name-target
    git worktree remove --force "$src" 2>/dev/null || rm -rf "$src"
    git worktree add --detach --force "$src" "$rev" >/dev/null
  fi
  (cd "$src" && CARGO_TARGET_DIR=$target cargo build --release -q -p rigfit-cli --bin rigfit >&2)
  if [ $# -gt 0 ]; then
    (cd "$src" && CARGO_TARGET_DIR=$target cargo build --release -q "$@" >&2)
  fi
  echo "$target/release"
}

echo "== building ${old} and ${new:-the working tree}"
old_bin=$(build "$old" old)
# The inputs' generators are rigfit-testkit's examples, built at NEW only.
new_bin=$(build "$new" new -p rigfit-testkit --example pose_cases --example track_sequence \
  --example surface_sequence)

echo "== inputs (with the new build's examples)"
inputs=$work/inputs
rm -rf "$inputs" && mkdir -p "$inputs"
"$new_bin/examples/pose_cases" "$inputs/pose" > /dev/null
for suite in hand 01_01 BCN_Epileptic Testwuson; do
  "$new_bin/examples/track_sequence" "$suite" "$inputs/track-$suite" > /dev/null
done
"$new_bin/examples/surface_sequence" "$RIGFIT_DATA/assimp/BCN_Epileptic.glb" jump "$inputs/surface-bcn" 10 > /dev/null
"$new_bin/examples/surface_sequence" "$RIGFIT_DATA/assimp/Testwuson.glb" run "$inputs/surface-wuson" 10 > /dev/null

python3 - "$inputs" <<'PY'
import json, pathlib, sys
inputs = pathlib.Path(sys.argv[1])
takes = []
for case in json.loads((inputs / "pose" / "cases.json").read_text())["cases"]:
    ext = "bvh" if case["rig"].endswith(".bvh") else "glb"
    for method in ("rigfit", "paper"):
        take = {"name": f"pose-{case['name']}-{method}", "command": "pose", "rig": case["rig"],
                "strokes": case["strokes"], "method": method,
                "output": f"out/pose/{case['name']}-{method}.{ext}",
                "report": f"out/pose/{case['name']}-{method}.json"}
        if case.get("start_frame"):
            take["start_frame"] = case["start_frame"]
        takes.append(take)
for seq in sorted(inputs.glob("track-*")):
    start = next(seq.glob("start.*"))
    for method in ("rigfit", "paper"):
        takes.append({"name": f"{seq.name}-{method}", "command": "track", "rig": str(start),
                      "frames": str(seq / "frame_*.ply"), "method": method,
                      "output": f"out/track/{seq.name}-{method}.bvh",
                      "report": f"out/track/{seq.name}-{method}.json"})
for seq in sorted(inputs.glob("surface-*")):
    takes.append({"name": seq.name, "command": "surface", "mesh": str(seq / "reference.ply"),
                  "frames": str(seq / "scan_*.ply"), "output": f"out/surface/{seq.name}",
                  "report": f"out/surface/{seq.name}.json"})
(inputs / "jobs.json").write_text(json.dumps({"takes": takes}, indent=1))
print(f"{len(takes)} takes")
PY

for side in old new; do
  bin_dir=${side}_bin
  run=$work/run-$side
  rm -rf "$run" && mkdir -p "$run"
  cp "$inputs/jobs.json" "$run/jobs.json"
  echo "== $side: rigfit batch"
  "${!bin_dir}/rigfit" batch "$run/jobs.json" --report "$run/batch.json" || true
done

echo "== comparing"
python3 - "$work/run-old/out" "$work/run-new/out" <<'PY'
import json, pathlib, sys
old, new = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])

def untimed(v):
    # Numbers to 12 significant digits: the surface tracker's rms and sigma are sums taken
    # in parallel, whose last bits depend on how the threads split the work.
    if isinstance(v, dict):
        return {k: untimed(x) for k, x in v.items() if k != "seconds"}
    if isinstance(v, list):
        return [untimed(x) for x in v]
    if isinstance(v, float):
        return float(f"{v:.12g}")
    return v

def files(d):
    return {str(p.relative_to(d)) for p in d.rglob("*") if p.is_file()}

a, b = files(old), files(new)
differ = sorted(a ^ b)
for name in sorted(a & b):
    x, y = (old / name).read_bytes(), (new / name).read_bytes()
    if name.endswith(".json"):
        same = untimed(json.loads(x)) == untimed(json.loads(y))
    else:
        same = x == y
    if not same:
        differ.append(name)
print(f"{len(a & b)} outputs in both, {len(a ^ b)} in one only, {len(differ)} differ")
for name in differ[:40]:
    print("  differs:", name)
sys.exit(1 if differ else 0)
PY
