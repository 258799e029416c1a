"""The chessboard lattice: X-corners linked into a grid and labelled ``(i, j)``.

Three tests make two X-corners lattice neighbours (:func:`ray_neighbours`): the
second lies along one of the first's edge lines (within :data:`CONE`), one of its
own edge lines points back along that line (:data:`EDGE_TOL`), and its light axis
is turned by about 90 degrees (the wedges' colours swap across an edge line,
:data:`POLARITY_TOL`).

A board grows from a **seed**, an X-corner whose four rays all reach mutual
neighbours at similar distances (a cross of five corners), labelled
``(0, 0), (1, 0), (0, 1), (-1, 0), (0, -1)`` along the seed's edge lines
``theta1 = light - spread`` (``+i``) and ``theta2 = light + spread`` (``+j``):
``sin(theta2 - theta1) = sin(2 spread) > 0``, so ``(a_i, a_j)`` is right-handed in
image coordinates (``x`` right, ``y`` down; ``i`` left to right and ``j`` top to
bottom on an upright board). Growth (:func:`grow`) then works by prediction: for
each free label next to the labelled ones, a homography fitted to the labelled
corners within two labels (a local homography follows perspective and lens
distortion) predicts its position; the nearest free X-corner within
:data:`SEARCH` cells of it is taken if its edge lines follow the local lattice
directions (:func:`_edges_follow`), its light axis has the label's parity, and its
strength is that of its neighbours within a factor :data:`CONTRAST_RATIO`. A label
whose search fails stays free. :func:`check` is the last guard: each corner must be
predicted by a homography of its neighbours (leaving it out) within a fraction of a
cell, or, where rows and columns are curves (a fisheye), by a second- or else a
third-order map of its neighbours within three labels (:func:`_fit_batch`:
polynomial numerators over the homography's linear denominator).

The loops of the ray test (:func:`_rays`), of the growth (:func:`_untried`,
:func:`_claims`) and the normal equations of the maps (:func:`_normal_equations`)
are compiled without ``fastmath``: they compute the same floating-point
operations, in the same order, as the numpy they replace, so the boards are the
same to the bit; ``arctan2``, the batched solves and the homography of
:func:`check`'s second fit stay numpy's (its ``arctan2`` is a SIMD one where the
CPU has it, whose last bits differ from libm's).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numba
import numpy as np
from scipy.spatial import cKDTree

from .xcorners import XCorners

__all__ = ["check", "homography", "predict_labels"]

#: numba's options for this module's compiled loops: no ``fastmath`` (not even contraction), so that each
#: computes the same floating-point operations, in the same order, as the numpy it replaces (bit for bit)
_JIT = dict(cache=True, nogil=True, error_model="numpy")

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
#: the second-order check (:func:`check`) fits the corners within this many labels ...
CURVE_REACH = 3
#: ... at least this many of them (14 unknowns: 24 equations or more)
CURVE_MIN = 12
#: the third-order check (:func:`check`) fits at least this many corners within :data:`CURVE_REACH` labels
#: (22 unknowns: 26 equations or more; a corner of a board of four rows has 15 such neighbours)
CUBIC_MIN = 13

_OFFS = np.array([(1, 0), (0, 1), (-1, 0), (0, -1)])
#: the label offsets whose corners predict a label (a 5 x 5 block without its centre)
_SUPPORT = np.array([(a, b) for a in range(-2, 3) for b in range(-2, 3) if (a, b) != (0, 0)])
_SUPPORT_F = _SUPPORT.astype(np.float64)
_CURVE_OFFS = np.array([(a, b) for a in range(-CURVE_REACH, CURVE_REACH + 1)
                        for b in range(-CURVE_REACH, CURVE_REACH + 1) if (a, b) != (0, 0)])


@dataclass
class Lattice:
    """One grown grid: ``index`` into the X-corners and their labels ``(i, j)``."""

    index: np.ndarray
    labels: np.ndarray

    def __len__(self) -> int:
        return len(self.index)


def ray_neighbours(xc: XCorners, tree: cKDTree | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The nearest lattice neighbour along each of the four rays of every corner.

    The rays point along ``theta1, theta2, theta1 + pi, theta2 + pi`` (the edge
    lines, :attr:`XCorners.edges`). Returns ``(nb (N, 4) int, -1 for none; dist (N, 4))``.
    """
    n = len(xc)
    nb = np.full((n, 4), -1, dtype=np.int64)
    dist = np.full((n, 4), np.inf)
    if n < 2:
        return nb, dist
    tree = cKDTree(xc.xy) if tree is None else tree
    k = min(KNN, n)
    d, idx = tree.query(xc.xy, k=k)
    d, idx = np.ascontiguousarray(d[:, 1:]), np.ascontiguousarray(idx[:, 1:], dtype=np.int64)  # not itself
    v = xc.xy[idx] - xc.xy[:, None, :]
    ang = np.arctan2(v[..., 1], v[..., 0])  # numpy's arctan2 (its SIMD one where it has it), as before
    light = np.ascontiguousarray(xc.light, dtype=np.float64)
    spread = np.ascontiguousarray(xc.spread, dtype=np.float64)
    _rays(d, idx, ang, light, spread, np.ascontiguousarray(xc.edges, dtype=np.float64), nb, dist)
    return nb, dist


