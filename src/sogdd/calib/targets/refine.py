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

from sogdd._jit import EXACT_JIT

from .grey import to_grey

__all__ = ["cell_sizes", "corner_covariance", "half_widths", "refine_corners"]

#: the most sampling steps of the window each way from the centre (larger windows are strided)
MAX_HALF = 12
#: directions (over half a turn) of a window's reach (:func:`refine_grey`'s ``reach``)
REACH_DIRS = 16
_WHOLE = np.full(REACH_DIRS, np.inf)
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


@numba.njit(**EXACT_JIT)
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


@numba.njit(**EXACT_JIT)
def _bil_grad(img, x, y):  # pragma: no cover - jit
    """``(I, dI/dx, dI/dy)`` at ``(x, y)``: :func:`_bil` there and its central differences
    ``(_bil(x + 1, y) - _bil(x - 1, y)) / 2`` and ``(_bil(x, y + 1) - _bil(x, y - 1)) / 2``.

    Inside the image (a pixel from every edge) the three share one cell and its weights, 12 pixels read
    once (the same sums, to rounding); at the edges, :func:`_bil`'s five samples with their clamping."""
    H, W = img.shape
    if not (1.0 <= x < W - 2.0 and 1.0 <= y < H - 2.0):
        return (_bil(img, x, y), 0.5 * (_bil(img, x + 1, y) - _bil(img, x - 1, y)),
                0.5 * (_bil(img, x, y + 1) - _bil(img, x, y - 1)))
    x0 = int(x)
    y0 = int(y)
    fx = x - x0
    fy = y - y0
    gx = 1.0 - fx
    gy = 1.0 - fy
    # unsigned indices (all >= 0 here): numba tests every signed index for wrapping around
    cm, c0, c1, c2 = np.uint64(x0 - 1), np.uint64(x0), np.uint64(x0 + 1), np.uint64(x0 + 2)
    r0 = img[np.uint64(y0)]
    r1 = img[np.uint64(y0 + 1)]
    a = r0[c0] * gx + r0[c1] * fx
    b = r1[c0] * gx + r1[c1] * fx
    dx0 = (r0[c1] - r0[cm]) * gx + (r0[c2] - r0[c0]) * fx
    dx1 = (r1[c1] - r1[cm]) * gx + (r1[c2] - r1[c0]) * fx
    up = img[np.uint64(y0 - 1)]
    dn = img[np.uint64(y0 + 2)]
    dy0 = (r1[c0] - up[c0]) * gy + (dn[c0] - r0[c0]) * fy
    dy1 = (r1[c1] - up[c1]) * gy + (dn[c1] - r0[c1]) * fy
    return a * gy + b * fy, 0.5 * (dx0 * gy + dx1 * fy), 0.5 * (dy0 * gx + dy1 * fx)


@numba.njit(**EXACT_JIT)
def _bounded(reach):  # pragma: no cover - jit
    """Whether a window's ``reach`` bounds it in some direction."""
    for t in range(reach.shape[0]):
        if reach[t] < np.inf:
            return True
    return False


@numba.njit(**EXACT_JIT)
def _beyond(dx, dy, reach):  # pragma: no cover - jit
    """Whether the offset ``(dx, dy)`` lies beyond the ``reach`` of its direction (the nearest, mod pi)."""
    t = int(round(math.atan2(dy, dx) * reach.shape[0] / np.pi)) % reach.shape[0]
    return dx * dx + dy * dy > reach[t] * reach[t]


