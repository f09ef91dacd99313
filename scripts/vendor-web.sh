#!/usr/bin/env bash
# Copies the npm files the page needs at run time into web/vendor/ (committed: `rigfit serve`
# embeds web/ in its binary). Pinned versions, installed into a temporary directory; only the
# files the page loads are copied. Rerun after changing a version below, then commit web/vendor.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

THREE_VERSION=0.187.0
PROFILES_VERSION=1.0.20
# The controller profiles drawn in VR: what iwer's Quest 3 / Quest 2 emulations report, and the
# generic fallback that nearly every trigger + squeeze + thumbstick controller lists.
PROFILES="meta-quest-touch-plus oculus-touch-v3 generic-trigger-squeeze-thumbstick"

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
npm install --prefix "$tmp" --no-save --no-audit --no-fund --ignore-scripts \
  "three@$THREE_VERSION" "@webxr-input-profiles/assets@$PROFILES_VERSION" >/dev/null
nm="$tmp/node_modules"

vendor="$root/web/vendor"
rm -rf "$vendor"
mkdir -p "$vendor"

copy() { # copy SRC_ROOT RELATIVE_PATH DEST_ROOT
  mkdir -p "$(dirname "$3/$2")"
  cp "$1/$2" "$3/$2"
}

# three.js: the core build and the addons the page imports (with what they import).
for f in LICENSE build/three.module.js build/three.core.js \
  examples/jsm/controls/OrbitControls.js examples/jsm/controls/TransformControls.js \
  examples/jsm/loaders/GLTFLoader.js examples/jsm/utils/BufferGeometryUtils.js \
  examples/jsm/utils/SkeletonUtils.js examples/jsm/webxr/XRControllerModelFactory.js \
  examples/jsm/libs/motion-controllers.module.js; do
  copy "$nm/three" "$f" "$vendor/three"
done

# Controller models for VR, loaded from this origin (XRControllerModelFactory.setPath).
assets="$nm/@webxr-input-profiles/assets"
mkdir -p "$vendor/webxr-input-profiles"
cp "$assets/LICENSE.md" "$vendor/webxr-input-profiles/LICENSE.md"
for p in $PROFILES; do
  for f in profile.json left.glb right.glb; do
    copy "$assets/dist/profiles" "$p/$f" "$vendor/webxr-input-profiles/profiles"
  done
done
# profilesList.json trimmed to the profiles copied, so no lookup ever leaves this origin.
node -e '
  const [list, keep] = [require(process.argv[1]), process.argv[2].split(" ")];
  const out = Object.fromEntries(keep.map((id) => [id, list[id]]));
  // three'"'"'s factory falls back to "generic-trigger" for a controller no profile matches:
  // draw the generic trigger + squeeze + thumbstick model for it.
  out["generic-trigger"] = list["generic-trigger-squeeze-thumbstick"];
  process.stdout.write(JSON.stringify(out, null, 2) + "\n");
' "$assets/dist/profiles/profilesList.json" "$PROFILES" >"$vendor/webxr-input-profiles/profiles/profilesList.json"

# Every relative import of a copied module must itself have been copied.
missing=0
while IFS= read -r js; do
  for rel in $(grep -oE "^(import|export)[^;]*from '\.\.?/[^']+'" "$js" | grep -oE "'[^']+'" | tr -d "'"); do
    [ -f "$(dirname "$js")/$rel" ] || { echo "vendor-web: $js imports missing $rel" >&2; missing=1; }
  done
done < <(find "$vendor" -name '*.js')
[ "$missing" = 0 ]

cat >"$vendor/VERSIONS" <<VERSIONS
# Written by scripts/vendor-web.sh; npm packages copied here, by version.
three $THREE_VERSION (build/, examples/jsm/: OrbitControls, TransformControls, GLTFLoader,
  XRControllerModelFactory and three's copy of @webxr-input-profiles/motion-controllers 1.0.0
  in examples/jsm/libs/motion-controllers.module.js)
@webxr-input-profiles/assets $PROFILES_VERSION (profiles: $PROFILES)
VERSIONS
du -sh "$vendor"
