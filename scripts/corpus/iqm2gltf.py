#!/usr/bin/env python3
"""Inter-Quake Model (.iqm, version 2) -> glTF 2.0 binary, for the rig corpus.

Usage: iqm2gltf.py IN.iqm OUT.glb

Assimp 5.2's IQM reader keeps the mesh but drops the skeleton, so this reads the file
itself: every IQM joint becomes a node with the joint's base translation, rotation and
scale (roots stay roots: a file with several root joints gives several root nodes), the
skin lists every joint in file order, and the inverse bind matrices come from the base pose.
The meshes become one skinned glTF mesh (positions, blend indexes and weights, one primitive
per IQM mesh). Each IQM animation becomes a glTF animation with translation and rotation
keys for every joint at the animation's frame rate, decoded from the quantised frame
channels (offset + value * scale). Axes and units are kept as found. Standard library only;
deterministic.
"""

import os
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gltf_skel as g  # noqa: E402

HEADER = ("version filesize flags num_text ofs_text num_meshes ofs_meshes num_vertexarrays "
          "num_vertexes ofs_vertexarrays num_triangles ofs_triangles ofs_adjacency num_joints "
          "ofs_joints num_poses ofs_poses num_anims ofs_anims num_frames num_framechannels "
          "ofs_frames ofs_bounds num_comment ofs_comment num_extensions ofs_extensions").split()
FORMATS = {0: "b", 1: "B", 2: "h", 3: "H", 4: "i", 5: "I", 7: "f", 8: "d"}
POSITION, BLENDINDEXES, BLENDWEIGHTS = 0, 4, 5


def convert(path, out):
    d = open(path, "rb").read()
    if d[:16] != b"INTERQUAKEMODEL\0":
        sys.exit(f"iqm2gltf: {path}: not an IQM file")
    h = dict(zip(HEADER, struct.unpack_from("<27I", d, 16)))
    if h["version"] != 2:
        sys.exit(f"iqm2gltf: {path}: IQM version {h['version']}, not 2")
    text = d[h["ofs_text"]:h["ofs_text"] + h["num_text"]]

    def s(o):
        return text[o:text.index(b"\0", o)].decode()

    nodes = []
    for i in range(h["num_joints"]):
        name, parent, *v = struct.unpack_from("<Ii10f", d, h["ofs_joints"] + 48 * i)
        if v[7:10] != [1.0, 1.0, 1.0] and any(abs(c - 1.0) > 1e-6 for c in v[7:10]):
            sys.exit(f"iqm2gltf: {path}: joint {s(name)} is scaled; not supported")
        nodes.append({"name": s(name), "parent": None if parent < 0 else parent,
                      "t": tuple(v[0:3]), "r": tuple(v[3:7])})

    arrays = {}
    for i in range(h["num_vertexarrays"]):
        kind, _flags, fmt, size, ofs = struct.unpack_from("<5I", d, h["ofs_vertexarrays"] + 20 * i)
        n = h["num_vertexes"] * size
        vals = struct.unpack_from(f"<{n}{FORMATS[fmt]}", d, ofs)
        arrays[kind] = (fmt, [vals[k:k + size] for k in range(0, n, size)])
    positions = [tuple(p) for p in arrays[POSITION][1]]
    joints = [tuple(j) for j in arrays[BLENDINDEXES][1]]
    wfmt, wraw = arrays[BLENDWEIGHTS]
    weights = []
    for w in wraw:
        total = float(sum(w))
        weights.append(tuple(c / total for c in w) if total > 0 else (1.0, 0.0, 0.0, 0.0))
    tris = struct.unpack_from(f"<{3 * h['num_triangles']}I", d, h["ofs_triangles"])
    primitives = []
    names = []
    for i in range(h["num_meshes"]):
        name, _mat, fv, nv, ft, nt = struct.unpack_from("<6I", d, h["ofs_meshes"] + 24 * i)
        names.append(s(name))
        # IQM winds triangles clockwise; glTF counter-clockwise.
        indices = []
        for t in range(ft, ft + nt):
            a, b, c = tris[3 * t:3 * t + 3]
            indices += [a - fv, c - fv, b - fv]
        primitives.append({"positions": positions[fv:fv + nv], "joints": joints[fv:fv + nv],
                           "weights": weights[fv:fv + nv], "indices": indices})

    poses = []
    for i in range(h["num_poses"]):
        parent, mask, *v = struct.unpack_from("<iI20f", d, h["ofs_poses"] + 88 * i)
        poses.append((mask, v[0:10], v[10:20]))
    frames = struct.unpack_from(f"<{h['num_frames'] * h['num_framechannels']}H", d,
                                h["ofs_frames"])
    decoded = []  # per frame, per joint: (t, r)
    k = 0
    for _f in range(h["num_frames"]):
        frame = []
        for mask, offset, scale in poses:
            c = []
            for ch in range(10):
                v = offset[ch]
                if mask & (1 << ch):
                    v += frames[k] * scale[ch]
                    k += 1
                c.append(v)
            frame.append((tuple(c[0:3]), g.quat_normalize(tuple(c[3:7]))))
        decoded.append(frame)

    animations = []
    for i in range(h["num_anims"]):
        name, first, count, rate, _flags = struct.unpack_from("<3IfI", d, h["ofs_anims"] + 20 * i)
        times = [f / rate for f in range(count)]
        channels = []
        for j in range(len(nodes)):
            channels.append({"node": j, "path": "translation",
                             "values": [c for f in range(first, first + count)
                                        for c in decoded[f][j][0]]})
            channels.append({"node": j, "path": "rotation",
                             "values": [c for f in range(first, first + count)
                                        for c in decoded[f][j][1]]})
        animations.append({"name": s(name), "times": times, "channels": channels})

    mesh = {"name": "+".join(names) or "mesh", "primitives": primitives}
    g.write_glb(out, nodes, animations=animations, mesh=mesh,
                generator="rigfit scripts/corpus/iqm2gltf.py")
    print(f"{out}: {len(nodes)} joints, {len(positions)} vertices, "
          f"{len(animations)} animation(s) from {path}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__.strip().splitlines()[2])
    convert(*sys.argv[1:])
