#!/usr/bin/env bash
# Rebuilds the real third-party test assets (see ../shared/data/README.md) and the rig corpus
# (data/README.md, data/corpus.json) from their packages, for a machine without the shared
# data folder.
#   scripts/fetch-data.sh DIR                writes DIR/assimp, DIR/cmu, DIR/bunny,
#                                            DIR/webxr_hand and DIR/corpus
#   scripts/fetch-data.sh --corpus-only DIR  writes DIR/corpus only
# DIR/corpus/.complete is written last. Every package is pinned; installs what it lacks
# (Debian: apt-get). Safe to run again over an earlier run.
set -euo pipefail

# ---------------------------------------------------------------- pinned packages
ASSIMP_TESTMODELS=5.2.5~ds0-1                    # Debian bookworm
MINETEST_DATA=5.6.1+dfsg+~1.9.0mt8+dfsg-2        # Debian bookworm
MINETEST_MOD_MAIDROID=0.1.0-2                    # Debian bookworm
WEBXR_ASSETS=1.0.20                              # npm @webxr-input-profiles/assets
BUNNY=1.0.1                                      # npm bunny
ASSIMPJS=0.0.10                                  # npm assimpjs (the converter, not data)
BVHTOOLBOX=0.1.3                                 # PyPI bvhtoolbox (source distribution)
DM_CONTROL=1.0.50                                # PyPI dm-control (wheel)
GYMNASIUM_ROBOTICS=1.4.2                         # PyPI gymnasium-robotics (wheel)

corpus_only=0
if [ "${1:-}" = "--corpus-only" ]; then
  corpus_only=1
  shift
