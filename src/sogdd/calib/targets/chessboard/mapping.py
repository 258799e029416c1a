"""The lattice's map: where a board's labels lie in the image, and the check that each corner is there.

A board's labels ``(i, j)`` map to the image by a homography locally (perspective
and mild lens distortion: :func:`homography`, :func:`predict_batch` over the
corners within two labels) or, where rows and columns are curves (a fisheye), by
a second- or else a third-order map of the corners within three labels
(:func:`_fit_batch`: polynomial numerators over the homography's linear
denominator; :func:`predict_labels`). :func:`check` is the lattice's last guard:
each corner must be predicted by a homography of its neighbours (leaving it out)
within a fraction of a cell, or by the curved map where the homography cannot
follow the rows.

The normal equations of the maps (:func:`_normal_equations`) are compiled
without ``fastmath``: the same floating-point operations, in the same order, as
the numpy they replace (the boards are the same to the bit). The lattice's
growth and :func:`check`'s first fit solve one local homography per label in
compiled code (:func:`predict_local`, a small LU: :func:`solve_small`); the
batched solves of the curved maps and the homography of :func:`check`'s second
fit stay numpy's.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sogdd._jit import EXACT_JIT

__all__ = ["CHECK_TOL", "SUPPORT", "apply", "check", "homography", "label_grid", "predict_batch",
           "predict_labels", "predict_local", "solve_small"]

#: leave-one-out prediction error allowed for a refined corner, in cells (:func:`check`)
CHECK_TOL = 0.12

#: the label offsets of the corners a local homography is fitted to: those within two labels
SUPPORT = np.array([(a, b) for a in range(-2, 3) for b in range(-2, 3) if (a, b) != (0, 0)])
_SUPPORT_F = SUPPORT.astype(np.float64)


_MONOMIALS: dict[tuple, np.ndarray] = {}


#: the second-order check (:func:`check`) fits the corners within this many labels ...
CURVE_REACH = 3


#: ... at least this many of them (14 unknowns: 24 equations or more)
CURVE_MIN = 12


#: the third-order check (:func:`check`) fits at least this many corners within :data:`CURVE_REACH` labels
#: (22 unknowns: 26 equations or more; a corner of a board of four rows has 15 such neighbours)
CUBIC_MIN = 13


_CURVE_OFFS = np.array([(a, b) for a in range(-CURVE_REACH, CURVE_REACH + 1)
                        for b in range(-CURVE_REACH, CURVE_REACH + 1) if (a, b) != (0, 0)])


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
    offs = SUPPORT if reach == 2 else np.array([(a, b) for a in span for b in span if (a, b) != (0, 0)])
    offs_f = _SUPPORT_F if reach == 2 else offs.astype(float)
    nbr = label_grid(labels, which, offs)
    w = (nbr >= 0).astype(np.float64)
    cnt = w.sum(axis=1)
    cov = np.einsum("nk,ka,kb->nab", w, offs_f, offs_f)
    fit = (cnt >= 5) & (np.linalg.det(cov) * 1.0 > 1e-9)
    err = np.full(len(which), np.inf)
    if fit.any():
        err[fit] = _local_errors(xy, nbr[fit], offs_f, which[fit])
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


def label_grid(labels: np.ndarray, which: np.ndarray, offs: np.ndarray, *,
                at_labels: np.ndarray | None = None) -> np.ndarray:
    """Indices of the corners at ``labels[which] + offs`` (len(which), K), -1 where there is none.

    With ``at_labels`` (M, 2), at ``at_labels + offs`` instead (labels that need not be corners).
    """
    at0 = labels[which] if at_labels is None else np.asarray(at_labels).reshape(-1, 2)
    if not len(labels):
        return np.full((len(at0), len(offs)), -1, dtype=np.int64)
    return _label_grid(np.ascontiguousarray(labels, dtype=np.int64), np.ascontiguousarray(at0, dtype=np.int64),
                       np.ascontiguousarray(offs, dtype=np.int64))  # compiled: it runs several times a view


@numba.njit(**EXACT_JIT)
def _label_grid(labels, at, offs):  # pragma: no cover - jit
    """:func:`label_grid`: the corners' indices on a grid of their labels (a later corner of a label over an
    earlier one, as numpy's assignment), read at ``at + offs``."""
    pad = 0
    for k in range(offs.shape[0]):
        pad = max(pad, abs(offs[k, 0]), abs(offs[k, 1]))
    lo0, lo1 = labels[0, 0], labels[0, 1]
    hi0, hi1 = lo0, lo1
    for src in (labels, at):
        for i in range(src.shape[0]):
            lo0, lo1 = min(lo0, src[i, 0]), min(lo1, src[i, 1])
            hi0, hi1 = max(hi0, src[i, 0]), max(hi1, src[i, 1])
    lo0 -= pad
    lo1 -= pad
    grid = np.full((hi0 - lo0 + pad + 1, hi1 - lo1 + pad + 1), -1, np.int64)
    for i in range(labels.shape[0]):
        grid[labels[i, 0] - lo0, labels[i, 1] - lo1] = i
    out = np.empty((at.shape[0], offs.shape[0]), np.int64)
    for m in range(at.shape[0]):
        for k in range(offs.shape[0]):
            out[m, k] = grid[at[m, 0] - lo0 + offs[k, 0], at[m, 1] - lo1 + offs[k, 1]]
    return out


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
    nbr = label_grid(labels, np.zeros(0, np.int64), _CURVE_OFFS, at_labels=targets)
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
    nbr = label_grid(labels, which, _CURVE_OFFS)
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


