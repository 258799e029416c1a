"""The chessboard target of the calibration renderer (:mod:`.render` has the maths); its camera is
:class:`sogdd.calib.cameras.Camera`, the one camera model of calibration and evaluation."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...calib.cameras import Camera, pose_matrix

__all__ = ["Camera", "ChessboardTarget", "pose_matrix", "in_frame"]


@dataclass(frozen=True)
class ChessboardTarget:
    """A chessboard of ``cols x rows`` inner corners (OpenCV's ``patternSize``) and squares of ``square``.

    Inner corner ``(i, j)`` is at ``(i square, j square, 0)``; the squares cover
    ``[-square, cols square] x [-square, rows square]`` and a white margin of
    ``margin`` (None: one square) surrounds them.

    Examples
    --------
    >>> t = ChessboardTarget(3, 2, 10.0)
    >>> t.labels().tolist()
    [[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1]]
    >>> t.object_points()[-1].tolist()
    [20.0, 10.0, 0.0]
    """

    cols: int
    rows: int
    square: float = 1.0
    margin: float | None = None

    def __post_init__(self) -> None:
        if int(self.cols) < 1 or int(self.rows) < 1:
            raise ValueError(f"a chessboard needs >= 1 inner corner each way, got {self.cols} x {self.rows}")
        if not (self.square > 0 and math.isfinite(self.square)):
            raise ValueError(f"square must be positive, got {self.square}")
        m = self.square if self.margin is None else float(self.margin)
        if not (m >= 0 and math.isfinite(m)):
            raise ValueError(f"margin must be >= 0, got {self.margin}")
        object.__setattr__(self, "cols", int(self.cols))
        object.__setattr__(self, "rows", int(self.rows))
        object.__setattr__(self, "square", float(self.square))
        object.__setattr__(self, "margin", m)

    @property
    def pattern_size(self) -> tuple[int, int]:
        return (self.cols, self.rows)

    def labels(self) -> np.ndarray:
        """``(i, j)`` of every inner corner (N, 2) int64, ``i`` fastest (OpenCV's order)."""
        j, i = np.mgrid[0:self.rows, 0:self.cols]
        return np.stack([i.ravel(), j.ravel()], axis=1).astype(np.int64)

    def object_points(self) -> np.ndarray:
        """Board coordinates (N, 3) of the inner corners, in :meth:`labels`' order."""
        out = np.zeros((self.cols * self.rows, 3))
        out[:, :2] = self.labels() * self.square
        return out

    def outline(self, with_margin: bool = False, per_side: int = 16) -> np.ndarray:
        """Points (4 per_side, 3) along the squares' (or the paper's) outer edge."""
        s, m = self.square, (self.margin if with_margin else 0.0)
        u0, u1, v0, v1 = -s - m, self.cols * s + m, -s - m, self.rows * s + m
        t = np.linspace(0.0, 1.0, per_side, endpoint=False)
        sides = [np.stack([u0 + (u1 - u0) * t, np.full_like(t, v0)], 1),
                 np.stack([np.full_like(t, u1), v0 + (v1 - v0) * t], 1),
                 np.stack([u1 - (u1 - u0) * t, np.full_like(t, v1)], 1),
                 np.stack([np.full_like(t, u0), v1 - (v1 - v0) * t], 1)]
        uv = np.concatenate(sides)
        return np.concatenate([uv, np.zeros((len(uv), 1))], axis=1)

def in_frame(corners: np.ndarray, size: tuple[int, int], border: float) -> np.ndarray:
    """Whether each point (N, 2) is finite and at least ``border`` px inside a frame of ``size`` (w, h)."""
    w, h = size
    with np.errstate(invalid="ignore"):
        return (np.all(np.isfinite(corners), axis=1) & (corners[:, 0] >= border) & (corners[:, 1] >= border)
                & (corners[:, 0] <= w - 1 - border) & (corners[:, 1] <= h - 1 - border))
