"""The rigfit Blender extension in real Blender: strokes fed to the draw operator, posing,
keyframes, undo / clear / reset, several armatures, save and reload, XR action maps."""

from types import SimpleNamespace

import bpy
import numpy as np
import pytest
from conftest import asset
from mathutils import Matrix, Vector

FRAME = 36  # the pose to recover: BCN_Epileptic's own animation at this frame
MIN_CHAIN = 0.15  # strokes are drawn on chains at least this long (fraction of the height)


def empty_scene():
    for coll in (bpy.data.objects, bpy.data.armatures, bpy.data.curves, bpy.data.meshes, bpy.data.actions):
        bpy.data.batch_remove(list(coll))
    for c in list(bpy.data.collections):
        bpy.data.collections.remove(c)
    scene = bpy.context.scene
    scene.frame_set(1)
    scene.rigfit.armature = None
    scene.rigfit.status = "IDLE"
    return scene


def import_character():
    bpy.ops.import_scene.gltf(filepath=str(asset("assimp/BCN_Epileptic.glb")))
    arms = [o for o in bpy.context.scene.objects if o.type == "ARMATURE"]
    assert len(arms) == 1
    return arms[0]


def feed_stroke(points):
    """The draw operator fed a recorded trace (world points)."""
    trace = [{"name": "", "co": tuple(float(v) for v in p)} for p in points]
    return bpy.ops.rigfit.draw_stroke(points=trace)


def strokes_of(addon, arm):
    return addon.rig.stroke_points(arm)


def posed_case(addon, arm):
    """Draws strokes through the armature at FRAME (Blender's evaluation of its animation),
    then takes the animation off and puts the armature in its rest pose.
    Returns (truth positions by name, drawn joint names, height)."""
    import rigfit

    bpy.context.scene.frame_set(FRAME)
    truth = addon.rig.bone_positions(arm)
    skel = addon.rig.ArmatureSkeleton(arm)
    rot, tr = skel.current_pose()
    height = skel.skeleton.height(rot, tr)
    # Limbs, as a user draws them (not the face's small bones).
    strokes, drawn = rigfit.draw_strokes(skel.skeleton, rot, tr, height=height, min_chain_length=MIN_CHAIN, seed=5)
    arm.animation_data.action = None
    bpy.context.scene.frame_set(1)
    bpy.ops.rigfit.select_armature(name=arm.name)
    assert bpy.ops.rigfit.reset_pose() == {"FINISHED"}
    for s in strokes:
        assert feed_stroke(addon.rig.to_blender(s)) == {"FINISHED"}
    names = [skel.skeleton.names[i] for i in drawn]
    return truth, names, height


def mean_error(addon, arm, truth, names, height):
    now = addon.rig.bone_positions(arm)
    return sum((now[n] - truth[n]).length for n in names) / len(names) / height


def test_the_extension_registers_operators_panel_and_handler(addon):
    for op in [
        "draw_stroke", "select_armature", "move_armature", "solve", "reset_pose",
        "delete_last_stroke", "delete_strokes", "insert_keyframe", "frame_step", "play",
    ]:
        assert hasattr(bpy.ops.rigfit, op), op
        assert bpy.ops.rigfit.__getattr__(op).get_rna_type() is not None
    assert hasattr(bpy.types, "RIGFIT_PT_panel")
    assert addon.xr.xr_session_start_pre in bpy.app.handlers.xr_session_start_pre


NEEDS_ARMATURE = [
    "draw_stroke", "move_armature", "solve", "reset_pose", "delete_last_stroke", "delete_strokes", "insert_keyframe",
]


