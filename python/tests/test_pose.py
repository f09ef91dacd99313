"""rigfit.solve_pose on the CLI's cases (crates/rigfit-cli/tests/pose.rs): strokes drawn through
real rigs posed by their own animations, solved from the stored (or rest) pose."""

import numpy as np
import pytest
import rigfit
from conftest import asset


def mean_error(result, truth, drawn, height):
    return float(np.linalg.norm(result.positions[drawn] - truth[drawn], axis=1).mean() / height)


def test_poses_a_gltf_character_within_two_percent():
    rig = rigfit.load_rig(asset("assimp/BCN_Epileptic.glb"))
    assert len(rig.skeleton) == 55
    assert rig.animations == ["Epileptisch"]
    rot, tr = rig.sample(1.5)
    strokes, drawn = rigfit.draw_strokes(rig.skeleton, rot, tr, height=rig.height, seed=5)
    assert len(strokes) == 6 and all(s.shape[1] == 3 for s in strokes)
    result = rigfit.solve_pose(rig.skeleton, strokes, rig.rotations, rig.translations, height=rig.height)
    truth = rig.skeleton.joint_positions(rot, tr)
    assert mean_error(result, truth, drawn, rig.height) < 0.02
    assert len(result.stroke_bones) == 6 and all(result.stroke_bones)
    assert result.iterations > 0 and result.seconds > 0
    assert result.rotations.shape == (55, 4) and result.translations.shape == (55, 3)
    # The returned pose reproduces the returned positions.
    again = rig.skeleton.joint_positions(result.rotations, result.translations)
    assert np.allclose(again, result.positions, atol=1e-9)


def test_poses_a_bvh_skeleton_from_its_rest_pose():
    rig = rigfit.load_rig(asset("cmu/01_01.bvh"), start_frame="rest")
    dt = rig.frame_time()
    assert dt is not None
    rot, tr = rig.sample(900 * dt)
    strokes, drawn = rigfit.draw_strokes(rig.skeleton, rot, tr, height=rig.height, seed=5)
    result = rigfit.solve_pose(rig.skeleton, strokes, rig.rotations, rig.translations, height=rig.height)
    truth = rig.skeleton.joint_positions(rot, tr)
    errors = np.linalg.norm(result.positions[drawn] - truth[drawn], axis=1) / rig.height
    assert errors.max() < 0.05, errors


def test_every_suite_rig_poses_within_two_percent_mostly():
    """The accuracy suites' rigs, a few cases each (the CLI's accuracy test runs all 25)."""
    errors = []
    for file in ["assimp/BCN_Epileptic.glb", "assimp/Testwuson.glb"]:
        rig = rigfit.load_rig(asset(file))
        start, end = rig.animation_range()
        for i in range(3):
            rot, tr = rig.sample(start + (end - start) * (i + 0.5) / 3)
            strokes, drawn = rigfit.draw_strokes(rig.skeleton, rot, tr, height=rig.height, seed=1000 + i)
            result = rigfit.solve_pose(rig.skeleton, strokes, rig.rotations, rig.translations, height=rig.height)
            errors.append(mean_error(result, rig.skeleton.joint_positions(rot, tr), drawn, rig.height))
    assert sum(e < 0.02 for e in errors) >= len(errors) - 1, errors


def test_the_paper_method_runs():
    rig = rigfit.load_rig(asset("assimp/BCN_Epileptic.glb"))
    rot, tr = rig.sample(1.5)
    strokes, _ = rigfit.draw_strokes(rig.skeleton, rot, tr, height=rig.height, seed=5)
    result = rigfit.solve_pose(rig.skeleton, strokes, rig.rotations, rig.translations, method="paper")
    assert result.iterations > 0


def test_only_the_chosen_bones_move_and_pinned_strokes_keep_their_bones():
    rig = rigfit.load_rig(asset("assimp/BCN_Epileptic.glb"))
    sk = rig.skeleton
    rot, tr = rig.sample(1.5)
    strokes, _ = rigfit.draw_strokes(sk, rot, tr, height=rig.height, seed=5)
    arm = ["B_UpperArm_Left", "B_ForeArm_Left"]
    for name in arm:
        sk.index(name)
    result = rigfit.solve_pose(sk, strokes, rig.rotations, rig.translations, bones=arm)
    moved = {
        sk.names[i]
        for i in range(len(sk))
        if abs(abs(float(np.dot(result.rotations[i], rig.rotations[i]))) - 1.0) > 1e-9
    }
    assert moved <= set(arm), moved
    pins = [None] * len(strokes)
    pins[0] = arm
    pinned = rigfit.solve_pose(sk, strokes, rig.rotations, rig.translations, stroke_bones=pins)
    assert set(pinned.stroke_bones[0]) <= set(arm)


