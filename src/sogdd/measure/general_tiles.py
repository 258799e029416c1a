"""The compiled tile function of the SODDC measure for any window shape (the authors' disk).

Each row of products is summed along the row with that row's half-width (the
row sums are kept in a ring of the last window-height rows), then the rows are
summed down the columns in order; the det and trace come from
:func:`sogdd.measure.square_tiles.det_trace`. Square windows take
:func:`sogdd.measure.square_tiles.tile_square`, which can also prune. (A fused pass down
the 5 rows of the authors' disk measured the same time: the column sums are not
what this kernel waits on.)
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import JIT, ROW_PAD
from .square_tiles import VARSIGMA, det_trace, pair_index, row_sum, steer

__all__ = ["tile_general"]


@numba.njit(**JIT)
def tile_general(planes, off, coef, halfw, want_parts, out, det_out, tr_out, block, kdim):  # pragma: no cover
    """Fill ``out`` (Ht, W) with det/(tr + varsigma) for any window shape.

    ``planes`` (n, Ht + 2M, W + 2M) are filter responses on the tile plus a margin
    of ``M = R + off`` rows and columns on each side (``R`` = window half-height); the K
    responses are ``|coef @ planes|`` (the three steerable basis responses for
    SOGDD, or K responses with the identity). Each row of products is summed
    along the row with that row's half-width, then the rows are summed. Work goes
    in column blocks of ``block`` pixels so the rows stay in cache. With
    ``want_parts`` the raw det and trace are written too. ``kdim``: the elimination
    (:func:`sogdd.measure.square_tiles.elimination`).
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
    pi, pj, diag = pair_index(K)
    WBP = block + 2 * R
    absl = np.empty((K, WBP))
    prod = np.empty(WBP)
    ring = np.empty((nr, nu, P, block + ROW_PAD))  # row sums of the last nr rows
    acc = np.empty((P, block + ROW_PAD))
    det = np.empty(block)
    f = np.empty(block)
    tr = np.empty(block)
    for x0 in range(0, W, block):
        n = min(block, W - x0)
        m = n + 2 * R
        for y in range(Ht + 2 * R):
            slot = y % nr
            steer(planes, y + off, x0 + off, coef, absl, 0, m)
            for q in range(P):
                ai = absl[pi[q]]
                aj = absl[pj[q]]
                for x in range(m):
                    prod[x] = ai[x] * aj[x]
                for u in range(nu):
                    h = uniq[u]
                    row_sum(prod[R - h :], 2 * h + 1, ring[slot, u, q], n, ())  # every width: one compilation
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
            det_trace(acc, diag, det, tr, f, n, kdim)
            for x in range(n):
                out[yo, x0 + x] = det[x] / (tr[x] + VARSIGMA)
                if want_parts:
                    det_out[yo, x0 + x] = det[x]
                    tr_out[yo, x0 + x] = tr[x]
