#!/usr/bin/env bash
# Builds the rigfit wheel and installs it into the Python first in PATH (your venv):
#   scripts/install-python.sh            # the package
#   scripts/install-python.sh cluster    # and Dask distributed for rigfit.cluster
# Needs cargo (rustup) and Python 3.11 or later; maturin and ziglang are pip-installed into
# that Python when missing. The wheel (abi3, manylinux_2_28: also what Blender accepts) is
# left in target/wheels/.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
python=$(command -v python3 || command -v python)
if ! "$python" -c 'import maturin, ziglang' 2>/dev/null; then
  "$python" -m pip install -q --disable-pip-version-check "maturin>=1.9,<2" ziglang
fi
rm -rf target/wheels
(cd crates/rigfit-py && "$python" -m maturin build --release --zig --compatibility manylinux_2_28 \
  --out "$root/target/wheels" 2>&1 | tail -n 2)
wheel=$(ls target/wheels/rigfit-*-cp311-abi3-manylinux_2_28_x86_64.whl)
extra=""
[ "${1:-}" = "cluster" ] && extra="[cluster]"
# The wheel replaces any earlier build; its dependencies are added only where missing (an
# installed numpy that satisfies it is kept).
"$python" -m pip install -q --disable-pip-version-check --force-reinstall --no-deps "$wheel"
"$python" -m pip install -q --disable-pip-version-check "$wheel$extra"
echo "installed $wheel$extra into $("$python" -c 'import sys; print(sys.prefix)')"
