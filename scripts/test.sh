#!/usr/bin/env bash
# The whole test suite: installs what the tests need on a fresh Debian machine, then runs
# formatting, lints and every test. README's second command; .ci/run calls it.
set -euo pipefail
cd "$(dirname "$0")/.."

# The real assets (scripts/test-data.sh).
. scripts/test-data.sh
echo "== test assets: $RIGFIT_DATA"

echo "== rustfmt"
cargo fmt --all -- --check
echo "== clippy"
cargo clippy --workspace --all-targets --quiet -- -D warnings
echo "== cargo test"
cargo test --workspace --quiet 2>&1 | tee target/cargo-test.log
# One closing line over every test binary (the last cargo line is the doc-tests' alone).
awk '/^test result:/ { for (i = 1; i <= NF; i++) { if ($i ~ /^passed/) p += $(i-1); if ($i ~ /^failed/) f += $(i-1) } }
     END { printf "%d passed, %d failed\n", p, f; exit (f > 0 || p == 0) }' target/cargo-test.log

scripts/test-web.sh
echo "== python package and Blender extension"
scripts/test-python.sh
