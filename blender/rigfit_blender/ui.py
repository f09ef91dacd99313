"""The sidebar panel (3D viewport, N panel, tab "rigfit"): status and every operator."""

from __future__ import annotations

import bpy

from . import ops, rig


class RIGFIT_PT_panel(bpy.types.Panel):
    bl_idname = "RIGFIT_PT_panel"
    bl_label = "rigfit: pose from strokes"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "rigfit"

    def draw(self, context):
        layout = self.layout
        s = context.scene.rigfit
        arm = ops.target_armature(context)
        frame = context.scene.frame_current
        box = layout.box()
        box.label(text=f"Status: {s.status.capitalize()}", icon="GREASEPENCIL" if s.status == "DRAWING" else "INFO")
        box.label(text=f"Armature: {arm.name if arm else '(none)'}", icon="ARMATURE_DATA")
        keyed = arm is not None and ops.has_keyframe(arm, frame)
        box.label(text=f"Frame {frame}: {'keyframe' if keyed else 'no keyframe'}", icon="KEYFRAME_HLT" if keyed else "KEYFRAME")
        if arm is not None:
            obj = rig.strokes_object(arm)
            box.label(text=f"Strokes: {len(obj.data.splines) if obj else 0}")
        if s.message:
            box.label(text=s.message)

        col = layout.column(align=True)
        col.prop_search(s, "armature", context.scene, "objects", text="")
        row = col.row(align=True)
        row.operator("rigfit.select_armature", text="Active").cycle = False
        row.operator("rigfit.select_armature", text="Next", icon="FORWARD").cycle = True
        col.operator("rigfit.move_armature", icon="ORIENTATION_GLOBAL")

        col = layout.column(align=True)
        col.operator("rigfit.draw_stroke", icon="GREASEPENCIL")
        row = col.row(align=True)
        row.operator("rigfit.delete_last_stroke", text="Delete Last", icon="BACK")
        row.operator("rigfit.delete_strokes", text="Delete All", icon="TRASH")
        col.operator("rigfit.solve", icon="PLAY")
        col.operator("rigfit.reset_pose", icon="ARMATURE_DATA")

        col = layout.column(align=True)
        col.operator("rigfit.insert_keyframe", icon="KEY_HLT")
        row = col.row(align=True)
        row.operator("rigfit.frame_step", text="", icon="FRAME_PREV").delta = -1
        row.operator("rigfit.play", text="Play/Stop", icon="PLAY")
        row.operator("rigfit.frame_step", text="", icon="FRAME_NEXT").delta = 1


CLASSES = (RIGFIT_PT_panel,)
