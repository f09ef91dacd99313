#!/usr/bin/env bash
# Surface tracking against the PyPI tools a user would otherwise pick (rustcpd, cycpd,
# trimesh's nricp_amberg), on the same generated scans, scored the same way (per-vertex
# error against the true skinned vertices, % of the bounding-box diagonal). Installs the
# peers in a venv under target/; prints a markdown table (BENCHMARKS.md, issue 5).
#
#   scripts/bench-surface-peers.sh [FRAMES [PEER...]]   (default 12 frames: 0-11, two hole
#   frames included; PEER picks among rustcpd, cycpd, nricp, pycpd, all by default)
#   PARTS="dmc-quadruped dmc-humanoid" runs those objects of the many-part surface corpus
#   (data/surface_corpus.json, issue 22) instead of the two skinned characters.
#
# Every tool runs on one thread (../shared/peers.md): rigfit, rustcpd (rayon) and the numpy
# ones (BLAS) alike. THREADS=2 gives every tool both cores instead. RUNS=N runs every tool N
# times, taking turns, and shows the median time with each run's (default 1).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
frames=${1:-12}
shift || true
peers=("$@")
threads=${THREADS:-1}
export RAYON_NUM_THREADS=$threads OMP_NUM_THREADS=$threads OPENBLAS_NUM_THREADS=$threads \
  MKL_NUM_THREADS=$threads
data=${RIGFIT_DATA:-$root/../shared/data}
cargo=${CARGO:-/work/bin/cargo-slot}
[ -x "$cargo" ] || cargo=cargo
venv=$root/target/surface-peers-venv
work=$root/target/surface-peers

if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
"$venv/bin/pip" install -q numpy scipy trimesh==5.2.0 rustcpd==4.0.0 cycpd==0.28 pycpd==2.0.0

"$cargo" build -q --release -p rigfit-cli --bin rigfit
"$cargo" build -q --release -p rigfit-testkit --example surface_sequence
rigfit=$root/target/release/rigfit
sequence=$root/target/release/examples/surface_sequence

echo "| asset (clip) | method | mean error (% diag) | p95 (% diag) | ms/frame |"
echo "|---|---|---|---|---|"
specs=("assimp/BCN_Epileptic.glb jump bcn 10000" "assimp/Testwuson.glb run wuson 10000")
if [ -n "${PARTS:-}" ]; then
  # Many-part objects of the surface corpus (issue 22): their fast motion, 8,000 points.
  specs=()
  for id in $PARTS; do specs+=("corpus:$id - $id 8000"); done
fi
for spec in "${specs[@]}"; do
  set -- $spec
  dir=$work/$3
  rm -rf "$dir" && mkdir -p "$dir"
  case $1 in corpus:*) asset=$1 ;; *) asset=$data/$1 ;; esac
  "$sequence" "$asset" "$2" "$dir/seq" 30 "$4" > /dev/null
  scans=$(for f in $(seq 0 $((frames - 1))); do printf '%s/seq/scan_%04d.ply ' "$dir" "$f"; done)
  run_rigfit="\"$rigfit\" surface \"$dir/seq/reference.ply\" $scans -o \"$dir/rigfit\" --report \"$dir/rigfit.json\""
  eval "$run_rigfit" > /dev/null
  RIGFIT_RERUN=$run_rigfit "$venv/bin/python" scripts/surface_peers.py "$dir/seq" "$dir/rigfit" "$dir/rigfit.json" "$frames" ${peers[@]+"${peers[@]}"}
done
