#!/usr/bin/env python3
"""MuJoCo MJCF model -> many-part skinned glTF 2.0 binary, for the surface corpus.

Usage: mjcf2parts.py [--groups G,G,...] MODEL.xml ROOT_BODY OUT.glb

The skeleton is mjcf2gltf.py's, unchanged (same nodes, same NAME_end nodes, same
OUT.joints.json). On it goes one skinned mesh, "parts": every kept geom of every body of
ROOT_BODY's subtree becomes one glTF primitive, a piece of its own (geoms are never welded
together; vertices are shared within a geom), skinned rigidly (weight 1) to its body's node.
Each primitive's extras name its body and geom. Vertex positions are the rest pose (qpos0) in
the model's world frame: Z-up, in the model's units (metres for every model here).

Which geoms are kept (the visual set):
  1. plane and hfield geoms (and any other type without a closed surface) are left out;
  2. only the geoms MuJoCo's viewer draws by default: group 0, 1 or 2 (--groups changes the
     set) and not fully transparent (alpha of the geom's rgba, else of its material's, > 0).
     Models put their collision duplicates in hidden groups (Shadow and Adroit hands:
     class D_Vizual meshes are group 1, class DC_Hand primitives group 4);
  3. if a body still has both visual-only geoms (contype = conaffinity = 0) and colliding
     ones, only the visual-only ones are kept (the colliding ones duplicate them);
  4. placeholders are left out: a geom whose bounding box diagonal is below 1% of the whole
     object's (the Shadow and Adroit thumbs' 2 mm boxes V_thbase and V_thhub).
--groups picks other groups than 0, 1, 2: dm-control's dog, which MuJoCo draws as a skin
with its bone meshes hidden, is converted with --groups 3, its collision primitives.

Mesh geoms: <asset><mesh file=... scale=...> (mesh default classes apply), found under
<compiler meshdir> (else assetdir, else the model's folder); binary or ASCII STL, OBJ (v and
f lines, polygons fan-triangulated) and MuJoCo's legacy .msh; inline vertex/face meshes.
Placement: a mesh's vertices, times its scale, are taken in the geom's frame as they are in
the file. MuJoCo does recentre every mesh on its centre of mass and turn it to its principal
axes of inertia, but it moves the geom's frame by the same offset, so the mesh is drawn
where the file puts it relative to the geom's pos/orientation (models are written that way:
dm-control's dog places every bone with a geom pos that undoes its body's offset). Checked on
the Shadow hand: with file coordinates every link meets its parent (gaps of 0.6 mm at
most); recentring the meshes on their centroids leaves the forearm over 2.8 cm (5% of the
diagonal) from every other piece, the knuckles off the palm and the wrist off the forearm.
Vertices are merged where their coordinates are equal (STL repeats every corner; .msh and
OBJ files may repeat corners for their normals), so a closed mesh file becomes a closed
mesh; triangles that then repeat a vertex are dropped. A piece with a negative signed volume
(wound inward) is flipped.

Primitive geoms (fromto honoured for capsule, cylinder, box and ellipsoid) are tessellated
into closed meshes wound outward: sphere and ellipsoid as UV spheres (16 around, 8 bands:
114 vertices), capsule 16 around with 4 bands per hemisphere plus 1 to 8 bands along its
body, about as long as the spacing around (130 to 242 vertices), cylinder the same with flat
caps holding one inner ring (66 to 178), box a grid of 4 cells along its longest side and as
many of that size as fit along the others (at most 98 vertices).
Prints one line: vertices, triangles, pieces, bodies with pieces, nodes.
Standard library only; deterministic.
"""

import math
import os
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gltf_skel as g  # noqa: E402
import mjcf2gltf as m  # noqa: E402

AROUND = 16          # vertices around a sphere, capsule or cylinder
SPHERE_BANDS = 8     # latitude bands of a sphere or ellipsoid
CAP_BANDS = 4        # latitude bands of a capsule's hemisphere
BOX_CELLS = 4        # grid cells along a box's longest side
BODY_RINGS = 8       # at most this many bands along a capsule or cylinder body
PLACEHOLDER = 0.01   # pieces smaller than this share of the object's diagonal are left out
DRAWN_GROUPS = (0, 1, 2)


