"""X-corner refinement by point symmetry, a drop-in for ``cv2.cornerSubPix``.

Why point symmetry
------------------
A chessboard is point-symmetric about each of its inner corners, and so is its
image near the corner under any blur, any contrast and any angle between the
edge lines: the two edge lines through the corner ``p`` stay straight lines
through ``p`` under perspective, and a Gaussian (or any symmetric) blur keeps the
symmetry. So ``I(p + d) = I(p - d)`` for every offset ``d`` smaller than the
distance to the next edge line, and the corner is the point that minimises

    E(p) = sum_d w(d) (I(p + d) - I(p - d))^2

over a window of integer offsets ``d`` (``I`` interpolated bilinearly). No model
of the blur or of the wedges is fitted, so nothing is biased by a wrong one, and
every pixel of the window contributes. Gauss-Newton steps
``(J^T W J) delta = -J^T W r`` with ``r = I(p + d) - I(p - d)`` and
``J = grad I(p + d) - grad I(p - d)`` converge in a few iterations. (A term
``- 2 g . d`` for a linear illumination gradient ``g`` was measured and left out:
on rendered boards with an illumination falloff of 0.4 it raised the mean error
from 0.017 to 0.023 px at cells of 6-8 px and from 0.014 to 0.015 at 10-16 px,
the two extra unknowns costing more than the gradient's pull.)

The window follows the corner: its half-width is 0.65 of the local cell (the
distance to the nearest other corner; the board stays point-symmetric beyond the
next edge lines, up to perspective) and its weight a Gaussian of the same width,
so a 6 px cell uses a 4 px window and a 31 px cell 20 px, the most (beyond it,
lens distortion bends the edges more than the extra pixels help; a blur of 5 px
still fits). Chosen on rendered boards (``benchmarks/bench_calib_detect.py
--accuracy``): 0.65 against 0.5 and 0.8 gave 0.021 / 0.025 / 0.023 px at cells of
6-8 px and 0.056 / 0.076 / 0.069 px at 10-16 px under a blur of 2.5 px. Large windows are
sampled on a coarser grid of offsets (at most :data:`MAX_HALF` steps each way),
which keeps the time per corner bounded.

A point that would move farther than ``max_shift`` (default: the window's
half-width), or whose normal matrix is singular, keeps its start and gets
quality 0. Near the image's edge the window shrinks to stay inside it.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from scipy.spatial import cKDTree

from .xcorners import to_grey

__all__ = ["cell_sizes", "refine_corners"]

_JIT = dict(cache=True, nogil=True, error_model="numpy")
#: the most sampling steps of the window each way from the centre (larger windows are strided)
MAX_HALF = 12
#: the window's half-width as a fraction of the local cell
WINDOW_FRACTION = 0.65
#: smallest and largest default half-widths (px)
MIN_HALF, MAX_WINDOW = 2, 20
#: the half-width when a point has no other point to measure its cell by (cornerSubPix's usual 11 x 11)
DEFAULT_HALF = 5
#: Gauss-Newton steps and the step (px) that stops them, when no ``criteria`` are given
DEFAULT_ITERATIONS, DEFAULT_TOL = 20, 1e-4
#: ``cv2.TERM_CRITERIA_COUNT`` (= ``MAX_ITER``), ``cv2.TERM_CRITERIA_EPS``, and cornerSubPix's cap on the count
_COUNT, _EPS, _MAX_COUNT = 1, 2, 100


@numba.njit(**_JIT)
def _bil(img, x, y):  # pragma: no cover - jit
    H, W = img.shape
    x = min(max(x, 0.0), W - 1.0)
    y = min(max(y, 0.0), H - 1.0)
    x0 = min(int(x), W - 2)
    y0 = min(int(y), H - 2)
    fx = x - x0
    fy = y - y0
    a = img[y0, x0] * (1.0 - fx) + img[y0, x0 + 1] * fx
    b = img[y0 + 1, x0] * (1.0 - fx) + img[y0 + 1, x0 + 1] * fx
    return a * (1.0 - fy) + b * fy


@numba.njit(**_JIT)
def _normal(img, px, py, R, s, inv, A, b):  # pragma: no cover - jit
    """Normal equations of the symmetric fit at ``(px, py)`` (module doc); returns ``(E, total)``."""
    for u in range(2):
        b[u] = 0.0
        for v in range(2):
            A[u, v] = 0.0
    e = 0.0
    sw = 0.0
    s1 = 0.0
    s2 = 0.0
    J = np.empty(2)
    for dy in range(0, R + 1, s):
        for dx in range(-R, R + 1, s):
            if dy == 0 and dx <= 0:
                continue  # d and -d give the same term
            w = math.exp(-(dx * dx + dy * dy) * inv)
            xa = px + dx
            ya = py + dy
            xb = px - dx
            yb = py - dy
            va = _bil(img, xa, ya)
            vb = _bil(img, xb, yb)
            r = va - vb
            J[0] = 0.5 * (_bil(img, xa + 1, ya) - _bil(img, xa - 1, ya)
                          - _bil(img, xb + 1, yb) + _bil(img, xb - 1, yb))
            J[1] = 0.5 * (_bil(img, xa, ya + 1) - _bil(img, xa, ya - 1)
                          - _bil(img, xb, yb + 1) + _bil(img, xb, yb - 1))
            for u in range(2):
                b[u] += w * J[u] * r
                for v in range(u, 2):
                    A[u, v] += w * J[u] * J[v]
            e += w * r * r
            sw += 2.0 * w
            s1 += w * (va + vb)
            s2 += w * (va * va + vb * vb)
    A[1, 0] = A[0, 1]
    return e, s2 - s1 * s1 / max(sw, 1e-300)


@numba.njit(**_JIT)
def _solve(A, b, x):  # pragma: no cover - jit
    """Solve the 2 x 2 normal equations of the corner's step; False when singular."""
    det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    if not (det > 1e-12 * (A[0, 0] * A[1, 1] + 1e-300)):
        return False
    x[0] = -(A[1, 1] * b[0] - A[0, 1] * b[1]) / det
    x[1] = -(A[0, 0] * b[1] - A[1, 0] * b[0]) / det
    return True


