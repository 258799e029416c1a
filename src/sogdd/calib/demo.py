"""Known cameras and boards for examples, doctests and tests: :func:`demo_calibration`, and
:func:`demo_boards`, boards of a 9 x 6 pattern projected through a known camera."""

from __future__ import annotations

import functools

import cv2
import numpy as np

from .cameras import CameraModel, project
from .fit import calibrate
from .result import Calibration
from .targets.board import Board

__all__ = ["DEMO_DIST", "DEMO_K", "DEMO_PATTERN", "DEMO_SIZE", "demo_boards", "demo_calibration", "demo_poses"]

#: the known camera of :func:`demo_boards`: 640 x 480, fx 600, fy 598, and OpenCV's k1, k2, p1, p2, k3
DEMO_SIZE = (640, 480)
DEMO_K = np.array([[600.0, 0, 322.0], [0, 598.0, 236.0], [0, 0, 1]])
DEMO_DIST = np.array([-0.25, 0.08, 0.001, -0.0005, 0.0])
#: its board: 9 x 6 inner corners, labels (i, j) and object points (i, j, 0), row by row
DEMO_PATTERN = (9, 6)
_OBJ = np.array([(i, j, 0.0) for j in range(DEMO_PATTERN[1]) for i in range(DEMO_PATTERN[0])])


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


def demo_poses(n: int, rng: np.random.Generator, K: np.ndarray = DEMO_K, dist: np.ndarray = DEMO_DIST,
               model: CameraModel = "pinhole", size: tuple[int, int] = DEMO_SIZE,
               spread: float = 1.0) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """``n`` poses of the 9 x 6 board whose corners all fall inside the frame: ``(rvec, tvec, pixels)``.

    Each pose tilts the board by up to 35 degrees about a random axis (mostly
    in the image plane), 11-18 squares away, its centre on the ray of a pixel
    within ``0.3 spread`` of the frame's size from the frame's centre; a pose
    with a corner within 5 px of the frame's edge is drawn again.

    Examples
    --------
    >>> rv, tv, px = demo_poses(1, np.random.default_rng(0))[0]
    >>> px.shape, bool(np.all((px > 5) & (px < [634, 474])))
    ((54, 2), True)
    """
    out = []
    w, h = size
    cols, rows = DEMO_PATTERN
    while len(out) < n:
        tilt = np.deg2rad(35) * rng.uniform(0, 1)
        axis = rng.normal(size=3)
        axis[2] *= 0.3
        rvec = axis / np.linalg.norm(axis) * tilt
        z = rng.uniform(11, 18)
        centre = np.array([w / 2, h / 2]) + spread * rng.uniform(-0.3, 0.3, 2) * [w, h]
        ray = np.linalg.solve(K, [centre[0], centre[1], 1.0])
        R, _ = cv2.Rodrigues(rvec)
        tvec = ray * z - R @ np.array([(cols - 1) / 2, (rows - 1) / 2, 0.0])
        p = project(_OBJ, K, dist, model, rvec, tvec)
        if np.all((p > 5) & (p < [w - 6, h - 6])):
            out.append((rvec, tvec, p))
    return out


def demo_boards(n: int = 14, noise: float = 0.05, seed: int = 1, **kw) -> list[Board]:
    """``n`` boards of :func:`demo_poses` (``kw`` goes there) with Gaussian noise of ``noise`` px.

    Examples
    --------
    >>> cal = calibrate(demo_boards(14), DEMO_SIZE)
    >>> bool(abs(cal.K[0, 0] - 600) < 1 and abs(cal.K[1, 1] - 598) < 1)
    True
    """
    rng = np.random.default_rng(seed)
    labels = _OBJ[:, :2].astype(int)
    return [Board(p + rng.normal(0, noise, p.shape), labels) for _, _, p in demo_poses(n, rng, **kw)]
