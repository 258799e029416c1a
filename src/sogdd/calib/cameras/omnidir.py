"""The unified omnidirectional model (Mei & Rives 2007; OpenCV contrib's ``cv2.omnidir``, Kalibr's
omni-radtan): ``xi, k1, k2, p1, p2``, for lenses at and beyond 180 degrees.

A camera-frame point :math:`X` goes to the unit sphere, :math:`X_s = X / \\lVert X \\rVert`, is
seen from a centre :math:`\\xi` behind the sphere's,
:math:`(x, y) = (X_{s,1}, X_{s,2}) / (X_{s,3} + \\xi)`, then OpenCV's radial-tangential distortion
with ``k1, k2, p1, p2`` (:func:`~.lens.opencv_distort`, ``k3 = 0``), then ``K``. Every ray with
:math:`X_{s,3} > -\\xi` projects: with :math:`\\xi > 1`, all but a cone straight behind.
The fit is OpenCV's (``cv2.omnidir.calibrate``, skew held at 0 as everywhere in this package).
"""

from __future__ import annotations

import cv2
import numpy as np

from .lens import LensModel, newton_undistort, opencv_distort

__all__ = ["LENS", "calibrate", "distort", "project", "unproject"]


def _coefficients(dist: np.ndarray) -> tuple[float, np.ndarray]:
    d = np.zeros(5)
    dist = np.asarray(dist, dtype=np.float64).ravel()
    d[: min(5, len(dist))] = dist[:5]
    return float(d[0]), d[1:]


def project(points: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Distorted normalised coordinates (N, 2) of camera-frame points (N, 3), as ``cv2.omnidir.projectPoints``
    before ``K``; NaN for a point the model cannot see (:math:`X_{s,3} + \\xi \\le 0`).

    Examples
    --------
    >>> project(np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 2.0]]), np.array([1.0, 0, 0, 0, 0])).tolist()
    [[1.0, 0.0], [0.0, 0.0]]
    """
    xi, k = _coefficients(dist)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = p / np.linalg.norm(p, axis=1, keepdims=True)
        z = s[:, 2] + xi
        z = np.where(z > 0, z, np.nan)
        return opencv_distort(s[:, :2] / z[:, None], k)


def distort(xy: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """:func:`project` of the rays ``(x, y, 1)``, (N, 2) -> (N, 2).

    Examples
    --------
    >>> distort(np.array([[0.0, 0.0]]), np.array([1.0, 0.1, 0, 0, 0])).tolist()
    [[0.0, 0.0]]
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    return project(np.c_[xy, np.ones(len(xy))], dist)


def unproject(pixels: np.ndarray, K: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Unit rays (N, 3) of pixels: the distortion inverted by Newton's method
    (:func:`~.lens.newton_undistort`), then lifted to the sphere,
    :math:`X_s = (\\eta x, \\eta y, \\eta - \\xi)` with
    :math:`\\eta = (\\xi + \\sqrt{1 + (1 - \\xi^2) r^2}) / (1 + r^2)`; NaN where there is none.

    Examples
    --------
    >>> K = np.array([[300.0, 0, 400], [0, 300, 400], [0, 0, 1]])
    >>> ray = np.array([[np.sin(2.0), 0.0, np.cos(2.0)]])   # 115 degrees off the axis
    >>> px = project(ray, np.array([1.5, 0.01, 0, 0, 0])) * 300 + 400
    >>> bool(np.allclose(unproject(px, K, np.array([1.5, 0.01, 0, 0, 0])), ray, atol=1e-9))
    True
    """
    xi, k = _coefficients(dist)
    xy, _ = newton_undistort(pixels, K, k, opencv_distort)
    r2 = np.sum(xy * xy, axis=1)
    with np.errstate(invalid="ignore"):
        eta = (xi + np.sqrt(1 + (1 - xi * xi) * r2)) / (1 + r2)
    return np.stack([eta * xy[:, 0], eta * xy[:, 1], eta - xi], axis=1)


def calibrate(obj: list[np.ndarray], img: list[np.ndarray], size: tuple[int, int], flags: int = 0,
              weights: list[np.ndarray] | None = None):
    """``cv2.omnidir.calibrate``: ``(K, (xi, k1, k2, p1, p2), rvecs (V, 3), tvecs (V, 3), None)``.

    ``flags`` are ``cv2.omnidir``'s, with ``CALIB_FIX_SKEW`` added (the package's cameras have
    no skew). OpenCV's fit has no weights: ``weights`` do not enter. A view OpenCV leaves out
    (its initialisation found no pose for it) gets NaN for its pose (the caller fits it).
    Raises ``cv2.error`` when no fit is possible.
    """
    o = [np.asarray(p, np.float64).reshape(-1, 1, 3) for p in obj]
    i = [np.asarray(p, np.float64).reshape(-1, 1, 2) for p in img]
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 300, 1e-12)
    _, K, xi, D, rv, tv, idx = cv2.omnidir.calibrate(o, i, tuple(int(v) for v in size), None, None, None,
                                                     int(flags) | cv2.omnidir.CALIB_FIX_SKEW, crit)
    rvecs, tvecs = np.full((len(obj), 3), np.nan), np.full((len(obj), 3), np.nan)
    used = np.asarray(idx, int).ravel()
    rvecs[used] = np.array([np.asarray(r, np.float64).ravel() for r in rv])
    tvecs[used] = np.array([np.asarray(t, np.float64).ravel() for t in tv])
    dist = np.r_[np.ravel(xi)[:1], np.ravel(D)[:4]].astype(np.float64)
    return np.asarray(K, np.float64), dist, rvecs, tvecs, None


#: the record
LENS = LensModel(name="omnidir", params=("xi", "k1", "k2", "p1", "p2"), fisheye=True, start="omnidir.calibrate",
                 cv_flags=0, distort=distort, project=project, unproject=unproject, auto_fov=150.0,
                 calibrate=calibrate,
                 summary="the unified omnidirectional (Mei) model, cv2.omnidir: xi, then k1, k2, p1, p2")