# ---------------------------------------------------------------- mesh files

def read_stl(path):
    data = open(path, "rb").read()
    if len(data) >= 84:
        count = struct.unpack_from("<I", data, 80)[0]
        if len(data) == 84 + 50 * count:
            tris = []
            for i in range(count):
                v = struct.unpack_from("<9f", data, 84 + 50 * i + 12)
                tris.append((v[0:3], v[3:6], v[6:9]))
            return tris
    tris, corner = [], []
    for line in data.decode("latin-1").splitlines():
        words = line.split()
        if words and words[0] == "vertex":
            corner.append(tuple(float(w) for w in words[1:4]))
        elif words and words[0] == "endfacet":
            if len(corner) == 3:
                tris.append(tuple(corner))
            corner = []
    if not tris:
        sys.exit(f"mjcf2parts: {path}: not an STL file")
    return tris


def shared(tris):
    """Triangles as corner coordinates -> (vertices, index triples), equal corners merged."""
    index, verts, out = {}, [], []
    for tri in tris:
        ids = []
        for c in tri:
            k = index.get(c)
            if k is None:
                k = index[c] = len(verts)
                verts.append(c)
            ids.append(k)
        out.append(tuple(ids))
    return verts, out


def read_obj(path):
    verts, faces = [], []
    for line in open(path, encoding="latin-1"):
        words = line.split()
        if not words:
            continue
        if words[0] == "v":
            verts.append(tuple(float(w) for w in words[1:4]))
        elif words[0] == "f":
            ids = []
            for w in words[1:]:
                k = int(w.split("/")[0])
                ids.append(k - 1 if k > 0 else len(verts) + k)
            faces += [(ids[0], ids[i], ids[i + 1]) for i in range(1, len(ids) - 1)]
    return verts, faces


def read_msh(path):
    """MuJoCo's legacy binary mesh: 4 int32 counts, then vertices, normals, texcoords, faces."""
    data = open(path, "rb").read()
    nv, nn, nt, nf = struct.unpack_from("<4i", data, 0)
    off = 16
    v = struct.unpack_from(f"<{3 * nv}f", data, off)
    off += 4 * (3 * nv + 3 * nn + 2 * nt)
    f = struct.unpack_from(f"<{3 * nf}i", data, off)
    return ([tuple(v[3 * i:3 * i + 3]) for i in range(nv)],
            [tuple(f[3 * i:3 * i + 3]) for i in range(nf)])


def mesh_assets(sk):
    """name -> the <mesh> element's attributes (with its default class)."""
    out = {}
    for asset in sk.root.iter("asset"):
        for e in asset.findall("mesh"):
            attrs = sk.defaults.attrs(e, None)
            name = attrs.get("name") or \
                os.path.splitext(os.path.basename(attrs.get("file", "")))[0]
            out[name] = attrs
    return out


def mesh_dir(sk):
    base = os.path.dirname(os.path.abspath(sk.model))
    meshdir = assetdir = None
    for c in sk.root.iter("compiler"):
        meshdir = c.get("meshdir", meshdir)
        assetdir = c.get("assetdir", assetdir)
    return os.path.join(base, meshdir or assetdir or "")


