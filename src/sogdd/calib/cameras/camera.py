"""A camera as one object: intrinsics, OpenCV's distortion ``(k1, k2, p1, p2, k3)`` and the image size.

What the calibration renderers and evaluations hold as the true camera; its maths
is :mod:`.models`' (one implementation for calibration and evaluation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from .models import distort, to_pixels, undistort

__all__ = ["Camera", "pose_matrix"]


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
        """Pixels of normalised coordinates ``(x', y')`` (N, 2): :func:`~.models.distort`, then ``K``."""
        return to_pixels(distort(xy, self.dist, "pinhole"), self.K)

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

    def undistort(self, pixels: np.ndarray) -> np.ndarray:
        """Normalised coordinates ``(x', y')`` (N, 2) of pixels (N, 2): :func:`~.models.undistort`, the
        inverse of :meth:`distort` to machine precision; NaN beyond the model's fold."""
        return undistort(pixels, self.K, self.dist, "pinhole")[0]


def pose_matrix(rvec: np.ndarray, tvec: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(R, t)`` of a Rodrigues vector and a translation, validated: (3, 3) and (3,).

    Examples
    --------
    >>> R, t = pose_matrix([0.0, 0.0, np.pi / 2], [1, 2, 3])
    >>> np.round(R @ [1.0, 0, 0], 12).tolist(), t.tolist()
    ([0.0, 1.0, 0.0], [1.0, 2.0, 3.0])
    """
    r = np.asarray(rvec, dtype=np.float64).reshape(-1)
    t = np.asarray(tvec, dtype=np.float64).reshape(-1)
    if r.shape != (3,) or t.shape != (3,) or not (np.all(np.isfinite(r)) and np.all(np.isfinite(t))):
        raise ValueError(f"rvec and tvec must be 3 finite values each, got {r.tolist()} and {t.tolist()}")
    return cv2.Rodrigues(r)[0], t