@numba.njit(**EXACT_JIT)
def _offsets(R, s, inv, reach):  # pragma: no cover - jit
    """The window's offsets ``d`` (one of each pair ``d, -d``) and their Gaussian weights, once per point:
    ``(dx, dy, w, n)``, the first ``n`` entries used.

    ``reach`` (:data:`REACH_DIRS`,): the longest offset taken along each direction ``k pi / REACH_DIRS``
    (an offset ``d`` counts in the direction nearest its own, mod pi); ``inf`` everywhere for the whole
    square window."""
    masked = _bounded(reach)
    m = (R // s + 1) * (2 * R // s + 1)  # the rows dy = 0, s, ..., R; the columns dx = -R, -R + s, ..., R
    dxs = np.empty(m, np.int64)
    dys = np.empty(m, np.int64)
    ws = np.empty(m)
    n = 0
    for dy in range(0, R + 1, s):
        for dx in range(-R, R + 1, s):
            if dy == 0 and dx <= 0:
                continue  # d and -d give the same term
            if masked and _beyond(dx, dy, reach):
                continue
            dxs[n] = dx
            dys[n] = dy
            ws[n] = math.exp(-(dx * dx + dy * dy) * inv)
            n += 1
    return dxs, dys, ws, n


@numba.njit(**EXACT_JIT)
def _normal(img, px, py, dxs, dys, ws, n, A, b):  # pragma: no cover - jit
    """Normal equations of the symmetric fit at ``(px, py)`` (module doc) over the window of
    :func:`_offsets`; returns ``(E, total)``."""
    # the sums in locals, not in ``A`` and ``b``: the compiler keeps them in registers (an array might
    # alias ``img``), the same additions in the same order
    a00 = 0.0
    a01 = 0.0
    a11 = 0.0
    b0 = 0.0
    b1 = 0.0
    e = 0.0
    sw = 0.0
    s1 = 0.0
    s2 = 0.0
    for t in range(n):
        dx = dxs[t]
        dy = dys[t]
        w = ws[t]
        xa = px + dx
        ya = py + dy
        xb = px - dx
        yb = py - dy
        va, gxa, gya = _bil_grad(img, xa, ya)
        vb, gxb, gyb = _bil_grad(img, xb, yb)
        r = va - vb
        j0 = gxa - gxb
        j1 = gya - gyb
        b0 += w * j0 * r
        a00 += w * j0 * j0
        a01 += w * j0 * j1
        b1 += w * j1 * r
        a11 += w * j1 * j1
        e += w * r * r
        sw += 2.0 * w
        s1 += w * (va + vb)
        s2 += w * (va * va + vb * vb)
    A[0, 0] = a00
    A[0, 1] = a01
    A[1, 0] = a01
    A[1, 1] = a11
    b[0] = b0
    b[1] = b1
    return e, s2 - s1 * s1 / max(sw, 1e-300)


@numba.njit(**EXACT_JIT)
def _solve(A, b, x):  # pragma: no cover - jit
    """Solve the 2 x 2 normal equations of the corner's step; False when singular."""
    det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    if not (det > 1e-12 * (A[0, 0] * A[1, 1] + 1e-300)):
        return False
    x[0] = -(A[1, 1] * b[0] - A[0, 1] * b[1]) / det
    x[1] = -(A[0, 0] * b[1] - A[1, 0] * b[0]) / det
    return True


@numba.njit(**EXACT_JIT)
def _inv(R):  # pragma: no cover - jit
    """``1 / (2 sigma^2)`` of the Gaussian weight of a window of half-width ``R`` (``sigma = R``, >= 1)."""
    sig = max(R / 1.0, 1.0)
    return 1.0 / (2.0 * sig * sig)


@numba.njit(**EXACT_JIT)
def _whole_windows(half, stride, reach):  # pragma: no cover - jit
    """The whole square windows' offsets and weights (:func:`_offsets`), once per half-width ``R`` (with the
    stride of the first point of that half-width): ``(slot, dx, dy, w, n, s)``, the table's row ``slot[R]``
    for half-width ``R`` (-1: no point of a whole window has it). Many corners share a half-width, and the
    weights' ``exp`` costs as much as a Gauss-Newton step."""
    top = 0
    for k in range(half.shape[0]):
        top = max(top, half[k])
    slot = np.full(top + 1, -1, np.int64)
    first = np.empty(half.shape[0], np.int64)
    rows = 0
    size = 1
    for k in range(half.shape[0]):
        R = half[k]
        if slot[R] < 0 and not _bounded(reach[k]):
            slot[R] = rows
            first[rows] = k
            rows += 1
            size = max(size, (R // stride[k] + 1) * (2 * R // stride[k] + 1))
    tdx = np.empty((rows, size), np.int64)
    tdy = np.empty((rows, size), np.int64)
    tw = np.empty((rows, size))
    tn = np.zeros(rows, np.int64)
    ts = np.zeros(rows, np.int64)
    for i in range(rows):
        k = first[i]
        dxs, dys, ws, m = _offsets(half[k], stride[k], _inv(half[k]), reach[k])
        tdx[i, :m] = dxs[:m]
        tdy[i, :m] = dys[:m]
        tw[i, :m] = ws[:m]
        tn[i] = m
        ts[i] = stride[k]
    return slot, tdx, tdy, tw, tn, ts


@numba.njit(parallel=True, **EXACT_JIT)
def _refine(img, pts, half, stride, max_shift, iterations, tol, reach, out, quality):  # pragma: no cover - jit
    slot, tdx, tdy, tw, tn, ts = _whole_windows(half, stride, reach)
    for k in numba.prange(pts.shape[0]):
        px0 = pts[k, 0]
        py0 = pts[k, 1]
        px = px0
        py = py0
        R = half[k]
        s = stride[k]
        A = np.empty((2, 2))
        b = np.empty(2)
        step = np.zeros(2)
        ok = False
        q = 0.0
        # the window, once: its weights do not move (a whole one shared by the points of its half-width)
        i = slot[R]
        if i >= 0 and ts[i] == s and not _bounded(reach[k]):
            dxs, dys, ws, m = tdx[i], tdy[i], tw[i], tn[i]
        else:
            dxs, dys, ws, m = _offsets(R, s, _inv(R), reach[k])
        for _ in range(iterations):
            e, tot = _normal(img, px, py, dxs, dys, ws, m, A, b)
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


@numba.njit(**EXACT_JIT)
def _spread(acc, x, y, ox, oy, gx, gy):  # pragma: no cover - jit
    """Add ``(gx, gy)`` times the bilinear weights of the sample at ``(x, y)`` (inside the image, as the
    windows keep it) to its four pixels in ``acc`` (pixel ``(i, j)`` at ``acc[j - oy, i - ox]``); return the
    sum of the squared weights."""
    x0 = int(x)
    y0 = int(y)
    fx = x - x0
    fy = y - y0
    q = 0.0
    for j in range(2):
        wy = fy if j else 1.0 - fy
        for i in range(2):
            c = wy * (fx if i else 1.0 - fx)
            acc[y0 + j - oy, x0 + i - ox, 0] += c * gx
            acc[y0 + j - oy, x0 + i - ox, 1] += c * gy
            q += c * c
    return q


@numba.njit(**EXACT_JIT)
def _noise_gain(img, px, py, R, dxs, dys, ws, m):  # pragma: no cover - jit
    """``G = sum_i g_i g_i^T`` (as ``G00, G01, G11``) and ``q = sum_d w_d sum_i l_di^2`` of
    :func:`corner_covariance` at ``(px, py)``: each term's ``w_d J_d`` spread onto the pixels its two
    samples interpolate, ``+`` at ``p + d`` and ``-`` at ``p - d`` (the window of :func:`_offsets`)."""
    H, W = img.shape
    ox = max(int(math.floor(px)) - R - 1, 0)  # the pixels of the samples p +- d, |d| <= R
    oy = max(int(math.floor(py)) - R - 1, 0)
    acc = np.zeros((min(int(math.floor(py)) + R + 3, H) - oy, min(int(math.floor(px)) + R + 3, W) - ox, 2))
    q = 0.0
    for t in range(m):
        w = ws[t]
        xa = px + dxs[t]
        ya = py + dys[t]
        xb = px - dxs[t]
        yb = py - dys[t]
        _, gxa, gya = _bil_grad(img, xa, ya)
        _, gxb, gyb = _bil_grad(img, xb, yb)
        gx = w * (gxa - gxb)
        gy = w * (gya - gyb)
        q += w * _spread(acc, xa, ya, ox, oy, gx, gy)
        q += w * _spread(acc, xb, yb, ox, oy, -gx, -gy)
    g = acc.reshape(-1, 2)
    return np.sum(g[:, 0] * g[:, 0]), np.sum(g[:, 0] * g[:, 1]), np.sum(g[:, 1] * g[:, 1]), q


@numba.njit(parallel=True, **EXACT_JIT)
def _covariance(img, pts, half, stride, out):  # pragma: no cover - jit
    """Each point's position covariance (:func:`corner_covariance`); NaN where it has none."""
    for k in numba.prange(pts.shape[0]):
        px = pts[k, 0]
        py = pts[k, 1]
        R = half[k]
        sig = max(R / 1.0, 1.0)
        inv = 1.0 / (2.0 * sig * sig)
        A = np.empty((2, 2))
        b = np.empty(2)
        dxs, dys, ws, m = _offsets(R, stride[k], inv, _WHOLE)
        e, _ = _normal(img, px, py, dxs, dys, ws, m, A, b)
        out[k, :, :] = np.nan
        det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
        if not (det > 1e-12 * (A[0, 0] * A[1, 1] + 1e-300)):
            continue
        G00, G01, G11, q = _noise_gain(img, px, py, R, dxs, dys, ws, m)
        a00 = A[1, 1] / det
        a01 = -A[0, 1] / det
        a11 = A[0, 0] / det
        # M = A^-1 G, its trace, and A^-1 G A^-1
        m00 = a00 * G00 + a01 * G01
        m01 = a00 * G01 + a01 * G11
        m10 = a01 * G00 + a11 * G01
        m11 = a01 * G01 + a11 * G11
        dof = q - (m00 + m11)
        if not (dof > 0.0):
            continue
        noise = e / dof
        out[k, 0, 0] = noise * (m00 * a00 + m01 * a01)
        out[k, 0, 1] = noise * (m00 * a01 + m01 * a11)
        out[k, 1, 0] = out[k, 0, 1]
        out[k, 1, 1] = noise * (m10 * a01 + m11 * a11)


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


def _windows(shape: tuple[int, ...], pts: np.ndarray, half: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The half-widths cut to stay inside the image (with the gradient's pixel), and their sampling strides."""
    H, W = shape[:2]
    # the room to the edges, less the gradient's pixel (np.column_stack: np.c_'s array, without its overhead)
    room = np.floor(np.min(np.column_stack([pts, W - 1 - pts[:, 0], H - 1 - pts[:, 1]]), axis=1)) - 2
    half = np.maximum(np.minimum(half, room), 1).astype(np.int64)  # the window stays inside the image
    stride = np.maximum(1, -(-half // MAX_HALF)).astype(np.int64)
    return half, stride


def refine_grey(grey: np.ndarray, pts: np.ndarray, half: np.ndarray, shift: np.ndarray,
                iterations: int = 20, tol: float = DEFAULT_TOL, reach: np.ndarray | None = None,
                ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`refine_corners` on a validated grey image with per-point half-widths and shift bounds.

    At most ``iterations`` Gauss-Newton steps, stopping after a step of at most ``tol`` px. ``reach``
    (N, :data:`REACH_DIRS`) or None: per point, the longest offset ``d`` of the window along each direction
    ``k pi / REACH_DIRS`` (``d`` and ``-d`` count in the direction nearest theirs, mod pi; ``inf``: the
    square's), a star-shaped window inside the square one, for a corner whose squares end sooner on some
    sides than on others (a board's border); None: the square window.
    """
    half, stride = _windows(grey.shape, pts, half)
    out = np.empty_like(pts)
    quality = np.zeros(len(pts))
    if reach is None:
        reach = np.broadcast_to(_WHOLE, (len(pts), REACH_DIRS))
    if len(pts):
        _refine(np.ascontiguousarray(grey, dtype=np.float64), pts, half.astype(np.int64), stride,
                shift.astype(np.float64), int(iterations), float(tol),
                np.ascontiguousarray(reach, dtype=np.float64), out, quality)
    return out, quality


def corner_covariance(grey: np.ndarray, xy: np.ndarray, half: np.ndarray | int) -> np.ndarray:
    """The covariance of refined corners' positions under the image's noise, (N, 2, 2) px^2.

    The refinement (module doc) minimises ``E(p) = sum_d w_d r_d^2`` over the
    half-window of offsets ``d`` (``d`` and ``-d`` are one term), with
    ``r_d = I(p + d) - I(p - d)``, ``J_d = grad I(p + d) - grad I(p - d)`` and the
    normal matrix ``A = sum_d w_d J_d J_d^T``. Each sample ``I(q)`` is the bilinear
    interpolation ``sum_i b_i(q) I_i`` of the pixels ``I_i``; with white pixel
    noise ``n_i`` of variance ``sigma_n^2``, the residuals' noise is
    ``e_d = sum_i l_di n_i``, ``l_di = b_i(p + d) - b_i(p - d)``, and linearising
    the optimum's condition ``sum_d w_d J_d r_d = 0`` moves the corner by

        delta p = -A^-1 sum_d w_d J_d e_d = -A^-1 sum_i g_i n_i,
        g_i = sum_d w_d J_d l_di,

    so that its covariance is

        C = sigma_n^2 A^-1 G A^-1,   G = sum_i g_i g_i^T.

    ``sigma_n^2`` is measured from the fit's own residuals: with the hat matrix
    ``H = J A^-1 J^T W``, the fitted residuals are ``(I - H) e`` and
    ``E[E] = sigma_n^2 (tr(W L L^T) - tr(A^-1 G))`` (the two cross terms are
    both ``tr(A^-1 G)``), ``tr(W L L^T) = sum_d w_d sum_i l_di^2``, so

        sigma_n^2 = E / (sum_d w_d sum_i l_di^2 - tr(A^-1 G)).

    This is the weighted form of ``s^2 = E / (n - 2)``, ``C = s^2 A^-1``, which
    it is for unit weights and independent samples: ``G = A`` and
    ``sum_i l_di^2 = 1`` make ``C = E / (n - 2) A^-1``. Here neither holds: the
    Gaussian weights are a window, not inverse variances (hence the sandwich
    ``A^-1 G A^-1``), and the samples at neighbouring offsets share pixels
    through the interpolation (at a fraction ``f`` of a pixel each sample's
    variance is ``((1 - f_x)^2 + f_x^2)((1 - f_y)^2 + f_y^2)`` of a pixel's, as
    little as a quarter, while their sum over the window carries a pixel's
    whole noise): ``G`` and ``l`` count every pixel once, exactly, so the
    covariance holds at any fraction. A departure from point symmetry
    (a shadow, a window reaching beyond the squares) adds to ``E`` as noise
    does, and makes ``C`` larger: it is the corner's precision as measured,
    never better than its noise.

    Parameters
    ----------
    grey : (H, W) ndarray
        The grey image the corners were refined on, float on 0-255 (what
        :func:`sogdd.calib.targets.grey.to_grey` returns; any real dtype).
    xy : (N, 2) array_like
        The refined corners (x = column, y = row).
    half : int or (N,) array_like of int
        The refinement windows' half-widths (:func:`half_widths`); cut to stay
        inside the image, and sampled with the strides, as :func:`refine_grey` does.

    Returns
    -------
    (N, 2, 2) float64
        Each corner's covariance in px^2; NaN where the normal matrix is
        singular (a flat or one-edge window), the residuals have no degrees
        of freedom left, or the corner lies within 3 px of the image's edge.

    Examples
    --------
    >>> import cv2
    >>> t = np.arange(40) + 0.5 - 20.3   # pixel centres relative to a corner at x = y = 19.8
    >>> edge = np.clip(t, -0.5, 0.5)
    >>> clean = cv2.GaussianBlur(128 + 160 * edge[:, None] * edge[None, :], (0, 0), 1.5)
    >>> img = clean + np.random.default_rng(0).normal(0, 2.0, clean.shape)  # noise of 2 grey levels
    >>> xy = refine_grey(img, np.array([[19.5, 19.5]]), np.array([6]), np.array([6.0]))[0]
    >>> C = corner_covariance(img, xy, 6)
    >>> C.shape, bool(0.01 < np.sqrt(np.linalg.eigvalsh(C[0])[-1]) < 0.05)
    ((1, 2, 2), True)
    """
    img = np.ascontiguousarray(grey, dtype=np.float64)
    if img.ndim != 2 or min(img.shape) < 8:
        raise ValueError(f"grey must be a 2-D image of at least 8 x 8 pixels, got shape {np.shape(grey)}")
    pts = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if not np.isfinite(pts).all():
        raise ValueError("xy must be finite")
    h = np.broadcast_to(np.asarray(half), (len(pts),)) if np.ndim(half) == 0 else np.asarray(half).reshape(-1)
    if len(h) != len(pts) or not np.all(np.isfinite(h)) or np.any(h < 1):
        raise ValueError(f"half must be a half-width >= 1, one or one per point, got {np.shape(half)}")
    H, W = img.shape
    # a window of at least 1 px and its gradient's pixel inside the image
    inside = np.min(np.c_[pts, W - 1 - pts[:, 0], H - 1 - pts[:, 1]], axis=1) >= 3
    out = np.full((len(pts), 2, 2), np.nan)
    k = np.flatnonzero(inside)
    if len(k):
        hk, stride = _windows(img.shape, pts[k], np.rint(h[k]).astype(np.int64))
        cov = np.empty((len(k), 2, 2))
        _covariance(img, np.ascontiguousarray(pts[k]), hk, stride, cov)
        out[k] = cov
    return out
