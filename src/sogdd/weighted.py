"""The SODDC measure with a Gaussian-weighted window (the ``hr`` preset's window).

Eq. 24 sums ``|l| |l|^T`` with equal weights over a square or disk. Here each
offset ``m`` of the window is weighted by ``w(m) = exp(-|m|^2 / (2 sigma_w^2))``
(``w(0) = 1``, truncated at ``3 sigma_w``), with ``sigma_w = window / 4``::

    Lambda_w(n) = sum_m w(m) |l(n + m)| |l(n + m)|^T,
    Upsilon = det(Lambda_w) / (tr(Lambda_w) + varsigma)        (eq. 25)

A square window of equal weights is the limit of wide Gaussians; the Gaussian
weights the pixels nearest the candidate most, so two corners a few pixels
apart pull less on each other's measure (the hr study, docs/hr.md).

The computation is direct: the three separable basis responses (reflect
border, as every stage), K steered absolute responses, K (K + 1) / 2 products
filtered with the separable Gaussian (OpenCV, float64), and the determinant by
symmetric elimination across pixel planes. :func:`gaussian_window_reference`
is the literal definition used by the tests.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from .filters import kernel_radius, orientations, sogdd_kernel, steerable_basis, steering_coefficients
from .response import VARSIGMA

__all__ = ["GaussianWindowSpec", "gaussian_window_measure", "gaussian_window_reference", "measure_of",
           "window_weights_1d"]

_BORDER = cv2.BORDER_REFLECT


@dataclass(frozen=True)
class GaussianWindowSpec:
    """What the Gaussian-window measure depends on (hashable, like ``MeasureSpec``)."""

    sigma2: float
    n_orientations: int
    window: int  # sigma_w = window / 4
    radius_rule: str = "paper"
    zero_mean: bool = False

    @property
    def sigma_w(self) -> float:
        return self.window / 4.0


def window_weights_1d(sigma_w: float) -> np.ndarray:
    """``exp(-t^2 / (2 sigma_w^2))`` on ``t = -R..R``, ``R = ceil(3 sigma_w)``; 2-D: its outer square."""
    R = max(1, int(math.ceil(3.0 * sigma_w - 1e-12)))
    t = np.arange(-R, R + 1, dtype=np.float64)
    return np.exp(-t * t / (2.0 * sigma_w * sigma_w))


def _responses(grey: np.ndarray, spec: GaussianWindowSpec) -> np.ndarray:
    r = kernel_radius(spec.sigma2, spec.radius_rule)
    b = steerable_basis(spec.sigma2, r, zero_mean=spec.zero_mean)
    img = np.ascontiguousarray(grey, dtype=np.float64)

    def f(kx, ky):
        return cv2.sepFilter2D(img, cv2.CV_64F, kx, ky, borderType=_BORDER)

    gxx, gxy, gyy = f(b.d2, b.gauss), f(b.d1, b.d1), f(b.gauss, b.d2)
    if spec.zero_mean:
        n = 2 * r + 1
        box = cv2.boxFilter(img, cv2.CV_64F, (n, n), normalize=False, borderType=_BORDER)
        m = b.means
        gxx, gxy, gyy = gxx - m[0] * box, gxy - m[1] * box, gyy - m[2] * box
    coef = steering_coefficients(orientations(spec.n_orientations))
    return np.abs(np.stack([c[0] * gxx + c[1] * gxy + c[2] * gyy for c in coef]))


def _det_planes(M: list[list[np.ndarray]]) -> np.ndarray:
    """det of K x K symmetric PSD matrices given as planes, by elimination (a zero pivot gives 0)."""
    K = len(M)
    A = [[M[i][j].copy() for j in range(K)] for i in range(K)]
    det = np.ones_like(A[0][0])
    for k in range(K):
        piv = A[k][k]
        det *= piv
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            inv = np.where(np.abs(piv) > 1e-280, 1.0 / piv, 0.0)
        for i in range(k + 1, K):
            f = A[i][k] * inv
            for j in range(k + 1, K):
                A[i][j] -= f * A[k][j]
    return det


def gaussian_window_measure(grey: np.ndarray, spec: GaussianWindowSpec) -> np.ndarray:
    """Upsilon with the Gaussian-weighted window (module doc), H x W float64.

    Examples
    --------
    >>> from sogdd.synthetic import pattern_image
    >>> img = pattern_image((120, 160))[0].astype(float)
    >>> spec = GaussianWindowSpec(1.2, 4, 3)
    >>> fast = gaussian_window_measure(img, spec)
    >>> ref = gaussian_window_reference(img, spec)
    >>> bool(np.max(np.abs(fast - ref)) <= 1e-9 * np.max(np.abs(ref)))
    True
    """
    a = _responses(grey, spec)
    w = window_weights_1d(spec.sigma_w)
    K = len(a)
    M: list[list[np.ndarray]] = [[None] * K for _ in range(K)]  # type: ignore[list-item]
    for i in range(K):
        for j in range(i, K):
            M[i][j] = M[j][i] = cv2.sepFilter2D(a[i] * a[j], cv2.CV_64F, w, w, borderType=_BORDER)
    # window sums of non-negative products: clip the ~1e-14 rounding of the filter
    tr = np.maximum(sum(M[k][k] for k in range(K)), 0.0)
    return np.maximum(_det_planes(M), 0.0) / (tr + VARSIGMA)


def gaussian_window_reference(grey: np.ndarray, spec: GaussianWindowSpec) -> np.ndarray:
    """The literal definition: sampled kernels (eq. 22), explicit weighted sums, ``numpy.linalg.det``."""
    from scipy import ndimage

    img = np.asarray(grey, dtype=np.float64)
    H, W = img.shape
    rk = kernel_radius(spec.sigma2, spec.radius_rule)
    ks = [sogdd_kernel(spec.sigma2, t, rk, zero_mean=spec.zero_mean) for t in orientations(spec.n_orientations)]
    absl = np.abs(np.stack([ndimage.convolve(img, k, mode="reflect") for k in ks]))
    w1 = window_weights_1d(spec.sigma_w)
    R = len(w1) // 2
    pad = np.pad(absl, ((0, 0), (R, R), (R, R)), mode="symmetric")
    K = len(ks)
    lam = np.zeros((H, W, K, K))
    for dy in range(-R, R + 1):
        for dx in range(-R, R + 1):
            v = pad[:, R + dy : R + dy + H, R + dx : R + dx + W]
            lam += w1[dy + R] * w1[dx + R] * np.einsum("ihw,jhw->hwij", v, v)
    det = np.linalg.det(lam)
    return np.maximum(det, 0.0) / (np.trace(lam, axis1=2, axis2=3) + VARSIGMA)


def measure_of(grey: np.ndarray, spec, floor: float | None = None) -> np.ndarray:
    """Upsilon for either spec: Gaussian windows here, squares and disks by ``response.soddc_measure``."""
    if isinstance(spec, GaussianWindowSpec):
        return gaussian_window_measure(grey, spec)
    from .response import soddc_measure

    return soddc_measure(grey, spec, floor=floor)
