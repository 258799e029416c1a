"""An exact upper bound of the measure, to skip pixels that cannot reach a threshold.

Detection with an absolute threshold ``T`` needs Upsilon only where it can
reach ``T``. Fischer's inequality on the 2 x 2 diagonal blocks of adjacent
orientations bounds det(Lambda) from six window sums of products of the basis
responses, for any K (:func:`fischer_row`). Pixels whose bound is below ``T``
are provably below it; the exact kernel runs on the others
(:func:`need_from_keep`), then on the 3 x 3 neighbourhoods of those found at
or above ``T`` that sub-pixel refinement reads (:func:`neighbour_need`).
Non-maximum suppression needs nothing more: a pixel left out is below ``T``,
so below every peak, whatever the radius.
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import JIT
from .square_tiles import VARSIGMA, column_sums, row_sum
from .window_sums import wcolumn_sums, wrow_sum

__all__ = ["bound_mask", "bound_tables", "fischer_row", "need_from_keep", "neighbour_need", "spread_masks"]

# Safety margins of the pruning bound, far above the rounding they cover: the
# bound's own (~50 eps relative to the Cauchy-Schwarz scale u_i u_j) and that of
# the elimination (~K^3 eps times the Hadamard bound of Upsilon).
_GAMMA = 1e-12
_HADAMARD_SLACK = 1e-10


@numba.njit(**JIT)
def fischer_row(srow, quad, pair, pi2, pj2, floor, keep, nb, work):  # pragma: no cover - jit
    """keep[c] = False where Upsilon < floor is proven from the window sums ``srow[:, c]``.

    ``srow`` holds the six window sums S_pq = sum g_p g_q of products of the
    basis responses (g_xx, g_xy, g_yy). Upper bound (Fischer's inequality on the
    2 x 2 diagonal blocks of adjacent orientations, then |sum l_i l_j| <= sum |l_i l_j|)::

        det(Lambda) <= prod_(i, j) (d_i d_j - t_ij^2),   d_i = sum l_i^2,   t_ij = sum l_i l_j

    Neither d nor t needs |.|: both are quadratic forms in S, so the bound costs
    six window sums for any K. Rounding is covered by the margins above, so a
    pruned pixel is one that the full computation also puts below ``floor``.

    The same holds for a window of positive weights ``w`` (the Gaussian window):
    ``S_pq = sum w g_p g_q``, ``d_i``, ``t_ij`` and ``Lambda = sum w |l| |l|^T``
    (PSD, ``Lambda_ij >= |t_ij|``) are the weighted sums. Each weighted sum of
    ``nr x nr`` terms is off by at most ``~(2 nr + 1) eps sum w |g_p g_q| <= (2 nr + 1)
    eps sqrt(S_pp S_qq)`` (Cauchy-Schwarz with positive weights), so ``d_i`` and ``t_ij``
    by at most ``~4 (2 nr + 7) eps u^2``: 2e-14 u^2 at nr = 7, 3e-13 u^2 at the
    largest window (nr = 153), under ``_GAMMA``; the tile function's own det is off by less
    than ``K (2 nr + 1) eps`` plus the elimination's ``~K^3 eps`` times the Hadamard
    bound, under ``_HADAMARD_SLACK``.
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
        trl = trs[c] - K * err[c] + VARSIGMA
        # NaN or inf (overflow) keep the pixel: the bound proves nothing there
        keep[c] = not (trl > 0.0 and (fb[c] + _HADAMARD_SLACK * hb[c]) / trl < lim)


@numba.njit(**JIT)
def need_from_keep(keep, need):  # pragma: no cover - jit
    """The pixels the first exact pass evaluates: those whose bound reaches the floor.

    ``keep`` (Ht + 2, W + 2) covers tile rows -1..Ht and columns -1..W; ``need``
    is (Ht, W). A pixel of a neighbouring tile (rows -1 and Ht) whose bound
    reaches the floor may be above it, and only that tile knows: its 3 x 3
    neighbours in this tile's first and last rows are evaluated too (needs W >= 3).
    """
    Ht, W = need.shape
    for y in range(Ht):
        kr = keep[y + 1]
        nd = need[y]
        for x in range(W):
            nd[x] = kr[x + 1]
    for y, h in ((0, 0), (Ht - 1, Ht + 1)):
        kr = keep[h]
        nd = need[y]
        for x in range(W):
            nd[x] |= kr[x] | kr[x + 1] | kr[x + 2]
        nd[2] |= kr[1]  # a patch at the image edge is moved inside it (columns 0..2, W-3..W-1)
        nd[W - 3] |= kr[W]


