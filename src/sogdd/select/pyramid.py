"""The image pyramid of corner detection (``levels > 1``), shared by the CPU and GPU paths.

Level ``l`` is the grey image resized by ``scale_factor**l`` (``cv2.INTER_AREA``;
the mask by nearest neighbour); its corners are mapped back to full resolution
with pixel centres at integers, ``x_full = (x_level + 0.5) s - 0.5``, their
size scaled by ``s`` and tagged with the level, then all levels are ranked
together and cut to ``max_corners``. A level smaller than ``2 border + 3`` or
8 pixels ends the pyramid.

The detector drives it top-down: :func:`pyramid_levels` gives the levels, the
detector detects on each, :func:`merge_levels` maps them back and ranks them.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import cv2
import numpy as np

from ..corners import Corners
from ..params import Params
from .peaks import inside_allowed

__all__ = ["Level", "merge_levels", "pyramid_levels"]


@dataclass(frozen=True)
class Level:
    """One pyramid level: its grey image and mask, and its scale ``(sx, sy)`` to full resolution."""

    index: int
    grey: object
    mask: np.ndarray | None
    sx: float = 1.0
    sy: float = 1.0

    def to_full(self, c: Corners) -> Corners:
        """This level's corners at full resolution: ``x_full = (x + 0.5) s - 0.5``, size x s, tagged."""
        xy = np.stack([(c.xy[:, 0] + 0.5) * self.sx - 0.5, (c.xy[:, 1] + 0.5) * self.sy - 0.5], axis=1)
        return Corners(xy, c.response, c.size * (self.sx + self.sy) / 2, np.full(len(c), self.index))


def pyramid_levels(grey, p: Params, mask: np.ndarray | None) -> Iterator[Level]:
    """The levels of ``grey`` (module doc); level 0 is ``grey`` as given (e.g. a ``GreyRows``).

    Examples
    --------
    >>> import sogdd
    >>> p = sogdd.resolve_params("paper", levels=3)
    >>> [(lv.index, lv.grey.shape) for lv in pyramid_levels(np.zeros((64, 96)), p, None)]
    [(0, (64, 96)), (1, (32, 48)), (2, (16, 24))]
    """
    h, w = grey.shape
    yield Level(0, grey, mask)
    for level in range(1, p.levels):
        f = p.scale_factor**level
        lw, lh = int(round(w / f)), int(round(h / f))
        if min(lw, lh) < 2 * p.border + 3 or min(lw, lh) < 8:
            return
        g = cv2.resize(np.asarray(grey), (lw, lh), interpolation=cv2.INTER_AREA)
        mk = None if mask is None else cv2.resize(
            mask.astype(np.uint8), (lw, lh), interpolation=cv2.INTER_NEAREST
        ).astype(bool)
        yield Level(level, g, mk, w / lw, h / lh)


def merge_levels(found: list[tuple[Level, Corners]], p: Params, mask: np.ndarray | None,
                 shape: tuple[int, int]) -> Corners:
    """Every level's corners at full resolution, inside border and mask, strongest first, top-k.

    Examples
    --------
    >>> import sogdd
    >>> from sogdd.synthetic import pattern_image
    >>> img = pattern_image((240, 320))[0]
    >>> p = sogdd.resolve_params("paper", levels=2)
    >>> found = [(lv, sogdd.detect_corners(lv.grey)) for lv in pyramid_levels(img, p, None)]
    >>> sorted(set(merge_levels(found, p, None, img.shape).level.tolist()))
    [0, 1]
    """
    parts = []
    for level, c in found:
        c = level.to_full(c)
        parts.append(c.subset(inside_allowed(c.xy, mask, p.border, shape)))
    out = Corners.concatenate(parts)
    if p.levels > 1:
        order = np.argsort(-out.response, kind="stable")
        if p.max_corners is not None:
            order = order[: p.max_corners]
        out = out.subset(order)
    return out
