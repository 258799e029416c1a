"""What a lens model is: :class:`LensModel`, one record per model, and the equations its records share.

Each model lives in a module of its own (:mod:`.pinhole4`, :mod:`.pinhole`,
:mod:`.rational`, :mod:`.fisheye`, :mod:`.omnidir`) holding its record,
``LENS``; :mod:`.registry` lists them. Everything that depends on the model
(projection, unprojection, which OpenCV calibration starts it, whether
``--model auto`` tries it) reads the record, so a new model is one module and
one registry row.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np

__all__ = ["LensModel", "Start", "from_pixels", "newton_undistort", "opencv_distort", "plane_project",
           "to_pixels", "unit_rays"]

#: the OpenCV calibration that starts a model's fit: ``cv2.calibrateCamera`` (with the record's flags),
#: ``cv2.fisheye.calibrate`` or ``cv2.omnidir.calibrate``
Start = Literal["calibrateCamera", "fisheye.calibrate", "omnidir.calibrate"]


@dataclass(frozen=True)
class LensModel:
    """One lens model: its name, its coefficients, its equations and how it is calibrated.

    Attributes
    ----------
    name : str
        What ``--model`` and the files call it.
    params : tuple of str
        The names of its distortion coefficients, in OpenCV's order (the ``dist`` vector's).
    fisheye : bool
        Whether it sees rays at and beyond 90 degrees (its projection takes the ray's angle, not
        ``X/Z, Y/Z``).
    start : {"calibrateCamera", "fisheye.calibrate", "omnidir.calibrate"}
        The OpenCV calibration that starts its fit.
    cv_flags : int
        Flags added to the caller's for ``cv2.calibrateCamera`` (0 for the others).
    distort : callable
        ``distort(xy (N, 2), dist) -> (N, 2)``: the distorted normalised coordinates of the ray
        ``(x, y, 1)``; :func:`~.models.undistort` inverts it.
    project : callable
        ``project(points (N, 3) in the camera frame, dist) -> (N, 2)``: distorted normalised
        coordinates, before ``K`` (:func:`to_pixels`).
    unproject : callable
        ``unproject(pixels (N, 2), K, dist) -> (N, 3)``: unit rays, NaN where the model has none.
    auto_fov : float or None
        Its rule as a candidate of ``--model auto``: tried when the lens is judged to see more than
        this many degrees (0: always; None: never).
    calibrate : callable or None
        ``calibrate(obj, img, size, flags, weights) -> (K, dist, rvecs, tvecs, std or None)`` for a
        model that brings its own fit; None where :func:`~sogdd.calib.solvers.fit_camera` knows its
        ``start``.
    summary : str
        One line for the documentation and ``--help``.
    radial_terms : tuple of (int, int)
        Its radial terms as ``(index in dist, power of the radius)`` (the radius :math:`\\tan\\theta`, or
        :math:`\\theta` for a fisheye), for the verdict's check of terms that cancel; () to skip it.

    Examples
    --------
    >>> import cv2
    >>> from sogdd.calib.cameras.registry import lens
    >>> rec = lens("pinhole4")
    >>> rec.params, rec.start, rec.cv_flags == cv2.CALIB_FIX_K3
    (('k1', 'k2', 'p1', 'p2'), 'calibrateCamera', True)
    >>> rec.project(np.array([[0.5, 0.0, 1.0]]), np.array([-0.2, 0, 0, 0])).round(6).tolist()
    [[0.475, 0.0]]
    """

    name: str
    params: tuple[str, ...]
    fisheye: bool
    start: Start
    cv_flags: int
    distort: Callable[[np.ndarray, np.ndarray], np.ndarray]
    project: Callable[[np.ndarray, np.ndarray], np.ndarray]
    unproject: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
    auto_fov: float | None
    calibrate: Callable | None = None
    summary: str = ""
    radial_terms: tuple[tuple[int, int], ...] = ()


def to_pixels(xyd: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Pixels of distorted normalised coordinates: ``u = fx x_d + s y_d + cx``, ``v = fy y_d + cy``."""
    K = np.asarray(K, dtype=np.float64)
    u = K[0, 0] * xyd[:, 0] + K[0, 1] * xyd[:, 1] + K[0, 2]
    v = K[1, 1] * xyd[:, 1] + K[1, 2]
    return np.stack([u, v], axis=1)