@numba.njit(parallel=True, **_JIT)
def _refine(img, pts, half, stride, max_shift, iterations, tol, out, quality):  # pragma: no cover - jit
    for k in numba.prange(pts.shape[0]):
        px0 = pts[k, 0]
        py0 = pts[k, 1]
        px = px0
        py = py0
        R = half[k]
        s = stride[k]
        sig = max(R / 1.0, 1.0)
        inv = 1.0 / (2.0 * sig * sig)
        A = np.empty((2, 2))
        b = np.empty(2)
        step = np.zeros(2)
        ok = False
        q = 0.0
        for _ in range(iterations):
            e, tot = _normal(img, px, py, R, s, inv, A, b)
            q = 1.0 - e / tot if tot > 0 else 0.0
            if not _solve(A, b, step):
                ok = False
                break
            n = math.hypot(step[0], step[1])
            if n > 0.5:  # a damped step far from the optimum
                step[0] *= 0.5 / n
                step[1] *= 0.5 / n
            px += step[0]
            py += step[1]
            ok = math.hypot(px - px0, py - py0) <= max_shift[k]
            if not ok or n <= tol:  # cornerSubPix's test: stop once a step is at most epsilon
                break
        if ok:
            out[k, 0] = px
            out[k, 1] = py
            quality[k] = max(0.0, min(1.0, q))
        else:
            out[k, 0] = px0
            out[k, 1] = py0
            quality[k] = 0.0


