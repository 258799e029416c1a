"""The measure handed on band by band: crops of the grey image measured with their margins.

Selection with an absolute or a relative threshold needs the measure only
within a few rows of each peak, so it reads the measure as a stream of bands of
rows instead of an H x W map (192 MB at 24 MP). A band owns rows ``a .. c - 1``
(every image row is owned by one band), uses the values of rows ``lo .. hi - 1``
(its own rows and a halo for the non-maximum suppression and the 3 x 3 patch of
the quadratic refinement), and is measured on the crop ``y0 .. y1 - 1`` that
extends ``radius + R + 2`` rows (the filters' and the window's reach) beyond
them, so that on rows ``lo .. hi - 1`` the crop's measure is the image's, bit
for bit (the kernels' values do not depend on where a tile starts).

The selection stage plans the bands (:func:`band_plan`) and pulls them from
:func:`measure_bands`, a generator: the measure stage reads the grey image and
hands each band forward; it never calls the selection back, except for the
``on_planes`` hook it is given (the X-junction stage's candidates from the
filter responses).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..image.rows import measure_rows
from .soddc import MeasureSpec, PlanesHook, abs_max, authors_apply, soddc_measure

__all__ = ["Band", "MeasuredBand", "band_plan", "measure_bands"]


@dataclass(frozen=True)
class Band:
    """One band: its own rows ``a .. c - 1``, the rows ``lo .. hi - 1`` whose values are used, and its crop."""

    a: int
    c: int
    lo: int
    hi: int
    y0: int
    y1: int


class MeasuredBand(NamedTuple):
    """Upsilon of rows ``lo .. hi - 1`` and, with ``raw``, what the authors' clamp still needs."""

    response: np.ndarray
    det: np.ndarray | None = None
    trace: np.ndarray | None = None
    abs_det_max: float = 0.0  #: max|det| over the band's own rows (``raw``)
    det_nan: bool = False  #: whether a det of its own rows is NaN (``raw``)


def band_plan(height: int, band_rows: int, halo: int, spec: MeasureSpec) -> list[Band]:
    """The bands of an image of ``height`` rows: ``band_rows`` own rows each, ``halo`` rows of values beyond.

    Examples
    --------
    >>> from sogdd.measure.window import window_halfwidths
    >>> spec = MeasureSpec(1.2, 8, window_halfwidths("square", 7))
    >>> [(b.a, b.c, b.lo, b.hi, b.y0, b.y1) for b in band_plan(100, 40, 1, spec)]
    [(0, 40, 0, 41, 0, 51), (40, 80, 39, 81, 29, 91), (80, 100, 79, 100, 69, 100)]
    """
    m = spec.radius + spec.window_radius + 2
    out = []
    for a in range(0, height, int(band_rows)):
        c = min(height, a + int(band_rows))
        lo, hi = max(0, a - halo), min(height, c + halo)
        out.append(Band(a, c, lo, hi, max(0, lo - m), min(height, hi + m)))
    return out


def measure_bands(
    grey,
    spec: MeasureSpec,
    plan: list[Band],
    *,
    floor: float | Callable[[], float | None] | None = None,
    raw: bool = False,
    on_planes: PlanesHook | None = None,
) -> Iterator[MeasuredBand]:
    """The measure of each band of ``plan``, in order, as :func:`~sogdd.measure.soddc.soddc_measure` gives it.

    ``grey``: an (H, W) array or a :class:`sogdd.image.rows.GreyRows`. ``floor``:
    the pruning floor (a value, or a function that gives it, called once before
    the first band). ``raw`` (the authors' measure): the band's det and trace
    too, and its response with nothing clamped (the clamp needs ``max|det|``
    over the whole image; values > 0 are the same either way).
    ``on_planes(top, lo, hi, planes)`` receives the filter responses of every
    tile, in image rows, with ``lo .. hi - 1`` the rows of the tile that are its
    band's own.
    """
    if callable(floor):
        floor = floor()
    for b in plan:
        hook = None
        if on_planes is not None:
            def hook(top, r0, r1, planes, b=b):
                on_planes(top + b.y0, max(r0 + b.y0, b.a), min(r1 + b.y0, b.c), planes)
        # nothing of a band stays referenced here while the consumer works on it and the next is measured
        yield _measure_band(grey, spec, b, floor, raw, hook)


def _measure_band(grey, spec: MeasureSpec, b: Band, floor: float | None, raw: bool,
                  hook: PlanesHook | None) -> MeasuredBand:
    crop = measure_rows(grey, b.y0, b.y1)
    if not (raw and spec.authors_measure):
        return MeasuredBand(soddc_measure(crop, spec, floor=floor, on_planes=hook)[b.lo - b.y0 : b.hi - b.y0])
    det, tr = soddc_measure(crop, spec, raw=True, on_planes=hook)
    det, tr = det[b.lo - b.y0 : b.hi - b.y0], tr[b.lo - b.y0 : b.hi - b.y0]
    big, nan = abs_max(det[b.a - b.lo : b.c - b.lo].reshape(-1))
    return MeasuredBand(authors_apply(det, tr, np.nan), det, tr, float(big), bool(nan))
