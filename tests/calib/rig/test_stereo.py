"""stereo_pair() and rectify_points(): OpenCV's stereo conventions, checked on a known rig's true points."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import project, undistort
from sogdd.calib.rig import calibrate_rig, rectify_points, stereo_pair
from sogdd.calib.rig.demo import synthetic_rig


@pytest.fixture(scope="module")
def known():
    d = synthetic_rig(cameras=2, frames=12, noise=0.05, seed=21)
    return d, calibrate_rig(d.boards, d.image_sizes)


def _true_points(d, f: int, cam: int):
    """Frame ``f``'s board corners in camera ``cam``'s true frame, and their noiseless pixels."""
    cols, rows = d.pattern
    obj = np.array([(i, j, 0.0) for j in range(rows) for i in range(cols)])
    X0 = obj @ cv2.Rodrigues(d.rvecs[f])[0].T + d.tvecs[f]
    Xc = X0 @ d.R[cam].T + d.T[cam]
    return obj, Xc, project(Xc, d.K[cam], d.dist[cam], d.models[d.names[cam]])


def _both(d):
    return [f for f in range(len(d.rvecs)) if all(d.boards[n][f] is not None and d.boards[n][f].size
                                                  for n in d.names)]


def test_the_pair_agrees_with_opencv_stereo_calibrate(known):
    d, rig = known
    pair = stereo_pair(rig)
    a, b = rig.cameras
    frames = _both(d)
    obj = [d.boards["cam0"][f].object_points().astype(np.float32) for f in frames]
    i1 = [d.boards["cam0"][f].image_points.astype(np.float32) for f in frames]
    i2 = [d.boards["cam1"][f].image_points.astype(np.float32) for f in frames]
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    _, _, _, _, _, R, T, E, F = cv2.stereoCalibrate(obj, i1, i2, a.K, a.dist, b.K, b.dist, a.image_size,
                                                    flags=cv2.CALIB_FIX_INTRINSIC, criteria=crit)
    angle = np.degrees(np.linalg.norm(cv2.Rodrigues(R @ pair.R.T)[0]))
    assert angle < 0.05 and np.abs(T.ravel() - pair.T).max() < 0.03
    assert np.allclose(pair.E / np.linalg.norm(pair.E), E / np.linalg.norm(E), atol=0.01)
    assert pair.names == ("cam0", "cam1") and pair.P1.shape == (3, 4) and pair.Q.shape == (4, 4)


def test_e_and_f_hold_on_the_true_points(known):
    """The true corners' pixels, as the estimated cameras see them (their rays by the estimated
    intrinsics), satisfy the epipolar constraint to a small part of a pixel."""
    d, rig = known
    pair = stereo_pair(rig)
    a, b = rig.cameras
    f = _both(d)[0]
    x0 = np.c_[undistort(_true_points(d, f, 0)[2], a.K, a.dist, a.model)[0], np.ones(54)]
    x1 = np.c_[undistort(_true_points(d, f, 1)[2], b.K, b.dist, b.model)[0], np.ones(54)]
    E = pair.E / np.linalg.norm(pair.T)  # x1^T E x0 = 0 for the rays of one point, E up to |T|
    assert np.abs(np.einsum("ni,ij,nj->n", x1, E, x0)).max() < 2e-4
    u0, u1 = x0 @ a.K.T, x1 @ b.K.T  # undistorted pixels
    lines = u0 @ pair.F.T  # the epipolar lines in the second image
    dist = np.abs(np.sum(lines * u1, axis=1)) / np.hypot(lines[:, 0], lines[:, 1])
    assert np.sqrt(np.mean(dist ** 2)) < 0.03 and dist.max() < 0.1
    # the true rays too, within the pose's error
    _, X0, _ = _true_points(d, f, 0)
    _, X1, _ = _true_points(d, f, 1)
    assert np.abs(np.einsum("ni,ij,nj->n", X1 / X1[:, 2:], E, X0 / X0[:, 2:])).max() < 1e-3


def test_rectified_true_corners_share_their_rows(known):
    d, rig = known
    pair = stereo_pair(rig)
    a, b = rig.cameras
    dy = []
    for f in _both(d):
        q1 = rectify_points(pair, a.K, a.dist, a.model, _true_points(d, f, 0)[2], 1)
        q2 = rectify_points(pair, b.K, b.dist, b.model, _true_points(d, f, 1)[2], 2)
        dy.append(q1[:, 1] - q2[:, 1])
    dy = np.concatenate(dy)
    assert np.sqrt(np.mean(dy ** 2)) < 0.05 and np.abs(dy).max() < 0.15
    # what cv2.undistortPoints gives, converged
    px = _true_points(d, _both(d)[0], 0)[2]
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    ref = cv2.undistortPoints(px.reshape(-1, 1, 2), a.K, a.dist, R=pair.R1, P=pair.P1, criteria=crit)
    ref = ref.reshape(-1, 2)
    assert np.abs(rectify_points(pair, a.K, a.dist, a.model, px, 1) - ref).max() < 1e-3


def test_a_fisheye_pair_is_rectified_by_the_fisheye_rectification():
    d = synthetic_rig(cameras=2, frames=12, noise=0.05, seed=22, models={"cam0": "fisheye", "cam1": "fisheye"})
    rig = calibrate_rig(d.boards, d.image_sizes, models="fisheye")
    pair = stereo_pair(rig)
    a, b = rig.cameras
    f = _both(d)[0]
    q1 = rectify_points(pair, a.K, a.dist, a.model, _true_points(d, f, 0)[2], 1)
    q2 = rectify_points(pair, b.K, b.dist, b.model, _true_points(d, f, 1)[2], 2)
    assert np.sqrt(np.mean((q1[:, 1] - q2[:, 1]) ** 2)) < 0.1
    xy, _ = undistort(_true_points(d, f, 0)[2], a.K, a.dist, "fisheye")
    assert np.all(np.isfinite(xy))


def test_pairs_of_larger_rigs_are_named():
    d = synthetic_rig(cameras=3, frames=12, noise=0.05, seed=23, baseline=3.0)
    rig = calibrate_rig(d.boards, d.image_sizes)
    with pytest.raises(ValueError, match="name the stereo pair"):
        stereo_pair(rig)
    pair = stereo_pair(rig, "cam1", "cam2")
    R = d.R[2] @ d.R[1].T
    assert np.degrees(np.linalg.norm(cv2.Rodrigues(pair.R @ R.T)[0])) < 0.1
    assert np.abs(pair.T - (d.T[2] - R @ d.T[1])).max() < 0.05
    with pytest.raises(ValueError, match="twice"):
        stereo_pair(rig, "cam1", "cam1")
    with pytest.raises(ValueError, match="which must be 1 or 2"):
        rectify_points(pair, rig.cameras[0].K, rig.cameras[0].dist, "pinhole", np.zeros((1, 2)), 3)


def test_the_pair_unpacks_as_opencvs_nine_matrices(known):
    """What the guide says it gives: ``R, T, E, F, R1, R2, P1, P2, Q = stereo_pair(rig)``, the same arrays as
    the pair's attributes."""
    _, rig = known
    pair = stereo_pair(rig)
    R, T, E, F, R1, R2, P1, P2, Q = stereo_pair(rig)
    for got, name in zip((R, T, E, F, R1, R2, P1, P2, Q), ("R", "T", "E", "F", "R1", "R2", "P1", "P2", "Q")):
        np.testing.assert_array_equal(got, getattr(pair, name))
    assert T.shape == (3,) and P2.shape == (3, 4) and Q.shape == (4, 4)