def test_operators_that_pose_an_armature_are_greyed_out_without_one(addon):
    """Their poll fails, with the reason Blender shows in the tooltip, when no armature is
    selected; it passes when one is active or chosen for rigfit. The others always run."""
    scene = empty_scene()
    for op in NEEDS_ARMATURE:
        operator = getattr(bpy.ops.rigfit, op)
        assert not operator.poll(), op
        with pytest.raises(RuntimeError, match=r"poll\(\) rigfit: no armature selected \(select one with Select Armature\)"):
            operator()
    assert bpy.ops.rigfit.frame_step.poll() and bpy.ops.rigfit.play.poll()
    assert bpy.ops.rigfit.select_armature.poll()
    with pytest.raises(RuntimeError, match="the scene has no armature"):
        bpy.ops.rigfit.select_armature()

    # An armature in the scene that is neither active nor chosen: still none to pose.
    arm = build_armature("Stick", [[((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))]])
    bpy.context.view_layer.objects.active = None
    assert all(not getattr(bpy.ops.rigfit, op).poll() for op in NEEDS_ARMATURE)
    # Active, then chosen (and not active).
    bpy.context.view_layer.objects.active = arm
    assert all(getattr(bpy.ops.rigfit, op).poll() for op in NEEDS_ARMATURE)
    assert bpy.ops.rigfit.select_armature(name=arm.name) == {"FINISHED"}
    bpy.context.view_layer.objects.active = None
    assert all(getattr(bpy.ops.rigfit, op).poll() for op in NEEDS_ARMATURE)
    assert bpy.ops.rigfit.reset_pose() == {"FINISHED"}
    assert bpy.ops.rigfit.delete_strokes() == {"FINISHED"}
    assert bpy.ops.rigfit.delete_last_stroke() == {"CANCELLED"}
    # A chosen armature taken out of the scene no longer counts.
    scene.collection.objects.unlink(arm)
    assert scene.rigfit.armature == arm
    assert all(not getattr(bpy.ops.rigfit, op).poll() for op in NEEDS_ARMATURE)


def test_the_armature_is_the_skeleton_rigfit_sees(addon):
    empty_scene()
    arm = import_character()
    bpy.context.scene.frame_set(FRAME)
    skel = addon.rig.ArmatureSkeleton(arm)
    rot, tr = skel.current_pose()
    rigfit_world = addon.rig.to_blender(skel.skeleton.joint_positions(rot, tr))
    blender = addon.rig.bone_positions(arm)
    assert len(blender) > 54
    for name, p in zip(skel.skeleton.names[1:], rigfit_world[1:]):
        assert (Vector(p) - blender[name]).length < 1e-4, name
    # And back: applying rigfit's pose leaves Blender's pose as it was.
    before = {n: v.copy() for n, v in blender.items()}
    skel.apply(rot, tr)
    bpy.context.view_layer.update()
    after = addon.rig.bone_positions(arm)
    assert max((after[n] - before[n]).length for n in before) < 1e-4


def test_strokes_pose_the_character_undo_reset_and_keys(addon):
    scene = empty_scene()
    arm = import_character()
    truth, names, height = posed_case(addon, arm)
    drawn = len(strokes_of(addon, arm))
    assert drawn >= 6
    rest = addon.rig.bone_positions(arm)
    assert mean_error(addon, arm, truth, names, height) > 0.05, "the rest pose is far from the truth"
    assert bpy.ops.rigfit.solve() == {"FINISHED"}
    error = mean_error(addon, arm, truth, names, height)
    assert error < 0.02, f"mean joint error {error:.4f} of the height"
    # Strokes on the tiny face bones may be set aside as strays; the limbs all match.
    matched = int(scene.rigfit.message.split(": ")[1].split(" of ")[0])
    assert matched >= 0.9 * drawn, scene.rigfit.message

    # Keyframes: frame 1 posed, frame 11 at rest; stepping frames shows which has a key.
    assert bpy.ops.rigfit.insert_keyframe() == {"FINISHED"}
    assert addon.ops.has_keyframe(arm, 1)
    assert bpy.ops.rigfit.frame_step(delta=10) == {"FINISHED"} and scene.frame_current == 11
    assert not addon.ops.has_keyframe(arm, 11)
    assert bpy.ops.rigfit.reset_pose() == {"FINISHED"}
    assert max((addon.rig.bone_positions(arm)[n] - rest[n]).length for n in rest) < 1e-5
    assert bpy.ops.rigfit.insert_keyframe() == {"FINISHED"}
    assert addon.ops.has_keyframe(arm, 11)
    assert bpy.ops.rigfit.frame_step(delta=-1) == {"FINISHED"} and scene.frame_current == 10
    assert not addon.ops.has_keyframe(arm, 10)
    keyed = {round(k.co.x) for fc in addon.ops.fcurves(arm) for k in fc.keyframe_points}
    assert keyed == {1, 11}
    channels = {fc.data_path for fc in addon.ops.fcurves(arm)}
    assert len(channels) == 3 * len(arm.pose.bones), "location, rotation and scale of every bone"
    # Back at frame 1 the keys give the solved pose.
    scene.frame_set(1)
    assert mean_error(addon, arm, truth, names, height) < 0.02

    # Undo takes back the last operator (here: a solve from the rest pose), as Ctrl+Z does
    # after operators run from the interface (which push their undo steps).
    name = arm.name
    bpy.ops.ed.undo_push(message="start")  # background mode starts with undo off
    bpy.ops.rigfit.reset_pose("EXEC_DEFAULT", True)
    bpy.ops.rigfit.solve("EXEC_DEFAULT", True)
    assert mean_error(addon, arm, truth, names, height) < 0.02
    assert bpy.ops.ed.undo() == {"FINISHED"}
    arm = bpy.data.objects[name]
    assert max((addon.rig.bone_positions(arm)[n] - rest[n]).length for n in rest) < 1e-5


