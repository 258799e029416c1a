"""The chessboard lattice: X-corners linked into a grid and labelled ``(i, j)``.

Three tests make two X-corners lattice neighbours (:func:`ray_neighbours`): the
second lies along one of the first's edge lines (within :data:`CONE`), one of its
own edge lines points back along that line (:data:`EDGE_TOL`), and its light axis
is turned by about 90 degrees (the wedges' colours swap across an edge line,
:data:`POLARITY_TOL`). The edge lines are tried twice: the Hessian's (:attr:`XCorners.spread`)
and those the corner's nearest corners of the other parity draw (:func:`_lattice_spread`), which the
smoothing does not bias where the cells are small, foreshortened or smeared; the nearest neighbour that
passes either is the ray's.

A board grows from a **seed**, an X-corner whose four rays all reach mutual
neighbours at similar distances (a cross of five corners), labelled
``(0, 0), (1, 0), (0, 1), (-1, 0), (0, -1)`` along the seed's edge lines
``theta1 = light - spread`` (``+i``) and ``theta2 = light + spread`` (``+j``):
``sin(theta2 - theta1) = sin(2 spread) > 0``, so ``(a_i, a_j)`` is right-handed in
image coordinates (``x`` right, ``y`` down; ``i`` left to right and ``j`` top to
bottom on an upright board). Growth (:func:`grow`) then works by prediction: for
each free label next to the labelled ones, a homography fitted to the labelled
corners within two labels (a local homography follows perspective and lens
distortion, :func:`sogdd.calib.targets.chessboard.mapping.predict_local`) predicts
its position; the nearest free X-corner within :data:`SEARCH` cells of it is taken
if its edge lines follow the local lattice directions (:func:`_edges_follow`), its
light axis has the label's parity, and its strength is that of its neighbours
within a factor :data:`CONTRAST_RATIO`. A label whose search fails stays free.

The ray test (:func:`_rays`) is compiled without ``fastmath``: the same
floating-point operations, in the same order, as the numpy it replaced, with
numpy's ``arctan2``. The growth is compiled whole (:func:`_grow`): each label's
local homography solved by a small LU
(:func:`~sogdd.calib.targets.chessboard.mapping.predict_local`), its
candidates found among the corners sorted by ``x``, its angles libm's. Its last
bits may differ from the numpy growth it replaced, whose boards it gave to the
bit on every real set (OpenCV's pair, Sony's photos, the industrial camera),
at a sixth of its time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from scipy.spatial import cKDTree

from sogdd._jit import EXACT_JIT

from .mapping import SUPPORT, predict_local
from .xcorners import XCorners

__all__ = ["Lattice", "grow", "ray_neighbours", "seeds"]


#: a neighbour lies within this angle (rad) of the ray along an edge line
CONE = np.radians(20.0)
#: one of the neighbour's edge lines is parallel to the ray within this angle (rad)
EDGE_TOL = np.radians(22.0)
#: the neighbour's light axis is perpendicular to the corner's within this angle (rad)
POLARITY_TOL = np.radians(25.0)
#: a predicted corner is searched within this fraction of the local cell
SEARCH = 0.3
#: neighbours' strengths differ by at most this factor
CONTRAST_RATIO = 4.0
#: opposite rays of a seed differ in length by at most this factor
SEED_RATIO = 1.6
#: neighbours examined per corner: enough to reach past the saddles between the dots of a code inside
#: the white squares (ECoCheck: 20 or more within a cell of a corner) to the next corner along each ray
KNN = 32

#: corners of the other parity that measure a spread (:func:`_lattice_spread`): the four edge neighbours
SPREAD_NEIGHBOURS = 4

_OFFS = np.array([(1, 0), (0, 1), (-1, 0), (0, -1)])
#: the label offsets whose corners predict a label (a 5 x 5 block without its centre)
_SUPPORT_F = SUPPORT.astype(np.float64)


@dataclass
class Lattice:
    """One grown grid: ``index`` into the X-corners and their labels ``(i, j)``."""

    index: np.ndarray
    labels: np.ndarray

    def __len__(self) -> int:
        return len(self.index)


def ray_neighbours(xc: XCorners) -> tuple[np.ndarray, np.ndarray]:
    """The nearest lattice neighbour along each of the four rays of every corner.

    The rays point along ``theta1, theta2, theta1 + pi, theta2 + pi`` (the edge
    lines, :attr:`XCorners.edges`). Returns ``(nb (N, 4) int, -1 for none; dist (N, 4))``.
    """
    n = len(xc)
    nb = np.full((n, 4), -1, dtype=np.int64)
    dist = np.full((n, 4), np.inf)
    if n < 2:
        return nb, dist
    k = min(KNN, n)
    d, idx = cKDTree(xc.xy).query(xc.xy, k=k)
    d, idx = np.ascontiguousarray(d[:, 1:]), np.ascontiguousarray(idx[:, 1:], dtype=np.int64)  # not itself
    v = xc.xy[idx] - xc.xy[:, None, :]
    ang = np.arctan2(v[..., 1], v[..., 0])  # numpy's arctan2 (its SIMD one where it has it), as before
    light = np.ascontiguousarray(xc.light, dtype=np.float64)
    spread = np.ascontiguousarray(xc.spread, dtype=np.float64)
    _rays(d, idx, ang, light, spread, np.ascontiguousarray(xc.edges, dtype=np.float64), nb, dist)
    # and along the edge lines the neighbours draw (:func:`_lattice_spread`): the nearest that passes either
    seen = _lattice_spread(idx, ang, light)
    edges = np.mod(np.stack([light - seen, light + seen], axis=1), np.pi)
    _rays(d, idx, ang, light, seen, edges, nb, dist)
    return nb, dist


@numba.njit(**EXACT_JIT)
def _lattice_spread(idx, ang, light):  # pragma: no cover - jit
    """Each corner's spread as its lattice neighbours draw it: the median of ``|wrap_pi(a - light)|`` over
    the directions ``a`` to its :data:`SPREAD_NEIGHBOURS` nearest corners whose light axis is turned by about
    90 degrees (:data:`POLARITY_TOL`); its own spread (NaN: none) where fewer are near.

    The four edge neighbours of a lattice corner lie along ``light +- s`` and
    ``light + pi +- s``, ``s`` the true spread, and are the nearest corners of the
    other parity (the diagonal ones share the corner's parity). The Hessian's
    spread (:attr:`XCorners.spread`) is biased towards 45 degrees where the cells
    are small, strongly foreshortened or smeared (20-30 degrees at a board tilted
    68 degrees under a 13 px smear), while the light axis, an eigenvector, stays
    within a few degrees, so the rays are tried along both.
    """
    n, m = idx.shape
    out = np.full(n, np.nan)
    buf = np.empty(SPREAD_NEIGHBOURS)
    for c in range(n):
        k = 0
        for t in range(m):
            q = idx[c, t]
            if not abs(abs(_wrap_pi(light[q] - light[c])) - np.pi / 2) < POLARITY_TOL:
                continue
            v = abs(_wrap_pi(ang[c, t] - light[c]))
            u = k
            while u > 0 and buf[u - 1] > v:  # insertion sort
                buf[u] = buf[u - 1]
                u -= 1
            buf[u] = v
            k += 1
            if k == SPREAD_NEIGHBOURS:
                break
        if k == SPREAD_NEIGHBOURS:
            out[c] = 0.5 * (buf[k // 2 - 1] + buf[k // 2])
    return out


@numba.njit(**EXACT_JIT)
def _mod(a, b):  # pragma: no cover - jit
    """numpy's ``mod(a, b)`` for ``b > 0``, the same bits: ``fmod``, then ``+ b`` where the signs differ,
    ``+0`` for a zero. Within ``(-2 b, 2 b)``, where the angles here lie, ``fmod`` is ``a``, ``a - b`` or
    ``a + b``, all exact (Sterbenz), so no ``fmod`` is called there."""
    if a == 0.0:
        return 0.0
    if a > 0.0:
        if a < b:
            return a
        if a < 2.0 * b:
            return a - b  # +0 when a == b
    elif a > -b:
        return a + b
    elif a > -2.0 * b:
        r = a + b
        return r + b if r != 0.0 else 0.0
    return a % b  # numba's float %: Python's, which is numpy's mod


@numba.njit(**EXACT_JIT)
def _wrap_pi(a):  # pragma: no cover - jit
    """An angle difference of lines (mod pi) to ``[-pi/2, pi/2)``: ``mod(a + pi/2, pi) - pi/2``."""
    return _mod(a + np.pi / 2, np.pi) - np.pi / 2


@numba.njit(**EXACT_JIT)
def _wrap(a):  # pragma: no cover - jit
    """An angle difference of rays (mod 2 pi) to ``[-pi, pi)``: ``mod(a + pi, 2 pi) - pi``."""
    return _mod(a + np.pi, 2 * np.pi) - np.pi


@numba.njit(**EXACT_JIT)
def _rays(d, idx, ang, light, spread, edges, nb, dist):  # pragma: no cover - jit
    """:func:`ray_neighbours`' tests for every corner and ray: the nearest neighbour that passes them all.

    ``d, idx`` (N, k): the k nearest other corners; ``ang`` the angles to them; ``edges`` (N, 2) the edge
    lines mod pi. Writes ``nb`` and ``dist`` where a neighbour passes (the first of the nearest on a tie).
    """
    n, m = idx.shape
    ray = np.empty(4)
    for c in range(n):
        lc = light[c]
        e0 = lc - spread[c]
        e1 = lc + spread[c]
        ray[0] = e0 + 0.0
        ray[1] = e1 + 0.0
        ray[2] = e0 + np.pi
        ray[3] = e1 + np.pi
        for t in range(m):
            if not d[c, t] > 0:
                continue
            q = idx[c, t]
            if not abs(abs(_wrap_pi(light[q] - lc)) - np.pi / 2) < POLARITY_TOL:  # the wedges' colours swap
                continue
            for r in range(4):
                if not d[c, t] < dist[c, r]:  # the first of the nearest
                    continue
                if not abs(_wrap(ang[c, t] - ray[r])) < CONE:
                    continue
                if not min(abs(_wrap_pi(edges[q, 0] - ray[r])), abs(_wrap_pi(edges[q, 1] - ray[r]))) < EDGE_TOL:
                    continue
                nb[c, r] = q
                dist[c, r] = d[c, t]


def seeds(xc: XCorners, nb: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Corners whose four rays reach mutual neighbours at similar distances, best first.

    A neighbour is mutual when one of its rays leads back to the corner. The order:
    the weakest of the five corners' strengths, descending.
    """
    n = len(xc)
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    full = (nb >= 0).all(axis=1)
    mutual = np.ones(n, dtype=bool)
    for r in range(4):
        j = np.where(nb[:, r] >= 0, nb[:, r], 0)
        mutual &= (nb[j] == np.arange(n)[:, None]).any(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.maximum(dist[:, 0] / dist[:, 2], dist[:, 2] / dist[:, 0])
        ratio = np.maximum(ratio, np.maximum(dist[:, 1] / dist[:, 3], dist[:, 3] / dist[:, 1]))
    ok = full & mutual & (ratio <= SEED_RATIO)
    cand = np.flatnonzero(ok)
    weakest = np.min(np.concatenate([xc.strength[cand][:, None], xc.strength[nb[cand]]], axis=1), axis=1)
    return cand[np.argsort(-weakest, kind="stable")]


def _edges_follow(light: float, spread: float, axes: np.ndarray) -> bool:
    """Whether an X-corner's edge lines ``light +- spread`` follow the lattice directions ``axes`` (2, 2).

    Each edge line within :data:`EDGE_TOL` of one axis (lines, mod pi); or,
    where the cells are strongly sheared, the light axis within
    ``EDGE_TOL / 2`` of a bisector of the axes and each edge line within
    ``2 EDGE_TOL``. The second rule is there because the spread comes from
    the ratio of the Hessian's eigenvalues, which the smoothing biases towards
    45 degrees where the cell is small and foreshortened (at the rim of a
    fisheye the edge lines of true corners come out 20-30 degrees off), while
    the light axis, an eigenvector, stays within a few degrees.
    """
    axes = np.asarray(axes, dtype=np.float64)
    ang = np.arctan2(axes[:, 1], axes[:, 0])
    return bool(_edges_follow1(float(light), float(spread), float(ang[0]), float(ang[1])))


@numba.njit(**EXACT_JIT)
def _edges_follow1(light, spread, ang0, ang1):  # pragma: no cover - jit
    """:func:`_edges_follow` with the axes' angles ``ang0, ang1`` given (compiled)."""
    e0 = light - spread
    e1 = light + spread
    d00 = abs(_wrap_pi(e0 - ang0))
    d01 = abs(_wrap_pi(e0 - ang1))
    d10 = abs(_wrap_pi(e1 - ang0))
    d11 = abs(_wrap_pi(e1 - ang1))
    straight = min(max(d00, d11), max(d01, d10))
    if straight < EDGE_TOL:
        return True
    mid = ang0 + 0.5 * _wrap_pi(ang1 - ang0)  # a bisector of the two axis lines
    t = light - mid
    bis = min(abs(_wrap_pi(t - 0.0)), abs(_wrap_pi(t - np.pi / 2)))
    return bis < EDGE_TOL / 2 and straight < 2 * EDGE_TOL


@numba.njit(**EXACT_JIT)
def _accept(k, near, ang0, ang1, light, spread, strength):  # pragma: no cover - jit
    """Whether candidate ``k`` may take a label (module doc): its edge lines follow the axes at angles
    ``ang0, ang1`` (:func:`_edges_follow1`), its strength is within :data:`CONTRAST_RATIO` of the median
    of its labelled 3 x 3 neighbours', and its light axis has the label's parity against each of them.

    ``near`` (9,): the corners at the label's 3 x 3 block, row by row (-1 for none; the centre, a free
    label, is -1). The median is numpy's: the middle value, or the mean of the middle two.
    """
    if not _edges_follow1(light[k], spread[k], ang0, ang1):
        return False
    buf = np.empty(9)
    m = 0
    for t in range(9):
        if near[t] >= 0:
            v = strength[near[t]]
            u = m
            while u > 0 and buf[u - 1] > v:  # insertion sort: the median of at most 8
                buf[u] = buf[u - 1]
                u -= 1
            buf[u] = v
            m += 1
    if m == 0:
        return False
    s = buf[m // 2] if m % 2 == 1 else (buf[m // 2 - 1] + buf[m // 2]) / 2.0  # np.median's
    if not (s / CONTRAST_RATIO <= strength[k] <= s * CONTRAST_RATIO):
        return False
    # parity: the light axis of a neighbour across an edge is perpendicular, of a diagonal one parallel
    for t in range(9):
        q = near[t]
        if q < 0 or t == 4:
            continue
        dl = abs(_wrap_pi(light[k] - light[q]))
        if (abs(dl - np.pi / 2) if (t // 3 + t % 3) % 2 == 1 else dl) >= POLARITY_TOL:
            return False
    return True


@numba.njit(**EXACT_JIT)
def _claims(ptr, near, xy, p, free, blk, ang, light, spread, strength):  # pragma: no cover - jit
    """The corner each label claims, and which claims stand.

    For label ``l``, the free corners among ``near[ptr[l]:ptr[l + 1]]`` (within its search radius) in
    order of distance to its prediction ``p[l]`` (ties: the lower index), the first that :func:`_accept`
    takes (``blk[l]``: its 3 x 3 block, ``ang[l]``: its axes' angles). Returns ``(got (L,) int, -1 for
    none; take (L,) bool)``: a claim stands when no other label claims the same corner.
    """
    L = ptr.shape[0] - 1
    got = np.full(L, -1, dtype=np.int64)
    buf_k = np.empty(max(near.shape[0], 1), dtype=np.int64)
    buf_d = np.empty(max(near.shape[0], 1))
    for lab in range(L):
        m = _nearest_first(near[ptr[lab]:ptr[lab + 1]], xy, p[lab, 0], p[lab, 1], free, buf_k, buf_d)
        for u in range(m):
            if _accept(buf_k[u], blk[lab], ang[lab, 0], ang[lab, 1], light, spread, strength):
                got[lab] = buf_k[u]
                break
    take = np.zeros(L, dtype=np.bool_)
    for lab in range(L):
        if got[lab] < 0:
            continue
        take[lab] = True
        for other in range(L):
            if other != lab and got[other] == got[lab]:
                take[lab] = False
                break
    return got, take


@numba.njit(**EXACT_JIT)
def _nearest_first(near, xy, px, py, free, buf_k, buf_d):  # pragma: no cover - jit
    """The free corners among ``near`` by distance to ``(px, py)`` (ties: the lower index) into ``buf_k``,
    their distances (libm's ``hypot``, as numpy's) into ``buf_d``; returns how many."""
    m = 0
    for k in near:
        if not free[k]:
            continue
        d = math.hypot(xy[k, 0] - px, xy[k, 1] - py)
        u = m
        while u > 0 and (buf_d[u - 1] > d or (buf_d[u - 1] == d and buf_k[u - 1] > k)):
            buf_k[u] = buf_k[u - 1]
            buf_d[u] = buf_d[u - 1]
            u -= 1
        buf_k[u] = k
        buf_d[u] = d
        m += 1
    return m


@numba.njit(**EXACT_JIT)
def _untried(grid, tried, sup, box, limit):  # pragma: no cover - jit
    """The free grid cells next to the board (4-neighbours, row by row: the labels sorted) with more
    support (labelled corners at the offsets ``sup``) than when last tried, and their support.

    ``box = (i0, j0, i1, j1)``: the board's grid cells; with ``limit >= 0``, only cells that keep the board
    within ``limit`` labels each way. ``tried`` is updated. Returns ``(cells (L, 2), nbr (L, K), fit (L,))``,
    ``fit``: at least 4 corners in the support, not all on one line (the moment matrix of their offsets,
    integers, has a determinant >= 1).
    """
    i0, j0, i1, j1 = box
    n_max = (i1 - i0 + 3) * (j1 - j0 + 3)
    K = sup.shape[0]
    cells = np.empty((n_max, 2), dtype=np.int64)
    nbr = np.empty((n_max, K), dtype=np.int64)
    fit = np.empty(n_max, dtype=np.bool_)
    L = 0
    for gi in range(i0 - 1, i1 + 2):
        for gj in range(j0 - 1, j1 + 2):
            if grid[gi, gj] >= 0:
                continue
            if grid[gi - 1, gj] < 0 and grid[gi + 1, gj] < 0 and grid[gi, gj - 1] < 0 and grid[gi, gj + 1] < 0:
                continue
            n = 0
            c00 = 0
            c01 = 0
            c11 = 0
            for t in range(K):
                v = grid[gi + sup[t, 0], gj + sup[t, 1]]
                nbr[L, t] = v
                if v >= 0:
                    n += 1
                    c00 += sup[t, 0] * sup[t, 0]
                    c01 += sup[t, 0] * sup[t, 1]
                    c11 += sup[t, 1] * sup[t, 1]
            if tried[gi, gj] >= n:
                continue
            if limit >= 0 and max(max(i1, gi) - min(i0, gi), max(j1, gj) - min(j0, gj)) + 1 > limit:
                continue
            tried[gi, gj] = n
            cells[L, 0] = gi
            cells[L, 1] = gj
            fit[L] = n >= 4 and c00 * c11 - c01 * c01 > 0
            L += 1
    return cells[:L], nbr[:L], fit[:L]


#: the 3 x 3 label block, row by row (:func:`_accept`'s ``near``)
_BLOCK = np.array([(a, b) for a in (-1, 0, 1) for b in (-1, 0, 1)])
#: the grid of labels keeps this many free labels around the board (the frontier, 1 out, reads 2 further)
_MARGIN = 4


@numba.njit(**EXACT_JIT)
def _place(grid, tried, st, index, labels, free, i, j, k):  # pragma: no cover - jit
    """Label ``(i, j)`` takes corner ``k``: the grid grown first (to twice the span it needs) where
    ``_MARGIN`` labels around ``(i, j)`` do not fit in it. ``st`` = ``(org0, org1, lo0, lo1, hi0, hi1,
    count)``; returns ``(grid, tried)``, new arrays when grown."""
    h, w = grid.shape
    if not (_MARGIN <= i + st[0] <= h - 1 - _MARGIN and _MARGIN <= j + st[1] <= w - 1 - _MARGIN):
        lo0 = min(min(st[2], i) - _MARGIN, -st[0])
        lo1 = min(min(st[3], j) - _MARGIN, -st[1])
        hi0 = max(max(st[4], i) + _MARGIN, h - 1 - st[0])
        hi1 = max(max(st[5], j) + _MARGIN, w - 1 - st[1])
        p0 = (hi0 - lo0 + 1) // 2
        p1 = (hi1 - lo1 + 1) // 2
        lo0 -= p0
        lo1 -= p1
        hi0 += p0
        hi1 += p1
        d0 = -lo0 - st[0]
        d1 = -lo1 - st[1]
        g2 = np.full((hi0 - lo0 + 1, hi1 - lo1 + 1), -1, dtype=np.int64)
        t2 = np.full((hi0 - lo0 + 1, hi1 - lo1 + 1), -1, dtype=np.int64)
        g2[d0:d0 + h, d1:d1 + w] = grid
        t2[d0:d0 + h, d1:d1 + w] = tried
        grid, tried = g2, t2
        st[0] = -lo0
        st[1] = -lo1
    grid[i + st[0], j + st[1]] = k
    index[st[6]] = k
    labels[st[6], 0] = i
    labels[st[6], 1] = j
    st[6] += 1
    free[k] = False
    st[2] = min(st[2], i)
    st[3] = min(st[3], j)
    st[4] = max(st[4], i)
    st[5] = max(st[5], j)
    return grid, tried


@numba.njit(**EXACT_JIT)
def _predictions(cells, nbr, fit, xy):  # pragma: no cover - jit
    """Each fitted label's prediction by its local homography (:func:`~.mapping.predict_local`): ``(ok
    (L,), p (L, 2) the position, ang (L, 2) the lattice axes' angles, rad (L,) the search radius,
    :data:`SEARCH` of the shorter axis)``."""
    L = cells.shape[0]
    ok = np.zeros(L, dtype=np.bool_)
    p = np.empty((L, 2))
    ang = np.empty((L, 2))
    rad = np.empty(L)
    P = np.empty((5, 2))
    for t in range(L):
        if not fit[t] or not predict_local(xy, nbr[t], _SUPPORT_F, P):
            continue
        a0x = P[1, 0] - P[2, 0]
        a0y = P[1, 1] - P[2, 1]
        a1x = P[3, 0] - P[4, 0]
        a1y = P[3, 1] - P[4, 1]
        ok[t] = True
        p[t, 0] = P[0, 0]
        p[t, 1] = P[0, 1]
        ang[t, 0] = math.atan2(a0y, a0x)
        ang[t, 1] = math.atan2(a1y, a1x)
        rad[t] = SEARCH * min(math.hypot(a0x, a0y), math.hypot(a1x, a1y))
    return ok, p, ang, rad


@numba.njit(**EXACT_JIT)
def _within(p, rad, xy, by_x, xs):  # pragma: no cover - jit
    """The corners within ``rad[t]`` of ``p[t]`` for each ``t``, as ``(ptr (T + 1,), near)``: those of
    ``t`` are ``near[ptr[t]:ptr[t + 1]]``. ``by_x``: the corners' indices by ``x``, ``xs`` their ``x``."""
    T = p.shape[0]
    lo = np.searchsorted(xs, p[:, 0] - rad, side="left")
    hi = np.searchsorted(xs, p[:, 0] + rad, side="right")
    ptr = np.zeros(T + 1, dtype=np.int64)
    near = np.empty(max(int((hi - lo).sum()), 1), dtype=np.int64)
    c = 0
    for t in range(T):
        r2 = rad[t] * rad[t]
        for v in range(lo[t], hi[t]):
            k = by_x[v]
            dx = xy[k, 0] - p[t, 0]
            dy = xy[k, 1] - p[t, 1]
            if dx * dx + dy * dy <= r2:
                near[c] = k
                c += 1
        ptr[t + 1] = c
    return ptr, near


@numba.njit(**EXACT_JIT)
def _grow(xy, light, spread, strength, free, seed, first, limit, by_x, xs):  # pragma: no cover - jit
    """:func:`grow`, compiled: the seed and its free ray neighbours ``first`` (4,), then rounds until one
    adds nothing. Returns ``(index (n,), labels (n, 2))``."""
    side = 8 * _MARGIN
    grid = np.full((side, side), -1, dtype=np.int64)
    tried = np.full((side, side), -1, dtype=np.int64)
    st = np.array([side // 2, side // 2, 0, 0, 0, 0, 0], dtype=np.int64)
    index = np.empty(xy.shape[0], dtype=np.int64)
    labels = np.empty((xy.shape[0], 2), dtype=np.int64)
    grid, tried = _place(grid, tried, st, index, labels, free, 0, 0, seed)
    for r in range(4):
        if first[r] >= 0 and free[first[r]]:
            grid, tried = _place(grid, tried, st, index, labels, free, _OFFS[r, 0], _OFFS[r, 1], first[r])
    added = 1
    while added:
        box = (st[2] + st[0], st[3] + st[1], st[4] + st[0], st[5] + st[1])
        cells, nbr, fit = _untried(grid, tried, SUPPORT, box, limit)
        ok, p, ang, rad = _predictions(cells, nbr, fit, xy)
        sel = np.flatnonzero(ok)
        cells = cells[sel]
        ptr, near = _within(p[sel], rad[sel], xy, by_x, xs)
        blk = np.empty((sel.shape[0], 9), dtype=np.int64)
        for u in range(sel.shape[0]):
            for b in range(9):
                blk[u, b] = grid[cells[u, 0] + _BLOCK[b, 0], cells[u, 1] + _BLOCK[b, 1]]
        got, take = _claims(ptr, near, xy, p[sel], free, blk, ang[sel], light, spread, strength)
        new = np.flatnonzero(take)
        i, j = cells[new, 0] - st[0], cells[new, 1] - st[1]  # labels first: the grid, and its origin, may grow
        for u in range(new.shape[0]):
            grid, tried = _place(grid, tried, st, index, labels, free, i[u], j[u], got[new[u]])
        added = new.shape[0]
    return index[:st[6]].copy(), labels[:st[6]].copy()


def grow(xc: XCorners, seed: int, nb: np.ndarray, free: np.ndarray, *, limit: int | None = None) -> Lattice:
    """Grow one board from ``seed`` (module doc); ``free`` (bool, N) marks unused corners and is updated.

    For each free label next to the board with more support than when last
    tried and a fit (4 corners or more within two labels, not on one line), the
    local homography predicts the position and the lattice steps
    (:func:`~sogdd.calib.targets.chessboard.mapping.predict_local`); the
    nearest free X-corner within :data:`SEARCH` cells that its tests take is
    its claim. A corner two labels claim is left for a later round; the growth
    ends with a round that adds nothing. ``limit``: the board stays within
    this many labels each way.
    """
    xy = np.ascontiguousarray(xc.xy, dtype=np.float64)
    order = xc.by_x
    index, labels = _grow(xy, np.ascontiguousarray(xc.light, dtype=np.float64),
                          np.ascontiguousarray(xc.spread, dtype=np.float64),
                          np.ascontiguousarray(xc.strength, dtype=np.float64), free, int(seed),
                          np.ascontiguousarray(nb[seed], dtype=np.int64), -1 if limit is None else int(limit),
                          order, np.ascontiguousarray(xy[order, 0]))
    return Lattice(index, labels)