def load_mesh(attrs, folder, cache):
    """A mesh asset's vertices (scaled, reference frame applied) and triangles."""
    key = (attrs.get("file"), attrs.get("vertex"), attrs.get("scale"), attrs.get("refpos"),
           attrs.get("refquat"))
    if key in cache:
        return cache[key]
    if attrs.get("file"):
        path = os.path.join(folder, attrs["file"])
        ext = os.path.splitext(path)[1].lower()
        if ext == ".stl":
            verts, faces = shared(read_stl(path))
        elif ext == ".obj":
            verts, faces = read_obj(path)
        elif ext == ".msh":
            verts, faces = read_msh(path)
        else:
            sys.exit(f"mjcf2parts: {path}: unsupported mesh format")
    elif attrs.get("vertex") and attrs.get("face"):
        v = m.floats(attrs["vertex"])
        f = [int(x) for x in attrs["face"].split()]
        verts = [tuple(v[i:i + 3]) for i in range(0, len(v) - 2, 3)]
        faces = [tuple(f[i:i + 3]) for i in range(0, len(f) - 2, 3)]
    else:
        sys.exit(f"mjcf2parts: mesh {attrs.get('name')!r}: no file and no vertex/face lists "
                 "(a convex hull of vertices alone is not supported)")
    # one vertex per position (.msh and OBJ files repeat corners for their normals)
    verts, faces = shared([tuple(verts[i] for i in f) for f in faces])
    s = m.floats(attrs.get("scale", "1 1 1"))
    verts = [(v[0] * s[0], v[1] * s[1], v[2] * s[2]) for v in verts]
    # Old MuJoCo's mesh reference frame: the file's coordinates relative to refpos/refquat.
    if attrs.get("refpos") or attrs.get("refquat"):
        rp = m.floats(attrs.get("refpos", "0 0 0"))
        w, x, y, z = m.floats(attrs.get("refquat", "1 0 0 0"))
        qi = g.quat_normalize((-x, -y, -z, w))
        verts = [g.quat_rotate(qi, (v[0] - rp[0], v[1] - rp[1], v[2] - rp[2])) for v in verts]
    faces = [f for f in faces if f[0] != f[1] and f[1] != f[2] and f[0] != f[2]]
    cache[key] = (verts, faces)
    return cache[key]


# ---------------------------------------------------------------- primitives

def revolve(profile, rx=1.0, ry=1.0):
    """A closed surface of revolution about z: profile [(rho, z)] from top to bottom, with
    rho = 0 at the two ends (poles); x and y scaled by rx, ry. Wound outward."""
    verts, rings = [], []
    for rho, z in profile:
        if rho == 0.0:
            rings.append([len(verts)])
            verts.append((0.0, 0.0, z))
            continue
        ring = []
        for j in range(AROUND):
            a = 2.0 * math.pi * j / AROUND
            ring.append(len(verts))
            verts.append((rx * rho * math.cos(a), ry * rho * math.sin(a), z))
        rings.append(ring)
    tris = []
    for top, bot in zip(rings, rings[1:]):
        for j in range(AROUND):
            j1 = (j + 1) % AROUND
            a, d = top[j % len(top)], top[j1 % len(top)]
            b, c = bot[j % len(bot)], bot[j1 % len(bot)]
            # quad a (top, j), b (bottom, j), c (bottom, j+1), d (top, j+1)
            if len(top) > 1:
                tris.append((a, b, d))
            if len(bot) > 1:
                tris.append((d, b, c))
    return verts, tris


def body_rings(r, half):
    """Rings between z = half and z = -half, about as far apart as the vertices around."""
    n = max(1, min(BODY_RINGS, round(2.0 * half / (2.0 * math.pi * r / AROUND))))
    return [half - 2.0 * half * i / n for i in range(n + 1)]


def sphere(a, b, c):
    prof = [(math.sin(math.pi * i / SPHERE_BANDS), math.cos(math.pi * i / SPHERE_BANDS))
            for i in range(SPHERE_BANDS + 1)]
    prof[0], prof[-1] = (0.0, 1.0), (0.0, -1.0)
    verts, tris = revolve(prof)
    return [(v[0] * a, v[1] * b, v[2] * c) for v in verts], tris


def capsule(r, half):
    angles = [0.5 * math.pi * i / CAP_BANDS for i in range(CAP_BANDS)]
    cap = [(r * math.sin(a), r * math.cos(a)) for a in angles]
    cap[0] = (0.0, r)
    prof = [(rho, half + z) for rho, z in cap]
    prof += [(r, z) for z in body_rings(r, half)]
    prof += [(rho, -half - z) for rho, z in reversed(cap)]
    return revolve(prof)


def cylinder(r, half):
    prof = [(0.0, half), (0.5 * r, half)]
    prof += [(r, z) for z in body_rings(r, half)]
    prof += [(0.5 * r, -half), (0.0, -half)]
    return revolve(prof)