def cell_sizes(points: np.ndarray) -> np.ndarray:
    """Each point's distance to its nearest other point (inf for a single point).

    On a board's corners this is the local cell, along the shorter side.

    Examples
    --------
    >>> cell_sizes(np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 25.0]])).tolist()
    [10.0, 10.0, 25.0]
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if len(pts) < 2:
        return np.full(len(pts), np.inf)
    d, _ = cKDTree(pts).query(pts, k=2)
    return d[:, 1]


def _is_int(v: object) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def _int_pair(value: object) -> tuple[int, int] | None:
    """``value`` as OpenCV's ``Size``: an int for both, or a pair of ints; None when it is neither."""
    if _is_int(value):
        return int(value), int(value)
    try:
        pair = tuple(value)  # type: ignore[arg-type]
    except TypeError:
        return None
    return (int(pair[0]), int(pair[1])) if len(pair) == 2 and all(_is_int(v) for v in pair) else None


def _half_width(winSize: object) -> int | None:
    """cornerSubPix's ``winSize`` as one half-width (the smaller of ``w, h``); None: from the local cell."""
    if winSize is None:
        return None
    w = _int_pair(winSize)
    if w == (-1, -1):
        return None
    if w is None or min(w) < 1:
        raise ValueError(f"winSize must be a half-width (w, h) of integers >= 1, or (-1, -1), got {winSize!r}")
    return min(w)


def _criteria(criteria: object) -> tuple[int, float]:
    """cornerSubPix's ``(type, maxCount, epsilon)``, mapped as it maps them: (most steps, the stopping step)."""
    if criteria is None:
        return DEFAULT_ITERATIONS, DEFAULT_TOL
    try:
        kind, count, eps = criteria  # type: ignore[misc]
    except (TypeError, ValueError):
        kind = count = eps = None
    if not (_is_int(kind) and _is_int(count) and isinstance(eps, (int, float, np.integer, np.floating))
            and not isinstance(eps, bool) and math.isfinite(eps)):
        raise ValueError(f"criteria must be (type, maxCount, epsilon) as cv2.TERM_CRITERIA_*, got {criteria!r}")
    iterations = min(max(int(count), 1), _MAX_COUNT) if int(kind) & _COUNT else _MAX_COUNT
    return iterations, (max(float(eps), 0.0) if int(kind) & _EPS else 0.0)


def _corner_array(corners: object) -> tuple[np.ndarray, np.ndarray | None, tuple[int, ...], np.dtype]:
    """The starts as (N, 2) float64, the array to refine in place (or None), the shape and dtype to return."""
    if isinstance(corners, np.ndarray):
        if corners.dtype.kind not in "iuf":
            raise ValueError(f"corners must be real numbers (float32 as OpenCV's), got dtype {corners.dtype}")
        given = corners
    else:
        try:
            given = np.asarray(corners, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"corners must be (N, 2) or (N, 1, 2) numbers, got {corners!r:.60}") from None
    if given.ndim not in (1, 2, 3) or given.shape[-1] != 2:
        raise ValueError(f"corners must be (N, 2) or (N, 1, 2), got shape {given.shape}")
    pts = given.astype(np.float64).reshape(-1, 2)
    if not np.isfinite(pts).all():
        raise ValueError("corners must be finite")
    kept = isinstance(corners, np.ndarray) and corners.dtype in (np.float32, np.float64)
    into = corners if kept and corners.flags.writeable else None
    return pts, into, given.shape, given.dtype if kept else np.dtype(np.float64)


def half_widths(pts: np.ndarray, window: object, cell: object) -> np.ndarray:
    n = len(pts)
    if window is not None:
        w = np.broadcast_to(np.asarray(window, dtype=np.float64), (2,) if np.ndim(window) else ())
        if not np.isfinite(w).all() or np.any(w < 1):
            raise ValueError(f"window must be a half-width >= 1 px (int or (w, h), as winSize), got {window!r}")
        return np.full(n, int(round(float(np.min(w)))), dtype=np.int64)
    if cell is None:
        c = cell_sizes(pts)
    else:
        c = np.broadcast_to(np.asarray(cell, dtype=np.float64), (n,)) if np.ndim(cell) == 0 else np.asarray(
            cell, dtype=np.float64).reshape(-1)
        if len(c) != n or not np.all(c > 0):
            raise ValueError(f"cell must be a positive number or one per point, got {np.shape(cell)}")
    h = np.where(np.isfinite(c), np.rint(WINDOW_FRACTION * c), DEFAULT_HALF)
    return np.clip(h, MIN_HALF, MAX_WINDOW).astype(np.int64)