def test_joint_order_is_the_callers():
    """A skeleton given children first poses exactly as the same skeleton given parents first."""
    rig = rigfit.load_rig(asset("assimp/BCN_Epileptic.glb"))
    sk = rig.skeleton
    n = len(sk)
    perm = np.arange(n)[::-1].copy()  # children before parents
    inverse = np.argsort(perm)
    parents = [int(inverse[p]) if p >= 0 else -1 for p in sk.parents[perm]]
    flipped = rigfit.Skeleton(
        [sk.names[i] for i in perm],
        parents,
        sk.rest_translations[perm],
        sk.rest_rotations[perm],
        end_sites=[sk.end_sites[i] for i in perm],
        helpers=[sk.helpers[i] for i in perm],
    )
    assert flipped.helpers[-1] and not any(flipped.helpers[:-1])
    assert flipped.names == [sk.names[i] for i in perm]
    assert list(flipped.parents) == parents
    rot, tr = rig.sample(1.5)
    assert np.allclose(flipped.joint_positions(rot[perm], tr[perm]), sk.joint_positions(rot, tr)[perm])
    strokes, _ = rigfit.draw_strokes(sk, rot, tr, height=rig.height, seed=5)
    # The same skeleton built the same way, parents first (a skeleton built from arrays has
    # no joint limits; the loaded rig's carries its clips' ranges, which the solver uses).
    same = rigfit.Skeleton(
        list(sk.names),
        list(sk.parents),
        sk.rest_translations,
        sk.rest_rotations,
        end_sites=list(sk.end_sites),
        helpers=list(sk.helpers),
    )
    a = rigfit.solve_pose(same, strokes, rig.rotations, rig.translations, height=rig.height)
    b = rigfit.solve_pose(flipped, strokes, rig.rotations[perm], rig.translations[perm], height=rig.height)
    assert np.allclose(a.positions[perm], b.positions, atol=1e-6)


@pytest.mark.parametrize(
    "strokes, kwargs, message",
    [
        ([], {}, "solve_pose: no strokes"),
        ([[[0.0, 1.0, 0.0]]], {}, "solve_pose: strokes[0]: a stroke needs at least 2 points"),
        ([[[0.0, 1.0, 0.0], [np.nan, 1.0, 0.0]]], {}, "strokes[0][1]: coordinate is not a finite number"),
        ([np.zeros((4, 2))], {}, "strokes[0]: expected an array of shape (n, 3), got shape [4, 2]"),
        ([[[0.0, 1.0, 0.0], [0.0, 0.5, 0.0]]], {"bones": ["NoSuchBone"]}, "unknown bone 'NoSuchBone'"),
        ([[[0.0, 1.0, 0.0], [0.0, 0.5, 0.0]]], {"method": "magic"}, "method: expected 'rigfit' or 'paper'"),
        ([[[0.0, 1.0, 0.0], [0.0, 0.5, 0.0]]], {"rotations": np.zeros((3, 4))}, "rotations: expected an array of shape (55, 4)"),
        ([[[0.0, 1.0, 0.0], [0.0, 0.5, 0.0]]], {"height": -1.0}, "height: expected a positive number"),
        ([[[0.0, 1.0, 0.0], [1e9, 0.5, 0.0]]], {}, "more than 100 character heights away"),
    ],
)
def test_bad_input_raises_one_clear_line(strokes, kwargs, message):
    rig = rigfit.load_rig(asset("assimp/BCN_Epileptic.glb"))
    with pytest.raises(rigfit.RigfitError) as caught:
        rigfit.solve_pose(rig.skeleton, strokes, **kwargs)
    text = str(caught.value)
    assert message in text and "\n" not in text, text
    assert isinstance(caught.value, ValueError)


def test_bad_skeletons_and_files_raise():
    with pytest.raises(rigfit.RigfitError, match="parents: expected 2 entries"):
        rigfit.Skeleton(["a", "b"], [-1], np.zeros((2, 3)), [[0, 0, 0, 1]] * 2)
    with pytest.raises(rigfit.RigfitError, match="are the parents a tree"):
        rigfit.Skeleton(["a", "b"], [1, 0], np.zeros((2, 3)), [[0, 0, 0, 1]] * 2)
    with pytest.raises(rigfit.RigfitError, match="rest_rotations\\[1\\]: a zero quaternion"):
        rigfit.Skeleton(["a", "b"], [-1, 0], np.zeros((2, 3)), [[0, 0, 0, 1], [0, 0, 0, 0]])
    with pytest.raises(rigfit.RigfitError, match="no_such.glb"):
        rigfit.load_rig("no_such.glb")
    with pytest.raises(rigfit.RigfitError, match="start_frame"):
        rigfit.load_rig(asset("cmu/01_01.bvh"), start_frame="middle")
    rig = rigfit.load_rig(asset("assimp/BCN_Epileptic.glb"))
    with pytest.raises(rigfit.RigfitError, match="no index 3"):
        rig.sample(0.0, animation=3)
    with pytest.raises(rigfit.RigfitError, match="unknown joint 'Nope'"):
        rig.skeleton.index("Nope")


def test_a_hand_built_skeleton_with_end_sites():
    """A three-bone arm given as Blender gives bones: a joint at each head, an end site at the tip."""
    names = ["root", "upper", "lower", "tip"]
    parents = [-1, 0, 1, 2]
    rest_t = [[0, 0, 0], [0, 1, 0], [0, 1, 0], [0, 1, 0]]
    rest_r = [[0, 0, 0, 1]] * 4
    sk = rigfit.Skeleton(names, parents, rest_t, rest_r, end_sites=[False, False, False, True])
    assert sk.height() == pytest.approx(3.0)
    # Bend the elbow by 90 degrees and draw the arm.
    s = np.sqrt(0.5)
    rot = np.array([[0, 0, 0, 1], [0, 0, 0, 1], [0, 0, s, s], [0, 0, 0, 1]], dtype=float)
    truth = sk.joint_positions(rot)
    line = np.concatenate([np.linspace(truth[1], truth[2], 20), np.linspace(truth[2], truth[3], 20)[1:]])
    result = rigfit.solve_pose(sk, [line], bones=["upper", "lower"])
    assert np.linalg.norm(result.positions - truth, axis=1).max() < 0.05
