"""X-junctions as saddle points, on the grey-level scale of the corners.

Why a second stage
------------------
On an X-junction (a checkerboard's inner corner) the four wedges cancel:
``g_xx = g_yy = 0`` at the junction, so the absolute SOGDD responses there are
``|l_k| = |sin 2 theta_k| |g_xy|``, one pattern over the K orientations, and
the SODDC matrix is nearly of rank one. Upsilon has a *local minimum* on the
junction with a ring of maxima about 2 px around it, and the reported corners
land off the junction. The junction is instead the saddle point of the smoothed
image ``G_sigma * I``: the gradient vanishes and ``det H < 0``.

The stage (Chen and Zhang 2005, "A new sub-pixel detector for X-corners in
camera calibration targets"; a Foerstner-style saddle fit):

1. ``g_xx, g_xy, g_yy`` of ``G_sigma * I`` at the detector's scale (the
   steerable basis);
2. candidates: 3x3 maxima of the saddle strength
   ``s = sigma^2 sqrt(max(0, g_xy^2 - g_xx g_yy))`` (a scale-normalised second
   derivative, linear in the image contrast), found in one compiled pass
   (:func:`strength_maxima`);
3. the saddle point: Newton steps ``delta = -H^{-1} grad`` on bilinearly
   interpolated derivatives, each evaluated from the image at the four pixels
   the step reads (:func:`newton_steps`; only candidates need them). A
   candidate is kept only when the last of four iterates is within one pixel of
   it: an L-corner's apex also has ``det H < 0`` but a large gradient, so its
   step leaves the pixel.

Bands and the measure's responses
---------------------------------
Every step is local. :func:`find_saddles` filters the three maps in bands of
rows (never image-sized float64 maps), and the Newton steps read the image in
crops of rows around groups of iterates; an iterate that would read beyond its
crop continues on another, so the points are the same for any band height: the
derivatives of a crop of full rows are those of the image, bit for bit, on
every row at least ``radius`` rows from a crop edge that is not the image's
(:func:`sogdd.measure.filters.basis_tile` computes each pixel from the same values in
the same order; tested). The measure filters the image with the same basis and
the same function, so detection takes the candidates from the measure's own
responses, tile by tile (:class:`SaddleCandidates`), and filters nothing twice.

Grey-level units: :mod:`sogdd.measure.units` (the saddle strength's unit, :func:`saddle_unit`,
is calibrated the same way on an ideal X-junction).

Compiled parts
--------------
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
  those from the measure's own filter responses (:class:`SaddleCandidates`).
  The derivatives at the four pixels are those of the cell the iterate is in,
  so an iterate that stays in its cell (most steps after the first) reads them
  again; the sums of both columns, and of the four pixels, run side by side
  (each in its own fixed order: the same bits, without waiting on one another).

Every value is a function of the image and the pixel only (fixed summation
order), so bands, crops and the whole image give the same bits.
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache

import numba
import numpy as np

from .._jit import JIT, thread_count
from ..corners import Corners
from ..image.rows import exact_grey, measure_rows
from ..measure.filters import basis_tile, kernel_radius, steerable_basis
from ..measure.soddc import MeasureSpec
from ..measure.units import CALIBRATION_CONTRAST, calibration_images
from ..measure.window import reflect1
from .peaks import inside_allowed
from .refine import one_per_point

__all__ = [
    "SaddleCandidates",
    "X_RING_RADIUS",
    "add_x_junctions",
    "find_saddles",
    "newton_steps",
    "row_groups",
    "strength_maxima",
    "near_any",
    "saddle_search",
    "saddle_unit",
    "strength_floor",
]


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
def _row_sums(img, off, height, width, y0, x0, x1, gauss, d1, d2, s0, s1):  # pragma: no cover - jit
    """Row sums at columns ``x0`` and ``x1`` of the ``2 r + 2`` image rows from ``y0 - r`` (reflected):
    gauss, d1, d2, into ``s0`` and ``s1``.

    Each sum runs over the taps in order, ``s[., a] = sum_b k[b] I(y0 + a - r, x + b - r)``; two rows of
    both columns at a time, twelve sums that do not wait on each other.
    """
    r = (gauss.shape[0] - 1) // 2
    inside = x0 - r >= 0 and x1 + r < width  # no column reflection: plain indices (the same sums)
    rows_inside = y0 - r >= 0 and y0 + r + 1 < height
    for a in range(0, 2 * r + 2, 2):  # an even number of rows
        ra = y0 + a - r - off if rows_inside else reflect1(y0 + a - r, height) - off
        rb = y0 + a + 1 - r - off if rows_inside else reflect1(y0 + a + 1 - r, height) - off
        # sums of (kernel: g gauss, p d1, q d2) (column 0, 1) (row a, a + 1)
        g0a = g0b = g1a = g1b = 0.0
        p0a = p0b = p1a = p1b = 0.0
        q0a = q0b = q1a = q1b = 0.0
        for b in range(2 * r + 1):
            c0 = x0 - r + b if inside else reflect1(x0 + b - r, width)
            c1 = x1 - r + b if inside else reflect1(x1 + b - r, width)
            kg = gauss[b]
            k1 = d1[b]
            k2 = d2[b]
            v0a = img[ra, c0]
            v0b = img[rb, c0]
            v1a = img[ra, c1]
            v1b = img[rb, c1]
            g0a += kg * v0a
            g0b += kg * v0b
            g1a += kg * v1a
            g1b += kg * v1b
            p0a += k1 * v0a
            p0b += k1 * v0b
            p1a += k1 * v1a
            p1b += k1 * v1b
            q0a += k2 * v0a
            q0b += k2 * v0b
            q1a += k2 * v1a
            q1b += k2 * v1b
        s0[0, a] = g0a
        s0[1, a] = p0a
        s0[2, a] = q0a
        s0[0, a + 1] = g0b
        s0[1, a + 1] = p0b
        s0[2, a + 1] = q0b
        s1[0, a] = g1a
        s1[1, a] = p1a
        s1[2, a] = q1a
        s1[0, a + 1] = g1b
        s1[1, a + 1] = p1b
        s1[2, a + 1] = q1b


@numba.njit(**JIT)
def _columns(s0, s1, dy, gauss, d1, d2, out):  # pragma: no cover - jit
    """The five derivatives at the four pixels, from the row sums of their two columns, into ``out`` (5, 4).

    Pixel ``0`` reads ``s0`` from its first row, ``1`` ``s1``, ``2`` and ``3`` the same ``dy`` rows
    below. ``g_xx`` (d2 along x, gauss along y), ``g_xy`` (d1, d1), ``g_yy`` (gauss, d2), ``g_x`` (d1,
    gauss), ``g_y`` (gauss, d1): correlations, as ``cv2.sepFilter2D``'s. Each of the twenty sums runs over
    the rows in order; the four pixels' sums are independent, so they are computed side by side.
    """
    xx0 = 0.0
    xy0 = 0.0
    yy0 = 0.0
    x0 = 0.0
    y0 = 0.0
    xx1 = 0.0
    xy1 = 0.0
    yy1 = 0.0
    x1 = 0.0
    y1 = 0.0
    xx2 = 0.0
    xy2 = 0.0
    yy2 = 0.0
    x2 = 0.0
    y2 = 0.0
    xx3 = 0.0
    xy3 = 0.0
    yy3 = 0.0
    x3 = 0.0
    y3 = 0.0
    for a in range(gauss.shape[0]):
        g = gauss[a]
        e1 = d1[a]
        e2 = d2[a]
        b = a + dy
        xx0 += g * s0[2, a]
        xy0 += e1 * s0[1, a]
        yy0 += e2 * s0[0, a]
        x0 += g * s0[1, a]
        y0 += e1 * s0[0, a]
        xx1 += g * s1[2, a]
        xy1 += e1 * s1[1, a]
        yy1 += e2 * s1[0, a]
        x1 += g * s1[1, a]
        y1 += e1 * s1[0, a]
        xx2 += g * s0[2, b]
        xy2 += e1 * s0[1, b]
        yy2 += e2 * s0[0, b]
        x2 += g * s0[1, b]
        y2 += e1 * s0[0, b]
        xx3 += g * s1[2, b]
        xy3 += e1 * s1[1, b]
        yy3 += e2 * s1[0, b]
        x3 += g * s1[1, b]
        y3 += e1 * s1[0, b]
    out[0, 0] = xx0
    out[1, 0] = xy0
    out[2, 0] = yy0
    out[3, 0] = x0
    out[4, 0] = y0
    out[0, 1] = xx1
    out[1, 1] = xy1
    out[2, 1] = yy1
    out[3, 1] = x1
    out[4, 1] = y1
    out[0, 2] = xx2
    out[1, 2] = xy2
    out[2, 2] = yy2
    out[3, 2] = x2
    out[4, 2] = y2
    out[0, 3] = xx3
    out[1, 3] = xy3
    out[2, 3] = yy3
    out[3, 3] = x3
    out[4, 3] = y3


@numba.njit(**JIT)
def _cell(x, y, height, width):  # pragma: no cover - jit
    """``(x, y)`` edge-clamped and the pixel ``(x0, y0)`` whose cell of four the interpolation reads."""
    x = min(max(x, 0.0), width - 1.0)
    y = min(max(y, 0.0), height - 1.0)
    x0 = min(int(math.floor(x)), width - 2 if width > 1 else 0)
    y0 = min(int(math.floor(y)), height - 2 if height > 1 else 0)
    return x, y, x0, y0


@numba.njit(**JIT)
def _corners(img, off, height, width, x0, y0, gauss, d1, d2, s0, s1, corners):  # pragma: no cover - jit
    """The five derivatives at the four pixels from ``(x0, y0)`` into ``corners`` (5, 4)."""
    x1 = min(x0 + 1, width - 1)
    dy = min(y0 + 1, height - 1) - y0  # 0 on a one-row image
    # the four pixels share their rows: row sums once per column
    _row_sums(img, off, height, width, y0, x0, x1, gauss, d1, d2, s0, s1)
    _columns(s0, s1, dy, gauss, d1, d2, corners)


@numba.njit(**JIT)
def _interpolate(corners, x, y, x0, y0, val):  # pragma: no cover - jit
    """The derivatives at the four pixels of ``corners`` bilinearly interpolated at ``(x, y)`` into ``val``."""
    fx = x - x0
    fy = y - y0
    for k in range(5):
        val[k] = (corners[k, 0] * (1 - fx) + corners[k, 1] * fx) * (1 - fy) + (
            corners[k, 2] * (1 - fx) + corners[k, 3] * fx) * fy


@numba.njit(**JIT)
def _at(img, off, height, width, x, y, gauss, d1, d2, s0, s1, corners, val):  # pragma: no cover - jit
    """The five derivatives bilinearly interpolated at ``(x, y)`` (edge-clamped) into ``val``."""
    x, y, x0, y0 = _cell(x, y, height, width)
    _corners(img, off, height, width, x0, y0, gauss, d1, d2, s0, s1, corners)
    _interpolate(corners, x, y, x0, y0, val)


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
        # the pixel whose cell's derivatives ``corners`` holds: an iterate that stays in the cell (most
        # steps after the first) reads them again, the same values
        cx = -1
        cy = -1
        while steps[t] < iterations:
            x, y, x0, y0 = _cell(xs[t], ys[t], height, width)
            if y0 != cy and not _readable(off, rows, height, ys[t], r):  # the rows of row y0 (read before)
                break
            if x0 != cx or y0 != cy:
                _corners(img, off, height, width, x0, y0, gauss, d1, d2, s0, s1, corners)
                cx = x0
                cy = y0
            _interpolate(corners, x, y, x0, y0, v)
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

#: Upsilon peaks closer than this (px) to a reported X-junction belong to its ring and are dropped
#: (the hr study's choice, docs/hr.md)
X_RING_RADIUS = 2.0
#: pixels per band of :func:`find_saddles` (three float64 maps of a band: 48 MB), and the most rows
#: one crop of Newton iterates spans
BAND_PIXELS = 1 << 21
#: saddle points closer than this (px) are one saddle, reached from tied candidates (a plateau of
#: the strength, e.g. the pixels around a junction on a symmetric JPEG block corner; their iterates
#: meet within ~1e-4 px)
SADDLE_MERGE = 0.1
#: rows of image read beyond those a group of Newton iterates reads (:func:`_converge`): an iterate
#: that moves farther (rare) continues on another crop
SLACK = 16


def strength_floor(sigma2: float, min_strength: float) -> float:
    """The ``N = g_xy^2 - g_xx g_yy`` that candidates must exceed: ``s > min_strength`` in ``N`` units."""
    t = max(float(min_strength), 0.0) / float(sigma2)
    return t * t


def _rows_of(y: np.ndarray, H: int) -> tuple[np.ndarray, np.ndarray]:
    """The two rows (or columns, with the width) a bilinear interpolation reads at ``y``, edge-clamped."""
    yc = np.clip(y, 0.0, H - 1.0)
    y0 = np.minimum(np.floor(yc).astype(np.int64), H - 2 if H > 1 else 0)
    return y0, np.minimum(y0 + 1, H - 1)


def _converge(grey, basis, x: np.ndarray, y: np.ndarray, iterations: int, band_rows: int) -> None:
    """``iterations`` Newton steps from every point (in place), reading the image in crops of rows.

    Each round sorts the points by the rows they read and gives groups of them a crop
    of at most ``band_rows`` rows (plus ``radius + SLACK`` on each side); a group ends
    where the next point's crop would not overlap its own, so a few scattered points
    read a few rows each (:func:`sogdd.select.x_junctions.row_groups`). A point stops where
    its next step would read outside its crop (:func:`sogdd.select.x_junctions.newton_steps`)
    and the next round continues it: every step is a function of the image and the
    point, so its path is the whole image's path. Groups run in threads.
    """
    H, W = grey.shape
    reach = basis.radius + SLACK
    steps = np.zeros(len(x), dtype=np.int64)

    def run(sel: np.ndarray) -> None:
        lo, hi = _rows_of(y[sel], H)
        c0, c1 = max(0, int(lo.min()) - reach), min(H, int(hi.max()) + 1 + reach)
        xs, ys, st = x[sel], y[sel], steps[sel]
        newton_steps(measure_rows(grey, c0, c1), c0, H, W, xs, ys, st, iterations, basis.gauss, basis.d1,
                     basis.d2)
        x[sel], y[sel], steps[sel] = xs, ys, st  # groups are disjoint

    act = np.arange(len(x))
    while len(act):
        lo, hi = _rows_of(y[act], H)
        order = np.argsort(lo, kind="stable")
        ends = row_groups(lo[order], hi[order], reach, band_rows)
        groups = [act[order[g0:g1]] for g0, g1 in zip(np.r_[0, ends[:-1]], ends)]
        n = min(thread_count(), len(groups))
        if n > 1:
            with ThreadPoolExecutor(n) as pool:
                list(pool.map(run, groups))
        else:
            for sel in groups:
                run(sel)
        act = act[steps[act] < iterations]


def _fit(grey, basis, rows: np.ndarray, cols: np.ndarray, n: np.ndarray, iterations: int,
         band_rows: int) -> tuple[np.ndarray, np.ndarray]:
    """Saddle points and strengths ``s`` from candidates in raster order (module doc, step 3)."""
    x0, y0 = cols.astype(np.float64), rows.astype(np.float64)
    x, y = x0.copy(), y0.copy()
    _converge(grey, basis, x, y, int(iterations), band_rows)
    ok = (np.abs(x - x0) <= 1.0) & (np.abs(y - y0) <= 1.0)
    xy, strength = np.stack([x[ok], y[ok]], axis=1), basis.sigma2 * np.sqrt(n[ok])
    keep = one_per_point(xy, strength, SADDLE_MERGE)  # tied candidates converge to one saddle
    return xy[keep], strength[keep]


def _band_rows(W: int, band_rows: int | None) -> int:
    return max(1, int(band_rows)) if band_rows is not None else max(64, -(-BAND_PIXELS // max(W, 1)))


def find_saddles(grey, sigma2: float, radius: int | None = None, *, iterations: int = 4,
                 min_strength: float = 0.0, band_rows: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Saddle points of the smoothed image: ``(xy (N, 2), strength (N,))``, strength ``s`` (module doc).

    Candidates with ``s <= min_strength`` are not fitted (a threshold, applied
    early). The derivative maps are filtered in bands of ``band_rows`` rows
    (default: about :data:`BAND_PIXELS` pixels, at least 64 rows), and the Newton
    steps read the image in crops, with the same result for any band height
    (module doc); ``grey`` may be a :class:`sogdd.image.rows.GreyRows`.

    Examples
    --------
    >>> from sogdd.synthetic import Polygon, render_polygons
    >>> q = np.array([[20.3, 20.6], [60, 20.6], [60, 60], [20.3, 60]])
    >>> img = render_polygons((41, 41), [Polygon(q, 200.0), Polygon(2 * q[0] - q, 200.0)], background=50.0)
    >>> xy, s = find_saddles(img, 1.2)
    >>> np.round(xy[np.argmax(s)], 1).tolist()  # within 0.02 px of the junction
    [20.3, 20.6]
    """
    r = kernel_radius(sigma2) if radius is None else int(radius)
    H, W = grey.shape
    rows_per_band = _band_rows(W, band_rows)
    t_n = strength_floor(sigma2, min_strength)
    basis = steerable_basis(sigma2, r)
    parts = []
    for a in range(0, H, rows_per_band):
        c = min(H, a + rows_per_band)
        ma, mb = max(0, a - 1), min(H, c + 1)  # the rows whose strength the maxima of rows a .. c - 1 read
        c0, c1 = max(0, ma - r), min(H, mb + r)  # a map row at least r rows inside the crop is the image's
        g = basis_tile(measure_rows(grey, c0, c1), ma - c0, mb - c0, 0, basis, reflect_image=False)
        parts.append(strength_maxima(g[0], g[1], g[2], top=ma, height=H, first=a - ma, last=c - ma, t_n=t_n))
    rows, cols, n = (np.concatenate([q[i] for q in parts]) for i in range(3))
    return _fit(grey, basis, rows, cols, n, iterations, rows_per_band)


