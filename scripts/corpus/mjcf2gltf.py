#!/usr/bin/env python3
"""MuJoCo MJCF model -> skeleton-only glTF 2.0 binary, for the rig corpus.

Usage: mjcf2gltf.py MODEL.xml ROOT_BODY OUT.glb

Every body of the subtree under ROOT_BODY becomes a node, with the body's frame (pos and
orientation: quat, axisangle, euler, xyaxes or zaxis, as MuJoCo's compiler reads them) as
its translation and rotation; the root node carries the root body's full world placement.
A leaf body whose geoms reach away from its origin gets one child node NAME_end at the geom
point farthest from it (like a BVH End Site), so the last bone of a chain has a length; mesh
geoms count only in a body with no other geom (a mesh geom's pos is its file's frame).
The skin lists every node. Axes and units are kept as found: MuJoCo is Z-up, in metres.
The pose is MuJoCo's qpos0 (the model as written); MJCF holds no animation.
Beside OUT.glb, OUT.joints.json (rigfit's joints file, `rigfit pose --joints`) says what
each body's MuJoCo joints let it do: none (welded) is fixed, one hinge a hinge about its
axis with its range, several hinges or a ball a ball bounded per axis, a slide joint
translates (free, with the rotation its hinges allow, and its translation within the box
its slides' ranges sweep from the rest position). Ranges become radians.
Standard library only; deterministic.
"""

import json
import math
import os
import sys
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gltf_skel as g  # noqa: E402


def load(path):
    """The model with every <include> replaced by the included file's children."""
    base = os.path.dirname(os.path.abspath(path))

    def expand(elem):
        out = []
        for child in list(elem):
            if child.tag == "include":
                inc = ET.parse(os.path.join(base, child.get("file"))).getroot()
                expand(inc)
                out.extend(list(inc))
            else:
                expand(child)
                out.append(child)
        for child in list(elem):
            elem.remove(child)
        elem.extend(out)

    root = ET.parse(path).getroot()
    expand(root)
    return root


def floats(text):
    return [float(v) for v in text.split()]


class Compiler:
    def __init__(self, root):
        self.radian = False
        self.eulerseq = "xyz"
        for c in root.iter("compiler"):
            if c.get("angle"):
                self.radian = c.get("angle") == "radian"
            if c.get("eulerseq"):
                self.eulerseq = c.get("eulerseq")

    def angle(self, a):
        return a if self.radian else math.radians(a)

    def orientation(self, e):
        """The orientation of a body or geom element as an (x, y, z, w) quaternion."""
        if e.get("quat"):
            w, x, y, z = floats(e.get("quat"))
            return g.quat_normalize((x, y, z, w))
        if e.get("axisangle"):
            x, y, z, a = floats(e.get("axisangle"))
            return g.quat_normalize(g.quat_axis_angle((x, y, z), self.angle(a)))
        if e.get("euler"):
            q = (0.0, 0.0, 0.0, 1.0)
            for axis, a in zip(self.eulerseq, floats(e.get("euler"))):
                v = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}[axis.lower()]
                r = g.quat_axis_angle(v, self.angle(a))
                # lower case: axes that move with the frame (intrinsic); upper: fixed axes.
                q = g.quat_mul(q, r) if axis.islower() else g.quat_mul(r, q)
            return g.quat_normalize(q)
        if e.get("xyaxes"):
            v = floats(e.get("xyaxes"))
            x = unit(v[0:3])
            y = v[3:6]
            d = sum(a * b for a, b in zip(x, y))
            y = unit([y[i] - d * x[i] for i in range(3)])
            z = cross(x, y)
            return g.quat_from_matrix([[x[0], y[0], z[0]], [x[1], y[1], z[1]], [x[2], y[2], z[2]]])
        if e.get("zaxis"):
            z = unit(floats(e.get("zaxis")))
            c = z[2]
            axis = cross((0.0, 0.0, 1.0), z)
            if math.sqrt(sum(a * a for a in axis)) < 1e-12:
                return (0.0, 0.0, 0.0, 1.0) if c > 0 else (1.0, 0.0, 0.0, 0.0)
            return g.quat_normalize(g.quat_axis_angle(axis, math.acos(max(-1.0, min(1.0, c)))))
        return (0.0, 0.0, 0.0, 1.0)


