#!/usr/bin/env bash
# Fuzzes rigfit with cargo-fuzz (libFuzzer), one target at a time: the file readers of
# rigfit-formats, a strokes file through the posing solver (strokes_solve), and a `rigfit
# serve` solve request through the real router (solve_request).
#
#   scripts/fuzz.sh [SECONDS] [TARGET...]
#
# SECONDS   how long each target runs (default 60)
# TARGET    any of: ply obj strokes bvh gltf strokes_solve solve_request (default: all of
#           them, in that order)
#
# The targets live in fuzz/fuzz_targets/ (fuzz/ is a cargo-fuzz project with its own
# workspace, not a member of the main one). Each run starts from the committed seeds in
# fuzz/seeds/TARGET/ and the corpus grown by earlier runs in fuzz/corpus/TARGET/ (new inputs
# are written there); crashes, timeouts and out-of-memory inputs land in
# fuzz/artifacts/TARGET/. corpus/, artifacts/ and target/ are git-ignored. The keywords of
# each format in fuzz/dicts/TARGET.dict are given to libFuzzer as a dictionary.
#
# Needs: `cargo install cargo-fuzz` and a C++ compiler (libfuzzer-sys builds libFuzzer).
# cargo-fuzz passes nightly-only rustc flags; on a stable toolchain this script sets
# RUSTC_BOOTSTRAP=1 to allow them. Environment:
#   FUZZ_SANITIZER  address (default) or none (faster, finds only panics, hangs and OOMs)
#   FUZZ_ARGS       extra libFuzzer arguments, e.g. "-seed=1 -use_value_profile=1"
#
# A finding of strokes_solve or solve_request, once fixed, is minimised and copied into
# seeds/TARGET/: the tests replay those folders (rigfit-cli tests/fuzz_corpus.rs and
# rigfit-server tests/fuzz_corpus.rs).
#
# Reproduce or minimise a finding:
#   cd fuzz && RUSTC_BOOTSTRAP=1 cargo fuzz run TARGET artifacts/TARGET/crash-...
#   cd fuzz && RUSTC_BOOTSTRAP=1 cargo fuzz tmin TARGET artifacts/TARGET/crash-...
# Exits non-zero when any target found something (all targets still run).
set -uo pipefail
cd "$(dirname "$0")/../fuzz"

seconds=${1:-60}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(ply obj strokes bvh gltf strokes_solve solve_request)
sanitizer=${FUZZ_SANITIZER:-address}
export RUSTC_BOOTSTRAP=1

max_len() {
  case "$1" in
    gltf | ply) echo 262144 ;;
    obj | bvh | solve_request | strokes_solve) echo 65536 ;;
    *) echo 16384 ;;
  esac
}

command -v cargo-fuzz >/dev/null || {
  echo "cargo-fuzz is missing: cargo install cargo-fuzz" >&2
  exit 2
}

# One build for all targets, so the runs below do not compile.
cargo fuzz build --sanitizer "$sanitizer" || exit 2

failed=()
for t in "${targets[@]}"; do
  mkdir -p "corpus/$t" "artifacts/$t"
  dict=()
  [ -f "dicts/$t.dict" ] && dict=("-dict=dicts/$t.dict")
  # A strokes file through the solver takes the strokes reader's keywords.
  [ "$t" = strokes_solve ] && dict=("-dict=dicts/strokes.dict")
  echo "== fuzz $t for ${seconds}s"
  # shellcheck disable=SC2086 # FUZZ_ARGS is a list of arguments
  if ! cargo fuzz run --sanitizer "$sanitizer" "$t" "corpus/$t" "seeds/$t" -- \
    -max_total_time="$seconds" -rss_limit_mb=4096 -max_len="$(max_len "$t")" \
    -timeout=20 -print_final_stats=1 "${dict[@]}" ${FUZZ_ARGS:-}; then
    failed+=("$t")
  fi
done

if [ ${#failed[@]} -gt 0 ]; then
  echo "== findings in: ${failed[*]} (see fuzz/artifacts/)" >&2
  exit 1
fi
echo "== no findings"
