"""A board's corners refined: windows that stop at the board's edge, shading taken out, the symmetry test.

:func:`refine_board` refines every corner of a grown lattice to its centre of
point symmetry (:func:`sogdd.calib.targets.refine.refine_grey`) with a window of
0.65 of its local cell (:func:`sogdd.calib.targets.board.lattice_cells`), cut for the corners on the
border and for those far less point-symmetric than the board's others to where
the squares around them are point-symmetric (:func:`edge_halves`,
:func:`recut`); those still far less symmetric are measured again on the image
divided by its light envelope (:func:`deshaded`: a shadow or a reflection over
part of a square), and, failing that, judged against the board's corners seen
through the same cut window (:func:`same_window`: noise makes a small window's
asymmetry large). :func:`symmetric` then keeps the corners
whose asymmetry ``1 - quality`` is within :func:`asymmetry_limit` of the board's
median.
"""

from __future__ import annotations

import math

import cv2
import numba
import numpy as np

from sogdd._jit import EXACT_JIT

from ..board import label_neighbours, lattice_cells, median
from ..refine import MAX_WINDOW, MIN_HALF, REACH_DIRS, half_widths, refine_grey

__all__ = ["ASYMMETRY", "MIN_ASYMMETRY", "asymmetry_limit", "bilinear", "border_reach", "deshaded",
           "edge_halves", "inner_corners", "recut", "refine_board", "same_window", "square_within",
           "star_refit", "symmetric"]

#: a refined corner is dropped when its asymmetry ``1 - quality`` exceeds this multiple of the board's median
ASYMMETRY = 10.0
#: ... unless it is below this (a board without noise has a median near 0)
MIN_ASYMMETRY = 0.1


def asymmetry_limit(typical: float) -> float:
    """The largest asymmetry ``1 - quality`` of a corner of a board whose median asymmetry is ``typical``.

    :data:`ASYMMETRY` times the median, or :data:`MIN_ASYMMETRY` where that is
    less, and at most halfway from the median to 1, the asymmetry of a window
    with no point symmetry at all: ``min(max(10 m, 0.1), (1 + m) / 2)``. On a
    noisy board (``m`` near 0.1) ten times the median would keep a fit that
    explains a tenth of its window: the corners of a board's outer row, whose
    squares the paper cuts, refined 3-5 px off the corner under noise 9
    (asymmetry 0.56-0.86 against a median of 0.1), where the real sets' corners
    never exceed 0.13.

    Examples
    --------
    >>> [round(asymmetry_limit(m), 3) for m in (0.001, 0.03, 0.1, 0.3)]
    [0.1, 0.3, 0.55, 0.65]
    """
    return min(max(ASYMMETRY * typical, MIN_ASYMMETRY), (1.0 + typical) / 2)


def symmetric(quality: np.ndarray) -> np.ndarray:
    """The corners whose asymmetry ``1 - quality`` is within :func:`asymmetry_limit` of the board's median.

    An occluder, a window cut by the frame or a corner that is not the board's
    breaks the point symmetry; noise alone leaves ``1 - quality`` near its median.
    """
    asym = 1.0 - quality
    if len(asym) == 0:
        return np.zeros(0, dtype=bool)
    return (quality > 0) & (asym <= asymmetry_limit(median(asym)))


