"""Grey-level units: one scale for the strength of every corner.

Both measures are put on the scale of *grey levels of corner contrast*: an
ideal right-angle L-corner of contrast ``c`` (rendered at 16x supersampling)
has corner strength ``c``, and an ideal X-junction of contrast ``c`` has
saddle strength ``c``. Upsilon grows as ``contrast^(2K-2)``, so its strength
is ``100 (Upsilon / Upsilon_L100)^(1 / (2K - 2))`` with ``Upsilon_L100`` the
L-corner's peak at contrast 100. A threshold ``T`` then keeps corners at
least as strong as a right-angle corner of contrast ``T``, on a dim photo as on
a bright one, and scaling an image's contrast by ``a`` scales every strength
by ``a`` exactly.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..synthetic import Polygon, render_polygons
from .soddc import MeasureSpec, soddc_measure

__all__ = ["CALIBRATION_CONTRAST", "calibration_images", "corner_unit", "grey_strength", "measure_threshold"]

#: the contrast (grey levels) of the calibration corner and junction
CALIBRATION_CONTRAST = 100.0


def calibration_images() -> tuple[np.ndarray, np.ndarray]:
    """The calibration L-corner and X-junction: contrast 100 on grey 50, 64 x 64, vertex at (31.5, 31.5)."""
    n, c, big = 64, 31.5, 200.0
    quad = np.array([[c, c], [c + big, c], [c + big, c + big], [c, c + big]])
    lo, hi = 50.0, 50.0 + CALIBRATION_CONTRAST
    L = render_polygons((n, n), [Polygon(quad, hi)], background=lo)
    X = render_polygons((n, n), [Polygon(quad, hi), Polygon(2 * c - quad, hi)], background=lo)
    return L, X


@lru_cache(maxsize=32)
def corner_unit(spec) -> float:
    """Peak Upsilon of an ideal right-angle L-corner of contrast 100 under ``spec``.

    ``spec``: a :class:`~sogdd.measure.soddc.MeasureSpec` (any window, equal or Gaussian weights).
    """
    L, _ = calibration_images()
    return float(soddc_measure(L, spec).max())


def grey_strength(upsilon: np.ndarray, spec: MeasureSpec) -> np.ndarray:
    """Upsilon in grey levels of corner contrast: ``100 (Upsilon / Upsilon_L100)^(1/(2K-2))``.

    Examples
    --------
    >>> from sogdd.measure.window import window_halfwidths
    >>> spec = MeasureSpec(1.2, 4, window_halfwidths("square", 7))
    >>> float(np.round(grey_strength(np.array([corner_unit(spec)]), spec)[0], 9))
    100.0
    """
    k = 2 * spec.n_orientations - 2
    u = np.maximum(np.asarray(upsilon, dtype=np.float64), 0.0) / corner_unit(spec)
    return CALIBRATION_CONTRAST * u ** (1.0 / k) if k > 0 else CALIBRATION_CONTRAST * u


def measure_threshold(grey_threshold: float, spec: MeasureSpec) -> float:
    """The Upsilon value whose grey-level strength is ``grey_threshold`` (inverse of :func:`grey_strength`)."""
    k = 2 * spec.n_orientations - 2
    t = max(float(grey_threshold), 0.0) / CALIBRATION_CONTRAST
    return corner_unit(spec) * (t**k if k > 0 else t)

