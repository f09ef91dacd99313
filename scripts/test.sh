#!/usr/bin/env bash
# The whole test suite: installs what the tests need on a fresh Debian machine, then runs
# formatting, lints and every test. README's second command; .ci/run calls it.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

# The real assets: ../shared/data when present, otherwise rebuilt from their packages.
if [ -z "${RIGFIT_DATA:-}" ]; then
  if [ -d "$root/../shared/data/assimp" ]; then
    export RIGFIT_DATA="$root/../shared/data"
  else
    export RIGFIT_DATA="$root/target/test-data"
    [ -f "$RIGFIT_DATA/assimp/BCN_Epileptic.glb" ] || scripts/fetch-data.sh "$RIGFIT_DATA"
  fi
fi
echo "== test assets: $RIGFIT_DATA"

echo "== rustfmt"
cargo fmt --all -- --check
echo "== clippy"
cargo clippy --workspace --all-targets --quiet -- -D warnings
echo "== cargo test"
cargo test --workspace --quiet 2>&1 | tee target/cargo-test.log
grep -q "test result: FAILED" target/cargo-test.log && exit 1
echo "== all tests passed"