def unit(v):
    n = math.sqrt(sum(a * a for a in v))
    return [a / n for a in v]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


class Defaults:
    """MJCF default classes (nested, inheriting), as far as geoms need them."""

    def __init__(self, root):
        self.classes = {}
        for d in root.findall("default"):
            self._walk(d, {})

    def _walk(self, d, inherited):
        name = d.get("class", "main")
        mine = {k: dict(v) for k, v in inherited.items()}
        for child in d:
            if child.tag != "default":
                mine.setdefault(child.tag, {}).update(child.attrib)
        self.classes[name] = mine
        for child in d.findall("default"):
            self._walk(child, mine)

    def attrs(self, elem, childclass):
        cls = elem.get("class") or childclass or "main"
        out = dict(self.classes.get(cls, {}).get(elem.tag, {}))
        out.update(elem.attrib)
        return out


def geom_points(attrs, compiler):
    """Points of a geom in its body's frame that may stick out: segment ends or its centre."""
    if attrs.get("fromto"):
        v = floats(attrs["fromto"])
        return [tuple(v[0:3]), tuple(v[3:6])]
    pos = tuple(floats(attrs.get("pos", "0 0 0")))
    kind = attrs.get("type", "sphere")
    size = floats(attrs.get("size", "0"))
    if kind in ("capsule", "cylinder") and len(size) >= 2:
        q = compiler.orientation(ET.Element("geom", {k: v for k, v in attrs.items()
                                                     if k in ("quat", "axisangle", "euler",
                                                              "xyaxes", "zaxis")}))
        a = g.quat_rotate(q, (0.0, 0.0, size[1]))
        return [tuple(pos[i] + a[i] for i in range(3)), tuple(pos[i] - a[i] for i in range(3))]
    return [pos]


def joint_spec(body, defaults, childclass, compiler):
    """What a body's MuJoCo joints let it do, as a joints-file entry (None for a free joint:
    the root's placement is not the rig's to limit)."""
    hinges, slides, balls = [], [], []
    for j in body.findall("joint"):
        a = defaults.attrs(j, childclass)
        kind = a.get("type", "hinge")
        rng = floats(a["range"]) if a.get("range") else None
        limited = a.get("limited", "auto")
        if limited == "false" or (limited == "auto" and rng is None):
            rng = None
        if kind == "hinge":
            axis = unit(floats(a.get("axis", "0 0 1")))
            lim = None if rng is None else (compiler.angle(rng[0]), compiler.angle(rng[1]))
            hinges.append((axis, lim))
        elif kind == "slide":
            slides.append((unit(floats(a.get("axis", "0 0 1"))), rng))
        elif kind == "ball":
            balls.append(None if rng is None else compiler.angle(rng[1]))
        elif kind == "free":
            return None
    if body.find("freejoint") is not None:
        return None
    if not hinges and not slides and not balls:
        return {"dof": "fixed"}
    if balls:
        spec = {"dof": "ball"}
        if balls[0] is not None:
            spec["min"] = [-balls[0]] * 3
            spec["max"] = [balls[0]] * 3
        return spec
    if len(hinges) == 1 and not slides:
        axis, lim = hinges[0]
        spec = {"dof": "hinge", "axis": [round(v, 9) for v in axis]}
        if lim is not None:
            spec["min"], spec["max"] = lim
        return spec
    # Several hinges (or slides): a ball (or free) joint bounded per axis by the sum of what
    # each hinge can turn about it; unlimited hinges leave their axes free.
    lo, hi = [0.0] * 3, [0.0] * 3
    for axis, lim in hinges:
        for c in range(3):
            if lim is None:
                if abs(axis[c]) > 1e-9:
                    lo[c], hi[c] = -math.pi, math.pi
                continue
            ends = (axis[c] * lim[0], axis[c] * lim[1])
            lo[c] += min(ends)
            hi[c] += max(ends)
    spec = {"dof": "free" if slides else "ball"}
    spec["min"] = [round(max(v, -math.pi), 9) for v in lo]
    spec["max"] = [round(min(v, math.pi), 9) for v in hi]
    # Slides bound the translation (from the body's rest position, in the model's units) to
    # the box their ranges sweep; an unlimited slide leaves it unbounded.
    # The rest position (every slide at 0, as the file places the body) is always inside.
    if slides and all(rng is not None for _, rng in slides):
        tlo, thi = [0.0] * 3, [0.0] * 3
        for axis, rng in slides:
            for c in range(3):
                ends = (axis[c] * min(rng[0], 0.0), axis[c] * max(rng[1], 0.0))
                tlo[c] += min(ends)
                thi[c] += max(ends)
        spec["translation"] = {"min": [round(v, 9) for v in tlo],
                               "max": [round(v, 9) for v in thi]}
    return spec


