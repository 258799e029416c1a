"""From a response map to points: thresholds, non-maximum suppression, top-k,
mask and border exclusion (sub-pixel refinement: :mod:`sogdd.select.refine`).

Functions take a float response map and return arrays; validation of user
parameters happens in :mod:`sogdd.detector`.

The compiled scan
-----------------
Compiled non-maximum suppression where few pixels pass: the local maxima above a threshold.

A pixel is kept when its value ``v`` is strictly above the threshold and no
pixel of its ``(2r+1)^2`` square (clipped to the map) exceeds it: the points of
``(response > thr) & local_maxima(response, r)`` (:func:`local_maxima`),
in raster order. :func:`maxima_scan_sparse` looks at the neighbours of the pixels
above the threshold only. Measured on 1024 x 2048 crops of the ``paper`` preset's
map (one thread, ms/MP, scan / OpenCV dilation and ``np.nonzero``): 0.6 / 3.5 with
0.3 % of the pixels above (fountain), 2.1 / 3.4 at 7 % (the dense mosaic), 4.3 / 3.5
at 18 %, 19 / 3.7 at 100 %; :func:`count_above` (stopping at a limit) picks the scan.
(A compiled ring of row maxima measured 10 ms/MP whatever passed: no better.)
"""

from __future__ import annotations

import cv2
import numba
import numpy as np

from .._jit import JIT  # importing sogdd._jit keys numba's on-disk cache before the decorators below run

#: maxima_above examines only the pixels above the threshold while at most 1 in this many pass
_SCAN_FRACTION = 10

__all__ = [
    "break_ties",
    "count_above",
    "maxima_scan_sparse",
    "inside_allowed",
    "keep_ranked",
    "rank_peaks",
    "local_maxima",
    "maxima_above",
    "resolve_threshold",
    "select_peaks",
    "valid_area",
]


def local_maxima(response: np.ndarray, radius: int = 1) -> np.ndarray:
    """Boolean map of pixels equal to the maximum of their ``(2r+1)^2`` square.

    Plateaus keep every pixel that attains the maximum (as a 3x3 maximum filter
    with equality does); ``max_corners`` and thresholds then decide.
    """
    size = 2 * int(radius) + 1
    resp = np.ascontiguousarray(response, dtype=np.float64)
    # dilate's default border (-inf-like) never raises a maximum
    dil = cv2.dilate(resp, np.ones((size, size), np.uint8))
    return resp >= dil


def valid_area(shape: tuple[int, int], border: int = 0, mask: np.ndarray | None = None) -> np.ndarray:
    """Pixels allowed to hold a corner: inside ``mask`` and ``border`` px from the edge."""
    h, w = shape
    valid = np.zeros((h, w), dtype=bool)
    if 2 * border < h and 2 * border < w:
        valid[border : h - border, border : w - border] = True
    if mask is not None:
        valid &= mask
    return valid


def resolve_threshold(
    response: np.ndarray,
    valid: np.ndarray | None,
    *,
    threshold: float | None = None,
    threshold_rel: float | None = None,
    quantile: float | None = None,
) -> float:
    """The effective threshold: the largest of the absolute, relative and quantile ones.

    ``threshold_rel`` is a fraction of the largest response in the valid area;
    ``quantile`` is taken over the *positive* responses in the valid area (the
    authors' rule). With none given, every local maximum above 0 passes.
    """
    levels = [] if threshold is None else [float(threshold)]
    if threshold_rel is not None or quantile is not None:
        # only these need the values themselves: one compiled pass, no image-sized masks
        use = valid is not None
        vmask = np.ascontiguousarray(valid, dtype=np.bool_) if use else np.ones((1, 1), np.bool_)
        resp = np.ascontiguousarray(response, dtype=np.float64)
        nfin, vmax, pos = _valid_values(resp, vmask, use, quantile is not None)
        if threshold_rel is not None and nfin:
            levels.append(float(threshold_rel) * vmax)
        if quantile is not None and pos.size:
            # numpy's quantile selects (introselect), it does not sort; pos is ours to overwrite
            levels.append(float(np.quantile(pos, quantile, overwrite_input=True)))
    return max(levels) if levels else 0.0


@numba.njit(cache=True, nogil=True)
def _valid_values(response, valid, use_valid, want_pos):  # pragma: no cover - jit
    """Count and maximum of the finite responses in the valid area, and its positive ones."""
    H, W = response.shape
    pos = np.empty(H * W if want_pos else 0)
    n = 0
    nfin = 0
    vmax = -np.inf
    for y in range(H):
        row = response[y]
        for x in range(W):
            if use_valid and not valid[y, x]:
                continue
            v = row[x]
            if not np.isfinite(v):
                continue
            nfin += 1
            if v > vmax:
                vmax = v
            if want_pos and v > 0:
                pos[n] = v
                n += 1
    return nfin, vmax, pos[:n]


