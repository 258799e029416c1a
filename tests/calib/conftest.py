"""Shared helpers of the calibration tests: boards projected through a known camera, rendered frames.

Fixtures, not imports: the tests run in importlib mode, where one test module cannot import another.
"""

from __future__ import annotations

from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from sogdd.calib.demo import DEMO_DIST, DEMO_K, DEMO_PATTERN, DEMO_SIZE, demo_boards, demo_poses

SIZE, K_TRUE, D_TRUE = DEMO_SIZE, DEMO_K, DEMO_DIST
COLS, ROWS = DEMO_PATTERN
OBJ = np.array([(i, j, 0.0) for j in range(ROWS) for i in range(COLS)])
LABELS = OBJ[:, :2].astype(int)
poses, boards = demo_poses, demo_boards


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