def bilinear(grey: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The image at points ``p`` (..., 2), bilinear between pixels, the points clamped to the frame.

    Examples
    --------
    >>> bilinear(np.array([[0.0, 10.0], [20.0, 30.0]]), np.array([[0.5, 0.5], [0.25, 0.0]])).tolist()
    [15.0, 2.5]
    """
    pts = np.ascontiguousarray(p, dtype=np.float64).reshape(-1, 2)
    out = np.empty(len(pts))
    _bilinear(np.ascontiguousarray(grey, dtype=np.float64), pts, out)
    return out.reshape(np.shape(p)[:-1])


@numba.njit(**EXACT_JIT)
def _bilinear(grey, p, out):  # pragma: no cover - jit
    for k in range(p.shape[0]):
        out[k] = _bilinear1(grey, p[k, 0], p[k, 1])


@numba.njit(**EXACT_JIT)
def _bilinear1(grey, x, y):  # pragma: no cover - jit
    """:func:`bilinear` at one point."""
    H, W = grey.shape
    x = min(max(x, 0.0), W - 1.001)
    y = min(max(y, 0.0), H - 1.001)
    x0, y0 = int(math.floor(x)), int(math.floor(y))
    fx, fy = x - x0, y - y0
    return ((grey[y0, x0] * (1 - fx) + grey[y0, x0 + 1] * fx) * (1 - fy)
            + (grey[y0 + 1, x0] * (1 - fx) + grey[y0 + 1, x0 + 1] * fx) * fy)


#: radii (in cells) and directions at which a border corner's surroundings are compared with their mirror image
_OUT_STEPS = np.arange(0.1, 0.96, 0.05)
_OUT_DIRS = np.stack([np.cos(np.arange(16) * np.pi / 16), np.sin(np.arange(16) * np.pi / 16)], axis=1)
#: the 32 rays of :func:`border_reach`'s ring: the directions and their opposites
_RING_DIRS = np.r_[_OUT_DIRS, -_OUT_DIRS]


def border_reach(grey: np.ndarray, xy: np.ndarray, labels: np.ndarray, cells: np.ndarray,
                 also: np.ndarray | None = None) -> np.ndarray:
    """How far the refinement window of each corner on the board's border (and ``also``) may reach, per
    direction: (n, :data:`sogdd.calib.targets.refine.REACH_DIRS`) px, ``inf`` where nothing bounds it.

    Beyond a border corner ``p`` (one without all four lattice neighbours) the
    outer squares may be narrower than a cell, or end at the paper's edge with
    the background right beyond, or at the frame's edge; the point symmetry
    ``I(p + d) = I(p - d)`` holds only while ``p + d`` stays on the squares. Along
    each of 32 rays ``u`` (16 directions and their opposites) the symmetric
    extent ``r(u)`` is the first radius ``t cell`` (``t`` in :data:`_OUT_STEPS`)
    at which ``|I(p + r u) - I(p - r u)| > 0.2 c``, with ``c`` the spread of the
    image on the ring of radius 0.2 cell (10th to 90th percentile: the corner's
    contrast): where a blurred edge that is not the corner's own begins. The
    window's Gaussian weight is still 0.6 at its rim, so its reach along ``u`` is
    ``0.8 r(u)``, at least :data:`sogdd.calib.targets.refine.MIN_HALF` (a ray
    symmetric out to 0.95 cell sets no bound). An inner corner is not bounded
    unless ``also`` (bool, one per corner) names it: an inner corner whose window
    is far less point-symmetric than the board's others (a code printed in its
    white squares, which differs between the two squares mirrored through it) is
    measured the same way. ``xy`` must be refined already (:func:`refine_board`).
    """
    border = ~inner_corners(labels)
    if also is not None:
        border |= also
    k = np.flatnonzero(border & np.isfinite(cells))
    out = np.full((len(xy), REACH_DIRS), np.inf)
    if len(k) == 0:
        return out
    _reach(np.ascontiguousarray(grey, dtype=np.float64), np.ascontiguousarray(xy, dtype=np.float64),
           np.ascontiguousarray(cells, dtype=np.float64), k, _RING_DIRS, _OUT_STEPS, _OUT_DIRS,
           float(MIN_HALF), out)
    return out


@numba.njit(**EXACT_JIT)
def _reach(grey, xy, cells, k, ring, steps, dirs, least, out):  # pragma: no cover - jit
    """:func:`border_reach`'s rays for the corners ``k``: the threshold ``0.2 (hi - lo)`` from the image
    on the ``ring`` of radius 0.2 cell (:func:`_spread`); along each direction ``u``, the first step ``t``
    with ``|I(p + d) - I(p - d)| > thr`` (``d = (steps[t] cell) u``, numpy's order of the products), the
    reach ``max(0.8 steps[t] cell, least)`` (``inf`` where none), into ``out``. Stops at the first such
    step: the steps beyond it are not measured."""
    vals = np.empty(ring.shape[0])
    for i in range(k.shape[0]):
        c = k[i]
        px = xy[c, 0]
        py = xy[c, 1]
        cell = cells[c]
        thr = 0.2 * _spread(grey, px, py, 0.2 * cell, ring, vals)
        for u in range(dirs.shape[0]):
            r = np.inf
            for t in range(steps.shape[0]):
                s = steps[t] * cell
                dx = s * dirs[u, 0]
                dy = s * dirs[u, 1]
                if abs(_bilinear1(grey, px + dx, py + dy) - _bilinear1(grey, px - dx, py - dy)) > thr:
                    r = steps[t] * cell
                    break
            out[c, u] = max(0.8 * r, least)


@numba.njit(**EXACT_JIT)
def _spread(grey, px, py, radius, ring, vals):  # pragma: no cover - jit
    """The image's spread on the ``ring`` of ``radius`` around ``(px, py)``: its 90th percentile less its 10th,
    each as numpy's ``percentile`` interpolates them (linear, from the sorted samples), into ``vals``."""
    n = ring.shape[0]
    for j in range(n):
        vals[j] = _bilinear1(grey, px + radius * ring[j, 0], py + radius * ring[j, 1])
    vals.sort()
    return _order(vals, 0.9) - _order(vals, 0.1)


@numba.njit(**EXACT_JIT)
def _order(v, q):  # pragma: no cover - jit
    """numpy's linear percentile ``q`` (a fraction) of the sorted ``v``: its interpolation, term for term."""
    at = q * (v.shape[0] - 1)
    lo = math.floor(at)
    g = at - lo
    a, b = v[int(lo)], v[min(int(lo) + 1, v.shape[0] - 1)]
    d = b - a
    return b - d * (1.0 - g) if g >= 0.5 else a + d * g


def square_within(reach: np.ndarray, half: np.ndarray) -> np.ndarray:
    """The half-widths ``half`` cut so that the square window stays within ``reach`` (:func:`border_reach`).

    A square of half-width ``h`` reaches ``h (|u_x| + |u_y|)`` along ``u``, so
    ``h = floor(min_u reach(u) / (|u_x| + |u_y|))``, at most ``half`` and
    :data:`sogdd.calib.targets.refine.MAX_WINDOW`, at least
    :data:`sogdd.calib.targets.refine.MIN_HALF`.
    """
    spread = np.abs(_OUT_DIRS[:, 0]) + np.abs(_OUT_DIRS[:, 1])
    bounded = np.isfinite(reach).any(axis=1)
    out = np.asarray(half).copy()
    if bounded.any():
        limit = np.floor(np.minimum(np.min(reach[bounded] / spread, axis=1), MAX_WINDOW)).astype(np.int64)
        out[bounded] = np.minimum(out[bounded], np.maximum(limit, MIN_HALF))
    return out


def edge_halves(grey: np.ndarray, xy: np.ndarray, labels: np.ndarray, half: np.ndarray,
                cells: np.ndarray, also: np.ndarray | None = None) -> np.ndarray:
    """Half-widths of the square refinement windows, cut for the corners on the board's border (and
    ``also``) to stay within :func:`border_reach`: :func:`square_within`."""
    return square_within(border_reach(grey, xy, labels, cells, also), half)


def recut(grey: np.ndarray, start: np.ndarray, out: np.ndarray, quality: np.ndarray, half: np.ndarray,
          reach: np.ndarray) -> None:
    """Refine again, from ``start``, the corners whose square window ``reach`` (:func:`border_reach`) cuts
    (:func:`square_within`); keep the more symmetric fit.

    ``out`` and ``quality`` are updated in place where the cut window's fit has
    the higher quality (the measure of the extent is noisy: a corner whose full
    window stayed on the squares keeps it, and its accuracy).
    """
    cut = square_within(reach, half)
    redo = np.flatnonzero(cut < half)
    if len(redo):
        xy2, q2 = refine_grey(grey, start[redo], cut[redo], cut[redo].astype(np.float64))
        better = q2 > quality[redo]
        out[redo[better]], quality[redo[better]] = xy2[better], q2[better]


def star_refit(grey: np.ndarray, start: np.ndarray, out: np.ndarray, quality: np.ndarray, half: np.ndarray,
               reach: np.ndarray, which: np.ndarray) -> None:
    """Refine again, from ``start``, the corners ``which`` (bool) with the star window ``reach`` draws in
    their square ``half`` (:func:`sogdd.calib.targets.refine.refine_grey`); keep the more symmetric fit.

    Beyond a corner on a board's border whose outer squares the paper cuts, the
    symmetric surroundings are long along the border (the squares go on) and
    short across it (the outer squares end): the square window cut to the
    short side (:func:`recut`) may hold too few pixels under blur and noise,
    and the star keeps the long side. It is the fallback for the corners that
    are still far less symmetric than the board's others (a tie with their
    fit, or a worse fit, keeps it: on a board the square fits well, the star's
    fewer pixels fit no more accurately).
    """
    star = np.flatnonzero(which & np.isfinite(reach).any(axis=1) & (np.min(reach, axis=1) < half))
    if len(star):
        xy2, q2 = refine_grey(grey, start[star], half[star], half[star].astype(np.float64), reach=reach[star])
        better = q2 > quality[star]
        out[star[better]], quality[star[better]] = xy2[better], q2[better]


def refine_board(grey: np.ndarray, xy: np.ndarray, labels: np.ndarray, cells: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The corners refined with windows of 0.65 of their local cell, cut to the plain squares where needed.

    The symmetric extent of :func:`edge_halves` is measured at the corners
    refined with the full window (at the X-corners' coarse positions the
    mirror images differ along the corner's own edge lines); the corners whose
    window it cuts are refined again with the cut window (:func:`recut`), from
    the full window's fit (a start the short window reaches, where the
    X-corner of a coarse level may lie pixels off). First the border corners;
    then the corners that :func:`symmetric` would drop against the board's median with the border
    cut (before it, the median itself may be that of windows reaching beyond
    the squares): a code in the white squares (ECoCheck's dots), which differs
    between the two squares mirrored through the corner, breaks the symmetry
    beyond its clear margin only, so a window within that margin fits the
    corner; an occluder over the corner leaves the cut fit asymmetric too.
    A corner still asymmetric whose full window had moved is refined again with the window cut at its
    lattice point, from there: a full window that slid off a narrow outer row onto the background (4-5 px
    on a board tilted 70 degrees) leaves its cut fit where it slid, out of the short window's reach.
    Those still asymmetric are refined with the star window of their reach
    (:func:`star_refit`), then on the image unshaded (:func:`deshaded`), and, failing both, judged
    through their own cut window against the board's corners (:func:`same_window`). ``cells``: the
    corners' :func:`~sogdd.calib.targets.board.lattice_cells`, when the caller has them already.
    """
    cells = lattice_cells(xy, labels) if cells is None else cells
    half = half_widths(xy, None, cells)
    out, quality = refine_grey(grey, xy, half, half.astype(np.float64))
    at = np.where(quality[:, None] > 0, out, xy)
    reach = border_reach(grey, at, labels, cells)
    recut(grey, at, out, quality, half, reach)
    asym = (quality > 0) & ~symmetric(quality)
    if asym.any():
        # measured on their own: the border corners' windows are cut already
        reach[asym] = border_reach(grey, at[asym], labels[asym], cells[asym], also=asym[asym])
        recut(grey, at, out, quality, half, np.where(asym[:, None], reach, np.inf))
    slid = ~symmetric(quality) & np.any(at != xy, axis=1)
    if slid.any():
        # a full window that slid off a narrow outer row left the cut fit there: refit from the lattice's point
        reach_xy = np.full_like(reach, np.inf)
        reach_xy[slid] = border_reach(grey, xy[slid], labels[slid], cells[slid], also=slid[slid])
        recut(grey, xy, out, quality, half, reach_xy)
    star_refit(grey, at, out, quality, half, reach, ~symmetric(quality))
    bad = ~symmetric(quality)
    if bad.any() and np.isfinite(cells).any():
        inner = inner_corners(labels) & ~bad
        ref = np.flatnonzero(inner if np.count_nonzero(inner) >= 5 else ~bad)
        cell = median(cells[np.isfinite(cells)])
        r, q = deshaded(grey, xy[bad], half[bad], out[ref], half[ref], cell)
        k = np.flatnonzero(bad)[q > quality[bad]]
        out[k], quality[k] = r[q > quality[bad]], q[q > quality[bad]]
        bad = ~symmetric(quality)
    if bad.any():
        same_window(grey, xy, out, quality, labels, cells, half, bad)
    return out, quality


#: the most of a board's symmetric inner corners :func:`same_window` measures through each window
SAME_WINDOW_REFS = 24


def same_window(grey: np.ndarray, start: np.ndarray, out: np.ndarray, quality: np.ndarray, labels: np.ndarray,
                cells: np.ndarray, half: np.ndarray, which: np.ndarray) -> None:
    """The corners ``which`` (bool) judged against the board's corners seen through the same cut window.

    A window cut to a narrow outer row (a board's rim through a fisheye, or under a steep tilt) holds a
    few px of a blurred corner: its spread is a few grey levels where the board's full windows span the
    board's contrast, so the image's noise alone makes its asymmetry ``1 - q`` many times the board's
    median ``m`` (0.31 against 0.02 at the rim of a rendered 174-degree fisheye under noise of 11 grey
    levels), and :func:`symmetric` would drop a corner that is where it should be.

    Each such corner is refined again from its lattice point ``start`` (not from a fit that may have
    slid off it), with the square window of its symmetric extent there (:func:`border_reach`,
    :func:`square_within`: half-width ``h``, within which it may move), and the board's symmetric inner
    corners (at most :data:`SAME_WINDOW_REFS`) are measured through the same ``h`` (one step from their
    fits): their median asymmetry ``m_h`` is what noise and blur give that window on this board. The
    corner is judged against them, ``1 - q`` within :func:`asymmetry_limit` ``L`` of ``m_h``: its
    asymmetry on the board's scale is ``a = max((1 - q) L(m) / L(m_h), m)`` (as :func:`deshaded` puts
    a corner measured on the unshaded image on it; never below the median, so that the limit the board's
    other corners are held to stays where it was), and its fit is kept where that is more symmetric than
    its own. A corner that an occluder or a foreign edge moved is as asymmetric against the board's
    corners through its window as it was through the board's. A corner whose window the squares do not
    cut, or whose fit failed, and a board with fewer than 5 symmetric inner corners, are left as they
    are. ``out`` and ``quality`` are updated in place.
    """
    ref = np.flatnonzero(inner_corners(labels) & ~which & (quality > 0))
    if len(ref) < 5:
        return
    ref = ref[np.linspace(0, len(ref) - 1, min(len(ref), SAME_WINDOW_REFS)).astype(np.int64)]
    k = np.flatnonzero(which & np.isfinite(cells) & (quality > 0))
    if len(k) == 0:
        return
    h = square_within(border_reach(grey, start[k], labels[k], cells[k], also=np.ones(len(k), bool)), half[k])
    k, h = k[h < half[k]], h[h < half[k]]  # a corner with its whole window was measured as the board's are
    if len(k) == 0:
        return
    m = median(1.0 - quality)
    xy, q = refine_grey(grey, start[k], h, h.astype(np.float64))
    a = np.full(len(k), np.inf)
    for hv in np.unique(h):
        at = h == hv
        _, qr = refine_grey(grey, out[ref], np.full(len(ref), hv), np.full(len(ref), float(hv)), iterations=1)
        a[at] = np.maximum((1.0 - q[at]) * asymmetry_limit(m) / asymmetry_limit(median(1.0 - qr)), m)
    better = (q > 0) & (1.0 - a > quality[k])
    out[k[better]], quality[k[better]] = xy[better], 1.0 - a[better]


def inner_corners(labels: np.ndarray) -> np.ndarray:
    """The corners with all four lattice neighbours."""
    return (label_neighbours(labels) >= 0).all(axis=1)


#: the light envelope of :func:`deshaded`: a closing over this many cells, computed at this many px per cell
SHADE_CELLS, SHADE_PX = 1.5, 16.0


def deshaded(grey: np.ndarray, start: np.ndarray, half: np.ndarray, ref: np.ndarray, ref_half: np.ndarray,
              cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Corners refined on the image divided by its light envelope, their quality on the board's scale.

    A shadow over part of a light square, or a bright reflection, makes the two
    light squares mirrored through the corner differ in brightness: the point
    symmetry breaks over the whole window, though the corner is where it was.
    Shading multiplies the image by a smooth light ``L``; the envelope of the
    light squares, a grey closing over :data:`SHADE_CELLS` cells (wider than a
    dark square, so it fills them; computed at :data:`SHADE_PX` px per cell and
    resized), follows it, and ``I / L`` is the board unshaded. The corners
    ``start`` are refined on it with windows ``half``; their asymmetry
    ``1 - q`` is put on the board's scale, ``a = (1 - q) m / m'`` with ``m`` the
    board's median asymmetry on the image (at its symmetric corners ``ref``,
    windows ``ref_half``) and ``m'`` the same on ``I / L``, so that
    :func:`symmetric` compares it with the board as the image shows it.
    Returns ``(xy, 1 - a)``; an occluder or a code in the squares stays
    asymmetric on ``I / L`` too. The region is the bounding box of all the
    points, with a margin of the windows and the closing.
    """
    H, W = grey.shape
    pts = np.r_[start, ref]
    m = int(np.ceil(max(int(np.max(np.r_[half, ref_half])), 1) + SHADE_CELLS * cell + 4))
    x0, y0 = (np.maximum(np.floor(pts.min(axis=0)) - m, 0)).astype(int)
    x1, y1 = (np.minimum(np.ceil(pts.max(axis=0)) + m + 1, [W, H])).astype(int)
    patch = grey[y0:y1, x0:x1].astype(np.float32)
    f = min(1.0, SHADE_PX / max(cell, 1e-9))
    small = cv2.resize(patch, None, fx=f, fy=f, interpolation=cv2.INTER_AREA) if f < 1 else patch
    k = 2 * int(round(SHADE_CELLS * cell * f / 2)) + 1
    env = cv2.morphologyEx(small, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_RECT, (k, k)))
    if f < 1:
        env = cv2.resize(env, (patch.shape[1], patch.shape[0]), interpolation=cv2.INTER_LINEAR)
    flat = patch.astype(np.float64)  # 255 I / max(L, 1) in place: the same numbers, no temporaries
    flat *= 255.0
    flat /= np.maximum(env, 1.0)
    o = np.array([x0, y0], dtype=np.float64)
    _, q_img = refine_grey(grey, ref, ref_half, ref_half.astype(np.float64), iterations=1)
    _, q_flat = refine_grey(flat, ref - o, ref_half, ref_half.astype(np.float64), iterations=1)
    scale = max(median(1.0 - q_img), 1e-6) / max(median(1.0 - q_flat), 1e-6)
    r, q = refine_grey(flat, start - o, half, half.astype(np.float64))
    a = (1.0 - q) * scale
    return r + o, np.where(q > 0, np.clip(1.0 - a, 0.0, 1.0), 0.0)