def test_delete_last_and_all_strokes(addon):
    empty_scene()
    arm = import_character()
    bpy.ops.rigfit.select_armature(name=arm.name)
    line = [(0.0, 0.0, z) for z in np.linspace(0.0, 1.0, 10)]
    for dx in range(3):
        feed_stroke([(x + dx, y, z) for x, y, z in line])
    strokes = strokes_of(addon, arm)
    assert len(strokes) == 3 and strokes[2][0][0] == pytest.approx(2.0)
    assert bpy.ops.rigfit.delete_last_stroke() == {"FINISHED"}
    strokes = strokes_of(addon, arm)
    assert len(strokes) == 2 and strokes[1][0][0] == pytest.approx(1.0)
    assert bpy.ops.rigfit.delete_strokes() == {"FINISHED"}
    assert strokes_of(addon, arm) == []
    assert bpy.ops.rigfit.delete_last_stroke() == {"CANCELLED"}
    with pytest.raises(RuntimeError, match="no strokes drawn"):
        bpy.ops.rigfit.solve()
    with pytest.raises(RuntimeError, match="at least 2 points"):
        feed_stroke([(0.0, 0.0, 0.0)])


def test_several_armatures_are_posed_one_at_a_time(addon):
    empty_scene()
    a = import_character()
    bpy.ops.import_scene.gltf(filepath=str(asset("assimp/BCN_Epileptic.glb")))
    b = next(o for o in bpy.context.scene.objects if o.type == "ARMATURE" and o != a)
    b.location.x += 2.0
    bpy.context.view_layer.update()
    for arm in (a, b):
        arm.animation_data.action = None
    # Cycling visits both.
    bpy.ops.rigfit.select_armature(cycle=True)
    first = bpy.context.scene.rigfit.armature
    bpy.ops.rigfit.select_armature(cycle=True)
    second = bpy.context.scene.rigfit.armature
    assert {first, second} == {a, b} and bpy.context.view_layer.objects.active == second
    truth, names, height = posed_case(addon, b)
    b_strokes = len(strokes_of(addon, b))
    a_before = addon.rig.bone_positions(a)
    bpy.ops.rigfit.solve()
    assert mean_error(addon, b, truth, names, height) < 0.02
    assert strokes_of(addon, a) == [] and b_strokes >= 6
    assert max((addon.rig.bone_positions(a)[n] - a_before[n]).length for n in a_before) < 1e-9
    with pytest.raises(RuntimeError, match="no armature called 'Nope'"):
        bpy.ops.rigfit.select_armature(name="Nope")


def test_the_blend_saves_and_reloads_with_strokes_and_keys(addon, tmp_path):
    scene = empty_scene()
    arm = import_character()
    truth, names, height = posed_case(addon, arm)
    bpy.ops.rigfit.solve()
    bpy.ops.rigfit.insert_keyframe()
    bpy.ops.rigfit.frame_step(delta=5)
    bpy.ops.rigfit.reset_pose()
    bpy.ops.rigfit.insert_keyframe()
    strokes = strokes_of(addon, arm)
    path = tmp_path / "posed.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    empty_scene()
    bpy.ops.wm.open_mainfile(filepath=str(path))
    scene = bpy.context.scene
    arm = scene.rigfit.armature
    assert arm is not None and arm.type == "ARMATURE"
    back = strokes_of(addon, arm)
    assert len(back) == len(strokes) >= 6
    assert all(np.allclose(x, y, atol=1e-5) for x, y in zip(back, strokes))
    assert addon.ops.has_keyframe(arm, 1) and addon.ops.has_keyframe(arm, 6)
    scene.frame_set(1)
    assert mean_error(addon, arm, truth, names, height) < 0.02