class SaddleCandidates:
    """The X-junction stage fed by the measure: candidates from its own filter responses.

    The measure filters the image with the same steerable basis, and
    :func:`sogdd.measure.filters.basis_tile` gives every in-image response the same bits
    whatever the tile, so the 3 x 3 strength maxima found on the measure's tiles
    are :func:`find_saddles`' candidates, and :meth:`result` is
    :func:`saddle_search`'s result, without filtering the image a second time
    (about a fifth of ``hr``'s work on photos). Call the object with the tiles'
    responses (``on_planes`` of :func:`sogdd.select.bands.stream_peaks`): ``(top, lo,
    hi, planes)``, ``planes`` of image rows ``top ..`` and columns ``-M .. W + M - 1``
    (a margin ``M``), candidates taken on rows ``lo .. hi - 1``; tiles may come in
    any order and from several threads.

    Examples
    --------
    >>> import sogdd
    >>> from sogdd.select.bands import stream_peaks
    >>> from sogdd.synthetic import Polygon, render_polygons
    >>> spec = sogdd.resolve_params("hr").measure_spec()
    >>> q = np.array([[20.3, 20.6], [60, 20.6], [60, 60], [20.3, 60]])
    >>> img = render_polygons((41, 41), [Polygon(q, 200.0), Polygon(2 * q[0] - q, 200.0)], background=50.0)
    >>> found = SaddleCandidates(img.shape, spec, 20.0)
    >>> _ = stream_peaks(img, spec, threshold=1e300, floor=1e300, band_rows=16, on_planes=found)
    >>> xy, s = found.result(img)
    >>> np.round(xy, 1).tolist(), bool(np.array_equal(xy, saddle_search(img, spec, 20.0)[0]))
    ([[20.3, 20.6]], True)
    """

    def __init__(self, shape: tuple[int, int], spec: MeasureSpec, threshold: float | None) -> None:
        if spec.zero_mean:
            raise ValueError("zero-mean kernels are not the saddle stage's derivatives")
        self.shape = tuple(shape)
        self.spec = spec
        self.t_n = strength_floor(spec.sigma2, _raw_min(spec, threshold))
        self.parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def __call__(self, top: int, lo: int, hi: int, planes: np.ndarray) -> None:
        if lo >= hi:
            return
        H, W = self.shape
        M = (planes.shape[2] - W) // 2
        g = planes[:, :, M : M + W]
        self.parts.append(strength_maxima(g[0], g[1], g[2], top=top, height=H, first=lo - top, last=hi - top,
                                          t_n=self.t_n))  # list.append: safe from the tiles' threads

    def result(self, grey) -> tuple[np.ndarray, np.ndarray]:
        """:func:`saddle_search`'s ``(xy, strength in grey levels)`` for the image the tiles came from."""
        basis = steerable_basis(self.spec.sigma2, self.spec.radius)
        rows, cols, n = (np.concatenate([np.zeros(0, dt)] + [q[i] for q in self.parts])
                         for i, dt in enumerate((np.int64, np.int64, np.float64)))
        order = np.lexsort((cols, rows))  # raster order, as find_saddles'
        xy, s = _fit(grey, basis, rows[order], cols[order], n[order], 4, _band_rows(self.shape[1], None))
        return xy, CALIBRATION_CONTRAST * s / saddle_unit(self.spec.sigma2, self.spec.radius)


