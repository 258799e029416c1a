"""OpenCV's fisheye model ``k1, k2, k3, k4`` (``cv2.fisheye``), valid at and beyond 90 degrees.

:math:`\\theta = \\operatorname{atan2}(\\sqrt{X^2 + Y^2}, Z)`,
:math:`\\theta_d = \\theta (1 + k_1 \\theta^2 + k_2 \\theta^4 + k_3 \\theta^6 + k_4 \\theta^8)`,
:math:`(x_d, y_d) = (\\theta_d / r)(X, Y)`, then ``K``. On the plane ``z = 1`` (:func:`distort`)
:math:`\\theta = \\arctan r`, OpenCV's form.
"""

from __future__ import annotations

import numpy as np

from .lens import LensModel, from_pixels

__all__ = ["LENS", "distort", "fisheye_distorted", "fisheye_theta", "fisheye_theta_d", "unproject"]


def distort(xy: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """The fisheye distortion of normalised coordinates, (N, 2) -> (N, 2): :math:`\\theta = \\arctan r`,
    :math:`(x_d, y_d) = (\\theta_d / r)(x, y)` (``cv2.fisheye.distortPoints``).

    Examples
    --------
    >>> distort(np.array([[1.0, 0.0]]), np.zeros(4)).round(6).tolist()
    [[0.785398, 0.0]]
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    d = np.zeros(8)
    dist = np.asarray(dist, dtype=np.float64).ravel()
    d[: min(8, len(dist))] = dist[:8]
    r = np.sqrt(xy[:, 0] * xy[:, 0] + xy[:, 1] * xy[:, 1])
    th = np.arctan(r)
    t2 = th * th
    thd = th * (1 + t2 * (d[0] + t2 * (d[1] + t2 * (d[2] + t2 * d[3]))))
    scale = np.where(r > 1e-12, thd / np.where(r > 1e-12, r, 1.0), 1.0)
    return xy * scale[:, None]


def unproject(pixels: np.ndarray, K: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Unit rays (N, 3) of pixels: :math:`(\\sin\\theta\\, x_d / \\theta_d, \\sin\\theta\\, y_d / \\theta_d,
    \\cos\\theta)` with :math:`\\theta` from :func:`fisheye_theta`, exact at any angle; NaN where it folds.

    Examples
    --------
    >>> K = np.array([[200.0, 0, 319.5], [0, 200.0, 239.5], [0, 0, 1]])
    >>> np.round(unproject(np.array([[319.5 + 200 * np.pi / 2, 239.5]]), K, np.zeros(4))[0], 12).tolist()
    [1.0, 0.0, -0.0]
    """
    xd = from_pixels(pixels, K)
    td = np.hypot(xd[:, 0], xd[:, 1])
    th = fisheye_theta(td, dist)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(td > 0, np.sin(th) / td, 1.0)
    return np.stack([xd[:, 0] * s, xd[:, 1] * s, np.cos(th)], axis=1)


def fisheye_distorted(points: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Distorted normalised coordinates (N, 2) of points (N, 3) in the camera frame, by the fisheye model:
    :math:`(x_d, y_d) = (\\theta_d / r)(X, Y)` with :math:`r = \\sqrt{X^2 + Y^2}` and
    :math:`\\theta = \\operatorname{atan2}(r, Z)` (:func:`fisheye_theta_d`).

    ``atan2``, not ``atan(r / Z)``: a fisheye sees rays at and beyond 90 degrees, where ``X/Z, Y/Z`` are
    infinite or point the wrong way; for ``Z > 0`` both agree. On the axis ``theta_d / r -> 1 / Z``.

    Examples
    --------
    >>> fisheye_distorted(np.array([[1.0, 0.0, 0.0]]), np.zeros(4)).round(6).tolist()  # 90 degrees off axis
    [[1.570796, 0.0]]
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    d = np.zeros(4)
    d[: min(4, np.size(dist))] = np.asarray(dist, dtype=np.float64).ravel()[:4]
    r = np.hypot(p[:, 0], p[:, 1])
    thd = fisheye_theta_d(np.arctan2(r, p[:, 2]), d)
    on_axis = 1.0 / np.where(p[:, 2] != 0, p[:, 2], 1.0)
    scale = np.where(r > 1e-12, thd / np.where(r > 1e-12, r, 1.0), on_axis)
    return p[:, :2] * scale[:, None]


def fisheye_theta_d(theta: np.ndarray, k: np.ndarray) -> np.ndarray:
    """The fisheye model's distorted angle :math:`\\theta_d = \\theta (1 + k_1 \\theta^2 + k_2 \\theta^4
    + k_3 \\theta^6 + k_4 \\theta^8)` of ray angles ``theta`` (radians from the optical axis).

    With ``k = 0`` the model is equidistant: :math:`\\theta_d = \\theta`, the pixel radius is
    :math:`f \\theta`.

    Examples
    --------
    >>> fisheye_theta_d(np.array([0.5, 1.5]), np.zeros(4)).tolist()
    [0.5, 1.5]
    >>> round(float(fisheye_theta_d(np.array([1.0]), np.array([0.1, 0, 0, 0]))[0]), 12)
    1.1
    """
    th = np.asarray(theta, dtype=np.float64)
    k1, k2, k3, k4 = (float(v) for v in np.asarray(k, dtype=np.float64).ravel()[:4])
    t2 = th * th
    return th * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))


