"""Directional filter banks that are not steerable: the anisotropic kernels of Zhang & Sun.

The core's compiled measure relies on the isotropic SOGDD filters being
steerable from three separable basis kernels. The anisotropic kernels of
Zhang & Sun (2020, 2021) are not, so their K directional responses are computed
one kernel at a time here (``cv2.filter2D``, which switches to a DFT for large
kernels); the window sums of ``|l| |l|^T`` and ``det / (trace + varsigma)`` are
the core's (:func:`sogdd.measure.soddc.soddc_from_responses` for the map,
:func:`sogdd.measure.soddc.soddc_at` at a few pixels).
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["anisotropic_gaussian", "directional_responses", "rotated_coordinates"]


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


def directional_responses(grey: np.ndarray, kernels: np.ndarray) -> np.ndarray:
    """|image * kernel_k| for each kernel, as a (K, H, W) float64 array.

    Half-sample symmetric padding (``cv2.BORDER_REFLECT``, MATLAB's
    ``imfilter(..., 'symmetric')``). ``filter2D`` correlates; every kernel used
    here is even or odd about its centre, so correlation equals convolution up to
    a sign, which the absolute value removes.
    """
    src = np.ascontiguousarray(grey, dtype=np.float64)
    h, w = src.shape
    out = np.empty((len(kernels), h, w), dtype=np.float64)
    for k, ker in enumerate(kernels):
        r = cv2.filter2D(src, cv2.CV_64F, np.ascontiguousarray(ker, dtype=np.float64),
                         borderType=cv2.BORDER_REFLECT)
        np.abs(r, out=out[k])
    return out
