"""Compiled tile code of the SODDC measure: steering, window sums, det/trace.

The K x K SODDC matrix of every pixel is the window sum of ``|l| |l|^T``
(eq. 24), and the measure is ``det / (trace + varsigma)`` (eq. 25). These
functions work on one row tile at a time (see :mod:`sogdd.measure.soddc` for the
driver). Sums are direct and in a fixed pair-wise order (no running sums), so a
value never depends on where a tile starts and never suffers cancellation.

Two tile functions are kept. :func:`tile_square` (square windows, the paper
preset) keeps column sums and can evaluate only masked pixels (pruning);
:func:`sogdd.measure.general_tiles.tile_general` handles any window shape (the authors' disk). On the full
map the square one is faster (paper preset's kernel alone, one thread: 50 against
64 ms/MP, its column sums serving 4 output rows per pass), and only it evaluates
the masked pixels that pruned detection needs (README's speed table). Where the
square tile function's time goes (K = 8, full map, one thread, by leaving stages out):
products 10 ms/MP, column sums 10, row sums 16.5, the elimination 5, the rest 6.
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import JIT, ROW_PAD
from .det_unrolled import det_trace_4, det_trace_6, det_trace_8
from .window_sums import wcolumn_sums, wrow_sum

__all__ = [
    "AUTHORS_EPS", "VARSIGMA", "det_trace", "det_trace_loop", "pair_index", "row_sum", "column_sum", "steer",
    "tile_square",
]

#: varsigma of eq. (25), the one home of both constants of the measure (the GPU path imports them)
VARSIGMA = 2.22e-16
#: the authors' varsigma: float64 machine epsilon (their code's ``eps``)
AUTHORS_EPS = float(np.finfo(np.float64).eps)


@numba.njit(**JIT)
def steer(planes, y, x0, coef, absl, a, b):  # pragma: no cover - jit
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


@numba.njit(**JIT)
def row_sum(src, width, dst, n, wdim):  # pragma: no cover - jit
    """dst[x] = sum(src[x : x + width]) for x < n (``wdim``: :func:`sogdd._jit.window_rows`).

    The common widths are written out as one fused loop with a fixed pair-wise
    order, which vectorises far better than a loop over the window.
    """
    if len(wdim) == 7 or width == 7:
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


@numba.njit(**JIT)
def column_sum(ring, first, nr, dst, a, b, wdim):  # pragma: no cover - jit
    """dst[x] = sum of ring[r % nh, x] for r = first .. first + nr - 1, a <= x < b, in a fixed order.

    ``wdim``: :func:`sogdd._jit.window_rows`.
    """
    # 1-D views indexed from 0 (here and in every hot loop): numba's negative-index
    # handling otherwise stops the loops from vectorising
    nh = ring.shape[0]  # the ring's rows, >= nr
    n = b - a
    d = dst[a:b]
    if len(wdim) == 7 or nr == 7:
        r0, r1, r2 = ring[first % nh, a:b], ring[(first + 1) % nh, a:b], ring[(first + 2) % nh, a:b]
        r3, r4, r5 = ring[(first + 3) % nh, a:b], ring[(first + 4) % nh, a:b], ring[(first + 5) % nh, a:b]
        r6 = ring[(first + 6) % nh, a:b]
        for x in range(n):
            d[x] = ((r0[x] + r1[x]) + (r2[x] + r3[x])) + ((r4[x] + r5[x]) + r6[x])
    elif nr == 5:
        r0, r1, r2 = ring[first % nh, a:b], ring[(first + 1) % nh, a:b], ring[(first + 2) % nh, a:b]
        r3, r4 = ring[(first + 3) % nh, a:b], ring[(first + 4) % nh, a:b]
        for x in range(n):
            d[x] = ((r0[x] + r1[x]) + (r2[x] + r3[x])) + r4[x]
    else:
        src = ring[first % nh, a:b]
        for x in range(n):
            d[x] = src[x]
        for dy in range(1, nr):
            src = ring[(first + dy) % nh, a:b]
            for x in range(n):
                d[x] += src[x]


@numba.njit(**JIT)
def column_sums(ring, first, nr, ng, dst, a, b, wdim):  # pragma: no cover - jit
    """dst[i, x] = :func:`column_sum` of ring rows ``first + i`` on (modulo the ring's rows), i < ng.

    Several output rows in one pass load each ring row once for all of them (the
    pass is bound by loads and stores, not additions); every sum keeps the
    order of :func:`column_sum`, so the values are the same bit for bit (``wdim``:
    :func:`sogdd._jit.window_rows`).
    """
    nh = ring.shape[0]
    n = b - a
    if (len(wdim) == 7 or nr == 7) and ng == 4:
        r0, r1, r2 = ring[first % nh, a:b], ring[(first + 1) % nh, a:b], ring[(first + 2) % nh, a:b]
        r3, r4, r5 = ring[(first + 3) % nh, a:b], ring[(first + 4) % nh, a:b], ring[(first + 5) % nh, a:b]
        r6, r7, r8 = ring[(first + 6) % nh, a:b], ring[(first + 7) % nh, a:b], ring[(first + 8) % nh, a:b]
        r9 = ring[(first + 9) % nh, a:b]
        d0, d1, d2, d3 = dst[0, a:b], dst[1, a:b], dst[2, a:b], dst[3, a:b]
        for x in range(n):
            p23 = r2[x] + r3[x]
            p45 = r4[x] + r5[x]
            p34 = r3[x] + r4[x]
            p56 = r5[x] + r6[x]
            d0[x] = ((r0[x] + r1[x]) + p23) + (p45 + r6[x])
            d1[x] = ((r1[x] + r2[x]) + p34) + (p56 + r7[x])
            d2[x] = (p23 + p45) + ((r6[x] + r7[x]) + r8[x])
            d3[x] = (p34 + p56) + ((r7[x] + r8[x]) + r9[x])
        return
    if len(wdim) != 7 and nr == 5 and ng == 4:
        r0, r1, r2 = ring[first % nh, a:b], ring[(first + 1) % nh, a:b], ring[(first + 2) % nh, a:b]
        r3, r4, r5 = ring[(first + 3) % nh, a:b], ring[(first + 4) % nh, a:b], ring[(first + 5) % nh, a:b]
        r6, r7 = ring[(first + 6) % nh, a:b], ring[(first + 7) % nh, a:b]
        d0, d1, d2, d3 = dst[0, a:b], dst[1, a:b], dst[2, a:b], dst[3, a:b]
        for x in range(n):
            p23 = r2[x] + r3[x]
            p34 = r3[x] + r4[x]
            d0[x] = ((r0[x] + r1[x]) + p23) + r4[x]
            d1[x] = ((r1[x] + r2[x]) + p34) + r5[x]
            d2[x] = (p23 + (r4[x] + r5[x])) + r6[x]
            d3[x] = (p34 + (r5[x] + r6[x])) + r7[x]
        return
    for i in range(ng):
        column_sum(ring, first + i, nr, dst[i], a, b, wdim)


@numba.njit(**JIT)
def det_trace(acc, diag, det, tr, f, n, kdim):  # pragma: no cover - jit
    """det and trace of packed symmetric K x K matrices, one per column of ``acc``.

    Symmetric Gaussian elimination (LDL^T without pivoting) vectorised across
    pixels; det is the product of the pivots. A zero pivot of a PSD matrix means a
    zero row, hence det = 0, which the zero inverse pivot carries through.
    ``acc`` may be overwritten. K = 4, 6 and 8 run :func:`det_trace_loop`'s
    operations unrolled, values in registers (:mod:`sogdd.measure.det_unrolled`; 2.6x
    faster at K = 8), with the same values bit for bit; ``kdim`` (:func:`sogdd._jit.elimination`)
    says which, when numba compiles (each ``len(kdim)`` is a constant of its type).
    """
    if len(kdim) == 8:
        det_trace_8(acc, det, tr, n)
    elif len(kdim) == 6:
        det_trace_6(acc, det, tr, n)
    elif len(kdim) == 4:
        det_trace_4(acc, det, tr, n)
    else:
        det_trace_loop(acc, diag, det, tr, f, n)


@numba.njit(**JIT)
def det_trace_loop(acc, diag, det, tr, f, n):  # pragma: no cover - jit
    """:func:`det_trace` for any K, each step of the elimination a loop over pixels (``acc`` overwritten)."""
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


@numba.njit(**JIT)
def pair_index(K):  # pragma: no cover - jit
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


@numba.njit(**JIT)
def next_run(mask, start, stop, gap):  # pragma: no cover - jit
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


@numba.njit(**JIT)
def tile_square(planes, off, coef, nr, need, colneed, rowneed, want_parts, out, det_out, tr_out,
                block, gap, y0, y1, clear, wts, kdim, wdim):  # pragma: no cover - jit
    """Fill ``out`` (Ht, W) with det/(tr + varsigma) for an ``nr x nr`` square window.

    ``planes`` as in :func:`sogdd.measure.general_tiles.tile_general`. Products of the K absolute
    responses are kept for the last ``nr + 3`` rows (a ring); groups of 4 output
    rows sum them down the columns in one pass (:func:`column_sums`, over the
    union of their column masks), then each row along the row, both directly in a fixed
    pair-wise order (no running sums: the result must not depend on where a
    tile starts, and must not cancel). ``need``, ``colneed`` and ``rowneed``
    (:func:`sogdd.measure.bound.spread_masks`) say which pixels, column sums and products to compute;
    with ``clear``, pixels outside the (gap-merged) runs of ``need`` get ``-inf``
    (without it they keep their value: a second pass adds pixels). An empty
    ``need`` (shape (0, 0)) means all. Only output rows ``y0 .. y1 - 1`` are
    touched. Evaluated pixels get the same value, bit for bit, whatever the
    masks and rows. ``wts`` (``nr`` positive weights) makes the window
    separable-weighted (:mod:`sogdd.measure.window_sums`): weighted column sums, then row sums;
    ``None`` is the box window. Each test of ``wts`` is written ``wts is None`` on the
    argument itself, so that numba drops the weighted code from the box window's
    compilation (dead branch pruning on a None argument: less to compile on the first run);
    ``kdim`` (:func:`sogdd._jit.elimination`) and ``wdim`` (:func:`sogdd._jit.window_rows`) do the same for
    the elimination and the window's sums.
    """
    K = coef.shape[0]
    P = K * (K + 1) // 2
    R = (nr - 1) // 2
    Ht, W = out.shape
    dense = need.shape[0] == 0
    pi, pj, diag = pair_index(K)
    WB = block + 2 * R
    labs = np.empty((K, WB))
    G = 4  # output rows per column pass (column_sums)
    pring = np.empty((P, nr + G - 1, WB))  # products of the last nr + G - 1 rows
    vsum = np.empty((G, WB))  # column sums of one pair for G output rows
    cm = np.empty(WB, np.uint8)
    ca = np.empty(G * WB, np.int64)  # runs [ca, cb) of column sums, [na, nb) of pixels in row ni of a group
    cb = np.empty(G * WB, np.int64)
    ci = np.empty(G * WB, np.int64)
    na = np.empty(G * block, np.int64)
    nb = np.empty(G * block, np.int64)
    ni = np.empty(G * block, np.int64)
    # window sums of needed pixels are gathered from several runs and rows, so the
    # elimination runs on long vectors (its ~K^3/6 loops cost little per pixel then)
    cap = G * block  # >= one group of rows
    acc = np.empty((P, cap + ROW_PAD))
    det = np.empty(cap)
    f = np.empty(cap)
    tr = np.empty(cap)
    ys = np.empty(cap, np.int64)
    xs = np.empty(cap, np.int64)
    # np.int64(0), not 0: a literal would compile a second, Literal[int](0) specialisation of
    # every callee it reaches before numba's type inference has unified it with the loop's values
    zero = np.int64(0)
    pos = zero
    for x0 in range(0, W, block):
        n = min(block, W - x0)
        m = n + 2 * R
        for y in range(y0, y1 + 2 * R):
            slot = y % (nr + G - 1)
            xp = x0 + off
            a, b = 0, m
            if not dense:
                a, b = next_run(rowneed[y, x0:], zero, m, gap)
            while a < b:
                w = b - a
                steer(planes, y + off, xp, coef, labs, a, b)
                for q in range(P):
                    li = labs[pi[q], a:b]
                    lj = labs[pj[q], a:b]
                    pr = pring[q, slot, a:b]
                    for j in range(w):
                        pr[j] = li[j] * lj[j]
                if dense:
                    break
                a, b = next_run(rowneed[y, x0:], b, m, gap)
            if y < y0 + 2 * R:
                continue
            yl = y - 2 * R  # the last output row whose window is complete
            if (yl - y0) % G != G - 1 and yl != y1 - 1:
                continue
            g0 = yl - (yl - y0) % G  # output rows g0 .. yl: their column sums in one pass
            ng = yl - g0 + 1
            nc = 0  # runs [ca, cb) of column sums for row ci of the group (-1: all, the union of their masks)
            if dense:
                ca[0], cb[0], ci[0] = 0, m, -1
                nc = 1
            elif wts is not None:  # row by row: no shared loads would repay a union's extra columns
                for i in range(ng):
                    a, b = next_run(colneed[g0 + i, x0:], zero, m, gap)
                    while a < b:
                        ca[nc], cb[nc], ci[nc] = a, b, i
                        nc += 1
                        a, b = next_run(colneed[g0 + i, x0:], b, m, gap)
            else:
                for c in range(m):
                    cm[c] = colneed[g0, x0 + c]
                for i in range(1, ng):
                    for c in range(m):
                        cm[c] |= colneed[g0 + i, x0 + c]
                a, b = next_run(cm, zero, m, gap)
                while a < b:
                    ca[nc], cb[nc], ci[nc] = a, b, -1
                    nc += 1
                    a, b = next_run(cm, b, m, gap)
            nn = 0  # runs of their needed pixels
            tot = 0
            for i in range(ng):
                yo = g0 + i
                if dense:
                    a, b = 0, n
                else:
                    if clear:
                        orow = out[yo, x0 : x0 + n]
                        for c in range(n):
                            orow[c] = -np.inf
                    a, b = next_run(need[yo, x0:], zero, n, gap)
                while a < b:
                    na[nn], nb[nn], ni[nn] = a, b, i
                    nn += 1
                    tot += b - a
                    if dense:
                        break
                    a, b = next_run(need[yo, x0:], b, n, gap)
            if pos + tot > cap:
                flush_gathered(acc, diag, det, tr, f, pos, ys, xs, want_parts, out, det_out, tr_out, kdim)
                pos = zero
            # one pair at a time: its column sums stay in L1 for the row sums
            for q in range(P):
                for r in range(nc):
                    if wts is None:
                        column_sums(pring[q], g0, nr, ng, vsum, ca[r], cb[r], wdim)
                    else:
                        wcolumn_sums(pring[q], g0, wts, ng, ci[r], vsum, ca[r], cb[r], wdim)
                p = pos
                for r in range(nn):
                    w = nb[r] - na[r]
                    if wts is None:
                        row_sum(vsum[ni[r], na[r]:], nr, acc[q, p:], w, wdim)
                    else:
                        wrow_sum(vsum[ni[r], na[r]:], wts, acc[q, p:], w, wdim)
                    p += w
            for r in range(nn):
                for t in range(nb[r] - na[r]):
                    ys[pos + t] = g0 + ni[r]
                    xs[pos + t] = x0 + na[r] + t
                pos += nb[r] - na[r]
    flush_gathered(acc, diag, det, tr, f, pos, ys, xs, want_parts, out, det_out, tr_out, kdim)


@numba.njit(**JIT)
def flush_gathered(acc, diag, det, tr, f, n, ys, xs, want_parts, out, det_out, tr_out,
                   kdim):  # pragma: no cover - jit
    """det / (tr + varsigma) of the n gathered window sums, written to their pixels."""
    det_trace(acc, diag, det, tr, f, n, kdim)
    for t in range(n):
        out[ys[t], xs[t]] = det[t] / (tr[t] + VARSIGMA)
        if want_parts:
            det_out[ys[t], xs[t]] = det[t]
            tr_out[ys[t], xs[t]] = tr[t]
