"""The cameras the formats hold: checked on construction, made from sogdd's results, scaled, re-referenced."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import project
from sogdd.calib.demo import demo_calibration
from sogdd.calib.exchange import StoredCamera, StoredRig, stored_rig
from sogdd.calib.rig.demo import demo_rig

K = [[600.0, 0, 320], [0, 601, 240], [0, 0, 1]]


def test_sogdds_results_become_stored_rigs_unchanged():
    cal = demo_calibration()
    (cam,) = stored_rig(cal, name="front").cameras
    assert (cam.name, cam.model) == ("front", cal.model) and np.array_equal(cam.K, cal.K)
    rig = demo_rig()
    stored = stored_rig(rig)
    assert stored.names == rig.names
    pts = np.array([[0.1, -0.2, 3.0], [0.5, 0.3, 2.0]])
    right = rig.camera("right")
    ours = stored.camera("right").project(pts, in_reference=True)
    R, T = np.asarray(right.R), np.ravel(right.T)
    assert np.array_equal(ours, project(pts @ R.T + T, right.K, right.dist, right.model))
    with pytest.raises(TypeError, match="not a calibration"):
        stored_rig("camera.yaml")


@pytest.mark.parametrize(("kwargs", "why"), [
    ({"model": "pinhole5"}, "unknown camera model"),
    ({"dist": [0.1, 0.2, 0.0]}, "dist"),
    ({"K": [[600.0, 0, 320], [0, -1, 240], [0, 0, 1]]}, "fx, fy > 0"),
    ({"R": np.diag([1.0, 1.0, -1.0])}, "rotation"),
    ({"T": [0.0, np.nan, 0.0]}, "finite"),
])
def test_a_camera_that_is_not_one_is_refused(kwargs, why):
    args = {"name": "c", "model": "pinhole4", "K": K, "dist": [0.0] * 4, "image_size": (640, 480)} | kwargs
    with pytest.raises(ValueError, match=why):
        StoredCamera(**args)


def test_scaled_and_relative_keep_the_geometry():
    R0 = cv2.Rodrigues(np.array([0.1, 0.2, -0.1]))[0]
    R1 = cv2.Rodrigues(np.array([-0.05, 0.3, 0.02]))[0]
    rig = StoredRig((StoredCamera("a", "pinhole4", K, [0.0] * 4, (640, 480), R0, [1.0, 2.0, 3.0]),
                     StoredCamera("b", "pinhole4", K, [0.0] * 4, (640, 480), R1, [-4.0, 0.5, 1.0])))
    rel = rig.relative()
    assert np.allclose(rel.cameras[0].R, np.eye(3), atol=1e-15) and np.allclose(rel.cameras[0].T, 0, atol=1e-15)
    x = np.array([[0.3, -0.1, 5.0]])  # a world point: both cameras see it where they did
    for a, b in zip(rig.cameras, rel.cameras):
        x_ref = x @ rig.cameras[0].R.T + rig.cameras[0].T
        assert np.abs(a.project(x, in_reference=True) - b.project(x_ref, in_reference=True)).max() < 1e-9
    assert rig.scaled(0.001).cameras[1].T.tolist() == [-0.004, 0.0005, 0.001]
    with pytest.raises(ValueError, match="positive"):
        rig.scaled(0)
    with pytest.raises(ValueError, match="distinct names"):
        StoredRig((rig.cameras[0], rig.cameras[0]))


def test_the_uncertainties_are_optional_and_follow_the_geometry():
    """Unknown by default; a vector as OpenCV's std_intrinsics; a held parameter's 0 is unknown; a new pose
    drops the pose's, a new unit scales the baseline's and the square."""
    cam = StoredCamera("a", "pinhole4", K, [0.0] * 4, (640, 480))
    assert all(np.isnan(v) for v in (*cam.std.values(), cam.rms, *cam.pose_std.values()))
    cam = StoredCamera("b", "pinhole4", K, [0.0] * 4, (640, 480), T=[-2.0, 0, 0], std=[0.5, 0.4, 0.0],
                       rms=0.1, pose_std={"rotation_deg": 0.01, "baseline": 0.02})
    assert cam.std["fx"] == 0.5 and cam.std["fy"] == 0.4 and np.isnan(cam.std["cx"]) and np.isnan(cam.std["cy"])
    assert cam.intrinsics == {"fx": 600.0, "fy": 601.0, "cx": 320.0, "cy": 240.0}
    rig = StoredRig((StoredCamera("a", "pinhole4", K, [0.0] * 4, (640, 480)), cam), square=25.0)
    scaled = rig.scaled(0.001)
    assert scaled.square == pytest.approx(0.025)
    assert scaled.cameras[1].pose_std["baseline"] == pytest.approx(2e-5)
    assert scaled.cameras[1].std == pytest.approx(cam.std, nan_ok=True) and scaled.cameras[1].rms == 0.1
    assert rig.relative().cameras[1].pose_std == cam.pose_std  # already in the first camera's frame
    moved = cam.with_pose(np.eye(3), [-3.0, 0, 0])
    assert moved.std == pytest.approx(cam.std, nan_ok=True) and np.isnan(moved.pose_std["baseline"])
    assert cam.with_pose(cam.R, cam.T, "c").pose_std == cam.pose_std
    cal = stored_rig(demo_calibration())
    assert cal.square == 1.0 and cal.cameras[0].std["fx"] > 0 and cal.cameras[0].rms > 0
    with pytest.raises(ValueError, match="square"):
        StoredRig(rig.cameras, square=0)
