"""Weighted window sums for the compiled tile code (the Gaussian window, :mod:`.gaussian_window`).

A separable window of positive weights ``w`` (length ``nr``) sums a plane as
weighted column sums, then weighted row sums::

    S(y, x) = sum_u w[u] (sum_v w[v] P(y + v, x + u))

Each sum runs from ``t = 0`` to ``nr - 1`` in that order, one multiply-add per
term, so a value depends only on the ``nr x nr`` values under its window, never
on where a tile, a run of pixels or a band starts. Against the literal
``sum_(u, v) w[u] w[v] P`` the order and grouping of the roundings differ, which
changes a sum by a few ulp (~1e-15 relative; :func:`sogdd.measure.gaussian_window.gaussian_window_reference`).
``wdim`` (:func:`sogdd.measure.square_tiles.window_rows`) tells numba, when it compiles, that the
window has 7 rows, so that the other sizes' code is left out.
"""

from __future__ import annotations

import numba

from .._jit import JIT

__all__ = ["wcolumn_sum", "wcolumn_sums", "wrow_sum"]


@numba.njit(**JIT, inline="always")
def _seven(w0, w1, w2, w3, w4, w5, w6, v0, v1, v2, v3, v4, v5, v6):  # pragma: no cover - jit
    """w0 v0 + w1 v1 + ... + w6 v6, in that order (the 7-tap window of `hr`, in registers)."""
    s = w0 * v0
    s += w1 * v1
    s += w2 * v2
    s += w3 * v3
    s += w4 * v4
    s += w5 * v5
    s += w6 * v6
    return s


@numba.njit(**JIT)
def wcolumn_sum(ring, first, wts, dst, a, b, wdim):  # pragma: no cover - jit
    """dst[x] = sum_t wts[t] ring[(first + t) % nring, x] for a <= x < b, t = 0 .. nr - 1 in order.

    ``nr`` is the window's height (``wts``), ``nring >= nr`` the ring's rows. The
    7-row window (``hr``'s) is written out in registers; the same multiply-adds in
    the same order as the general loop.
    """
    nr = wts.shape[0]
    nring = ring.shape[0]
    n = b - a
    d = dst[a:b]  # 1-D views from 0: they vectorise (see sogdd.measure.square_tiles.column_sum)
    if len(wdim) == 7 or nr == 7:
        r0, r1, r2 = ring[first % nring, a:b], ring[(first + 1) % nring, a:b], ring[(first + 2) % nring, a:b]
        r3, r4 = ring[(first + 3) % nring, a:b], ring[(first + 4) % nring, a:b]
        r5, r6 = ring[(first + 5) % nring, a:b], ring[(first + 6) % nring, a:b]
        w0, w1, w2, w3, w4, w5, w6 = wts[0], wts[1], wts[2], wts[3], wts[4], wts[5], wts[6]
        for x in range(n):
            d[x] = _seven(w0, w1, w2, w3, w4, w5, w6, r0[x], r1[x], r2[x], r3[x], r4[x], r5[x], r6[x])
        return
    src = ring[first % nring, a:b]
    w0 = wts[0]
    for x in range(n):
        d[x] = w0 * src[x]
    for t in range(1, nr):
        src = ring[(first + t) % nring, a:b]
        wt = wts[t]
        for x in range(n):
            d[x] += wt * src[x]


@numba.njit(**JIT)
def wcolumn_sums(ring, first, wts, ng, only, dst, a, b, wdim):  # pragma: no cover - jit
    """dst[i] = :func:`wcolumn_sum` of ring rows ``first + i`` on, for i < ng (``only`` >= 0: that i alone).

    Four 7-row windows in one pass load each of their 10 ring rows once (the
    pass is bound by loads); every sum keeps :func:`wcolumn_sum`'s order, so the
    values are the same bit for bit.
    """
    if only < 0 and ng == 4 and wts.shape[0] == 7:
        nring = ring.shape[0]
        n = b - a
        r0, r1, r2 = ring[first % nring, a:b], ring[(first + 1) % nring, a:b], ring[(first + 2) % nring, a:b]
        r3, r4 = ring[(first + 3) % nring, a:b], ring[(first + 4) % nring, a:b]
        r5, r6 = ring[(first + 5) % nring, a:b], ring[(first + 6) % nring, a:b]
        r7, r8 = ring[(first + 7) % nring, a:b], ring[(first + 8) % nring, a:b]
        r9 = ring[(first + 9) % nring, a:b]
        d0, d1, d2, d3 = dst[0, a:b], dst[1, a:b], dst[2, a:b], dst[3, a:b]
        w0, w1, w2, w3, w4, w5, w6 = wts[0], wts[1], wts[2], wts[3], wts[4], wts[5], wts[6]
        for x in range(n):
            v0, v1, v2, v3, v4 = r0[x], r1[x], r2[x], r3[x], r4[x]
            v5, v6, v7, v8, v9 = r5[x], r6[x], r7[x], r8[x], r9[x]
            d0[x] = _seven(w0, w1, w2, w3, w4, w5, w6, v0, v1, v2, v3, v4, v5, v6)
            d1[x] = _seven(w0, w1, w2, w3, w4, w5, w6, v1, v2, v3, v4, v5, v6, v7)
            d2[x] = _seven(w0, w1, w2, w3, w4, w5, w6, v2, v3, v4, v5, v6, v7, v8)
            d3[x] = _seven(w0, w1, w2, w3, w4, w5, w6, v3, v4, v5, v6, v7, v8, v9)
        return
    for i in range(ng):
        if only < 0 or only == i:
            wcolumn_sum(ring, first + i, wts, dst[i], a, b, wdim)


@numba.njit(**JIT)
def wrow_sum(src, wts, dst, n, wdim):  # pragma: no cover - jit
    """dst[x] = sum_t wts[t] src[x + t] for x < n, t = 0 .. nr - 1 in order (7 taps in registers)."""
    nr = wts.shape[0]
    d = dst[:n]
    if len(wdim) == 7 or nr == 7:
        w0, w1, w2, w3, w4, w5, w6 = wts[0], wts[1], wts[2], wts[3], wts[4], wts[5], wts[6]
        for x in range(n):
            d[x] = _seven(w0, w1, w2, w3, w4, w5, w6, src[x], src[x + 1], src[x + 2], src[x + 3], src[x + 4],
                          src[x + 5], src[x + 6])
        return
    w0 = wts[0]
    for x in range(n):
        d[x] = w0 * src[x]
    for t in range(1, nr):
        s = src[t : t + n]
        wt = wts[t]
        for x in range(n):
            d[x] += wt * s[x]
