"""From selected peaks of Upsilon to corners: units, sub-pixel positions and X-junctions.

Both detection paths, the CPU one (:mod:`sogdd.detector`) and the GPU one
(:mod:`sogdd.gpu`), find the peaks of the measure their own way and then finish
them here, so a setting means the same on both:

1. the threshold in the measure's units (:func:`peak_threshold`: grey levels of
   corner contrast are converted with :func:`sogdd.measure.units.measure_threshold`),
   and how many peaks to keep before X-junctions are added (:func:`peak_limit`);
2. :func:`assemble`: quadratic offsets and gradient refinement, strengths in
   grey levels, the X-junction stage (:func:`sogdd.select.x_junctions.add_x_junctions`) and
   the adaptive gradient refinement, which needs the final neighbours; after it,
   corners it brought within :data:`COINCIDENT` px of a stronger one are merged
   into it (one point per corner);
3. :func:`merge_levels`: with an image pyramid (:mod:`sogdd.image.pyramid`), every level's
   corners mapped back to full resolution with pixel centres at integers,
   ``x_full = (x_level + 0.5) s - 0.5``, their size scaled by ``s`` and tagged with the
   level, then ranked together and cut to ``max_corners``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..corners import Corners
from ..image.pyramid import Level
from ..measure.soddc import MeasureSpec
from ..measure.units import grey_strength, measure_threshold
from ..params import Params
from .peaks import inside_allowed
from .refine import one_per_point, refine_gradient, refine_gradient_adaptive
from .x_junctions import X_RING_RADIUS, add_x_junctions

__all__ = ["COINCIDENT", "assemble", "merge_levels", "peak_limit", "peak_threshold"]

#: with ``subpixel="adaptive"``, corners that refinement brings within this many px of a stronger
#: one are that corner (two peaks of Upsilon around one vertex converge to ~0.005 px of each other)
COINCIDENT = 0.1


def peak_threshold(p: Params, spec: MeasureSpec) -> float | None:
    """The absolute threshold on Upsilon itself (``threshold_units="grey"`` converted).

    Examples
    --------
    >>> import sogdd
    >>> p = sogdd.resolve_params("hr")
    >>> t = peak_threshold(p, p.measure_spec())
    >>> bool(0 < t < 1e12), peak_threshold(sogdd.resolve_params("paper"), p.measure_spec())
    (True, 1000000000.0)
    """
    if p.threshold is None or p.threshold_units != "grey":
        return p.threshold
    return measure_threshold(p.threshold, spec)


def peak_limit(p: Params) -> int | None:
    """How many peaks to keep: ``max_corners``, or all of them when X-junctions join later."""
    return None if p.x_junctions else p.max_corners


def assemble(grey, p: Params, spec: MeasureSpec, rows: np.ndarray, cols: np.ndarray, values: np.ndarray,
             qoff: np.ndarray | None, mask: np.ndarray | None = None, *,
             gradient: Callable[[np.ndarray], np.ndarray] | None = None,
             saddles: tuple[np.ndarray, np.ndarray] | None = None) -> Corners:
    """Corners from peaks (strongest first) with their values and quadratic offsets (dx, dy).

    ``grey``: the grey 0-255 image (an array or a :class:`sogdd.image.rows.GreyRows`),
    read by the X-junction stage, the gradient and the adaptive refinements.
    ``gradient``: ``subpixel="gradient"`` refinement of an (N, 2) array of points
    (default :func:`sogdd.select.refine.refine_gradient` on ``grey``). Strengths are in
    grey levels with ``threshold_units="grey"``. ``saddles``: the X-junction
    stage's :func:`sogdd.select.x_junctions.saddle_search`, if already computed.
    """
    xy = np.stack([cols, rows], axis=1).astype(np.float64)
    if p.subpixel != "none" and len(rows):
        xy += qoff
        if p.subpixel == "gradient":
            xy = gradient(xy) if gradient is not None else refine_gradient(grey, xy)
    strength = grey_strength(values, spec) if p.threshold_units == "grey" else values
    out = Corners(xy, strength, np.full(len(rows), p.keypoint_size()))
    is_x = np.zeros(len(out), bool)
    if p.x_junctions:
        out, is_x = add_x_junctions(out, grey, spec, threshold=p.threshold, rho=X_RING_RADIUS,
                                    size=p.keypoint_size(), border=p.border, mask=mask, found=saddles)
        if p.max_corners is not None:
            out, is_x = out.subset(np.arange(min(len(out), p.max_corners))), is_x[: p.max_corners]
    if p.subpixel == "adaptive" and len(out):  # after the cut: windows see the final neighbours
        c = ~is_x
        xy = out.xy.copy()
        # the float32 image the refinement reads, built once (band by band from a GreyRows)
        xy[c] = refine_gradient_adaptive(np.asarray(grey, np.float32), xy[c], xy[is_x])
        out = Corners(xy, out.response, out.size, out.level)
        # two peaks of one corner that the refinement brought together are one corner
        out = out.subset(one_per_point(out.xy, out.response, COINCIDENT))
    return out


def _to_full(level: Level, c: Corners) -> Corners:
    """A level's corners at full resolution: ``x_full = (x + 0.5) s - 0.5``, size x s, tagged."""
    xy = np.stack([(c.xy[:, 0] + 0.5) * level.sx - 0.5, (c.xy[:, 1] + 0.5) * level.sy - 0.5], axis=1)
    return Corners(xy, c.response, c.size * (level.sx + level.sy) / 2, np.full(len(c), level.index))


def merge_levels(found: list[tuple[Level, Corners]], p: Params, mask: np.ndarray | None,
                 shape: tuple[int, int]) -> Corners:
    """Every level's corners at full resolution, inside border and mask, strongest first, top-k.

    Examples
    --------
    >>> import sogdd
    >>> from sogdd.image.pyramid import pyramid_levels
    >>> from sogdd.synthetic import pattern_image
    >>> img = pattern_image((240, 320))[0]
    >>> p = sogdd.resolve_params("paper", levels=2)
    >>> found = [(lv, sogdd.detect_corners(lv.grey)) for lv in pyramid_levels(img, p.levels)]
    >>> sorted(set(merge_levels(found, p, None, img.shape).level.tolist()))
    [0, 1]
    """
    parts = []
    for level, c in found:
        c = _to_full(level, c)
        parts.append(c.subset(inside_allowed(c.xy, mask, p.border, shape)))
    out = Corners.concatenate(parts)
    if p.levels > 1:
        order = np.argsort(-out.response, kind="stable")
        if p.max_corners is not None:
            order = order[: p.max_corners]
        out = out.subset(order)
    return out
