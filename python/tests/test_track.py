"""rigfit.Tracker: a real rig tracked between two of its own animation poses."""

import numpy as np
import pytest
import rigfit
from conftest import asset


def test_tracks_a_small_motion_of_a_real_rig():
    rig = rigfit.load_rig(asset("assimp/BCN_Epileptic.glb"))
    rot0, tr0 = rig.sample(1.5)
    rot1, tr1 = rig.sample(1.5 + 1 / 30)
    # The data: the model's own surface in the next frame's pose.
    cloud = rigfit.Tracker(rig, rot1, tr1).surface_points()
    tracker = rigfit.Tracker(rig, rot0, tr0)
    fit = tracker.track(cloud)
    truth = rig.skeleton.joint_positions(rot1, tr1)
    error = np.linalg.norm(fit.positions - truth, axis=1).mean() / rig.height
    assert error < 0.02, error
    assert fit.inliers > 0.9 * len(cloud) and len(fit.inlier) == len(cloud)
    assert np.allclose(tracker.positions(), fit.positions)


def test_tracker_bad_input():
    rig = rigfit.load_rig(asset("assimp/BCN_Epileptic.glb"))
    tracker = rigfit.Tracker(rig)
    with pytest.raises(rigfit.RigfitError, match="track: the point cloud is empty"):
        tracker.track(np.zeros((0, 3)))
    with pytest.raises(rigfit.RigfitError, match="points: expected an array of shape"):
        tracker.track(np.zeros((5, 2)))
    with pytest.raises(rigfit.RigfitError, match="model: expected a rigfit.Rig or a rigfit.Skeleton"):
        rigfit.Tracker("rig.glb")
    with pytest.raises(rigfit.RigfitError, match="noise: expected a positive fraction"):
        rigfit.Tracker(rig, noise=0.0)
