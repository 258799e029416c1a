"""The fisheye fit on boards at and beyond 90 degrees off the axis, where OpenCV's own fit fails."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import project
from sogdd.calib.fit import calibrate
from sogdd.calib.solvers import FISHEYE_FOVS, fit_fisheye
from sogdd.calib.targets.board import Board

SIZE = (720, 720)
F, C = 190.0, (359.5, 359.5)
K_TRUE = np.array([[F, 0, C[0]], [0, F * 1.002, C[1]], [0, 0, 1]])
D_TRUE = np.array([0.02, -0.01, 0.002, 0.0])
OBJ = np.array([(i, j, 0.0) for j in range(4) for i in range(6)])
LABELS = OBJ[:, :2].astype(int)


def _boards(n: int, noise: float, seed: int, K: np.ndarray = K_TRUE, dist: np.ndarray = D_TRUE
            ) -> tuple[list[Board], list[np.ndarray]]:
    """``n`` boards (6 x 4 corners) whose centres lie 60-85 degrees off the axis, all round it, facing
    the camera within 25 degrees: their outer corners reach beyond 90 degrees (seen through ``K, dist``)."""
    rng = np.random.default_rng(seed)
    boards, theta = [], []
    for a in np.linspace(0, 2 * np.pi, n, endpoint=False) + rng.uniform(0, 0.3):
        off = np.deg2rad(rng.uniform(60, 85))
        d = np.array([np.sin(off) * np.cos(a), np.sin(off) * np.sin(a), np.cos(off)])
        face = cv2.Rodrigues(np.cross([0, 0, 1.0], d) / np.sin(off) * off)[0]
        R = face @ cv2.Rodrigues(rng.normal(0, 0.25, 3))[0]
        t = rng.uniform(6, 9) * d - R @ np.array([2.5, 1.5, 0])
        rv = cv2.Rodrigues(R)[0].ravel()
        p = project(OBJ, K, dist, "fisheye", rv, t)
        boards.append(Board(p + rng.normal(0, noise, p.shape), LABELS))
        pc = OBJ @ R.T + t
        theta.append(np.arctan2(np.hypot(pc[:, 0], pc[:, 1]), pc[:, 2]))
    return boards, theta


def test_project_takes_the_ray_angle_beyond_90_degrees():
    """A ray at angle theta lands f theta from the centre, whichever side of the image plane it comes from."""
    K = np.array([[200.0, 0, 300], [0, 200, 300], [0, 0, 1]])
    th = np.deg2rad([30.0, 90.0, 100.0, 120.0])
    pts = np.c_[np.sin(th), np.zeros(4), np.cos(th)]
    np.testing.assert_allclose(project(pts, K, np.zeros(4), "fisheye")[:, 0], 300 + 200 * th, atol=1e-9)


def test_the_fisheye_fit_recovers_a_lens_opencv_cannot():
    boards, theta = _boards(10, noise=0.05, seed=3)
    assert max(t.max() for t in theta) > np.deg2rad(90)  # the set does reach beyond a half sphere
    obj = [OBJ.reshape(1, -1, 3)] * len(boards)
    img = [b.image_points.reshape(1, -1, 2) for b in boards]
    try:
        flags = cv2.fisheye.CALIB_RECOMPUTE_EXTRINSIC | cv2.fisheye.CALIB_FIX_SKEW
        crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-12)
        _, K_cv, *_ = cv2.fisheye.calibrate(obj, img, SIZE, np.eye(3), np.zeros(4), flags=flags, criteria=crit)
        opencv_error = abs(K_cv[0, 0] / F - 1)
    except cv2.error:
        opencv_error = np.inf
    assert opencv_error > 0.05  # the premise: OpenCV's initialisation cannot cope

    cal = calibrate(boards, SIZE, model="fisheye", cross_validate=False)
    assert abs(cal.K[0, 0] / K_TRUE[0, 0] - 1) < 0.005 and abs(cal.K[1, 1] / K_TRUE[1, 1] - 1) < 0.005
    assert np.hypot(cal.K[0, 2] - C[0], cal.K[1, 2] - C[1]) < 1.0
    assert cal.rms < 0.1 and cal.n_used == len(boards)
    assert cal.std_note == "" and all(np.isfinite(v) and v > 0 for v in cal.std.values())
    assert cal.std["fx"] < 1.0


def test_fixed_distortion_terms_stay_at_zero():
    boards, _ = _boards(8, noise=0.05, seed=7)
    flags = cv2.fisheye.CALIB_FIX_K3 | cv2.fisheye.CALIB_FIX_K4
    K, D, rv, tv = fit_fisheye([OBJ] * 8, [b.image_points for b in boards], SIZE, flags)
    assert D[2] == 0.0 and D[3] == 0.0 and rv.shape == tv.shape == (8, 3)
    # the true k3 is not 0, so the fit with it held is close, not exact
    assert abs(K[0, 0] / K_TRUE[0, 0] - 1) < 0.03


@pytest.mark.parametrize("fov", [FISHEYE_FOVS[1], FISHEYE_FOVS[-2]])
def test_the_starts_are_equidistant_lenses_of_their_field_of_view(fov):
    """Each start is the equidistant lens that sees ``fov`` across the image's larger side: a ray fov / 2
    off the axis lands on that side's edge, ``f = (max(w, h) / 2) / (fov / 2)``. With the focal length
    held at the start's, a lens of exactly that focal length (k = 0) is fitted to the noise."""
    f = max(SIZE) / 2 / np.deg2rad(fov / 2)
    K = np.array([[f, 0, C[0]], [0, f, C[1]], [0, 0, 1]])
    boards, _ = _boards(8, noise=0.05, seed=5, K=K, dist=np.zeros(4))
    img = [b.image_points for b in boards]
    Kf, D, rv, tv = fit_fisheye([OBJ] * 8, img, SIZE, cv2.fisheye.CALIB_FIX_FOCAL_LENGTH)
    assert Kf[0, 0] == pytest.approx(f, rel=1e-12) and Kf[1, 1] == pytest.approx(f, rel=1e-12)
    r = np.concatenate([i - project(OBJ, Kf, D, "fisheye", a, b) for i, a, b in zip(img, rv, tv)])
    assert np.sqrt(np.mean(np.sum(r * r, axis=1))) < 0.1