@numba.njit(**_JIT)
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


@numba.njit(**_JIT)
def _wrap_pi(a):  # pragma: no cover - jit
    """An angle difference of lines (mod pi) to ``[-pi/2, pi/2)``: ``mod(a + pi/2, pi) - pi/2``."""
    return _mod(a + np.pi / 2, np.pi) - np.pi / 2


@numba.njit(**_JIT)
def _wrap(a):  # pragma: no cover - jit
    """An angle difference of rays (mod 2 pi) to ``[-pi, pi)``: ``mod(a + pi, 2 pi) - pi``."""
    return _mod(a + np.pi, 2 * np.pi) - np.pi


@numba.njit(**_JIT)
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
    weakest = np.min(np.c_[xc.strength[cand], xc.strength[nb[cand]]], axis=1)
    return cand[np.argsort(-weakest, kind="stable")]


def homography(src: np.ndarray, dst: np.ndarray) -> np.ndarray | None:
    """The least-squares homography mapping ``src`` (N, 2) to ``dst`` (``h33 = 1``); None if degenerate.

    Examples
    --------
    >>> src = np.array([[0, 0], [1, 0], [0, 1], [1, 1], [2, 1]], float)
    >>> H = homography(src, 3 * src + 5)
    >>> (np.round(H / H[2, 2], 6) + 0.0).tolist()
    [[3.0, 0.0, 5.0], [0.0, 3.0, 5.0], [0.0, 0.0, 1.0]]
    """
    if len(src) < 4:
        return None
    src = np.asarray(src, np.float64)
    dst = np.asarray(dst, np.float64)
    cs, cd = src.mean(axis=0), dst.mean(axis=0)
    ss = np.sqrt(2) / max(float(np.sqrt(((src - cs) ** 2).sum(axis=1)).mean()), 1e-12)
    sd = np.sqrt(2) / max(float(np.sqrt(((dst - cd) ** 2).sum(axis=1)).mean()), 1e-12)
    a, b = (src - cs) * ss, (dst - cd) * sd
    n = len(a)
    M = np.zeros((2 * n, 8))
    M[:n, 0:2], M[:n, 2] = a, 1.0
    M[:n, 6:8] = -b[:, :1] * a
    M[n:, 3:5], M[n:, 5] = a, 1.0
    M[n:, 6:8] = -b[:, 1:] * a
    A = M.T @ M
    rhs = M.T @ np.concatenate([b[:, 0], b[:, 1]])
    try:
        h = np.linalg.solve(A, rhs)
    except np.linalg.LinAlgError:
        return None
    if not np.isfinite(h).all() or abs(np.linalg.det(A)) < 1e-12 * np.trace(A) ** 8:
        return None
    Hn = np.append(h, 1.0).reshape(3, 3)
    ts = np.array([[ss, 0, -ss * cs[0]], [0, ss, -ss * cs[1]], [0, 0, 1]])
    td_inv = np.array([[1 / sd, 0, cd[0]], [0, 1 / sd, cd[1]], [0, 0, 1]])
    return td_inv @ Hn @ ts


def apply(H: np.ndarray, p: np.ndarray) -> np.ndarray:
    """``H`` applied to points (N, 2)."""
    q = p @ H[:, :2].T + H[:, 2]
    return q[:, :2] / q[:, 2:]


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
    ang = np.arctan2(axes[:, 1], axes[:, 0])  # numpy's arctan2, as the growth's (:meth:`_Grower.round`)
    return bool(_edges_follow1(float(light), float(spread), float(ang[0]), float(ang[1])))


@numba.njit(**_JIT)
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


@numba.njit(**_JIT)
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


@numba.njit(**_JIT)
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


@numba.njit(**_JIT)
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


@numba.njit(**_JIT)
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


