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

import cv2
import numpy as np

__all__ = [
    "SteerableBasis",
    "basis_responses",
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


def basis_responses(padded: np.ndarray, basis: SteerableBasis) -> np.ndarray:
    """Filter a padded float64 image with ``g_xx, g_xy, g_yy``; (3, h, w) valid part.

    ``padded`` must already carry ``basis.radius`` pixels of border on every side;
    the result covers the interior ``padded[r:-r, r:-r]``. OpenCV correlates rather
    than convolves; every 2-D basis kernel is even (``d1`` is odd, but it appears
    twice), so the two agree.
    """
    r = basis.radius
    src = np.ascontiguousarray(padded, dtype=np.float64)
    out_shape = (src.shape[0] - 2 * r, src.shape[1] - 2 * r)
    out = np.empty((3, *out_shape), dtype=np.float64)
    for i, (kx, ky) in enumerate(
        [(basis.d2, basis.gauss), (basis.d1, basis.d1), (basis.gauss, basis.d2)]
    ):
        full = cv2.sepFilter2D(src, cv2.CV_64F, kx, ky, borderType=cv2.BORDER_REFLECT)
        out[i] = full[r : r + out_shape[0], r : r + out_shape[1]]
    if basis.zero_mean:
        # A constant c subtracted from a kernel subtracts c times the box sum of the image.
        # a separable filter, not cv2.boxFilter, whose running sums would make the
        # result depend on where a tile starts
        ones = np.ones(2 * r + 1)
        box = cv2.sepFilter2D(src, cv2.CV_64F, ones, ones, borderType=cv2.BORDER_REFLECT)
        box = box[r : r + out_shape[0], r : r + out_shape[1]]
        out -= basis.means[:, None, None] * box[None]
    return out
