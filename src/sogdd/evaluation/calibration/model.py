"""The camera model and the chessboard target of the calibration renderer (:mod:`.render` has the maths)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["Camera", "ChessboardTarget", "pose_matrix", "in_frame"]


@dataclass(frozen=True)
class Camera:
    """A pinhole camera with OpenCV's distortion ``(k1, k2, p1, p2[, k3])``.

    Parameters
    ----------
    K : (3, 3) array
        Intrinsic matrix ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]``.
    dist : sequence of 4 or 5 floats
        ``(k1, k2, p1, p2[, k3])``; stored as five values.
    size : (width, height)
        Image size in pixels.

    Examples
    --------
    >>> cam = Camera(np.array([[800.0, 0, 319.5], [0, 800.0, 239.5], [0, 0, 1]]), (0.0, 0, 0, 0), (640, 480))
    >>> cam.project(np.array([[0.0, 0.0, 2.0], [0.1, 0.0, 1.0]])).round(6).tolist()
    [[319.5, 239.5], [399.5, 239.5]]
    >>> cam.fx, cam.width, cam.height
    (800.0, 640, 480)
    """

    K: np.ndarray
    dist: tuple = (0.0, 0.0, 0.0, 0.0, 0.0)
    size: tuple[int, int] = (640, 480)

    def __post_init__(self) -> None:
        K = np.asarray(self.K, dtype=np.float64)
        if K.shape != (3, 3) or not np.all(np.isfinite(K)) or K[0, 0] <= 0 or K[1, 1] <= 0:
            raise ValueError(f"K must be a finite (3, 3) matrix with positive focal lengths, got {K.tolist()}")
        d = tuple(float(v) for v in np.asarray(self.dist, dtype=np.float64).reshape(-1))
        if len(d) not in (4, 5) or not all(math.isfinite(v) for v in d):
            raise ValueError(f"dist must be 4 or 5 finite values (k1, k2, p1, p2[, k3]), got {d}")
        w, h = (int(v) for v in self.size)
        if w < 1 or h < 1:
            raise ValueError(f"size must be (width, height) >= 1, got {self.size}")
        K = K.copy()
        K.setflags(write=False)
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "dist", d + (0.0,) * (5 - len(d)))
        object.__setattr__(self, "size", (w, h))

    @property
    def fx(self) -> float:
        return float(self.K[0, 0])

    @property
    def fy(self) -> float:
        return float(self.K[1, 1])

    @property
    def width(self) -> int:
        return self.size[0]

    @property
    def height(self) -> int:
        return self.size[1]

    def distort(self, xy: np.ndarray) -> np.ndarray:
        """Pixels of normalised coordinates ``(x', y')`` (N, 2): the model of the module doc."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        xd, yd = _distort_np(xy[:, 0], xy[:, 1], self.dist)
        K = self.K
        return np.stack([K[0, 0] * xd + K[0, 1] * yd + K[0, 2], K[1, 1] * yd + K[1, 2]], axis=1)

    def project(self, points3d: np.ndarray, rvec: np.ndarray | None = None,
                tvec: np.ndarray | None = None) -> np.ndarray:
        """Project 3-D points (N, 3) to pixels (N, 2), as ``cv2.projectPoints``.

        The points are in the camera frame, or in a frame given by ``rvec``
        (Rodrigues vector) and ``tvec``: ``X_c = R(rvec) X + tvec``. Points at
        or behind the camera's centre plane give NaN.
        """
        P = np.asarray(points3d, dtype=np.float64).reshape(-1, 3)
        if rvec is not None or tvec is not None:
            R, t = pose_matrix(np.zeros(3) if rvec is None else rvec, np.zeros(3) if tvec is None else tvec)
            P = P @ R.T + t
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(P[:, 2] > 0, P[:, 2], np.nan)
            return self.distort(np.stack([P[:, 0] / z, P[:, 1] / z], axis=1))

    def undistort(self, pixels: np.ndarray, *, tol: float = 1e-13, max_iter: int = 100) -> np.ndarray:
        """Normalised coordinates ``(x', y')`` (N, 2) of pixels (N, 2): the exact inverse of :meth:`distort`.

        Newton's method on ``distort(x') = pixel`` from ``x' = K^-1 pixel``,
        until every step is below ``tol`` (in normalised units). A pixel where
        it does not converge (beyond the model's fold) gives NaN.
        """
        px = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
        K = self.K
        yd = (px[:, 1] - K[1, 2]) / K[1, 1]
        xd = (px[:, 0] - K[0, 2] - K[0, 1] * yd) / K[0, 0]
        x, y = xd.copy(), yd.copy()
        active = np.ones(len(px), dtype=bool)
        for _ in range(max_iter):
            if not active.any():
                break
            xa, ya = x[active], y[active]
            fx_, fy_ = _distort_np(xa, ya, self.dist)
            j00, j01, j10, j11 = _distort_jac_np(xa, ya, self.dist)
            ex, ey = fx_ - xd[active], fy_ - yd[active]
            det = j00 * j11 - j01 * j10
            dx = (j11 * ex - j01 * ey) / det
            dy = (-j10 * ex + j00 * ey) / det
            x[active], y[active] = xa - dx, ya - dy
            step = np.maximum(np.abs(dx), np.abs(dy))
            idx = np.flatnonzero(active)
            active[idx[~(step > tol)]] = False  # NaN steps stop too
        out = np.stack([x, y], axis=1)
        bad = active | ~np.all(np.isfinite(out), axis=1)
        if bad.any():
            back = self.distort(out[~bad]) if (~bad).any() else np.zeros((0, 2))
            out[bad] = np.nan
            # a fold of the model can converge to a far-off preimage: check it
            far = np.zeros(len(px), dtype=bool)
            far[np.flatnonzero(~bad)] = np.hypot(*(back - px[~bad]).T) > 1e-6
            out[far] = np.nan
        return out

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