def maxima_above(response: np.ndarray, threshold: float, radius: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns of the local maxima (:func:`local_maxima`) strictly above ``threshold``, raster order.

    Where few pixels pass (up to 1 in 10: a detector's threshold) only they are
    examined (:func:`maxima_scan_sparse`); where many do, one dilation of the whole map is
    cheaper. Both give the same points.
    """
    resp = np.ascontiguousarray(response, dtype=np.float64)
    limit = resp.size // _SCAN_FRACTION + 1
    if count_above(resp, float(threshold), limit) < limit:
        return maxima_scan_sparse(resp, float(threshold), int(radius))
    # in bands of rows (with the radius as overlap), so no image-sized float copy is made
    H, r, band = response.shape[0], int(radius), 512
    rows, cols = [], []
    for r0 in range(0, H, band):
        r1 = min(H, r0 + band)
        a, b = max(0, r0 - r), min(H, r1 + r)
        blk = response[a:b]
        rr, cc = np.nonzero(((blk > threshold) & local_maxima(blk, r))[r0 - a : r1 - a])
        rows.append(rr + r0)
        cols.append(cc)
    return np.concatenate(rows).astype(np.int64), np.concatenate(cols).astype(np.int64)


def select_peaks(
    response: np.ndarray,
    *,
    threshold: float | None = None,
    threshold_rel: float | None = None,
    quantile: float | None = None,
    nms_radius: int = 1,
    border: int = 0,
    mask: np.ndarray | None = None,
    max_corners: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns of the selected peaks, strongest first.

    A peak is a local maximum (``nms_radius``) strictly above the effective
    threshold, inside the valid area; with ``border`` the maxima are those of the
    valid area alone (what lies beyond the border never suppresses a peak, as in
    the authors' code). Ties in strength keep raster order.

    Examples
    --------
    >>> r = np.zeros((7, 9))
    >>> r[2, 3], r[2, 4], r[5, 7] = 5.0, 4.0, 3.0
    >>> rows, cols = select_peaks(r, threshold=1.0)
    >>> rows.tolist(), cols.tolist()  # (2, 4) is not a local maximum
    ([2, 5], [3, 7])
    >>> select_peaks(r, threshold=1.0, border=2)[0].tolist()
    [2]
    """
    resp = np.asarray(response)
    if resp.dtype not in (np.float32, np.float64):
        resp = resp.astype(np.float64)
    resp = np.ascontiguousarray(resp)
    if threshold_rel is not None or quantile is not None:
        valid = valid_area(resp.shape, border, mask)
    else:
        valid = None  # the absolute threshold needs no map of the valid area
    thr = resolve_threshold(
        resp, valid, threshold=threshold, threshold_rel=threshold_rel, quantile=quantile
    )
    h, w = resp.shape
    b = int(border)
    if b and 2 * b < h and 2 * b < w:
        # The excluded border is outside the image for the maxima too: a peak on the last valid
        # row or column is not suppressed by a larger pixel beyond it (the authors' 3x3 maximum
        # filter runs on the valid area alone).
        rows, cols = maxima_above(np.ascontiguousarray(resp[b : h - b, b : w - b]), float(thr), int(nms_radius))
        rows, cols = rows + b, cols + b
    else:
        rows, cols = maxima_above(resp, float(thr), int(nms_radius))
    sel = keep_ranked(rows, cols, resp[rows, cols], (h, w), border, mask, nms_radius, max_corners)
    return rows[sel], cols[sel]


def keep_ranked(rows: np.ndarray, cols: np.ndarray, values: np.ndarray, shape: tuple[int, int], border: int,
                mask: np.ndarray | None, radius: int, max_corners: int | None = None) -> np.ndarray:
    """Indices of the local maxima to keep, strongest first: inside border and mask, ranked, top-k.

    The maxima must come in raster order (:func:`rank_peaks`). What :func:`select_peaks`
    does after finding them, and what the device path does with the maxima it finds.

    Examples
    --------
    >>> rows, cols = np.array([0, 1, 3]), np.array([1, 1, 3])
    >>> keep_ranked(rows, cols, np.array([5.0, 4.0, 6.0]), (5, 5), 1, None, 1).tolist()
    [2, 1]
    """
    h, w = shape
    inside = (rows >= border) & (rows < h - border) & (cols >= border) & (cols < w - border)
    if mask is not None:
        inside &= np.asarray(mask, dtype=bool)[rows, cols]
    idx = np.flatnonzero(inside)
    return idx[rank_peaks(values[idx], rows[idx], cols[idx], radius, max_corners)]


def rank_peaks(values: np.ndarray, rows: np.ndarray, cols: np.ndarray, radius: int,
               max_corners: int | None = None) -> np.ndarray:
    """Indices of the peaks to keep, strongest first: rank, break ties within ``radius``, top-k.

    The candidates must come in raster order, so that equal values keep it.

    Examples
    --------
    >>> rank_peaks(np.array([1.0, 3.0, 3.0]), np.array([0, 0, 0]), np.array([0, 5, 6]), 1).tolist()
    [1, 0]
    """
    order = np.argsort(-np.asarray(values), kind="stable")
    order = order[break_ties(rows[order], cols[order], radius)]
    return order if max_corners is None else order[: int(max_corners)]


def inside_allowed(xy: np.ndarray, mask: np.ndarray | None, border: int, shape: tuple[int, int]) -> np.ndarray:
    """Points whose nearest pixel is inside the mask and ``border`` px from the edge.

    Sub-pixel refinement (up to 3 px) and the pyramid's coarser mask can move a
    peak found inside the allowed area out of it; such points are dropped, not clamped.

    Examples
    --------
    >>> inside_allowed(np.array([[1.4, 5.0], [0.4, 5.0]]), None, 1, (10, 10)).tolist()
    [True, False]
    """
    h, w = shape
    col, row = np.rint(xy[:, 0]).astype(np.int64), np.rint(xy[:, 1]).astype(np.int64)
    ok = (col >= border) & (col <= w - 1 - border) & (row >= border) & (row <= h - 1 - border)
    if mask is not None:
        ok[ok] = mask[row[ok], col[ok]]
    return ok


def break_ties(rows: np.ndarray, cols: np.ndarray, radius: int) -> np.ndarray:
    """Keep one point per plateau: of candidates within ``radius`` (Chebyshev), the first.

    Two local maxima closer than the NMS radius must have equal values, so this
    only decides ties, and it keeps the guarantee that no two corners lie
    within ``radius`` of each other: a candidate is dropped exactly when an
    earlier *kept* candidate lies within ``radius`` (strongest first, raster
    order among equals).
    """
    keep = np.ones(len(rows), dtype=bool)
    if len(rows) < 2:
        return keep
    r = int(radius)
    r0, c0 = int(rows.min()) - r, int(cols.min()) - r
    blocked = np.zeros((int(rows.max()) - r0 + r + 1, int(cols.max()) - c0 + r + 1), np.uint8)
    _greedy_ties(np.asarray(rows, np.int64) - r0, np.asarray(cols, np.int64) - c0, r, blocked, keep)
    return keep


@numba.njit(cache=True, nogil=True)
def _greedy_ties(rows, cols, r, blocked, keep):  # pragma: no cover - jit
    """Greedy pass in candidate order: a kept point blocks its (2r+1)^2 square for later ones."""
    for i in range(rows.shape[0]):
        y, x = rows[i], cols[i]
        if blocked[y, x]:
            keep[i] = False
            continue
        for yy in range(y - r, y + r + 1):
            for xx in range(x - r, x + r + 1):
                blocked[yy, xx] = 1



@numba.njit(**JIT)
def _append(rows, cols, n, y, x):  # pragma: no cover - jit
    if n == rows.shape[0]:
        rows = np.concatenate((rows, np.empty(n, np.int64)))
        cols = np.concatenate((cols, np.empty(n, np.int64)))
    rows[n] = y
    cols[n] = x
    return rows, cols


@numba.njit(**JIT)
def maxima_scan_sparse(response, thr, radius):  # pragma: no cover - jit
    """Rows and columns of the maxima (module doc), looking around the pixels above ``thr`` only."""
    H, W = response.shape
    rows = np.empty(64, np.int64)
    cols = np.empty(64, np.int64)
    n = np.int64(0)  # not 0: a literal compiles a second, Literal[int](0) specialisation of _append
    for y in range(H):
        row = response[y]
        for x in range(W):
            v = row[x]
            if not v > thr:
                continue
            peak = True
            for yy in range(max(0, y - radius), min(H, y + radius + 1)):
                nb = response[yy]
                for xx in range(max(0, x - radius), min(W, x + radius + 1)):
                    if nb[xx] > v:
                        peak = False
                        break
                if not peak:
                    break
            if peak:
                rows, cols = _append(rows, cols, n, y, x)
                n += 1
    return rows[:n], cols[:n]


@numba.njit(**JIT)
def count_above(response, thr, limit):  # pragma: no cover - jit
    """How many pixels are strictly above ``thr``, counting no further than ``limit``."""
    n = 0
    for y in range(response.shape[0]):
        row = response[y]
        for x in range(row.shape[0]):
            n += row[x] > thr
        if n >= limit:
            return limit
    return n