@numba.njit(**EXACT_JIT)
def _local_errors(xy, nbr, offs, at):  # pragma: no cover - jit
    """Leave-one-out errors in cells of the corners ``at`` (n,) against the local homographies of their
    neighbours ``nbr`` (n, K) at offsets ``offs`` (:func:`predict_local`):
    ``|P0 - xy[at]| / max(min(|P1 - P2|, |P3 - P4|), 1e-9)``, ``inf`` where the map is not finite."""
    n = nbr.shape[0]
    out = np.full(n, np.inf)
    P = np.empty((5, 2))
    for t in range(n):
        if not predict_local(xy, nbr[t], offs, P):
            continue
        cell = min(math.hypot(P[1, 0] - P[2, 0], P[1, 1] - P[2, 1]),
                   math.hypot(P[3, 0] - P[4, 0], P[3, 1] - P[4, 1]))
        e = math.hypot(P[0, 0] - xy[at[t], 0], P[0, 1] - xy[at[t], 1]) / max(cell, 1e-9)
        if np.isfinite(e):
            out[t] = e
    return out


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

    The offsets are a few fixed sets (:data:`SUPPORT`, :data:`_CURVE_OFFS`, :data:`_HALF`, parts of
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
    w = np.ascontiguousarray(w, dtype=np.float64)
    cnt, mean, rel, dist = _centred(np.ascontiguousarray(xy, dtype=np.float64), np.ascontiguousarray(nbr), w)
    scale = np.einsum("nk,nk->n", w, dist) / cnt  # numpy's: its SIMD sums in an order of their own
    scale = np.maximum(scale, 1e-12)
    b = rel / scale[:, None, None]
    m0 = _monomials(offs, order)
    A, rhs = _normal_equations(w, np.ascontiguousarray(b),
                               np.ascontiguousarray(offs, dtype=np.float64), np.ascontiguousarray(m0))
    h = np.linalg.solve(A, rhs[..., None])[..., 0]
    return h, mean, scale


@numba.njit(**EXACT_JIT)
def _centred(xy, nbr, w):  # pragma: no cover - jit
    """:func:`_fit_batch`'s neighbours about their mean, as its numpy computed them, bit for bit: ``(cnt (n,),
    mean (n, 2), rel (n, K, 2), dist (n, K))`` with ``cnt = max(sum_k w, 1)``, ``mean = sum_k w xy / cnt``
    (``einsum("nk,nkd->nd", ...)``'s sum, in order from ``k = 0``), ``rel = xy - mean`` and ``dist`` the
    length of ``rel`` (libm's ``hypot``, as numpy's); ``xy`` of ``nbr < 0`` is ``xy[0]`` (weight 0)."""
    n, K = nbr.shape
    cnt = np.empty(n)
    mean = np.empty((n, 2))
    rel = np.empty((n, K, 2))
    dist = np.empty((n, K))
    for t in range(n):
        c = 0.0
        m0 = 0.0
        m1 = 0.0
        for k in range(K):
            q = max(nbr[t, k], 0)
            c += w[t, k]
            m0 += w[t, k] * xy[q, 0]
            m1 += w[t, k] * xy[q, 1]
        c = max(c, 1.0)
        cnt[t] = c
        m0 /= c
        m1 /= c
        mean[t, 0] = m0
        mean[t, 1] = m1
        for k in range(K):
            q = max(nbr[t, k], 0)
            rel[t, k, 0] = xy[q, 0] - m0
            rel[t, k, 1] = xy[q, 1] - m1
            dist[t, k] = math.hypot(rel[t, k, 0], rel[t, k, 1])
    return cnt, mean, rel, dist


@numba.njit(**EXACT_JIT)
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


@numba.njit(**EXACT_JIT)
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


@numba.njit(**EXACT_JIT)
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


@numba.njit(**EXACT_JIT)
def predict_local(xy, nbr, offs, P):  # pragma: no cover - jit
    """One local homography of :func:`predict_batch` (``order=1``), compiled: the lattice's growth and
    :func:`check` fit one per label.

    ``nbr`` (K,): indices into ``xy`` of the corners at label offsets ``offs``
    (K, 2) float, -1 for none.
    The same map as :func:`_fit_batch`'s, in the same normalisation (positions
    about the corners' mean, over their mean distance from it), with the 8 x 8
    normal equations solved by LU with partial pivoting (:func:`solve_small`)
    instead of numpy's batched solve: the last bits may differ from
    :func:`predict_batch`'s. Writes into ``P`` (5, 2) the map at the offsets
    ``0, (+-1/2, 0), (0, +-1/2)`` (the rows of :data:`_HALF`) and returns
    whether they are all finite.
    """
    K = nbr.shape[0]
    w = np.zeros(K)
    b = np.zeros((K, 2))
    m0 = np.ones((K, 3))  # the monomials (i, j, 1)
    m0[:, :2] = offs
    cnt = 0.0
    mx = 0.0
    my = 0.0
    for k in range(K):
        q = nbr[k]
        if q >= 0:
            w[k] = 1.0
            cnt += 1.0
            mx += xy[q, 0]
            my += xy[q, 1]
    cnt = max(cnt, 1.0)
    mx /= cnt
    my /= cnt
    scale = 0.0
    for k in range(K):
        q = nbr[k]
        if q >= 0:
            b[k, 0] = xy[q, 0] - mx
            b[k, 1] = xy[q, 1] - my
            scale += math.hypot(b[k, 0], b[k, 1])
    scale = max(scale / cnt, 1e-12)
    for k in range(K):
        b[k, 0] /= scale
        b[k, 1] /= scale
    A = np.zeros((8, 8))
    h = np.empty(8)
    _monomial_rows(w, b, offs, m0, A, h)
    _step_rows(w, b, offs, 3, A, h)
    if not solve_small(A, h):
        return False
    fin = True
    for t in range(5):
        i = _HALF[t, 0]
        j = _HALF[t, 1]
        den = 1.0 + h[6] * i + h[7] * j
        P[t, 0] = (h[0] * i + h[1] * j + h[2]) / den * scale + mx
        P[t, 1] = (h[3] * i + h[4] * j + h[5]) / den * scale + my
        fin &= np.isfinite(P[t, 0]) and np.isfinite(P[t, 1])
    return fin


@numba.njit(**EXACT_JIT)
def solve_small(A, b):  # pragma: no cover - jit
    """``A x = b`` for a small square ``A`` by LU with partial pivoting, in place: ``b`` becomes ``x`` and
    ``A`` is overwritten; False where a pivot is zero (a singular ``A``)."""
    n = A.shape[0]
    for c in range(n):
        piv = c + np.argmax(np.abs(A[c:, c]))
        if A[piv, c] == 0.0:
            return False
        if piv != c:
            for u in range(c, n):
                A[c, u], A[piv, u] = A[piv, u], A[c, u]
            b[c], b[piv] = b[piv], b[c]
        for r in range(c + 1, n):
            f = A[r, c] / A[c, c]
            for u in range(c + 1, n):
                A[r, u] -= f * A[c, u]
            b[r] -= f * b[c]
    for c in range(n - 1, -1, -1):
        s = b[c]
        for u in range(c + 1, n):
            s -= A[c, u] * b[u]
        b[c] = s / A[c, c]
    return True


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
