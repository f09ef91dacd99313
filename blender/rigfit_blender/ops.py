"""Operators: everything the paper's controllers do (Cannavò et al. 2020, section 3.1).

draw a stroke, select the armature to pose, move/rotate it, solve, reset to the rest pose,
delete the last stroke, delete all strokes, insert a keyframe for all bones, step a frame
back/forward, play/stop. Each works from the sidebar panel, a mouse or pen in the 3D
viewport, and the VR controllers (xr.py binds them).
"""

from __future__ import annotations

import bpy
from bpy.props import BoolProperty, CollectionProperty, FloatVectorProperty, IntProperty, StringProperty
from bpy_extras import view3d_utils
from mathutils import Euler, Matrix, Vector

from . import rig


class RIGFIT_PG_point(bpy.types.PropertyGroup):
    """One sample of a recorded stroke (world coordinates)."""

    co: FloatVectorProperty(name="Location", size=3, subtype="TRANSLATION")


def settings(context) -> bpy.types.PropertyGroup:
    return context.scene.rigfit


def target_armature(context) -> bpy.types.Object | None:
    """The armature being posed: the one selected for rigfit, else the active armature."""
    arm = settings(context).armature
    if arm is not None and arm.name in context.scene.objects:
        return arm
    obj = context.active_object
    return obj if obj is not None and obj.type == "ARMATURE" else None


NO_ARMATURE = "rigfit: no armature selected (select one with Select Armature)"


class NeedsArmature:
    """Mixin for the operators that work on the armature being posed: their `poll` fails when
    there is none, so Blender greys them out (the reason in the tooltip) and refuses to run
    them, and their `execute` / `invoke` can take `target_armature` as found."""

    @classmethod
    def poll(cls, context):
        if getattr(context, "scene", None) is not None and target_armature(context) is not None:
            return True
        cls.poll_message_set(NO_ARMATURE)
        return False


def stroke_point(context, event, depth: Vector | None = None) -> Vector | None:
    """Where a stroke sample goes: the VR controller's aim location for an XR event, else the
    mouse position placed in the view plane through `depth` (the selected armature's centre)."""
    if event.type == "XR_ACTION" and getattr(event, "xr", None) is not None:
        return Vector(event.xr.controller_location)
    region, rv3d, coord = view_under_mouse(context, event)
    if region is None or rv3d is None:
        return None
    if depth is None:
        arm = target_armature(context)
        depth = arm.matrix_world.translation if arm is not None else context.scene.cursor.location
    return view3d_utils.region_2d_to_location_3d(region, rv3d, coord, depth)


def view_under_mouse(context, event):
    """The 3D viewport region under the mouse, its view and the mouse in its coordinates.
    The draw operator is often started from the sidebar, whose region is not the view."""
    screen = getattr(context, "screen", None)
    if screen is not None and hasattr(event, "mouse_x"):
        for area in screen.areas:
            if area.type != "VIEW_3D":
                continue
            for region in area.regions:
                inside = (
                    region.type == "WINDOW"
                    and region.x <= event.mouse_x < region.x + region.width
                    and region.y <= event.mouse_y < region.y + region.height
                )
                if inside:
                    coord = (event.mouse_x - region.x, event.mouse_y - region.y)
                    return region, area.spaces.active.region_3d, coord
    return context.region, context.region_data, (event.mouse_region_x, event.mouse_region_y)


def armature_centre(arm: bpy.types.Object) -> Vector:
    """The middle of the armature's bones in the current pose (world)."""
    heads = list(rig.bone_positions(arm).values())
    if not heads:
        return arm.matrix_world.translation.copy()
    return sum(heads, Vector()) / len(heads)