def fisheye_theta(theta_d: np.ndarray, k: np.ndarray, *, iterations: int = 50) -> np.ndarray:
    """The ray angle :math:`\\theta` of distorted angles :math:`\\theta_d`: the inverse of
    :func:`fisheye_theta_d` by Newton's method from :math:`\\theta = \\theta_d`; NaN where it does not
    converge or the model folds (:math:`d\\theta_d / d\\theta \\le 0`).

    Works for any angle, 90 degrees and beyond (a ray's direction is
    :math:`(\\sin\\theta \\cos\\phi, \\sin\\theta \\sin\\phi, \\cos\\theta)`), unlike
    :func:`undistort`, whose rays live on the plane ``z = 1``.

    Examples
    --------
    >>> fisheye_theta(np.array([0.3, 1.55]), np.zeros(4)).tolist()
    [0.3, 1.55]
    >>> k = np.array([0.05, -0.01, 0.0, 0.0])
    >>> bool(abs(fisheye_theta(fisheye_theta_d(np.array([1.4]), k), k)[0] - 1.4) < 1e-13)
    True
    """
    td = np.asarray(theta_d, dtype=np.float64)
    k1, k2, k3, k4 = (float(v) for v in np.asarray(k, dtype=np.float64).ravel()[:4])
    th = td.copy()
    for _ in range(iterations):
        t2 = th * th
        f = th * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)))) - td
        df = 1 + t2 * (3 * k1 + t2 * (5 * k2 + t2 * (7 * k3 + t2 * 9 * k4)))
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(df > 0, f / df, np.nan)
        th = th - step
        if np.all(~np.isfinite(step) | (np.abs(step) < 1e-15)):
            break
    t2 = th * th
    df = 1 + t2 * (3 * k1 + t2 * (5 * k2 + t2 * (7 * k3 + t2 * 9 * k4)))
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(th) & (df > 0) & (np.abs(fisheye_theta_d(th, [k1, k2, k3, k4]) - td) < 1e-12)
    return np.where(ok, th, np.nan)


#: the record
LENS = LensModel(name="fisheye", params=("k1", "k2", "k3", "k4"), fisheye=True, start="fisheye.calibrate",
                 cv_flags=0, distort=distort, project=fisheye_distorted, unproject=unproject, auto_fov=120.0,
                 summary="OpenCV's fisheye model: theta_d = theta (1 + k1 theta^2 + ... + k4 theta^8)",
                 radial_terms=((0, 3), (1, 5), (2, 7), (3, 9)))
