#!/usr/bin/env bash
# Rebuilds the real third-party test assets (see ../shared/data/README.md) from their
# packages, for a machine without the shared data folder. Usage: scripts/fetch-data.sh DIR
set -euo pipefail
out=${1:?usage: fetch-data.sh DIR}
mkdir -p "$out"/{assimp,cmu,bunny,webxr_hand}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
export DEBIAN_FRONTEND=noninteractive
if ! command -v assimp >/dev/null; then
  apt-get update -qq && apt-get install -y -qq assimp-utils >/dev/null
fi
apt-get download assimp-testmodels >/dev/null
dpkg-deb -x assimp-testmodels_*.deb pkg
m=pkg/usr/share/assimp/models
cp "$m/BVH/01_01.bvh" "$out/cmu/01_01.bvh"
cp "$m/glTF2/simple_skin/simple_skin.gltf" "$out/assimp/simple_skin.gltf"
cp "$m/PLY/pond.0.ply" "$out/assimp/pond.0.ply"
assimp export "$m/X/BCN_Epileptic.X" "$out/assimp/BCN_Epileptic.glb" -fglb2 >/dev/null
assimp export "$m/X/Testwuson.X" "$out/assimp/Testwuson.glb" -fglb2 >/dev/null
assimp export "$m/FBX/animation_with_skeleton.fbx" "$out/assimp/animation_with_skeleton.glb" -fglb2 >/dev/null
npm pack --silent @webxr-input-profiles/assets@1.0.20 >/dev/null
tar xzf webxr-input-profiles-assets-1.0.20.tgz
cp package/dist/profiles/generic-hand/left.glb package/dist/profiles/generic-hand/right.glb "$out/webxr_hand/"
rm -rf package
npm pack --silent bunny@1.0.1 >/dev/null
tar xzf bunny-1.0.1.tgz
node -e '
const b = require("./package/index.js");
const lines = ["ply", "format ascii 1.0", "element vertex " + b.positions.length,
  "property float x", "property float y", "property float z",
  "element face " + b.cells.length, "property list uchar int vertex_indices", "end_header"];
for (const p of b.positions) lines.push(p.join(" "));
for (const c of b.cells) lines.push(c.length + " " + c.join(" "));
require("fs").writeFileSync(process.argv[1], lines.join("\n") + "\n");
' "$out/bunny/bunny.ply"
echo "test assets written to $out"
