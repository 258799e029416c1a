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

from .filters import basis_responses, kernel_radius, orientations, steerable_basis, steering_coefficients

__all__ = ["VARSIGMA", "MeasureSpec", "window_offsets", "window_halfwidths", "soddc_measure"]

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


@numba.njit(cache=True, nogil=True, fastmath=False)
def _soddc_tile(a, b, c, coef, halfw, want_parts, out, det_out, tr_out):  # pragma: no cover - jit
    """Fill ``out`` (Ht, W) with det/(tr + varsigma) from steerable responses.

    ``a, b, c`` are the g_xx, g_xy, g_yy responses on the tile plus a margin of
    ``R`` rows and columns on each side (R = window half-height, equal to the
    largest half-width). With ``want_parts`` the raw det and trace are written too.
    """
    K = coef.shape[0]
    P = K * (K + 1) // 2
    nr = halfw.shape[0]
    R = (nr - 1) // 2
    Ht, W = out.shape
    Wp = W + 2 * R
    # distinct half-widths and, per row offset, which one it uses
    uniq = np.unique(halfw)
    nu = uniq.shape[0]
    which = np.empty(nr, np.int64)
    for i in range(nr):
        for j in range(nu):
            if uniq[j] == halfw[i]:
                which[i] = j
    # packed upper-triangle index pairs
    pi = np.empty(P, np.int64)
    pj = np.empty(P, np.int64)
    diag = np.empty(K, np.int64)
    p = 0
    for i in range(K):
        for j in range(i, K):
            pi[p] = i
            pj[p] = j
            if i == j:
                diag[i] = p
            p += 1
    absl = np.empty((K, Wp))
    prod = np.empty((P, Wp))
    ring = np.empty((nr, nu, P, W))  # horizontal sums of the last nr rows
    acc = np.empty((P, W))
    det = np.empty(W)
    f = np.empty(W)
    zero = np.empty(W, np.bool_)
    for y in range(Ht + 2 * R):
        # steer and take absolute values (eq. 23 and the |.| of eq. 24)
        for k in range(K):
            c0 = coef[k, 0]
            c1 = coef[k, 1]
            c2 = coef[k, 2]
            for x in range(Wp):
                absl[k, x] = abs(c0 * a[y, x] + c1 * b[y, x] + c2 * c[y, x])
        for q in range(P):
            i = pi[q]
            j = pj[q]
            for x in range(Wp):
                prod[q, x] = absl[i, x] * absl[j, x]
        slot = y % nr
        for u in range(nu):
            h = uniq[u]
            for q in range(P):
                for x in range(W):
                    ring[slot, u, q, x] = prod[q, x + R - h]
                for dx in range(-h + 1, h + 1):
                    for x in range(W):
                        ring[slot, u, q, x] += prod[q, x + R + dx]
        if y < 2 * R:
            continue
        yo = y - 2 * R
        # vertical sum over the nr rows yo..yo+2R (ring slots), each with its half-width
        for q in range(P):
            for x in range(W):
                acc[q, x] = 0.0
        for dy in range(nr):
            s = (yo + dy) % nr
            u = which[dy]
            for q in range(P):
                for x in range(W):
                    acc[q, x] += ring[s, u, q, x]
        # trace, then det by symmetric Gaussian elimination (LDL^T without pivoting),
        # vectorised over the row of pixels
        for x in range(W):
            t = 0.0
            for k in range(K):
                t += acc[diag[k], x]
            if want_parts:
                tr_out[yo, x] = t
            out[yo, x] = t
            det[x] = 1.0
            zero[x] = False
        for j in range(K):
            dj = diag[j]
            for x in range(W):
                d = acc[dj, x]
                if d == 0.0:
                    zero[x] = True
                    d = 1.0
                det[x] *= d
                acc[dj, x] = 1.0 / d  # keep the inverse pivot in place
            for i in range(j + 1, K):
                qji = dj + (i - j)
                qi0 = diag[i]
                for x in range(W):
                    f[x] = acc[qji, x] * acc[dj, x]
                for kk in range(i, K):
                    qik = qi0 + (kk - i)
                    qjk = dj + (kk - j)
                    for x in range(W):
                        acc[qik, x] -= f[x] * acc[qjk, x]
        for x in range(W):
            dt = 0.0 if zero[x] else det[x]
            if want_parts:
                det_out[yo, x] = dt
            out[yo, x] = dt / (out[yo, x] + 2.22e-16)


def _tile_domain(spec: MeasureSpec, img: np.ndarray, r0: int, r1: int, rk: int, R: int):
    """Steerable basis responses on rows r0-R..r1+R-1 and columns -R..W+R-1 of the tile."""
    H, W = img.shape
    basis = steerable_basis(spec.sigma2, rk, zero_mean=spec.zero_mean)
    if spec.padding == "image":
        rows = _reflect(np.arange(r0 - R - rk, r1 + R + rk), H)
        cols = _reflect(np.arange(-R - rk, W + R + rk), W)
        return basis_responses(img[rows][:, cols], basis)
    # "response": compute the responses on the image rows the tile needs, then reflect them
    need = _reflect(np.arange(r0 - R, r1 + R), H)
    lo, hi = int(need.min()), int(need.max()) + 1
    rows = _reflect(np.arange(lo - rk, hi + rk), H)
    cols = _reflect(np.arange(-rk, W + rk), W)
    resp = basis_responses(img[rows][:, cols], basis)
    return resp[:, need - lo][:, :, _reflect(np.arange(-R, W + R), W)]


def _n_threads() -> int:
    env = os.environ.get("SOGDD_NUM_THREADS")
    if env:
        return max(1, int(env))
    return max(1, min(os.cpu_count() or 1, 8))


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
    halfw = np.ascontiguousarray(spec.halfwidths, dtype=np.int64)
    R = (len(halfw) - 1) // 2
    coef = steering_coefficients(orientations(spec.n_orientations))
    out = np.empty((H, W), dtype=np.float64)
    parts = spec.authors_measure
    det = np.empty((H, W)) if parts else np.empty((1, 1))
    tr = np.empty((H, W)) if parts else np.empty((1, 1))
    starts = list(range(0, H, tile_rows))

    def run(r0: int) -> None:
        r1 = min(H, r0 + tile_rows)
        dom = _tile_domain(spec, img, r0, r1, rk, R)
        _soddc_tile(
            dom[0], dom[1], dom[2], coef, halfw, parts, out[r0:r1],
            det[r0:r1] if parts else det, tr[r0:r1] if parts else tr,
        )

    n = threads or _n_threads()
    if n == 1 or len(starts) == 1:
        for r0 in starts:
            run(r0)
    else:
        with ThreadPoolExecutor(n) as pool:
            list(pool.map(run, starts))
    if parts:
        out = _authors_measure(det, tr)
    return out


def _authors_measure(det: np.ndarray, tr: np.ndarray) -> np.ndarray:
    """The authors' post-processing: tiny negative det -> 0, non-finite -> -inf."""
    big = np.max(np.abs(det)) if det.size else 0.0
    det = np.where((det < 0) & (det >= -_EPS * big), 0.0, det)
    with np.errstate(all="ignore"):
        ups = det / (tr + _EPS)
    ups[~np.isfinite(ups)] = -np.inf
    return ups