class RIGFIT_OT_draw_stroke(NeedsArmature, bpy.types.Operator):
    """Draw a stroke: hold the left mouse button (or pen, or the VR trigger) and draw; the
    stroke lies in the view plane through the armature (in VR, where the controller points)"""

    bl_idname = "rigfit.draw_stroke"
    bl_label = "Draw Stroke"
    bl_options = {"REGISTER", "UNDO"}

    points: CollectionProperty(type=RIGFIT_PG_point, name="Trace", description="A recorded trace (world)")

    def execute(self, context):
        arm = target_armature(context)
        pts = [Vector(p.co) for p in self.points]
        if len(pts) < 2:
            self.report({"ERROR"}, "rigfit: a stroke needs at least 2 points")
            return {"CANCELLED"}
        rig.add_stroke(arm, pts)
        settings(context).status = "IDLE"
        return {"FINISHED"}

    def invoke(self, context, event):
        if len(self.points) > 0:
            return self.execute(context)
        arm = target_armature(context)
        self._arm = arm
        self._depth = armature_centre(arm)
        self._trace: list[Vector] = []
        self._drawing = False
        settings(context).status = "DRAWING"
        if event.type == "XR_ACTION":
            self._begin(context, event)
        context.window_manager.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _begin(self, context, event):
        self._drawing = True
        self._add(context, event)

    def _add(self, context, event):
        p = stroke_point(context, event, self._depth)
        if p is None:
            return
        if self._trace and (p - self._trace[-1]).length < 1e-6:
            return
        self._trace.append(p)
        self._show(context)

    def _show(self, context):
        """Keeps the stroke visible while it is drawn: a spline updated in place."""
        spline = getattr(self, "_spline", None)
        if spline is None and len(self._trace) >= 2:
            self._spline = rig.add_stroke(self._arm, self._trace)
            return
        if spline is not None:
            spline.points.add(1)
            p = self._trace[-1]
            spline.points[-1].co = (p.x, p.y, p.z, 1.0)
            self._arm.rigfit_strokes.data.update_tag()
        if context.area is not None:
            context.area.tag_redraw()

    def _finish(self, context):
        settings(context).status = "IDLE"
        if getattr(self, "_spline", None) is None:
            return {"CANCELLED"}
        return {"FINISHED"}

    def modal(self, context, event):
        if event.type == "XR_ACTION":
            self._add(context, event)
            if event.value == "RELEASE":
                return self._finish(context)
            return {"RUNNING_MODAL"}
        if event.type in {"ESC", "RIGHTMOUSE"}:
            spline = getattr(self, "_spline", None)
            if spline is not None:
                self._arm.rigfit_strokes.data.splines.remove(spline)
                self._spline = None
            return self._finish(context)
        if event.type in {"LEFTMOUSE", "PEN"}:
            if event.value == "PRESS":
                self._begin(context, event)
            elif event.value == "RELEASE" and self._drawing:
                self._add(context, event)
                return self._finish(context)
            return {"RUNNING_MODAL"}
        if event.type in {"MOUSEMOVE", "INBETWEEN_MOUSEMOVE"} and self._drawing:
            self._add(context, event)
            return {"RUNNING_MODAL"}
        return {"PASS_THROUGH"}


class RIGFIT_OT_select_armature(bpy.types.Operator):
    """Choose the armature to pose: by name, the active object, or the next one in the scene"""

    bl_idname = "rigfit.select_armature"
    bl_label = "Select Armature"
    bl_options = {"REGISTER", "UNDO"}

    name: StringProperty(name="Armature", description="Armature to pose (empty: active or next)")
    cycle: BoolProperty(name="Next", description="Pick the next armature in the scene", default=False)

    def execute(self, context):
        scene = context.scene
        candidates = rig.armatures(scene)
        if not candidates:
            self.report({"ERROR"}, "rigfit: the scene has no armature")
            return {"CANCELLED"}
        current = settings(context).armature
        if self.name:
            arm = scene.objects.get(self.name)
            if arm is None or arm.type != "ARMATURE":
                self.report({"ERROR"}, f"rigfit: no armature called '{self.name}' in the scene")
                return {"CANCELLED"}
        elif self.cycle or context.active_object is None or context.active_object.type != "ARMATURE":
            i = candidates.index(current) + 1 if current in candidates else 0
            arm = candidates[i % len(candidates)]
        else:
            arm = context.active_object
        settings(context).armature = arm
        for o in context.view_layer.objects:
            o.select_set(o == arm)
        context.view_layer.objects.active = arm
        settings(context).status = "IDLE"
        return {"FINISHED"}


