"""Camera models in numpy by name: distortion, projection, unprojection, each the registered model's
(:mod:`.registry`: OpenCV's pinhole with 4 or 5 coefficients, rational, fisheye).

The equations are OpenCV's (``cv2.projectPoints``, ``cv2.fisheye.projectPoints``),
so that a camera from ``cv2.calibrateCamera`` is used as it was fitted; the
inverse (:func:`undistort`) iterates to machine precision and says where the
model cannot be inverted.
"""

from __future__ import annotations

from typing import Literal

import cv2
import numpy as np

from .fisheye import fisheye_distorted, fisheye_theta, fisheye_theta_d
from .lens import newton_undistort, to_pixels
from .registry import LENSES, lens

__all__ = ["MODELS", "CameraModel", "check_model", "check_size", "distort", "fisheye_distorted",
           "fisheye_theta", "fisheye_theta_d", "project", "to_pixels", "undistort"]

#: model name -> names of its distortion coefficients, in OpenCV's order: the registry's
#: (:data:`~.registry.LENSES`) view by name. "pinhole4" is OpenCV's four-coefficient vector (k3 = 0;
#: mrcal's LENSMODEL_OPENCV4), valid wherever OpenCV takes one.
MODELS: dict[str, tuple[str, ...]] = {n: m.params for n, m in LENSES.items()}

#: the camera models, by name (the registry's names)
CameraModel = Literal[tuple(LENSES)]  # type: ignore[valid-type]


def distort(xy: np.ndarray, dist: np.ndarray, model: CameraModel = "pinhole") -> np.ndarray:
    """Distort normalised image coordinates by OpenCV's model, (N, 2) -> (N, 2): the model's record's
    ``distort`` (:mod:`.registry`).

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
    return lens(model).distort(np.asarray(xy, dtype=np.float64).reshape(-1, 2), dist)


def project(points3d: np.ndarray, K: np.ndarray, dist: np.ndarray, model: CameraModel = "pinhole",
            rvec: np.ndarray | None = None, tvec: np.ndarray | None = None) -> np.ndarray:
    """Project 3-D points to pixels (OpenCV's convention: pixel centres at integers), (N, 3) -> (N, 2).

    :math:`X_c = R(\\mathrm{rvec}) X + \\mathrm{tvec}`, then the model's record's ``project``
    (:mod:`.registry`), then ``K``. Pinhole family: :math:`(x, y) = (X_c/Z_c, Y_c/Z_c)`,
    :math:`(x_d, y_d) =` :func:`distort` :math:`(x, y)`; then :math:`u = f_x x_d + s\\,y_d + c_x`,
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
    record = lens(model)
    p = np.asarray(points3d, dtype=np.float64).reshape(-1, 3)
    if rvec is not None:
        R, _ = cv2.Rodrigues(np.asarray(rvec, dtype=np.float64).reshape(3, 1))
        p = p @ R.T
    if tvec is not None:
        p = p + np.asarray(tvec, dtype=np.float64).reshape(1, 3)
    return to_pixels(record.project(p, dist), K)


def undistort(pixels: np.ndarray, K: np.ndarray, dist: np.ndarray, model: CameraModel = "pinhole", *,
              iterations: int = 50, tol: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """The rays of pixels: normalised undistorted coordinates on the plane ``z = 1``, and which are valid.

    Inverts :func:`distort` by Newton's method on :math:`d(x) = x_d` (a
    numerical 2x2 Jacobian, ``iterations`` steps from :math:`x = x_d`;
    :func:`~.lens.newton_undistort`). A pixel
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
    return newton_undistort(pixels, K, dist, lens(model).distort, iterations=iterations, tol=tol)


def check_model(model: str) -> None:
    """``ValueError`` naming the choices if ``model`` is not one of :data:`MODELS`."""
    lens(model)


def check_size(image_size: object) -> tuple[int, int]:
    """``(width, height)`` as two ints of at least 2 px each, else a one-line ``ValueError``."""
    try:
        w, h = (int(v) for v in image_size)
    except (TypeError, ValueError):
        raise ValueError(f"image_size must be (width, height); got {image_size!r}") from None
    if w < 2 or h < 2:
        raise ValueError(f"image_size must be (width, height) of at least 2 px each; got {image_size!r}")
    return w, h
