"""The saddle points of :func:`sogdd.saddles.find_saddles` in bands of rows, without image-sized maps.

:func:`~sogdd.saddles.find_saddles` filters the whole image into three float64
derivative maps (and one more for the strength): 1.5 GB at
24 MP. Every step is local, so the same points come band by band:

- the derivatives of a crop of full rows are those of the image, bit for bit,
  on every row at least ``radius`` rows from a crop edge that is not the
  image's (OpenCV's separable filter computes each pixel from the same values
  in the same order; tested), so a band's maps are exact on ``halo`` rows
  beyond the band;
- the strength and its 3 x 3 maxima on the band's rows read rows +-1 only;
- each Newton step reads the maps on two rows (bilinear interpolation), and the
  grey crop ``radius`` rows beyond them (the gradient at those pixels). A point
  whose step needs a row outside the band's exact rows (it wandered more than
  ``halo`` rows; almost always refused in the end) continues afterwards on crops
  filtered around the rows it reads (:func:`_finish`), so its path is the full maps' path.

Candidates keep the raster order of the full maps; the result is
``find_saddles(grey, ...)`` exactly, with three maps of ``band_rows + 2 halo``
rows and a grey crop of ``band_rows + 2 (halo + radius)`` rows. ``grey`` may be a
:class:`sogdd._grey_rows.GreyRows`.
"""

from __future__ import annotations

import numpy as np

from ._saddle_kernels import strength_maxima
from .filters import steerable_basis
from .saddles import newton_step, second_derivatives, strength_floor

__all__ = ["saddles_in_bands"]

BAND_ROWS = 512  # OpenCV filters a crop of fewer rows on one thread only
HALO = 16


def _rows_of(y: np.ndarray, H: int) -> tuple[np.ndarray, np.ndarray]:
    """The two rows the bilinear interpolation of :func:`sogdd.saddles.bilinear_rows` reads at ``y``."""
    yc = np.clip(y, 0.0, H - 1.0)
    y0 = np.minimum(np.floor(yc).astype(np.int64), H - 2 if H > 1 else 0)
    return y0, np.minimum(y0 + 1, H - 1)


def _finish(grey, sigma2: float, r: int, x: np.ndarray, y: np.ndarray, steps: np.ndarray, iterations: int,
            band_rows: int) -> tuple[np.ndarray, np.ndarray]:
    """Newton steps of the points that left their band, until each has done ``iterations``.

    Each round sorts the points by the rows they read and filters crops of at most
    ``band_rows`` rows (plus ``r`` on each side) around groups of them, so memory stays
    that of a band however far the points went.
    """
    H, W = grey.shape
    basis = steerable_basis(sigma2, r)
    x, y, steps = x.copy(), y.copy(), steps.copy()
    act = np.flatnonzero(steps < iterations)
    while len(act):
        lo, hi = _rows_of(y[act], H)
        order = np.argsort(lo, kind="stable")
        g0 = 0
        while g0 < len(order):
            glo = int(lo[order[g0]])
            g1 = g0
            while g1 < len(order) and (g1 == g0 or hi[order[g1]] < glo + band_rows):
                g1 += 1
            sel = act[order[g0:g1]]
            ghi = int(hi[order[g0:g1]].max())
            c0, c1 = max(0, glo - r), min(H, ghi + 1 + r)  # rows glo .. ghi are the image's
            crop = np.ascontiguousarray(grey[c0:c1], dtype=np.float64)
            maps = [m[glo - c0 : ghi + 1 - c0] for m in second_derivatives(crop, sigma2, r)]
            x[sel], y[sel] = newton_step(maps, glo, crop, c0, (H, W), x[sel], y[sel], basis)
            g0 = g1
        steps[act] += 1
        act = act[steps[act] < iterations]
    return x, y


def saddles_in_bands(grey, sigma2: float, radius: int, *, iterations: int = 4, min_strength: float = 0.0,
                     band_rows: int = BAND_ROWS, halo: int = HALO) -> tuple[np.ndarray, np.ndarray]:
    """``find_saddles(grey, sigma2, radius, iterations=..., min_strength=...)`` in bands (module doc)."""
    H, W = grey.shape
    r = int(radius)
    halo = max(int(halo), 1)
    t_n = strength_floor(sigma2, min_strength)
    basis = steerable_basis(sigma2, r)
    cand_x, cand_y, cand_n = [], [], []
    done_xy, done_idx, stray = [], [], []  # stray: (candidate index, x, y, steps done)
    n0 = 0
    for a in range(0, H, int(band_rows)):
        c = min(H, a + int(band_rows))
        ea, eb = max(0, a - halo), min(H, c + halo)  # rows where the band's maps are the image's
        y0, y1 = max(0, ea - r), min(H, eb + r)
        crop = np.ascontiguousarray(grey[y0:y1], dtype=np.float64)
        maps = [m[ea - y0 : eb - y0] for m in second_derivatives(crop, sigma2, r)]  # rows ea .. eb - 1
        rows, cols, n = strength_maxima(*maps, top=ea, height=H, first=a - ea, last=c - ea, t_n=t_n)
        idx = n0 + np.arange(len(rows))
        n0 += len(rows)
        x0, yy0 = cols.astype(np.float64), rows.astype(np.float64)
        cand_x.append(x0)
        cand_y.append(yy0)
        cand_n.append(n)
        x, y = x0.copy(), yy0.copy()
        for step in range(int(iterations)):
            lo, hi = _rows_of(y, H)
            out = (lo < ea) | (hi >= eb)
            if out.any():
                stray += [(i, xi, yi, step) for i, xi, yi in zip(idx[out], x[out], y[out])]
                x, y, idx = x[~out], y[~out], idx[~out]
            x, y = newton_step(maps, ea, crop, y0, (H, W), x, y, basis)
        done_xy.append(np.stack([x, y], axis=1))
        done_idx.append(idx)
    if n0 == 0:
        return np.zeros((0, 2)), np.zeros(0)
    cx, cy, cn = np.concatenate(cand_x), np.concatenate(cand_y), np.concatenate(cand_n)
    fin = np.empty((n0, 2))
    di = np.concatenate(done_idx)
    fin[di] = np.concatenate(done_xy)
    if stray:  # (candidate index, x, y, steps done)
        i, sx, sy, st = (np.array(v) for v in zip(*stray))
        sx, sy = _finish(grey, sigma2, r, sx.astype(np.float64), sy.astype(np.float64), st.astype(np.int64),
                         int(iterations), int(band_rows))
        fin[i.astype(np.int64)] = np.stack([sx, sy], axis=1)
    ok = (np.abs(fin[:, 0] - cx) <= 1.0) & (np.abs(fin[:, 1] - cy) <= 1.0)
    return fin[ok], sigma2 * np.sqrt(cn[ok])
