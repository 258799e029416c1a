"""The blur family of the repeatability test (beyond the paper): Gaussian and motion blur.

The abstract claims "robustness to image blur transformation", which none of
Fig. 9's six families tests. Both kinds keep the geometry (the identity map):
each kernel is centred, so a corner stays where it was.

* **Gaussian**: ``G_s(x, y) ∝ exp(-(x² + y²) / 2s²)``, s = 0.5 to 5.0 px in steps of 0.5,
  sampled on ``[-ceil(4s), ceil(4s)]`` per axis and normalised to sum 1 (separable).
* **Motion**: a straight segment of ``L`` taps at unit spacing, ``t·(cos a, sin a)``
  for ``t = -(L-1)/2 .. (L-1)/2``, each tap splatted bilinearly on the pixel grid,
  normalised to sum 1; L = 3 to 15 px in steps of 2. At a = 0 it is the 1 x L box
  filter (MATLAB ``fspecial('motion', L, 0)``). The angle ``a`` is drawn uniformly
  in [0, pi) from a generator seeded by ``(seed, L)``, so each image gets its own
  angle and a run is reproducible.

Borders are reflected (OpenCV ``BORDER_REFLECT``, half-sample) and the result is
rounded back to uint8.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

__all__ = ["GAUSSIAN_SIGMAS", "MOTION_LENGTHS", "apply_blur", "gaussian_kernel", "motion_angle",
           "motion_kernel"]

#: Gaussian standard deviations (px) of the full grid
GAUSSIAN_SIGMAS = tuple(round(0.5 * k, 1) for k in range(1, 11))
#: motion-blur lengths (px) of the full grid
MOTION_LENGTHS = tuple(range(3, 16, 2))


def gaussian_kernel(sigma: float) -> np.ndarray:
    """The 1-D Gaussian factor of standard deviation ``sigma`` on ``[-ceil(4 sigma), ceil(4 sigma)]``, sum 1.

    Examples
    --------
    >>> k = gaussian_kernel(1.5)
    >>> len(k), bool(np.isclose(k.sum(), 1.0)), bool(np.allclose(k, k[::-1]))
    (13, True, True)
    """
    if not (math.isfinite(sigma) and sigma > 0):
        raise ValueError(f"Gaussian blur sigma must be a positive number, got {sigma!r}")
    r = int(math.ceil(4.0 * sigma))
    x = np.arange(-r, r + 1, dtype=np.float64)
    k = np.exp(-0.5 * (x / sigma) ** 2)
    return k / k.sum()


def motion_kernel(length: int, angle: float) -> np.ndarray:
    """A motion-blur kernel: ``length`` taps along ``(cos angle, sin angle)`` (x right, y down), sum 1.

    The kernel is square and odd-sized with the segment's midpoint on its centre
    pixel, so its centroid is the centre (no shift).

    Examples
    --------
    >>> motion_kernel(5, 0.0)[3].tolist()  # a = 0: the 1 x 5 box filter (and a zero margin)
    [0.0, 0.2, 0.2, 0.2, 0.2, 0.2, 0.0]
    >>> k = motion_kernel(7, 0.6)
    >>> bool(np.isclose(k.sum(), 1.0)), k.shape
    (True, (9, 9))
    """
    if not (isinstance(length, (int, np.integer)) and length >= 1):
        raise ValueError(f"motion blur length must be a positive integer, got {length!r}")
    half = (int(length) - 1) / 2.0
    r = int(math.ceil(half)) + 1  # room for the bilinear splat of the end taps
    k = np.zeros((2 * r + 1, 2 * r + 1))
    t = np.arange(int(length), dtype=np.float64) - half
    x = r + t * math.cos(angle)
    y = r + t * math.sin(angle)
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = x - x0, y - y0
    for dx, dy, w in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)),
                      (0, 1, (1 - fx) * fy), (1, 1, fx * fy)):
        np.add.at(k, (y0 + dy, x0 + dx), w)
    return k / k.sum()


def motion_angle(seed: int, length: int) -> float:
    """The seeded random angle in [0, pi) of the motion blur of ``length`` for one image's ``seed``.

    Examples
    --------
    >>> motion_angle(3, 7) == motion_angle(3, 7), 0 <= motion_angle(3, 7) < np.pi
    (True, True)
    """
    return float(np.random.default_rng([int(seed), 7919, int(length)]).uniform(0.0, math.pi))


def apply_blur(image: np.ndarray, kind: str, value: float, seed: int = 0) -> np.ndarray:
    """Blur a uint8 image: ``kind`` ``"gaussian"`` (``value`` = sigma) or ``"motion"`` (``value`` = length).

    Examples
    --------
    >>> img = np.zeros((32, 32), np.uint8); img[8:24, 8:24] = 200
    >>> out = apply_blur(img, "gaussian", 2.0)
    >>> out.dtype.name, out.shape, int(out[16, 16]), 0 < int(out[8, 16]) < 200
    ('uint8', (32, 32), 200, True)
    """
    src = np.asarray(image)
    if kind == "gaussian":
        k = gaussian_kernel(float(value))
        out = cv2.sepFilter2D(src.astype(np.float32), cv2.CV_32F, k, k, borderType=cv2.BORDER_REFLECT)
    elif kind == "motion":
        k = motion_kernel(int(value), motion_angle(seed, int(value)))
        out = cv2.filter2D(src.astype(np.float32), cv2.CV_32F, k.astype(np.float32),
                           borderType=cv2.BORDER_REFLECT)
    else:
        raise ValueError(f"blur kind must be 'gaussian' or 'motion', got {kind!r}")
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)
