# Sourced by the test scripts from the repository root: exports RIGFIT_DATA, the real assets
# (../shared/data when present, otherwise rebuilt from their packages under target/test-data),
# and RIGFIT_CORPUS, the rig corpus of data/corpus.json ($RIGFIT_DATA/corpus when it is
# complete, otherwise fetched under target/test-data/corpus).
if [ -z "${RIGFIT_DATA:-}" ]; then
  if [ -d "../shared/data/assimp" ]; then
    RIGFIT_DATA="$(cd ../shared/data && pwd)"
  else
    RIGFIT_DATA="$(pwd)/target/test-data"
    [ -f "$RIGFIT_DATA/assimp/BCN_Epileptic.glb" ] || scripts/fetch-data.sh "$RIGFIT_DATA"
  fi
  export RIGFIT_DATA
fi
if [ -z "${RIGFIT_CORPUS:-}" ]; then
  # A corpus fetched before the many-part objects (data/surface_corpus.json) lacks parts/.
  if [ -f "$RIGFIT_DATA/corpus/.complete" ] && [ -d "$RIGFIT_DATA/corpus/parts" ]; then
    RIGFIT_CORPUS="$RIGFIT_DATA/corpus"
  else
    RIGFIT_CORPUS="$(pwd)/target/test-data/corpus"
    [ -f "$RIGFIT_CORPUS/.complete" ] && [ -d "$RIGFIT_CORPUS/parts" ] \
      || scripts/fetch-data.sh --corpus-only target/test-data
  fi
  export RIGFIT_CORPUS
fi
