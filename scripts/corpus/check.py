#!/usr/bin/env python3
"""Checks the rig corpus against its manifest (data/corpus.json).

Usage: check.py CORPUS_DIR [--rigfit BIN] [--manifest FILE] [--update]

For every rig: the file exists, `rigfit info FILE` reads it, and its joints (skin joints),
height, clips and frames (of the first clip) are the manifest's. Also lists, per rig, the
joints other than the root whose animation translates them (BVH position channels, glTF
translation keys that move), which the solver needs translation freedom for.
--update writes the measured numbers into the manifest instead of comparing them.
Standard library only.
"""

import argparse
import json
import os
import re
import struct
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))


def info(rigfit, path):
    run = subprocess.run([rigfit, "info", path], capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError((run.stderr or run.stdout).strip())
    text = run.stdout
    m = re.search(r"^joints: \d+ \((\d+) skin joints", text, re.M)
    joints = int(m.group(1))
    m = re.search(r"^height: ([-0-9.]+)", text, re.M)
    height = float(m.group(1)) if m else None
    m = re.search(r"^animations: (\d+)", text, re.M)
    clips = int(m.group(1)) if m else 0
    m = re.search(r"^  [^\n]*: [0-9.]+ s, (\d+) frames", text, re.M)
    frames = int(m.group(1)) if m and clips else 0
    free = re.findall(r"^ +(\S.*?)(?: \(helper\))? \[free\]$", text, re.M)
    return {"joints": joints, "height": height, "clips": clips, "frames": frames}, free


def bvh_translating(path):
    """Non-root joints with position channels."""
    names = []
    tokens = open(path).read().split()
    current = None
    for i, t in enumerate(tokens):
        if t == "MOTION":
            break
        if t in ("ROOT", "JOINT"):
            current = (t, tokens[i + 1])
        elif t == "CHANNELS" and current is not None:
            n = int(tokens[i + 1])
            if current[0] == "JOINT" and any(c.endswith("position")
                                             for c in tokens[i + 2:i + 2 + n]):
                names.append(current[1])
    return names


def glb_translating(path, free):
    """Nodes (not scene roots nor rigfit's free joint) whose translation keys move."""
    data = open(path, "rb").read()
    n = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + n])
    binary = data[20 + n + 8:] if len(data) > 20 + n else b""
    nodes = doc.get("nodes", [])
    roots = set(doc.get("scenes", [{}])[doc.get("scene", 0)].get("nodes", []))
    moving = set()
    for anim in doc.get("animations", []):
        for ch in anim["channels"]:
            target = ch["target"]
            if target.get("path") != "translation" or "node" not in target:
                continue
            node = target["node"]
            name = nodes[node].get("name", f"node{node}")
            if node in roots or name in free:
                continue
            acc = doc["accessors"][anim["samplers"][ch["sampler"]]["output"]]
            view = doc["bufferViews"][acc["bufferView"]]
            start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
            stride = view.get("byteStride", 12)
            keys = [struct.unpack_from("<3f", binary, start + k * stride)
                    for k in range(acc["count"])]
            rest = nodes[node].get("translation", [0.0, 0.0, 0.0])
            scale = max(1e-9, max(abs(c) for c in rest), *(abs(c) for k in keys for c in k))
            if any(abs(k[i] - keys[0][i]) > 1e-4 * scale for k in keys for i in range(3)):
                moving.add(name)
    return sorted(moving)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("corpus")
    ap.add_argument("--rigfit", default=os.path.join(REPO, "target", "release", "rigfit"))
    ap.add_argument("--manifest", default=os.path.join(REPO, "data", "corpus.json"))
    ap.add_argument("--update", action="store_true")
    args = ap.parse_args()
    manifest = json.load(open(args.manifest))
    problems = 0
    for rig in manifest["rigs"]:
        path = os.path.join(args.corpus, rig["file"])
        try:
            got, free = info(args.rigfit, path)
        except (RuntimeError, OSError) as e:
            print(f"{rig['id']}: FAILED: {e}")
            problems += 1
            continue
        if path.endswith(".bvh"):
            moving = bvh_translating(path)
        else:
            moving = glb_translating(path, free)
        if args.update:
            rig["joints"], rig["clips"], rig["frames"] = got["joints"], got["clips"], got["frames"]
            rig["height"] = round(got["height"], 4) if got["height"] is not None else None
        else:
            for key in ("joints", "clips", "frames"):
                if rig[key] != got[key]:
                    print(f"{rig['id']}: {key} {got[key]}, manifest says {rig[key]}")
                    problems += 1
            h, want = got["height"], rig["height"]
            if (h is None) != (want is None) or (h is not None and
                                                 abs(h - want) > 1e-3 * max(1.0, abs(want))):
                print(f"{rig['id']}: height {h}, manifest says {want}")
                problems += 1
        shown = ", ".join(moving[:8]) + (f", ... ({len(moving)} in all)" if len(moving) > 8
                                          else "")
        print(f"{rig['id']:28} {rig['half']:9} {rig['kind']:19} joints {got['joints']:3} "
              f"height {got['height']!s:>10} clips {got['clips']} frames {got['frames']:5}"
              f"  translating: {shown or '-'}")
    if args.update:
        with open(args.manifest, "w") as f:
            f.write(json.dumps(manifest, indent=2, ensure_ascii=False) + "\n")
    if problems:
        sys.exit(f"check.py: {problems} problem(s)")


if __name__ == "__main__":
    main()
