"""Compiled parts of the X-junction stage (:mod:`sogdd.saddles`).

Two things made the stage a third of ``hr``'s time with numpy: five
image-sized derivative maps, and five full passes (strength, square root,
dilation, comparison, ``nonzero``) to find a few thousand candidates among
millions of pixels. Here:

- :func:`strength_maxima` finds the candidates in one pass over the three
  second-derivative maps: ``N = g_xy^2 - g_xx g_yy`` (the saddle strength is
  ``sigma^2 sqrt(max(N, 0))``, monotone in ``N``), and a pixel is a candidate when
  ``N > t_N`` and ``N`` is not below any in-image 8-neighbour;
- :func:`gradient_bilinear` gives ``(g_x, g_y)`` at the Newton iterates from the
  image itself (separable Gaussian-derivative sums at the four pixels the
  bilinear interpolation reads, sharing their row sums), so the two
  first-derivative maps are never filtered; only the candidates ever need them.

Every value is a function of the image and the pixel only (fixed summation
order), so bands, crops and the whole image give the same bits.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ._jit import JIT
from .window import reflect1

__all__ = ["gradient_bilinear", "strength_maxima"]


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
def _row_sums(img, off, height, width, y0, x, gauss, d1, sg, s1):  # pragma: no cover - jit
    """Row sums at column ``x`` of the ``2 r + 2`` image rows from ``y0 - r`` (reflected): gauss and d1."""
    r = (gauss.shape[0] - 1) // 2
    inside = x - r >= 0 and x + r < width  # no column reflection: plain indices (the same sums)
    for a in range(2 * r + 2):
        line = img[reflect1(y0 + a - r, height) - off]
        vg = 0.0
        v1 = 0.0
        for b in range(2 * r + 1):
            v = line[x - r + b] if inside else line[reflect1(x + b - r, width)]
            vg += gauss[b] * v
            v1 += d1[b] * v
        sg[a] = vg
        s1[a] = v1


@numba.njit(**JIT)
def _column(sg, s1, shift, gauss, d1):  # pragma: no cover - jit
    """``(g_x, g_y)`` at the row ``shift`` below the first: d1 along x with gauss along y, and the reverse."""
    gx = 0.0
    gy = 0.0
    for a in range(gauss.shape[0]):
        gx += gauss[a] * s1[a + shift]
        gy += d1[a] * sg[a + shift]
    return gx, gy


@numba.njit(**JIT)
def _gradient_bilinear(img, off, height, width, xs, ys, gauss, d1, gx, gy):  # pragma: no cover - jit
    n = gauss.shape[0] + 1
    sg0, s10, sg1, s11 = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    for t in range(xs.shape[0]):
        x = min(max(xs[t], 0.0), width - 1.0)
        y = min(max(ys[t], 0.0), height - 1.0)
        x0 = min(int(math.floor(x)), width - 2 if width > 1 else 0)
        y0 = min(int(math.floor(y)), height - 2 if height > 1 else 0)
        x1 = min(x0 + 1, width - 1)
        dy = min(y0 + 1, height - 1) - y0  # 0 on a one-row image
        fx = x - x0
        fy = y - y0
        # the four pixels share their rows: row sums once per column (correlation, as cv2.sepFilter2D)
        _row_sums(img, off, height, width, y0, x0, gauss, d1, sg0, s10)
        _row_sums(img, off, height, width, y0, x1, gauss, d1, sg1, s11)
        ax00, ay00 = _column(sg0, s10, 0, gauss, d1)
        ax01, ay01 = _column(sg1, s11, 0, gauss, d1)
        ax10, ay10 = _column(sg0, s10, dy, gauss, d1)
        ax11, ay11 = _column(sg1, s11, dy, gauss, d1)
        gx[t] = (ax00 * (1 - fx) + ax01 * fx) * (1 - fy) + (ax10 * (1 - fx) + ax11 * fx) * fy
        gy[t] = (ay00 * (1 - fx) + ay01 * fx) * (1 - fy) + (ay10 * (1 - fx) + ay11 * fx) * fy


def gradient_bilinear(img: np.ndarray, off: int, height: int, width: int, x: np.ndarray, y: np.ndarray,
                      gauss: np.ndarray, d1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(g_x, g_y)`` of ``G_sigma * I`` bilinearly interpolated at ``(x, y)`` (edge-clamped).

    ``img`` holds image rows ``off ..`` of a ``height x width`` image, enough to
    reach ``radius`` rows beyond the two rows each point reads (reflected at the
    image's edges). The interpolation is that of
    :func:`sogdd.saddles.bilinear_rows`.
    """
    xs = np.ascontiguousarray(x, dtype=np.float64)
    ys = np.ascontiguousarray(y, dtype=np.float64)
    gx, gy = np.empty(len(xs)), np.empty(len(xs))
    f64 = np.float64
    _gradient_bilinear(np.ascontiguousarray(img, dtype=f64), int(off), int(height), int(width), xs, ys,
                       np.ascontiguousarray(gauss, dtype=f64), np.ascontiguousarray(d1, dtype=f64), gx, gy)
    return gx, gy