class Skeleton:
    """What `skeleton` reads from a model: the parsed model (root, compiler, defaults), the
    glTF nodes, the joints-file entries, and which node each body of the subtree became."""

    def __init__(self, **fields):
        self.__dict__.update(fields)


def skeleton(model, root_name, tool="mjcf2gltf"):
    root = load(model)
    compiler = Compiler(root)
    defaults = Defaults(root)
    parent_of = {c: p for p in root.iter() for c in p}
    start = None
    for b in root.iter("body"):
        if b.get("name") == root_name:
            start = b
            break
    if start is None:
        sys.exit(f"{tool}: {model}: no body named {root_name!r}")

    def local(b):
        return (tuple(floats(b.get("pos", "0 0 0"))), compiler.orientation(b))

    # The root's placement in the world: its own frame after every body above it.
    placement = local(start)
    up = parent_of.get(start)
    while up is not None and up.tag == "body":
        placement = g.compose(local(up), placement)
        up = parent_of.get(up)

    def childclass_of(b):
        e = b
        while e is not None:
            if e.get("childclass"):
                return e.get("childclass")
            e = parent_of.get(e)
        return None

    nodes = []
    specs = {}
    bodies = []  # (body element, its node index), in node order
    ends = 0

    def visit(b, parent, tr):
        nonlocal ends
        index = len(nodes)
        name = b.get("name") or f"body{index}"
        nodes.append({"name": name, "parent": parent, "t": tr[0], "r": tr[1]})
        bodies.append((b, index))
        if parent is not None:
            spec = joint_spec(b, defaults, childclass_of(b), compiler)
            if spec is not None:
                specs[name] = spec
        kids = b.findall("body")
        for k in kids:
            visit(k, index, local(k))
        if not kids:
            # A mesh geom's pos places the mesh file's frame, often far from the geometry
            # (the dog's toe meshes sit 0.55 m from their pos): the body's other geoms say
            # where it reaches, and a mesh's pos only when it has nothing else.
            geoms = [defaults.attrs(geom, childclass_of(b)) for geom in b.findall("geom")]
            placed = [a for a in geoms if a.get("type", "sphere") != "mesh"] or geoms
            best, far = None, 1e-4
            for attrs in placed:
                for p in geom_points(attrs, compiler):
                    d = math.sqrt(sum(c * c for c in p))
                    if d > far:
                        best, far = p, d
            if best is not None:
                nodes.append({"name": f"{name}_end", "parent": index, "t": best,
                              "r": (0.0, 0.0, 0.0, 1.0)})
                ends += 1

    visit(start, None, placement)
    return Skeleton(model=model, root_name=root_name, root=root, compiler=compiler,
                    defaults=defaults, childclass_of=childclass_of, nodes=nodes, specs=specs,
                    bodies=bodies, ends=ends)


def write(out, sk, generator, mesh=None):
    """OUT.glb (the nodes, and the mesh if any) and its OUT.joints.json; returns the latter."""
    g.write_glb(out, sk.nodes, generator=generator, mesh=mesh)
    sidecar = os.path.splitext(out)[0] + ".joints.json"
    with open(sidecar, "w") as f:
        json.dump({"joints": sk.specs}, f, indent=1, sort_keys=True)
        f.write("\n")
    return sidecar


def convert(model, root_name, out):
    sk = skeleton(model, root_name)
    sidecar = write(out, sk, "rigfit scripts/corpus/mjcf2gltf.py")
    print(f"{out}: {len(sk.nodes)} nodes ({sk.ends} end nodes) from body {root_name!r} of "
          f"{model}; {len(sk.specs)} joints in {sidecar}")


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__.strip().splitlines()[2])
    convert(*sys.argv[1:])