@numba.njit(**JIT)
def neighbour_need(out, floor, r0, H, need):  # pragma: no cover - jit
    """need = pixels not yet evaluated (-inf) in the 3 x 3 patch of a pixel at or above ``floor``.

    The patch is the one :func:`sogdd.select.refine.refine_quadratic` reads: centred on
    the pixel, moved inside the image at its edges (image rows ``r0 + y``, ``H``
    rows; needs H, W >= 3 and tiles of >= 3 rows, so an edge patch lies in its
    tile). Returns the range ``lo, hi`` of tile rows with a needed pixel (``lo
    >= hi``: none).
    """
    Ht, W = out.shape
    lo, hi = Ht, 0
    for y in range(Ht):
        nd = need[y]
        for x in range(W):
            nd[x] = 0
    for y in range(Ht):
        row = out[y]
        for x in range(W):
            if not row[x] >= floor:
                continue
            cy = min(max(r0 + y, 1), H - 2) - r0
            cx = min(max(x, 1), W - 2)
            for yy in range(max(cy - 1, 0), min(cy + 2, Ht)):
                orow = out[yy]
                for xx in range(cx - 1, cx + 2):
                    if orow[xx] == -np.inf:
                        need[yy, xx] = 1
                        lo = min(lo, yy)
                        hi = max(hi, yy + 1)
    return lo, hi


@numba.njit(**JIT)
def spread_masks(need, R, colneed, rowneed, lo, hi):  # pragma: no cover - jit
    """From the pixels to evaluate (rows ``lo .. hi - 1`` of ``need``) to what the square tile code computes.

    ``colneed`` (Ht, W + 2R): columns -R..W+R-1 whose column sums those pixels
    use; ``rowneed`` (Ht + 2R, W + 2R): window rows and columns whose products
    those sums use. Only rows ``lo .. hi - 1`` of ``colneed`` and ``lo .. hi + 2R - 1``
    of ``rowneed`` are written.
    """
    W = need.shape[1]
    nr = 2 * R + 1
    for y in range(lo, hi):
        nd = need[y]
        cn = colneed[y]
        for j in range(W + 2 * R):
            cn[j] = 0
        for t in range(nr):  # need[x] covers columns x .. x + 2R
            dst = cn[t : t + W]
            for x in range(W):
                dst[x] |= nd[x]
    for y in range(lo, hi + 2 * R):
        rn = rowneed[y]
        for j in range(W + 2 * R):
            rn[j] = 0
        for yo in range(max(lo, y - 2 * R), min(hi, y + 1)):
            cn = colneed[yo]
            for j in range(W + 2 * R):
                rn[j] |= cn[j]


@numba.njit(**JIT)
def bound_mask(planes, nr, quad, pair, pi2, pj2, floor, keep, block, wts, wdim):  # pragma: no cover - jit
    """keep (Ht + 2, W + 2): the Fischer bound of tile rows -1..Ht, columns -1..W (margin R + 1).

    The six products of the basis responses are kept for the last ``nr + 3`` rows
    (a ring); groups of 4 keep rows sum them down the columns in one pass (as the
    exact kernel does: :func:`sogdd.measure.square_tiles.column_sums`), then each row along the
    row; with ``wts`` (None: the box window), weighted sums as the tile function's (:func:`fischer_row`
    holds for positive weights). ``wts`` is tested as the argument itself, so that numba leaves the
    weighted code out of the box window's compilation (see :func:`sogdd.measure.square_tiles.tile_square`),
    as ``wdim`` (:func:`sogdd.measure.square_tiles.window_rows`) does the other window sizes' code.
    """
    Hk, Wk = keep.shape
    nbm = block + 2
    WB = nbm + nr - 1
    G = 4  # keep rows per column pass
    pring = np.empty((6, nr + G - 1, WB))
    scol = np.empty((6, G, WB))
    srow = np.empty((6, nbm))
    work = (np.empty(nbm), np.empty(nbm), np.empty(nbm), np.empty(nbm))
    row = np.empty(nbm, np.bool_)
    # np.int64, not literals: a literal argument compiles its own specialisation of the callee
    zero, everyone = np.int64(0), np.int64(-1)
    for x0 in range(0, Wk - 2, block):
        nb = min(block, Wk - 2 - x0) + 2
        wcols = nb + nr - 1
        for y in range(Hk + nr - 1):
            slot = y % (nr + G - 1)
            q = 0
            for p in range(3):
                for pp in range(p, 3):
                    a = planes[p, y, x0 : x0 + wcols]
                    b = planes[pp, y, x0 : x0 + wcols]
                    dst = pring[q, slot]
                    for j in range(wcols):
                        dst[j] = a[j] * b[j]
                    q += 1
            r = y - nr + 1  # the last keep row whose window ends at planes row y
            if r < 0 or (r % G != G - 1 and r != Hk - 1):
                continue
            g0 = r - r % G  # keep rows g0 .. r: their column sums in one pass
            ng = r - g0 + 1
            for q in range(6):
                if wts is None:
                    column_sums(pring[q], g0, nr, ng, scol[q], zero, wcols, wdim)
                else:
                    wcolumn_sums(pring[q], g0, wts, ng, everyone, scol[q], zero, wcols, wdim)
            for i in range(ng):
                for q in range(6):
                    if wts is None:
                        row_sum(scol[q, i], nr, srow[q], nb, wdim)
                    else:
                        wrow_sum(scol[q, i], wts, srow[q], nb, wdim)
                fischer_row(srow, quad, pair, pi2, pj2, floor, row, nb, work)
                kr = keep[g0 + i, x0 : x0 + nb]
                for c in range(nb):
                    kr[c] = row[c]


def bound_tables(coef: np.ndarray):
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
