"""The SODDC measure with a Gaussian-weighted window (the ``hr`` preset's window).

Eq. 24 sums ``|l| |l|^T`` with equal weights over a square or disk. Here each
offset ``m`` of the window is weighted by ``w(m) = exp(-|m|^2 / (2 sigma_w^2))``
(``w(0) = 1``, truncated at ``3 sigma_w``), with ``sigma_w = window / 4``::

    Lambda_w(n) = sum_m w(m) |l(n + m)| |l(n + m)|^T,
    Upsilon = det(Lambda_w) / (tr(Lambda_w) + varsigma)        (eq. 25)

A square window of equal weights is the limit of wide Gaussians; the Gaussian
weights the pixels nearest the candidate most, so two corners a few pixels
apart pull less on each other's measure (the hr study, docs/hr.md).

The computation is the compiled, tiled kernel of the square window
(:func:`sogdd.response._tiled`, :mod:`sogdd._kernels`) with separable weights
(:mod:`sogdd._weighted_sums`): basis responses per tile (reflect border),
K steered absolute responses, K (K + 1) / 2 products, weighted column sums then
weighted row sums in a fixed order (so a value never depends on the tile, band or
thread), det/trace by symmetric elimination. With ``floor`` the Fischer bound
prunes as for the square window (:mod:`sogdd._pruning`; it holds for positive
weights). :func:`gaussian_window_reference` is the literal definition used by the
tests; the two differ by the order of the roundings (~1e-15 relative).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .filters import (
    basis_tile,
    kernel_radius,
    orientations,
    sogdd_kernel,
    steerable_basis,
    steering_coefficients,
)
from .response import VARSIGMA

__all__ = ["GaussianWindowSpec", "gaussian_window_measure", "gaussian_window_reference", "measure_of",
           "window_weights_1d"]


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

    @property
    def radius(self) -> int:
        """The basis kernels' radius."""
        return kernel_radius(self.sigma2, self.radius_rule)

    @property
    def window_radius(self) -> int:
        """R, the weighted window's half-width (``ceil(3 sigma_w)``)."""
        return len(window_weights_1d(self.sigma_w)) // 2


def window_weights_1d(sigma_w: float) -> np.ndarray:
    """``exp(-t^2 / (2 sigma_w^2))`` on ``t = -R..R``, ``R = ceil(3 sigma_w)``; 2-D: its outer square."""
    R = max(1, int(math.ceil(3.0 * sigma_w - 1e-12)))
    t = np.arange(-R, R + 1, dtype=np.float64)
    return np.exp(-t * t / (2.0 * sigma_w * sigma_w))


def gaussian_window_measure(grey: np.ndarray, spec: GaussianWindowSpec, *, floor: float | None = None,
                            tile_rows: int = 128, threads: int | None = None) -> np.ndarray:
    """Upsilon with the Gaussian-weighted window (module doc), H x W float64.

    With ``floor`` (> 0) only what peak selection above ``floor`` needs is
    computed, with the contract of :func:`sogdd.response.soddc_measure`: exact,
    bit for bit as without ``floor``, at every pixel at or above it and in the
    3 x 3 patches around those; ``-inf`` only where the measure is provably below it.

    Examples
    --------
    >>> from sogdd.synthetic import pattern_image
    >>> img = pattern_image((120, 160))[0].astype(float)
    >>> spec = GaussianWindowSpec(1.2, 4, 3)
    >>> fast = gaussian_window_measure(img, spec)
    >>> ref = gaussian_window_reference(img, spec)
    >>> bool(np.max(np.abs(fast - ref)) <= 1e-12 * np.max(np.abs(ref)))
    True
    >>> pruned = gaussian_window_measure(img, spec, floor=1e6)
    >>> bool(np.all((pruned == fast) | ((pruned == -np.inf) & (fast < 1e6))))
    True
    """
    from .response import _tiled

    img = np.ascontiguousarray(grey, dtype=np.float64)
    H, W = img.shape
    if floor is not None and not floor > 0:
        raise ValueError("floor needs a positive value")
    if min(H, W) < 3:  # too small for 3 x 3 patches: the full map is the pruned one
        floor = None
    w = window_weights_1d(spec.sigma_w)
    R = len(w) // 2
    r = kernel_radius(spec.sigma2, spec.radius_rule)
    basis = steerable_basis(spec.sigma2, r, zero_mean=spec.zero_mean)
    coef = steering_coefficients(orientations(spec.n_orientations))
    M = R + 1  # one margin for the full and pruned kernels: the same responses

    def domain(r0: int, r1: int) -> np.ndarray:
        return basis_tile(img, r0, r1, M, basis, reflect_image=False)

    return _tiled(H, W, domain, M, coef, np.full(2 * R + 1, R), floor=floor, tile_rows=tile_rows,
                  threads=threads, weights=w)


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
        return gaussian_window_measure(grey, spec, floor=floor)
    from .response import soddc_measure

    return soddc_measure(grey, spec, floor=floor)
