"""A pruning floor for relative thresholds, from a few exact values of the measure.

With ``threshold_rel`` the detection threshold is ``rel * M``, ``M`` the largest
Upsilon in the valid area, which is only known once the map is. Any exact value
``v <= M`` gives a floor ``rel * v <= rel * M`` below which pixels cannot be
peaks, so the pruned measure (``soddc_measure(..., floor=...)``) applies: the
pixel that holds ``M`` is above the floor, hence exact, so the pruned map has
the same maximum, the same threshold and the same peaks as the full one. The
values come from small crops around the strongest corners of a cheap proxy
(the Shi-Tomasi measure on a 4x smaller image); a poor proxy only prunes less.
"""

from __future__ import annotations

import cv2
import numpy as np

from .soddc import MeasureSpec, prune_pays, soddc_measure, supports_floor

__all__ = ["max_lower_bound", "relative_floor"]

_SHRINK = 4  # proxy resolution
_CANDIDATES = 12  # crops evaluated exactly
_HALF = 12  # half-size of a crop's useful part, pixels


def max_lower_bound(
    grey: np.ndarray, spec: MeasureSpec, border: int = 0, mask: np.ndarray | None = None
) -> float:
    """An exact value of Upsilon in the valid area, so a lower bound of its maximum (``-inf`` if none found).

    Each candidate crop is extended by the filter radius plus the window
    half-height (plus 2) on every side that is not the image border, and only
    its inner part is used: there the crop's measure is the image's.

    Examples
    --------
    >>> from sogdd.synthetic import pattern_image
    >>> from sogdd.measure.window import window_halfwidths
    >>> img = pattern_image((120, 160))[0].astype(float)
    >>> spec = MeasureSpec(1.2, 8, window_halfwidths("square", 7))
    >>> lo = max_lower_bound(img, spec)
    >>> bool(0 < lo <= soddc_measure(img, spec).max())
    True
    """
    H, W = grey.shape
    m = spec.radius + spec.window_radius + 2
    small = cv2.resize(np.asarray(grey, np.float32), (max(1, W // _SHRINK), max(1, H // _SHRINK)),
                       interpolation=cv2.INTER_AREA)
    proxy = cv2.cornerMinEigenVal(small, 3).ravel()
    top = np.argsort(-proxy, kind="stable")[:_CANDIDATES]
    best = -np.inf
    for i in top:
        cy = int(i // small.shape[1]) * H // small.shape[0] + _SHRINK // 2
        cx = int(i % small.shape[1]) * W // small.shape[1] + _SHRINK // 2
        y0, y1 = max(0, cy - _HALF - m), min(H, cy + _HALF + m + 1)
        x0, x1 = max(0, cx - _HALF - m), min(W, cx + _HALF + m + 1)
        ups = soddc_measure(grey[y0:y1, x0:x1], spec, threads=1)
        # inner part: away from every crop edge that is not the image's own edge
        iy0, iy1 = (0 if y0 == 0 else m), (y1 - y0 if y1 == H else y1 - y0 - m)
        ix0, ix1 = (0 if x0 == 0 else m), (x1 - x0 if x1 == W else x1 - x0 - m)
        iy0, ix0 = max(iy0, border - y0), max(ix0, border - x0)
        iy1, ix1 = min(iy1, H - border - y0), min(ix1, W - border - x0)
        if iy1 <= iy0 or ix1 <= ix0:
            continue
        inner = ups[iy0:iy1, ix0:ix1]
        if mask is not None:
            inner = np.where(mask[y0 + iy0 : y0 + iy1, x0 + ix0 : x0 + ix1], inner, -np.inf)
        best = max(best, float(inner.max()))
    return best


def relative_floor(
    grey: np.ndarray,
    params,
    spec: MeasureSpec,
    mask: np.ndarray | None = None,
    *,
    threshold: float | None = None,
) -> float | None:
    """The pruning floor of a detection with ``threshold_rel`` (and no quantile), or None.

    ``max(threshold, threshold_rel * v)`` with ``threshold`` the absolute one on
    Upsilon (if any) and ``v`` from :func:`max_lower_bound`, lowered by 1e-9
    relative so that a rounding difference in ``v`` cannot raise it above the
    threshold the full map gives.
    """
    rel = params.threshold_rel
    if rel is None or params.quantile is not None or not rel > 0:
        return None
    # no pruning (no band is large enough where the image is not): no floor to compute
    if not (supports_floor(spec) and prune_pays(spec, grey.shape[0] * grey.shape[1])):
        return None
    levels = [float(threshold)] if threshold is not None else []
    lo = max_lower_bound(grey, spec, params.border, mask)
    if lo > 0 and np.isfinite(lo):
        levels.append(float(rel) * lo * (1.0 - 1e-9))
    floor = max(levels, default=0.0)
    return floor if floor > 0 else None
