"""Corners at the labels a grown lattice left free, measured where the lattice puts them.

The X-corner search misses a board's corner where the junction is no saddle at
its scale (the dark squares do not touch: over-exposure or blur bleeding the
light squares over it, strong blur at a fisheye's rim), and the lattice's
growth misses one whose X-corner lies beyond its search from a flat
prediction. :func:`_fill` predicts each free label next to the board from the
board's own curved map, refines the point symmetry there, and keeps the point
when its squares, its symmetry and its neighbours say it is the board's
corner; :func:`fill_board` adds the new corners to a board in the making.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..board import lattice_cells, median
from ..refine import MIN_HALF, WINDOW_FRACTION, half_widths, refine_grey
from .mapping import CHECK_TOL, check, label_grid, predict_labels
from .windows import (
    asymmetry_limit,
    bilinear,
    border_reach,
    deshaded,
    inner_corners,
    recut,
    star_refit,
)
from .xcorners import XCorners

__all__ = ["fill_board"]

#: rounds of :func:`_fill` (each may add a row of corners the last one made predictable)
FILL_ROUNDS = 4
#: Gauss-Newton steps for a filled corner: a prediction may lie most of a window (up to 20 px) away, and
#: the steps are damped to 0.5 px each
FILL_ITERATIONS = 60
#: the check's tolerance for a filled corner, in cells: its identity is tested by its squares
#: (:func:`_wedges`) and its window lies inside the frame, so only a point off the lattice by a good part
#: of a cell is left to the check; a corner of the board, extrapolated from one side, the map misses by
#: up to 0.2 of a cell at a fisheye's rim
FILL_TOL = 0.2
#: ... but beyond :data:`~.mapping.CHECK_TOL` (the grown corners' tolerance) only a corner as point symmetric as
#: the board's: asymmetry within this multiple of their median. A curved rim leaves a corner's symmetry
#: alone; an occluder or a smear that moved the point breaks it (the moved corners of the sweep's rendered
#: views: 5-14 times the board's median; the extrapolated rim corners of the real 180-degree fisheye set: 1)
FILL_SYMMETRY = 3.0
#: ... or under this asymmetry (a board without noise has a median near 0; the moved corners were 0.04 and more)
FILL_SYMMETRY_FLOOR = 0.02
#: a filled corner's X-junction contrast (:func:`_ring_contrast`), at least this share of the board's median
FILL_CONTRAST = 0.5


def _fill_labels(labels: np.ndarray, pattern: tuple[int, int] | None) -> np.ndarray:
    """The free labels next to the board (4-neighbours) that keep it within ``pattern``, (M, 2).

    Without a pattern, only those inside the board's bounding box (holes and notches). Sorted (row by row).
    """
    labels = np.asarray(labels, dtype=np.int64).reshape(-1, 2)
    lo, hi = labels.min(axis=0), labels.max(axis=0)
    occ = np.zeros(tuple(hi - lo + 3), dtype=bool)  # the bounding box and one label around it
    occ[labels[:, 0] - lo[0] + 1, labels[:, 1] - lo[1] + 1] = True
    near = np.zeros_like(occ)
    near[1:] |= occ[:-1]
    near[:-1] |= occ[1:]
    near[:, 1:] |= occ[:, :-1]
    near[:, :-1] |= occ[:, 1:]
    q = np.argwhere(near & ~occ) + lo - 1  # sorted as tuples
    if pattern is not None:
        ext = np.sort(np.maximum(hi, q) - np.minimum(lo, q) + 1, axis=1)
        keep = np.all(ext <= sorted(pattern), axis=1)
    else:
        keep = np.all((q >= lo) & (q <= hi), axis=1)
    return q[keep].reshape(-1, 2)


#: the four squares around a corner: their sides along ``(i, j)`` (``+1`` forward, ``-1`` back)
_QUADS = ((1, 1), (-1, -1), (1, -1), (-1, 1))
#: the labels :func:`_frame` reads around a corner: per axis forward, back, two forward, two back
_STEPS = np.array([(1, 0), (-1, 0), (2, 0), (-2, 0), (0, 1), (0, -1), (0, 2), (0, -2)])


def _frame(p: np.ndarray, at: np.ndarray, xy: np.ndarray, labels: np.ndarray,
           P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vectors from corners ``p`` (labels ``at``) to the centres of their four squares, and their cells.

    Per axis and side, the label step is measured to the corner there where it
    exists (``xy(i + 1, j) - p`` forward, ``p - xy(i - 1, j)`` back); else it is
    the other side's step, shrunk by the ratio of that step to the one before it
    (clipped to [0.3, 1.5]; cells shrink towards a fisheye's rim, where a map
    extrapolated from the board overshoots them), else the map's step from ``P``
    (n, 5, 2; :func:`sogdd.calib.targets.chessboard.mapping.predict_labels`). The square
    in quadrant ``(s_i, s_j)`` (:data:`_QUADS`) is centred ``(s_i f_i + s_j f_j) / 2``
    from the corner, ``f`` the steps on those sides. Returns ``(d (n, 4, 2), cell
    (n,))``, the cell the shortest of the four steps.
    """
    n = len(p)
    steps = np.zeros((n, 2, 2, 2))  # corner, axis, side (0 forward, 1 back), xy
    if n == 0:
        return np.zeros((0, 4, 2)), np.zeros(0)
    nbr = label_grid(labels, np.zeros(0, np.int64), _STEPS, at_labels=at)  # (n, 8): _STEPS' corners
    for ax in range(2):
        fwd, back, fwd2, back2 = (nbr[:, 4 * ax + t] for t in range(4))
        got = (xy[np.maximum(fwd, 0)] - p, -(xy[np.maximum(back, 0)] - p))  # the steps to the neighbours
        has = (fwd >= 0, back >= 0)
        # the step beyond a neighbour on the other side, shrunk by the ratio of the two steps there
        beyond = (np.where((back2 >= 0)[:, None], xy[np.maximum(back, 0)] - xy[np.maximum(back2, 0)], np.nan),
                  np.where((fwd2 >= 0)[:, None], xy[np.maximum(fwd, 0)] - xy[np.maximum(fwd2, 0)], np.nan))
        for side in (0, 1):
            o = got[1 - side]
            with np.errstate(invalid="ignore"):
                ratio = np.clip(np.hypot(o[:, 0], o[:, 1])
                                / np.maximum(np.hypot(beyond[side][:, 0], beyond[side][:, 1]), 1e-9), 0.3, 1.5)
            ratio = np.where(np.isnan(beyond[side][:, 0]), 1.0, ratio)
            steps[:, ax, side] = np.where(has[side][:, None], got[side],
                                          np.where(has[1 - side][:, None], o * ratio[:, None],
                                                   P[:, 1 + 2 * ax] - P[:, 2 + 2 * ax]))
    d = np.stack([(si * steps[:, 0, (1 - si) // 2] + sj * steps[:, 1, (1 - sj) // 2]) / 2 for si, sj in _QUADS],
                 axis=1)
    return d, np.min(np.hypot(steps[..., 0], steps[..., 1]), axis=(1, 2))


def _wedges(grey: np.ndarray, p: np.ndarray, d: np.ndarray,
            labels: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which diagonal of each corner is light, and how much: the image inside its four squares.

    ``d`` (n, 4, 2): vectors from the corners ``p`` to the centres of the
    squares in the quadrants of :data:`_QUADS` (:func:`_frame`). Returns
    ``(light_pp, contrast, angle)``: whether the squares in ``(+i, +j)`` and
    ``(-i, -j)`` are the light ones (it turns with each label step, so
    ``light_pp XOR (i + j odd)`` is one value on a board); the smallest
    ``min(light samples) - max(dark samples)`` at ``p + s d``, ``s = 0.45, 0.7``
    (the four wedges' contrast, beyond a gap where the dark squares do not
    touch, inside the squares however sheared and small they are); the angle of
    the light diagonal in ``[0, pi)``.
    """
    v = {t: bilinear(grey, p[:, None, :] + t * d) for t in (0.45, 0.7)}  # (n, 4)
    pp = v[0.7][:, :2].mean(axis=1) > v[0.7][:, 2:].mean(axis=1)
    con = np.full(len(p), np.inf)
    for vt in v.values():
        hi = np.where(pp, vt[:, :2].min(axis=1), vt[:, 2:].min(axis=1))
        lo = np.where(pp, vt[:, 2:].max(axis=1), vt[:, :2].max(axis=1))
        con = np.minimum(con, hi - lo)
    diag = np.where(pp[:, None], d[:, 0] - d[:, 1], d[:, 2] - d[:, 3])
    return pp ^ (labels.sum(axis=1) % 2 == 1), con, np.mod(np.arctan2(diag[:, 1], diag[:, 0]), np.pi)


def _predicted(grey: np.ndarray, xy: np.ndarray, labels: np.ndarray, pattern: tuple[int, int] | None,
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The free labels to try (:func:`_fill_labels`), the lattice's map there (n, 5, 2) and the local cells.

    Only labels the map reaches and whose window (0.65 of the cell) lies inside the frame.
    """
    H, W = grey.shape
    cand = _fill_labels(labels, pattern)
    P = predict_labels(xy, labels, cand)
    ok = np.isfinite(P).all(axis=(1, 2))
    cand, P = cand[ok], P[ok]
    p = P[:, 0]
    cell = _frame(p, cand, xy, labels, P)[1]
    room = np.min(np.column_stack([p, W - 1 - p[:, 0], H - 1 - p[:, 1]]), axis=1)  # np.c_'s array, cheaper
    ok = (cell > 2 * MIN_HALF) & (room >= WINDOW_FRACTION * cell + 2)
    return cand[ok], P[ok], cell[ok]


def _measured(grey: np.ndarray, xy: np.ndarray, labels: np.ndarray, cand: np.ndarray, p: np.ndarray,
              cell: np.ndarray, thr: float) -> tuple[np.ndarray, np.ndarray]:
    """The point symmetry refined from the predictions ``p``: positions and qualities.

    The windows of a border corner (:func:`sogdd.calib.targets.chessboard.windows.recut`, and its
    star window where the square stays asymmetric:
    :func:`sogdd.calib.targets.chessboard.windows.star_refit`); where the asymmetry exceeds ``thr``
    (a shadow or a reflection over the squares), also measured unshaded
    (:func:`sogdd.calib.targets.chessboard.windows.deshaded`), the better fit kept.
    """
    half = half_widths(p, None, cell)
    r, q = refine_grey(grey, p, half, half.astype(np.float64), iterations=FILL_ITERATIONS)
    at = np.where(q[:, None] > 0, r, p)
    reach = border_reach(grey, at, cand, cell, also=np.ones(len(cand), bool))
    recut(grey, at, r, q, half, reach)
    star_refit(grey, at, r, q, half, reach, 1.0 - q > thr)
    shaded = 1.0 - q > thr
    if not shaded.any():  # the board's own windows are needed for the unshaded measure only
        return r, q
    cells = lattice_cells(xy, labels)
    inner = inner_corners(labels) & np.isfinite(cells)
    ref = np.flatnonzero(inner if np.count_nonzero(inner) >= 5 else np.isfinite(cells))
    if len(ref):
        rd, qd = deshaded(grey, p[shaded], half[shaded], xy[ref], half_widths(xy[ref], None, cells[ref]),
                           median(cells[ref]))
        better = qd > q[shaded]
        k = np.flatnonzero(shaded)[better]
        r[k], q[k] = rd[better], qd[better]
    return r, q


def _board_wedges(grey: np.ndarray, xy: np.ndarray, labels: np.ndarray) -> tuple[bool, float] | None:
    """The board's own squares (:func:`_wedges`): its ``light_pp XOR (i + j odd)`` and median contrast."""
    P = predict_labels(xy, labels, labels)
    ok = np.isfinite(P).all(axis=(1, 2))
    if not ok.any():
        return None
    d, _ = _frame(xy[ok], labels[ok], xy, labels, P[ok])
    par, con, _ = _wedges(grey, xy[ok], d, labels[ok])
    return bool(np.count_nonzero(par) * 2 > len(par)), median(con)


def _fill(grey: np.ndarray, xy: np.ndarray, labels: np.ndarray, quality: np.ndarray,
          light: np.ndarray, pattern: tuple[int, int] | None,
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Corners at the labels the lattice did not reach, measured where the lattice puts them.

    For each free label next to the board (:func:`_fill_labels`: within the
    pattern, or inside the board without one) the board's second-order map
    predicts the position (:func:`sogdd.calib.targets.chessboard.mapping.predict_labels`),
    the point symmetry is refined from there (:func:`_measured`: the window of a
    border corner, and the image unshaded where a shadow breaks the symmetry),
    and the point is kept when it is a board corner as the others are: its
    window lies inside the frame (:func:`_predicted`), its asymmetry within
    :func:`sogdd.calib.targets.chessboard.windows.asymmetry_limit` of the board's median, its
    light squares where the label's parity puts them and the contrast of its
    four wedges at least :data:`FILL_CONTRAST` of the board's median (both
    measured along the lattice's local steps, :func:`_frame` and
    :func:`_wedges`: at a fisheye's rim the cells are too sheared and small for
    an X-corner's own light axis), at least half a cell from every other
    corner, and the check of its neighbours within :data:`~.mapping.CHECK_TOL`, or within
    :data:`FILL_TOL` for a corner as symmetric as the board's (:data:`FILL_SYMMETRY`,
    :data:`FILL_SYMMETRY_FLOOR`)
    (:func:`sogdd.calib.targets.chessboard.mapping.check`). Up to :data:`FILL_ROUNDS`
    rounds; returns ``xy, labels, quality, light`` with the new corners
    appended (``light``: the angle of the light diagonal).
    """
    asym = median(1.0 - quality)
    thr = asymmetry_limit(asym)
    ref: tuple[bool, float] | None = None  # the board's own wedges, measured once a candidate needs them
    for _ in range(FILL_ROUNDS):
        cand, P, cell = _predicted(grey, xy, labels, pattern)
        if len(cand) == 0:
            break
        r, q = _measured(grey, xy, labels, cand, P[:, 0], cell, thr)
        keep = (q > 0) & (1.0 - q <= thr) & (cKDTree(xy).query(r)[0] > 0.5 * cell)
        if keep.any() and ref is None:
            ref = _board_wedges(grey, xy, labels)
        if not keep.any() or ref is None:
            break
        par, con, lt = _wedges(grey, r, _frame(r, cand, xy, labels, P)[0], cand)
        keep &= (par == ref[0]) & (con >= FILL_CONTRAST * ref[1])
        if keep.sum() > 1:  # two labels on one point: neither
            d, _ = cKDTree(r[keep]).query(r[keep], k=2)
            keep[np.flatnonzero(keep)[d[:, 1] < 0.5 * cell[keep]]] = False
        good = _on_lattice(np.r_[xy, r[keep]], np.r_[labels, cand[keep]], np.r_[quality, q[keep]], len(xy),
                           asym)
        if not good.any():
            break
        sel = np.flatnonzero(keep)[good]
        xy, labels = np.r_[xy, r[sel]], np.r_[labels, cand[sel]]
        quality, light = np.r_[quality, q[sel]], np.r_[light, lt[sel]]
    return xy, labels, quality, light


def _on_lattice(xy: np.ndarray, labels: np.ndarray, quality: np.ndarray, n0: int, asym: float) -> np.ndarray:
    """Whether each corner from ``n0`` on is where its neighbours put it: the check within
    :data:`~.mapping.CHECK_TOL`, or within :data:`FILL_TOL` for a corner whose asymmetry is within
    :data:`FILL_SYMMETRY` times the board's median ``asym`` (or :data:`FILL_SYMMETRY_FLOOR`)."""
    new = np.arange(n0, len(xy))
    good = check(xy, labels, tol=CHECK_TOL, only=new)[n0:]
    near = ~good & (1.0 - quality[n0:] <= max(FILL_SYMMETRY * asym, FILL_SYMMETRY_FLOOR))
    if near.any():
        good[near] = check(xy, labels, tol=FILL_TOL, only=new[near])[new[near]]
    return good


def fill_board(grey: np.ndarray, xc: XCorners, idx: np.ndarray, xy: np.ndarray, labels: np.ndarray,
            quality: np.ndarray, pattern: tuple[int, int] | None,
            ) -> tuple[XCorners, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The board with :func:`_fill`'s corners, which join ``xc`` as X-corners of their own (``idx``)."""
    n0 = len(xy)
    xy, labels, quality, light = _fill(grey, xy, labels, quality, xc.light[idx], pattern)
    extra = len(xy) - n0
    if extra:
        strength = np.full(extra, np.median(xc.strength[idx]))
        xc = XCorners(np.r_[xc.xy, xy[n0:]], np.r_[xc.strength, strength], np.r_[xc.light, light[n0:]],
                      np.r_[xc.spread, np.full(extra, np.pi / 4)])
        idx = np.r_[idx, len(xc) - extra + np.arange(extra)]
    return xc, idx, xy, labels, quality
