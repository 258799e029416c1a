"""Compiled parts of the X-junction stage (:mod:`sogdd.select.x_junctions`).

Two things made the stage a third of ``hr``'s time with numpy: five
image-sized derivative maps, and five full passes (strength, square root,
dilation, comparison, ``nonzero``) to find a few thousand candidates among
millions of pixels. Here:

- :func:`strength_maxima` finds the candidates in one pass over the three
  second-derivative maps: ``N = g_xy^2 - g_xx g_yy`` (the saddle strength is
  ``sigma^2 sqrt(max(N, 0))``, monotone in ``N``), and a pixel is a candidate when
  ``N > t_N`` and ``N`` is not below any in-image 8-neighbour;
- :func:`newton_steps` runs the Newton steps of every candidate in one
  compiled loop, with the Hessian and the gradient at each iterate from the
  image itself (separable Gaussian-derivative sums at the four pixels the
  bilinear interpolation reads, sharing their row sums, ``_at``;
  ``_derivatives`` evaluates it at given points, for the tests): only the candidates need them, so the
  derivative maps are needed for the candidates only, and detection takes
  those from the measure's own filter responses (:mod:`sogdd.select.x_junctions`).

Every value is a function of the image and the pixel only (fixed summation
order), so bands, crops and the whole image give the same bits.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .._jit import JIT
from ..image.grey import exact_grey
from ..measure.window import reflect1

__all__ = ["newton_steps", "row_groups", "strength_maxima"]


@numba.njit(**JIT)
def _n_at(gxx, gxy, gyy, i, j):  # pragma: no cover - jit
    v = gxy[i, j] * gxy[i, j] - gxx[i, j] * gyy[i, j]
    return v if v > 0.0 else 0.0


@numba.njit(**JIT)
def _maxima(gxx, gxy, gyy, first, last, top, height, t_n, rows, cols, vals):  # pragma: no cover - jit
    """Raster-order pixels of map rows ``first .. last - 1`` above ``t_n`` and not below a neighbour.

    ``N`` is computed where read: almost every pixel fails the threshold at once,
    so the neighbours are read for a few candidates only.
    """
    w = gxx.shape[1]
    k = 0
    for i in range(first, last):
        g = top + i  # image row
        i0 = i - 1 if g > 0 else i
        i1 = i + 1 if g < height - 1 else i
        for j in range(w):
            v = _n_at(gxx, gxy, gyy, i, j)
            if v <= t_n:
                continue
            ok = True
            for a in range(i0, i1 + 1):
                for b in range(max(j - 1, 0), min(j + 1, w - 1) + 1):
                    if _n_at(gxx, gxy, gyy, a, b) > v:
                        ok = False
            if ok:
                rows[k] = g
                cols[k] = j
                vals[k] = v
                k += 1
    return k


def strength_maxima(gxx: np.ndarray, gxy: np.ndarray, gyy: np.ndarray, *, top: int, height: int, first: int,
                    last: int, t_n: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Candidates among map rows ``first .. last - 1``: ``(image rows, cols, N)`` in raster order.

    The maps hold image rows ``top ..`` of an image ``height`` rows high, and must
    include the rows just above and below the tested ones (where those are in the
    image): the 3 x 3 neighbourhood is that of ``cv2.dilate`` with a replicated
    border, that is the in-image neighbours only.
    """
    size = max((last - first) * gxx.shape[1], 0)
    rows, cols, vals = np.empty(size, np.int64), np.empty(size, np.int64), np.empty(size)
    k = _maxima(gxx, gxy, gyy, int(first), int(last), int(top), int(height), float(t_n), rows, cols, vals)
    return rows[:k], cols[:k], vals[:k]


@numba.njit(**JIT)
def _row_sums(img, off, height, width, y0, x, gauss, d1, d2, sums):  # pragma: no cover - jit
    """Row sums at column ``x`` of the ``2 r + 2`` image rows from ``y0 - r`` (reflected): gauss, d1, d2."""
    r = (gauss.shape[0] - 1) // 2
    inside = x - r >= 0 and x + r < width  # no column reflection: plain indices (the same sums)
    for a in range(2 * r + 2):
        line = img[reflect1(y0 + a - r, height) - off]
        vg = 0.0
        v1 = 0.0
        v2 = 0.0
        for b in range(2 * r + 1):
            v = line[x - r + b] if inside else line[reflect1(x + b - r, width)]
            vg += gauss[b] * v
            v1 += d1[b] * v
            v2 += d2[b] * v
        sums[0, a] = vg
        sums[1, a] = v1
        sums[2, a] = v2


@numba.njit(**JIT)
def _column(sums, shift, gauss, d1, d2, out, i):  # pragma: no cover - jit
    """The five derivatives at row ``shift`` (below the first), from one column's row sums, into ``out[:, i]``.

    ``g_xx`` (d2 along x, gauss along y), ``g_xy`` (d1, d1), ``g_yy`` (gauss, d2),
    ``g_x`` (d1, gauss), ``g_y`` (gauss, d1): correlations, as ``cv2.sepFilter2D``'s.
    """
    gxx = 0.0
    gxy = 0.0
    gyy = 0.0
    gx = 0.0
    gy = 0.0
    for a in range(gauss.shape[0]):
        sg = sums[0, a + shift]
        s1 = sums[1, a + shift]
        gxx += gauss[a] * sums[2, a + shift]
        gxy += d1[a] * s1
        gyy += d2[a] * sg
        gx += gauss[a] * s1
        gy += d1[a] * sg
    out[0, i] = gxx
    out[1, i] = gxy
    out[2, i] = gyy
    out[3, i] = gx
    out[4, i] = gy


