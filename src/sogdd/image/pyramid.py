"""The image pyramid of corner detection (``levels > 1``): the grey image resized level by level.

Level ``l`` is the grey image resized by ``scale_factor**l`` (``cv2.INTER_AREA``;
the mask by nearest neighbour). A level smaller than ``2 border + 3`` or 8
pixels ends the pyramid. Each level carries its scale ``(sx, sy)`` to full
resolution, with which the selection stage maps its corners back
(:func:`sogdd.select.assemble.merge_levels`).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["Level", "pyramid_levels"]


@dataclass(frozen=True)
class Level:
    """One pyramid level: its grey image and mask, and its scale ``(sx, sy)`` to full resolution."""

    index: int
    grey: object
    mask: np.ndarray | None
    sx: float = 1.0
    sy: float = 1.0


def pyramid_levels(grey, levels: int, scale_factor: float = 2.0, *, border: int = 0,
                   mask: np.ndarray | None = None) -> Iterator[Level]:
    """The levels of ``grey`` (module doc); level 0 is ``grey`` as given (e.g. a ``GreyRows``).

    Examples
    --------
    >>> [(lv.index, lv.grey.shape) for lv in pyramid_levels(np.zeros((64, 96)), 3)]
    [(0, (64, 96)), (1, (32, 48)), (2, (16, 24))]
    """
    h, w = grey.shape
    yield Level(0, grey, mask)
    for level in range(1, levels):
        f = scale_factor**level
        lw, lh = int(round(w / f)), int(round(h / f))
        if min(lw, lh) < 2 * border + 3 or min(lw, lh) < 8:
            return
        g = cv2.resize(np.asarray(grey), (lw, lh), interpolation=cv2.INTER_AREA)
        mk = None if mask is None else cv2.resize(
            mask.astype(np.uint8), (lw, lh), interpolation=cv2.INTER_NEAREST
        ).astype(bool)
        yield Level(level, g, mk, w / lw, h / lh)
