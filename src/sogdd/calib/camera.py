"""Camera models (OpenCV's pinhole, rational and fisheye) in numpy, and the projection difference
between two cameras: how far apart they put the same rays, over the image.

The equations are OpenCV's (``cv2.projectPoints``, ``cv2.fisheye.projectPoints``),
so that a camera from ``cv2.calibrateCamera`` is used as it was fitted; the
inverse (:func:`undistort`) iterates to machine precision and says where the
model cannot be inverted.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["MODELS", "ProjectionDifference", "distort", "project", "projection_difference", "undistort"]

#: model name -> names of its distortion coefficients, in OpenCV's order
MODELS: dict[str, tuple[str, ...]] = {
    "pinhole": ("k1", "k2", "p1", "p2", "k3"),
    "rational": ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"),
    "fisheye": ("k1", "k2", "k3", "k4"),
}

# --------------------------------------------------------------------------------------------------
# camera models: distortion, projection, unprojection (numpy, OpenCV's equations)


def distort(xy: np.ndarray, dist: np.ndarray, model: str = "pinhole") -> np.ndarray:
    """Distort normalised image coordinates by OpenCV's model, (N, 2) -> (N, 2).

    Pinhole and rational (``k1, k2, p1, p2, k3[, k4, k5, k6]``), with
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


