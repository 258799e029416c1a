"""From a response map to points: thresholds, non-maximum suppression, top-k,
mask, border exclusion and sub-pixel refinement.

Functions take a float response map and return arrays; validation of user
parameters happens in :mod:`sogdd.detector`.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import cv2
import numba
import numpy as np
from scipy.spatial import cKDTree

from ._nms import count_above, maxima_scan_sparse
from .response import thread_count

#: points per thread below which gradient refinement stays on one thread
_REFINE_CHUNK = 512
#: maxima_above examines only the pixels above the threshold while at most 1 in this many pass
_SCAN_FRACTION = 10

__all__ = [
    "break_ties",
    "inside_allowed",
    "rank_peaks",
    "local_maxima",
    "maxima_above",
    "one_per_point",
    "refine_gradient",
    "refine_quadratic",
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
    examined (:mod:`sogdd._nms`); where many do, one dilation of the whole map is
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
    inside = (rows >= border) & (rows < h - border) & (cols >= border) & (cols < w - border)
    if mask is not None:
        inside &= np.asarray(mask, dtype=bool)[rows, cols]
    rows, cols = rows[inside], cols[inside]
    sel = rank_peaks(resp[rows, cols], rows, cols, nms_radius, max_corners)
    return rows[sel], cols[sel]


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
    # sogdd._banded_relative) gives NaN here and the fallback below; no warning for it
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