class _Grower:
    """The state of one board's growth: labels, positions, the free X-corners.

    The labels live on a grid (``grid[i + org[0], j + org[1]]``, the corner's index or -1), with the
    support each free label had when last tried (``tried``, -1 for never).
    """

    def __init__(self, xc: XCorners, tree: cKDTree, free: np.ndarray, limit: int | None) -> None:
        self.xc, self.tree, self.free, self.limit = xc, tree, free, limit
        self.index: list[int] = []
        self.labels: list[tuple[int, int]] = []
        self.lo = (0, 0)
        self.hi = (0, 0)
        side = 8 * _MARGIN
        self.org = np.array([side // 2, side // 2])
        self.grid = np.full((side, side), -1, dtype=np.int64)
        self.tried = np.full((side, side), -1, dtype=np.int64)
        #: the labels ``(i0, j0, i1, j1)`` that keep ``_MARGIN`` labels of the grid around them
        self.room = (_MARGIN - side // 2, _MARGIN - side // 2, side // 2 - 1 - _MARGIN, side // 2 - 1 - _MARGIN)
        self.xy = np.ascontiguousarray(xc.xy, dtype=np.float64)
        self.light = np.ascontiguousarray(xc.light, dtype=np.float64)
        self.spread = np.ascontiguousarray(xc.spread, dtype=np.float64)
        self.strength = np.ascontiguousarray(xc.strength, dtype=np.float64)

    def _room(self, i: int, j: int) -> None:
        """Grow the grid (to twice the span it needs) so that ``_MARGIN`` labels around the board and
        ``(i, j)`` fit in it."""
        lo = np.array([min(self.lo[0], i), min(self.lo[1], j)]) - _MARGIN
        hi = np.array([max(self.hi[0], i), max(self.hi[1], j)]) + _MARGIN
        lo = np.minimum(lo, -self.org)  # and the grid as it is
        hi = np.maximum(hi, np.array(self.grid.shape) - 1 - self.org)
        pad = (hi - lo + 1) // 2
        lo, hi = lo - pad, hi + pad
        org = -lo
        d0, d1 = org - self.org
        h, w = self.grid.shape
        for name in ("grid", "tried"):
            new = np.full(tuple(hi - lo + 1), -1, dtype=np.int64)
            new[d0:d0 + h, d1:d1 + w] = getattr(self, name)
            setattr(self, name, new)
        self.org = org
        self.room = (_MARGIN - int(org[0]), _MARGIN - int(org[1]),
                     int(self.grid.shape[0]) - 1 - _MARGIN - int(org[0]),
                     int(self.grid.shape[1]) - 1 - _MARGIN - int(org[1]))

    def add(self, lab: tuple[int, int], k: int) -> None:
        i, j = lab
        r = self.room
        if not (r[0] <= i <= r[2] and r[1] <= j <= r[3]):
            self._room(i, j)
        self.grid[i + self.org[0], j + self.org[1]] = k
        self.index.append(k)
        self.labels.append((i, j))
        self.free[k] = False
        self.lo = (min(self.lo[0], i), min(self.lo[1], j))
        self.hi = (max(self.hi[0], i), max(self.hi[1], j))

    def round(self) -> int:
        """One round over the free labels next to the board; the number of corners added.

        For each free label next to the board with more support than when last tried (:func:`_untried`)
        and a fit (4 corners or more within two labels, not on one line), the local homography predicts
        the position and the lattice steps; the nearest free X-corner within :data:`SEARCH` cells that
        :func:`_accept` takes is its claim. A corner two labels claim is left for a later round.
        """
        o0, o1 = int(self.org[0]), int(self.org[1])
        box = (self.lo[0] + o0, self.lo[1] + o1, self.hi[0] + o0, self.hi[1] + o1)
        limit = -1 if self.limit is None else self.limit
        cells, nbr, fit = _untried(self.grid, self.tried, _SUPPORT, box, limit)
        if not fit.any():
            return 0
        cells, nbr = cells[fit], nbr[fit]
        P = predict_batch(self.xc.xy, nbr, (nbr >= 0).astype(np.float64), _SUPPORT_F)
        ok = np.isfinite(P).all(axis=(1, 2))
        if not ok.all():
            if not ok.any():
                return 0
            cells, P = cells[ok], P[ok]
        axes = np.stack([P[:, 1] - P[:, 2], P[:, 3] - P[:, 4]], axis=1)  # (L, 2 axes, xy)
        cell = np.minimum(np.hypot(axes[:, 0, 0], axes[:, 0, 1]), np.hypot(axes[:, 1, 0], axes[:, 1, 1]))
        p = np.ascontiguousarray(P[:, 0])
        near = self.tree.query_ball_point(p, SEARCH * cell)
        ptr = np.zeros(len(near) + 1, dtype=np.int64)
        np.cumsum([len(q) for q in near], out=ptr[1:])
        flat = np.fromiter(itertools.chain.from_iterable(near), dtype=np.int64, count=int(ptr[-1]))
        blk = self.grid[cells[:, :1] + _BLOCK[:, 0], cells[:, 1:] + _BLOCK[:, 1]]
        ang = np.arctan2(axes[..., 1], axes[..., 0])  # numpy's arctan2, as _edges_follow's
        got, take = _claims(ptr, flat, self.xy, p, self.free, blk, ang, self.light, self.spread, self.strength)
        labs = (cells[take] - self.org).tolist()  # labels first: the grid, and its origin, may grow
        for (i, j), k in zip(labs, got[take].tolist()):
            self.add((i, j), k)
        return len(labs)


def grow(xc: XCorners, seed: int, nb: np.ndarray, free: np.ndarray, tree: cKDTree, *,
         limit: int | None = None) -> Lattice:
    """Grow one board from ``seed`` (module doc); ``free`` (bool, N) marks unused corners and is updated."""
    g = _Grower(xc, tree, free, limit)
    g.add((0, 0), int(seed))
    for r, (di, dj) in enumerate(_OFFS):
        k = int(nb[seed, r])
        if k >= 0 and free[k]:
            g.add((int(di), int(dj)), k)
    while g.round():
        pass
    labs = np.array(g.labels, dtype=np.int64).reshape(-1, 2)
    return Lattice(np.array(g.index, dtype=np.int64), labs)


def check(xy: np.ndarray, labels: np.ndarray, *, tol: float = 0.1, reach: int = 2,
          curved: bool = True, only: np.ndarray | None = None) -> np.ndarray:
    """Mask of the corners that their neighbours predict: leave-one-out error <= ``tol`` cells.

    For each corner, the homography fitted to the other corners within ``reach``
    labels predicts it; the error is divided by the local cell (the distance the
    same homography puts between labels ``+-0.5`` along each axis, the smaller
    one). A corner with fewer than 5 such neighbours (or all on one line) fails.

    With ``curved`` (the default), a corner the homography misses gets a second
    chance from a second-order map of its neighbours within :data:`CURVE_REACH`
    labels (:func:`_curved_errors`): through a fisheye, rows and columns are
    curves and cells shrink towards the rim, which a homography over five labels
    cannot follow (on a 180-degree lens it misses true corners by 0.1-0.4 of a
    cell). The map has 14 unknowns against 24 or more equations, and is fitted
    without the corner, so a corner off the board's smooth lattice still stands
    out; on a flat board seen through a pinhole it reduces to the homography.
    A corner the second order misses too gets a third chance from the
    third-order map (22 unknowns, :data:`CUBIC_MIN` neighbours or more): radial
    distortion ``x (1 + k r^2)`` is a cubic of the label, which the second
    order misses by up to 0.3 of a cell at the rim of a 180-degree lens and the
    third follows to a few hundredths, with the same ``tol``.

    With ``only`` (indices), just those corners are tested (the others' entries are False).

    Examples
    --------
    >>> lab = np.array([(i, j) for j in range(4) for i in range(4)])
    >>> xy = 20.0 * lab + 3.0
    >>> xy[5] += 4.0  # 0.2 cell off
    >>> check(xy, lab).tolist().count(False), bool(check(xy, lab)[5])
    (1, False)
    """
    xy = np.asarray(xy, dtype=np.float64)
    labels = np.asarray(labels, dtype=np.int64)
    n = len(xy)
    ok = np.zeros(n, dtype=bool)
    if n == 0:
        return ok
    which = np.arange(n) if only is None else np.asarray(only, dtype=np.int64).reshape(-1)
    span = range(-reach, reach + 1)
    offs = np.array([(a, b) for a in span for b in span if (a, b) != (0, 0)])
    nbr = _label_grid(labels, which, offs)
    w = (nbr >= 0).astype(np.float64)
    cnt = w.sum(axis=1)
    cov = np.einsum("nk,ka,kb->nab", w, offs.astype(float), offs.astype(float))
    fit = (cnt >= 5) & (np.linalg.det(cov) * 1.0 > 1e-9)
    err = np.full(len(which), np.inf)
    if fit.any():
        err[fit] = _batch_errors(xy, nbr[fit], w[fit], offs.astype(float), which[fit])
    okw = err <= tol
    # a neighbour that is itself off spoils the fit: fit again without the worst one
    for m in np.flatnonzero(fit & ~okw & (cnt >= 6)):
        idx = nbr[m][nbr[m] >= 0]
        k = which[m]
        err_k = _loo_error(labels[idx].astype(np.float64), xy[idx], labels[k].astype(float), xy[k], tol)
        okw[m] = err_k <= tol
    for order in (2, 3) if curved else ():
        bad = np.flatnonzero(~okw)
        if len(bad) == 0:
            break
        okw[bad] = _curved_errors(xy, labels, which[bad], tol, order) <= tol
    ok[which] = okw
    return ok


def _label_grid(labels: np.ndarray, which: np.ndarray, offs: np.ndarray, *,
                at_labels: np.ndarray | None = None) -> np.ndarray:
    """Indices of the corners at ``labels[which] + offs`` (len(which), K), -1 where there is none.

    With ``at_labels`` (M, 2), at ``at_labels + offs`` instead (labels that need not be corners).
    """
    pad = int(np.abs(offs).max())
    at0 = labels[which] if at_labels is None else np.asarray(at_labels, dtype=np.int64).reshape(-1, 2)
    both = np.r_[labels, at0]
    lo = both.min(axis=0) - pad
    ext = both.max(axis=0) - lo + pad + 1
    grid = np.full(tuple(ext), -1, dtype=np.int64)
    grid[labels[:, 0] - lo[0], labels[:, 1] - lo[1]] = np.arange(len(labels))
    at = at0[:, None, :] - lo + offs[None].astype(np.int64)
    return grid[at[..., 0], at[..., 1]]


def predict_labels(xy: np.ndarray, labels: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Where the lattice puts labels ``targets`` (M, 2): positions at offsets ``0, (+-1/2, 0), (0, +-1/2)``.

    From the second-order map (:func:`_fit_batch`, 14 unknowns) of the corners
    within :data:`CURVE_REACH` labels where at least :data:`CURVE_MIN` of them
    span its monomials (rows and columns that curve, cells that shrink towards a
    fisheye's rim), else from the homography of the corners within two labels
    (at least 5, not on one line). Returns (M, 5, 2); NaN where neither fits.

    Examples
    --------
    >>> lab = np.array([(i, j) for j in range(4) for i in range(5)])
    >>> P = predict_labels(10.0 * lab + 3.0, lab, np.array([[5, 1], [9, 9]]))
    >>> np.round(P[0, 0], 6).tolist(), bool(np.isnan(P[1]).all())
    ([53.0, 13.0], True)
    """
    xy = np.asarray(xy, dtype=np.float64)
    labels = np.asarray(labels, dtype=np.int64)
    targets = np.asarray(targets, dtype=np.int64).reshape(-1, 2)
    out = np.full((len(targets), 5, 2), np.nan)
    if len(targets) == 0 or len(labels) == 0:
        return out
    nbr = _label_grid(labels, np.zeros(0, np.int64), _CURVE_OFFS, at_labels=targets)
    w = (nbr >= 0).astype(np.float64)
    offs = _CURVE_OFFS.astype(np.float64)
    mono = _monomials(offs, 2)
    mom = np.einsum("nk,ka,kb->nab", w, mono, mono)
    tr = np.trace(mom, axis1=1, axis2=2)
    curved = (w.sum(axis=1) >= CURVE_MIN) & (np.linalg.eigvalsh(mom)[:, 0] > 1e-6 * np.maximum(tr, 1.0))
    if curved.any():
        out[curved] = predict_batch(xy, nbr[curved], w[curved], offs, order=2)
    near = (np.abs(offs) <= 2).all(axis=1)
    w1 = w[:, near]
    cov = np.einsum("nk,ka,kb->nab", w1, offs[near], offs[near])
    flat = ~curved & (w1.sum(axis=1) >= 5) & (np.linalg.det(cov) > 1e-9)
    if flat.any():
        out[flat] = predict_batch(xy, nbr[flat][:, near], w1[flat], offs[near])
    return out


def _curved_errors(xy: np.ndarray, labels: np.ndarray, which: np.ndarray, tol: float,
                   order: int = 2) -> np.ndarray:
    """Leave-one-out errors in cells of the corners ``which`` against second- or third-order maps of their
    neighbours.

    The map (:func:`_fit_batch`) is fitted to the corners within
    :data:`CURVE_REACH` labels, at least :data:`CURVE_MIN` of them for
    ``order=2`` (14 unknowns) and :data:`CUBIC_MIN` for ``order=3`` (22
    unknowns), whose monomials (:func:`_monomials`) span all of theirs
    (``order + 1`` distinct columns and rows: a row's curvature is measured,
    not guessed); the error is divided by the local cell of the same map. A
    corner whose error exceeds ``tol`` gets a second fit without the neighbour
    that fits worst. Corners with too few neighbours get ``inf``.

    The third order is there for strong lenses: a radial distortion
    ``x_d = x (1 + k r^2)`` of a board seen face on is a cubic of the label,
    which a second-order map misses by up to 0.3 of a cell at the rim of a
    180-degree fisheye; the cubic follows it to a few hundredths, so the
    tolerance stays the same.
    """
    err = np.full(len(which), np.inf)
    if len(which) == 0:
        return err
    nbr = _label_grid(labels, which, _CURVE_OFFS)
    w = (nbr >= 0).astype(np.float64)
    offs = _CURVE_OFFS.astype(np.float64)
    mono = _monomials(offs, order)
    mom = np.einsum("nk,ka,kb->nab", w, mono, mono)
    tr = np.trace(mom, axis1=1, axis2=2)
    least = CURVE_MIN if order == 2 else CUBIC_MIN
    fit = (w.sum(axis=1) >= least) & (np.linalg.eigvalsh(mom)[:, 0] > 1e-6 * np.maximum(tr, 1.0))
    if not fit.any():
        return err
    nbr, w, at = nbr[fit], w[fit], which[fit]
    e = _cells_batch(xy, nbr, w, offs, at, order)
    # a neighbour that is itself off spoils the fit: fit again without the worst one, if enough are left
    again = (e > tol) & (w.sum(axis=1) > least)
    if again.any():
        f = _fit_batch(xy, nbr[again], w[again], offs, order)
        res = np.hypot(*(_eval_batch(f, offs, order) - xy[np.maximum(nbr[again], 0)]).transpose(2, 0, 1))
        w2 = w[again].copy()
        w2[np.arange(len(w2)), np.argmax(np.where(w2 > 0, res, -np.inf), axis=1)] = 0.0
        e[again] = np.minimum(e[again], _cells_batch(xy, nbr[again], w2, offs, at[again], order))
    err[fit] = e
    return err


def _cells_batch(xy: np.ndarray, nbr: np.ndarray, w: np.ndarray, offs: np.ndarray,
                 at: np.ndarray, order: int = 2) -> np.ndarray:
    """Errors in local cells of ``xy[at]`` against maps of order ``order`` of the neighbours ``nbr``."""
    P = _eval_batch(_fit_batch(xy, nbr, w, offs, order), _HALF, order)
    cell = np.minimum(np.hypot(*(P[:, 1] - P[:, 2]).T), np.hypot(*(P[:, 3] - P[:, 4]).T))
    e = np.hypot(*(P[:, 0] - xy[at]).T) / np.maximum(cell, 1e-9)
    return np.where(np.isfinite(e), e, np.inf)


def _batch_errors(xy: np.ndarray, nbr: np.ndarray, w: np.ndarray, offs: np.ndarray,
                  which: np.ndarray) -> np.ndarray:
    """Leave-one-out errors in cells of the corners ``which`` (:func:`predict_batch`)."""
    P = predict_batch(xy, nbr, w, offs)
    cell = np.minimum(np.hypot(*(P[:, 1] - P[:, 2]).T), np.hypot(*(P[:, 3] - P[:, 4]).T))
    err = np.hypot(*(P[:, 0] - xy[which]).T) / np.maximum(cell, 1e-9)
    return np.where(np.isfinite(err), err, np.inf)


def predict_batch(xy: np.ndarray, nbr: np.ndarray, w: np.ndarray, offs: np.ndarray, *,
                  order: int = 1) -> np.ndarray:
    """Positions at label offsets ``0, (+-1/2, 0), (0, +-1/2)`` from maps fitted to the neighbours, (n, 5, 2).

    ``nbr`` (n, K): indices into ``xy`` of the neighbours at label offsets ``offs``
    (K, 2), -1 where there is none; ``w`` their 0/1 weights. One least-squares map
    per corner, all solved at once (:func:`_fit_batch`): ``order=1`` a homography,
    ``order=2`` its second-order extension.
    """
    fit = _fit_batch(xy, nbr, w, offs, order)
    return _eval_batch(fit, _HALF, order)


#: the label offsets at which a fitted map is evaluated: the corner and half a label along each axis
_HALF = np.array([[0, 0], [0.5, 0], [-0.5, 0], [0, 0.5], [0, -0.5]], float)


def _monomials(a: np.ndarray, order: int) -> np.ndarray:
    """``(i, j, 1)``, for ``order >= 2`` also ``(i^2, i j, j^2)``, for ``order=3`` also
    ``(i^3, i^2 j, i j^2, j^3)``, of label offsets ``a`` (..., 2).

    The offsets are a few fixed sets (:data:`_SUPPORT`, :data:`_CURVE_OFFS`, :data:`_HALF`, parts of
    them), so the result is kept (read-only) for each set and order.
    """
    a = np.asarray(a, dtype=np.float64)
    key = (a.shape, a.tobytes(), int(order))
    out = _MONOMIALS.get(key)
    if out is None:
        i, j = a[..., 0], a[..., 1]
        cols = [i, j, np.ones_like(i)]
        if order >= 2:
            cols += [i * i, i * j, j * j]
        if order >= 3:
            cols += [i ** 3, i * i * j, i * j * j, j ** 3]
        out = np.stack(cols, axis=-1)
        out.flags.writeable = False
        if len(_MONOMIALS) < 64:
            _MONOMIALS[key] = out
    return out


_MONOMIALS: dict[tuple, np.ndarray] = {}


def _fit_batch(xy: np.ndarray, nbr: np.ndarray, w: np.ndarray, offs: np.ndarray,
               order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares rational maps from label offsets to positions, one per row of ``nbr``.

    With ``m(i, j)`` the monomials of :func:`_monomials` (``M`` = 3 or 6 of
    them), the map is

        x = (p . m) / (1 + g1 i + g2 j),    y = (q . m) / (1 + g1 i + g2 j),

    in positions relative to the neighbours' mean and scaled by their mean
    distance from it (the normalisation of the DLT). ``order=1`` is the
    homography with ``h33 = 1`` (8 unknowns); ``order=2`` adds the quadratic
    terms to the numerators (14 unknowns): to second order in the label it
    follows rows and columns that are curves (lens distortion) as well as
    perspective, which it contains. The equations ``p . m - x (g1 i + g2 j) = x``
    (and the same for ``y``) are linear; the normal equations get a ridge of
    ``1e-12`` against exact degeneracy.

    Returns ``(h (n, 2 M + 2), mean (n, 2), scale (n,))``.
    """
    dst = xy[np.maximum(nbr, 0)]  # (n, K, 2)
    cnt = np.maximum(w.sum(axis=1), 1.0)
    mean = np.einsum("nk,nkd->nd", w, dst) / cnt[:, None]
    rel = dst - mean[:, None, :]
    scale = np.einsum("nk,nk->n", w, np.hypot(rel[..., 0], rel[..., 1])) / cnt
    scale = np.maximum(scale, 1e-12)
    b = rel / scale[:, None, None]
    m0 = _monomials(offs, order)
    A, rhs = _normal_equations(np.ascontiguousarray(w, dtype=np.float64), np.ascontiguousarray(b),
                               np.ascontiguousarray(offs, dtype=np.float64), np.ascontiguousarray(m0))
    h = np.linalg.solve(A, rhs[..., None])[..., 0]
    return h, mean, scale


@numba.njit(**_JIT)
def _normal_equations(w, b, a, m0):  # pragma: no cover - jit
    """The normal equations of :func:`_fit_batch`, ``(A (n, P, P), rhs (n, P))`` with ``P = 2 M + 2``.

    The rows of the design are ``r1 = (m, 0, -x a)`` and ``r2 = (0, m, -y a)`` (``m`` the monomials
    ``m0`` (K, M) of the offsets ``a`` (K, 2), ``(x, y)`` = ``b`` (n, K, 2)), weighted by ``w`` (0 or 1):
    ``A = sum_k w r1 r1^T + sum_k w r2 r2^T + 1e-12 I`` and ``rhs = sum_k w x r1 + sum_k w y r2``, as
    numpy's ``einsum("nk,nki,nkj->nij", ...)`` computes them, bit for bit: each sum over ``k`` in order
    from 0, each term ``(w r_i) r_j``. With ``w`` 0 or 1 the terms are symmetric in ``i, j``, and the sums
    over the zero blocks of ``r1`` and ``r2`` are ``+0``, so only the other blocks' sums are computed.
    """
    n = w.shape[0]
    P = 2 * m0.shape[1] + 2
    A = np.zeros((n, P, P))
    rhs = np.empty((n, P))
    for t in range(n):
        _monomial_rows(w[t], b[t], a, m0, A[t], rhs[t])
        _step_rows(w[t], b[t], a, m0.shape[1], A[t], rhs[t])
    return A, rhs


@numba.njit(**_JIT)
def _monomial_rows(w, b, a, m0, A, rhs):  # pragma: no cover - jit
    """:func:`_normal_equations`' rows of the monomials (the first ``2 M``), for one map."""
    K, M = m0.shape
    C = 2 * M
    for i in range(M):
        for j in range(i, M):
            s = 0.0
            for k in range(K):
                s += w[k] * m0[k, i] * m0[k, j]
            e = 1e-12 * (1.0 if i == j else 0.0)
            A[i, j] = A[j, i] = (s + 0.0) + e  # r1's block, r2's zeros
            A[M + i, M + j] = A[M + j, M + i] = (0.0 + s) + e  # r1's zeros, r2's block
        for c in range(2):
            s1 = 0.0
            s2 = 0.0
            for k in range(K):
                s1 += w[k] * m0[k, i] * (-b[k, 0] * a[k, c])
                s2 += w[k] * m0[k, i] * (-b[k, 1] * a[k, c])
            A[i, C + c] = A[C + c, i] = (s1 + 0.0) + 0.0
            A[M + i, C + c] = A[C + c, M + i] = (0.0 + s2) + 0.0
        q1 = 0.0
        q2 = 0.0
        for k in range(K):
            q1 += w[k] * m0[k, i] * b[k, 0]
            q2 += w[k] * m0[k, i] * b[k, 1]
        rhs[i] = q1 + 0.0
        rhs[M + i] = 0.0 + q2


@numba.njit(**_JIT)
def _step_rows(w, b, a, M, A, rhs):  # pragma: no cover - jit
    """:func:`_normal_equations`' last two rows (the denominator's ``g1, g2``), for one map."""
    K = w.shape[0]
    C = 2 * M
    for c in range(2):
        for d in range(c, 2):
            s1 = 0.0
            s2 = 0.0
            for k in range(K):
                s1 += w[k] * (-b[k, 0] * a[k, c]) * (-b[k, 0] * a[k, d])
                s2 += w[k] * (-b[k, 1] * a[k, c]) * (-b[k, 1] * a[k, d])
            A[C + c, C + d] = A[C + d, C + c] = (s1 + s2) + 1e-12 * (1.0 if c == d else 0.0)
        q1 = 0.0
        q2 = 0.0
        for k in range(K):
            q1 += w[k] * (-b[k, 0] * a[k, c]) * b[k, 0]
            q2 += w[k] * (-b[k, 1] * a[k, c]) * b[k, 1]
        rhs[C + c] = q1 + q2


def _eval_batch(fit: tuple[np.ndarray, np.ndarray, np.ndarray], q: np.ndarray, order: int) -> np.ndarray:
    """The maps of :func:`_fit_batch` at label offsets ``q`` (Q, 2): positions (n, Q, 2)."""
    h, mean, scale = fit
    m = _monomials(q, order)  # (Q, M)
    M = m.shape[1]
    den = 1.0 + q @ h[:, 2 * M:].T  # (Q, n)
    num = np.stack([h[:, :M] @ m.T, h[:, M:2 * M] @ m.T], axis=-1)  # (n, Q, 2)
    return num / den.T[..., None] * scale[:, None, None] + mean[:, None, :]


def _loo_error(src: np.ndarray, dst: np.ndarray, q: np.ndarray, p: np.ndarray, tol: float) -> float:
    """The error of ``p`` against the homography of its neighbours, in cells; fitted again without the
    neighbour that fits worst when the first is beyond ``tol`` (that neighbour may be the one that is off)."""
    H = homography(src, dst)
    if H is None:
        return np.inf
    err = _cells_off(H, q, p)
    if err > tol and len(src) >= 6:
        m = np.ones(len(src), bool)
        m[np.argmax(np.hypot(*(apply(H, src) - dst).T))] = False
        H2 = homography(src[m], dst[m])
        if H2 is not None:
            err = min(err, _cells_off(H2, q, p))
    return err


def _cells_off(H: np.ndarray, q: np.ndarray, p: np.ndarray) -> float:
    pts = apply(H, np.array([q, q + (0.5, 0), q - (0.5, 0), q + (0, 0.5), q - (0, 0.5)]))
    cell = min(np.hypot(*(pts[1] - pts[2])), np.hypot(*(pts[3] - pts[4])))
    return float(np.hypot(*(pts[0] - p)) / max(cell, 1e-9))