def box(sx, sy, sz):
    size = (sx, sy, sz)
    step = 2.0 * max(size) / BOX_CELLS
    n = [max(1, min(BOX_CELLS, math.ceil(2.0 * s / step - 1e-9))) for s in size]
    index, verts, tris = {}, [], []

    def vid(ijk):
        k = index.get(ijk)
        if k is None:
            k = index[ijk] = len(verts)
            verts.append(tuple(-size[a] + 2.0 * size[a] * ijk[a] / n[a] for a in range(3)))
        return k

    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3  # (u, v, axis) is right-handed
        for side in (0, n[axis]):
            for i in range(n[u]):
                for j in range(n[v]):
                    q = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        ijk = [0, 0, 0]
                        ijk[axis], ijk[u], ijk[v] = side, i + di, j + dj
                        q.append(vid(tuple(ijk)))
                    if side == 0:  # outward is -axis: reverse
                        q.reverse()
                    tris += [(q[0], q[1], q[2]), (q[0], q[2], q[3])]
    return verts, tris


# ---------------------------------------------------------------- geoms

def alpha(attrs, materials):
    if attrs.get("rgba"):
        v = m.floats(attrs["rgba"])
        return v[3] if len(v) > 3 else 1.0
    mat = materials.get(attrs.get("material"))
    if mat is not None and mat.get("rgba"):
        v = m.floats(mat["rgba"])
        return v[3] if len(v) > 3 else 1.0
    return 1.0


def frame(attrs, compiler):
    """The geom's frame in its body (t, q) and, for fromto, the half length along its z."""
    if attrs.get("fromto"):
        v = m.floats(attrs["fromto"])
        a, b = v[0:3], v[3:6]
        d = [b[i] - a[i] for i in range(3)]
        length = math.sqrt(sum(c * c for c in d))
        mid = tuple(0.5 * (a[i] + b[i]) for i in range(3))
        q = compiler.orientation({"zaxis": " ".join(repr(c) for c in d)}) if length > 0 \
            else (0.0, 0.0, 0.0, 1.0)
        return (mid, q), 0.5 * length
    return (tuple(m.floats(attrs.get("pos", "0 0 0"))), compiler.orientation(attrs)), None


def geom_shape(attrs, compiler, meshes, folder, cache):
    """(vertices in the body's frame, triangles) of a geom, or None if it has no surface."""
    kind = attrs.get("type", "sphere")
    size = m.floats(attrs.get("size", "0 0 0")) + [0.0, 0.0, 0.0]
    tr, half = frame(attrs, compiler)
    if kind == "mesh":
        name = attrs.get("mesh")
        if name not in meshes:
            sys.exit(f"mjcf2parts: geom {attrs.get('name')!r}: no mesh asset {name!r}")
        verts, tris = load_mesh(meshes[name], folder, cache)
    elif kind == "sphere":
        verts, tris = sphere(size[0], size[0], size[0])
    elif kind == "ellipsoid":
        verts, tris = sphere(size[0], size[1], size[2] if half is None else half)
    elif kind == "capsule":
        verts, tris = capsule(size[0], size[1] if half is None else half)
    elif kind == "cylinder":
        verts, tris = cylinder(size[0], size[1] if half is None else half)
    elif kind == "box":
        verts, tris = box(size[0], size[1], size[2] if half is None else half)
    else:  # plane, hfield, sdf: no closed surface of their own
        return None
    verts = [g.compose(tr, (v, (0.0, 0.0, 0.0, 1.0)))[0] for v in verts]
    return verts, list(tris)


def signed_volume(verts, tris):
    s = 0.0
    for a, b, c in tris:
        p, q, r = verts[a], verts[b], verts[c]
        s += (p[0] * (q[1] * r[2] - q[2] * r[1]) - p[1] * (q[0] * r[2] - q[2] * r[0])
              + p[2] * (q[0] * r[1] - q[1] * r[0]))
    return s / 6.0


