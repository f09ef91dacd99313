"""Small, dependency-free helpers for the corpus converters: rotations as quaternions and a
writer of skeleton-only glTF 2.0 binaries (.glb): nodes, one skin listing them (a skin with
no mesh is valid glTF), inverse bind matrices from the rest pose, and keyed animations.

Quaternions are (x, y, z, w) as in glTF. Output is deterministic: same input, same bytes.
"""

import json
import math
import struct


# ---------------------------------------------------------------- rotations

def quat_normalize(q):
    n = math.sqrt(sum(c * c for c in q))
    if n == 0.0:
        return (0.0, 0.0, 0.0, 1.0)
    q = tuple(c / n for c in q)
    # One sign for a rotation, so identical rotations give identical bytes.
    if q[3] < 0.0:
        q = tuple(-c for c in q)
    return q


def quat_mul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def quat_axis_angle(axis, angle):
    n = math.sqrt(sum(c * c for c in axis))
    if n == 0.0:
        return (0.0, 0.0, 0.0, 1.0)
    s = math.sin(angle / 2.0) / n
    return (axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle / 2.0))


def quat_rotate(q, v):
    x, y, z, w = q
    # v' = v + 2 w (q x v) + 2 q x (q x v)
    cx = y * v[2] - z * v[1]
    cy = z * v[0] - x * v[2]
    cz = x * v[1] - y * v[0]
    ccx = y * cz - z * cy
    ccy = z * cx - x * cz
    ccz = x * cy - y * cx
    return (v[0] + 2 * (w * cx + ccx), v[1] + 2 * (w * cy + ccy), v[2] + 2 * (w * cz + ccz))


