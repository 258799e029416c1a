"""The SODDC matrix and its det/trace corner measure (eqs. 23-25), tiled and compiled.

For every pixel the K x K second-order directional derivative correlation
(SODDC) matrix is the unnormalised window sum of outer products of the
absolute SOGDD responses (eq. 24)::

    Lambda = sum_{window} |l| |l|^T,     l = (l_1, ..., l_K)

and the corner measure is (eq. 25)::

    Upsilon = det(Lambda) / (trace(Lambda) + varsigma),   varsigma = 2.22e-16

The image is processed in row tiles, so memory stays bounded on large images.
Each tile is filtered with the three steerable basis kernels
(:func:`sogdd.filters.basis_tile`), then a numba kernel steers the responses to
K orientations, forms the window sums directly (no running sums, so no
cancellation) and takes the determinant with a symmetric Gaussian elimination
vectorised across pixels. Everything is float64: with K = 8 the determinant
passes 1e40 on strong corners.

Detection with an absolute threshold needs Upsilon only where it can reach
that threshold: ``soddc_measure(..., floor=T)`` first proves most pixels below
T with a Fischer bound built from six window sums, then evaluates the rest
exactly (see :func:`soddc_measure`).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numba
import numpy as np

from .filters import (
    basis_tile,
    kernel_radius,
    orientations,
    steerable_basis,
    steering_coefficients,
)

__all__ = [
    "VARSIGMA",
    "MeasureSpec",
    "soddc_from_responses",
    "soddc_measure",
    "supports_floor",
    "window_halfwidths",
    "window_offsets",
]

VARSIGMA = 2.22e-16
_EPS = float(np.finfo(np.float64).eps)


def window_halfwidths(shape: str, size: int) -> np.ndarray:
    """Half-width of the window on each row offset ``dy = -R..R``, ``size = 2R + 1``.

    ``"square"``: a ``size x size`` square. ``"disk"``: the offsets with
    ``dy^2 + dx^2 <= (R + 1/2)^2``; ``size = 5`` gives the 21 offsets with
    ``dy^2 + dx^2 <= 5`` of the authors' code.
    """
    R = int(size) // 2
    if shape == "square":
        return np.full(2 * R + 1, R, dtype=np.int64)
    if shape == "disk":
        dy = np.arange(-R, R + 1)
        return np.floor(np.sqrt((R + 0.5) ** 2 - dy * dy)).astype(np.int64)
    raise ValueError(f"unknown window shape {shape!r}")


def window_offsets(halfwidths: np.ndarray) -> np.ndarray:
    """(N, 2) ``(dy, dx)`` offsets covered by a window given by its half-widths."""
    R = (len(halfwidths) - 1) // 2
    return np.array(
        [(dy - R, dx) for dy, h in enumerate(halfwidths) for dx in range(-h, h + 1)], dtype=np.int64
    )


@dataclass(frozen=True)
class MeasureSpec:
    """Everything the measure depends on, resolved from a preset."""

    sigma2: float
    n_orientations: int
    halfwidths: np.ndarray  # per row offset of the window
    radius_rule: str = "paper"  # kernel radius rule
    zero_mean: bool = False  # subtract each kernel's mean (authors)
    # "response": filter the reflected image, then reflect the responses for the
    # window sums (scipy mode="reflect" at both stages). "image": reflect the image
    # once, wide enough for both stages (the authors' numpy.pad(..., "symmetric")).
    padding: str = "response"
    authors_measure: bool = False  # clamp tiny negative det, -inf for non-finite


def _reflect(idx: np.ndarray, n: int) -> np.ndarray:
    """Half-sample symmetric index map (scipy ``reflect``, numpy ``symmetric``), any reach."""
    m = np.mod(idx, 2 * n)
    return np.where(m < n, m, 2 * n - 1 - m)


_JIT = dict(cache=True, nogil=True, error_model="numpy", fastmath={"contract"})


@numba.njit(**_JIT)
def _steer(planes, y, x0, coef, absl, a, b):  # pragma: no cover - jit
    """absl[k, a:b] = |sum_p coef[k, p] planes[p, y, x0 + a : x0 + b]| (eq. 23 and the |.| of eq. 24)."""
    npl = planes.shape[0]
    w = b - a
    for k in range(coef.shape[0]):
        row = absl[k, a:b]
        if npl == 3:  # the steerable basis g_xx, g_xy, g_yy
            c0, c1, c2 = coef[k, 0], coef[k, 1], coef[k, 2]
            g0 = planes[0, y, x0 + a : x0 + b]
            g1 = planes[1, y, x0 + a : x0 + b]
            g2 = planes[2, y, x0 + a : x0 + b]
            for x in range(w):
                row[x] = abs(c0 * g0[x] + c1 * g1[x] + c2 * g2[x])
        else:
            for x in range(w):
                row[x] = 0.0
            for p in range(npl):
                cp = coef[k, p]
                if cp != 0.0:
                    g = planes[p, y, x0 + a : x0 + b]
                    for x in range(w):
                        row[x] += cp * g[x]
            for x in range(w):
                row[x] = abs(row[x])


@numba.njit(**_JIT)
def _row_sum(src, width, dst, n):  # pragma: no cover - jit
    """dst[x] = sum(src[x : x + width]) for x < n.

    The common widths are written out as one fused loop with a fixed pair-wise
    order, which vectorises far better than a loop over the window.
    """
    if width == 7:
        for x in range(n):
            dst[x] = ((src[x] + src[x + 1]) + (src[x + 2] + src[x + 3])) + (
                (src[x + 4] + src[x + 5]) + src[x + 6]
            )
    elif width == 5:
        for x in range(n):
            dst[x] = ((src[x] + src[x + 1]) + (src[x + 2] + src[x + 3])) + src[x + 4]
    elif width == 3:
        for x in range(n):
            dst[x] = (src[x] + src[x + 1]) + src[x + 2]
    else:
        for x in range(n):
            s = src[x]
            for t in range(1, width):
                s += src[x + t]
            dst[x] = s


@numba.njit(**_JIT)
def _column_sum(ring, first, nr, dst, a, b):  # pragma: no cover - jit
    """dst[x] = sum of ring[r, x] over the nr ring rows from ``first`` on, a <= x < b, in a fixed order."""
    # 1-D views indexed from 0 (here and in every hot loop): numba's negative-index
    # handling otherwise stops the loops from vectorising
    n = b - a
    d = dst[a:b]
    if nr == 7:
        r0, r1, r2 = ring[first % 7, a:b], ring[(first + 1) % 7, a:b], ring[(first + 2) % 7, a:b]
        r3, r4, r5 = ring[(first + 3) % 7, a:b], ring[(first + 4) % 7, a:b], ring[(first + 5) % 7, a:b]
        r6 = ring[(first + 6) % 7, a:b]
        for x in range(n):
            d[x] = ((r0[x] + r1[x]) + (r2[x] + r3[x])) + ((r4[x] + r5[x]) + r6[x])
    elif nr == 5:
        r0, r1, r2 = ring[first % 5, a:b], ring[(first + 1) % 5, a:b], ring[(first + 2) % 5, a:b]
        r3, r4 = ring[(first + 3) % 5, a:b], ring[(first + 4) % 5, a:b]
        for x in range(n):
            d[x] = ((r0[x] + r1[x]) + (r2[x] + r3[x])) + r4[x]
    else:
        src = ring[first % nr, a:b]
        for x in range(n):
            d[x] = src[x]
        for dy in range(1, nr):
            src = ring[(first + dy) % nr, a:b]
            for x in range(n):
                d[x] += src[x]


@numba.njit(**_JIT)
def _det_trace(acc, diag, det, tr, f, n):  # pragma: no cover - jit
    """det and trace of packed symmetric K x K matrices, one per column of ``acc``.

    Symmetric Gaussian elimination (LDL^T without pivoting) vectorised across
    pixels; det is the product of the pivots. A zero pivot of a PSD matrix means a
    zero row, hence det = 0, which the zero inverse pivot carries through.
    ``acc`` is overwritten.
    """
    K = diag.shape[0]
    for x in range(n):
        tr[x] = 0.0
        det[x] = 1.0
    for k in range(K):
        d = acc[diag[k]]
        for x in range(n):
            tr[x] += d[x]
    for j in range(K):
        dj = diag[j]
        pv = acc[dj]
        for x in range(n):
            d = pv[x]
            det[x] *= d
            pv[x] = 1.0 / d if d != 0.0 else 0.0
        for i in range(j + 1, K):
            rji = acc[dj + (i - j)]
            for x in range(n):
                f[x] = rji[x] * pv[x]
            qi0 = diag[i]
            for kk in range(i, K):
                dst = acc[qi0 + (kk - i)]
                src = acc[dj + (kk - j)]
                for x in range(n):
                    dst[x] -= f[x] * src[x]


@numba.njit(**_JIT)
def _pair_index(K):  # pragma: no cover - jit
    """Row i, column j of each packed upper-triangle entry q, and the q of each diagonal entry."""
    P = K * (K + 1) // 2
    pi = np.empty(P, np.int64)
    pj = np.empty(P, np.int64)
    diag = np.empty(K, np.int64)
    q = 0
    for i in range(K):
        for j in range(i, K):
            pi[q] = i
            pj[q] = j
            if i == j:
                diag[i] = q
            q += 1
    return pi, pj, diag


@numba.njit(**_JIT)
def _soddc_tile_rows(planes, off, coef, halfw, want_parts, out, det_out, tr_out, block):  # pragma: no cover
    """Fill ``out`` (Ht, W) with det/(tr + varsigma) for any window shape.

    ``planes`` (n, Ht + 2M, W + 2M) are filter responses on the tile plus a margin
    of ``M = R + off`` rows and columns on each side (``R`` = window half-height); the K
    responses are ``|coef @ planes|`` (the three steerable basis responses for
    SOGDD, or K responses with the identity). Each row of products is summed
    along the row with that row's half-width, then the rows are summed. Work goes
    in column blocks of ``block`` pixels so the rows stay in cache. With
    ``want_parts`` the raw det and trace are written too.
    """
    K = coef.shape[0]
    P = K * (K + 1) // 2
    nr = halfw.shape[0]
    R = (nr - 1) // 2
    Ht, W = out.shape
    uniq = np.unique(halfw)
    nu = uniq.shape[0]
    which = np.empty(nr, np.int64)
    for i in range(nr):
        for j in range(nu):
            if uniq[j] == halfw[i]:
                which[i] = j
    pi, pj, diag = _pair_index(K)
    WBP = block + 2 * R
    absl = np.empty((K, WBP))
    prod = np.empty(WBP)
    ring = np.empty((nr, nu, P, block))  # row sums of the last nr rows
    acc = np.empty((P, block))
    det = np.empty(block)
    f = np.empty(block)
    tr = np.empty(block)
    for x0 in range(0, W, block):
        n = min(block, W - x0)
        m = n + 2 * R
        for y in range(Ht + 2 * R):
            slot = y % nr
            _steer(planes, y + off, x0 + off, coef, absl, 0, m)
            for q in range(P):
                ai = absl[pi[q]]
                aj = absl[pj[q]]
                for x in range(m):
                    prod[x] = ai[x] * aj[x]
                for u in range(nu):
                    h = uniq[u]
                    _row_sum(prod[R - h :], 2 * h + 1, ring[slot, u, q], n)
            if y < 2 * R:
                continue
            yo = y - 2 * R
            for q in range(P):
                dst = acc[q]
                src = ring[yo % nr, which[0], q]
                for x in range(n):
                    dst[x] = src[x]
                for dy in range(1, nr):
                    src = ring[(yo + dy) % nr, which[dy], q]
                    for x in range(n):
                        dst[x] += src[x]
            _det_trace(acc, diag, det, tr, f, n)
            for x in range(n):
                out[yo, x0 + x] = det[x] / (tr[x] + 2.22e-16)
                if want_parts:
                    det_out[yo, x0 + x] = det[x]
                    tr_out[yo, x0 + x] = tr[x]


# Safety margins of the pruning bound, far above the rounding they cover: the
# bound's own (~50 eps relative to the Cauchy-Schwarz scale u_i u_j) and that of
# the elimination (~K^3 eps times the Hadamard bound of Upsilon).
_GAMMA = 1e-12
_HADAMARD_SLACK = 1e-10


@numba.njit(**_JIT)
def _fischer_row(srow, quad, pair, pi2, pj2, floor, keep, nb, work):  # pragma: no cover - jit
    """keep[c] = False where Upsilon < floor is proven from the window sums ``srow[:, c]``.

    ``srow`` holds the six window sums S_pq = sum g_p g_q of products of the
    basis responses (g_xx, g_xy, g_yy). Upper bound (Fischer's inequality on the
    2 x 2 diagonal blocks of adjacent orientations, then |sum l_i l_j| <= sum |l_i l_j|)::

        det(Lambda) <= prod_(i, j) (d_i d_j - t_ij^2),   d_i = sum l_i^2,   t_ij = sum l_i l_j

    Neither d nor t needs |.|: both are quadratic forms in S, so the bound costs
    six window sums for any K. Rounding is covered by the margins above, so a
    pruned pixel is one that the full computation also puts below ``floor``.
    """
    err, fb, hb, trs = work
    s00, s01, s02, s11, s12, s22 = srow[0], srow[1], srow[2], srow[3], srow[4], srow[5]
    for c in range(nb):
        # |c_kp| <= 1, so u = sum_p sqrt(S_pp) >= sum_p |c_kp| sqrt(S_pp) >= ||l_k|| (Minkowski),
        # and the rounding errors of d_k and t_ij are a tiny multiple of u^2
        u = np.sqrt(max(s00[c], 0.0)) + np.sqrt(max(s11[c], 0.0)) + np.sqrt(max(s22[c], 0.0))
        err[c] = _GAMMA * u * u
        fb[c] = 1.0
        hb[c] = 1.0
        trs[c] = 0.0
    K = quad.shape[0]
    for t in range(pi2.shape[0]):
        i = pi2[t]
        j = pj2[t]
        a0, a1, a2, a3, a4, a5 = quad[i, 0], quad[i, 1], quad[i, 2], quad[i, 3], quad[i, 4], quad[i, 5]
        b0, b1, b2, b3, b4, b5 = quad[j, 0], quad[j, 1], quad[j, 2], quad[j, 3], quad[j, 4], quad[j, 5]
        p0, p1, p2, p3, p4, p5 = pair[t, 0], pair[t, 1], pair[t, 2], pair[t, 3], pair[t, 4], pair[t, 5]
        for c in range(nb):
            di = a0 * s00[c] + a1 * s01[c] + a2 * s02[c] + a3 * s11[c] + a4 * s12[c] + a5 * s22[c]
            dj = b0 * s00[c] + b1 * s01[c] + b2 * s02[c] + b3 * s11[c] + b4 * s12[c] + b5 * s22[c]
            tij = p0 * s00[c] + p1 * s01[c] + p2 * s02[c] + p3 * s11[c] + p4 * s12[c] + p5 * s22[c]
            e = err[c]
            dd = (di + e) * (dj + e)
            tl = max(abs(tij) - e, 0.0)
            fb[c] *= dd - tl * tl
            hb[c] *= dd
            trs[c] += di + dj
    if K % 2 == 1:  # the last orientation is a 1 x 1 block
        k = K - 1
        a0, a1, a2, a3, a4, a5 = quad[k, 0], quad[k, 1], quad[k, 2], quad[k, 3], quad[k, 4], quad[k, 5]
        for c in range(nb):
            dk = a0 * s00[c] + a1 * s01[c] + a2 * s02[c] + a3 * s11[c] + a4 * s12[c] + a5 * s22[c]
            fb[c] *= dk + err[c]
            hb[c] *= dk + err[c]
            trs[c] += dk
    lim = floor * (1.0 - 1e-9)
    for c in range(nb):
        trl = trs[c] - K * err[c] + 2.22e-16
        # NaN or inf (overflow) keep the pixel: the bound proves nothing there
        keep[c] = not (trl > 0.0 and (fb[c] + _HADAMARD_SLACK * hb[c]) / trl < lim)


@numba.njit(**_JIT)
def _dilate_masks(keep, R, need, colneed, rowneed):  # pragma: no cover - jit
    """From the bound mask to what the square kernel must compute.

    ``keep`` (Ht + 2, W + 2) covers tile rows -1..Ht and columns -1..W. ``need``
    (Ht, W): pixels to evaluate (a 3 x 3 neighbour kept). ``colneed`` (Ht, W + 2R):
    columns -R..W+R-1 whose column sums those pixels use. ``rowneed``
    (Ht + 2R, W + 2R): window rows and columns whose products those sums use.
    """
    Ht, W = need.shape
    nr = 2 * R + 1
    hk = np.empty(W, np.uint8)
    for y in range(Ht):
        nd = need[y]
        for x in range(W):
            nd[x] = 0
        for dy in range(3):
            kr = keep[y + dy]
            for x in range(W):
                hk[x] = kr[x] | kr[x + 1] | kr[x + 2]
            for x in range(W):
                nd[x] |= hk[x]
        cn = colneed[y]
        for j in range(W + 2 * R):
            cn[j] = 0
        for t in range(nr):  # need[x] covers columns x .. x + 2R
            dst = cn[t : t + W]
            for x in range(W):
                dst[x] |= nd[x]
    for y in range(Ht + 2 * R):
        rn = rowneed[y]
        for j in range(W + 2 * R):
            rn[j] = 0
        for yo in range(max(0, y - 2 * R), min(Ht, y + 1)):
            cn = colneed[yo]
            for j in range(W + 2 * R):
                rn[j] |= cn[j]


@numba.njit(**_JIT)
def _next_run(mask, start, stop, gap):  # pragma: no cover - jit
    """The next run [a, b) of ``mask[j]`` (start <= a, b <= stop), bridging gaps shorter than ``gap``.

    Short loops cost more in overhead than they save, so nearby runs are merged.
    """
    j = start
    while j < stop and mask[j] == 0:
        j += 1
    a = j
    b = j
    while j < stop:
        if mask[j] != 0:
            j += 1
            b = j
        elif j - b < gap:
            j += 1
        else:
            break
    return a, b


@numba.njit(**_JIT)
def _soddc_tile_square(planes, off, coef, nr, need, colneed, rowneed, want_parts, out, det_out, tr_out,
                       block, gap):  # pragma: no cover - jit
    """Fill ``out`` (Ht, W) with det/(tr + varsigma) for an ``nr x nr`` square window.

    ``planes`` as in :func:`_soddc_tile_rows`. Products of the K absolute
    responses are kept for the last ``nr`` rows (a ring); each output row sums
    them down the columns, then along the row, both directly in a fixed
    pair-wise order (no running sums: the result must not depend on where a
    tile starts, and must not cancel). ``need``, ``colneed`` and ``rowneed``
    (:func:`_dilate_masks`) say which pixels, column sums and products to compute;
    pixels outside the (gap-merged) runs of ``need`` get ``-inf``. An empty
    ``need`` (shape (0, 0)) means all. Evaluated pixels get the same value, bit
    for bit, whatever the masks.
    """
    K = coef.shape[0]
    P = K * (K + 1) // 2
    R = (nr - 1) // 2
    Ht, W = out.shape
    dense = need.shape[0] == 0
    pi, pj, diag = _pair_index(K)
    WB = block + 2 * R
    labs = np.empty((K, WB))
    pring = np.empty((P, nr, WB))  # products of the last nr rows
    vsum = np.empty((P, WB))  # column sums of one output row
    # window sums of needed pixels are gathered from several runs and rows, so the
    # elimination runs on long vectors (its ~K^3/6 loops cost little per pixel then)
    cap = 2 * block
    acc = np.empty((P, cap))
    det = np.empty(cap)
    f = np.empty(cap)
    tr = np.empty(cap)
    ys = np.empty(cap, np.int64)
    xs = np.empty(cap, np.int64)
    pos = 0
    for x0 in range(0, W, block):
        n = min(block, W - x0)
        m = n + 2 * R
        for y in range(Ht + 2 * R):
            slot = y % nr
            xp = x0 + off
            a, b = 0, m
            if not dense:
                a, b = _next_run(rowneed[y, x0:], 0, m, gap)
            while a < b:
                w = b - a
                _steer(planes, y + off, xp, coef, labs, a, b)
                for q in range(P):
                    li = labs[pi[q], a:b]
                    lj = labs[pj[q], a:b]
                    pr = pring[q, slot, a:b]
                    for j in range(w):
                        pr[j] = li[j] * lj[j]
                if dense:
                    break
                a, b = _next_run(rowneed[y, x0:], b, m, gap)
            if y < 2 * R:
                continue
            yo = y - 2 * R
            a, b = 0, m
            if not dense:
                a, b = _next_run(colneed[yo, x0:], 0, m, gap)
            while a < b:
                for q in range(P):
                    _column_sum(pring[q], yo, nr, vsum[q], a, b)
                if dense:
                    break
                a, b = _next_run(colneed[yo, x0:], b, m, gap)
            if not dense:
                orow = out[yo, x0 : x0 + n]
                for c in range(n):
                    orow[c] = -np.inf
                a, b = _next_run(need[yo, x0:], 0, n, gap)
            else:
                a, b = 0, n
            while a < b:
                w = b - a
                if pos + w > cap:
                    _flush(acc, diag, det, tr, f, pos, ys, xs, want_parts, out, det_out, tr_out)
                    pos = 0
                for q in range(P):
                    _row_sum(vsum[q, a:], nr, acc[q, pos:], w)
                for t in range(w):
                    ys[pos + t] = yo
                    xs[pos + t] = x0 + a + t
                pos += w
                if dense:
                    break
                a, b = _next_run(need[yo, x0:], b, n, gap)
    _flush(acc, diag, det, tr, f, pos, ys, xs, want_parts, out, det_out, tr_out)


@numba.njit(**_JIT)
def _flush(acc, diag, det, tr, f, n, ys, xs, want_parts, out, det_out, tr_out):  # pragma: no cover - jit
    """det / (tr + varsigma) of the n gathered window sums, written to their pixels."""
    _det_trace(acc, diag, det, tr, f, n)
    for t in range(n):
        out[ys[t], xs[t]] = det[t] / (tr[t] + 2.22e-16)
        if want_parts:
            det_out[ys[t], xs[t]] = det[t]
            tr_out[ys[t], xs[t]] = tr[t]


@numba.njit(**_JIT)
def _bound_mask(planes, nr, quad, pair, pi2, pj2, floor, keep, block):  # pragma: no cover - jit
    """keep (Ht + 2, W + 2): the Fischer bound of tile rows -1..Ht, columns -1..W (margin R + 1).

    The six products of the basis responses are kept for the last ``nr`` rows
    (a ring), summed down the columns, then along the rows.
    """
    Hk, Wk = keep.shape
    nbm = block + 2
    WB = nbm + nr - 1
    pring = np.empty((6, nr, WB))
    scol = np.empty((6, WB))
    srow = np.empty((6, nbm))
    work = (np.empty(nbm), np.empty(nbm), np.empty(nbm), np.empty(nbm))
    row = np.empty(nbm, np.bool_)
    for x0 in range(0, Wk - 2, block):
        nb = min(block, Wk - 2 - x0) + 2
        wcols = nb + nr - 1
        for y in range(Hk + nr - 1):
            slot = y % nr
            q = 0
            for p in range(3):
                for pp in range(p, 3):
                    a = planes[p, y, x0 : x0 + wcols]
                    b = planes[pp, y, x0 : x0 + wcols]
                    dst = pring[q, slot]
                    for j in range(wcols):
                        dst[j] = a[j] * b[j]
                    q += 1
            r = y - nr + 1  # keep row whose window ends at planes row y
            if r < 0:
                continue
            for q in range(6):
                _column_sum(pring[q], r, nr, scol[q], 0, wcols)
                _row_sum(scol[q], nr, srow[q], nb)
            _fischer_row(srow, quad, pair, pi2, pj2, floor, row, nb, work)
            kr = keep[r, x0 : x0 + nb]
            for c in range(nb):
                kr[c] = row[c]


def _bound_tables(coef: np.ndarray):
    """Coefficients of d_k and t_ij (adjacent pairs) as forms in (S00, S01, S02, S11, S12, S22)."""
    c = np.asarray(coef, dtype=np.float64)
    K = len(c)
    quad = np.stack([c[:, 0] ** 2, 2 * c[:, 0] * c[:, 1], 2 * c[:, 0] * c[:, 2],
                     c[:, 1] ** 2, 2 * c[:, 1] * c[:, 2], c[:, 2] ** 2], axis=1)
    pi2 = np.arange(0, K - 1, 2, dtype=np.int64)
    pj2 = pi2 + 1
    a, b = c[pi2], c[pj2]
    pair = np.stack([a[:, 0] * b[:, 0], a[:, 0] * b[:, 1] + a[:, 1] * b[:, 0],
                     a[:, 0] * b[:, 2] + a[:, 2] * b[:, 0], a[:, 1] * b[:, 1],
                     a[:, 1] * b[:, 2] + a[:, 2] * b[:, 1], a[:, 2] * b[:, 2]], axis=1).reshape(-1, 6)
    return quad, pair, pi2, pj2


def _take(arr: np.ndarray, axis: int, start: int, stop: int) -> np.ndarray:
    """Indices start..stop-1 of ``arr`` along ``axis`` with half-sample reflection.

    A view when the range lies inside; otherwise the reflected copy (image edges).
    """
    n = arr.shape[axis]
    if 0 <= start and stop <= n:
        return arr[(slice(None),) * axis + (slice(start, stop),)]
    return np.take(arr, _reflect(np.arange(start, stop), n), axis=axis)


def _tile_domain(spec: MeasureSpec, img: np.ndarray, r0: int, r1: int, rk: int, M: int):
    """Steerable basis responses on rows r0-M..r1+M-1 and columns -M..W+M-1 of the tile."""
    basis = steerable_basis(spec.sigma2, rk, zero_mean=spec.zero_mean)
    return basis_tile(img, r0, r1, M, basis, reflect_image=spec.padding == "image")


def _n_threads() -> int:
    env = os.environ.get("SOGDD_NUM_THREADS")
    if env:
        return max(1, int(env))
    return max(1, min(os.cpu_count() or 1, 8))


def _tiled(
    H: int,
    W: int,
    domain,
    margin: int,
    coef: np.ndarray,
    halfwidths: np.ndarray,
    *,
    parts: bool = False,
    floor: float | None = None,
    tile_rows: int = 128,
    threads: int | None = None,
) -> np.ndarray | tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run the compiled tile kernel over row tiles, in threads.

    ``domain(r0, r1)`` returns the filter-response planes of one tile with
    ``margin`` extra rows and columns on each side (at least the window
    half-height R; R + 1 for ``floor``). With ``parts`` the raw det and trace
    maps are returned too; with ``floor`` the pruned kernel runs.
    """
    halfw = np.ascontiguousarray(halfwidths, dtype=np.int64)
    R = (len(halfw) - 1) // 2
    nr = 2 * R + 1
    square = _is_square(halfw)
    coef = np.ascontiguousarray(coef, dtype=np.float64)
    out = np.empty((H, W), dtype=np.float64)
    det = np.empty((H, W)) if parts else np.empty((1, 1))
    tr = np.empty((H, W)) if parts else np.empty((1, 1))
    starts = list(range(0, H, tile_rows))
    tables = _bound_tables(coef) if floor is not None else None
    none = np.zeros((0, 0), np.uint8)

    def run(r0: int) -> None:
        r1 = min(H, r0 + tile_rows)
        planes = domain(r0, r1)
        o, d, t = out[r0:r1], det[r0:r1] if parts else det, tr[r0:r1] if parts else tr
        if not square:
            _soddc_tile_rows(planes, margin - R, coef, halfw, parts, o, d, t, 256)
            return
        need = colneed = rowneed = none
        if tables is not None:
            h = r1 - r0
            keep = np.empty((h + 2, W + 2), np.uint8)
            _bound_mask(planes, nr, *tables, float(floor), keep, 256)
            need = np.empty((h, W), np.uint8)
            colneed = np.empty((h, W + 2 * R), np.uint8)
            rowneed = np.empty((h + 2 * R, W + 2 * R), np.uint8)
            _dilate_masks(keep, R, need, colneed, rowneed)
        _soddc_tile_square(planes, margin - R, coef, nr, need, colneed, rowneed, parts, o, d, t, 256, 32)

    n = threads or _n_threads()
    if n == 1 or len(starts) == 1:
        for r0 in starts:
            run(r0)
    else:
        with ThreadPoolExecutor(n) as pool:
            list(pool.map(run, starts))
    return (out, det, tr) if parts else out


