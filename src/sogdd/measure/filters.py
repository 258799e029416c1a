"""SOGDD filters: sampled kernels, the steerable basis and separable filtering.

The isotropic second-order Gaussian directional derivative (SOGDD) filter of
the paper (eq. 2, sampled in eq. 22) is

    psi_theta(x, y) = (1/s2) * ((x cos(theta) + y sin(theta))**2 / s2 - 1) * g(x, y)

with ``s2 = sigma**2`` and ``g`` the normalised isotropic Gaussian (eq. 1).
Expanding the square shows that it is *steerable*, pointwise and therefore also
for the sampled kernels::

    psi_theta = cos^2(theta) g_xx + 2 sin(theta) cos(theta) g_xy + sin^2(theta) g_yy

where ``g_xx``, ``g_xy`` and ``g_yy`` are the second partial derivatives of ``g``.
Each of them is separable, so three separable convolutions give the responses
at *every* orientation exactly (up to floating-point rounding).

Coordinates: ``x`` is the column and ``y`` the row. The set of orientations
``theta_k = (k - 1) pi / K`` is closed under ``theta -> pi/2 - theta`` and
``theta -> -theta`` (modulo pi), so the corner measure, which depends only on the
set of responses, does not depend on that convention.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from .._jit import JIT, ROW_PAD
from ..image.rows import exact_grey
from .window import reflect1

__all__ = [
    "SteerableBasis",
    "basis_tile",
    "kernel_radius",
    "orientations",
    "sogdd_kernel",
    "steerable_basis",
    "steering_coefficients",
]


def kernel_radius(sigma2: float, rule: str = "paper") -> int:
    """Radius ``r`` of the square ``[-r, r]^2`` on which the kernels are sampled.

    ``"paper"``: ``ceil(4 sigma)``. ``"authors"``: ``max(3, ceil(4 sigma))`` as in
    the authors' public code.
    """
    r = int(np.ceil(4.0 * np.sqrt(sigma2) - 1e-12))
    return max(3, r) if rule == "authors" else max(1, r)


def orientations(n_orientations: int) -> np.ndarray:
    """The ``K`` filter orientations ``theta_k = (k - 1) pi / K``, k = 1..K (eq. 22)."""
    return np.arange(n_orientations, dtype=np.float64) * np.pi / n_orientations


def steering_coefficients(thetas: np.ndarray) -> np.ndarray:
    """(K, 3) weights of ``(g_xx, g_xy, g_yy)`` that give ``psi_theta`` for each theta."""
    c, s = np.cos(thetas), np.sin(thetas)
    return np.stack([c * c, 2.0 * s * c, s * s], axis=1)


def sogdd_kernel(sigma2: float, theta: float, radius: int, *, zero_mean: bool = False) -> np.ndarray:
    """The sampled 2-D SOGDD kernel of eq. 22 at orientation ``theta``.

    Returned as a ``(2r+1, 2r+1)`` float64 array indexed ``[y + r, x + r]``. This
    is the literal definition, used as the oracle for the steerable path.
    ``zero_mean`` subtracts the kernel's own mean (the authors' code does).
    """
    t = np.arange(-radius, radius + 1, dtype=np.float64)
    y, x = np.meshgrid(t, t, indexing="ij")
    g = np.exp(-(x * x + y * y) / (2.0 * sigma2)) / (2.0 * np.pi * sigma2)
    u = x * np.cos(theta) + y * np.sin(theta)
    k = (u * u / sigma2 - 1.0) / sigma2 * g
    if zero_mean:
        k = k - k.mean()
    return k


@dataclass(frozen=True)
class SteerableBasis:
    """Separable factors of the three second-derivative kernels.

    ``g_xx = outer(gauss, d2)`` (rows x columns), ``g_yy = outer(d2, gauss)`` and
    ``g_xy = outer(d1, d1)``, each 1-D factor sampled on ``[-r, r]``.
    ``means`` holds the mean of each 2-D kernel ``(g_xx, g_xy, g_yy)``, which a
    zero-mean variant subtracts.
    """

    sigma2: float
    radius: int
    gauss: np.ndarray
    d1: np.ndarray
    d2: np.ndarray
    zero_mean: bool = False

    @property
    def means(self) -> np.ndarray:
        n = (2 * self.radius + 1) ** 2
        sg, s1, s2 = self.gauss.sum(), self.d1.sum(), self.d2.sum()
        return np.array([s2 * sg, s1 * s1, sg * s2]) / n

    def kernels(self) -> np.ndarray:
        """The (3, 2r+1, 2r+1) kernels ``g_xx, g_xy, g_yy`` (zero-mean if requested)."""
        k = np.stack(
            [np.outer(self.gauss, self.d2), np.outer(self.d1, self.d1), np.outer(self.d2, self.gauss)]
        )
        if self.zero_mean:
            k = k - self.means[:, None, None]
        return k


def steerable_basis(sigma2: float, radius: int, *, zero_mean: bool = False) -> SteerableBasis:
    """Build the separable steerable basis for scale ``sigma2`` (= sigma squared)."""
    t = np.arange(-radius, radius + 1, dtype=np.float64)
    gauss = np.exp(-t * t / (2.0 * sigma2)) / np.sqrt(2.0 * np.pi * sigma2)
    d1 = t / sigma2 * gauss
    d2 = (t * t / sigma2 - 1.0) / sigma2 * gauss
    return SteerableBasis(float(sigma2), int(radius), gauss, d1, d2, zero_mean)


@numba.njit(**JIT)
def _basis_tile(img, r0, nrows, M, ext, fx, fy, odd, means, out, cblock):  # pragma: no cover - jit
    """Separable correlation of ``img`` with the basis pairs, rows ``r0 - M ..`` of a tile.

    ``out[i, pr, x]`` holds filter pair i (row filter ``fy[i]``, column filter
    ``fx[i]``) at image row ``r0 - M + pr`` and column ``x - M``, for
    ``nrows + 2M`` rows and ``W + 2M`` columns. With ``ext == M`` the image is
    reflected and filtered everywhere (numpy ``symmetric`` padding, the authors'
    code); with ``ext == 0`` the responses are computed inside the image and
    reflected themselves (scipy ``mode="reflect"`` at both stages). A fourth pair,
    if present, is the box sum that makes zero-mean kernels (``out[i] -= means[i] * box``).
    Horizontal passes are kept for the last ``2r + 1`` image rows in a ring, one
    strip of ``cblock`` columns at a time so that the ring stays in cache on wide
    images (each value is computed the same way whatever the strip).
    """
    H, W = img.shape
    nf, T = fx.shape
    rk = (T - 1) // 2
    Wo = W + 2 * ext  # columns filtered, -ext .. W + ext
    rs = T + 1
    ring = np.empty((nf, rs, cblock + ROW_PAD))
    ring_id = np.empty(rs, np.int64)
    rowbuf = np.empty(cblock + 2 * rk)
    vert = np.empty((nf, cblock + ROW_PAD))
    c0 = ext + rk  # position of image column 0 in padded coordinates
    for xs in range(0, Wo, cblock):
        cw = min(cblock, Wo - xs)
        ring_id[:] = -(1 << 62)
        for pr in range(nrows + 2 * M):
            y = r0 - M + pr
            yc = y if ext > 0 else reflect1(y, H)  # the row whose response this is
            for a in range(T):
                ri = reflect1(yc - rk + a, H)
                slot = ri % rs
                if ring_id[slot] != ri:  # horizontal passes of image row ri, this strip
                    ring_id[slot] = ri
                    src = img[ri]
                    for x in range(cw + 2 * rk):
                        xx = xs + x - c0
                        rowbuf[x] = src[xx] if 0 <= xx < W else src[reflect1(xx, W)]
                    # every factor is even or odd, so taps b and T-1-b share one multiply
                    for i in range(nf):
                        h = ring[i, slot]
                        w = fx[i, rk]
                        rc = rowbuf[rk : rk + cw]
                        for x in range(cw):
                            h[x] = w * rc[x]
                        for b in range(rk):
                            w = fx[i, b]
                            lo = rowbuf[b : b + cw]
                            hi = rowbuf[T - 1 - b : T - 1 - b + cw]
                            if odd[i]:
                                for x in range(cw):
                                    h[x] += w * (lo[x] - hi[x])
                            else:
                                for x in range(cw):
                                    h[x] += w * (lo[x] + hi[x])
            for i in range(nf):
                v = vert[i]
                w = fy[i, rk]
                hc = ring[i, reflect1(yc, H) % rs]
                for x in range(cw):
                    v[x] = w * hc[x]
                for a in range(rk):
                    w = fy[i, a]
                    top = ring[i, reflect1(yc - rk + a, H) % rs]
                    bot = ring[i, reflect1(yc + rk - a, H) % rs]
                    if odd[nf + i]:
                        for x in range(cw):
                            v[x] += w * (top[x] - bot[x])
                    else:
                        for x in range(cw):
                            v[x] += w * (top[x] + bot[x])
            if nf == 4:
                box = vert[3]
                for i in range(3):
                    v = vert[i]
                    mi = means[i]
                    for x in range(cw):
                        v[x] -= mi * box[x]
            for i in range(3):
                dst = out[i, pr, M - ext + xs : M - ext + xs + cw]
                v = vert[i]
                for x in range(cw):
                    dst[x] = v[x]
    if ext < M:  # reflect the responses into the column margin
        for i in range(3):
            for pr in range(nrows + 2 * M):
                row = out[i, pr]
                for x in range(M - ext):
                    row[x] = row[M + reflect1(x - M, W)]
                for x in range(M + W + ext, W + 2 * M):
                    row[x] = row[M + reflect1(x - M, W)]


def _parity(f: np.ndarray) -> bool:
    """True for an odd 1-D factor, False for an even one (the filter relies on one or the other)."""
    if np.array_equal(f, f[::-1]):
        return False
    if np.array_equal(f, -f[::-1]):
        return True
    raise ValueError("basis factors must be even or odd")


def basis_tile(
    image: np.ndarray, r0: int, r1: int, margin: int, basis: SteerableBasis, *, reflect_image: bool
) -> np.ndarray:
    """Responses to ``g_xx, g_xy, g_yy`` of image rows ``r0 .. r1 - 1`` with a margin.

    Returns (3, r1 - r0 + 2 margin, W + 2 margin) float64: rows ``r0 - margin ..
    r1 + margin - 1`` and columns ``-margin .. W + margin - 1``, outside positions
    reflected (half-sample). ``reflect_image=True`` reflects the image and filters
    there (numpy ``symmetric`` padding); ``False`` filters the image with
    reflected borders and reflects the responses (scipy ``mode="reflect"``).
    Correlation and convolution agree: every 2-D basis kernel is even. A uint8
    image is read as it is (:func:`exact_grey`), anything else as float64.
    """
    img = exact_grey(image)
    H, W = img.shape
    M = int(margin)
    fx = [basis.d2, basis.d1, basis.gauss]  # along x (columns)
    fy = [basis.gauss, basis.d1, basis.d2]  # along y (rows)
    if basis.zero_mean:
        ones = np.ones(2 * basis.radius + 1)
        fx.append(ones)
        fy.append(ones)
    out = np.empty((3, r1 - r0 + 2 * M, W + 2 * M))
    fx, fy = np.array(fx), np.array(fy)
    odd = np.array([_parity(f) for f in [*fx, *fy]])
    _basis_tile(img, int(r0), int(r1 - r0), M, M if reflect_image else 0, fx, fy, odd, basis.means, out, 512)
    return out