def refine_corners(image: np.ndarray, corners: object, winSize: int | tuple[int, int] | None = None,
                   zeroZone: tuple[int, int] | None = None, criteria: tuple[int, int, float] | None = None, *,
                   cell: float | np.ndarray | None = None, max_shift: float | None = None,
                   return_quality: bool = False, value_range: tuple[float, float] | None = None,
                   ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Refine X-corners (chessboard inner corners) to their centre of point symmetry, as ``cv2.cornerSubPix``.

    Minimises ``E(p) = sum_d w(d) (I(p + d) - I(p - d))^2`` over the corner ``p``
    (its centre of point symmetry) by Gauss-Newton, with a
    Gaussian weight ``w(d) = exp(-|d|^2 / (2 h^2))`` over the offsets ``|d_x|, |d_y| <= h``
    (module doc). A drop-in for ``cv2.cornerSubPix(image, corners, winSize, zeroZone,
    criteria)`` on any detector's X-corners (``findChessboardCorners``,
    ``findChessboardCornersSB``, ChArUco, mrgingham): the same arguments in the same
    order, the result written into ``corners`` and returned in its shape and dtype.

    Parameters
    ----------
    image : ndarray
        Grey or colour image (RGB), any dtype the corner detector takes, on its
        scale (:func:`sogdd.image.to_gray255`): uint8, uint16, float on [0, 1];
        another range (``cornerSubPix``'s float32 grey levels) needs ``value_range``.
    corners : array_like
        Start points, (N, 2) or (N, 1, 2) as OpenCV gives them; x = column,
        y = row, pixel centres at integers. A writable float32 or float64 array
        is refined in place, as ``cornerSubPix`` does (so code that ignores the
        return value still gets the refined corners); anything else (a list, an
        integer or read-only array) is left as it is.
    winSize : (int, int) or int or None
        Half-width ``h`` in px, as ``cornerSubPix``'s (``(5, 5)`` is an 11 x 11
        window); the window is square, of the smaller of the two. ``(-1, -1)`` or
        None: 0.65 of the local cell, clipped to [2, 20] px (module doc), the default
        because it follows the corner's scale.
    zeroZone : (int, int) or None
        Accepted for ``cornerSubPix``'s signature and ignored: its dead zone keeps the
        autocorrelation matrix of a gradient fit from going singular at the corner,
        but the offsets ``d`` near 0 add almost nothing here (``I(p + d) - I(p - d)``
        and its derivative both vanish as ``d -> 0``), and the normal matrix gets its
        rank from the edge lines further out.
    criteria : (type, maxCount, epsilon) or None
        ``cv2.TERM_CRITERIA_COUNT`` (= ``MAX_ITER``) caps the Gauss-Newton steps at
        ``maxCount`` clipped to [1, 100], else 100; ``cv2.TERM_CRITERIA_EPS`` stops
        after a step of at most ``epsilon`` px, else only the count stops them: the
        mapping ``cornerSubPix`` uses. None: at most 20 steps, stopping at 1e-4 px.
    cell : float or (N,) array or None
        The local cell size in px, for the default window; None: each point's
        distance to its nearest other point (:func:`cell_sizes`), and an 11 x 11
        window for a point alone.
    max_shift : float or None
        A point that would move farther than this keeps its start (quality 0);
        None: the window's half-width (``cornerSubPix`` keeps the start when
        either coordinate moves more than its half-width).
    return_quality : bool
        Also return each point's quality ``1 - E / V`` in [0, 1] (``V``: the weighted
        variance of the window's samples; 1 for a perfectly symmetric corner, 0 for a
        failed one).
    value_range : (lo, hi) or None
        The image's range, mapped to 0-255 (``(0, 255)`` for a float image of
        grey levels); None: the dtype's, and a float image outside [0, 1] is a
        one-line ``ValueError``.

    Returns
    -------
    ndarray, or (corners, quality) with ``return_quality=True``
        The refined corners in the shape and dtype of ``corners`` (float64 for a
        list or an integer array): ``corners`` itself when it was refined in place.
        A point that cannot be refined (a singular normal matrix: a flat or one-edge
        neighbourhood; or a move beyond ``max_shift``) keeps its start exactly, as
        ``cornerSubPix`` leaves a point that moved beyond its window, and gets quality 0.

    Examples
    --------
    >>> import cv2
    >>> t = np.arange(40) + 0.5 - 20.3   # pixel centres relative to a corner at x = y = 19.8
    >>> edge = np.clip(t, -0.5, 0.5)     # each pixel's covered fraction, minus 1/2
    >>> img = cv2.GaussianBlur(128 + 200 * edge[:, None] * edge[None, :], (0, 0), 1.0)  # blur sigma 1 px
    >>> xy, q = refine_corners(img, [[19.0, 20.5]], 6, return_quality=True, value_range=(0, 255))
    >>> np.round(np.abs(xy - 19.8).max(), 2), bool(q[0] > 0.99)  # from 0.8 px off to 0.01
    (np.float64(0.01), True)

    OpenCV's calling convention, the corners refined in place:

    >>> grey = np.rint(img).astype(np.uint8)
    >>> found = np.array([[[19.0, 20.5]]], np.float32)  # as findChessboardCorners gives them
    >>> crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)
    >>> out = refine_corners(grey, found, (6, 6), (-1, -1), crit)
    >>> out is found, out.shape, out.dtype, bool(np.abs(found - 19.8).max() < 0.02)
    (True, (1, 1, 2), dtype('float32'), True)
    """
    grey = to_grey(image, value_range)
    pts, into, shape, dtype = _corner_array(corners)
    window = _half_width(winSize)
    if zeroZone is not None and _int_pair(zeroZone) is None:
        raise ValueError(f"zeroZone must be (w, h) integers as cornerSubPix's, e.g. (-1, -1), got {zeroZone!r}")
    iterations, tol = _criteria(criteria)
    half = half_widths(pts, window, cell)
    if max_shift is None:
        shift = half.astype(np.float64)
    else:
        if not (np.isfinite(max_shift) and max_shift > 0):
            raise ValueError(f"max_shift must be a positive number, got {max_shift!r}")
        shift = np.full(len(pts), float(max_shift))
    out, quality = refine_grey(grey, pts, half, shift, iterations, tol)
    if into is not None:
        into[...] = out.reshape(shape)
        result = into
    else:
        result = out.reshape(shape).astype(dtype, copy=False)
    return (result, quality) if return_quality else result


def refine_grey(grey: np.ndarray, pts: np.ndarray, half: np.ndarray, shift: np.ndarray,
                iterations: int = 20, tol: float = DEFAULT_TOL) -> tuple[np.ndarray, np.ndarray]:
    """:func:`refine_corners` on a validated grey image with per-point half-widths and shift bounds.

    At most ``iterations`` Gauss-Newton steps, stopping after a step of at most ``tol`` px.
    """
    H, W = grey.shape
    room = np.floor(np.min(np.c_[pts, W - 1 - pts[:, 0], H - 1 - pts[:, 1]], axis=1)) - 2  # and the gradient
    half = np.maximum(np.minimum(half, room), 1).astype(np.int64)  # the window stays inside the image
    stride = np.maximum(1, -(-half // MAX_HALF)).astype(np.int64)
    out = np.empty_like(pts)
    quality = np.zeros(len(pts))
    if len(pts):
        _refine(np.ascontiguousarray(grey, dtype=np.float64), pts, half.astype(np.int64), stride,
                shift.astype(np.float64), int(iterations), float(tol), out, quality)
    return out, quality
