"""The unified omnidirectional (Mei) model, added through the lens registry alone: its projection is
``cv2.omnidir.projectPoints``', its fit ``cv2.omnidir.calibrate``'s, on a synthetic 200-degree fisheye."""

import cv2
import numpy as np
import pytest

from sogdd.calib import calibrate
from sogdd.calib.cameras import LENSES, MODELS, lens, project
from sogdd.calib.cameras.fisheye import fisheye_distorted
from sogdd.calib.model_selection import select_model
from sogdd.calib.rig import calibrate_rig
from sogdd.calib.targets.board import Board

SIZE = (1000, 1000)
OBJ = np.array([(i, j, 0.0) for j in range(6) for i in range(9)])


def _facing(d: np.ndarray) -> np.ndarray:
    """A board rotation whose normal points back along ``d`` (the board faces the camera)."""
    z = -d
    x = np.cross([0.0, 1.0, 0.0], z) if abs(z[1]) < 0.9 else np.cross([1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], 1)


def _wide_views(noise: float = 0.1, seed: int = 0):
    """Corners of 15 views of a 9x6 board through an equidistant fisheye (f = 190 px), the boards
    up to 100 degrees off the axis on every side: the views span more than 200 degrees."""
    rng = np.random.default_rng(seed)
    objs, imgs, widest = [], [], 0.0
    for th in np.radians([0, 30, 55, 75, 88, 95, 100, 60, 80, 92, 98, 45, 70, 85, 97]):
        ph = rng.uniform(0, 2 * np.pi)
        d = np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
        R = _facing(d) @ cv2.Rodrigues(rng.normal(0, 0.25, 3))[0]
        P = OBJ @ R.T + (8.0 * d - R @ np.array([4.0, 2.5, 0.0]))
        widest = max(widest, float(np.degrees(np.arccos(P[:, 2] / np.linalg.norm(P, axis=1))).max()))
        uv = fisheye_distorted(P, np.zeros(4)) * 190 + 499.5
        objs.append(OBJ.copy())
        imgs.append(uv + rng.normal(0, noise, uv.shape))
    return objs, imgs, widest


def test_the_model_is_one_registry_row():
    rec = lens("omnidir")
    assert list(LENSES)[-1] == "omnidir" and MODELS["omnidir"] == ("xi", "k1", "k2", "p1", "p2")
    assert rec.fisheye and rec.start == "omnidir.calibrate" and rec.auto_fov == 150.0


def test_projection_is_opencvs():
    rng = np.random.default_rng(3)
    # points all round the camera, 0 to 120 degrees off the axis, seen through xi = 1.3
    th, ph = np.radians(rng.uniform(0, 120, 200)), rng.uniform(0, 2 * np.pi, 200)
    X = np.c_[np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)] * rng.uniform(1, 5, (200, 1))
    K = np.array([[310.0, 0.0, 512.3], [0.0, 305.0, 498.7], [0.0, 0.0, 1.0]])
    xi, D = 1.3, np.array([-0.12, 0.03, 0.002, -0.001])
    rv, tv = np.array([0.1, -0.2, 0.05]), np.array([0.3, -0.1, 0.2])
    ours = project(X, K, np.r_[xi, D], "omnidir", rv, tv)
    cv, _ = cv2.omnidir.projectPoints(X.reshape(-1, 1, 3), rv, tv, K, xi, D)
    assert np.abs(ours - cv.reshape(-1, 2)).max() < 1e-6


def test_unprojection_inverts_projection_beyond_90_degrees():
    K = np.array([[300.0, 0.0, 500.0], [0.0, 300.0, 500.0], [0.0, 0.0, 1.0]])
    dist = np.array([1.4, -0.05, 0.01, 0.001, -0.002])
    th = np.radians(np.linspace(0, 110, 12))
    rays = np.c_[np.sin(th) * 0.6, np.sin(th) * 0.8, np.cos(th)]
    back = lens("omnidir").unproject(project(rays, K, dist, "omnidir"), K, dist)
    assert np.abs(back - rays).max() < 1e-9