class RIGFIT_OT_move_armature(NeedsArmature, bpy.types.Operator):
    """Move and rotate the selected armature: with the mouse (Blender's grab), in VR by
    holding the left trigger (the armature follows the controller), or by offset and angle"""

    bl_idname = "rigfit.move_armature"
    bl_label = "Move/Rotate Armature"
    bl_options = {"REGISTER", "UNDO"}

    offset: FloatVectorProperty(name="Offset", size=3, subtype="TRANSLATION")
    angle: FloatVectorProperty(name="Rotation", size=3, subtype="EULER", description="About the armature's origin")

    def execute(self, context):
        arm = target_armature(context)
        origin = arm.matrix_world.translation.copy()
        rotate = Matrix.Translation(origin) @ Euler(self.angle).to_matrix().to_4x4() @ Matrix.Translation(-origin)
        arm.matrix_world = Matrix.Translation(Vector(self.offset)) @ rotate @ arm.matrix_world
        return {"FINISHED"}

    def invoke(self, context, event):
        arm = target_armature(context)
        if event.type == "XR_ACTION":
            self._arm = arm
            self._start_object = arm.matrix_world.copy()
            self._start_controller = self._controller(event)
            settings(context).status = "MOVING"
            context.window_manager.modal_handler_add(self)
            return {"RUNNING_MODAL"}
        if any(v != 0 for v in (*self.offset, *self.angle)):
            return self.execute(context)
        bpy.ops.rigfit.select_armature(name=arm.name)
        return bpy.ops.transform.translate("INVOKE_DEFAULT")

    @staticmethod
    def _controller(event) -> Matrix:
        xr = event.xr
        return Matrix.LocRotScale(Vector(xr.controller_location), xr.controller_rotation, None)

    def modal(self, context, event):
        if event.type != "XR_ACTION":
            return {"PASS_THROUGH"}
        now = self._controller(event)
        self._arm.matrix_world = now @ self._start_controller.inverted() @ self._start_object
        if event.value == "RELEASE":
            settings(context).status = "IDLE"
            return {"FINISHED"}
        return {"RUNNING_MODAL"}


class RIGFIT_OT_solve(NeedsArmature, bpy.types.Operator):
    """Pose the selected armature so its bones follow the strokes (rigfit.solve_pose)"""

    bl_idname = "rigfit.solve"
    bl_label = "Solve Pose"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        import rigfit

        arm = target_armature(context)
        strokes = rig.stroke_points(arm)
        if not strokes:
            self.report({"ERROR"}, f"rigfit: no strokes drawn for '{arm.name}'")
            return {"CANCELLED"}
        skel = rig.ArmatureSkeleton(arm)
        rotations, translations = skel.current_pose()
        try:
            result = rigfit.solve_pose(
                skel.skeleton, [rig.to_rigfit(s) for s in strokes], rotations, translations
            )
        except rigfit.RigfitError as e:
            self.report({"ERROR"}, f"rigfit: {e}")
            return {"CANCELLED"}
        skel.apply(result.rotations, result.translations)
        matched = sum(1 for b in result.stroke_bones if b)
        message = f"posed {arm.name}: {matched} of {len(strokes)} strokes matched ({result.seconds * 1000:.0f} ms)"
        settings(context).message = message
        self.report({"INFO"}, message)
        return {"FINISHED"}


class RIGFIT_OT_reset_pose(NeedsArmature, bpy.types.Operator):
    """Put the selected armature back in its rest pose"""

    bl_idname = "rigfit.reset_pose"
    bl_label = "Reset to Rest Pose"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        arm = target_armature(context)
        for pb in arm.pose.bones:
            pb.matrix_basis = Matrix.Identity(4)
        return {"FINISHED"}


