"""Camera models (OpenCV's pinhole with 4 or 5 coefficients, rational, fisheye) in numpy: distortion,
projection, unprojection.

The equations are OpenCV's (``cv2.projectPoints``, ``cv2.fisheye.projectPoints``),
so that a camera from ``cv2.calibrateCamera`` is used as it was fitted; the
inverse (:func:`undistort`) iterates to machine precision and says where the
model cannot be inverted.
"""

from __future__ import annotations

from typing import Literal

import cv2
import numpy as np

__all__ = ["MODELS", "CameraModel", "check_model", "check_size", "distort", "fisheye_distorted",
           "fisheye_theta", "fisheye_theta_d", "project", "to_pixels", "undistort"]

#: the camera models, by name
CameraModel = Literal["pinhole4", "pinhole", "rational", "fisheye"]

#: model name -> names of its distortion coefficients, in OpenCV's order. "pinhole4" is OpenCV's
#: four-coefficient vector (k3 = 0; mrcal's LENSMODEL_OPENCV4), valid wherever OpenCV takes one.
MODELS: dict[str, tuple[str, ...]] = {
    "pinhole4": ("k1", "k2", "p1", "p2"),
    "pinhole": ("k1", "k2", "p1", "p2", "k3"),
    "rational": ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"),
    "fisheye": ("k1", "k2", "k3", "k4"),
}

