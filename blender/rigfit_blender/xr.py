"""VR through Blender's own OpenXR session: the paper's controller layout (Cannavò et al.
2020, Fig. 3) as action-map items, added when a session starts (`xr_session_start_pre`).

Right hand: trigger draws, grip selects the next armature, trackpad / thumbstick up solves,
right resets to the rest pose, down deletes all strokes, left deletes the last stroke.
Left hand: trigger moves/rotates the armature, grip selects, up plays/stops, right/left steps
a frame, down inserts a keyframe. Bound for the HTC Vive, Valve Index and Oculus Touch.
"""

from __future__ import annotations

import bpy
from bpy.app.handlers import persistent

ACTION_MAP = "rigfit"
LEFT, RIGHT = "/user/hand/left", "/user/hand/right"

PROFILES = {
    "vive": "/interaction_profiles/htc/vive_controller",
    "index": "/interaction_profiles/valve/index_controller",
    "oculus": "/interaction_profiles/oculus/touch_controller",
}

# Component paths per profile: trigger, grip and the directional pad (Vive trackpad, Index and
# Oculus thumbstick).
COMPONENTS = {
    "vive": {"trigger": "/input/trigger/value", "grip": "/input/squeeze/click", "x": "/input/trackpad/x", "y": "/input/trackpad/y"},
    "index": {"trigger": "/input/trigger/value", "grip": "/input/squeeze/value", "x": "/input/thumbstick/x", "y": "/input/thumbstick/y"},
    "oculus": {"trigger": "/input/trigger/value", "grip": "/input/squeeze/value", "x": "/input/thumbstick/x", "y": "/input/thumbstick/y"},
}

# (item name, user path, input, axis region, operator, mode, operator properties)
ACTIONS = [
    ("draw_stroke", RIGHT, "trigger", "ANY", "rigfit.draw_stroke", "MODAL", {}),
    ("select_armature", RIGHT, "grip", "ANY", "rigfit.select_armature", "PRESS", {"cycle": True}),
    ("select_armature_left", LEFT, "grip", "ANY", "rigfit.select_armature", "PRESS", {"cycle": True}),
    ("move_armature", LEFT, "trigger", "ANY", "rigfit.move_armature", "MODAL", {}),
    ("solve", RIGHT, "y", "POSITIVE", "rigfit.solve", "PRESS", {}),
    ("reset_pose", RIGHT, "x", "POSITIVE", "rigfit.reset_pose", "PRESS", {}),
    ("delete_strokes", RIGHT, "y", "NEGATIVE", "rigfit.delete_strokes", "PRESS", {}),
    ("delete_last_stroke", RIGHT, "x", "NEGATIVE", "rigfit.delete_last_stroke", "PRESS", {}),
    ("play", LEFT, "y", "POSITIVE", "rigfit.play", "PRESS", {}),
    ("frame_forward", LEFT, "x", "POSITIVE", "rigfit.frame_step", "PRESS", {"delta": 1}),
    ("frame_back", LEFT, "x", "NEGATIVE", "rigfit.frame_step", "PRESS", {"delta": -1}),
    ("insert_keyframe", LEFT, "y", "NEGATIVE", "rigfit.insert_keyframe", "PRESS", {}),
]

THRESHOLD = 0.5


def add_action_maps(session_state) -> object:
    """Adds the rigfit action map (controller poses and every action above, bound for each
    profile) to an XR session state and makes it the active one. Returns the action map."""
    am = session_state.actionmaps.new(session_state, ACTION_MAP, True)
    # Controller poses: the aim pose gives XR events their controller location.
    for name, component, grip, aim in (
        ("controller_grip", "/input/grip/pose", True, False),
        ("controller_aim", "/input/aim/pose", False, True),
    ):
        ami = am.actionmap_items.new(name, True)
        ami.type = "POSE"
        ami.user_paths.new(LEFT)
        ami.user_paths.new(RIGHT)
        ami.pose_is_controller_grip = grip
        ami.pose_is_controller_aim = aim
        for profile, path in PROFILES.items():
            amb = ami.bindings.new(profile, True)
            amb.profile = path
            amb.component_paths.new(component)
            amb.component_paths.new(component)
    for name, user_path, component, region, op, mode, props in ACTIONS:
        ami = am.actionmap_items.new(name, True)
        ami.type = "FLOAT"
        ami.user_paths.new(user_path)
        ami.op = op
        ami.op_mode = mode
        if props and ami.op_properties is not None:
            for key, value in props.items():
                setattr(ami.op_properties, key, value)
        for profile, path in PROFILES.items():
            amb = ami.bindings.new(profile, True)
            amb.profile = path
            amb.component_paths.new(COMPONENTS[profile][component])
            amb.threshold = THRESHOLD
            amb.axis0_region = region
    for i, m in enumerate(session_state.actionmaps):
        if m.name == ACTION_MAP:
            session_state.active_actionmap = i
    return am


@persistent
def xr_session_start_pre(*_args):
    """`bpy.app.handlers.xr_session_start_pre`: install the rigfit action map."""
    state = bpy.context.window_manager.xr_session_state
    if state is not None:
        add_action_maps(state)


def register():
    if xr_session_start_pre not in bpy.app.handlers.xr_session_start_pre:
        bpy.app.handlers.xr_session_start_pre.append(xr_session_start_pre)


def unregister():
    if xr_session_start_pre in bpy.app.handlers.xr_session_start_pre:
        bpy.app.handlers.xr_session_start_pre.remove(xr_session_start_pre)