class RIGFIT_OT_delete_last_stroke(NeedsArmature, bpy.types.Operator):
    """Delete the last stroke drawn for the selected armature"""

    bl_idname = "rigfit.delete_last_stroke"
    bl_label = "Delete Last Stroke"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        arm = target_armature(context)
        obj = rig.strokes_object(arm)
        if obj is None or len(obj.data.splines) == 0:
            self.report({"WARNING"}, "rigfit: no stroke to delete")
            return {"CANCELLED"}
        obj.data.splines.remove(obj.data.splines[-1])
        return {"FINISHED"}


class RIGFIT_OT_delete_strokes(NeedsArmature, bpy.types.Operator):
    """Delete every stroke drawn for the selected armature"""

    bl_idname = "rigfit.delete_strokes"
    bl_label = "Delete All Strokes"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        arm = target_armature(context)
        obj = rig.strokes_object(arm)
        if obj is not None:
            obj.data.splines.clear()
        return {"FINISHED"}


def bone_channels(pb: bpy.types.PoseBone) -> list[str]:
    rotation = {"QUATERNION": "rotation_quaternion", "AXIS_ANGLE": "rotation_axis_angle"}.get(
        pb.rotation_mode, "rotation_euler"
    )
    return ["location", rotation, "scale"]


def fcurves(arm: bpy.types.Object):
    """The F-curves of the armature's action (layered actions of Blender 4.4+, or legacy)."""
    ad = arm.animation_data
    if ad is None or ad.action is None:
        return []
    action = ad.action
    slot = getattr(ad, "action_slot", None)
    if slot is not None:
        from bpy_extras import anim_utils

        bag = anim_utils.action_get_channelbag_for_slot(action, slot)
        return list(bag.fcurves) if bag is not None else []
    return list(getattr(action, "fcurves", []))


def has_keyframe(arm: bpy.types.Object, frame: float) -> bool:
    """Whether any of the armature's bone channels has a key at `frame`."""
    for fc in fcurves(arm):
        if fc.data_path.startswith("pose.bones") and any(abs(k.co.x - frame) < 1e-3 for k in fc.keyframe_points):
            return True
    return False


class RIGFIT_OT_insert_keyframe(NeedsArmature, bpy.types.Operator):
    """Key the location, rotation and scale of every bone of the selected armature at the
    current frame"""

    bl_idname = "rigfit.insert_keyframe"
    bl_label = "Insert Keyframe"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        arm = target_armature(context)
        frame = context.scene.frame_current
        for pb in arm.pose.bones:
            for path in bone_channels(pb):
                pb.keyframe_insert(path, frame=frame, group=pb.name)
        return {"FINISHED"}


class RIGFIT_OT_frame_step(bpy.types.Operator):
    """Go to the previous or the next frame"""

    bl_idname = "rigfit.frame_step"
    bl_label = "Step Frame"
    bl_options = {"REGISTER"}

    delta: IntProperty(name="Frames", default=1)

    def execute(self, context):
        scene = context.scene
        scene.frame_set(scene.frame_current + self.delta)
        return {"FINISHED"}


class RIGFIT_OT_play(bpy.types.Operator):
    """Play the animation, or stop it when it plays"""

    bl_idname = "rigfit.play"
    bl_label = "Play/Stop"

    def execute(self, context):
        if context.screen is None:
            self.report({"ERROR"}, "rigfit: playback needs a window (none in background mode)")
            return {"CANCELLED"}
        if context.screen.is_animation_playing:
            bpy.ops.screen.animation_cancel(restore_frame=False)
        else:
            bpy.ops.screen.animation_play()
        return {"FINISHED"}


CLASSES = (
    RIGFIT_PG_point,
    RIGFIT_OT_draw_stroke,
    RIGFIT_OT_select_armature,
    RIGFIT_OT_move_armature,
    RIGFIT_OT_solve,
    RIGFIT_OT_reset_pose,
    RIGFIT_OT_delete_last_stroke,
    RIGFIT_OT_delete_strokes,
    RIGFIT_OT_insert_keyframe,
    RIGFIT_OT_frame_step,
    RIGFIT_OT_play,
)
