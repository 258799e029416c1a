"""The saddle points of :func:`sogdd.saddles.find_saddles` in bands of rows, without image-sized maps.

:func:`~sogdd.saddles.find_saddles` filters the whole image into five float64
derivative maps (and three more for the strength and its maxima): 1.5 GB at
24 MP. Every step is local, so the same points come band by band:

- the derivatives of a crop of full rows are those of the image, bit for bit,
  on every row at least ``radius`` rows from a crop edge that is not the
  image's (OpenCV's separable filter computes each pixel from the same values
  in the same order; tested), so a band's maps are exact on ``halo`` rows
  beyond the band;
- the strength and its 3 x 3 maxima on the band's rows read rows +-1 only;
- each Newton step reads the maps on two rows (bilinear interpolation). A point
  whose step needs a row outside the band's exact rows (it wandered more than
  ``halo`` rows; almost always refused in the end) continues afterwards on crops
  filtered around the rows it reads (:func:`_finish`), so its path is the full maps' path.

Candidates keep the raster order of the full maps; the result is
``find_saddles(grey, ...)`` exactly, with maps of ``band_rows + 2 (halo +
radius)`` rows. ``grey`` may be a :class:`sogdd._grey_rows.GreyRows`.
"""

from __future__ import annotations

import cv2
import numpy as np

from .saddles import bilinear_rows, derivatives

__all__ = ["saddles_in_bands"]

BAND_ROWS = 256
HALO = 16


def _rows_of(y: np.ndarray, H: int) -> tuple[np.ndarray, np.ndarray]:
    """The two rows the bilinear interpolation of :func:`sogdd.saddles.bilinear_rows` reads at ``y``."""
    yc = np.clip(y, 0.0, H - 1.0)
    y0 = np.minimum(np.floor(yc).astype(np.int64), H - 2 if H > 1 else 0)
    return y0, np.minimum(y0 + 1, H - 1)


def _newton_step(vals: list[np.ndarray], x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One step of :func:`sogdd.saddles.find_saddles` from ``(g_x, g_y, g_xx, g_xy, g_yy)`` at the points."""
    px, py, a, b, c = vals
    det = a * c - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        dx = -(c * px - b * py) / det
        dy = -(a * py - b * px) / det
    return x + np.where(np.isfinite(dx), dx, 9.0), y + np.where(np.isfinite(dy), dy, 9.0)


def _finish(grey, sigma2: float, r: int, x: np.ndarray, y: np.ndarray, steps: np.ndarray, iterations: int,
            band_rows: int) -> tuple[np.ndarray, np.ndarray]:
    """Newton steps of the points that left their band, until each has done ``iterations``.

    Each round sorts the points by the rows they read and filters crops of at most
    ``band_rows`` rows (plus ``r`` on each side) around groups of them, so memory stays
    that of a band however far the points went.
    """
    H, W = grey.shape
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
            maps = [m[glo - c0 : ghi + 1 - c0] for m in derivatives(np.asarray(grey[c0:c1]), sigma2, r)]
            x[sel], y[sel] = _newton_step(bilinear_rows(maps, glo, H, W, x[sel], y[sel]), x[sel], y[sel])
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
    thr = max(float(min_strength), 0.0)
    cand_x, cand_y, cand_s = [], [], []
    done_xy, done_idx, stray = [], [], []  # stray: (candidate index, x, y, steps done)
    n0 = 0
    for a in range(0, H, int(band_rows)):
        c = min(H, a + int(band_rows))
        ea, eb = max(0, a - halo), min(H, c + halo)  # rows where the band's maps are the image's
        y0, y1 = max(0, ea - r), min(H, eb + r)
        d = derivatives(np.asarray(grey[y0:y1]), sigma2, r)
        maps = [m[ea - y0 : eb - y0] for m in d]  # g_x, g_y, g_xx, g_xy, g_yy on rows ea .. eb - 1
        gxx, gxy, gyy = maps[2], maps[3], maps[4]
        neg = gxy * gxy - gxx * gyy
        s = sigma2 * np.sqrt(np.maximum(neg, 0.0))
        dil = cv2.dilate(s, np.ones((3, 3), np.uint8), borderType=cv2.BORDER_REPLICATE)
        own = s[a - ea : c - ea]
        rows, cols = np.nonzero((own >= dil[a - ea : c - ea]) & (own > thr))
        del neg, dil
        idx = n0 + np.arange(len(rows))
        n0 += len(rows)
        x0, yy0 = cols.astype(np.float64), (rows + a).astype(np.float64)
        cand_x.append(x0)
        cand_y.append(yy0)
        cand_s.append(own[rows, cols])
        x, y = x0.copy(), yy0.copy()
        for step in range(int(iterations)):
            lo, hi = _rows_of(y, H)
            out = (lo < ea) | (hi >= eb)
            if out.any():
                stray += [(i, xi, yi, step) for i, xi, yi in zip(idx[out], x[out], y[out])]
                x, y, idx = x[~out], y[~out], idx[~out]
            x, y = _newton_step(bilinear_rows(maps, ea, H, W, x, y), x, y)
        done_xy.append(np.stack([x, y], axis=1))
        done_idx.append(idx)
    if n0 == 0:
        return np.zeros((0, 2)), np.zeros(0)
    cx, cy, cs = np.concatenate(cand_x), np.concatenate(cand_y), np.concatenate(cand_s)
    fin = np.empty((n0, 2))
    di = np.concatenate(done_idx)
    fin[di] = np.concatenate(done_xy)
    if stray:  # (candidate index, x, y, steps done)
        i, sx, sy, st = (np.array(v) for v in zip(*stray))
        sx, sy = _finish(grey, sigma2, r, sx.astype(np.float64), sy.astype(np.float64), st.astype(np.int64),
                         int(iterations), int(band_rows))
        fin[i.astype(np.int64)] = np.stack([sx, sy], axis=1)
    ok = (np.abs(fin[:, 0] - cx) <= 1.0) & (np.abs(fin[:, 1] - cy) <= 1.0)
    return fin[ok], cs[ok]
