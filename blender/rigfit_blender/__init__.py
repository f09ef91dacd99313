"""rigfit for Blender: pose armatures from strokes drawn with a mouse, a pen or a VR
controller (Cannavò et al. 2020), solved by the rigfit Python package (bundled wheel).

Modules: `rig` (armatures as rigfit skeletons, strokes as curve objects), `ops` (the
operators), `ui` (the sidebar panel), `xr` (OpenXR action maps for the controllers).
"""

from __future__ import annotations

import bpy
from bpy.props import EnumProperty, PointerProperty, StringProperty

from . import ops, rig, ui, xr

__all__ = ["ops", "rig", "ui", "xr", "register", "unregister"]


def _is_armature(_self, obj) -> bool:
    return obj.type == "ARMATURE"


class RIGFIT_PG_scene(bpy.types.PropertyGroup):
    """Per-scene state: the armature being posed and what the tool is doing."""

    armature: PointerProperty(type=bpy.types.Object, poll=_is_armature, name="Armature")
    status: EnumProperty(
        name="Status",
        items=(
            ("IDLE", "Idle", "Waiting for a command"),
            ("DRAWING", "Drawing", "A stroke is being drawn"),
            ("MOVING", "Moving", "The armature follows the controller"),
        ),
        default="IDLE",
    )
    message: StringProperty(name="Message", description="What the last solve did")


CLASSES = (*ops.CLASSES, RIGFIT_PG_scene, *ui.CLASSES)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.rigfit = PointerProperty(type=RIGFIT_PG_scene)
    bpy.types.Object.rigfit_strokes = PointerProperty(
        type=bpy.types.Object, name="rigfit strokes", description="The curve holding this armature's strokes"
    )
    xr.register()


def unregister():
    xr.unregister()
    del bpy.types.Object.rigfit_strokes
    del bpy.types.Scene.rigfit
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