def quat_from_matrix(m):
    """m: 3x3 rotation as rows."""
    t = m[0][0] + m[1][1] + m[2][2]
    if t > 0.0:
        s = math.sqrt(t + 1.0) * 2.0
        q = ((m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, 0.25 * s)
    elif m[0][0] > m[1][1] and m[0][0] > m[2][2]:
        s = math.sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]) * 2.0
        q = (0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s)
    elif m[1][1] > m[2][2]:
        s = math.sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]) * 2.0
        q = ((m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s)
    else:
        s = math.sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]) * 2.0
        q = ((m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s, (m[1][0] - m[0][1]) / s)
    return quat_normalize(q)


def compose(parent, local):
    """(t, q) transforms: parent * local."""
    pt, pq = parent
    lt, lq = local
    r = quat_rotate(pq, lt)
    return ((pt[0] + r[0], pt[1] + r[1], pt[2] + r[2]), quat_normalize(quat_mul(pq, lq)))


def inverse(tr):
    t, q = tr
    qi = (-q[0], -q[1], -q[2], q[3])
    r = quat_rotate(qi, t)
    return ((-r[0], -r[1], -r[2]), qi)


def matrix_cols(tr):
    """Column-major 4x4 of a rigid transform (glTF accessor order)."""
    t, (x, y, z, w) = tr
    r = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    return [r[0][0], r[1][0], r[2][0], 0.0,
            r[0][1], r[1][1], r[2][1], 0.0,
            r[0][2], r[1][2], r[2][2], 0.0,
            t[0], t[1], t[2], 1.0]


# ---------------------------------------------------------------- the writer

def _r(v):
    # Round what goes into the JSON so that the text does not depend on the last bits.
    return float(f"{v:.9g}")


def _f32(v):
    return struct.unpack("<f", struct.pack("<f", v))[0]


class _Buffer:
    def __init__(self):
        self.data = bytearray()
        self.views = []
        self.accessors = []

    def floats(self, values, kind, count, minmax=False, fmt="f", component=5126, target=None):
        while len(self.data) % 4:
            self.data.append(0)
        offset = len(self.data)
        self.data += struct.pack(f"<{len(values)}{fmt}", *values)
        view = {"buffer": 0, "byteOffset": offset, "byteLength": len(self.data) - offset}
        if target:
            view["target"] = target
        self.views.append(view)
        acc = {"bufferView": len(self.views) - 1, "componentType": component, "count": count,
               "type": kind}
        if minmax:
            width = len(values) // count
            acc["min"] = [_r(_f32(min(values[i::width]))) for i in range(width)]
            acc["max"] = [_r(_f32(max(values[i::width]))) for i in range(width)]
        self.accessors.append(acc)
        return len(self.accessors) - 1


def write_glb(path, nodes, skin_joints=None, animations=(), skin_name="skeleton",
              generator="rigfit scripts/corpus", extras=None, mesh=None):
    """nodes: list of dicts {name, parent (index or None), t (x, y, z), r (x, y, z, w)}.
    skin_joints: node indices of the skin (default: every node).
    animations: list of {name, times [s], channels: [{node, path, values (flat list)}]}.
    mesh: None or {name, primitives: [{positions [(x, y, z)], joints [(4 skin-joint
    indices)], weights [(4 floats)], indices [triangle vertex indices], optional extras (a
    dict kept as the primitive's glTF extras)}]}, skinned by the skin on a node of its own
    at the scene root."""
    if skin_joints is None:
        skin_joints = list(range(len(nodes)))
    children = [[] for _ in nodes]
    for i, n in enumerate(nodes):
        if n["parent"] is not None:
            children[n["parent"]].append(i)
    world = [None] * len(nodes)

    def world_of(i):
        if world[i] is None:
            local = (tuple(nodes[i]["t"]), quat_normalize(nodes[i]["r"]))
            p = nodes[i]["parent"]
            world[i] = local if p is None else compose(world_of(p), local)
        return world[i]

    buf = _Buffer()
    gnodes = []
    for i, n in enumerate(nodes):
        g = {"name": n["name"]}
        if children[i]:
            g["children"] = children[i]
        t = [_r(c) for c in n["t"]]
        q = [_r(c) for c in quat_normalize(n["r"])]
        if any(t):
            g["translation"] = t
        if q != [0.0, 0.0, 0.0, 1.0]:
            g["rotation"] = q
        gnodes.append(g)
    ibm = []
    for j in skin_joints:
        ibm += matrix_cols(inverse(world_of(j)))
    ibm_acc = buf.floats(ibm, "MAT4", len(skin_joints))
    roots = [i for i, n in enumerate(nodes) if n["parent"] is None]
    skin = {"name": skin_name, "joints": list(skin_joints), "inverseBindMatrices": ibm_acc}
    if len(roots) == 1:
        skin["skeleton"] = roots[0]
    doc = {
        "asset": {"version": "2.0", "generator": generator},
        "scene": 0,
        "scenes": [{"nodes": roots}],
        "nodes": gnodes,
        "skins": [skin],
    }
    if extras:
        doc["asset"]["extras"] = extras
    if mesh is not None:
        prims = []
        for prim in mesh["primitives"]:
            n = len(prim["positions"])
            pos = buf.floats([c for p in prim["positions"] for c in p], "VEC3", n, minmax=True,
                             target=34962)
            jnt = buf.floats([c for j in prim["joints"] for c in j], "VEC4", n, fmt="H",
                             component=5123, target=34962)
            wgt = buf.floats([c for w in prim["weights"] for c in w], "VEC4", n, target=34962)
            tris = prim["indices"]
            idx = buf.floats(list(tris), "SCALAR", len(tris), fmt="I", component=5125,
                             target=34963)
            gprim = {"attributes": {"POSITION": pos, "JOINTS_0": jnt, "WEIGHTS_0": wgt},
                     "indices": idx, "mode": 4}
            if prim.get("extras"):
                gprim["extras"] = prim["extras"]
            prims.append(gprim)
        doc["meshes"] = [{"name": mesh["name"], "primitives": prims}]
        gnodes.append({"name": mesh["name"], "mesh": 0, "skin": 0})
        doc["scenes"][0]["nodes"].append(len(gnodes) - 1)
    ganims = []
    for anim in animations:
        times = [float(t) for t in anim["times"]]
        t_acc = buf.floats(times, "SCALAR", len(times), minmax=True)
        samplers, channels = [], []
        for ch in anim["channels"]:
            kind = "VEC4" if ch["path"] == "rotation" else "VEC3"
            v_acc = buf.floats(ch["values"], kind, len(times))
            samplers.append({"input": t_acc, "output": v_acc, "interpolation": "LINEAR"})
            channels.append({"sampler": len(samplers) - 1,
                             "target": {"node": ch["node"], "path": ch["path"]}})
        ganims.append({"name": anim["name"], "samplers": samplers, "channels": channels})
    if ganims:
        doc["animations"] = ganims
    while len(buf.data) % 4:
        buf.data.append(0)
    doc["buffers"] = [{"byteLength": len(buf.data)}]
    doc["bufferViews"] = buf.views
    doc["accessors"] = buf.accessors
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    total = 12 + 8 + len(text) + 8 + len(buf.data)
    with open(path, "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, total))
        f.write(struct.pack("<I4s", len(text), b"JSON") + text)
        f.write(struct.pack("<I4s", len(buf.data), b"BIN\x00") + bytes(buf.data))