def test_the_draw_operator_takes_the_controller_aim_and_the_mouse(addon):
    empty_scene()
    arm = import_character()
    bpy.ops.rigfit.select_armature(name=arm.name)
    # A recorded VR trace: XR events carry the controller's aim location.
    trace = [Vector((0.3, -0.2, 1.0 + 0.02 * i)) for i in range(20)]
    events = [
        SimpleNamespace(type="XR_ACTION", value="PRESS", xr=SimpleNamespace(controller_location=p))
        for p in trace
    ]
    points = [addon.ops.stroke_point(bpy.context, e) for e in events]
    assert all((p - q).length < 1e-9 for p, q in zip(points, trace))
    assert feed_stroke(points) == {"FINISHED"}
    assert np.allclose(strokes_of(addon, arm)[0], np.array(trace), atol=1e-6)
    # The mouse: the view plane through the armature (orthographic front-facing view).
    region = SimpleNamespace(width=200, height=100)
    rv3d = SimpleNamespace(
        is_perspective=False, view_perspective="ORTHO", view_matrix=Matrix.Identity(4), perspective_matrix=Matrix.Identity(4)
    )
    context = SimpleNamespace(region=region, region_data=rv3d, scene=bpy.context.scene, active_object=arm)
    mouse = SimpleNamespace(type="MOUSEMOVE", mouse_region_x=150, mouse_region_y=75)
    p = addon.ops.stroke_point(context, mouse, depth=Vector((0.0, 0.0, 0.7)))
    assert (p - Vector((0.5, 0.5, 0.7))).length < 1e-6


def test_move_armature(addon):
    empty_scene()
    arm = import_character()
    bpy.ops.rigfit.select_armature(name=arm.name)
    before = arm.matrix_world.copy()
    assert bpy.ops.rigfit.move_armature(offset=(1.0, 0.0, 0.0), angle=(0.0, 0.0, np.pi / 2)) == {"FINISHED"}
    assert (arm.matrix_world.translation - before.translation - Vector((1, 0, 0))).length < 1e-6
    x_axis = arm.matrix_world.to_3x3() @ Vector((1, 0, 0))
    assert (x_axis - Vector((0, 1, 0))).length < 1e-6
    # Posing works wherever the armature stands.
    truth, names, height = posed_case(addon, arm)
    bpy.ops.rigfit.solve()
    assert mean_error(addon, arm, truth, names, height) < 0.02


class Recorder:
    """Stands in for XrSessionState (which exists only while a headset session runs) and
    records what the handler builds, through the same calls bpy offers."""

    class Collection(list):
        def __init__(self, make):
            super().__init__()
            self.make = make

        def new(self, *args):
            name = args[-2] if len(args) >= 2 and isinstance(args[-1], bool) else args[-1]
            item = self.make(name)
            self.append(item)
            return item

    def __init__(self):
        self.active_actionmap = -1
        self.actionmaps = Recorder.Collection(
            lambda name: SimpleNamespace(name=name, actionmap_items=Recorder.Collection(Recorder.item))
        )

    @staticmethod
    def item(name):
        return SimpleNamespace(
            name=name,
            user_paths=Recorder.Collection(lambda p: SimpleNamespace(path=p)),
            bindings=Recorder.Collection(Recorder.binding),
            op_properties=SimpleNamespace(),
        )

    @staticmethod
    def binding(name):
        return SimpleNamespace(name=name, component_paths=Recorder.Collection(lambda p: SimpleNamespace(path=p)))


