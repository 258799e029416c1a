"""Direct, slow implementation of eqs. 22-25: the oracle for the fast path.

Nothing here is clever: 2-D convolutions with the literally sampled kernels
(eq. 22), absolute values, window sums of every product, and a batched
``numpy.linalg.det``. Tests and ``benchmarks/bench_speed.py`` compare the tiled,
compiled measure of :mod:`sogdd.measure.soddc` against it.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from .filters import kernel_radius, orientations, sogdd_kernel
from .soddc import VARSIGMA, MeasureSpec, authors_measure
from .window import window_offsets

__all__ = ["reference_lambda", "reference_measure"]


def reference_lambda(image: np.ndarray, spec: MeasureSpec) -> np.ndarray:
    """The SODDC matrices by the definition (eq. 24): (H, W, K, K) float64.

    With ``spec.weights`` each offset's outer product is weighted by ``w(dy) w(dx)``.
    """
    img = np.asarray(image, dtype=np.float64)
    H, W = img.shape
    rk = kernel_radius(spec.sigma2, spec.radius_rule)
    offsets = window_offsets(spec.halfwidths)
    R = int(np.abs(offsets[:, 0]).max())
    kernels = [
        sogdd_kernel(spec.sigma2, t, rk, zero_mean=spec.zero_mean)
        for t in orientations(spec.n_orientations)
    ]
    if spec.padding == "image":
        pad = rk + R
        src = np.pad(img, pad, mode="symmetric")
        resp = np.stack([ndimage.convolve(src, k, mode="constant") for k in kernels])
        resp = resp[:, rk:-rk, rk:-rk]  # responses on the image plus R pixels of margin
    else:
        resp = np.stack([ndimage.convolve(img, k, mode="reflect") for k in kernels])
        resp = np.pad(resp, ((0, 0), (R, R), (R, R)), mode="symmetric")
    absl = np.abs(resp)
    K = len(kernels)
    lam = np.zeros((H, W, K, K))
    w = spec.weights
    for dy, dx in offsets:
        v = absl[:, R + dy : R + dy + H, R + dx : R + dx + W]
        if w:
            lam += w[dy + R] * w[dx + R] * np.einsum("ihw,jhw->hwij", v, v)
        else:
            lam += np.einsum("ihw,jhw->hwij", v, v)
    return lam


def reference_measure(image: np.ndarray, spec: MeasureSpec, *, chunk: int = 65536) -> np.ndarray:
    """Upsilon by the definition (eq. 25), float64, H x W.

    Examples
    --------
    >>> from sogdd.measure.soddc import soddc_measure
    >>> from sogdd.measure.window import window_halfwidths
    >>> img = np.random.default_rng(0).uniform(0, 255, (20, 24))
    >>> spec = MeasureSpec(1.2, 4, window_halfwidths("square", 5))
    >>> ref, fast = reference_measure(img, spec), soddc_measure(img, spec)
    >>> bool(np.allclose(fast, ref, rtol=1e-8, atol=0))
    True
    """
    lam = reference_lambda(image, spec)
    H, W, K, _ = lam.shape
    lam = lam.reshape(-1, K, K)
    det = np.concatenate([np.linalg.det(lam[i : i + chunk]) for i in range(0, len(lam), chunk)])
    tr = np.trace(lam, axis1=1, axis2=2)
    det = det.reshape(H, W)
    tr = tr.reshape(H, W)
    if spec.authors_measure:
        return authors_measure(det, tr)
    return det / (tr + VARSIGMA)
