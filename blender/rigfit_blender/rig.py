"""Blender armatures as rigfit skeletons, and strokes as curve objects.

rigfit works in a Y-up world (glTF, BVH); Blender's is Z-up. `Y_UP` maps Blender world
coordinates into rigfit's: (x, y, z) -> (x, z, -y). A skeleton gets one helper joint for the
armature object (its world matrix, fixed), a joint at the head of every bone, and a fixed end
site at the tail of every bone with no children, so leaf bones have a length to match.
"""

from __future__ import annotations

import bpy
import numpy as np
from mathutils import Matrix, Quaternion, Vector

Y_UP = Matrix(((1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0), (0.0, -1.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)))
Z_UP = Y_UP.inverted()

STROKES_COLLECTION = "rigfit strokes"
TAIL_SUFFIX = ".tail"


def _trs(m: Matrix) -> tuple[list[float], list[float], list[float]]:
    """Translation, quaternion [x, y, z, w] and scale of a 4x4 matrix."""
    t, q, s = m.decompose()
    return [t.x, t.y, t.z], [q.x, q.y, q.z, q.w], [s.x, s.y, s.z]


class ArmatureSkeleton:
    """The rigfit skeleton of one armature, with the matrices to go back to pose bones."""

    def __init__(self, arm: bpy.types.Object):
        import rigfit

        self.arm = arm
        bones = list(arm.data.bones)
        self.bone_names = [b.name for b in bones]
        index = {b.name: i + 1 for i, b in enumerate(bones)}
        names = [arm.name]
        parents = [-1]
        rest = [Y_UP @ arm.matrix_world]
        end_sites = [False]
        helpers = [True]
        self.rest_local: list[Matrix] = []
        for b in bones:
            local = b.matrix_local if b.parent is None else b.parent.matrix_local.inverted() @ b.matrix_local
            self.rest_local.append(local)
            names.append(b.name)
            parents.append(index[b.parent.name] if b.parent else 0)
            rest.append(local)
            end_sites.append(False)
            helpers.append(False)
        for b in bones:
            if not b.children:
                names.append(b.name + TAIL_SUFFIX)
                parents.append(index[b.name])
                rest.append(Matrix.Translation((0.0, b.length, 0.0)))
                end_sites.append(True)
                helpers.append(False)
        trs = [_trs(m) for m in rest]
        self.skeleton = rigfit.Skeleton(
            names,
            parents,
            np.array([t for t, _, _ in trs]),
            np.array([q for _, q, _ in trs]),
            np.array([s for _, _, s in trs]),
            end_sites=end_sites,
            helpers=helpers,
        )
        self.rest_translations = self.skeleton.rest_translations
        self.rest_rotations = self.skeleton.rest_rotations

    def current_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Local rotations and translations of the armature's current pose."""
        rotations = self.rest_rotations.copy()
        translations = self.rest_translations.copy()
        for i, name in enumerate(self.bone_names):
            local = self.rest_local[i] @ self.arm.pose.bones[name].matrix_basis
            t, q, _ = _trs(local)
            rotations[i + 1] = q
            translations[i + 1] = t
        return rotations, translations

    def apply(self, rotations: np.ndarray, translations: np.ndarray) -> None:
        """Sets the pose bones from local rotations and translations. When the armature has
        several root bones the solver moves the armature's helper joint; that motion goes
        into the root bones (the object itself stays where it is)."""

        def matrix(i: int, scale=None) -> Matrix:
            x, y, z, w = rotations[i]
            return Matrix.LocRotScale(Vector(translations[i]), Quaternion((w, x, y, z)), scale)

        helper_rest = Y_UP @ self.arm.matrix_world
        _, _, scale = helper_rest.decompose()
        helper_motion = helper_rest.inverted() @ matrix(0, scale)
        for i, name in enumerate(self.bone_names):
            local = matrix(i + 1)
            if self.arm.data.bones[name].parent is None:
                local = helper_motion @ local
            self.arm.pose.bones[name].matrix_basis = self.rest_local[i].inverted() @ local

    def world_heads(self, positions: np.ndarray) -> dict[str, Vector]:
        """Blender world positions of the bone heads (and tails of leaf bones) from rigfit
        positions."""
        return {n: Z_UP @ Vector(p) for n, p in zip(self.skeleton.names, positions)}


def to_rigfit(points) -> np.ndarray:
    """Blender world points (m, 3) in rigfit's Y-up world."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    return np.stack([p[:, 0], p[:, 2], -p[:, 1]], axis=1)


def to_blender(points) -> np.ndarray:
    """rigfit Y-up points (m, 3) in Blender's world."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    return np.stack([p[:, 0], -p[:, 2], p[:, 1]], axis=1)


def bone_positions(arm: bpy.types.Object) -> dict[str, Vector]:
    """World positions of every bone head, and of leaf bones' tails (name + '.tail'), as Blender
    evaluates the current pose."""
    out = {}
    for pb in arm.pose.bones:
        out[pb.name] = arm.matrix_world @ pb.head
        if not pb.bone.children:
            out[pb.name + TAIL_SUFFIX] = arm.matrix_world @ pb.tail
    return out


# ---- strokes: one curve object per armature, one poly spline per stroke, in world space ----


def strokes_object(arm: bpy.types.Object, create: bool = False) -> bpy.types.Object | None:
    """The curve object holding `arm`'s strokes (created on demand)."""
    obj = arm.rigfit_strokes
    if obj is not None and obj.name in bpy.data.objects:
        return obj
    if not create:
        return None
    curve = bpy.data.curves.new(f"rigfit strokes: {arm.name}", "CURVE")
    curve.dimensions = "3D"
    curve.bevel_depth = 0.004
    obj = bpy.data.objects.new(f"rigfit strokes: {arm.name}", curve)
    coll = bpy.data.collections.get(STROKES_COLLECTION)
    if coll is None:
        coll = bpy.data.collections.new(STROKES_COLLECTION)
        bpy.context.scene.collection.children.link(coll)
    coll.objects.link(obj)
    mat = bpy.data.materials.get("rigfit stroke") or bpy.data.materials.new("rigfit stroke")
    mat.diffuse_color = (0.1, 0.35, 1.0, 1.0)
    curve.materials.append(mat)
    arm.rigfit_strokes = obj
    return obj


def add_stroke(arm: bpy.types.Object, points) -> bpy.types.Spline:
    """Appends a stroke (world points) to `arm`'s strokes."""
    obj = strokes_object(arm, create=True)
    spline = obj.data.splines.new("POLY")
    pts = list(points)
    spline.points.add(len(pts) - 1)
    for sp, p in zip(spline.points, pts):
        sp.co = (p[0], p[1], p[2], 1.0)
    return spline


def stroke_points(arm: bpy.types.Object) -> list[np.ndarray]:
    """`arm`'s strokes as world point arrays (m, 3), in drawing order."""
    obj = strokes_object(arm)
    if obj is None:
        return []
    world = obj.matrix_world
    out = []
    for spline in obj.data.splines:
        pts = [world @ Vector(p.co[:3]) for p in spline.points]
        out.append(np.array([[p.x, p.y, p.z] for p in pts]))
    return out


def armatures(scene: bpy.types.Scene) -> list[bpy.types.Object]:
    """The scene's armatures, by name."""
    return sorted((o for o in scene.objects if o.type == "ARMATURE"), key=lambda o: o.name)
