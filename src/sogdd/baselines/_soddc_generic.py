"""Directional filter banks and the det/trace measure for any K responses.

The core's compiled measure (:mod:`sogdd.response`) relies on the isotropic
SOGDD filters being steerable from three separable basis kernels. The
anisotropic kernels of Zhang & Sun (2020, 2021) are not, so here the K
directional responses are computed one kernel at a time (``cv2.filter2D``,
which switches to a DFT for large kernels) and a small numba kernel forms, for
every pixel, the window sum of ``|l| |l|^T`` and the measure
``det / (trace + varsigma)`` with the core's tiled kernel
(:func:`sogdd.response.soddc_from_responses`); :func:`soddc_at` evaluates it at
a few pixels only.
"""

from __future__ import annotations

import cv2
import numba
import numpy as np

from ..response import soddc_from_responses

__all__ = [
    "VARSIGMA",
    "anisotropic_gaussian",
    "directional_responses",
    "disk_offsets",
    "rotated_coordinates",
    "soddc_at",
    "soddc_map",
]

VARSIGMA = 2.22e-16


def rotated_coordinates(radius: int, theta: float) -> tuple[np.ndarray, np.ndarray]:
    """``(x_r, y_r)`` on the ``(2r+1)^2`` grid indexed ``[y + r, x + r]`` (x = column).

    ``x_r = x cos(theta) + y sin(theta)``, ``y_r = -x sin(theta) + y cos(theta)``.
    """
    t = np.arange(-radius, radius + 1, dtype=np.float64)
    y, x = np.meshgrid(t, t, indexing="ij")
    c, s = np.cos(theta), np.sin(theta)
    return x * c + y * s, -x * s + y * c


def anisotropic_gaussian(xr: np.ndarray, yr: np.ndarray, sigma2: float, rho: float) -> np.ndarray:
    """``1/(2 pi s2) exp(-(rho x_r^2 + y_r^2 / rho) / (2 s2))``: narrow along ``x_r`` for rho > 1."""
    return np.exp(-(rho * xr * xr + yr * yr / rho) / (2.0 * sigma2)) / (2.0 * np.pi * sigma2)


def disk_offsets(r2: float) -> np.ndarray:
    """(N, 2) ``(dy, dx)`` integer offsets with ``dy^2 + dx^2 <= r2`` (r2 = 10: 37 offsets)."""
    R = int(np.floor(np.sqrt(r2)))
    t = np.arange(-R, R + 1)
    dy, dx = np.meshgrid(t, t, indexing="ij")
    keep = dy * dy + dx * dx <= r2
    return np.stack([dy[keep], dx[keep]], axis=1).astype(np.int64)


def directional_responses(grey: np.ndarray, kernels: np.ndarray) -> np.ndarray:
    """|image * kernel_k| for each kernel, as an (H, W, K) float64 array.

    Half-sample symmetric padding (``cv2.BORDER_REFLECT``, MATLAB's
    ``imfilter(..., 'symmetric')``). ``filter2D`` correlates; every kernel used
    here is even or odd about its centre, so correlation equals convolution up to
    a sign, which the absolute value removes.
    """
    src = np.ascontiguousarray(grey, dtype=np.float64)
    h, w = src.shape
    out = np.empty((h, w, len(kernels)), dtype=np.float64)
    for k, ker in enumerate(kernels):
        r = cv2.filter2D(src, cv2.CV_64F, np.ascontiguousarray(ker, dtype=np.float64),
                         borderType=cv2.BORDER_REFLECT)
        np.abs(r, out=out[:, :, k])
    return out


def _pad_reflect(absl: np.ndarray, R: int) -> np.ndarray:
    """Pad (H, W, K) by R on both spatial axes, half-sample symmetric (any R)."""
    h, w, _ = absl.shape
    ri = np.arange(-R, h + R)
    ci = np.arange(-R, w + R)
    ri = np.mod(ri, 2 * h)
    ri = np.where(ri < h, ri, 2 * h - 1 - ri)
    ci = np.mod(ci, 2 * w)
    ci = np.where(ci < w, ci, 2 * w - 1 - ci)
    return np.ascontiguousarray(absl[ri][:, ci])


_JIT = dict(cache=True, nogil=True, error_model="numpy")


@numba.njit(**_JIT)
def _measure_one(pad, y, x, dys, dxs, K, m, v):  # pragma: no cover - jit
    """det/(tr + varsigma) of sum over offsets of |l||l|^T at padded position (y, x)."""
    P = K * (K + 1) // 2
    for q in range(P):
        m[q] = 0.0
    for o in range(dys.shape[0]):
        yy = y + dys[o]
        xx = x + dxs[o]
        for k in range(K):
            v[k] = pad[yy, xx, k]
        q = 0
        for i in range(K):
            vi = v[i]
            for j in range(i, K):
                m[q] += vi * v[j]
                q += 1
    # symmetric Gaussian elimination (no pivoting: the matrix is PSD); det = product of pivots
    tr = 0.0
    q = 0
    for i in range(K):
        tr += m[q]
        q += K - i
    det = 1.0
    d0 = 0
    for j in range(K):
        piv = m[d0]
        det *= piv
        if piv == 0.0:
            det = 0.0
            break
        inv = 1.0 / piv
        di = d0 + (K - j)  # packed index of (j+1, j+1)
        for i in range(j + 1, K):
            f = m[d0 + (i - j)] * inv
            for kk in range(i, K):
                m[di + (kk - i)] -= f * m[d0 + (kk - j)]
            di += K - i
        d0 += K - j
    return det / (tr + 2.22e-16)


@numba.njit(**_JIT)
def _measure_points(pad, dys, dxs, R, rows, cols, out):  # pragma: no cover - jit
    K = pad.shape[2]
    m = np.empty(K * (K + 1) // 2)
    v = np.empty(K)
    for i in range(rows.shape[0]):
        out[i] = _measure_one(pad, rows[i] + R, cols[i] + R, dys, dxs, K, m, v)


def soddc_map(absl: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """``det(L) / (trace(L) + varsigma)`` with ``L = sum_offsets |l||l|^T``, at every pixel.

    Parameters
    ----------
    absl : (H, W, K) float64
        Absolute directional responses.
    offsets : (N, 2) int
        ``(dy, dx)`` window offsets; responses are reflected at the border.
    """
    off = np.asarray(offsets, dtype=np.int64)
    R = int(np.abs(off).max())
    halfw = np.full(2 * R + 1, -1, dtype=np.int64)
    for dy in range(-R, R + 1):
        dxs = off[off[:, 0] == dy, 1]
        if len(dxs):
            h = int(dxs.max())
            if int(dxs.min()) != -h or len(dxs) != 2 * h + 1:
                raise ValueError("window offsets must be symmetric runs along each row")
            halfw[dy + R] = h
    if (halfw < 0).any():
        raise ValueError("window offsets must cover every row between the first and the last")
    # the core's tiled kernel, with the K responses as its planes
    return soddc_from_responses(np.moveaxis(np.asarray(absl, dtype=np.float64), 2, 0), halfw)


def soddc_at(absl: np.ndarray, offsets: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """The same measure as :func:`soddc_map`, only at the given pixels."""
    off = np.asarray(offsets, dtype=np.int64)
    R = int(np.abs(off).max())
    pad = _pad_reflect(np.asarray(absl, dtype=np.float64), R)
    out = np.empty(len(rows), dtype=np.float64)
    _measure_points(pad, np.ascontiguousarray(off[:, 0]), np.ascontiguousarray(off[:, 1]), R,
                    np.asarray(rows, dtype=np.int64), np.asarray(cols, dtype=np.int64), out)
    return out
