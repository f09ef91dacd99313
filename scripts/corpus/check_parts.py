#!/usr/bin/env python3
"""Checks the many-part surface corpus against its manifest (data/surface_corpus.json).

Usage: check_parts.py CORPUS_DIR [--rigfit BIN] [--manifest FILE] [--update] [--only ID,...]
                      [--pieces]

For every object: the file exists, `rigfit info FILE` reads it (skin joints, and the mesh's
vertices and triangles), and its pieces (glTF primitives: one per MuJoCo geom), components
(connected triangles: a mesh file may hold several shells, so these can exceed the pieces),
vertices, triangles and joints are the manifest's.
It also measures how the pieces sit together in the rest pose, in % of the bounding-box
diagonal: each piece's distance to the nearest other piece (median and largest); a piece
more than 5% from every other piece is listed and fails the check (a placement bug, or a
part that really floats). The same per body (all its pieces) against its parent's pieces
(the nearest body above with pieces): a body more than 5% from them is listed, for
information (models may leave gaps, e.g. a head over a neck).
Distances are between points sampled on the surfaces every 0.2% of the diagonal, and pairs
of grid cells that cannot bring two pieces closer by more than that are skipped: touching
or crossing pieces measure up to about 0.2%, and a gap is within about 0.4% of the truth.
--update writes the measured counts into the manifest instead of comparing them; --only
checks the listed objects; --pieces prints every piece's gaps.
Standard library only.
"""

import argparse
import json
import math
import os
import re
import struct
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
SPACING = 0.002   # sample spacing, share of the diagonal
FLOATING = 0.05   # a piece farther than this share of the diagonal from all others floats
KEYS = ("pieces", "components", "vertices", "triangles", "joints")


def read_pieces(path):
    """[(name, vertices [(x, y, z)], triangles [(a, b, c)], body)], one per primitive of the
    first mesh, positions as stored (the rest pose); and {node name: parent node name}."""
    data = open(path, "rb").read()
    n = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + n])
    binary = data[20 + n + 8:]

    def accessor(i, fmt, width, group):
        acc = doc["accessors"][i]
        view = doc["bufferViews"][acc["bufferView"]]
        start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        values = struct.unpack_from(f"<{acc['count'] * width}{fmt}", binary, start)
        return [values[k:k + group] for k in range(0, len(values), group)]

    out = []
    for k, prim in enumerate(doc["meshes"][0]["primitives"]):
        verts = accessor(prim["attributes"]["POSITION"], "f", 3, 3)
        tris = accessor(prim["indices"], {5125: "I", 5123: "H"}[
            doc["accessors"][prim["indices"]]["componentType"]], 1, 3)
        extras = prim.get("extras", {})
        out.append((extras.get("geom", f"primitive{k}"), verts, tris, extras.get("body")))
    nodes = doc["nodes"]
    parent = {nodes[c].get("name"): n.get("name") for n in nodes for c in n.get("children", [])}
    return out, parent


def body_groups(pieces, parent):
    """Each piece's body as a group number, and per body group the group of the nearest body
    above it that has pieces (an empty list at the top)."""
    bodies = []
    for p in pieces:
        if p[3] not in bodies:
            bodies.append(p[3])
    group_of = [bodies.index(p[3]) for p in pieces]
    partners = []
    for b in bodies:
        a = parent.get(b)
        while a is not None and a not in bodies:
            a = parent.get(a)
        partners.append([] if a is None else [bodies.index(a)])
    return group_of, partners, bodies


def components(pieces):
    parent = {}

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for k, (_, verts, tris, _) in enumerate(pieces):
        for i in range(len(verts)):
            parent[(k, i)] = (k, i)
        for a, b, c in tris:
            for u, v in ((a, b), (b, c)):
                ru, rv = find((k, u)), find((k, v))
                if ru != rv:
                    parent[ru] = rv
    return len({find(x) for x in parent})


def samples(verts, tris, s):
    """Points on the surface no farther than s from any surface point: the vertices and the
    midpoints made by halving each triangle at its longest edge until no edge exceeds s."""
    pts = list(verts)
    for a, b, c in tris:
        stack = [(verts[a], verts[b], verts[c])]
        while stack:
            p, q, r = stack.pop()
            e = [(math.dist(p, q), 0), (math.dist(q, r), 1), (math.dist(r, p), 2)]
            longest, i = max(e)
            if longest <= s:
                continue
            p, q, r = ((p, q, r), (q, r, p), (r, p, q))[i]  # longest edge p-q
            m = ((p[0] + q[0]) / 2, (p[1] + q[1]) / 2, (p[2] + q[2]) / 2)
            pts.append(m)
            stack += [(p, m, r), (m, q, r)]
    return pts


