"""Sub-pixel positions of selected peaks.

Three refinements, from the cheapest:

* :func:`refine_quadratic`: a 2-D quadratic fit to ``log Upsilon`` on the 3x3
  patch of a peak (the paper's own peak, to a fraction of a pixel);
* :func:`refine_gradient`: the least-squares point ``q`` with
  ``grad I(p) . (p - q) = 0`` over a window centred on it (Foerstner 1987, the
  step of ``cv2.cornerSubPix``, iterated to its fixed point in
  :mod:`sogdd.select.refine`), which moves the measure's peak, about 1.5 px
  inside a corner, onto its vertex;
* :func:`refine_gradient_adaptive`: the same in a window shrunk to half the
  distance to the nearest other point (``hr``), so that adjacent corners keep
  apart.

:func:`one_per_point` then merges points that the refinement brought together
(within :data:`COINCIDENT` px of a stronger one), and :func:`first_distinct`
refills a ``max_corners`` cut that the merge shortened; both detection paths
(the CPU one and the GPU one, :mod:`sogdd.gpu`) merge through them, in
:func:`sogdd.select.assemble.assemble`.

Foerstner's corner point, iterated until it no longer moves (compiled)
----------------------------------------------------------------------

The corner point ``q`` of a window is the least-squares solution of
``grad I(p) . (p - q) = 0`` over the window's pixels ``p`` (Foerstner and Guelch
1987), with the window centred on ``q`` itself, so ``q`` is a fixed point of
``q -> F(q)``:

    F(q) = q + A^{-1} b,   A = sum_p w_p g_p g_p^T,   b = sum_p w_p g_p g_p^T (p - q),

``g_p`` the central-difference gradient of the image bilinearly resampled on the
window's grid around ``q`` (edge pixels replicated) and
``w_p = exp(-(dx / h)^2 - (dy / h)^2)`` for offsets ``|dx|, |dy| <= h`` (the
half-window): the step of ``cv2.cornerSubPix``. OpenCV iterates ``F`` a fixed
number of times or until a step is below a tolerance (1e-3 *squared*, i.e.
0.03 px, in sogdd before 0.3): in a 3 x 3 window ``F`` often overshoots, the
iterates oscillate or wander, and where they stop depends on the input's last
bits (a photo and its float32 copy gave corners 1 px apart). Here the iteration
is damped: the step is halved
whenever it turns back against the previous one (an overshoot), which turns an
oscillation into convergence while a point on its way to a corner keeps full
steps, and it stops only when ``|F(q) - q|`` is below ``tol`` (1e-5 px), in float64. A point
that does not converge in ``max_iter`` steps, or whose window matrix is singular,
keeps its start.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np
from scipy.spatial import cKDTree

from .._jit import JIT, thread_count

__all__ = [
    "COINCIDENT", "first_distinct", "forstner_points", "one_per_point", "patch_offsets", "quadratic_offsets",
    "refine_gradient", "refine_gradient_adaptive", "refine_quadratic",
]


#: points per thread below which gradient refinement stays on one thread
_REFINE_CHUNK = 512

#: points that sub-pixel refinement leaves within this many px of a stronger one are that point.
#: Two local maxima of Upsilon around one vertex (``nms_radius=1`` keeps maxima >= 2 px apart, and
#: a plateau once) mostly converge to one fixed point of the gradient refinement, to its tolerance
#: (within 1e-3 px). But a point that the refinement refuses (no convergence in ``max_iter`` steps,
#: a singular window, a move beyond the half-window) keeps its quadratic peak, and a flat window can
#: hold two fixed points: on the 12 shared repeatability photos, with a radius of 0.1 px, ``paper``
#: kept 4 pairs 0.29-0.48 px apart (both points unrefined, one of each, or two fixed points), ``hr``
#: 2 (0.21 and 0.49 px). Half a pixel, the radius, is the finest separation at which two points can be
#: two corners of the sampled image: the image has one sample per pixel, the measure smooths at sigma
#: ~ 1.1 px, and two refinement windows (7 x 7 in ``paper``) centred 0.5 px apart share 86 % of their
#: pixels, so both positions are estimates of one corner from the same data. The closest distinct
#: corners a pixel grid resolves, the two corners at the end of a 1-px line, are twice as far apart.
#: The merge keeps the stronger point as it is: no position moves, the local maxima are the paper's.
COINCIDENT = 0.5


def refine_quadratic(
    response: np.ndarray, rows: np.ndarray, cols: np.ndarray, *, log: bool = True
) -> np.ndarray:
    """Sub-pixel offsets ``(dx, dy)`` of peaks from a 2-D quadratic fit on the 3x3 patch.

    With ``log`` the fit is made to ``log(response)``: the measure is a product of
    K eigenvalues, so its peaks are close to Gaussian, whose logarithm is
    exactly quadratic. The offset is the stationary point of the fitted
    quadratic, ``-H^{-1} g``, where it is a maximum within +-1 px; where the fit is
    not a maximum, each axis falls back to its own 1-D parabola (clipped to +-0.5),
    and between +-1 and +-2 px the two are blended linearly, so that the offset is
    a continuous function of the patch (a switch moved a corner
    by 0.47 px between a photo and its float32 copy).
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


