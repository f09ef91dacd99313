"""Files from Python: meshes and point clouds (load_mesh, load_cloud, save_mesh), posed and
animated rigs written back (Rig.save, Rig.save_animation) and read again with load_rig, and
the skinned mesh in a pose (Rig.mesh)."""

import os

import numpy as np
import pytest
import rigfit
from conftest import asset, no_temporaries

CHARACTER = "assimp/BCN_Epileptic.glb"


@pytest.fixture(scope="module")
def rig():
    return rigfit.load_rig(asset(CHARACTER))


def f32(a):
    """What a PLY's 32-bit float coordinates hold of a float64 array."""
    return a.astype(np.float32).astype(np.float64)


def test_a_mesh_round_trips_through_ply_and_obj(tmp_path, rig):
    vertices, faces = rig.mesh(*rig.sample(0.5))
    assert vertices.dtype == np.float64 and faces.dtype == np.int64
    rigfit.save_mesh(tmp_path / "m.ply", vertices, faces)
    v, f = rigfit.load_mesh(tmp_path / "m.ply")
    assert v.dtype == np.float64 and f.dtype == np.int64
    assert np.array_equal(v, f32(vertices)) and np.array_equal(f, faces)
    # OBJ numbers are written in full: the same float64 values come back.
    rigfit.save_mesh(str(tmp_path / "m.obj"), vertices.tolist(), faces.tolist())
    v, f = rigfit.load_mesh(str(tmp_path / "m.obj"))
    assert np.array_equal(v, vertices) and np.array_equal(f, faces)
    no_temporaries(tmp_path)


def test_a_point_cloud_round_trips_with_and_without_normals(tmp_path):
    rng = np.random.default_rng(3)
    points = rng.normal(size=(200, 3))
    normals = points / np.linalg.norm(points, axis=1, keepdims=True)
    for ext in ["ply", "obj"]:
        rigfit.save_mesh(tmp_path / f"c.{ext}", points, normals=normals)
        p, n = rigfit.load_cloud(tmp_path / f"c.{ext}")
        exact = (lambda a: a) if ext == "obj" else f32
        assert np.array_equal(p, exact(points)) and np.array_equal(n, exact(normals))
        rigfit.save_mesh(tmp_path / f"bare.{ext}", points)
        p, n = rigfit.load_cloud(tmp_path / f"bare.{ext}")
        assert n is None and p.shape == (200, 3)
        v, f = rigfit.load_mesh(tmp_path / f"bare.{ext}")
        assert f.shape == (0, 3) and f.dtype == np.int64


def test_a_gltf_reference_is_its_skinned_mesh_in_the_stored_pose(rig):
    vertices, faces = rigfit.load_mesh(asset(CHARACTER))
    mine, my_faces = rig.mesh()
    assert vertices.shape == (3014, 3) and faces.shape == (5126, 3)
    assert np.array_equal(vertices, mine) and np.array_equal(faces, my_faces)
    # The stored pose with the given rotations put in; another pose moves the vertices.
    assert np.allclose(rig.mesh(rig.rotations)[0], mine, rtol=0, atol=1e-12)
    moved, _ = rig.mesh(*rig.sample(1.5))
    assert np.linalg.norm(moved - mine, axis=1).mean() > 0.01 * rig.height


def test_saving_replaces_a_file_whole_or_not_at_all(tmp_path):
    path = tmp_path / "m.ply"
    rigfit.save_mesh(path, np.zeros((3, 3)))
    before = path.read_bytes()
    with pytest.raises(rigfit.RigfitError, match=r"normals: expected an array of shape \(4, 3\)"):
        rigfit.save_mesh(path, np.ones((4, 3)), normals=np.ones((3, 3)))
    assert path.read_bytes() == before
    rigfit.save_mesh(path, np.ones((4, 3)))
    assert rigfit.load_cloud(path)[0].shape == (4, 3)
    no_temporaries(tmp_path)


def test_unreadable_files_and_bad_arrays_are_one_line_errors(tmp_path):
    missing = tmp_path / "missing.ply"
    bad = tmp_path / "bad.ply"
    bad.write_text("ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nend_header\n1\n2\n")
    cases = [
        (lambda: rigfit.load_mesh(missing), f"{missing}: No such file"),
        (lambda: rigfit.load_cloud(missing), f"{missing}: No such file"),
        (lambda: rigfit.load_mesh(tmp_path / "m.stl"), r"m.stl: unsupported file type \(expected a reference mesh: .ply, .obj, .glb or .gltf\)"),
        (lambda: rigfit.load_cloud(tmp_path / "m.glb"), r"m.glb: unsupported file type \(expected a mesh or point cloud: .ply or .obj\)"),
        (lambda: rigfit.load_mesh(bad), 'bad.ply: header line 3: the vertex element has no "y" property'),
        (lambda: rigfit.load_mesh(asset("cmu/01_01.bvh")), r"unsupported file type"),
        (lambda: rigfit.save_mesh(tmp_path / "m.stl", np.zeros((3, 3))), r"m.stl: unsupported file type \(expected a mesh: .ply or .obj\)"),
        (lambda: rigfit.save_mesh(tmp_path / "no" / "m.ply", np.zeros((3, 3))), "m.ply: cannot write: folder .*no"),
        (lambda: rigfit.save_mesh(tmp_path / "m.ply", np.zeros((3, 2))), r"vertices: expected an array of shape \(n, 3\), got shape \[3, 2\]"),
        (lambda: rigfit.save_mesh(tmp_path / "m.ply", [[0, 0, np.inf]]), r"vertices\[0\]: coordinate is not a finite number"),
        (lambda: rigfit.save_mesh(tmp_path / "m.ply", [[0, 0, 1e300]]), r"vertices\[0\]: a coordinate is beyond"),
        (lambda: rigfit.save_mesh(tmp_path / "m.ply", np.zeros((3, 3)), [[0, 1, 3]]), r"faces\[0\]: vertex index 3 is out of range \(0..3\)"),
        (lambda: rigfit.save_mesh(tmp_path / "m.ply", np.zeros((3, 3)), [[0, 1, 2.0]]), "faces: expected integer vertex indices"),
    ]
    for call, message in cases:
        with pytest.raises(rigfit.RigfitError, match=message) as e:
            call()
        assert "\n" not in str(e.value)
    assert sorted(os.listdir(tmp_path)) == ["bad.ply"]


