"""The projection difference between two cameras: how far apart they put the same rays, over the image."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .models import check_model, check_size, project, undistort

__all__ = ["ProjectionDifference", "projection_difference"]

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
    check_model(model)
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
    w, h = check_size(image_size)
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