def _is_square(halfwidths: np.ndarray) -> bool:
    """Whether a window given by its half-widths is a square."""
    return bool(np.all(np.asarray(halfwidths) == (len(halfwidths) - 1) // 2))


def supports_floor(spec: MeasureSpec) -> bool:
    """Whether :func:`soddc_measure` can prune below a floor for this spec (square windows)."""
    return not spec.authors_measure and _is_square(spec.halfwidths)


def soddc_measure(
    image: np.ndarray,
    spec: MeasureSpec,
    *,
    floor: float | None = None,
    tile_rows: int = 128,
    threads: int | None = None,
) -> np.ndarray:
    """The corner measure Upsilon (eq. 25) of a float64 grey image, H x W float64.

    Inputs are assumed valid (see :func:`sogdd.corner_response` for the checked
    public entry point).

    With ``floor`` (> 0, square windows, see :func:`supports_floor`) only what
    peak selection above ``floor`` needs is computed: Upsilon is exact, bit for
    bit as without ``floor``, at every pixel that has a 3 x 3 neighbour where a
    Fischer bound on det(Lambda) reaches ``floor`` (and at a few more, where
    nearby runs are merged); every pixel that holds ``-inf`` is provably below
    ``floor``. Local maxima above ``floor``,
    their values and their 3 x 3 neighbourhoods are then those of the full map,
    at a fraction of the cost on photographs (most pixels are proven below
    ``T_h`` by six window sums instead of K(K+1)/2 and an elimination).
    """
    img = np.ascontiguousarray(image, dtype=np.float64)
    H, W = img.shape
    rk = kernel_radius(spec.sigma2, spec.radius_rule)
    R = (len(spec.halfwidths) - 1) // 2
    if floor is not None and not (floor > 0 and supports_floor(spec)):
        raise ValueError("floor needs a positive value, a square window and the paper's measure")
    coef = steering_coefficients(orientations(spec.n_orientations))
    # one margin for both kernels, so the filter responses are computed identically
    M = R + 1
    res = _tiled(
        H, W, lambda r0, r1: _tile_domain(spec, img, r0, r1, rk, M), M, coef, spec.halfwidths,
        parts=spec.authors_measure, floor=floor, tile_rows=tile_rows, threads=threads,
    )
    return _authors_measure(res[1], res[2]) if spec.authors_measure else res


def soddc_from_responses(
    responses: np.ndarray, halfwidths: np.ndarray, *, tile_rows: int = 128, threads: int | None = None
) -> np.ndarray:
    """det / (tr + varsigma) of the window sums of ``|l| |l|^T`` for any K responses.

    For filter banks that are not steerable (the anisotropic kernels of the
    Zhang & Sun baselines). ``responses`` is (K, H, W), signed or absolute;
    they are reflected (half-sample) at the image border for the window sums.
    """
    resp = np.ascontiguousarray(responses, dtype=np.float64)
    K, H, W = resp.shape
    halfw = np.asarray(halfwidths, dtype=np.int64)
    if halfw.ndim != 1 or len(halfw) % 2 != 1 or (halfw < 0).any():
        raise ValueError("halfwidths must be an odd-length array of non-negative half-widths")
    R = (len(halfw) - 1) // 2

    def domain(r0: int, r1: int) -> np.ndarray:
        return np.ascontiguousarray(_take(_take(resp, 1, r0 - R, r1 + R), 2, -R, W + R))

    return _tiled(H, W, domain, R, np.eye(K), halfw, tile_rows=tile_rows, threads=threads)


def _authors_measure(det: np.ndarray, tr: np.ndarray) -> np.ndarray:
    """The authors' post-processing: tiny negative det -> 0, non-finite -> -inf."""
    big = np.max(np.abs(det)) if det.size else 0.0
    det = np.where((det < 0) & (det >= -_EPS * big), 0.0, det)
    with np.errstate(all="ignore"):
        ups = det / (tr + _EPS)
    ups[~np.isfinite(ups)] = -np.inf
    return ups