def from_pixels(pixels: np.ndarray, K: np.ndarray) -> np.ndarray:
    """The inverse of :func:`to_pixels`: :math:`y_d = (v - c_y) / f_y`, :math:`x_d = (u - c_x - s y_d) / f_x`.

    Examples
    --------
    >>> K = np.array([[500.0, 2, 320], [0, 400, 240], [0, 0, 1]])
    >>> from_pixels(to_pixels(np.array([[0.1, -0.2]]), K), K).round(12).tolist()
    [[0.1, -0.2]]
    """
    px = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
    K = np.asarray(K, dtype=np.float64)
    yd = (px[:, 1] - K[1, 2]) / K[1, 1]
    xd = (px[:, 0] - K[0, 2] - K[0, 1] * yd) / K[0, 0]
    return np.stack([xd, yd], axis=1)


def opencv_distort(xy: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """OpenCV's pinhole distortion (``k1, k2, p1, p2[, k3[, k4, k5, k6]]``, missing ones 0), (N, 2) -> (N, 2).

    With :math:`r^2 = x^2 + y^2`:

    .. math::
        x_d = x\\,\\frac{1 + k_1 r^2 + k_2 r^4 + k_3 r^6}{1 + k_4 r^2 + k_5 r^4 + k_6 r^6}
              + 2 p_1 x y + p_2 (r^2 + 2 x^2)

    and :math:`y_d` alike (:math:`p_1 (r^2 + 2 y^2) + 2 p_2 x y`).

    Examples
    --------
    >>> opencv_distort(np.array([[0.5, 0.0]]), np.array([-0.2, 0, 0, 0])).round(6).tolist()
    [[0.475, 0.0]]
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    d = np.zeros(8)
    dist = np.asarray(dist, dtype=np.float64).ravel()
    d[: min(8, len(dist))] = dist[:8]
    x, y = xy[:, 0], xy[:, 1]
    r2 = x * x + y * y
    k1, k2, p1, p2, k3, k4, k5, k6 = d
    radial = (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.stack([xd, yd], axis=1)


def plane_project(points: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """OpenCV's pinhole projection before ``K``: :math:`(x, y) = (X/Z, Y/Z)`, then :func:`opencv_distort`."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return opencv_distort(p[:, :2] / p[:, 2:3], dist)


def newton_undistort(pixels: np.ndarray, K: np.ndarray, dist: np.ndarray,
                     distort: Callable[[np.ndarray, np.ndarray], np.ndarray], *, iterations: int = 50,
                     tol: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Invert ``distort`` at pixels: ``(xy (N, 2), valid (N,))``, NaN where invalid.

    Newton's method on :math:`d(x) = x_d` (a numerical 2x2 Jacobian, ``iterations`` steps from
    :math:`x = x_d`); a pixel whose solution, distorted back, lands more than ``tol`` px from it
    is invalid (a model that folds over, or no solution).

    Examples
    --------
    >>> K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    >>> xy, ok = newton_undistort(np.array([[557.5, 240.0]]), K, np.array([-0.2, 0, 0, 0]), opencv_distort)
    >>> xy.round(9).tolist(), ok.tolist()
    ([[0.5, 0.0]], [True])
    """
    px = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
    target = from_pixels(px, K)
    x = target.copy()
    h = 1e-7
    for _ in range(iterations):
        f = distort(x, dist) - target
        jx = (distort(x + [h, 0], dist) - distort(x - [h, 0], dist)) / (2 * h)
        jy = (distort(x + [0, h], dist) - distort(x - [0, h], dist)) / (2 * h)
        det = jx[:, 0] * jy[:, 1] - jy[:, 0] * jx[:, 1]
        det = np.where(np.abs(det) > 1e-12, det, np.nan)
        dx = (jy[:, 1] * f[:, 0] - jy[:, 0] * f[:, 1]) / det
        dy = (-jx[:, 1] * f[:, 0] + jx[:, 0] * f[:, 1]) / det
        x = x - np.stack([dx, dy], axis=1)
        if np.all(~np.isfinite(dx) | (np.abs(dx) + np.abs(dy) < 1e-15)):
            break
    back = to_pixels(distort(x, dist), K)
    with np.errstate(invalid="ignore"):
        valid = np.all(np.isfinite(x), axis=1) & (np.hypot(*(back - px).T) <= tol)
    x[~valid] = np.nan
    return x, valid


def unit_rays(xy: np.ndarray) -> np.ndarray:
    """Unit rays (N, 3) of points ``(x, y)`` on the plane ``z = 1``: ``(x, y, 1)`` normalised."""
    d = np.concatenate([xy, np.ones((len(xy), 1))], axis=1)
    return d / np.linalg.norm(d, axis=1, keepdims=True)
