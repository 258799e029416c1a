"""The selection stage's one entry point: how the measure is read, and the corners it gives.

:func:`select_corners` chooses how the peaks of the measure are found and
finishes them the same way whatever the choice (:func:`sogdd.select.assemble.assemble`):

1. an absolute threshold alone, with a measure that can prune below it
   (:func:`sogdd.measure.soddc.supports_floor`): the measure band by band, pruned
   below the threshold (:mod:`sogdd.measure.bands`, :mod:`sogdd.select.bands`),
   never an H x W map;
2. otherwise (relative or quantile thresholds, the authors' measure, other
   windows): the measure band by band in one pass as well, pruned below a floor
   of the relative threshold (:func:`sogdd.measure.relative_floor.relative_floor`)
   where there is one;
3. the full map, where one pass cannot know the threshold (it could be negative).

A device (the GPU path, :mod:`sogdd.gpu`) brings its own measure: the maxima it
finds itself, with their 3 x 3 patches, or the whole map copied back; the rest is
the same code.

Both read every peak above the threshold, ranked, where sub-pixel refinement
may bring two onto one point (:func:`sogdd.select.assemble.peak_limit`): the
merge of such points comes before the ``max_corners`` cut, which is refilled
(:func:`sogdd.select.assemble.assemble`).
"""

from __future__ import annotations

from functools import cache, partial
from typing import Protocol

import numpy as np

from ..corners import Corners
from ..measure.bands import Band, measure_bands
from ..measure.relative_floor import relative_floor
from ..measure.soddc import MeasureSpec, supports_floor
from ..params import Params
from .assemble import assemble, peak_limit, peak_threshold
from .bands import stream_peaks
from .peaks import keep_ranked, select_peaks
from .refine import patch_offsets, refine_quadratic
from .x_junctions import SaddleCandidates

__all__ = ["DeviceMeasure", "select_corners"]


class DeviceMeasure(Protocol):
    """The measure of one image on a device, as :func:`select_corners` reads it."""

    shape: tuple[int, int]

    def peaks(self, threshold: float, nms_radius: int, border: int):
        """Rows, columns, values and (n, 3, 3) patches of the local maxima above ``threshold`` inside the
        ``border``, raster order (as :func:`sogdd.select.peaks.maxima_above` on the valid area); None
        where the device cannot find them (then :meth:`whole` is read)."""

    def whole(self) -> np.ndarray:
        """The whole map, on the host."""

    def gradient(self, rows: np.ndarray, cols: np.ndarray, xy: np.ndarray) -> np.ndarray | None:
        """The points ``xy`` of the peaks at ``rows``, ``cols``, refined on the device by the gradient
        refinement (:func:`sogdd.select.refine.refine_gradient`), or None (then on the host image).
        Called for the strongest peaks first and again for the next ones where the merge of coincident
        points asks for more (:func:`sogdd.select.assemble.assemble`)."""


def _absolute_floor(p: Params, spec: MeasureSpec, threshold: float | None) -> float | None:
    """The absolute threshold, when it alone decides which peaks pass (no relative or quantile one)."""
    if threshold is None or threshold <= 0 or p.threshold_rel is not None or p.quantile is not None:
        return None
    return float(threshold) if supports_floor(spec) else None


def select_corners(grey, p: Params, mask: np.ndarray | None = None, *,
                   device: DeviceMeasure | None = None) -> Corners:
    """The corners of one image (one pyramid level): its measure's peaks, refined, strongest first.

    ``grey``: the grey 0-255 image (an array or a :class:`sogdd.image.rows.GreyRows`),
    measured here band by band (module doc), or None with a ``device`` whose
    measure is read instead. ``mask``: a boolean mask of the image's shape.

    Examples
    --------
    >>> import sogdd
    >>> from sogdd.synthetic import pattern_image
    >>> img = pattern_image((120, 160))[0]
    >>> c = select_corners(img, sogdd.resolve_params("paper"))
    >>> bool(np.array_equal(c.xy, sogdd.detect_corners(img).xy))
    True
    """
    spec = p.measure_spec()
    thr = peak_threshold(p, spec)
    if device is not None:
        return _on_device(device, grey, p, spec, thr, mask)
    H = grey.shape[0]
    top = peak_limit(p)
    quadratic = p.subpixel != "none"
    saddles = _saddles(grey, p, spec)
    floor = _absolute_floor(p, spec, thr)
    if floor is None:  # a relative threshold prunes too, below a floor found from a few exact values
        floor = cache(partial(relative_floor, grey, p, spec, mask, threshold=thr))
    found = stream_peaks(grey, spec, floor=floor, on_planes=saddles, threshold=thr,
                         threshold_rel=p.threshold_rel, quantile=p.quantile, nms_radius=p.nms_radius,
                         border=p.border, mask=mask, max_corners=top, quadratic=quadratic)
    if found is None:  # only the full map can tell the threshold
        saddles = _saddles(grey, p, spec)
        whole = [Band(0, H, 0, H, 0, H)]
        resp = next(measure_bands(grey, spec, whole, floor=floor, on_planes=saddles)).response
        rows, cols = select_peaks(resp, threshold=thr, threshold_rel=p.threshold_rel, quantile=p.quantile,
                                  nms_radius=p.nms_radius, border=p.border, mask=mask, max_corners=top)
        found = rows, cols, resp[rows, cols], refine_quadratic(resp, rows, cols) if quadratic else None
        del resp
    rows, cols, values, qoff = found
    return assemble(grey, p, spec, rows, cols, values, qoff, mask,
                    saddles=None if saddles is None else saddles.result(grey))


def _saddles(grey, p: Params, spec: MeasureSpec) -> SaddleCandidates | None:
    """The X-junction stage's candidates, taken from the measure's own filter responses (not filtered twice)."""
    return SaddleCandidates(grey.shape, spec, p.threshold) if p.x_junctions and not spec.zero_mean else None


def _on_device(device: DeviceMeasure, grey, p: Params, spec: MeasureSpec, thr: float | None,
               mask: np.ndarray | None) -> Corners:
    """Peaks from the device's maxima (absolute threshold) or from its whole map, finished on the host."""
    shape, top = device.shape, peak_limit(p)
    quadratic = p.subpixel != "none"
    found = None
    if p.threshold_rel is None and p.quantile is None:
        # no threshold: every local maximum above 0, as sogdd.select.peaks.resolve_threshold
        found = device.peaks(0.0 if thr is None else float(thr), int(p.nms_radius), int(p.border))
    if found is not None:
        rows, cols, values, patches = found
        sel = keep_ranked(rows, cols, values, shape, p.border, mask, p.nms_radius, top)
        rows, cols, values = rows[sel], cols[sel], values[sel]
        qoff = patch_offsets(patches[sel], rows, cols, shape) if quadratic and len(rows) else None
        gradient = device.gradient
    else:
        resp = device.whole()
        rows, cols = select_peaks(resp, threshold=thr, threshold_rel=p.threshold_rel, quantile=p.quantile,
                                  nms_radius=p.nms_radius, border=p.border, mask=mask, max_corners=top)
        values = resp[rows, cols]
        qoff = refine_quadratic(resp, rows, cols) if quadratic and len(rows) else None
        gradient = None
    return assemble(grey, p, spec, rows, cols, values, qoff, mask, gradient=gradient, shape=shape)