@lru_cache(maxsize=32)
def saddle_unit(sigma2: float, radius: int) -> float:
    """Peak saddle strength ``s`` of an ideal X-junction of contrast 100."""
    _, X = calibration_images()
    _, s = find_saddles(X, sigma2, radius)
    return float(s.max())


def near_any(xy: np.ndarray, centres: np.ndarray, radius: float) -> np.ndarray:
    """Mask of the points of ``xy`` within ``radius`` of some point of ``centres``."""
    if len(xy) == 0 or len(centres) == 0:
        return np.zeros(len(xy), dtype=bool)
    from scipy.spatial import cKDTree

    d, _ = cKDTree(centres).query(xy, k=1, distance_upper_bound=radius + 1e-9)
    return np.isfinite(d) & (d <= radius)


def _raw_min(spec: MeasureSpec, threshold: float | None) -> float:
    """A grey-level saddle threshold in units of ``s``."""
    unit = saddle_unit(spec.sigma2, spec.radius)
    return 0.0 if threshold is None else threshold * unit / CALIBRATION_CONTRAST


def saddle_search(grey, spec: MeasureSpec, threshold: float | None) -> tuple[np.ndarray, np.ndarray]:
    """The saddles :func:`add_x_junctions` starts from: ``(xy, strength in grey levels)``.

    Detection gets the same from the measure's responses (:class:`SaddleCandidates`).
    """
    xy, s = find_saddles(grey, spec.sigma2, spec.radius, min_strength=_raw_min(spec, threshold))
    return xy, CALIBRATION_CONTRAST * s / saddle_unit(spec.sigma2, spec.radius)