def test_xr_action_maps_bind_the_controllers_to_the_operators(addon):
    xr = addon.xr
    state = Recorder()
    am = xr.add_action_maps(state)
    assert am.name == "rigfit" and state.active_actionmap == 0
    items = {i.name: i for i in am.actionmap_items}
    # Every attribute set exists on Blender's own XR types, with valid enum values.
    item_props = bpy.types.XrActionMapItem.bl_rna.properties
    binding_props = bpy.types.XrActionMapBinding.bl_rna.properties
    for item in items.values():
        for key in vars(item):
            if key not in {"user_paths", "bindings", "op_properties"}:
                assert key in item_props, key
        assert item.type in {e.identifier for e in item_props["type"].enum_items}
        if hasattr(item, "op_mode"):
            assert item.op_mode in {e.identifier for e in item_props["op_mode"].enum_items}
        assert {b.name for b in item.bindings} == {"vive", "index", "oculus"}
        for b in item.bindings:
            for key in vars(b):
                assert key in binding_props or key == "component_paths", key
            assert b.profile in {
                "/interaction_profiles/htc/vive_controller",
                "/interaction_profiles/valve/index_controller",
                "/interaction_profiles/oculus/touch_controller",
            }
            if hasattr(b, "axis0_region"):
                assert b.axis0_region in {e.identifier for e in binding_props["axis0_region"].enum_items}
            assert len(b.component_paths) == len(item.user_paths)
    # The paper's layout (Fig. 3), every operator a registered one.
    expected = {
        "draw_stroke": ("/user/hand/right", "trigger", "ANY", "rigfit.draw_stroke", "MODAL"),
        "select_armature": ("/user/hand/right", "squeeze", "ANY", "rigfit.select_armature", "PRESS"),
        "move_armature": ("/user/hand/left", "trigger", "ANY", "rigfit.move_armature", "MODAL"),
        "solve": ("/user/hand/right", "/y", "POSITIVE", "rigfit.solve", "PRESS"),
        "reset_pose": ("/user/hand/right", "/x", "POSITIVE", "rigfit.reset_pose", "PRESS"),
        "delete_strokes": ("/user/hand/right", "/y", "NEGATIVE", "rigfit.delete_strokes", "PRESS"),
        "delete_last_stroke": ("/user/hand/right", "/x", "NEGATIVE", "rigfit.delete_last_stroke", "PRESS"),
        "play": ("/user/hand/left", "/y", "POSITIVE", "rigfit.play", "PRESS"),
        "frame_forward": ("/user/hand/left", "/x", "POSITIVE", "rigfit.frame_step", "PRESS"),
        "frame_back": ("/user/hand/left", "/x", "NEGATIVE", "rigfit.frame_step", "PRESS"),
        "insert_keyframe": ("/user/hand/left", "/y", "NEGATIVE", "rigfit.insert_keyframe", "PRESS"),
    }
    for name, (hand, component, region, op, mode) in expected.items():
        item = items[name]
        assert [u.path for u in item.user_paths] == [hand]
        assert item.op == op and item.op_mode == mode
        assert hasattr(bpy.ops.rigfit, op.split(".")[1])
        for b in item.bindings:
            assert component in b.component_paths[0].path and b.axis0_region == region
            pad = "trackpad" if b.name == "vive" else "thumbstick"
            if component.startswith("/"):
                assert pad in b.component_paths[0].path
    assert items["frame_back"].op_properties.delta == -1 and items["frame_forward"].op_properties.delta == 1
    assert items["select_armature"].op_properties.cycle is True
    # The controller aim pose gives XR events their location.
    assert items["controller_aim"].type == "POSE" and items["controller_aim"].pose_is_controller_aim
    assert [u.path for u in items["controller_aim"].user_paths] == ["/user/hand/left", "/user/hand/right"]
    # Without a headset session the handler does nothing (and does not fail).
    assert bpy.context.window_manager.xr_session_state is None
    xr.xr_session_start_pre(None)


def test_play_and_stop(addon):
    assert bpy.ops.rigfit.play() == {"FINISHED"}
    assert bpy.context.screen.is_animation_playing
    assert bpy.ops.rigfit.play() == {"FINISHED"}
    assert not bpy.context.screen.is_animation_playing


class Layout:
    """Records what a panel draws."""

    def __init__(self):
        self.labels, self.operators = [], []

    def box(self):
        return self

    def column(self, **_):
        return self

    def row(self, **_):
        return self

    def label(self, text="", icon="NONE"):
        self.labels.append((text, icon))

    def prop_search(self, *args, **kwargs):
        pass

    def operator(self, idname, **_):
        props = SimpleNamespace()
        self.operators.append((idname, props))
        return props