def distort(xy: np.ndarray, dist: np.ndarray, model: CameraModel = "pinhole") -> np.ndarray:
    """Distort normalised image coordinates by OpenCV's model, (N, 2) -> (N, 2).

    Pinhole and rational (``k1, k2, p1, p2[, k3[, k4, k5, k6]]``, missing ones 0), with
    :math:`r^2 = x^2 + y^2`:

    .. math::
        x_d = x\\,\\frac{1 + k_1 r^2 + k_2 r^4 + k_3 r^6}{1 + k_4 r^2 + k_5 r^4 + k_6 r^6}
              + 2 p_1 x y + p_2 (r^2 + 2 x^2)

    and :math:`y_d` alike (:math:`p_1 (r^2 + 2 y^2) + 2 p_2 x y`). Fisheye
    (``k1..k4``): :math:`\\theta = \\arctan r`,
    :math:`\\theta_d = \\theta (1 + k_1 \\theta^2 + k_2 \\theta^4 + k_3 \\theta^6 + k_4 \\theta^8)`,
    :math:`(x_d, y_d) = (\\theta_d / r) (x, y)`.

    Examples
    --------
    >>> distort(np.array([[0.5, 0.0]]), np.array([-0.2, 0, 0, 0, 0])).round(6).tolist()
    [[0.475, 0.0]]
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    d = np.zeros(8)
    dist = np.asarray(dist, dtype=np.float64).ravel()
    d[: min(8, len(dist))] = dist[:8]
    x, y = xy[:, 0], xy[:, 1]
    r2 = x * x + y * y
    if model == "fisheye":
        r = np.sqrt(r2)
        th = np.arctan(r)
        t2 = th * th
        thd = th * (1 + t2 * (d[0] + t2 * (d[1] + t2 * (d[2] + t2 * d[3]))))
        scale = np.where(r > 1e-12, thd / np.where(r > 1e-12, r, 1.0), 1.0)
        return xy * scale[:, None]
    k1, k2, p1, p2, k3, k4, k5, k6 = d
    radial = (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.stack([xd, yd], axis=1)


def project(points3d: np.ndarray, K: np.ndarray, dist: np.ndarray, model: CameraModel = "pinhole",
            rvec: np.ndarray | None = None, tvec: np.ndarray | None = None) -> np.ndarray:
    """Project 3-D points to pixels (OpenCV's convention: pixel centres at integers), (N, 3) -> (N, 2).

    :math:`X_c = R(\\mathrm{rvec}) X + \\mathrm{tvec}`, :math:`(x, y) = (X_c/Z_c, Y_c/Z_c)`,
    :math:`(x_d, y_d) =` :func:`distort` :math:`(x, y)`, :math:`u = f_x x_d + s\\,y_d + c_x`,
    :math:`v = f_y y_d + c_y` (``s = K[0, 1]``, the skew). Matches ``cv2.projectPoints``
    and ``cv2.fisheye.projectPoints``. The fisheye takes the ray angle from the 3-D point,
    :math:`\\theta = \\operatorname{atan2}(\\sqrt{X_c^2 + Y_c^2}, Z_c)`, so that rays at and beyond
    90 degrees (``Z_c <= 0``) project too: :math:`(x_d, y_d) = (\\theta_d / r)(X_c, Y_c)`.

    Examples
    --------
    >>> K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    >>> project(np.array([[0.1, -0.2, 1.0]]), K, np.zeros(5)).tolist()
    [[370.0, 140.0]]
    """
    p = np.asarray(points3d, dtype=np.float64).reshape(-1, 3)
    if rvec is not None:
        R, _ = cv2.Rodrigues(np.asarray(rvec, dtype=np.float64).reshape(3, 1))
        p = p @ R.T
    if tvec is not None:
        p = p + np.asarray(tvec, dtype=np.float64).reshape(1, 3)
    if model == "fisheye":
        return to_pixels(fisheye_distorted(p, dist), K)
    xy = p[:, :2] / p[:, 2:3]
    return to_pixels(distort(xy, dist, model), K)


def to_pixels(xyd: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Pixels of distorted normalised coordinates: ``u = fx x_d + s y_d + cx``, ``v = fy y_d + cy``."""
    K = np.asarray(K, dtype=np.float64)
    u = K[0, 0] * xyd[:, 0] + K[0, 1] * xyd[:, 1] + K[0, 2]
    v = K[1, 1] * xyd[:, 1] + K[1, 2]
    return np.stack([u, v], axis=1)


def undistort(pixels: np.ndarray, K: np.ndarray, dist: np.ndarray, model: CameraModel = "pinhole", *,
              iterations: int = 50, tol: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """The rays of pixels: normalised undistorted coordinates on the plane ``z = 1``, and which are valid.

    Inverts :func:`distort` by Newton's method on :math:`d(x) = x_d` (a
    numerical 2x2 Jacobian, ``iterations`` steps from :math:`x = x_d`). A pixel
    whose ray, projected back, lands more than ``tol`` px from it (a model that
    folds over near the image corners, or rays behind the camera) is invalid.

    Returns
    -------
    xy : (N, 2) float64
        ``(X/Z, Y/Z)`` of each pixel's ray (NaN where invalid).
    valid : (N,) bool

    Examples
    --------
    >>> K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    >>> xy, ok = undistort(np.array([[570.0, 240.0]]), K, np.array([-0.2, 0.05, 0, 0, 0]))
    >>> bool(ok[0]), project(np.c_[xy, 1.0], K, np.array([-0.2, 0.05, 0, 0, 0])).round(6).tolist()
    (True, [[570.0, 240.0]])
    """
    px = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
    K = np.asarray(K, dtype=np.float64)
    yd = (px[:, 1] - K[1, 2]) / K[1, 1]
    xd = (px[:, 0] - K[0, 2] - K[0, 1] * yd) / K[0, 0]
    target = np.stack([xd, yd], axis=1)
    x = target.copy()
    h = 1e-7
    for _ in range(iterations):
        f = distort(x, dist, model) - target
        jx = (distort(x + [h, 0], dist, model) - distort(x - [h, 0], dist, model)) / (2 * h)
        jy = (distort(x + [0, h], dist, model) - distort(x - [0, h], dist, model)) / (2 * h)
        det = jx[:, 0] * jy[:, 1] - jy[:, 0] * jx[:, 1]
        det = np.where(np.abs(det) > 1e-12, det, np.nan)
        dx = (jy[:, 1] * f[:, 0] - jy[:, 0] * f[:, 1]) / det
        dy = (-jx[:, 1] * f[:, 0] + jx[:, 0] * f[:, 1]) / det
        x = x - np.stack([dx, dy], axis=1)
        if np.all(~np.isfinite(dx) | (np.abs(dx) + np.abs(dy) < 1e-15)):
            break
    back = to_pixels(distort(x, dist, model), K)
    with np.errstate(invalid="ignore"):
        valid = np.all(np.isfinite(x), axis=1) & (np.hypot(*(back - px).T) <= tol)
    if model == "fisheye":  # the fisheye model is monotone only up to its ray angle of 90 degrees
        valid &= np.isfinite(x[:, 0])
    x[~valid] = np.nan
    return x, valid


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


def check_model(model: str) -> None:
    """``ValueError`` naming the choices if ``model`` is not one of :data:`MODELS`."""
    if model not in MODELS:
        raise ValueError(f"unknown camera model {model!r}; choose one of {', '.join(MODELS)}")


def check_size(image_size: object) -> tuple[int, int]:
    """``(width, height)`` as two ints of at least 2 px each, else a one-line ``ValueError``."""
    try:
        w, h = (int(v) for v in image_size)
    except (TypeError, ValueError):
        raise ValueError(f"image_size must be (width, height); got {image_size!r}") from None
    if w < 2 or h < 2:
        raise ValueError(f"image_size must be (width, height) of at least 2 px each; got {image_size!r}")
    return w, h
