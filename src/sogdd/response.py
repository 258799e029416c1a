"""The SODDC matrix and its det/trace corner measure (eqs. 23-25), tiled and compiled.

For every pixel the K x K second-order directional derivative correlation
(SODDC) matrix is the unnormalised window sum of outer products of the
absolute SOGDD responses (eq. 24)::

    Lambda = sum_{window} |l| |l|^T,     l = (l_1, ..., l_K)

and the corner measure is (eq. 25)::

    Upsilon = det(Lambda) / (trace(Lambda) + varsigma),   varsigma = 2.22e-16

The image is processed in row tiles, so memory stays bounded on large images.
Each tile is filtered with the three steerable basis kernels (OpenCV), then a
numba kernel steers the responses to K orientations, forms the window sums
directly (no running sums, so no cancellation) and takes the determinant with a
symmetric Gaussian elimination vectorised across pixels. Everything is float64:
with K = 8 the determinant passes 1e40 on strong corners.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numba
import numpy as np

from .filters import (
    basis_responses,
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
def _steer(planes, y, x0, coef, absl, n):  # pragma: no cover - jit
    """|l_k| = |sum_p coef[k, p] planes[p]| on one row (eq. 23 and the |.| of eq. 24)."""
    npl = planes.shape[0]
    for k in range(coef.shape[0]):
        row = absl[k]
        if npl == 3:  # the steerable basis g_xx, g_xy, g_yy
            c0 = coef[k, 0]
            c1 = coef[k, 1]
            c2 = coef[k, 2]
            a = planes[0, y, x0:]
            b = planes[1, y, x0:]
            c = planes[2, y, x0:]
            for x in range(n):
                row[x] = abs(c0 * a[x] + c1 * b[x] + c2 * c[x])
        else:
            for x in range(n):
                row[x] = 0.0
            for p in range(npl):
                w = coef[k, p]
                if w != 0.0:
                    src = planes[p, y, x0:]
                    for x in range(n):
                        row[x] += w * src[x]
            for x in range(n):
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
def _column_sum(rows, first, nr, dst, m):  # pragma: no cover - jit
    """dst[x] = sum over the nr ring rows starting at ``first`` of rows[r, x], in a fixed order."""
    if nr == 7:
        r0 = rows[first % 7]
        r1 = rows[(first + 1) % 7]
        r2 = rows[(first + 2) % 7]
        r3 = rows[(first + 3) % 7]
        r4 = rows[(first + 4) % 7]
        r5 = rows[(first + 5) % 7]
        r6 = rows[(first + 6) % 7]
        for x in range(m):
            dst[x] = ((r0[x] + r1[x]) + (r2[x] + r3[x])) + ((r4[x] + r5[x]) + r6[x])
    elif nr == 5:
        r0 = rows[first % 5]
        r1 = rows[(first + 1) % 5]
        r2 = rows[(first + 2) % 5]
        r3 = rows[(first + 3) % 5]
        r4 = rows[(first + 4) % 5]
        for x in range(m):
            dst[x] = ((r0[x] + r1[x]) + (r2[x] + r3[x])) + r4[x]
    else:
        src = rows[first % nr]
        for x in range(m):
            dst[x] = src[x]
        for dy in range(1, nr):
            src = rows[(first + dy) % nr]
            for x in range(m):
                dst[x] += src[x]


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
def _soddc_tile(planes, coef, halfw, want_parts, out, det_out, tr_out, block):  # pragma: no cover
    """Fill ``out`` (Ht, W) with det/(tr + varsigma) from steerable responses.

    ``planes`` (n, Ht + 2R, W + 2R) are filter responses on the tile plus a margin
    of ``R`` rows and columns on each side (``R`` = window half-height); the K
    responses are ``|coef @ planes|`` (the three steerable basis responses for
    SOGDD, or K responses with the identity). Work goes
    in column blocks of ``block`` pixels so the rows of products stay in cache.
    A square window sums the columns of products, then pair-wise along the rows;
    any other window sums each row with its own half-width, then the rows. With ``want_parts`` the raw det and
    trace are written too.
    """
    K = coef.shape[0]
    P = K * (K + 1) // 2
    nr = halfw.shape[0]
    R = (nr - 1) // 2
    Ht, W = out.shape
    square = True
    for i in range(nr):
        if halfw[i] != R:
            square = False
    uniq = np.unique(halfw)
    nu = uniq.shape[0]
    which = np.empty(nr, np.int64)
    for i in range(nr):
        for j in range(nu):
            if uniq[j] == halfw[i]:
                which[i] = j
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
    WBP = block + 2 * R
    absl = np.empty((K, WBP))
    prod = np.empty(WBP)
    if square:
        pring = np.empty((nr, P, WBP))  # products of the last nr rows
        vsum = np.empty((P, WBP))  # column sums of one output row
        ring = np.empty((1, 1, 1, 1))
    else:
        pring = np.empty((1, 1, 1))
        vsum = np.empty((1, 1))
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
            _steer(planes, y, x0, coef, absl, m)
            for q in range(P):
                ai = absl[pi[q]]
                aj = absl[pj[q]]
                if square:
                    new = pring[slot, q]
                    for x in range(m):
                        new[x] = ai[x] * aj[x]
                else:
                    for x in range(m):
                        prod[x] = ai[x] * aj[x]
                    for u in range(nu):
                        h = uniq[u]
                        _row_sum(prod[R - h :], 2 * h + 1, ring[slot, u, q], n)
            if y < 2 * R:
                continue
            yo = y - 2 * R
            for q in range(P):
                if square:
                    # direct column sums (no running sums: results must not depend on
                    # where a tile starts), then row sums
                    _column_sum(pring[:, q], yo, nr, vsum[q], m)
                    _row_sum(vsum[q], nr, acc[q], n)
                else:
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


def _take(arr: np.ndarray, axis: int, start: int, stop: int) -> np.ndarray:
    """Indices start..stop-1 of ``arr`` along ``axis`` with half-sample reflection.

    A view when the range lies inside; otherwise the reflected copy (image edges).
    """
    n = arr.shape[axis]
    if 0 <= start and stop <= n:
        return arr[(slice(None),) * axis + (slice(start, stop),)]
    return np.take(arr, _reflect(np.arange(start, stop), n), axis=axis)


def _tile_domain(spec: MeasureSpec, img: np.ndarray, r0: int, r1: int, rk: int, R: int):
    """Steerable basis responses on rows r0-R..r1+R-1 and columns -R..W+R-1 of the tile."""
    H, W = img.shape
    basis = steerable_basis(spec.sigma2, rk, zero_mean=spec.zero_mean)
    if spec.padding == "image":
        src = _take(_take(img, 0, r0 - R - rk, r1 + R + rk), 1, -R - rk, W + R + rk)
        return basis_responses(src, basis)
    # "response": compute the responses on the image rows the tile needs, then reflect them
    lo, hi = max(0, r0 - R), min(H, r1 + R)
    if r0 - R < 0 or r1 + R > H:  # rows reflected at the top or bottom edge
        need = _reflect(np.arange(r0 - R, r1 + R), H)
        lo, hi = int(need.min()), int(need.max()) + 1
    src = _take(_take(img, 0, lo - rk, hi + rk), 1, -rk, W + rk)
    resp = basis_responses(src, basis)
    return _take(_take(resp, 1, r0 - R - lo, r1 + R - lo), 2, -R, W + R)


def _n_threads() -> int:
    env = os.environ.get("SOGDD_NUM_THREADS")
    if env:
        return max(1, int(env))
    return max(1, min(os.cpu_count() or 1, 8))


def _tiled(
    H: int,
    W: int,
    domain,
    coef: np.ndarray,
    halfwidths: np.ndarray,
    *,
    parts: bool = False,
    tile_rows: int = 128,
    threads: int | None = None,
) -> np.ndarray | tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run the compiled tile kernel over row tiles, in threads.

    ``domain(r0, r1)`` returns the filter-response planes of one tile with its
    margin. With ``parts`` the raw det and trace maps are returned too.
    """
    halfw = np.ascontiguousarray(halfwidths, dtype=np.int64)
    coef = np.ascontiguousarray(coef, dtype=np.float64)
    out = np.empty((H, W), dtype=np.float64)
    det = np.empty((H, W)) if parts else np.empty((1, 1))
    tr = np.empty((H, W)) if parts else np.empty((1, 1))
    starts = list(range(0, H, tile_rows))

    def run(r0: int) -> None:
        r1 = min(H, r0 + tile_rows)
        _soddc_tile(
            domain(r0, r1), coef, halfw, parts, out[r0:r1],
            det[r0:r1] if parts else det, tr[r0:r1] if parts else tr, 256,
        )

    n = threads or _n_threads()
    if n == 1 or len(starts) == 1:
        for r0 in starts:
            run(r0)
    else:
        with ThreadPoolExecutor(n) as pool:
            list(pool.map(run, starts))
    return (out, det, tr) if parts else out