def pose_matrix(rvec: np.ndarray, tvec: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(R, t)`` of a Rodrigues vector and a translation, validated: (3, 3) and (3,)."""
    r = np.asarray(rvec, dtype=np.float64).reshape(-1)
    t = np.asarray(tvec, dtype=np.float64).reshape(-1)
    if r.shape != (3,) or t.shape != (3,) or not (np.all(np.isfinite(r)) and np.all(np.isfinite(t))):
        raise ValueError(f"rvec and tvec must be 3 finite values each, got {r.tolist()} and {t.tolist()}")
    return cv2.Rodrigues(r)[0], t


def in_frame(corners: np.ndarray, size: tuple[int, int], border: float) -> np.ndarray:
    """Whether each point (N, 2) is finite and at least ``border`` px inside a frame of ``size`` (w, h)."""
    w, h = size
    with np.errstate(invalid="ignore"):
        return (np.all(np.isfinite(corners), axis=1) & (corners[:, 0] >= border) & (corners[:, 1] >= border)
                & (corners[:, 0] <= w - 1 - border) & (corners[:, 1] <= h - 1 - border))


def _distort_np(x, y, d):
    k1, k2, p1, p2, k3 = d
    r2 = x * x + y * y
    rad = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    return (x * rad + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
            y * rad + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y)


def _distort_jac_np(x, y, d):
    k1, k2, p1, p2, k3 = d
    r2 = x * x + y * y
    rad = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    drad = k1 + r2 * (2 * k2 + 3 * k3 * r2)  # d rad / d r2
    j00 = rad + 2 * x * x * drad + 2 * p1 * y + 6 * p2 * x
    j01 = 2 * x * y * drad + 2 * p1 * x + 2 * p2 * y
    j10 = 2 * x * y * drad + 2 * p1 * x + 2 * p2 * y
    j11 = rad + 2 * y * y * drad + 6 * p1 * y + 2 * p2 * x
    return j00, j01, j10, j11
