"""Detection at a relative or quantile threshold in bands of rows, in one pass, without image-sized maps.

The thresholds of ``threshold_rel`` (a fraction of the largest Upsilon in the
valid area) and ``quantile`` (a quantile of its positive values, the authors'
rule) are known only once the whole image is, and the authors' measure clamps
``det`` in ``[-eps max|det|, 0)`` to 0 with ``max|det|`` over the whole image.
One pass over bands (crops with halo, as in :mod:`sogdd.select.banded`) still gives
the full map's result bit for bit:

- the positive values of Upsilon do not depend on the clamp (it only turns tiny
  negative values into 0), nor does a peak above a threshold >= 0 (no value
  <= 0 exceeds it) or its value; only the 3 x 3 patch of the quadratic
  refinement can, so with the authors' measure that patch is kept as raw
  det and trace and measured once ``max|det|`` is known;
- the quantile is exact from :class:`sogdd.select.stream_quantile.StreamQuantile`,
  which keeps about ``(1 - q)`` of the values; the maximum is a running one;
- each band keeps its local maxima above a lower bound of the final threshold
  (absolute threshold, ``threshold_rel`` times the running maximum, the
  quantile's running bound); at the end those above the threshold are ranked
  as :func:`sogdd.select.peaks.select_peaks` ranks them.

Where the final threshold could be negative (no positive value in the valid
area and ``threshold_rel``, or a negative absolute threshold) the pass cannot
know it, and :func:`peaks_relative_in_bands` returns None: the caller then uses
the full map.
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import JIT
from ..image.rows import measure_rows
from ..measure.soddc import MeasureSpec, abs_max, authors_apply, authors_limit, soddc_measure
from .peaks import maxima_above, rank_peaks
from .stream_quantile import StreamQuantile
from .subpixel import quadratic_offsets, refine_quadratic

__all__ = ["BAND_ROWS", "peaks_relative_in_bands", "positives"]

BAND_ROWS = 512  # three band-sized maps with the authors' measure (det, trace, Upsilon)
_SAFE = 1.0 - 1e-9  # candidates kept a little below the bound, so a rounding in the lerp cannot matter


def _empty() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    e = np.zeros(0, np.int64)
    return e, e, np.zeros(0), np.zeros((0, 2))


def _valid_per_row(H: int, W: int, b: int, mask: np.ndarray | None) -> tuple[np.ndarray, tuple[int, ...]]:
    """Pixels of the valid area (:func:`~sogdd.select.peaks.valid_area`) per row; its box before the mask."""
    box = (b, H - b, b, W - b) if 2 * b < H and 2 * b < W else (0, 0, 0, 0)
    r0, r1, c0, c1 = box
    per_row = np.zeros(H, np.int64)
    per_row[r0:r1] = c1 - c0 if mask is None else np.count_nonzero(mask[r0:r1, c0:c1], axis=1)
    return per_row, box


def peaks_relative_in_bands(
    grey,
    spec: MeasureSpec,
    *,
    threshold: float | None = None,
    threshold_rel: float | None = None,
    quantile: float | None = None,
    floor: float | None = None,
    nms_radius: int = 1,
    border: int = 0,
    mask: np.ndarray | None = None,
    max_corners: int | None = None,
    quadratic: bool = False,
    band_rows: int = BAND_ROWS,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """Rows, columns, values and quadratic offsets of the peaks, as on the full map; None if it cannot tell.

    The points are those of ``select_peaks(soddc_measure(grey, spec), threshold=...,
    threshold_rel=..., quantile=..., nms_radius=..., border=..., mask=...,
    max_corners=...)``, strongest first, their values those of the map, and the
    offsets (zeros unless ``quadratic``) those of
    :func:`sogdd.select.subpixel.refine_quadratic` on it. ``floor`` (a pruning floor at
    or below the final threshold, paper measure, no quantile) is passed to
    :func:`sogdd.measure.soddc.soddc_measure`. ``grey`` is an (H, W) array or
    anything whose row crops are (:class:`sogdd.image.rows.GreyRows`).
    """
    H, W = grey.shape
    mk = None if mask is None else np.asarray(mask, dtype=bool)
    per_row, (vr0, vr1, vc0, vc1) = _valid_per_row(H, W, int(border), mk)
    if not per_row.any():  # no pixel may hold a peak, whatever the threshold
        return _empty()
    sq = None if quantile is None else StreamQuantile(quantile, int(per_row.sum()))
    vmax = -np.inf  # the largest positive value in the valid area
    big, nan = 0.0, False  # max|det| over the image, whether a det is NaN (authors)
    m = spec.radius + spec.window_radius + 2
    halo = max(int(nms_radius), 1)
    cand: list[tuple[np.ndarray, ...]] = []
    for a in range(0, H, int(band_rows)):
        c = min(H, a + int(band_rows))
        lo, hi = max(0, a - halo), min(H, c + halo)  # rows whose values are used
        y0, y1 = max(0, lo - m), min(H, hi + m)
        det = tr = None
        if spec.authors_measure:
            det, tr = soddc_measure(measure_rows(grey, y0, y1), spec, raw=True)
            det, tr = det[lo - y0 : hi - y0], tr[lo - y0 : hi - y0]
            bb, bn = abs_max(det[a - lo : c - lo].reshape(-1))
            big, nan = max(big, bb), nan or bn
            resp = authors_apply(det, tr, np.nan)  # NaN: no clamp; values > 0 are the same either way
        else:
            resp = soddc_measure(measure_rows(grey, y0, y1), spec, floor=floor)[lo - y0 : hi - y0]
        s0, s1 = max(a, vr0), min(c, vr1)  # the band's rows of the valid area
        vals, below, bmax = positives(resp[s0 - lo : s1 - lo, vc0:vc1],
                                      None if mk is None else mk[s0:s1, vc0:vc1],
                                      np.inf if sq is None else sq.floor)
        vmax = max(vmax, bmax)
        if sq is not None and s1 > s0:
            sq.add(vals, slots=int(per_row[s0:s1].sum()), dropped=below)
        del vals
        part = _band_peaks(resp, det, tr, lo, a, c, _bound(threshold, threshold_rel, vmax, sq), nms_radius,
                           border, mk, quadratic, (H, W))
        del resp, det, tr
        cand = _prune(cand + [part], _bound(threshold, threshold_rel, vmax, sq))
    if threshold_rel is not None and vmax == -np.inf:
        return None  # the largest value is <= 0 and may depend on the clamp
    # the final threshold, as sogdd.select.peaks.resolve_threshold gives it on the full map
    levels = [] if threshold is None else [float(threshold)]
    levels += [] if threshold_rel is None else [float(threshold_rel) * vmax]
    levels += [sq.result()] if sq is not None and sq.count else []
    thr = max(levels) if levels else 0.0
    if thr < 0:
        return None
    cand = _prune(cand, thr)
    if not cand:
        return _empty()
    lim = authors_limit(big, nan) if spec.authors_measure else None
    return _rank(cand, H, W, lim, int(nms_radius), quadratic, max_corners)


@numba.njit(**JIT)
def _split_positives(sub, mask, use_mask, floor, out):  # pragma: no cover - jit
    k = 0
    below = 0
    vmax = -np.inf
    for i in range(sub.shape[0]):
        for j in range(sub.shape[1]):
            v = sub[i, j]
            if v > 0.0 and v < np.inf and (not use_mask or mask[i, j]):
                vmax = max(vmax, v)
                if v >= floor:
                    out[k] = v
                    k += 1
                else:
                    below += 1
    return k, below, vmax


def positives(sub: np.ndarray, mask: np.ndarray | None,
              floor: float = -np.inf) -> tuple[np.ndarray, int, float]:
    """The positive finite values of ``sub`` (where ``mask``), as resolve_threshold collects them, in one pass.

    Returns those at or above ``floor`` (raster order), how many were below it,
    and the largest of all (``-inf`` if none).

    Examples
    --------
    >>> sub = np.array([[0.5, -1.0, np.nan], [2.0, np.inf, 3.0]])
    >>> vals, below, top = positives(sub, None, floor=1.0)
    >>> vals.tolist(), below, top
    ([2.0, 3.0], 1, 3.0)
    """
    m = np.zeros((1, 1), np.bool_) if mask is None else np.asarray(mask, dtype=np.bool_)
    out = np.empty(sub.size)
    k, below, vmax = _split_positives(sub, m, mask is not None, float(floor), out)
    return out[:k], int(below), float(vmax)


def _band_peaks(resp, det, tr, lo: int, a: int, c: int, bound: float, nms_radius: int, border: int,
                mask: np.ndarray | None, quadratic: bool, shape: tuple[int, int]) -> tuple[np.ndarray, ...]:
    """Local maxima above ``bound`` on the band's own rows ``a:c`` (map rows from ``lo``), as select_peaks'.

    Returns rows, columns, values and what the offsets need: nothing, the
    offsets, or (authors' measure) the raw det and trace of each 3 x 3 patch.
    """
    H, W = shape
    rad, b = int(nms_radius), int(border)
    inner = bool(b) and 2 * b < H and 2 * b < W  # select_peaks: maxima of the valid area alone
    rlo, rhi, clo, chi = (b, H - b, b, W - b) if inner else (0, H, 0, W)
    n0, n1 = max(a - rad, rlo), min(c + rad, rhi)
    rr = cc = np.zeros(0, np.int64)
    if n1 > n0 and chi > clo:
        rr, cc = maxima_above(np.ascontiguousarray(resp[n0 - lo : n1 - lo, clo:chi]), bound, rad)
        rr, cc = rr + n0, cc + clo
    own = (rr >= a) & (rr < c) & (rr >= b) & (rr < H - b) & (cc >= b) & (cc < W - b)
    rr, cc = rr[own], cc[own]
    if mask is not None:
        ok = mask[rr, cc]
        rr, cc = rr[ok], cc[ok]
    part = (rr, cc, resp[rr - lo, cc])
    if not quadratic:
        return part
    if det is None:
        return part + (refine_quadratic(resp, rr - lo, cc),)
    # the authors' measure: the patch's values below 0 wait for the clamp, so keep det and trace
    dy, dx = np.mgrid[-1:2, -1:2]
    iy = np.clip(rr, 1, H - 2)[:, None, None] - lo + dy
    ix = np.clip(cc, 1, W - 2)[:, None, None] + dx
    return part + (det[iy, ix], tr[iy, ix])


def _rank(cand: list, H: int, W: int, lim: float | None, rad: int, quadratic: bool, max_corners: int | None):
    """Candidates ranked as select_peaks ranks them, with their offsets."""
    rows, cols, vals = (np.concatenate([x[i] for x in cand]) for i in range(3))
    if not quadratic:
        offs = np.zeros((len(rows), 2))
    elif lim is not None:
        pd, pt = np.concatenate([x[3] for x in cand]), np.concatenate([x[4] for x in cand])
        offs = quadratic_offsets(authors_apply(pd, pt, lim))
        offs[(rows != np.clip(rows, 1, H - 2)) | (cols != np.clip(cols, 1, W - 2))] = 0.0
    else:
        offs = np.concatenate([x[3] for x in cand])
    sel = rank_peaks(vals, rows, cols, rad, max_corners)  # candidates in raster order, as select_peaks'
    return rows[sel], cols[sel], vals[sel], offs[sel]


def _bound(threshold, threshold_rel, vmax: float, sq: StreamQuantile | None) -> float:
    """A lower bound (>= 0) of the final threshold, from what has been seen so far."""
    bound = 0.0
    if threshold is not None:
        bound = max(bound, float(threshold))
    if threshold_rel is not None and vmax > 0:
        bound = max(bound, float(threshold_rel) * vmax * _SAFE)
    if sq is not None and sq.floor > 0:
        bound = max(bound, sq.floor * _SAFE)
    return bound


def _prune(cand: list[tuple[np.ndarray, ...]], thr: float) -> list:
    """Candidates strictly above ``thr``; empty parts dropped."""
    out = []
    for part in cand:
        ok = part[2] > thr
        if ok.all():
            out.append(part)
        elif ok.any():
            out.append(tuple(x[ok] for x in part))
    return out
