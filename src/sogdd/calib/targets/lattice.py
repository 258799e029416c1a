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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .xcorners import XCorners

__all__ = ["check", "homography", "predict_labels"]

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
_CURVE_OFFS = np.array([(a, b) for a in range(-CURVE_REACH, CURVE_REACH + 1)
                        for b in range(-CURVE_REACH, CURVE_REACH + 1) if (a, b) != (0, 0)])


@dataclass
class Lattice:
    """One grown grid: ``index`` into the X-corners and their labels ``(i, j)``."""

    index: np.ndarray
    labels: np.ndarray

    def __len__(self) -> int:
        return len(self.index)


def _wrap_pi(a: np.ndarray) -> np.ndarray:
    """Angle differences of lines (mod pi) to ``[-pi/2, pi/2)``."""
    return np.mod(a + np.pi / 2, np.pi) - np.pi / 2


def _wrap(a: np.ndarray) -> np.ndarray:
    """Angle differences of rays (mod 2 pi) to ``[-pi, pi)``."""
    return np.mod(a + np.pi, 2 * np.pi) - np.pi


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
    d, idx = d[:, 1:], idx[:, 1:]  # the first is the corner itself
    v = xc.xy[idx] - xc.xy[:, None, :]
    ang = np.arctan2(v[..., 1], v[..., 0])
    e = np.stack([xc.light - xc.spread, xc.light + xc.spread], axis=1)  # rays: unwrapped, right-handed
    other = xc.edges[idx]  # (N, k-1, 2)
    flip = np.abs(np.abs(_wrap_pi(xc.light[idx] - xc.light[:, None])) - np.pi / 2) < POLARITY_TOL
    for r in range(4):
        ray = e[:, r % 2] + (np.pi if r >= 2 else 0.0)
        ok = np.abs(_wrap(ang - ray[:, None])) < CONE
        ok &= np.min(np.abs(_wrap_pi(other - ray[:, None, None])), axis=2) < EDGE_TOL
        ok &= flip & (d > 0)
        dd = np.where(ok, d, np.inf)
        best = np.argmin(dd, axis=1)
        has = np.isfinite(dd[np.arange(n), best])
        nb[has, r] = idx[has, best[has]]
        dist[has, r] = dd[has, best[has]]
    return nb, dist


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
    ang = np.arctan2(axes[:, 1], axes[:, 0])
    e = np.array([light - spread, light + spread])
    d = np.abs(_wrap_pi(e[:, None] - ang[None, :]))  # (edge, axis)
    straight = min(max(d[0, 0], d[1, 1]), max(d[0, 1], d[1, 0]))
    if straight < EDGE_TOL:
        return True
    mid = ang[0] + 0.5 * _wrap_pi(ang[1] - ang[0])  # a bisector of the two axis lines
    bis = float(np.min(np.abs(_wrap_pi(light - mid - np.array([0.0, np.pi / 2])))))
    return bis < EDGE_TOL / 2 and straight < 2 * EDGE_TOL