def test_fit_of_a_200_degree_fisheye_is_opencvs():
    objs, imgs, widest = _wide_views()
    assert widest > 100  # a corner beyond 100 degrees off the axis: the views span over 200 degrees
    cal = calibrate([Board(i, OBJ[:, :2].astype(int)) for i in imgs], SIZE, model="omnidir", reject=False,
                    cross_validate=False)
    o = [p.reshape(-1, 1, 3) for p in objs]
    i = [p.reshape(-1, 1, 2) for p in imgs]
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 300, 1e-12)
    _, K, xi, D, rv, tv, idx = cv2.omnidir.calibrate(o, i, SIZE, None, None, None, cv2.omnidir.CALIB_FIX_SKEW,
                                                     crit)
    assert cal.model == "omnidir" and cal.K[0, 1] == 0
    assert np.allclose(cal.K, K, rtol=0, atol=1e-9)
    assert np.allclose(cal.dist, np.r_[np.ravel(xi), np.ravel(D)], rtol=0, atol=1e-9)
    # the corners' noise is 0.1 px; Mei's radial-tangential terms follow an equidistant lens at 130 degrees
    # off the axis to a fraction of a pixel
    assert cal.rms < 0.3
    for n, v in enumerate(np.ravel(idx)):
        cv, _ = cv2.omnidir.projectPoints(o[v], rv[n], tv[n], K, float(np.ravel(xi)[0]), D)
        ours = project(objs[v], cal.K, cal.dist, "omnidir", cal.rvecs[v], cal.tvecs[v])
        assert np.abs(ours - cv.reshape(-1, 2)).max() < 1e-6
    # the views OpenCV's initialisation left out got their poses from their rays
    left_out = sorted(set(range(len(objs))) - set(np.ravel(idx).tolist()))
    for v in left_out:
        r = imgs[v] - project(objs[v], cal.K, cal.dist, "omnidir", cal.rvecs[v], cal.tvecs[v])
        assert np.sqrt(np.mean(np.sum(r * r, axis=1))) < 0.3
    assert all(np.isfinite(s) and s > 0 for s in cal.std.values())


def test_auto_tries_it_only_for_views_beyond_150_degrees():
    objs, imgs, _ = _wide_views()
    boards = [Board(i, OBJ[:, :2].astype(int)) for i in imgs]
    sel = select_model(boards[:8], SIZE, folds=2)
    assert [r.model for r in sel.table][-2:] == ["fisheye", "omnidir"]
    assert any("fisheye, omnidir added" in n for n in sel.notes)
    K = np.array([[600.0, 0, 320], [0, 600, 240], [0, 0, 1]])
    rng = np.random.default_rng(1)
    poses = [((0.4 * np.sin(a), 0.4 * np.cos(a), 0.1), (-4.0 + np.cos(a), -2.5 + np.sin(a), 11.0))
             for a in np.linspace(0, 6, 10)]
    dist = np.array([-0.2, 0.05, 0, 0])
    labels = OBJ[:, :2].astype(int)
    narrow = [Board(project(OBJ, K, dist, "pinhole", r, t) + rng.normal(0, 0.1, (54, 2)), labels)
              for r, t in poses]
    assert "omnidir" not in [r.model for r in select_model(narrow, (640, 480)).table]


def test_the_rig_fit_refuses_it_in_one_line():
    objs, imgs, _ = _wide_views()
    boards = [Board(i, OBJ[:, :2].astype(int)) for i in imgs]
    with pytest.raises(ValueError, match="joint rig fit cannot take the omnidir model") as err:
        calibrate_rig({"a": boards, "b": boards}, {"a": SIZE, "b": SIZE}, models="omnidir")
    assert "\n" not in str(err.value)