fi
[ $# -eq 1 ] || { echo "usage: fetch-data.sh [--corpus-only] DIR" >&2; exit 2; }
mkdir -p "$1"
out=$(cd "$1" && pwd)
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
conv=$here/corpus
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
export DEBIAN_FRONTEND=noninteractive

die() { echo "fetch-data.sh: $*" >&2; exit 1; }

# ---------------------------------------------------------------- tools
apt_updated=0
apt_install() {
  if [ $apt_updated = 0 ]; then
    apt-get update -qq
    apt_updated=1
  fi
  apt-get install -y -qq "$@" >/dev/null
}

need_tools() {
  command -v assimp >/dev/null || apt_install assimp-utils
  command -v node >/dev/null || apt_install nodejs
  command -v npm >/dev/null || apt_install npm
  command -v python3 >/dev/null || apt_install python3
  python3 -m pip --version >/dev/null 2>&1 || apt_install python3-pip
}

# ---------------------------------------------------------------- package clients
# Each fetches one pinned package once into $work and prints where its files are.

deb() { # NAME VERSION -> the unpacked package's root
  local dir=$work/deb-$1
  if [ ! -d "$dir" ]; then
    apt-get download "$1=$2" >/dev/null 2>"$work/apt.log" || {
      # the package lists may be stale: refresh them once and try again
      apt-get update -qq && apt_updated=1
      apt-get download "$1=$2" >/dev/null || die "apt-get download $1=$2 failed"
    }
    dpkg-deb -x "$1_"*.deb "$dir"
    rm -f "$1_"*.deb
  fi
  echo "$dir"
}

npm_pkg() { # NAME VERSION -> the unpacked package folder
  local dir=$work/npm-${1//[@\/]/_}
  if [ ! -d "$dir" ]; then
    mkdir -p "$dir.tmp"
    (cd "$dir.tmp" && npm pack --silent "$1@$2" >/dev/null && tar xzf ./*.tgz) \
      || die "npm pack $1@$2 failed"
    mv "$dir.tmp/package" "$dir"
    rm -rf "$dir.tmp"
  fi
  echo "$dir"
}

pypi() { # NAME VERSION wheel|sdist -> the unpacked distribution
  local dir=$work/pypi-$1 kind
  if [ ! -d "$dir" ]; then
    if [ "$3" = sdist ]; then kind=(--no-binary :all:); else kind=(--only-binary :all:); fi
    python3 -m pip download -q --no-deps --no-cache-dir --ignore-requires-python "${kind[@]}" \
      -d "$dir.dl" "$1==$2" >/dev/null || die "pip download $1==$2 failed"
    mkdir -p "$dir"
    case $(ls "$dir.dl") in
      *.whl) # the models only: MJCF files, the mesh files they load, and licences
        python3 - "$dir.dl"/*.whl "$dir" <<'EOF'
import sys, zipfile
keep = (".xml", ".stl", ".obj", ".msh")
with zipfile.ZipFile(sys.argv[1]) as z:
    z.extractall(sys.argv[2], [n for n in z.namelist() if n.lower().endswith(keep)
                               or "LICENSE" in n or "AUTHORS" in n])
EOF
        ;;
      *.tar.gz) tar xzf "$dir.dl"/*.tar.gz -C "$dir" --strip-components=1 ;;
      *) die "pip download $1==$2: unexpected $(ls "$dir.dl")" ;;
    esac
    rm -rf "$dir.dl"
  fi
  echo "$dir"
}

assimp_models() {
  local d
  d=$(deb assimp-testmodels "$ASSIMP_TESTMODELS")
  echo "$d/usr/share/assimp/models"
}

to_glb() { # IN OUT: Debian's assimp command line
  assimp export "$1" "$2" -fglb2 >/dev/null || die "assimp export $1 failed"
}

# ---------------------------------------------------------------- the test assets
test_assets() {
  local m
  m=$(assimp_models)
  mkdir -p "$out"/{assimp,cmu,bunny,webxr_hand}
  cp "$m/BVH/01_01.bvh" "$out/cmu/01_01.bvh"
  cp "$m/glTF2/simple_skin/simple_skin.gltf" "$out/assimp/simple_skin.gltf"
  cp "$m/PLY/pond.0.ply" "$out/assimp/pond.0.ply"
  to_glb "$m/X/BCN_Epileptic.X" "$out/assimp/BCN_Epileptic.glb"
  to_glb "$m/X/Testwuson.X" "$out/assimp/Testwuson.glb"
  to_glb "$m/FBX/animation_with_skeleton.fbx" "$out/assimp/animation_with_skeleton.glb"
  local hands
  hands=$(npm_pkg @webxr-input-profiles/assets "$WEBXR_ASSETS")/dist/profiles/generic-hand
  cp "$hands/left.glb" "$hands/right.glb" "$out/webxr_hand/"
  local bunny
  bunny=$(npm_pkg bunny "$BUNNY")
  node -e '
const b = require(process.argv[1] + "/index.js");
const lines = ["ply", "format ascii 1.0", "element vertex " + b.positions.length,
  "property float x", "property float y", "property float z",
  "element face " + b.cells.length, "property list uchar int vertex_indices", "end_header"];
for (const p of b.positions) lines.push(p.join(" "));
for (const c of b.cells) lines.push(c.length + " " + c.join(" "));
require("fs").writeFileSync(process.argv[2], lines.join("\n") + "\n");
' "$bunny" "$out/bunny/bunny.ply"
}

# ---------------------------------------------------------------- the rig corpus
# One function per source package; each writes its rigs under $c (data/corpus.json lists
# them, data/README.md says where each comes from).

corpus_assimp_testmodels() { # Debian assimp-testmodels (BSD-3)
  local m
  m=$(assimp_models)
  mkdir -p "$c/cmu" "$c/assimp"
  cp "$m/BVH/01_01.bvh" "$m/BVH/01_03.bvh" "$c/cmu/"
  cp "$m/BVH/01_nn.bvh.source.txt" "$c/cmu/"
  cp "$m/BVH/Boxing_Toes.bvh" "$c/assimp/"
  to_glb "$m/X/BCN_Epileptic.X" "$c/assimp/BCN_Epileptic.glb"
  to_glb "$m/X/Testwuson.X" "$c/assimp/Testwuson.glb"
  to_glb "$m/FBX/huesitos.fbx" "$c/assimp/huesitos.glb"
  # assimp 5.2 reads IQM meshes but not their skeletons: our own reader
  python3 "$conv/iqm2gltf.py" "$m/IQM/mrfixit.iqm" "$c/assimp/mrfixit.glb" >/dev/null
}

corpus_webxr() { # npm @webxr-input-profiles/assets (MIT)
  local p
  p=$(npm_pkg @webxr-input-profiles/assets "$WEBXR_ASSETS")
  mkdir -p "$c/webxr_hand"
  cp "$p/dist/profiles/generic-hand/left.glb" "$c/webxr_hand/"
  [ -f "$p/LICENSE.md" ] && cp "$p/LICENSE.md" "$c/webxr_hand/LICENSE.md"
  return 0
}

corpus_minetest() { # Debian minetest-data, minetest-mod-maidroid (B3D, via assimpjs)
  local ajs mt md
  ajs=$(npm_pkg assimpjs "$ASSIMPJS")
  mt=$(deb minetest-data "$MINETEST_DATA")/usr/share/games/minetest/games/minetest_game
  md=$(deb minetest-mod-maidroid "$MINETEST_MOD_MAIDROID")/usr/share/games/minetest/mods
  mkdir -p "$c/minetest"
  node "$conv/assimpjs-convert.js" "$ajs" "$mt/mods/player_api/models/character.b3d" \
    "$c/minetest/character.glb"
  node "$conv/assimpjs-convert.js" "$ajs" "$md/maidroid/maidroid/models/maidroid.b3d" \
    "$c/minetest/maidroid.glb"
}

corpus_bvhtoolbox() { # PyPI bvhtoolbox source distribution (MIT): its test BVH files
  local p
  p=$(pypi bvhtoolbox "$BVHTOOLBOX" sdist)
  mkdir -p "$c/bvhtoolbox"
  cp "$p/tests/example_files/test_freebvh.bvh" "$p/tests/example_files/test_mocapbank.bvh" \
    "$c/bvhtoolbox/"
}

corpus_dm_control() { # PyPI dm-control wheel (Apache-2.0): MJCF bodies -> glTF
  local p
  p=$(pypi dm-control "$DM_CONTROL" wheel)/dm_control
  mkdir -p "$c/dm_control"
  python3 "$conv/mjcf2gltf.py" "$p/suite/dog.xml" torso "$c/dm_control/dog.glb" >/dev/null
  python3 "$conv/mjcf2gltf.py" "$p/suite/quadruped.xml" torso \
    "$c/dm_control/quadruped.glb" >/dev/null
  python3 "$conv/mjcf2gltf.py" "$p/suite/humanoid_CMU.xml" root \
    "$c/dm_control/humanoid_CMU.glb" >/dev/null
  python3 "$conv/mjcf2gltf.py" "$p/locomotion/walkers/assets/rodent.xml" torso \
    "$c/dm_control/rodent.glb" >/dev/null
  python3 "$conv/mjcf2gltf.py" "$p/locomotion/walkers/assets/build_fruitfly/fruitfly.xml" \
    thorax "$c/dm_control/fruitfly.glb" >/dev/null
}

corpus_gymnasium_robotics() { # PyPI gymnasium-robotics wheel (MIT; assets/LICENSE.md)
  local p
  p=$(pypi gymnasium-robotics "$GYMNASIUM_ROBOTICS" wheel)/gymnasium_robotics/envs/assets
  mkdir -p "$c/gymnasium_robotics"
  python3 "$conv/mjcf2gltf.py" "$p/hand/manipulate_block.xml" "robot0:hand mount" \
    "$c/gymnasium_robotics/shadow_hand.glb" >/dev/null
  python3 "$conv/mjcf2gltf.py" "$p/adroit_hand/adroit_door.xml" forearm \
    "$c/gymnasium_robotics/adroit_hand.glb" >/dev/null
  python3 "$conv/mjcf2gltf.py" "$p/fetch/reach.xml" robot0:base_link \
    "$c/gymnasium_robotics/fetch.glb" >/dev/null
  cp "$p/LICENSE.md" "$c/gymnasium_robotics/LICENSE.md"
}

corpus_parts() { # many-part objects for surface tracking (data/surface_corpus.json):
  # MJCF bodies with every visible geom as a rigid piece (scripts/corpus/mjcf2parts.py)
  local d gr
  d=$(pypi dm-control "$DM_CONTROL" wheel)/dm_control
  gr=$(pypi gymnasium-robotics "$GYMNASIUM_ROBOTICS" wheel)/gymnasium_robotics/envs/assets
  mkdir -p "$c/parts"
  parts() { python3 "$conv/mjcf2parts.py" "$@" >/dev/null || die "mjcf2parts.py $* failed"; }
  parts "$gr/hand/manipulate_block.xml" "robot0:hand mount" "$c/parts/shadow_hand.glb"
  parts "$gr/adroit_hand/adroit_door.xml" forearm "$c/parts/adroit_hand.glb"
  parts "$gr/fetch/reach.xml" robot0:base_link "$c/parts/fetch.glb"
  parts "$d/suite/humanoid_CMU.xml" root "$c/parts/humanoid_CMU.glb"
  parts "$d/suite/humanoid.xml" torso "$c/parts/humanoid.glb"
  parts "$d/suite/quadruped.xml" torso "$c/parts/quadruped.glb"
  parts "$d/locomotion/walkers/assets/rodent.xml" torso "$c/parts/rodent.glb"
  # the dog is drawn with a skin, and its bone meshes hold 308,000 triangles:
  # its collision primitives (group 3) instead
  parts --groups 3 "$d/suite/dog.xml" torso "$c/parts/dog.glb"
  parts "$d/suite/cheetah.xml" torso "$c/parts/cheetah.glb"
  parts "$d/suite/walker.xml" torso "$c/parts/walker.glb"
  parts "$d/suite/manipulator.xml" upper_arm "$c/parts/manipulator.glb"
  cp "$gr/LICENSE.md" "$c/parts/LICENSE-gymnasium-robotics-assets.md"
  cp "$(dirname "$d")"/dm_control-*.dist-info/licenses/LICENSE "$c/parts/LICENSE-dm-control"
}

corpus_derived() { # flat marker rigs made from real mocap (scripts/corpus/bvh2markers.py)
  mkdir -p "$c/derived"
  # CMU units are 1/0.45 inch: 56.444 mm
  python3 "$conv/bvh2markers.py" "$c/cmu/01_03.bvh" "$c/derived/markers_cmu_01_03.glb" \
    56.444 >/dev/null
  python3 "$conv/bvh2markers.py" "$c/assimp/Boxing_Toes.bvh" \
    "$c/derived/markers_boxing_toes.glb" 10 >/dev/null
}

corpus() {
  c=$out/corpus
  rm -f "$c/.complete"
  mkdir -p "$c"
  corpus_assimp_testmodels
  corpus_webxr
  corpus_minetest
  corpus_bvhtoolbox
  corpus_dm_control
  corpus_gymnasium_robotics
  corpus_parts
  corpus_derived
  (cd "$c" && find . -type f ! -name SHA256SUMS ! -name .complete | LC_ALL=C sort \
    | sed 's|^\./||' | xargs sha256sum > SHA256SUMS)
  date -u +%Y-%m-%dT%H:%M:%SZ > "$c/.complete"
}

need_tools
if [ $corpus_only = 0 ]; then
  test_assets
fi
corpus
if [ $corpus_only = 0 ]; then
  echo "test assets and rig corpus written to $out"
else
  echo "rig corpus written to $out/corpus"
fi
