"""From selected peaks of Upsilon to corners: units, sub-pixel positions and X-junctions.

Both detection paths, the CPU one (:mod:`sogdd.detector`) and the GPU one
(:mod:`sogdd.gpu`), find the peaks of the measure their own way and then finish
them here, so a setting means the same on both:

1. the threshold in the measure's units (:func:`peak_threshold`: grey levels of
   corner contrast are converted with :func:`sogdd.measure.units.measure_threshold`),
   and how many peaks to keep before X-junctions are added (:func:`peak_limit`);
2. :func:`assemble`, in this order: quadratic offsets, strengths in grey levels,
   the X-junction stage (:func:`sogdd.select.x_junctions.add_x_junctions`; the
   gradient refinement before it, as it compares corners with the junctions);
   then, for the strongest candidates only, the gradient or the adaptive
   refinement (the latter needs the final neighbours), the drop of points that
   it moved out of the border or mask, and the merge: a point within
   :data:`~sogdd.select.refine.COINCIDENT` px of a stronger one is that one
   (two local maxima of one vertex refine onto one point, or, where one
   refinement is refused, to within half a pixel of it). The merge comes
   before the ``max_corners`` cut, which is refilled from the next candidates
   (:func:`sogdd.select.refine.first_distinct`), so ``max_corners=N`` gives N
   distinct corners where the image holds them; the local maxima themselves
   are the paper's, unchanged;
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
from .refine import COINCIDENT, first_distinct, refine_gradient, refine_gradient_adaptive
from .x_junctions import X_RING_RADIUS, add_x_junctions

__all__ = ["COINCIDENT", "assemble", "merge_levels", "peak_limit", "peak_threshold"]

#: refines the points ``xy`` of the peaks at ``rows``, ``cols`` on a device, or gives None (then on the host)
DeviceGradient = Callable[[np.ndarray, np.ndarray, np.ndarray], "np.ndarray | None"]


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
    """How many peaks to keep: ``max_corners``, or all of them when X-junctions join later or when
    the merge after sub-pixel refinement may drop some (:func:`assemble` refills the cut then)."""
    return None if p.x_junctions or p.subpixel != "none" else p.max_corners


def assemble(grey, p: Params, spec: MeasureSpec, rows: np.ndarray, cols: np.ndarray, values: np.ndarray,
             qoff: np.ndarray | None, mask: np.ndarray | None = None, *,
             gradient: DeviceGradient | None = None,
             saddles: tuple[np.ndarray, np.ndarray] | None = None,
             shape: tuple[int, int] | None = None) -> Corners:
    """Corners from peaks (strongest first) with their values and quadratic offsets (dx, dy).

    ``grey``: the grey 0-255 image (an array or a :class:`sogdd.image.rows.GreyRows`),
    read by the X-junction stage, the gradient and the adaptive refinements.
    ``gradient``: ``subpixel="gradient"`` refinement on a device,
    ``gradient(rows, cols, xy)`` for the peaks at ``rows``, ``cols`` from their
    (n, 2) points ``xy``, or None where it wants the host image (then, and by
    default, :func:`sogdd.select.refine.refine_gradient` on ``grey``). Strengths are in
    grey levels with ``threshold_units="grey"``. ``saddles``: the X-junction
    stage's :func:`sogdd.select.x_junctions.saddle_search`, if already computed.
    ``shape``: the image's (H, W), by default ``grey.shape`` (``grey`` is None on a
    device that refines there).

    The peaks are ranked candidates (all of them where the merge may drop some,
    :func:`peak_limit`); only the strongest are refined, as many as the merge and
    the ``max_corners`` cut need (:func:`sogdd.select.refine.first_distinct`).
    Returns at most ``max_corners`` points, pairwise at least ``COINCIDENT`` px
    apart, inside ``border`` and ``mask``.
    """
    xy = np.stack([cols, rows], axis=1).astype(np.float64)
    if p.subpixel != "none" and len(rows):
        xy += qoff
    strength = grey_strength(values, spec) if p.threshold_units == "grey" else values
    lazy = _GradientPrefix(grey, rows, cols, xy, gradient) if p.subpixel == "gradient" else None
    is_x = np.zeros(len(rows), bool)
    if p.x_junctions:  # the junctions replace the corners near them: compared at refined positions
        xy = xy if lazy is None else lazy(len(xy)).copy()
        out, is_x = add_x_junctions(Corners(xy, strength, np.full(len(rows), p.keypoint_size())), grey, spec,
                                    threshold=p.threshold, rho=X_RING_RADIUS, size=p.keypoint_size(),
                                    border=p.border, mask=mask, found=saddles)
        xy, strength, lazy = out.xy, out.response, None
    place = lazy if lazy is not None else (lambda m: xy[:m])
    if p.subpixel == "adaptive":
        place = _adaptive_prefix(grey, xy, is_x)
    hw = grey.shape if shape is None else shape
    # refinement can move a point out of the border or mask (dropped, then refilled) and onto another
    keep, refined = first_distinct(place, strength, p.max_corners, tol=COINCIDENT,
                                   allowed=lambda q: inside_allowed(q, mask, p.border, hw))
    return Corners(refined[keep], strength[keep], np.full(len(keep), p.keypoint_size()))


class _GradientPrefix:
    """The gradient refinement of the first ``m`` points, refined once each and only when asked for.

    Each point is refined on its own (:func:`sogdd.select.refine.refine_gradient`), so refining
    a prefix, then more, gives the positions of refining all at once, bit for bit.
    """

    def __init__(self, grey, rows: np.ndarray, cols: np.ndarray, xy: np.ndarray,
                 device: DeviceGradient | None) -> None:
        self.grey, self.rows, self.cols, self.xy, self.device = grey, rows, cols, xy, device
        self.done = xy.copy()
        self.n = 0
        self._img: np.ndarray | None = None

    def __call__(self, m: int) -> np.ndarray:
        k = self.n
        if m > k:
            got = self.device(self.rows[k:m], self.cols[k:m], self.xy[k:m]) if self.device is not None else None
            if got is None:
                if self._img is None:  # the float32 image the refinement reads, built once
                    self._img = np.asarray(self.grey, np.float32)
                got = refine_gradient(self._img, self.xy[k:m])
            self.done[k:m] = got
            self.n = m
        return self.done[:m]


def _adaptive_prefix(grey, xy: np.ndarray, is_x: np.ndarray) -> Callable[[int], np.ndarray]:
    """The adaptive refinement of the first ``m`` points among themselves (X-junctions stay, as neighbours).

    Each window shrinks to half the distance to the nearest other of the ``m`` points, so the
    positions depend on ``m``: each prefix is refined anew.
    """
    img = np.asarray(grey, np.float32)  # the float32 image the refinement reads, built once

    def place(m: int) -> np.ndarray:
        out = xy[:m].copy()
        c, x = ~is_x[:m], is_x[:m]
        if c.any():
            out[c] = refine_gradient_adaptive(img, out[c], out[x])
        return out

    return place


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
