"""Why detectors fail on X-corners: the response around each corner, and refinement from the truth.

Two measurements behind the benchmark's numbers:

* :func:`response_ring`: for a response map ``R`` (e.g. :func:`sogdd.corner_response`)
  and each inner corner ``p``, the distance from ``p`` to the strongest pixel of
  ``R`` within ``c / 2`` (the *peak offset*) and the *dip* ``R(p) / max``, with
  ``R(p)`` interpolated bilinearly. A peak offset near 0 and a dip near 1 mean
  a maximum on the corner; a dip well below 1 with a peak offset of 1-2 px is a
  local minimum on the corner inside a ring of maxima.
* :func:`refine_from_truth`: ``cv2.cornerSubPix`` started *on* every true
  corner; the mean distance it moves away measures the refiner's own bias
  (the window sees the neighbouring corners once ``2 win + 1`` exceeds the
  cell).
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np

from .scenes import BoardScene, board_size, render_board

__all__ = ["response_ring", "refine_from_truth"]


def _bilinear(r: np.ndarray, xy: np.ndarray) -> np.ndarray:
    m = cv2.remap(r.astype(np.float32), xy[:, 0].astype(np.float32).reshape(-1, 1),
                  xy[:, 1].astype(np.float32).reshape(-1, 1), cv2.INTER_LINEAR)
    return m.reshape(-1).astype(np.float64)


def response_ring(response: Callable[[np.ndarray], np.ndarray], cell: float, *, psf: float = 0.7,
                  noise: float = 0.0, angle: float = 0.0, phases: int = 4, seed: int = 0) -> dict:
    """Peak offset and dip of ``response(image)`` at the inner corners (module doc).

    Returns ``{"peak_offset_mean", "peak_offset_p95", "dip_median", "n"}``; the
    statistics pool every inner corner of ``phases`` boards with random phases.

    Examples
    --------
    >>> import sogdd
    >>> r = response_ring(lambda im: sogdd.corner_response(im, preset="authors"), 16, psf=1.5, phases=1)
    >>> r["peak_offset_mean"] > 1.0 and r["dip_median"] < 0.5
    True
    """
    rng = np.random.default_rng(seed)
    offs, dips = [], []
    for _ in range(phases):
        s = BoardScene(float(cell), *board_size(cell), angle, tuple(rng.uniform(0, 1, 2)), psf, noise,
                       int(rng.integers(2**31)))
        rb = render_board(s)
        r = np.asarray(response(rb.image), dtype=np.float64)
        h, w = r.shape
        yy, xx = np.mgrid[0:h, 0:w]
        rad = cell / 2
        for x, y in rb.corners:
            x0, x1 = int(np.floor(x - rad)), int(np.ceil(x + rad)) + 1
            y0, y1 = int(np.floor(y - rad)), int(np.ceil(y + rad)) + 1
            win, wx, wy = r[y0:y1, x0:x1], xx[y0:y1, x0:x1], yy[y0:y1, x0:x1]
            inside = np.hypot(wx - x, wy - y) <= rad
            vals = np.where(inside, win, -np.inf)
            k = int(np.argmax(vals))
            offs.append(float(np.hypot(wx.flat[k] - x, wy.flat[k] - y)))
            top = float(vals.flat[k])
            dips.append(float(_bilinear(r, np.array([[x, y]]))[0] / top) if top > 0 else np.nan)
    offs_a = np.asarray(offs)
    return {"peak_offset_mean": float(offs_a.mean()), "peak_offset_p95": float(np.percentile(offs_a, 95)),
            "dip_median": float(np.nanmedian(dips)), "n": len(offs)}


def refine_from_truth(cell: float, *, win: int = 5, psf: float = 0.7, noise: float = 0.0,
                      angle: float = 0.0, phases: int = 4, seed: int = 0) -> dict:
    """Where ``cv2.cornerSubPix(winSize=(win, win))`` goes when started on the true corners.

    Returns ``{"mean_move", "p95_move", "n"}`` in px.

    Examples
    --------
    >>> refine_from_truth(16, phases=1)["mean_move"] < 0.05
    True
    """
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 100, 0.001)
    rng = np.random.default_rng(seed)
    moves = []
    for _ in range(phases):
        s = BoardScene(float(cell), *board_size(cell), angle, tuple(rng.uniform(0, 1, 2)), psf, noise,
                       int(rng.integers(2**31)))
        rb = render_board(s)
        p = rb.corners.astype(np.float32).reshape(-1, 1, 2)
        r = cv2.cornerSubPix(rb.image, p.copy(), (win, win), (-1, -1), crit).reshape(-1, 2)
        moves.append(np.hypot(*(r - rb.corners).T))
    m = np.concatenate(moves)
    return {"mean_move": float(m.mean()), "p95_move": float(np.percentile(m, 95)), "n": len(m)}