def project(points3d: np.ndarray, K: np.ndarray, dist: np.ndarray, model: str = "pinhole",
            rvec: np.ndarray | None = None, tvec: np.ndarray | None = None) -> np.ndarray:
    """Project 3-D points to pixels (OpenCV's convention: pixel centres at integers), (N, 3) -> (N, 2).

    :math:`X_c = R(\\mathrm{rvec}) X + \\mathrm{tvec}`, :math:`(x, y) = (X_c/Z_c, Y_c/Z_c)`,
    :math:`(x_d, y_d) =` :func:`distort` :math:`(x, y)`, :math:`u = f_x x_d + s\\,y_d + c_x`,
    :math:`v = f_y y_d + c_y` (``s = K[0, 1]``, the skew). Matches ``cv2.projectPoints``
    and ``cv2.fisheye.projectPoints``.

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
    xy = p[:, :2] / p[:, 2:3]
    return _to_pixels(distort(xy, dist, model), K)


def _to_pixels(xyd: np.ndarray, K: np.ndarray) -> np.ndarray:
    K = np.asarray(K, dtype=np.float64)
    u = K[0, 0] * xyd[:, 0] + K[0, 1] * xyd[:, 1] + K[0, 2]
    v = K[1, 1] * xyd[:, 1] + K[1, 2]
    return np.stack([u, v], axis=1)


def undistort(pixels: np.ndarray, K: np.ndarray, dist: np.ndarray, model: str = "pinhole", *,
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
    back = _to_pixels(distort(x, dist, model), K)
    with np.errstate(invalid="ignore"):
        valid = np.all(np.isfinite(x), axis=1) & (np.hypot(*(back - px).T) <= tol)
    if model == "fisheye":  # the fisheye model is monotone only up to its ray angle of 90 degrees
        valid &= np.isfinite(x[:, 0])
    x[~valid] = np.nan
    return x, valid


# --------------------------------------------------------------------------------------------------
# projection difference between two cameras


@dataclass(frozen=True)
class ProjectionDifference:
    """Where two cameras put the same rays, compared over a grid of pixels.

    Attributes
    ----------
    mean, max : float
        Mean and largest distance in px over the valid grid points.
    xs, ys : 1-D float64
        The grid's columns and rows (pixel coordinates).
    distance : (len(ys), len(xs)) float64
        The distance at each grid point; NaN where camera A's ray is invalid.
    valid_fraction : float
        Share of grid points where both cameras' rays are defined.
    within : (len(ys), len(xs)) bool or None
        Grid points inside the ``within`` polygon (None without one).
    mean_within, max_within : float
        Mean and largest distance inside that polygon (NaN without one).
    """

    mean: float
    max: float
    xs: np.ndarray
    ys: np.ndarray
    distance: np.ndarray
    valid_fraction: float
    within: np.ndarray | None = None
    mean_within: float = float("nan")
    max_within: float = float("nan")


def _camera_parts(cam) -> tuple[np.ndarray, np.ndarray, str]:
    """``(K, dist, model)`` of a :class:`Calibration`, any object with ``K`` and ``dist`` (and
    optionally ``model``), or a tuple ``(K, dist[, model])``."""
    if isinstance(cam, (tuple, list)):
        if len(cam) not in (2, 3):
            raise ValueError(f"a camera as a tuple is (K, dist[, model]); got {len(cam)} items")
        K, dist, model = cam[0], cam[1], cam[2] if len(cam) == 3 else "pinhole"
    elif hasattr(cam, "K") and hasattr(cam, "dist"):
        K, dist, model = cam.K, cam.dist, getattr(cam, "model", "pinhole")
    else:
        raise ValueError(f"not a camera: {type(cam).__name__} (give a Calibration, an object with K and "
                         "dist, or a tuple (K, dist[, model]))")
    K = np.asarray(K, dtype=np.float64)
    if K.shape != (3, 3) or not np.all(np.isfinite(K)) or K[0, 0] <= 0 or K[1, 1] <= 0:
        raise ValueError(f"camera matrix K must be a finite 3x3 matrix with positive focal lengths; got {K!r}")
    _check_model(model)
    dist = np.asarray(dist, dtype=np.float64).ravel()
    if not np.all(np.isfinite(dist)):
        raise ValueError("distortion coefficients must be finite")
    return K, dist, model


def projection_difference(cam_a, cam_b, image_size: tuple[int, int], *, grid: int = 64,
                          margin: float = 0.0, fit_rotation: bool = False,
                          within: np.ndarray | None = None) -> ProjectionDifference:
    """The distance between where two cameras project the same rays, over the image.

    Each point ``p`` of a ``grid`` x ``grid * h / w`` grid of pixels is
    unprojected through camera A to its ray ``(x, y, 1)`` on the unit-depth
    plane (:func:`undistort`) and projected through camera B; the difference is
    :math:`\\lVert \\pi_B(R\\,\\pi_A^{-1}(p)) - p \\rVert` in px. By default
    :math:`R = I`: both cameras are taken in their own frame. With
    ``fit_rotation`` the rotation :math:`R` minimising the sum of squared
    differences is fitted first (as mrcal does): two calibrations whose
    principal points differ, each with its views' poses rotated to match, see
    the same rays, and only what no rotation explains is left. With a
    ``within`` polygon (e.g. the hull of the calibration's corners) the rotation
    is fitted to the grid points inside it, and the mean and max there are
    reported too: outside the data a model extrapolates, often wildly.

    Parameters
    ----------
    cam_a, cam_b : Calibration, object with ``K`` and ``dist`` (and ``model``), or tuple
        ``(K, dist[, model])``; ``model`` is "pinhole" when not given.
    image_size : (width, height)
    grid : int
        Grid points along the width (>= 2).
    margin : float
        Keep the grid this many px inside the image border.
    fit_rotation : bool
        Fit the rotation between the two camera frames (see above).
    within : (M, 2) array, optional
        A polygon in pixel coordinates (x, y).

    Examples
    --------
    >>> K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    >>> K2 = K.copy(); K2[0, 2] += 1.0
    >>> d = projection_difference((K, np.zeros(5)), (K2, np.zeros(5)), (640, 480))
    >>> round(d.mean, 9), round(d.max, 9), d.distance.shape
    (1.0, 1.0, (48, 64))
    """
    Ka, da, ma = _camera_parts(cam_a)
    Kb, db, mb = _camera_parts(cam_b)
    w, h = _check_size(image_size)
    if int(grid) < 2:
        raise ValueError(f"grid must be >= 2, got {grid}")
    xs = np.linspace(margin, w - 1 - margin, int(grid))
    ys = np.linspace(margin, h - 1 - margin, max(2, int(round(grid * h / w))))
    gx, gy = np.meshgrid(xs, ys)
    px = np.stack([gx.ravel(), gy.ravel()], axis=1)
    rays, ok = undistort(px, Ka, da, ma)
    inside = _inside(px, within)
    d = np.full(len(px), np.nan)
    if ok.any():
        pts = np.c_[rays[ok], np.ones(ok.sum())]
        fit = inside[ok] if within is not None and inside[ok].sum() >= 3 else np.ones(ok.sum(), bool)
        rvec = _best_rotation(pts[fit], px[ok][fit], Kb, db, mb) if fit_rotation else None
        pb = project(pts, Kb, db, mb, rvec)
        d[ok] = np.hypot(*(pb - px[ok]).T)
    mean, mx = _stats(d)
    shape = gx.shape
    if within is None:
        return ProjectionDifference(mean, mx, xs, ys, d.reshape(shape), float(np.isfinite(d).mean()))
    mean_in, max_in = _stats(d[inside])
    return ProjectionDifference(mean, mx, xs, ys, d.reshape(shape), float(np.isfinite(d).mean()),
                                inside.reshape(shape), mean_in, max_in)


def _stats(d: np.ndarray) -> tuple[float, float]:
    good = np.isfinite(d)
    return (float(d[good].mean()), float(d[good].max())) if good.any() else (float("nan"), float("nan"))


def _inside(px: np.ndarray, polygon: np.ndarray | None) -> np.ndarray:
    if polygon is None:
        return np.ones(len(px), bool)
    poly = np.asarray(polygon, dtype=np.float32).reshape(-1, 1, 2)
    if len(poly) < 3:
        raise ValueError(f"within must be a polygon of at least 3 points, got {len(poly)}")
    return np.array([cv2.pointPolygonTest(poly, (float(x), float(y)), False) >= 0 for x, y in px])


def _best_rotation(rays: np.ndarray, px: np.ndarray, K, dist, model) -> np.ndarray:
    """The rotation vector minimising the squared distances of ``project(R rays)`` from ``px``."""
    from scipy.optimize import least_squares

    def f(rv):
        return (project(rays, K, dist, model, rv) - px).ravel()

    return least_squares(f, np.zeros(3), x_scale=1e-3, xtol=1e-12, ftol=1e-12).x


def _check_model(model: str) -> None:
    if model not in MODELS:
        raise ValueError(f"unknown camera model {model!r}; choose one of {', '.join(MODELS)}")


def _check_size(image_size) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in image_size)
    except (TypeError, ValueError):
        raise ValueError(f"image_size must be (width, height); got {image_size!r}") from None
    if w < 2 or h < 2:
        raise ValueError(f"image_size must be (width, height) of at least 2 px each; got {image_size!r}")
    return w, h
