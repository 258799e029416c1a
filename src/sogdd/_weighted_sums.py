"""Weighted window sums for the compiled kernels (the Gaussian window of :mod:`sogdd.weighted`).

A separable window of positive weights ``w`` (length ``nr``) sums a plane as
weighted column sums, then weighted row sums::

    S(y, x) = sum_u w[u] (sum_v w[v] P(y + v, x + u))

Each sum runs from ``t = 0`` to ``nr - 1`` in that order, one multiply-add per
term, so a value depends only on the ``nr x nr`` values under its window, never
on where a tile, a run of pixels or a band starts. Against the literal
``sum_(u, v) w[u] w[v] P`` the order and grouping of the roundings differ, which
changes a sum by a few ulp (~1e-15 relative; :func:`sogdd.weighted.gaussian_window_reference`).
"""

from __future__ import annotations

import numba

from ._jit import JIT

__all__ = ["wcolumn_sum", "wrow_sum"]


@numba.njit(**JIT)
def wcolumn_sum(ring, first, wts, dst, a, b):  # pragma: no cover - jit
    """dst[x] = sum_t wts[t] ring[(first + t) % nring, x] for a <= x < b, t = 0 .. nr - 1 in order.

    ``nr`` is the window's height (``wts``), ``nring >= nr`` the ring's rows.
    """
    nr = wts.shape[0]
    nring = ring.shape[0]
    n = b - a
    d = dst[a:b]  # 1-D views from 0: they vectorise (see sogdd._kernels.column_sum)
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
def wrow_sum(src, wts, dst, n):  # pragma: no cover - jit
    """dst[x] = sum_t wts[t] src[x + t] for x < n, t = 0 .. nr - 1 in order."""
    nr = wts.shape[0]
    d = dst[:n]
    w0 = wts[0]
    for x in range(n):
        d[x] = w0 * src[x]
    for t in range(1, nr):
        s = src[t : t + n]
        wt = wts[t]
        for x in range(n):
            d[x] += wt * s[x]
