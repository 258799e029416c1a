"""Whether a grown, refined lattice is a board: the acceptance tests of the chessboard search.

A board's links run along edges between dark and light squares (:func:`edge_links`),
it leaves few strong X-corners inside its outline unused (:func:`orphans`: a
lattice of wrong steps leaves most of them out), it holds a complete 3 x 3 block
(:func:`has_block`), and a board proposed by OpenCV for a pattern does not go on
beyond its sides (:func:`extends`: a part of a larger grid).
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy.spatial import cKDTree

from ..board import Board, label_neighbours, lattice_cells, median
from ..refine import half_widths, refine_grey
from .mapping import predict_labels
from .windows import asymmetry_limit, bilinear
from .xcorners import SIGMA2, XCorners, hessian_at, junction_strength

__all__ = ["EDGE_CONTRAST", "EDGE_SHARE", "MAX_ORPHANS", "edge_links", "extends", "has_block", "orphans",
           "ring_contrast"]


#: a link's contrast across it, relative to the median of the board's links along its axis (:func:`edge_links`)
EDGE_CONTRAST = 0.3


#: the share of a board's links that must run along edges
EDGE_SHARE = 0.8


#: strong X-corners inside a board's outline that are not its corners, per board corner (:func:`orphans`)
MAX_ORPHANS = 0.25


def edge_links(grey: np.ndarray, xy: np.ndarray, labels: np.ndarray) -> tuple[float, np.ndarray]:
    """The share of lattice links that run along an edge, and the corners with at least one such link.

    A link between label neighbours ``p, q`` of a true board runs along an edge
    between a dark and a light square: at ``t = 1/4, 1/2, 3/4`` of the way the
    image differs across the link, ``I(m + d) - I(m - d)``, with ``d`` 0.15 of the
    lattice's step across the link (the mean of the steps at its two ends; at
    least 1 px; far enough from the edge that a blur of a fifth of a cell leaves
    most of the contrast against the noise, and within the 0.2 of a cell a code
    printed in the squares keeps clear). Along that step, not the link's normal,
    the samples stay in the two squares beside the link however skewed the
    cells: on a board tilted 75 degrees about its diagonal the steps meet at 157
    degrees, and a sample 0.15 of a link off its normal a quarter of the way
    along lies across the other edge through the corner. Where neither end has a
    neighbour across, ``d`` is 0.15 of the link along its normal. The differences have one sign and at least
    :data:`EDGE_CONTRAST` of the median difference of the board's links along the
    same axis (``i`` or ``j``), or of the strongest link of that axis at either of
    its ends where that is less: a motion blur smears the edges across it and a tilt
    shortens the links of one axis, which lowers that axis's contrast (by 3.5
    times under an 18 px smear) and not the other's; light falling unevenly on the
    board lowers it over a part of the board (a linear camera's dim corner has a
    third of the median contrast). A grid that links
    corners across squares (a lattice of wrong steps, e.g. a knight's move of a
    board blurred beyond recognition) fails it at ``t = 1/4`` or ``3/4``.
    """
    nb4 = label_neighbours(labels)
    nb = nb4[:, ::2]  # (+1, 0) and (0, +1): each link once
    k, a = np.nonzero(nb >= 0)
    pairs = np.stack([k, nb[k, a]], axis=1)
    if len(pairs) == 0:
        return 0.0, np.zeros(len(xy), dtype=bool)
    p, q = xy[pairs[:, 0]], xy[pairs[:, 1]]
    v = q - p
    length = np.hypot(v[:, 0], v[:, 1])
    n = np.stack([-v[:, 1], v[:, 0]], axis=1) / np.maximum(length, 1e-9)[:, None]
    d = np.maximum(0.15 * length, 1.0)[:, None] * n
    w = _across(xy, nb4, pairs, a)
    has_w = np.isfinite(w).all(axis=1)
    wl = np.hypot(w[has_w, 0], w[has_w, 1])
    d[has_w] = np.maximum(0.15 * wl, 1.0)[:, None] * w[has_w] / np.maximum(wl, 1e-9)[:, None]
    diff = np.stack([bilinear(grey, p + t * v + d) - bilinear(grey, p + t * v - d)
                     for t in (0.25, 0.5, 0.75)])
    mid = np.abs(diff[1])
    scale = np.zeros(len(a))
    for axis in (0, 1):
        on = a == axis
        scale[on] = median(mid[on]) if on.any() else 0.0
    # ... and at most the strongest of its axis's links at either end: a board lit unevenly, seen by a camera
    # whose response is not linear, has its edges' contrast vary over it, and its dim part keeps its links
    near = np.zeros((len(xy), 2))
    np.maximum.at(near, (pairs[:, 0], a), mid)
    np.maximum.at(near, (pairs[:, 1], a), mid)
    scale = np.minimum(scale, np.maximum(near[pairs[:, 0], a], near[pairs[:, 1], a]))
    ok = (np.abs(diff) >= EDGE_CONTRAST * scale).all(axis=0) & (np.sign(diff) == np.sign(diff[1])).all(axis=0)
    ok &= scale > 0
    has = np.zeros(len(xy), dtype=bool)
    has[pairs[ok].ravel()] = True
    return float(np.mean(ok)), has


def _across(xy: np.ndarray, nb4: np.ndarray, pairs: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """For each link ``pairs`` along ``axis`` (0: ``i``, 1: ``j``), the lattice's step across it: the mean of
    the steps along the other axis at its two ends (towards ``+j`` or ``+i``), (n, 2); NaN where neither end
    has a neighbour across."""
    plus, minus = np.where(axis == 0, 2, 0), np.where(axis == 0, 3, 1)
    total, count = np.zeros((len(pairs), 2)), np.zeros(len(pairs))
    for end in (0, 1):
        c = pairs[:, end]
        for col, sign in ((plus, 1.0), (minus, -1.0)):
            o = nb4[c, col]
            ok = o >= 0
            total[ok] += sign * (xy[o[ok]] - xy[c[ok]])
            count[ok] += 1
    with np.errstate(invalid="ignore", divide="ignore"):
        return total / count[:, None]


def ring_contrast(grey: np.ndarray, xy: np.ndarray, light: np.ndarray, cell: float) -> np.ndarray:
    """How much the light wedges of X-corners stay lighter than the dark ones out to a third of a cell.

    With ``u`` the light axis and ``v`` perpendicular to it (the dark wedges'
    bisector), at radii ``r = (0.15, 0.3) cell``:
    ``c = min_r [min(I(p +- r u)) - max(I(p +- r v))]``. A board's corner keeps
    its full contrast at both radii (its wedges are squares a cell wide); a
    saddle between the dots or bits of a code inside a white square is light all
    round a few pixels out, so its ``c`` is small or negative.
    """
    u = np.stack([np.cos(light), np.sin(light)], axis=1)
    v = np.stack([-u[:, 1], u[:, 0]], axis=1)
    out = np.full(len(xy), np.inf)
    for r in (0.15 * cell, 0.3 * cell):
        lo = np.minimum(bilinear(grey, xy + r * u), bilinear(grey, xy - r * u))
        hi = np.maximum(bilinear(grey, xy + r * v), bilinear(grey, xy - r * v))
        out = np.minimum(out, lo - hi)
    return out


def orphans(grey: np.ndarray, xc: XCorners, idx: np.ndarray, xy: np.ndarray, cells: np.ndarray,
             grown: np.ndarray | None = None) -> float:
    """Strong X-corners inside the board's outline that are none of its corners, per board corner.

    A true board uses every inner corner in its outline; a lattice of wrong steps
    (a knight's move, a diagonal) leaves most of them out. Only X-corners with
    the wedges of a board corner count (:func:`ring_contrast` at least half the
    board's median): the saddles between the dots of a code inside a white
    square (ECoCheck, ChArUco's markers) are strong but light all round. The
    X-corners ``grown`` (indices into ``xc``: the lattice as grown, before the
    refinement and the check dropped some of it) are not left out by the
    lattice and do not count: a corner dropped for its asymmetry (an occluder,
    a code in its squares) says nothing about the lattice's steps.
    """
    hull = cv2.convexHull(xy.astype(np.float32)).reshape(-1, 2)
    strong = xc.strength >= 0.5 * median(xc.strength[idx])
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    cand = np.flatnonzero(strong & np.all((xc.xy >= lo) & (xc.xy <= hi), axis=1))
    if grown is not None:  # np.setdiff1d's result (cand is sorted and unique), by a mask
        out = np.ones(len(xc), dtype=bool)
        out[grown] = False
        cand = cand[out[cand]]
    cell = median(cells[np.isfinite(cells)]) if np.isfinite(cells).any() else 1.0
    d, _ = cKDTree(xy).query(xc.xy[cand])
    cand = cand[d > 0.3 * cell]
    if len(cand):
        own = median(ring_contrast(grey, xy, xc.light[idx], cell))
        cand = cand[ring_contrast(grey, xc.xy[cand], xc.light[cand], cell) >= 0.5 * max(own, 1e-9)]
    inside = [cv2.pointPolygonTest(hull, (float(x), float(y)), True) > 0.3 * cell for x, y in xc.xy[cand]]
    return float(np.count_nonzero(inside)) / max(len(xy), 1)


def has_block(labels: np.ndarray) -> bool:
    s = {tuple(q) for q in labels.tolist()}
    return any(all((i + a, j + b) in s for a in (-1, 0, 1) for b in (-1, 0, 1)) for i, j in s)


def extends(grey: np.ndarray, board: Board) -> bool:
    """Whether the grid goes on beyond a side of the board: a part of a larger board.

    The labels one step beyond each side are put where the board's map puts
    them (:func:`sogdd.calib.targets.chessboard.mapping.predict_labels`) and refined there; a side
    continues when at least half of them are X-junctions like the board's own:
    saddle strength (:func:`sogdd.calib.targets.chessboard.xcorners.junction_strength`) at least
    half the board's median, and point-symmetric within the board's limit
    (:func:`sogdd.calib.targets.chessboard.windows.symmetric`'s rule). Beyond a board's last corners
    lie the edges of its outer squares and the paper: no X-junction.
    """
    xy, labels = board.image_points, board.labels
    lo, hi = labels.min(axis=0), labels.max(axis=0)
    cols, rows = range(lo[0], hi[0] + 1), range(lo[1], hi[1] + 1)
    sides = [[(lo[0] - 1, j) for j in rows], [(hi[0] + 1, j) for j in rows],
             [(i, lo[1] - 1) for i in cols], [(i, hi[1] + 1) for i in cols]]
    cells = lattice_cells(xy, labels)
    cell = median(cells[np.isfinite(cells)]) if np.isfinite(cells).any() else 0.0
    own_half = half_widths(xy, None, np.where(np.isfinite(cells), cells, cell))
    _, q_own = refine_grey(grey, xy, own_half, own_half.astype(np.float64), iterations=1)
    limit = asymmetry_limit(median(1.0 - q_own))
    strong = 0.5 * median(junction_strength(hessian_at(grey, xy, np.sqrt(SIGMA2))))
    H, W = grey.shape
    for side in sides:
        P = predict_labels(xy, labels, np.array(side))[:, 0]
        room = np.min(np.c_[P, W - 1 - P[:, 0], H - 1 - P[:, 1]], axis=1)
        P = P[np.isfinite(room) & (room > 0.5 * cell)]
        if len(P) < max(2, len(side) // 2):
            continue
        half = half_widths(P, None, np.full(len(P), cell))
        r, q = refine_grey(grey, P, half, 0.5 * half.astype(np.float64))
        s_side = junction_strength(hessian_at(grey, r, np.sqrt(SIGMA2)))
        like = (q > 0) & (1.0 - q <= limit) & (s_side >= strong)
        if np.count_nonzero(like) >= max(2, len(side) / 2):
            return True
    return False
