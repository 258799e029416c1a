"""The image pyramid of corner detection (``levels > 1``), shared by the CPU and GPU paths.

Level ``l`` is the grey image resized by ``scale_factor**l`` (``cv2.INTER_AREA``;
the mask by nearest neighbour); its corners are mapped back to full resolution
with pixel centres at integers, ``x_full = (x_level + 0.5) s - 0.5``, their
size scaled by ``s`` and tagged with the level, then all levels are ranked
together and cut to ``max_corners``. A level smaller than ``2 border + 3`` or
8 pixels ends the pyramid.
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np

from .corners import Corners
from .params import Params
from .peaks import inside_allowed

__all__ = ["detect_pyramid"]


def detect_pyramid(grey, p: Params, mask: np.ndarray | None,
                   detect_level: Callable[[np.ndarray, np.ndarray | None], Corners]) -> Corners:
    """Corners of every pyramid level, strongest first (module doc).

    ``detect_level(grey_level, mask_level)`` detects on one level (a single
    level when ``p.levels == 1``: ``grey`` is then passed as given, e.g. a
    :class:`sogdd._grey_rows.GreyRows`).

    Examples
    --------
    >>> import sogdd
    >>> from sogdd.synthetic import pattern_image
    >>> img = pattern_image((240, 320))[0].astype(float)
    >>> p = sogdd.resolve_params("paper", levels=2)
    >>> c = detect_pyramid(img, p, None, lambda g, m: sogdd.detect_corners(g, value_range=(0, 255)))
    >>> sorted(set(c.level.tolist()))
    [0, 1]
    """
    parts = []
    h, w = grey.shape
    for level in range(p.levels):
        if level == 0:
            g, mk, sx, sy = grey, mask, 1.0, 1.0
        else:
            f = p.scale_factor**level
            lw, lh = int(round(w / f)), int(round(h / f))
            if min(lw, lh) < 2 * p.border + 3 or min(lw, lh) < 8:
                break
            g = cv2.resize(np.asarray(grey), (lw, lh), interpolation=cv2.INTER_AREA)
            mk = None if mask is None else cv2.resize(
                mask.astype(np.uint8), (lw, lh), interpolation=cv2.INTER_NEAREST
            ).astype(bool)
            sx, sy = w / lw, h / lh
        c = detect_level(g, mk)
        # pixel centres at integers: x_full = (x_level + 0.5) * s - 0.5
        xy = np.stack([(c.xy[:, 0] + 0.5) * sx - 0.5, (c.xy[:, 1] + 0.5) * sy - 0.5], axis=1)
        c = Corners(xy, c.response, c.size * (sx + sy) / 2, np.full(len(c), level))
        parts.append(c.subset(inside_allowed(xy, mask, p.border, (h, w))))
    out = Corners.concatenate(parts)
    if p.levels > 1:
        order = np.argsort(-out.response, kind="stable")
        if p.max_corners is not None:
            order = order[: p.max_corners]
        out = out.subset(order)
    return out