@numba.njit(**JIT)
def _at(img, off, height, width, x, y, gauss, d1, d2, s0, s1, corners, val):  # pragma: no cover - jit
    """The five derivatives bilinearly interpolated at ``(x, y)`` (edge-clamped) into ``val``."""
    x = min(max(x, 0.0), width - 1.0)
    y = min(max(y, 0.0), height - 1.0)
    x0 = min(int(math.floor(x)), width - 2 if width > 1 else 0)
    y0 = min(int(math.floor(y)), height - 2 if height > 1 else 0)
    x1 = min(x0 + 1, width - 1)
    dy = min(y0 + 1, height - 1) - y0  # 0 on a one-row image
    fx = x - x0
    fy = y - y0
    # the four pixels share their rows: row sums once per column
    _row_sums(img, off, height, width, y0, x0, gauss, d1, d2, s0)
    _row_sums(img, off, height, width, y0, x1, gauss, d1, d2, s1)
    _column(s0, 0, gauss, d1, d2, corners, 0)
    _column(s1, 0, gauss, d1, d2, corners, 1)
    _column(s0, dy, gauss, d1, d2, corners, 2)
    _column(s1, dy, gauss, d1, d2, corners, 3)
    for k in range(5):
        val[k] = (corners[k, 0] * (1 - fx) + corners[k, 1] * fx) * (1 - fy) + (
            corners[k, 2] * (1 - fx) + corners[k, 3] * fx) * fy


@numba.njit(**JIT)
def _readable(off, rows, height, y, r):  # pragma: no cover - jit
    """Whether the image rows a step at ``y`` reads (reflected) are among rows ``off .. off + rows - 1``."""
    yc = min(max(y, 0.0), height - 1.0)
    y0 = min(int(math.floor(yc)), height - 2 if height > 1 else 0)
    for a in range(2 * r + 2):
        ri = reflect1(y0 + a - r, height)
        if ri < off or ri >= off + rows:
            return False
    return True


@numba.njit(**JIT)
def _derivatives(img, off, height, width, xs, ys, gauss, d1, d2, out):  # pragma: no cover - jit
    n = gauss.shape[0] + 1
    s0, s1, corners, val = np.empty((3, n)), np.empty((3, n)), np.empty((5, 4)), np.empty(5)
    for t in range(xs.shape[0]):
        _at(img, off, height, width, xs[t], ys[t], gauss, d1, d2, s0, s1, corners, val)
        for k in range(5):
            out[k, t] = val[k]


@numba.njit(**JIT)
def _newton(img, off, height, width, xs, ys, steps, iterations, gauss, d1, d2):  # pragma: no cover - jit
    r = (gauss.shape[0] - 1) // 2
    n = gauss.shape[0] + 1
    s0, s1, corners, v = np.empty((3, n)), np.empty((3, n)), np.empty((5, 4)), np.empty(5)
    rows = img.shape[0]
    for t in range(xs.shape[0]):
        while steps[t] < iterations and _readable(off, rows, height, ys[t], r):
            _at(img, off, height, width, xs[t], ys[t], gauss, d1, d2, s0, s1, corners, v)
            a, b, c, px, py = v[0], v[1], v[2], v[3], v[4]
            det = a * c - b * b
            dx = -(c * px - b * py) / det
            dy = -(a * py - b * px) / det
            # a singular Hessian is no saddle: the point is sent 9 px away, so that it is refused
            xs[t] += dx if math.isfinite(dx) else 9.0
            ys[t] += dy if math.isfinite(dy) else 9.0
            steps[t] += 1


@numba.njit(**JIT)
def _row_groups(lo, hi, reach, band_rows, ends):  # pragma: no cover - jit
    k = 0
    g0 = 0
    n = lo.shape[0]
    while g0 < n:
        glo = lo[g0]
        ghi = hi[g0]
        g1 = g0 + 1
        while g1 < n and lo[g1] <= ghi + 2 * reach + 1 and hi[g1] < glo + band_rows:
            ghi = max(ghi, hi[g1])
            g1 += 1
        ends[k] = g1
        k += 1
        g0 = g1
    return k


def row_groups(lo: np.ndarray, hi: np.ndarray, reach: int, band_rows: int) -> np.ndarray:
    """Ends of the groups of points, sorted by the first row ``lo`` they read (``hi``: the last).

    A group grows while the next point's rows, widened by ``reach``, overlap its own
    widened rows and span fewer than ``band_rows`` rows; its points then share one
    crop of rows ``min(lo) - reach .. max(hi) + reach``.

    Examples
    --------
    >>> row_groups(np.array([0, 1, 50, 51]), np.array([1, 2, 51, 52]), 3, 100).tolist()
    [2, 4]
    """
    ends = np.empty(len(lo), np.int64)
    k = _row_groups(np.ascontiguousarray(lo, dtype=np.int64), np.ascontiguousarray(hi, dtype=np.int64),
                    int(reach), int(band_rows), ends)
    return ends[:k]


def newton_steps(img: np.ndarray, off: int, height: int, width: int, x: np.ndarray, y: np.ndarray,
                 steps: np.ndarray, iterations: int, gauss: np.ndarray, d1: np.ndarray, d2: np.ndarray) -> None:
    """Newton steps ``delta = -H^{-1} grad`` from each point, in place, until ``steps`` reaches ``iterations``.

    H and grad are ``_derivatives``' (module doc). A point stops early where its
    next step would read an image row that ``img`` (rows ``off ..``) does not
    hold; its ``steps`` then tell how far it got, and another crop continues it
    with the same result (every value is a function of the image and the point).
    ``x``, ``y`` (float64) and ``steps`` (int64) are C-contiguous and updated in place.
    """
    f = [np.ascontiguousarray(k, dtype=np.float64) for k in (gauss, d1, d2)]
    _newton(exact_grey(img), int(off), int(height), int(width), x, y, steps, int(iterations), *f)