def patch_offsets(patches: np.ndarray, rows: np.ndarray, cols: np.ndarray,
                  shape: tuple[int, int]) -> np.ndarray:
    """:func:`refine_quadratic`'s offsets from the gathered (n, 3, 3) patches of peaks of an image of ``shape``.

    The patches are those :func:`refine_quadratic` reads (centred on the peak,
    moved inside at the image's edge); peaks on the outermost row or column keep
    their integer position, as there.

    Examples
    --------
    >>> r = np.exp(-((np.arange(7)[:, None] - 3.2) ** 2 + (np.arange(9)[None, :] - 4.4) ** 2))
    >>> rows, cols = np.array([3]), np.array([4])
    >>> bool(np.array_equal(patch_offsets(r[None, 2:5, 3:6], rows, cols, r.shape),
    ...                     refine_quadratic(r, rows, cols)))
    True
    """
    out = quadratic_offsets(np.asarray(patches, dtype=np.float64))
    h, w = shape
    out[(rows != np.clip(rows, 1, h - 2)) | (cols != np.clip(cols, 1, w - 2))] = 0.0
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
    # sogdd.select.bands) gives NaN here and the fallback below; no warning for it
    with np.errstate(divide="ignore", invalid="ignore"):
        gx = (patch[:, 1, 2] - patch[:, 1, 0]) / 2
        gy = (patch[:, 2, 1] - patch[:, 0, 1]) / 2
        fxx = patch[:, 1, 2] - 2 * patch[:, 1, 1] + patch[:, 1, 0]
        fyy = patch[:, 2, 1] - 2 * patch[:, 1, 1] + patch[:, 0, 1]
        fxy = (patch[:, 2, 2] - patch[:, 2, 0] - patch[:, 0, 2] + patch[:, 0, 0]) / 4
        det = fxx * fyy - fxy * fxy
        ox = -(fyy * gx - fxy * gy) / det
        oy = -(fxx * gy - fxy * gx) / det
        # the weight of the 2-D solution: 1 within the pixel's +-1 box, fading to 0 at +-2, and 0
        # where the fit has no maximum (det -> 0 sends the solution to infinity, so this is continuous)
        reach = np.maximum(np.abs(ox), np.abs(oy))
        w = np.where((fxx < 0) & (det > 0), np.clip(2.0 - np.nan_to_num(reach, nan=2.0), 0.0, 1.0), 0.0)
        ox1 = np.where(fxx < 0, -gx / fxx, 0.0)
        oy1 = np.where(fyy < 0, -gy / fyy, 0.0)
    for k, (o2, o1) in enumerate(((ox, ox1), (oy, oy1))):
        one = np.clip(np.nan_to_num(o1), -0.5, 0.5)
        out[:, k] = np.where(w > 0, w * np.nan_to_num(o2) + (1.0 - w) * one, one)
    return out


