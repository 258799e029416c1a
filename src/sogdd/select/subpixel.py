"""Sub-pixel positions of selected peaks.

Three refinements, from the cheapest:

* :func:`refine_quadratic`: a 2-D quadratic fit to ``log Upsilon`` on the 3x3
  patch of a peak (the paper's own peak, to a fraction of a pixel);
* :func:`refine_gradient`: the least-squares point ``q`` with
  ``grad I(p) . (p - q) = 0`` over a window (Foerstner 1987,
  ``cv2.cornerSubPix``), which moves the measure's peak, about 1.5 px inside a
  corner, onto its vertex;
* :func:`refine_gradient_adaptive`: the same in a window shrunk to half the
  distance to the nearest other point (``hr``), so that adjacent corners keep
  apart.

:func:`one_per_point` then merges points that the refinement brought together.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import cv2
import numpy as np
from scipy.spatial import cKDTree

from .._jit import thread_count

__all__ = [
    "one_per_point", "quadratic_offsets", "refine_gradient", "refine_gradient_adaptive", "refine_quadratic",
]

#: points per thread below which gradient refinement stays on one thread
_REFINE_CHUNK = 512


def refine_quadratic(
    response: np.ndarray, rows: np.ndarray, cols: np.ndarray, *, log: bool = True
) -> np.ndarray:
    """Sub-pixel offsets ``(dx, dy)`` of peaks from a 2-D quadratic fit on the 3x3 patch.

    With ``log`` the fit is made to ``log(response)``: the measure is a product of
    K eigenvalues, so its peaks are close to Gaussian, whose logarithm is
    exactly quadratic. The offset is the stationary point of the fitted
    quadratic, ``-H^{-1} g``; where the fit is not a maximum or would leave the
    pixel, each axis falls back to its own 1-D parabola, clipped to +-0.5.
    """
    n = len(rows)
    out = np.zeros((n, 2))
    if n == 0:
        return out
    h, w = response.shape
    r = np.clip(rows, 1, h - 2)
    c = np.clip(cols, 1, w - 2)
    dy, dx = np.mgrid[-1:2, -1:2]
    patch = response[r[:, None, None] + dy, c[:, None, None] + dx].astype(np.float64)
    out[:] = quadratic_offsets(patch, log=log)
    # peaks on the outermost pixel row/column keep their integer position
    edge = (rows != r) | (cols != c)
    out[edge] = 0.0
    return out


def quadratic_offsets(patch: np.ndarray, *, log: bool = True) -> np.ndarray:
    """The offsets of :func:`refine_quadratic` from the (n, 3, 3) patches themselves (float64)."""
    out = np.zeros((len(patch), 2))
    if log:
        with np.errstate(divide="ignore", invalid="ignore"):
            lp = np.log(patch)
        ok = np.isfinite(lp).all(axis=(1, 2))
        patch = np.where(ok[:, None, None], lp, patch)
    # a patch holding -inf (a pruned pixel beside a band's provisional candidate in
    # sogdd.select.banded_relative) gives NaN here and the fallback below; no warning for it
    with np.errstate(divide="ignore", invalid="ignore"):
        gx = (patch[:, 1, 2] - patch[:, 1, 0]) / 2
        gy = (patch[:, 2, 1] - patch[:, 0, 1]) / 2
        fxx = patch[:, 1, 2] - 2 * patch[:, 1, 1] + patch[:, 1, 0]
        fyy = patch[:, 2, 1] - 2 * patch[:, 1, 1] + patch[:, 0, 1]
        fxy = (patch[:, 2, 2] - patch[:, 2, 0] - patch[:, 0, 2] + patch[:, 0, 0]) / 4
        det = fxx * fyy - fxy * fxy
        ox = -(fyy * gx - fxy * gy) / det
        oy = -(fxx * gy - fxy * gx) / det
        good = (fxx < 0) & (det > 0) & (np.abs(ox) <= 1) & (np.abs(oy) <= 1)
        ox1 = np.where(fxx < 0, -gx / fxx, 0.0)
        oy1 = np.where(fyy < 0, -gy / fyy, 0.0)
    out[:, 0] = np.where(good, ox, np.clip(np.nan_to_num(ox1), -0.5, 0.5))
    out[:, 1] = np.where(good, oy, np.clip(np.nan_to_num(oy1), -0.5, 0.5))
    return out


def refine_gradient(
    grey: np.ndarray,
    xy: np.ndarray,
    *,
    half_window: int = 3,
    max_shift: float = 3.0,
    iterations: int = 30,
    eps: float = 1e-3,
) -> np.ndarray:
    """Move corners to the point orthogonal to the image gradients around them.

    A second-derivative measure peaks *inside* a corner, not on its vertex (about
    1.5 px on the wedges of ``sogdd.synthetic.pattern_image`` with sigma^2 = 1.2).
    The vertex of an ideal corner is the one point ``q`` with
    ``grad I(p) . (p - q) = 0`` for every ``p`` on its two edges, so the least
    squares solution of that system (Foerstner 1987; ``cv2.cornerSubPix``) removes
    the bias. Points that would move more than ``max_shift`` pixels keep their
    input position, so a refinement that wanders to another structure is refused.
    """
    pts = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if len(pts) == 0:
        return pts.copy()
    h, w = grey.shape
    win = int(half_window)
    if h < 2 * win + 5 or w < 2 * win + 5:  # cv2.cornerSubPix's own minimum
        return pts.copy()
    start = pts.astype(np.float32).reshape(-1, 1, 2).copy()
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, int(iterations), float(eps))
    img = np.ascontiguousarray(grey, dtype=np.float32)
    # each point is refined on its own, and cv2 releases the GIL: chunks in threads, the same result
    n = max(1, min(thread_count(), len(start) // _REFINE_CHUNK))
    if n == 1:  # few points: no thread pool to start
        outs = [cv2.cornerSubPix(img, start, (win, win), (-1, -1), crit)]
    else:
        with ThreadPoolExecutor(n) as pool:
            outs = list(pool.map(lambda s: cv2.cornerSubPix(img, s, (win, win), (-1, -1), crit),
                                 np.array_split(start, n)))
    out = np.concatenate(outs).reshape(-1, 2).astype(np.float64)
    moved = np.linalg.norm(out - pts, axis=1)
    keep = ~np.isfinite(out).all(axis=1) | (moved > max_shift)
    out[keep] = pts[keep]
    return out


def refine_gradient_adaptive(grey: np.ndarray, xy: np.ndarray, neighbours: np.ndarray | None = None, *,
                             max_half: int = 3) -> np.ndarray:
    """:func:`refine_gradient` with a window that shrinks to half the distance to the nearest other point.

    The half-window of each point is ``min(max_half, floor(d / 2))`` (at least 1), with
    ``d`` the distance to the nearest other point of ``xy`` or ``neighbours`` (e.g. the
    X-junctions reported beside the corners), so the gradients of a close neighbour do
    not pull a corner towards it; a move longer than the half-window is refused.
    Points outside the image keep their position.
    """
    pts = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if len(pts) == 0:
        return pts.copy()
    allp = pts if neighbours is None or len(neighbours) == 0 else np.concatenate([pts, neighbours])
    if len(allp) > 1:
        d = cKDTree(allp).query(pts, k=2)[0][:, 1]
    else:
        d = np.full(len(pts), np.inf)
    half = np.clip(np.floor(d / 2), 1, max_half).astype(np.int64)
    h, w = grey.shape
    inside = (pts[:, 0] >= 0) & (pts[:, 0] <= w - 1) & (pts[:, 1] >= 0) & (pts[:, 1] <= h - 1)
    out = pts.copy()
    for hw in np.unique(half):
        sel = np.flatnonzero((half == hw) & inside)
        if len(sel):
            out[sel] = refine_gradient(grey, pts[sel], half_window=int(hw), max_shift=float(hw))
    return out


def one_per_point(xy: np.ndarray, strength: np.ndarray, tol: float) -> np.ndarray:
    """Indices (ascending) of the points to keep when several reached the same point.

    Of points closer than ``tol`` px the strongest is kept (the first among
    equals), greedily from the strongest: a point dropped suppresses nothing.

    Examples
    --------
    >>> xy = np.array([[5.0, 5.0], [5.0001, 5.0], [9.0, 9.0]])
    >>> one_per_point(xy, np.array([1.0, 1.0, 2.0]), 0.1).tolist()
    [0, 2]
    """
    if len(xy) < 2:
        return np.arange(len(xy))
    pairs = cKDTree(xy).query_pairs(float(tol), output_type="ndarray")
    if len(pairs) == 0:
        return np.arange(len(xy))
    rank = np.argsort(np.argsort(-np.asarray(strength), kind="stable"))  # 0 = strongest, then raster
    drop = np.zeros(len(xy), bool)
    for i, j in sorted(map(tuple, pairs), key=lambda ij: min(rank[ij[0]], rank[ij[1]])):
        a, b = (i, j) if rank[i] < rank[j] else (j, i)
        if not drop[a]:
            drop[b] = True
    return np.flatnonzero(~drop)

