"""The Gaussian-weighted SODDC window (the ``hr`` preset's window).

Eq. 24 sums ``|l| |l|^T`` with equal weights over a square or disk. Here each
offset ``m`` of the window is weighted by ``w(m) = exp(-|m|^2 / (2 sigma_w^2))``
(``w(0) = 1``, truncated at ``3 sigma_w``), with ``sigma_w = window / 4``::

    Lambda_w(n) = sum_m w(m) |l(n + m)| |l(n + m)|^T,
    Upsilon = det(Lambda_w) / (tr(Lambda_w) + varsigma)        (eq. 25)

A square window of equal weights is the limit of wide Gaussians; the Gaussian
weights the pixels nearest the candidate most, so two corners a few pixels
apart pull less on each other's measure (the hr study, docs/hr.md).

The weights are separable, so the window is a :class:`~sogdd.measure.soddc.MeasureSpec`
over a square with ``weights`` set, and the measure is the core's
(:func:`sogdd.measure.soddc.soddc_measure`): the compiled, tiled kernel with weighted
column sums then weighted row sums in a fixed order (:mod:`sogdd.measure.window_sums`;
a value never depends on the tile, band or thread), pruned by the Fischer bound
with ``floor`` (it holds for positive weights). :func:`gaussian_window_reference`
is the literal definition used by the tests; the two differ by the order of the
roundings (~1e-15 relative).
"""

from __future__ import annotations

import math

import numpy as np

from .oracle import reference_lambda
from .soddc import VARSIGMA, MeasureSpec

__all__ = ["gaussian_window_reference", "gaussian_window_spec", "window_weights_1d"]


def window_weights_1d(sigma_w: float) -> np.ndarray:
    """``exp(-t^2 / (2 sigma_w^2))`` on ``t = -R..R``, ``R = ceil(3 sigma_w)``; 2-D: its outer square."""
    R = max(1, int(math.ceil(3.0 * sigma_w - 1e-12)))
    t = np.arange(-R, R + 1, dtype=np.float64)
    return np.exp(-t * t / (2.0 * sigma_w * sigma_w))


def gaussian_window_spec(sigma2: float, n_orientations: int, window: int, radius_rule: str = "paper",
                         zero_mean: bool = False) -> MeasureSpec:
    """The measure's spec with Gaussian window weights, ``sigma_w = window / 4``.

    Examples
    --------
    >>> from sogdd.measure.soddc import soddc_measure
    >>> from sogdd.synthetic import pattern_image
    >>> img = pattern_image((120, 160))[0].astype(float)
    >>> spec = gaussian_window_spec(1.2, 4, 3)
    >>> spec.window_radius, len(spec.weights)
    (3, 7)
    >>> fast = soddc_measure(img, spec)
    >>> ref = gaussian_window_reference(img, spec)
    >>> bool(np.max(np.abs(fast - ref)) <= 1e-12 * np.max(np.abs(ref)))
    True
    >>> pruned = soddc_measure(img, spec, floor=1e6)
    >>> bool(np.all((pruned == fast) | ((pruned == -np.inf) & (fast < 1e6))))
    True
    """
    w = window_weights_1d(window / 4.0)
    R = len(w) // 2
    return MeasureSpec(float(sigma2), int(n_orientations), (R,) * (2 * R + 1), radius_rule=radius_rule,
                       zero_mean=bool(zero_mean), weights=tuple(w))


def gaussian_window_reference(grey: np.ndarray, spec: MeasureSpec) -> np.ndarray:
    """The literal definition: sampled kernels (eq. 22), explicit weighted sums, ``numpy.linalg.det``."""
    lam = reference_lambda(grey, spec)
    det = np.linalg.det(lam)
    return np.maximum(det, 0.0) / (np.trace(lam, axis1=2, axis2=3) + VARSIGMA)
