"""Shared helpers of the calibration tests: boards projected through a known camera, rendered frames.

Fixtures, not imports: the tests run in importlib mode, where one test module cannot import another.
"""

from __future__ import annotations

from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import project
from sogdd.calib.targets.board import Board

SIZE = (640, 480)
K_TRUE = np.array([[600.0, 0, 322.0], [0, 598.0, 236.0], [0, 0, 1]])
D_TRUE = np.array([-0.25, 0.08, 0.001, -0.0005, 0.0])
COLS, ROWS = 9, 6
OBJ = np.array([(i, j, 0.0) for j in range(ROWS) for i in range(COLS)])
LABELS = OBJ[:, :2].astype(int)


def poses(n: int, rng: np.random.Generator, K=K_TRUE, dist=D_TRUE, model="pinhole", size=SIZE,
          spread: float = 1.0):
    """``n`` board poses (tilt <= 35 degrees) whose corners all fall inside the frame."""
    out = []
    w, h = size
    while len(out) < n:
        tilt = np.deg2rad(35) * rng.uniform(0, 1)
        axis = rng.normal(size=3)
        axis[2] *= 0.3
        rvec = axis / np.linalg.norm(axis) * tilt
        z = rng.uniform(11, 18)
        centre = np.array([w / 2, h / 2]) + spread * rng.uniform(-0.3, 0.3, 2) * [w, h]
        ray = np.linalg.solve(K, [centre[0], centre[1], 1.0])
        R, _ = cv2.Rodrigues(rvec)
        tvec = ray * z - R @ np.array([(COLS - 1) / 2, (ROWS - 1) / 2, 0.0])
        p = project(OBJ, K, dist, model, rvec, tvec)
        if np.all((p > 5) & (p < [w - 6, h - 6])):
            out.append((rvec, tvec, p))
    return out


def boards(n=14, noise=0.05, seed=1, **kw):
    """``n`` 9 x 6 boards seen through ``K_TRUE``/``D_TRUE`` (:func:`poses`), with Gaussian noise in px."""
    rng = np.random.default_rng(seed)
    return [Board(p + rng.normal(0, noise, p.shape), LABELS) for _, _, p in poses(n, rng, **kw)]


@pytest.fixture(scope="session")
def synthetic():
    """The known camera and board of the synthetic tests, and :func:`poses` and :func:`boards`."""
    return SimpleNamespace(SIZE=SIZE, K_TRUE=K_TRUE, D_TRUE=D_TRUE, COLS=COLS, ROWS=ROWS, OBJ=OBJ,
                           LABELS=LABELS, poses=poses, boards=boards)


#: the rendered frames' camera (fx = fy = 560 at 640 x 480)
RENDER_K = np.array([[560.0, 0, 322.0], [0, 560.0, 236.0], [0, 0, 1]])
RENDER_DIST = (-0.2, 0.06, 0.001, -0.0005, 0.0)


@pytest.fixture(scope="session")
def rendered_frames(tmp_path_factory):
    """Eight rendered 640 x 480 views of a 9 x 6 board (blur 0.8 px, noise 2 grey levels), f0.png ... f7.png.

    Read only: a test that changes the set copies it.
    """
    render = pytest.importorskip("sogdd.evaluation.calibration.render")
    cam = render.Camera(RENDER_K, RENDER_DIST, (640, 480))
    target = render.ChessboardTarget(9, 6, 1.0)
    folder = tmp_path_factory.mktemp("frames")
    for k, (rv, tv) in enumerate(render.random_sequence(cam, target, 8, seed=3)):
        view = render.render_view(cam, target, rv, tv, blur=0.8, noise=2.0, rng=k)
        assert cv2.imwrite(str(folder / f"f{k}.png"), view.image)
    return folder
