"""Peaks from the measure's bands, in one pass, under an absolute, relative or quantile threshold.

A peak and its 3 x 3 patch depend on the measure within ``nms_radius`` rows
(and 1 row for the patch) only, so the selection stage reads the measure band
by band (:func:`sogdd.measure.bands.measure_bands`) and never holds an H x W
map: each band keeps its local maxima above a lower bound of the final
threshold, with their values and quadratic offsets, and at the end those above
the threshold are ranked as :func:`sogdd.select.peaks.select_peaks` ranks them
on the whole map. The result is the full map's, bit for bit:

- with an absolute threshold the bound is the threshold itself;
- the thresholds of ``threshold_rel`` (a fraction of the largest Upsilon in the
  valid area) and ``quantile`` (a quantile of its positive values, the authors'
  rule) are known only once the whole image is: the maximum is a running one,
  and the quantile is exact from :class:`sogdd.select.stream_quantile.StreamQuantile`,
  which keeps about ``(1 - q)`` of the values; the bound rises as bands arrive;
- the authors' measure clamps ``det`` in ``[-eps max|det|, 0)`` to 0 with
  ``max|det|`` over the whole image. The positive values of Upsilon do not
  depend on the clamp (it only turns tiny negative values into 0), nor does a
  peak above a threshold >= 0 or its value; only the 3 x 3 patch of the
  quadratic refinement can, so that patch is kept as raw det and trace and
  measured once ``max|det|`` is known.

Where the final threshold could be negative (no positive value in the valid
area and ``threshold_rel``, or a negative absolute threshold) one pass cannot
know it, and :func:`peaks_in_bands` returns None: the caller then uses the full map.

:func:`stream_peaks` plans the bands and reads them from the measure's stream;
:func:`peaks_in_bands` selects from any such stream.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numba
import numpy as np

from .._jit import JIT
from ..measure.bands import Band, MeasuredBand, band_plan, measure_bands
from ..measure.soddc import MeasureSpec, PlanesHook, authors_apply, authors_limit
from .peaks import maxima_above, rank_peaks
from .refine import patch_offsets, refine_quadratic
from .stream_quantile import StreamQuantile

__all__ = ["BAND_ROWS", "RAW_BAND_ROWS", "peaks_in_bands", "positives", "stream_peaks"]

BAND_ROWS = 1024  # rows per band: 2 x 10 halo rows recomputed per band at the paper preset (2 %)
RAW_BAND_ROWS = 512  # three band-sized maps with the authors' measure (det, trace, Upsilon)
_SAFE = 1.0 - 1e-9  # candidates kept a little below the bound, so a rounding in the lerp cannot matter

Peaks = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def _empty() -> Peaks:
    e = np.zeros(0, np.int64)
    return e, e, np.zeros(0), np.zeros((0, 2))


def _valid_per_row(H: int, W: int, b: int, mask: np.ndarray | None) -> tuple[np.ndarray, tuple[int, ...]]:
    """Pixels of the valid area (:func:`~sogdd.select.peaks.valid_area`) per row; its box before the mask."""
    box = (b, H - b, b, W - b) if 2 * b < H and 2 * b < W else (0, 0, 0, 0)
    r0, r1, c0, c1 = box
    per_row = np.zeros(H, np.int64)
    per_row[r0:r1] = c1 - c0 if mask is None else np.count_nonzero(mask[r0:r1, c0:c1], axis=1)
    return per_row, box


def stream_peaks(
    grey,
    spec: MeasureSpec,
    *,
    floor: float | Callable[[], float | None] | None = None,
    on_planes: PlanesHook | None = None,
    band_rows: int | None = None,
    nms_radius: int = 1,
    **selection,
) -> Peaks | None:
    """:func:`peaks_in_bands` on the measure of ``grey`` read in bands of ``band_rows`` rows.

    ``grey``: an (H, W) array or a :class:`sogdd.image.rows.GreyRows`; ``floor`` and
    ``on_planes``: as :func:`sogdd.measure.bands.measure_bands` takes them (the authors'
    measure is read raw); ``band_rows``: by default :data:`BAND_ROWS`
    (:data:`RAW_BAND_ROWS` for the authors' measure); the result does not depend on it.
    ``selection``: the other keywords of :func:`peaks_in_bands`.

    Examples
    --------
    >>> import sogdd
    >>> from sogdd.synthetic import pattern_image
    >>> from sogdd.measure.soddc import soddc_measure
    >>> from sogdd.select.peaks import select_peaks
    >>> img = pattern_image((120, 160))[0]
    >>> spec = sogdd.resolve_params("paper").measure_spec()
    >>> rows, cols, values, _ = stream_peaks(img, spec, floor=1e9, band_rows=32, threshold=1e9)
    >>> full = select_peaks(soddc_measure(img, spec), threshold=1e9)
    >>> bool(np.array_equal(rows, full[0]) and np.array_equal(cols, full[1]))
    True
    """
    if band_rows is None:
        band_rows = RAW_BAND_ROWS if spec.authors_measure else BAND_ROWS
    plan = band_plan(grey.shape[0], band_rows, max(int(nms_radius), 1), spec)
    bands = measure_bands(grey, spec, plan, floor=floor, raw=spec.authors_measure, on_planes=on_planes)
    return peaks_in_bands(bands, plan, grey.shape, nms_radius=nms_radius, **selection)


def peaks_in_bands(
    bands: Iterable[MeasuredBand],
    plan: list[Band],
    shape: tuple[int, int],
    *,
    threshold: float | None = None,
    threshold_rel: float | None = None,
    quantile: float | None = None,
    nms_radius: int = 1,
    border: int = 0,
    mask: np.ndarray | None = None,
    max_corners: int | None = None,
    quadratic: bool = False,
) -> Peaks | None:
    """Rows, columns, values and quadratic offsets of the peaks, as on the full map; None if it cannot tell.

    ``bands``: the measure of each band of ``plan`` (:func:`sogdd.measure.bands.measure_bands`,
    with a halo of at least ``max(nms_radius, 1)`` rows) of an image of ``shape``.
    The points are those of ``select_peaks(soddc_measure(grey, spec), threshold=...,
    threshold_rel=..., quantile=..., nms_radius=..., border=..., mask=...,
    max_corners=...)``, strongest first, their values those of the map, and the
    offsets (zeros unless ``quadratic``) those of
    :func:`sogdd.select.refine.refine_quadratic` on it.
    """
    H, W = shape
    mk = None if mask is None else np.asarray(mask, dtype=bool)
    relative = threshold_rel is not None or quantile is not None
    per_row, (vr0, vr1, vc0, vc1) = _valid_per_row(H, W, int(border), mk)
    if relative and not per_row.any():  # no pixel may hold a peak, whatever the threshold
        return _empty()
    sq = None if quantile is None else StreamQuantile(quantile, int(per_row.sum()))
    vmax = -np.inf  # the largest positive value in the valid area
    raw, big, nan = False, 0.0, False  # the authors' raw bands: max|det| over the image, whether a det is NaN
    cand: list[tuple[np.ndarray, ...]] = []
    stream = iter(bands)
    for b in plan:
        m = next(stream)  # not zip(): its reused tuple keeps the last band alive while the next is measured
        if m.det is not None:
            raw, big, nan = True, max(big, m.abs_det_max), nan or m.det_nan
        if relative:
            s0, s1 = max(b.a, vr0), min(b.c, vr1)  # the band's rows of the valid area
            vals, below, bmax = positives(m.response[s0 - b.lo : s1 - b.lo, vc0:vc1],
                                          None if mk is None else mk[s0:s1, vc0:vc1],
                                          np.inf if sq is None else sq.floor)
            vmax = max(vmax, bmax)
            if sq is not None and s1 > s0:
                sq.add(vals, slots=int(per_row[s0:s1].sum()), dropped=below)
            del vals
        bound = _bound(threshold, threshold_rel, vmax, sq)
        part = _band_peaks(m, b, bound, nms_radius, border, mk, quadratic, (H, W))
        del m
        cand = _prune(cand + [part], bound)
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
    lim = authors_limit(big, nan) if raw else None
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


def _band_peaks(m: MeasuredBand, b: Band, bound: float, nms_radius: int, border: int,
                mask: np.ndarray | None, quadratic: bool, shape: tuple[int, int]) -> tuple[np.ndarray, ...]:
    """Local maxima above ``bound`` on the band's own rows, as select_peaks'.

    Returns rows, columns, values and what the offsets need: nothing, the
    offsets, or (authors' measure) the raw det and trace of each 3 x 3 patch.
    """
    H, W = shape
    resp, lo = m.response, b.lo
    rad, bd = int(nms_radius), int(border)
    inner = bool(bd) and 2 * bd < H and 2 * bd < W  # select_peaks: maxima of the valid area alone
    rlo, rhi, clo, chi = (bd, H - bd, bd, W - bd) if inner else (0, H, 0, W)
    n0, n1 = max(b.a - rad, rlo), min(b.c + rad, rhi)
    rr = cc = np.zeros(0, np.int64)
    if n1 > n0 and chi > clo:
        rr, cc = maxima_above(np.ascontiguousarray(resp[n0 - lo : n1 - lo, clo:chi]), bound, rad)
        rr, cc = rr + n0, cc + clo
    own = (rr >= b.a) & (rr < b.c) & (rr >= bd) & (rr < H - bd) & (cc >= bd) & (cc < W - bd)
    rr, cc = rr[own], cc[own]
    if mask is not None:
        ok = mask[rr, cc]
        rr, cc = rr[ok], cc[ok]
    part = (rr, cc, resp[rr - lo, cc])
    if not quadratic:
        return part
    if m.det is None:
        # the band's map has all rows a patch needs; at the image's first and last rows it is
        # the image's edge as well, so refine_quadratic moves edge patches inside exactly as on the map
        return part + (refine_quadratic(resp, rr - lo, cc),)
    # the authors' measure: the patch's values below 0 wait for the clamp, so keep det and trace
    dy, dx = np.mgrid[-1:2, -1:2]
    iy = np.clip(rr, 1, H - 2)[:, None, None] - lo + dy
    ix = np.clip(cc, 1, W - 2)[:, None, None] + dx
    return part + (m.det[iy, ix], m.trace[iy, ix])


def _rank(cand: list, H: int, W: int, lim: float | None, rad: int, quadratic: bool, max_corners: int | None):
    """Candidates ranked as select_peaks ranks them, with their offsets."""
    rows, cols, vals = (np.concatenate([x[i] for x in cand]) for i in range(3))
    if not quadratic:
        offs = np.zeros((len(rows), 2))
    elif lim is not None:
        pd, pt = np.concatenate([x[3] for x in cand]), np.concatenate([x[4] for x in cand])
        offs = patch_offsets(authors_apply(pd, pt, lim), rows, cols, (H, W))
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