def test_the_panel_shows_status_armature_frame_and_keyframe(addon):
    empty_scene()
    arm = import_character()
    arm.animation_data.action = None
    bpy.ops.rigfit.select_armature(name=arm.name)
    feed_stroke([(0.0, 0.0, 0.0), (0.0, 0.0, 1.0)])

    def draw():
        panel = SimpleNamespace(layout=Layout())
        addon.ui.RIGFIT_PT_panel.draw(panel, bpy.context)
        return panel.layout

    layout = draw()
    texts = [t for t, _ in layout.labels]
    assert "Status: Idle" in texts and f"Armature: {arm.name}" in texts
    assert ("Frame 1: no keyframe", "KEYFRAME") in layout.labels and "Strokes: 1" in texts
    ops_drawn = {idname for idname, _ in layout.operators}
    assert ops_drawn == {
        "rigfit.select_armature", "rigfit.move_armature", "rigfit.draw_stroke", "rigfit.delete_last_stroke",
        "rigfit.delete_strokes", "rigfit.solve", "rigfit.reset_pose", "rigfit.insert_keyframe",
        "rigfit.frame_step", "rigfit.play",
    }
    bpy.ops.rigfit.insert_keyframe()
    bpy.context.scene.rigfit.status = "DRAWING"
    layout = draw()
    assert ("Frame 1: keyframe", "KEYFRAME_HLT") in layout.labels
    assert "Status: Drawing" in [t for t, _ in layout.labels]
    bpy.context.scene.rigfit.status = "IDLE"


def build_armature(name, roots):
    """An armature made in edit mode: each root is a chain of (head, tail) bones."""
    data = bpy.data.armatures.new(name)
    obj = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    for r, chain in enumerate(roots):
        parent = None
        for i, (head, tail) in enumerate(chain):
            bone = data.edit_bones.new(f"{name}.{r}.{i}")
            bone.head, bone.tail = head, tail
            if parent is not None:
                bone.parent, bone.use_connect = parent, True
            parent = bone
    bpy.ops.object.mode_set(mode="OBJECT")
    return obj


def test_a_hand_built_armature_with_two_root_bones(addon):
    """Two legs with no common parent bone: the solver moves them together through the
    armature's helper joint, which the add-on folds back into the root bones."""
    import rigfit

    empty_scene()
    arm = build_armature(
        "Legs",
        [
            [((0.15, 0.0, 1.0), (0.15, 0.0, 0.5)), ((0.15, 0.0, 0.5), (0.15, 0.0, 0.05)), ((0.15, 0.0, 0.05), (0.15, -0.15, 0.0))],
            [((-0.15, 0.0, 1.0), (-0.15, 0.0, 0.5)), ((-0.15, 0.0, 0.5), (-0.15, 0.0, 0.05)), ((-0.15, 0.0, 0.05), (-0.15, -0.15, 0.0))],
        ],
    )
    arm.location = (0.5, 0.2, 0.0)
    # The truth: one leg kicked forward, the other knee bent.
    arm.pose.bones["Legs.0.0"].rotation_quaternion = (0.92, 0.38, 0.0, 0.0)
    arm.pose.bones["Legs.1.1"].rotation_quaternion = (0.87, -0.5, 0.0, 0.0)
    bpy.context.view_layer.update()
    truth = addon.rig.bone_positions(arm)
    skel = addon.rig.ArmatureSkeleton(arm)
    rot, tr = skel.current_pose()
    height = skel.skeleton.height(rot, tr)
    strokes, drawn = rigfit.draw_strokes(skel.skeleton, rot, tr, height=height, seed=3)
    assert len(strokes) == 2
    bpy.ops.rigfit.select_armature(name=arm.name)
    bpy.ops.rigfit.reset_pose()
    for s in strokes:
        feed_stroke(addon.rig.to_blender(s))
    assert bpy.ops.rigfit.solve() == {"FINISHED"}
    names = [skel.skeleton.names[i] for i in drawn if skel.skeleton.names[i] in truth]  # not the object
    assert len(names) == 8  # three heads and a tail per leg
    assert mean_error(addon, arm, truth, names, height) < 0.02
    assert (arm.location - Vector((0.5, 0.2, 0.0))).length < 1e-9, "the object itself stays"
