"""A camera as one object: intrinsics, OpenCV's distortion (pinhole ``(k1, k2, p1, p2, k3)`` or fisheye
``(k1, k2, k3, k4)``) and the image size.

What the calibration renderers and evaluations hold as the true camera; its maths
is :mod:`.models`' (one implementation for calibration and evaluation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

from .models import distort, to_pixels, undistort
from .registry import lens

__all__ = ["Camera", "pose_matrix"]


@dataclass(frozen=True)
class Camera:
    """A camera: OpenCV's pinhole model with ``(k1, k2, p1, p2[, k3])``, or its fisheye model.

    Pinhole (``cv2.projectPoints``): a camera-frame point ``(X, Y, Z)``, ``Z > 0``,
    goes to ``(x, y) = (X/Z, Y/Z)``, then :func:`~.models.distort`, then ``K``.
    Fisheye (``cv2.fisheye.projectPoints``, ``dist = (k1, k2, k3, k4)``): the ray's
    angle from the axis :math:`\\theta = \\operatorname{atan2}(\\sqrt{X^2 + Y^2}, Z)`,
    :math:`\\theta_d = \\theta (1 + k_1 \\theta^2 + k_2 \\theta^4 + k_3 \\theta^6 + k_4 \\theta^8)`,
    :math:`(x_d, y_d) = \\theta_d (X, Y) / \\sqrt{X^2 + Y^2}`, then ``K``. With ``k = 0`` it is
    equidistant, pixel radius :math:`f \\theta`: a 200 px focal length puts a ray 80 degrees off
    the axis 279.3 px from the principal point. OpenCV's form (:math:`\\theta = \\arctan r`,
    :math:`r = |(X/Z, Y/Z)|`) is the same for ``Z > 0``; the ``atan2`` form also holds at and
    beyond 90 degrees, so a fisheye projects every point not straight behind it (NaN there).

    Parameters
    ----------
    K : (3, 3) array
        Intrinsic matrix ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]``.
    dist : sequence of floats
        Pinhole: ``(k1, k2, p1, p2[, k3])``, stored as five values. Fisheye: ``(k1, k2, k3, k4)``.
    size : (width, height)
        Image size in pixels.
    model : "pinhole" or "fisheye"

    Examples
    --------
    >>> cam = Camera(np.array([[800.0, 0, 319.5], [0, 800.0, 239.5], [0, 0, 1]]), (0.0, 0, 0, 0), (640, 480))
    >>> cam.project(np.array([[0.0, 0.0, 2.0], [0.1, 0.0, 1.0]])).round(6).tolist()
    [[319.5, 239.5], [399.5, 239.5]]
    >>> cam.fx, cam.width, cam.height
    (800.0, 640, 480)
    >>> fish = Camera(np.array([[200.0, 0, 319.5], [0, 200.0, 239.5], [0, 0, 1]]), (0.0, 0, 0, 0), (640, 480),
    ...               model="fisheye")
    >>> a = np.radians(80)
    >>> fish.project(np.array([[np.sin(a), 0.0, np.cos(a)]])).round(4).tolist()
    [[598.7527, 239.5]]
    """

    K: np.ndarray
    dist: tuple = (0.0, 0.0, 0.0, 0.0, 0.0)
    size: tuple[int, int] = (640, 480)
    model: Literal["pinhole", "fisheye"] = "pinhole"

    def __post_init__(self) -> None:
        K = np.asarray(self.K, dtype=np.float64)
        if K.shape != (3, 3) or not np.all(np.isfinite(K)) or K[0, 0] <= 0 or K[1, 1] <= 0:
            raise ValueError(f"K must be a finite (3, 3) matrix with positive focal lengths, got {K.tolist()}")
        if self.model not in ("pinhole", "fisheye"):
            raise ValueError(f"model must be 'pinhole' or 'fisheye', got {self.model!r}")
        d = tuple(float(v) for v in np.asarray(self.dist, dtype=np.float64).reshape(-1))
        if not all(math.isfinite(v) for v in d):
            raise ValueError(f"dist must be finite, got {d}")
        if self.model == "fisheye":
            if len(d) != 4:
                raise ValueError(f"a fisheye's dist must be 4 values (k1, k2, k3, k4), got {d}")
        elif len(d) not in (4, 5):
            raise ValueError(f"dist must be 4 or 5 finite values (k1, k2, p1, p2[, k3]), got {d}")
        w, h = (int(v) for v in self.size)
        if w < 1 or h < 1:
            raise ValueError(f"size must be (width, height) >= 1, got {self.size}")
        K = K.copy()
        K.setflags(write=False)
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "dist", d if self.model == "fisheye" else d + (0.0,) * (5 - len(d)))
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
        return to_pixels(distort(xy, self.dist, self.model), self.K)

    def project(self, points3d: np.ndarray, rvec: np.ndarray | None = None,
                tvec: np.ndarray | None = None) -> np.ndarray:
        """Project 3-D points (N, 3) to pixels (N, 2), as ``cv2.projectPoints``.

        The points are in the camera frame, or in a frame given by ``rvec``
        (Rodrigues vector) and ``tvec``: ``X_c = R(rvec) X + tvec``. Points at
        or behind the camera's centre plane give NaN (a fisheye: only points straight behind it).
        """
        P = np.asarray(points3d, dtype=np.float64).reshape(-1, 3)
        if rvec is not None or tvec is not None:
            R, t = pose_matrix(np.zeros(3) if rvec is None else rvec, np.zeros(3) if tvec is None else tvec)
            P = P @ R.T + t
        record = lens(self.model)
        if record.fisheye:  # it sees behind its centre plane: only a point straight behind has no direction
            xd = record.project(P, np.asarray(self.dist))
            xd[(P[:, 0] == 0) & (P[:, 1] == 0) & (P[:, 2] <= 0)] = np.nan
            return to_pixels(xd, self.K)
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(P[:, 2] > 0, P[:, 2], np.nan)
            return self.distort(np.stack([P[:, 0] / z, P[:, 1] / z], axis=1))

    def undistort(self, pixels: np.ndarray) -> np.ndarray:
        """Normalised coordinates ``(x', y')`` (N, 2) of pixels (N, 2): :func:`~.models.undistort`, the
        inverse of :meth:`distort` to machine precision; NaN beyond the model's fold (a fisheye: also
        at and beyond 90 degrees, which no point of ``z = 1`` reaches: :meth:`rays` has those)."""
        return undistort(pixels, self.K, self.dist, self.model)[0]

    def rays(self, pixels: np.ndarray) -> np.ndarray:
        """Unit ray directions (N, 3) in the camera frame of pixels (N, 2), the inverse of :meth:`project`.

        The model's record's ``unproject`` (:mod:`.registry`). A fisheye's ray is
        :math:`(\\sin\\theta\\, x_d / \\theta_d, \\sin\\theta\\, y_d / \\theta_d, \\cos\\theta)` with
        :math:`\\theta` from :func:`~.models.fisheye_theta`, exact at any angle; a pinhole's is
        :math:`(x', y', 1)` normalised. NaN where the model cannot be inverted.

        Examples
        --------
        >>> fish = Camera(np.array([[200.0, 0, 319.5], [0, 200.0, 239.5], [0, 0, 1]]), (0.0, 0, 0, 0),
        ...               (640, 480), model="fisheye")
        >>> d = fish.rays(np.array([[319.5 + 200 * np.pi / 2, 239.5]]))[0]
        >>> np.round(d, 12).tolist()  # 90 degrees off the axis: along x
        [1.0, 0.0, -0.0]
        """
        return lens(self.model).unproject(np.asarray(pixels, dtype=np.float64).reshape(-1, 2), self.K,
                                          np.asarray(self.dist))


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
