"""Shared helpers of the calibration tests: boards projected through a known camera (the rendered frames
are in tests/conftest.py, shared with the command's tests).

Fixtures, not imports: the tests run in importlib mode, where one test module cannot import another.
"""

from __future__ import annotations

from types import SimpleNamespace

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
