"""A small, known calibration for examples and doctests (:func:`demo_calibration`)."""

from __future__ import annotations

import functools

import numpy as np

from .cameras import project
from .fit import calibrate
from .result import Calibration
from .targets.board import Board

__all__ = ["demo_calibration"]


@functools.lru_cache(maxsize=1)
def demo_calibration() -> Calibration:
    """A small calibration for examples: eight views of a 9 x 6 board through a known camera.

    The camera is ``fx = fy = 600``, ``(cx, cy) = (320, 240)``, ``k1 = -0.2``,
    ``k2 = 0.05`` at 640 x 480; the corners carry Gaussian noise of 0.03 px
    (seed 0), and a ninth view has no board. Computed once, then cached.

    Examples
    --------
    >>> cal = demo_calibration()
    >>> cal.n_used, len(cal.names), bool(abs(cal.K[0, 0] - 600) < 1)
    (8, 9, True)
    """
    K = np.array([[600.0, 0, 320], [0, 600, 240], [0, 0, 1]])
    obj = np.array([(i, j, 0.0) for j in range(6) for i in range(9)])
    rng = np.random.default_rng(0)
    boards: list[Board | None] = []
    for a in range(8):
        rv, tv = (0.4 * np.sin(a), 0.4 * np.cos(a), 0.1), (-4.0 + 0.5 * np.cos(2 * a), -2.5, 12.0 + a % 3)
        pts = project(obj, K, np.array([-0.2, 0.05, 0, 0, 0]), "pinhole", rv, tv)
        boards.append(Board(pts + rng.normal(0, 0.03, pts.shape), obj[:, :2].astype(int)))
    return calibrate(boards + [None], (640, 480), names=[f"view{v}.png" for v in range(9)])
