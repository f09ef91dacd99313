#!/usr/bin/env python3
"""A flat marker rig from real motion capture: BVH -> glTF 2.0 binary, for the rig corpus.

Usage: bvh2markers.py IN.bvh OUT.glb MM_PER_UNIT

What a Vicon-style marker export looks like: one root node ("Vicon", at the origin, never
animated) and one child node per marker, every marker a direct child of the root and moved
by translation keys only (no rotations anywhere), Z-up, in millimetres. The markers sit at
the world positions of the BVH's joints and End Sites in every frame (a marker that always
coincides with its parent joint is left out). Y-up BVH axes (x, y, z) become Z-up
(x, -z, y); lengths are multiplied by MM_PER_UNIT. The node's own translation (its rest) is
the first frame. The skin lists the root and every marker. Every frame is kept, at the BVH's
frame time. Standard library only; deterministic.
"""

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gltf_skel as g  # noqa: E402


def parse_bvh(path):
    """Joints [{name, parent, offset, channels}] (End Sites as joints with no channels),
    the frame time and the motion rows."""
    tokens = open(path).read().split()
    pos = 0
    joints = []
    stack = []

    def take():
        nonlocal pos
        pos += 1
        return tokens[pos - 1]

    assert take() == "HIERARCHY"
    while True:
        t = take()
        if t in ("ROOT", "JOINT"):
            name = take()
            joints.append({"name": name, "parent": stack[-1] if stack else None,
                           "channels": []})
        elif t == "End":
            take()  # "Site"
            parent = stack[-1]
            joints.append({"name": joints[parent]["name"] + "_End", "parent": parent,
                           "channels": []})
        elif t == "{":
            stack.append(len(joints) - 1)
        elif t == "}":
            stack.pop()
        elif t == "OFFSET":
            joints[stack[-1]]["offset"] = [float(take()) for _ in range(3)]
        elif t == "CHANNELS":
            joints[stack[-1]]["channels"] = [take() for _ in range(int(take()))]
        elif t == "MOTION":
            break
    assert take() == "Frames:"
    take()  # the header's count: the rows present are what counts
    assert take() == "Frame" and take() == "Time:"
    frame_time = float(take())
    width = sum(len(j["channels"]) for j in joints)
    values = [float(v) for v in tokens[pos:]]
    rows = [values[i:i + width] for i in range(0, len(values) - width + 1, width)]
    return joints, frame_time, rows


AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}


def world_positions(joints, row):
    out = []
    k = 0
    for j in joints:
        t = list(j["offset"])
        q = (0.0, 0.0, 0.0, 1.0)
        for ch in j["channels"]:
            v = row[k]
            k += 1
            if ch.endswith("position"):
                t["XYZ".index(ch[0])] += v  # offset + channel, as rigfit reads BVH
            else:
                q = g.quat_mul(q, g.quat_axis_angle(AXES[ch[0]], math.radians(v)))
        if j["parent"] is None:
            out.append(((t[0], t[1], t[2]), q))
        else:
            out.append(g.compose(out[j["parent"]], ((t[0], t[1], t[2]), q)))
    return [tr[0] for tr in out]


def convert(bvh, out, mm_per_unit):
    joints, frame_time, rows = parse_bvh(bvh)
    keep = [i for i, j in enumerate(joints)
            if j["parent"] is None or any(abs(c) > 1e-9 for c in j["offset"])]
    tracks = {i: [] for i in keep}
    for row in rows:
        p = world_positions(joints, row)
        for i in keep:
            x, y, z = p[i]
            tracks[i].append((x * mm_per_unit, -z * mm_per_unit, y * mm_per_unit))
    nodes = [{"name": "Vicon", "parent": None, "t": (0.0, 0.0, 0.0), "r": (0.0, 0.0, 0.0, 1.0)}]
    channels = []
    for i in keep:
        nodes.append({"name": joints[i]["name"], "parent": 0, "t": tracks[i][0],
                      "r": (0.0, 0.0, 0.0, 1.0)})
        channels.append({"node": len(nodes) - 1, "path": "translation",
                         "values": [c for p in tracks[i] for c in p]})
    times = [k * frame_time for k in range(len(rows))]
    g.write_glb(out, nodes, skin_name="markers",
                animations=[{"name": "markers", "times": times, "channels": channels}],
                generator="rigfit scripts/corpus/bvh2markers.py")
    print(f"{out}: {len(keep)} markers, {len(rows)} frames from {bvh}")


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__.strip().splitlines()[2])
    convert(sys.argv[1], sys.argv[2], float(sys.argv[3]))