def parts(sk, groups=DRAWN_GROUPS):
    """The kept geoms as [(body node index, body name, geom name, world vertices, tris)]."""
    materials = {}
    for asset in sk.root.iter("asset"):
        for e in asset.findall("material"):
            materials[e.get("name")] = sk.defaults.attrs(e, None)
    meshes = mesh_assets(sk)
    folder = mesh_dir(sk)
    cache = {}
    world = []
    for n in sk.nodes:
        local = (tuple(n["t"]), g.quat_normalize(n["r"]))
        world.append(local if n["parent"] is None else g.compose(world[n["parent"]], local))
    pieces = []
    for body, node in sk.bodies:
        drawn = []
        for k, geom in enumerate(body.findall("geom")):
            attrs = sk.defaults.attrs(geom, sk.childclass_of(body))
            if attrs.get("type", "sphere") in ("plane", "hfield", "sdf"):
                continue
            if int(attrs.get("group", "0")) not in groups or alpha(attrs, materials) <= 0.0:
                continue
            drawn.append((k, attrs))
        visual = [d for d in drawn
                  if attrs_int(d[1], "contype", 1) == 0 and attrs_int(d[1], "conaffinity", 1) == 0]
        if visual and len(visual) < len(drawn):
            drawn = visual
        for k, attrs in drawn:
            shape = geom_shape(attrs, sk.compiler, meshes, folder, cache)
            if shape is None:
                continue
            verts, tris = shape
            if signed_volume(verts, tris) < 0.0:
                tris = [(a, c, b) for a, b, c in tris]
            verts = [g.compose(world[node], (v, (0.0, 0.0, 0.0, 1.0)))[0] for v in verts]
            name = attrs.get("name") or f"{sk.nodes[node]['name']}/geom{k}"
            pieces.append((node, sk.nodes[node]["name"], name, verts, tris))
    # Placeholders: pieces far smaller than the object.
    lo = [min(v[a] for p in pieces for v in p[3]) for a in range(3)]
    hi = [max(v[a] for p in pieces for v in p[3]) for a in range(3)]
    diag = math.dist(lo, hi)
    kept = []
    for p in pieces:
        plo = [min(v[a] for v in p[3]) for a in range(3)]
        phi = [max(v[a] for v in p[3]) for a in range(3)]
        if math.dist(plo, phi) >= PLACEHOLDER * diag:
            kept.append(p)
    return kept


def attrs_int(attrs, key, default):
    return int(attrs.get(key, str(default)))


def convert(model, root_name, out, groups=DRAWN_GROUPS):
    sk = m.skeleton(model, root_name, tool="mjcf2parts")
    pieces = parts(sk, groups)
    if not pieces:
        sys.exit(f"mjcf2parts: {model}: no visible geom under body {root_name!r}")
    prims = []
    for node, body, geom, verts, tris in pieces:
        prims.append({"positions": verts, "joints": [(node, 0, 0, 0)] * len(verts),
                      "weights": [(1.0, 0.0, 0.0, 0.0)] * len(verts),
                      "indices": [i for t in tris for i in t],
                      "extras": {"body": body, "geom": geom}})
    sidecar = m.write(out, sk, "rigfit scripts/corpus/mjcf2parts.py",
                      mesh={"name": "parts", "primitives": prims})
    nv = sum(len(p[3]) for p in pieces)
    nt = sum(len(p[4]) for p in pieces)
    nb = len({p[0] for p in pieces})
    print(f"{out}: {nv} vertices, {nt} triangles, {len(pieces)} pieces on {nb} bodies; "
          f"{len(sk.nodes)} nodes ({sk.ends} end nodes) from body {root_name!r} of {model}; "
          f"{len(sk.specs)} joints in {sidecar}")


if __name__ == "__main__":
    args = sys.argv[1:]
    groups = DRAWN_GROUPS
    if args and args[0].startswith("--groups"):
        value = args[0].split("=", 1)[1] if "=" in args[0] else args.pop(1)
        groups = tuple(int(x) for x in value.split(","))
        args = args[1:]
    if len(args) != 3:
        sys.exit(__doc__.strip().splitlines()[2])
    convert(*args, groups=groups)