def sampled(pieces):
    """The diagonal, the sample spacing, and each piece's surface samples."""
    allv = [v for p in pieces for v in p[1]]
    lo = [min(v[d] for v in allv) for d in range(3)]
    hi = [max(v[d] for v in allv) for d in range(3)]
    diag = math.dist(lo, hi)
    s = SPACING * diag
    return diag, s, [samples(verts, tris, s) for _, verts, tris, _ in pieces]


def gaps(surf, group_of, partners=None):
    """Per group of pieces (group_of[k]: piece k's group, 0 ... n-1): the distance to the
    nearest piece of another group (of the groups partners[g] only, if given), None beyond
    FLOATING times the diagonal, NaN if partners[g] is empty."""
    diag, s, pts_of = surf
    h = 4.0 * s
    n = max(group_of) + 1
    cells = {}                       # cell -> {group: [points]}
    mine = [set() for _ in range(n)]  # group -> its cells
    box = [None] * n                 # group -> bounding box of its samples
    for k, pts in enumerate(pts_of):
        g = group_of[k]
        for p in pts:
            c = (math.floor(p[0] / h), math.floor(p[1] / h), math.floor(p[2] / h))
            cells.setdefault(c, {}).setdefault(g, []).append(p)
            mine[g].add(c)
        lo = [min(p[d] for p in pts) for d in range(3)]
        hi = [max(p[d] for p in pts) for d in range(3)]
        if box[g] is not None:
            lo = [min(a, b) for a, b in zip(lo, box[g][0])]
            hi = [max(a, b) for a, b in zip(hi, box[g][1])]
        box[g] = (lo, hi)
    extent = {}  # (cell, group) -> the bounding box of its points
    for c, groups in cells.items():
        for g, pts in groups.items():
            extent[c, g] = (tuple(min(p[d] for p in pts) for d in range(3)),
                            tuple(max(p[d] for p in pts) for d in range(3)))

    def to_box(c, b):
        """Squared distance from cell c to box b, at least."""
        d = 0.0
        for a in range(3):
            lo, hi = c[a] * h, (c[a] + 1) * h
            gap = max(b[0][a] - hi, lo - b[1][a], 0.0)
            d += gap * gap
        return d

    rings = math.ceil(FLOATING * diag / h) + 1
    limit = (FLOATING * diag) ** 2
    result = []
    for g in range(n):
        allowed = set(range(n)) - {g} if partners is None else set(partners[g]) - {g}
        if not allowed:
            result.append(math.nan)  # nothing to measure against
            continue
        targets = [box[a] for a in allowed]
        # cells of ours that could be within reach of the allowed groups at all
        near = [c for c in mine[g] if min(to_box(c, b) for b in targets) <= limit]
        best = math.inf  # squared
        for r in range(rings + 1):
            if not near:
                break
            offsets = [(i, j, l) for i in range(-r, r + 1) for j in range(-r, r + 1)
                       for l in range(-r, r + 1) if max(abs(i), abs(j), abs(l)) == r]
            # the least distance between points of two cells this far apart
            bounds = [sum(max(0, abs(c) - 1) ** 2 for c in o) * h * h for o in offsets]
            for c in near:
                ours = None
                for o, bound in zip(offsets, bounds):
                    if bound >= best:
                        continue
                    c2 = (c[0] + o[0], c[1] + o[1], c[2] + o[2])
                    other = cells.get(c2)
                    if not other:
                        continue
                    for group, pts in other.items():
                        if group not in allowed:
                            continue
                        # skip a pair of cells that cannot come closer by more than s
                        ea, eb = extent[c, g], extent[c2, group]
                        lb = math.sqrt(sum(max(eb[0][d] - ea[1][d], ea[0][d] - eb[1][d], 0.0)
                                           ** 2 for d in range(3)))
                        if lb >= math.sqrt(best) - s:
                            continue
                        if ours is None:
                            ours = cells[c][g]
                        for p in ours:
                            for q in pts:
                                d = ((p[0] - q[0]) ** 2 + (p[1] - q[1]) ** 2
                                     + (p[2] - q[2]) ** 2)
                                if d < best:
                                    best = d
                    if best <= s * s:
                        break  # touching, as far as the samples can tell
                if best <= s * s:
                    break
            if best <= (r * h) ** 2 or best <= s * s:
                break
        d = math.sqrt(best)
        result.append(d if d <= FLOATING * diag else None)
    return result


