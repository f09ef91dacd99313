# Sourced by the test scripts from the repository root: exports RIGFIT_DATA, the real assets
# (../shared/data when present, otherwise rebuilt from their packages under target/test-data).
if [ -z "${RIGFIT_DATA:-}" ]; then
  if [ -d "../shared/data/assimp" ]; then
    RIGFIT_DATA="$(cd ../shared/data && pwd)"
  else
    RIGFIT_DATA="$(pwd)/target/test-data"
    [ -f "$RIGFIT_DATA/assimp/BCN_Epileptic.glb" ] || scripts/fetch-data.sh "$RIGFIT_DATA"
  fi
  export RIGFIT_DATA
fi
