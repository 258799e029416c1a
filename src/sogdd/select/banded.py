"""Detection at an absolute threshold in bands of rows, without an image-sized response map.

With an absolute threshold ``T`` (the paper preset) a peak and its
sub-pixel patch depend on the measure within ``nms_radius`` rows (and 1 row
for the 3 x 3 patch) only, so the measure is computed band by band on crops
of the grey image: each crop extends ``radius + R + 2`` rows beyond the rows
whose values are used (as in :mod:`sogdd.select.relative_floor`), so there the
crop's measure is the image's, bit for bit (the kernels' values do not depend
on where a tile starts). Peaks are found per band with the band's own halo
and ranked together as :func:`sogdd.select.peaks.select_peaks` ranks them: the
same points, values and quadratic offsets as detection on the whole map, with
a band-sized map instead of an H x W float64 one (192 MB at 24 MP).
"""

from __future__ import annotations

import numpy as np

from ..image.rows import measure_rows
from ..measure.soddc import MeasureSpec, PlanesHook, soddc_measure
from .peaks import maxima_above, rank_peaks
from .subpixel import refine_quadratic

__all__ = ["BAND_ROWS", "peaks_in_bands"]

BAND_ROWS = 1024  # rows per band: 2 x 10 halo rows recomputed per band at the paper preset (2 %)


def peaks_in_bands(
    grey: np.ndarray,
    spec: MeasureSpec,
    *,
    threshold: float,
    floor: float,
    nms_radius: int = 1,
    border: int = 0,
    mask: np.ndarray | None = None,
    max_corners: int | None = None,
    band_rows: int = BAND_ROWS,
    on_planes: PlanesHook | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rows, columns, values and quadratic offsets (dx, dy) of the peaks above ``threshold``.

    ``spec``: a :class:`~sogdd.measure.soddc.MeasureSpec` with a square window (equal or
    Gaussian weights). The points are those of
    ``select_peaks(soddc_measure(grey, spec, floor=floor),
    threshold=threshold, nms_radius=..., border=..., mask=..., max_corners=...)``
    (``floor <= threshold``), strongest first, and the offsets those of
    :func:`sogdd.select.subpixel.refine_quadratic` on that map. ``on_planes(top, lo, hi,
    planes)`` receives the filter responses of every tile the bands measure, as
    :func:`~sogdd.measure.soddc.soddc_measure`'s, in image rows, with ``lo .. hi - 1``
    the rows of the tile that are its band's own (each image row is in one band's
    own rows, and its responses there are the image's).
    """
    H, W = grey.shape
    rad = int(nms_radius)
    b = int(border)
    inner = bool(b) and 2 * b < H and 2 * b < W  # select_peaks: maxima of the valid area alone
    rlo, rhi, clo, chi = (b, H - b, b, W - b) if inner else (0, H, 0, W)
    m = spec.radius + spec.window_radius + 2
    halo = max(rad, 1)
    rows, cols, vals, offs = [], [], [], []
    for a in range(0, H, int(band_rows)):
        c = min(H, a + int(band_rows))
        lo, hi = max(0, a - halo), min(H, c + halo)  # rows whose values are used
        y0, y1 = max(0, lo - m), min(H, hi + m)
        hook = None
        if on_planes is not None:
            def hook(top, r0, r1, planes, y0=y0, a=a, c=c):
                on_planes(top + y0, max(r0 + y0, a), min(r1 + y0, c), planes)
        resp = soddc_measure(measure_rows(grey, y0, y1), spec, floor=floor, on_planes=hook)[lo - y0 : hi - y0]
        n0, n1 = max(a - rad, rlo), min(c + rad, rhi)
        if n1 <= n0 or chi <= clo:
            continue
        rr, cc = maxima_above(np.ascontiguousarray(resp[n0 - lo : n1 - lo, clo:chi]), float(threshold), rad)
        rr, cc = rr + n0, cc + clo
        own = (rr >= a) & (rr < c) & (rr >= b) & (rr < H - b) & (cc >= b) & (cc < W - b)
        rr, cc = rr[own], cc[own]
        if mask is not None:
            ok = np.asarray(mask, dtype=bool)[rr, cc]
            rr, cc = rr[ok], cc[ok]
        # the band's map has all rows a patch needs; at the image's first and last rows it is
        # the image's edge as well, so refine_quadratic moves edge patches inside exactly as on the map
        offs.append(refine_quadratic(resp, rr - lo, cc) if len(rr) else np.zeros((0, 2)))
        rows.append(rr)
        cols.append(cc)
        vals.append(resp[rr - lo, cc])
    if not rows:
        e = np.zeros(0, np.int64)
        return e, e, np.zeros(0), np.zeros((0, 2))
    rows, cols, vals, offs = (np.concatenate(rows), np.concatenate(cols), np.concatenate(vals),
                              np.concatenate(offs))
    sel = rank_peaks(vals, rows, cols, rad, max_corners)  # candidates in raster order, as select_peaks'
    return rows[sel], cols[sel], vals[sel], offs[sel]