def stats(values):
    """Median and largest of the measured distances (None: beyond FLOATING, counted as
    such; NaN: not measured)."""
    got = sorted(math.inf if d is None else d for d in values if d is None or d == d)
    if not got:
        return math.nan, math.nan
    return got[len(got) // 2], got[-1]


def pct(d, diag):
    if d is None:
        return "FLOATING"
    return "-" if d != d else f"{100 * d / diag:.2f}%"


def info(rigfit, path):
    run = subprocess.run([rigfit, "info", path], capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError((run.stderr or run.stdout).strip())
    text = run.stdout
    joints = int(re.search(r"^joints: \d+ \((\d+) skin joints", text, re.M).group(1))
    m = re.search(r"^  \S.*: (\d+) vertices, (\d+) triangles, skinned", text, re.M)
    if not m:
        raise RuntimeError("rigfit info shows no skinned mesh")
    return {"joints": joints, "vertices": int(m.group(1)), "triangles": int(m.group(2))}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("corpus")
    ap.add_argument("--rigfit", default=os.path.join(REPO, "target", "release", "rigfit"))
    ap.add_argument("--manifest", default=os.path.join(REPO, "data", "surface_corpus.json"))
    ap.add_argument("--update", action="store_true")
    ap.add_argument("--only", default="")
    ap.add_argument("--pieces", action="store_true", help="print every piece's gap")
    args = ap.parse_args()
    manifest = json.load(open(args.manifest))
    only = set(filter(None, args.only.split(",")))
    problems = 0
    for obj in manifest["rigs"]:
        if only and obj["id"] not in only:
            continue
        path = os.path.join(args.corpus, obj["file"])
        try:
            got = info(args.rigfit, path)
            pieces, parent = read_pieces(path)
        except (RuntimeError, OSError) as e:
            print(f"{obj['id']}: FAILED: {e}")
            problems += 1
            continue
        got["pieces"] = len(pieces)
        got["components"] = comps = components(pieces)
        surf = sampled(pieces)
        diag = surf[0]
        near = gaps(surf, list(range(len(pieces))))
        floating = [pieces[k][0] for k, d in enumerate(near) if d is None]
        median, worst = stats(near)
        group_of, partners, bodies = body_groups(pieces, parent)
        up = gaps(surf, group_of, partners)
        apart = [bodies[b] for b, d in enumerate(up) if d is None]
        up_median, up_worst = stats(up)
        if args.pieces:
            for k, ((name, verts, _, body), d) in enumerate(zip(pieces, near)):
                print(f"    {name:36} on {body:28} {len(verts):6} vertices  gap "
                      f"{pct(d, diag):>8}  body to its parent {pct(up[group_of[k]], diag):>8}")
        if args.update:
            for key in KEYS:
                obj[key] = got[key]
        else:
            for key in KEYS:
                if obj[key] != got[key]:
                    print(f"{obj['id']}: {key} {got[key]}, manifest says {obj[key]}")
                    problems += 1
        if floating:
            problems += 1
        print(f"{obj['id']:24} {obj['half']:9} {obj['kind']:9} pieces {got['pieces']:4} "
              f"components {comps:4} vertices {got['vertices']:6} triangles "
              f"{got['triangles']:6} joints {got['joints']:3} diagonal {diag:.4g} "
              f"gap median {100 * median / diag:.2f}% max {100 * worst / diag:.2f}%, "
              f"body to parent median {100 * up_median / diag:.2f}% max "
              f"{100 * up_worst / diag:.2f}%"
              + (f"  FLOATING (> {100 * FLOATING:.0f}%): {', '.join(floating)}"
                 if floating else "")
              + (f"  bodies far from their parent (> {100 * FLOATING:.0f}%): "
                 f"{', '.join(apart)}" if apart else ""))
    if args.update:
        with open(args.manifest, "w") as f:
            f.write(json.dumps(manifest, indent=2, ensure_ascii=False) + "\n")
    if problems:
        sys.exit(f"check_parts.py: {problems} problem(s)")


if __name__ == "__main__":
    main()