def refine_gradient(
    grey: np.ndarray,
    xy: np.ndarray,
    *,
    half_window: int = 3,
    max_shift: float | None = None,
    max_iter: int = 100,
    tol: float = 1e-5,
) -> np.ndarray:
    """Move corners to the point orthogonal to the image gradients around them.

    A second-derivative measure peaks *inside* a corner, not on its vertex (about
    1.5 px on the wedges of ``sogdd.synthetic.pattern_image`` with sigma^2 = 1.2).
    The vertex of an ideal corner is the one point ``q`` with
    ``grad I(p) . (p - q) = 0`` for every ``p`` on its two edges, so the least
    squares solution of that system in a window centred on ``q`` (Foerstner 1987;
    the step of ``cv2.cornerSubPix``) removes the bias. The solution is iterated
    to its fixed point (:func:`sogdd.select.refine.forstner_points`: damped, to
    ``tol`` px), so it does not depend on where an iteration happened to stop.
    Points that would leave the window around their start (``|dx|`` or ``|dy|``
    over ``half_window``, cornerSubPix's own rule) or move more than ``max_shift``
    pixels (None: no further limit), or do not converge in ``max_iter`` steps, keep
    their input position, so a refinement that wanders to another structure is
    refused.

    Examples
    --------
    >>> import numpy as np
    >>> from sogdd.synthetic import Polygon, render_polygons
    >>> img = render_polygons((40, 40), [Polygon(np.array([[12.3, 11.6], [40, 11.6], [40, 40], [12.3, 40]]))])
    >>> q = refine_gradient(img, np.array([[13.5, 13.0]]))  # the vertex is at (12.3, 11.6)
    >>> q.round(3).tolist(), bool(np.abs(q - [12.3, 11.6]).max() < 0.2)
    ([[12.452, 11.611]], True)
    """
    pts = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if len(pts) == 0:
        return pts.copy()
    img = np.ascontiguousarray(grey, dtype=np.float32)
    half = np.full(len(pts), int(half_window), np.int64)
    shift = np.full(len(pts), np.inf if max_shift is None else float(max_shift))
    # each point is refined on its own, and the compiled code releases the GIL: chunks in threads
    n = max(1, min(thread_count(), len(pts) // _REFINE_CHUNK))
    if n == 1:  # few points: no thread pool to start
        return forstner_points(img, pts, half, shift, max_iter=max_iter, tol=tol)
    parts = np.array_split(np.arange(len(pts)), n)
    with ThreadPoolExecutor(n) as pool:
        outs = list(pool.map(lambda k: forstner_points(img, pts[k], half[k], shift[k], max_iter=max_iter,
                                                       tol=tol), parts))
    return np.concatenate(outs)


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


def first_distinct(place: Callable[[int], np.ndarray], strength: np.ndarray, limit: int | None, *,
                   tol: float = COINCIDENT,
                   allowed: Callable[[np.ndarray], np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The first ``limit`` distinct points of a ranked list whose positions are refined on demand.

    The candidates ``c_1 .. c_n`` come strongest first (``strength`` non-increasing,
    ties in the order given); ``place(m)`` gives the refined positions ``q_1 .. q_m``
    of the first ``m`` as an (m, 2) array. A candidate is kept when its position is
    allowed (``allowed(q)``, a boolean per point; None: all are) and no kept
    stronger one lies within ``tol`` px (:func:`one_per_point`):

        K_m = { i <= m : allowed(q_i) and |q_i - q_j| >= tol for every j in K_m, j < i },

    and the result is the first ``limit`` of ``K_m``. The cut is refilled: from
    ``m_0 = limit``, while ``|K_m| < limit`` and candidates remain,
    ``m <- m + (limit - |K_m|)`` (each further candidate adds at most one point, so
    no fewer candidates can do). Where ``q_i`` does not depend on ``m`` (the
    quadratic and gradient refinements treat each point alone), the greedy rule
    makes ``K_m`` a prefix of ``K_n``: the result is that of merging every candidate
    and cutting after, with only the candidates needed refined. ``limit`` None:
    ``m = n`` at once.

    Returns the indices kept (ascending, so strongest first; at most ``limit``)
    and the positions of the first ``m`` candidates (index them with the former).

    Examples
    --------
    >>> q = np.array([[5.0, 5.0], [5.0, 5.00001], [9.0, 9.0], [2.0, 2.0]])
    >>> keep, xy = first_distinct(lambda m: q[:m], np.array([4.0, 3.0, 2.0, 1.0]), 2)
    >>> keep.tolist(), len(xy)  # the duplicate is dropped and the third candidate fills its place
    ([0, 2], 3)
    """
    n = len(strength)
    m = n if limit is None else min(n, int(limit))
    while True:
        xy = place(m)
        ok = np.ones(m, bool) if allowed is None else np.asarray(allowed(xy), bool)
        idx = np.flatnonzero(ok)
        keep = idx[one_per_point(xy[idx], strength[:m][idx], tol)]
        if limit is None or len(keep) >= limit or m == n:
            return keep[:limit], xy
        m = min(n, m + int(limit) - len(keep))



@numba.njit(**JIT)
def _step(img, qx, qy, hw, patch, mask):  # pragma: no cover - jit
    """``F(q) - q`` for half-window ``hw`` (``patch``: (2 hw + 3)^2 scratch), or NaN where A is singular."""
    # the window's grid is q + integers: one pair of bilinear weights for all its samples
    h, w = img.shape
    n = 2 * hw + 3
    x0 = math.floor(qx) - hw - 1
    y0 = math.floor(qy) - hw - 1
    fx = qx - math.floor(qx)
    fy = qy - math.floor(qy)
    inside = x0 >= 0 and y0 >= 0 and x0 + n < w and y0 + n < h
    for i in range(n):
        ya = y0 + i
        yb = ya + 1
        if not inside:  # edge pixels replicated (getRectSubPix's border)
            ya = min(max(ya, 0), h - 1)
            yb = min(max(yb, 0), h - 1)
        for j in range(n):
            xa = x0 + j
            xb = xa + 1
            if not inside:
                xa = min(max(xa, 0), w - 1)
                xb = min(max(xb, 0), w - 1)
            top = img[ya, xa] * (1.0 - fx) + img[ya, xb] * fx
            bot = img[yb, xa] * (1.0 - fx) + img[yb, xb] * fx
            patch[i, j] = top * (1.0 - fy) + bot * fy
    a = 0.0
    b = 0.0
    c = 0.0
    b1 = 0.0
    b2 = 0.0
    for i in range(2 * hw + 1):
        py = float(i - hw)
        for j in range(2 * hw + 1):
            px = float(j - hw)
            m = mask[i, j]
            gx = patch[i + 1, j + 2] - patch[i + 1, j]
            gy = patch[i + 2, j + 1] - patch[i, j + 1]
            gxx = gx * gx * m
            gxy = gx * gy * m
            gyy = gy * gy * m
            a += gxx
            b += gxy
            c += gyy
            b1 += gxx * px + gxy * py
            b2 += gxy * px + gyy * py
    det = a * c - b * b
    if not det > 1e-12 * (a + c) * (a + c):
        return math.nan, math.nan
    return (c * b1 - b * b2) / det, (a * b2 - b * b1) / det


@numba.njit(**JIT)
def _converge(img, x, y, hw, patch, mask, max_iter, tol):  # pragma: no cover - jit
    """(x, y, converged): the damped fixed-point iteration of ``F`` from (x, y)."""
    lam = 1.0
    px = 0.0
    py = 0.0
    for _ in range(max_iter):
        dx, dy = _step(img, x, y, hw, patch, mask)
        n = math.sqrt(dx * dx + dy * dy)
        if not n < math.inf:  # singular window matrix
            return x, y, False
        if n < tol:  # q = F(q) to within tol: converged (not a step made small by damping)
            return x + dx, y + dy, True
        if dx * px + dy * py < 0.0:  # the step turned back: an overshoot, damp it
            lam *= 0.5
        x += lam * dx
        y += lam * dy
        px = dx
        py = dy
    return x, y, False


@numba.njit(**JIT)
def _refine(img, pts, half, max_shift, max_iter, tol, out):  # pragma: no cover - jit
    """``out[i]``: the damped fixed-point iteration of ``F`` from ``pts[i]``, or ``pts[i]`` (see module)."""
    hmax = 1
    for i in range(len(half)):
        hmax = max(hmax, half[i])
    patch = np.empty((2 * hmax + 3, 2 * hmax + 3))
    mask = np.empty((2 * hmax + 1, 2 * hmax + 1))
    last = -1
    for i in range(len(pts)):
        hw = half[i]
        if hw != last:  # cornerSubPix's weights
            for r in range(2 * hw + 1):
                for s in range(2 * hw + 1):
                    mask[r, s] = math.exp(-((r - hw) / hw) ** 2 - ((s - hw) / hw) ** 2)
            last = hw
        x0, y0 = pts[i, 0], pts[i, 1]
        x, y, done = _converge(img, x0, y0, hw, patch, mask, max_iter, tol)
        # inside the window the start defines (cornerSubPix's own rule), and within max_shift
        inside = abs(x - x0) <= hw and abs(y - y0) <= hw
        if done and inside and math.sqrt((x - x0) ** 2 + (y - y0) ** 2) <= max_shift[i]:
            out[i, 0], out[i, 1] = x, y
        else:
            out[i, 0], out[i, 1] = x0, y0


def forstner_points(
    grey: np.ndarray,
    xy: np.ndarray,
    half_window: np.ndarray,
    max_shift: np.ndarray,
    *,
    max_iter: int = 100,
    tol: float = 1e-5,
) -> np.ndarray:
    """Foerstner's corner point of each start point, iterated to convergence (see the module docstring).

    ``grey``: (H, W) image (read as float32); ``xy``: (N, 2) start points;
    ``half_window`` (>= 1), ``max_shift``: (N,) per point. A point that does not
    converge (``|F(q) - q| < tol``) within ``max_iter`` steps, that would leave the
    window around its start (``|dx|`` or ``|dy|`` over its half-window, as
    ``cv2.cornerSubPix`` refuses) or move more than its ``max_shift``, or whose
    window matrix is singular, keeps its start.

    Examples
    --------
    Where ``cv2.cornerSubPix`` converges, the two agree (to its float32 coordinates):

    >>> import cv2
    >>> import numpy as np
    >>> img = np.zeros((21, 21), np.float32)
    >>> img[10:, 10:] = 100.0  # an L-corner, vertex at (9.5, 9.5), blurred
    >>> img = cv2.GaussianBlur(img, (0, 0), 1.0)
    >>> q = forstner_points(img, np.array([[11.2, 10.8]]), np.array([3]), np.array([3.0]))
    >>> ocv = cv2.cornerSubPix(img, np.float32([[[11.2, 10.8]]]), (3, 3), (-1, -1), (3, 100, 1e-12))
    >>> q.round(4).tolist(), bool(np.abs(q - ocv.reshape(1, 2)).max() < 1e-5)
    ([[9.7019, 9.7019]], True)
    """
    img = np.ascontiguousarray(grey, dtype=np.float32)
    pts = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
    out = np.empty_like(pts)
    half = np.ascontiguousarray(half_window, dtype=np.int64).reshape(-1)
    if len(half) != len(pts) or (half < 1).any():
        raise ValueError("half_window must hold one integer >= 1 per point")
    shift = np.ascontiguousarray(max_shift, dtype=np.float64).reshape(-1)
    if len(shift) != len(pts):
        raise ValueError("max_shift must hold one value per point")
    if len(pts):
        _refine(img, pts, half, shift, int(max_iter), float(tol), out)
    return out