class _Grower:
    """The state of one board's growth: labels, positions, the free X-corners."""

    def __init__(self, xc: XCorners, tree: cKDTree, free: np.ndarray, limit: int | None) -> None:
        self.xc, self.tree, self.free, self.limit = xc, tree, free, limit
        self.at: dict[tuple[int, int], int] = {}
        self.tried: dict[tuple[int, int], int] = {}
        self.lo = np.array([0, 0])
        self.hi = np.array([0, 0])

    def add(self, lab: tuple[int, int], k: int) -> None:
        self.at[lab] = k
        self.free[k] = False
        self.lo = np.minimum(self.lo, lab)
        self.hi = np.maximum(self.hi, lab)

    def support(self, lab: tuple[int, int], reach: int = 2) -> tuple[np.ndarray, np.ndarray]:
        i, j = lab
        keys = [(a, b) for a in range(i - reach, i + reach + 1) for b in range(j - reach, j + reach + 1)
                if (a, b) in self.at and (a, b) != lab]
        idx = np.array([self.at[q] for q in keys], dtype=np.int64)
        return np.array(keys, dtype=np.float64).reshape(-1, 2), idx

    def within_limit(self, lab: tuple[int, int]) -> bool:
        if self.limit is None:
            return True
        ext = np.maximum(self.hi, lab) - np.minimum(self.lo, lab) + 1
        return bool(ext.max() <= self.limit)

    def accept(self, lab: tuple[int, int], k: int, axes: np.ndarray) -> bool:
        """The checks of a candidate ``k`` for ``lab`` (module doc)."""
        xc = self.xc
        if not _edges_follow(xc.light[k], xc.spread[k], axes):
            return False
        _, idx = self.support(lab, 1)
        if len(idx) == 0:
            return False
        s = np.median(xc.strength[idx])
        if not (s / CONTRAST_RATIO <= xc.strength[k] <= s * CONTRAST_RATIO):
            return False
        # parity: the light axis of a neighbour across an edge is perpendicular, of a diagonal one parallel
        i, j = lab
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                m = self.at.get((i + di, j + dj))
                if m is None or (di, dj) == (0, 0):
                    continue
                turn = (di + dj) % 2 == 1
                dl = abs(_wrap_pi(xc.light[k] - xc.light[m]))
                if (abs(dl - np.pi / 2) if turn else dl) >= POLARITY_TOL:
                    return False
        return True

    def search(self, lab: tuple[int, int], p: np.ndarray, radius: float,
               axes: np.ndarray) -> tuple[float, int] | None:
        """The nearest free X-corner within ``radius`` of ``p`` that :meth:`accept` takes for ``lab``:
        ``(distance, index)``, or None."""
        near = self.tree.query_ball_point(p, radius)
        for dd, k in sorted((float(np.hypot(*(self.xc.xy[k] - p))), k) for k in near if self.free[k]):
            if self.accept(lab, k, axes):
                return dd, k
        return None

    def frontier(self) -> list[tuple[int, int]]:
        out = set()
        for i, j in self.at:
            for di, dj in _OFFS:
                q = (i + di, j + dj)
                if q not in self.at:
                    out.add(q)
        return sorted(out)

    def untried(self) -> list[tuple[int, int]]:
        """The free labels next to the board with more support than when last tried."""
        labs = []
        for lab in self.frontier():
            n_sup = len(self.support(lab)[1])
            if self.tried.get(lab, -1) >= n_sup or not self.within_limit(lab):
                continue
            self.tried[lab] = n_sup
            labs.append(lab)
        return labs

    def round(self) -> int:
        """One round over the free labels next to the board; the number of corners added."""
        labs = self.untried()
        if not labs:
            return 0
        nbr = np.array([[self.at.get((i + a, j + b), -1) for a, b in _SUPPORT.tolist()] for i, j in labs],
                       dtype=np.int64)
        w = (nbr >= 0).astype(np.float64)
        cov = np.einsum("nk,ka,kb->nab", w, _SUPPORT.astype(float), _SUPPORT.astype(float))
        fit = (w.sum(axis=1) >= 4) & (np.linalg.det(cov) > 1e-9)
        if not fit.any():
            return 0
        P = predict_batch(self.xc.xy, nbr[fit], w[fit], _SUPPORT.astype(float))
        claims: dict[int, list[tuple[float, tuple[int, int]]]] = {}
        for lab, pts in zip([q for q, f in zip(labs, fit) if f], P):
            if not np.isfinite(pts).all():
                continue
            p, axes = pts[0], np.array([pts[1] - pts[2], pts[3] - pts[4]])
            cell = float(min(np.hypot(*axes[0]), np.hypot(*axes[1])))
            k = self.search(lab, p, SEARCH * cell, axes)
            if k is not None:
                claims.setdefault(k[1], []).append((k[0], lab))
        added = 0
        for k, cl in claims.items():
            if len(cl) == 1:  # a corner two labels claim is left for a later round
                self.add(cl[0][1], k)
                added += 1
        return added


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
    labs = np.array(list(g.at), dtype=np.int64).reshape(-1, 2)
    idx = np.array([g.at[tuple(q)] for q in labs.tolist()], dtype=np.int64)
    return Lattice(idx, labs)


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
    ``(i^3, i^2 j, i j^2, j^3)``, of label offsets ``a`` (..., 2)."""
    i, j = a[..., 0], a[..., 1]
    cols = [i, j, np.ones_like(i)]
    if order >= 2:
        cols += [i * i, i * j, j * j]
    if order >= 3:
        cols += [i ** 3, i * i * j, i * j * j, j ** 3]
    return np.stack(cols, axis=-1)


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
    m = np.broadcast_to(m0, b.shape[:2] + m0.shape[-1:])
    z = np.zeros_like(m)
    a = np.broadcast_to(offs, b.shape)
    r1 = np.concatenate([m, z, -b[..., :1] * a], axis=-1)
    r2 = np.concatenate([z, m, -b[..., 1:] * a], axis=-1)
    A = np.einsum("nk,nki,nkj->nij", w, r1, r1) + np.einsum("nk,nki,nkj->nij", w, r2, r2)
    rhs = np.einsum("nk,nki,nk->ni", w, r1, b[..., 0]) + np.einsum("nk,nki,nk->ni", w, r2, b[..., 1])
    A = A + 1e-12 * np.eye(A.shape[-1])
    h = np.linalg.solve(A, rhs[..., None])[..., 0]
    return h, mean, scale


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