def add_x_junctions(corners, grey, spec: MeasureSpec, *, threshold: float | None, rho: float, size: float,
                    border: int = 0, mask: np.ndarray | None = None,
                    found: tuple[np.ndarray, np.ndarray] | None = None):
    """Replace the ring of Upsilon peaks around each X-junction by the junction's saddle point.

    ``corners`` carry grey-level strengths (:func:`grey_strength`). Saddles of
    strength ``>= threshold`` (grey levels, :func:`saddle_unit` scale) are added;
    corners within ``rho`` px of one are dropped. Returns ``(Corners, is_x)``, strongest first,
    ``is_x`` marking the X-junctions. ``grey``: an array or a :class:`sogdd.image.rows.GreyRows`
    (:func:`find_saddles` reads it in bands). ``found``: :func:`saddle_search`'s result for
    this ``grey``, ``spec`` and ``threshold``, if already computed.
    """
    xy, s = saddle_search(grey, spec, threshold) if found is None else found
    keep = inside_allowed(xy, mask, border, grey.shape)
    if threshold is not None:
        keep &= s >= threshold
    xy, s = xy[keep], s[keep]
    c = corners.subset(~near_any(corners.xy, xy, rho))
    out = Corners.concatenate([c, Corners(xy, s, np.full(len(s), float(size)))])
    order = np.argsort(-out.response, kind="stable")
    is_x = np.r_[np.zeros(len(c), bool), np.ones(len(s), bool)][order]
    return out.subset(order), is_x