def soddc_measure(
    image: np.ndarray, spec: MeasureSpec, *, tile_rows: int = 128, threads: int | None = None
) -> np.ndarray:
    """The corner measure Upsilon (eq. 25) of a float64 grey image, H x W float64.

    Inputs are assumed valid (see :func:`sogdd.corner_response` for the checked
    public entry point).
    """
    img = np.ascontiguousarray(image, dtype=np.float64)
    H, W = img.shape
    rk = kernel_radius(spec.sigma2, spec.radius_rule)
    R = (len(spec.halfwidths) - 1) // 2
    coef = steering_coefficients(orientations(spec.n_orientations))
    res = _tiled(
        H, W, lambda r0, r1: _tile_domain(spec, img, r0, r1, rk, R), coef, spec.halfwidths,
        parts=spec.authors_measure, tile_rows=tile_rows, threads=threads,
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

    return _tiled(H, W, domain, np.eye(K), halfw, tile_rows=tile_rows, threads=threads)


def _authors_measure(det: np.ndarray, tr: np.ndarray) -> np.ndarray:
    """The authors' post-processing: tiny negative det -> 0, non-finite -> -inf."""
    big = np.max(np.abs(det)) if det.size else 0.0
    det = np.where((det < 0) & (det >= -_EPS * big), 0.0, det)
    with np.errstate(all="ignore"):
        ups = det / (tr + _EPS)
    ups[~np.isfinite(ups)] = -np.inf
    return ups