def same_rotations(a, b, atol):
    """Quaternions equal up to sign."""
    return np.abs(np.abs(np.sum(a * b, axis=1)) - 1).max() < atol


@pytest.mark.parametrize("ext", ["glb", "gltf", "bvh"])
def test_a_saved_pose_reads_back_as_the_stored_pose(tmp_path, rig, ext):
    rot, tr = rig.sample(1.5)
    rig.save(tmp_path / f"posed.{ext}", rot, tr)
    back = rigfit.load_rig(tmp_path / f"posed.{ext}")
    assert back.skeleton.names == rig.skeleton.names
    assert same_rotations(back.rotations, rot, 1e-12)
    assert np.allclose(back.translations, tr, atol=1e-12)
    if ext != "bvh":
        assert "rigfit" in back.animations
        assert np.allclose(back.mesh()[0], rig.mesh(rot, tr)[0], atol=1e-9)
    no_temporaries(tmp_path)


@pytest.mark.parametrize("ext, atol", [("glb", 1e-6), ("bvh", 1e-9)])
def test_a_saved_animation_reads_back_frame_by_frame(tmp_path, rig, ext, atol):
    fps = 30.0
    times = 1.0 + np.arange(5) / fps
    poses = [rig.sample(t) for t in times]
    rotations = np.stack([r for r, _ in poses])
    translations = np.stack([t for _, t in poses])
    rig.save_animation(tmp_path / f"anim.{ext}", rotations, translations, fps=fps)
    back = rigfit.load_rig(tmp_path / f"anim.{ext}")
    # A glTF keeps its own animations and gains (or replaces) the `rigfit` one.
    animation = back.animations.index("rigfit") if ext == "glb" else 0
    start, end = back.animation_range(animation)
    assert start == 0 and abs(end - 4 / fps) < 1e-6
    for k in range(len(times)):
        rot, tr = back.sample(k / fps, animation)
        got = back.skeleton.joint_positions(rot, tr)
        want = rig.skeleton.joint_positions(rotations[k], translations[k])
        assert np.abs(got - want).max() < atol * rig.height, k
    # Without translations: the stored pose's, every frame.
    rig.save_animation(tmp_path / f"still.{ext}", rotations[:2], fps=fps)
    back = rigfit.load_rig(tmp_path / f"still.{ext}")
    animation = back.animations.index("rigfit") if ext == "glb" else 0
    _, tr = back.sample(1 / fps, animation)
    assert np.allclose(tr, rig.translations, atol=1e-6)


def test_bad_poses_and_outputs_are_refused(tmp_path, rig):
    n = len(rig.skeleton)
    one = rig.rotations
    cases = [
        (lambda: rig.save(tmp_path / "x.fbx", one), r"x.fbx: unsupported file type \(expected an output rig: .glb, .gltf or .bvh\)"),
        (lambda: rig.save(asset(CHARACTER), one), "rigfit does not overwrite its inputs"),
        (lambda: rig.save(tmp_path / "no" / "x.glb", one), "x.glb: cannot write: folder"),
        (lambda: rig.save(tmp_path / "x.glb", np.zeros((3, 4))), rf"rotations: expected an array of shape \({n}, 4\), got shape \[3, 4\]"),
        (lambda: rig.save(tmp_path / "x.glb", np.zeros((n, 4))), r"rotations\[0\]: a zero quaternion"),
        (lambda: rig.save(tmp_path / "x.glb", one, np.full((n, 3), np.nan)), r"translations\[0\]: coordinate is not a finite number"),
        (lambda: rig.save_animation(tmp_path / "x.glb", one), rf"rotations: expected an array of shape \(frames, {n}, 4\), got shape \[{n}, 4\]"),
        (lambda: rig.save_animation(tmp_path / "x.glb", np.zeros((0, n, 4))), "rotations: no frames"),
        (lambda: rig.save_animation(tmp_path / "x.glb", np.stack([one, 0 * one])), r"rotations\[1\]\[0\]: a zero quaternion"),
        (lambda: rig.save_animation(tmp_path / "x.glb", one[None], np.zeros((2, n, 3))), "translations: 2 frames, rotations has 1"),
        (lambda: rig.save_animation(tmp_path / "x.glb", one[None], fps=0), "fps: expected a number of frames per second from 0.001 to 1000000, got 0"),
        (lambda: rig.save_animation(tmp_path / "x.glb", one[None], fps="fast"), "fps: expected a number, got str"),
        (lambda: rig.mesh(np.zeros((3, 4))), rf"rotations: expected an array of shape \({n}, 4\)"),
        (lambda: rigfit.load_rig(asset("cmu/01_01.bvh")).mesh(), "mesh: .*01_01.bvh: the rig has no skinned mesh"),
        (lambda: rigfit.load_rig(asset("cmu/01_01.bvh")).save(tmp_path / "x.gltf", rigfit.load_rig(asset("cmu/01_01.bvh")).rotations), "expected an output rig: .bvh or .glb"),
    ]
    for call, message in cases:
        with pytest.raises(rigfit.RigfitError, match=message) as e:
            call()
        assert "\n" not in str(e.value)
    assert os.listdir(tmp_path) == []
