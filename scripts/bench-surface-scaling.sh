#!/usr/bin/env bash
# Surface tracking time against points per frame, rigfit and the PyPI peers on the same
# scans (BCN_Epileptic's jump, 3 frames per size): prints "points<TAB>method<TAB>ms" rows
# for `cargo run --release -p rigfit-testkit --example surface_plots -- docs/img TIMES.tsv`.
# cycpd runs at the smallest size only (20-30 s a frame at 10,000 points).
#
#   scripts/bench-surface-scaling.sh > target/surface-scaling.tsv
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
data=${RIGFIT_DATA:-$root/../shared/data}
cargo=${CARGO:-/work/bin/cargo-slot}
[ -x "$cargo" ] || cargo=cargo
venv=$root/target/surface-peers-venv
work=$root/target/surface-scaling
frames=3
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
"$venv/bin/pip" install -q numpy scipy trimesh==5.2.0 rustcpd==4.0.0 cycpd==0.28
"$cargo" build -q --release -p rigfit-cli --bin rigfit
"$cargo" build -q --release -p rigfit-testkit --example surface_sequence
for points in 2500 5000 10000 20000; do
  dir=$work/$points
  rm -rf "$dir" && mkdir -p "$dir"
  target/release/examples/surface_sequence "$data/assimp/BCN_Epileptic.glb" jump "$dir/seq" $frames $points > /dev/null
  scans=$(for f in $(seq 0 $((frames - 1))); do printf '%s/seq/scan_%04d.ply ' "$dir" "$f"; done)
  # shellcheck disable=SC2086
  target/release/rigfit surface "$dir/seq/reference.ply" $scans -o "$dir/rigfit" --report "$dir/rigfit.json" > /dev/null
  peers="rustcpd nricp"
  [ "$points" = 2500 ] && peers="$peers cycpd"
  # shellcheck disable=SC2086
  "$venv/bin/python" scripts/surface_peers.py "$dir/seq" "$dir/rigfit" "$dir/rigfit.json" $frames $peers \
    | awk -F'|' -v n="$points" '$3 !~ /not moved/ { gsub(/^ +| +$/, "", $3); gsub(/ /, "", $6); print n "\t" $3 "\t" $6 }'
done
