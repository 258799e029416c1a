"""Zhang & Sun (2020): multi-directional structure tensor with multiple scales.

W. Zhang and C. Sun, "Corner detection using multi-directional structure
tensor with multiple scales", IJCV 128, 2020. No Python code is public; this
follows the facts gathered from the authors' public MATLAB code:

* anisotropic Gaussian ``g = 1/(2 pi s2) exp(-(rho x_r^2 + y_r^2/rho) / (2 s2))``
  and its first-order directional derivative ``-rho x_r / s2 * g``, made
  zero-mean, ``rho = 1.5``, 8 directions over ``[0, pi)``;
* three scales ``s2`` in {1.5, 3.0, 4.5}, 31 x 31 kernels, symmetric padding;
* an 8 x 8 matrix of products of absolute responses summed over a 37-pixel
  disk (offsets with ``dx^2 + dy^2 <= 10``), measure ``det / (trace + 2.22e-16)``;
* candidates: 5 x 5 local maxima of the measure at ``s2 = 1.5`` above the
  threshold ``10^8.4``, kept only if the measure at ``s2 = 3`` and ``4.5``
  exceeds the threshold at the same pixel.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from ..corners import Corners
from ..measure.soddc import soddc_at, soddc_from_responses
from ..measure.window import disk_halfwidths
from ..select.peaks import select_peaks
from .directional_bank import anisotropic_gaussian, directional_responses, rotated_coordinates
from .registry import BaselineDetector, check_int, check_number, register

__all__ = ["Zhang2020", "fogdd_kernels"]


def fogdd_kernels(sigma2: float, rho: float, n_orientations: int, radius: int = 15,
                  zero_mean: bool = True) -> np.ndarray:
    """(K, 2r+1, 2r+1) first-order anisotropic Gaussian directional derivative kernels."""
    ks = []
    for k in range(n_orientations):
        xr, yr = rotated_coordinates(radius, k * np.pi / n_orientations)
        ker = -rho * xr / sigma2 * anisotropic_gaussian(xr, yr, sigma2, rho)
        if zero_mean:
            ker = ker - ker.mean()
        ks.append(ker)
    return np.stack(ks)


@register
class Zhang2020(BaselineDetector):
    name: ClassVar[str] = "zhang2020"
    defaults: ClassVar[dict[str, Any]] = dict(
        threshold=10**8.4, scales=(1.5, 3.0, 4.5), rho=1.5, n_orientations=8, kernel_size=31,
        window_r2=10.0, nms_size=5, max_corners=None,
    )
    strength_doc: ClassVar[str] = (
        "(absolute, on det/(trace + 2.22e-16) for 0-255 intensities; applied at every scale)"
    )
    source: ClassVar[str] = (
        "Zhang & Sun, IJCV 2020 (multi-directional structure tensor, multiple scales), reimplemented "
        "from the facts of the authors' public MATLAB code: rho = 1.5, 8 directions, sigma^2 in "
        "{1.5, 3, 4.5}, 31x31 zero-mean kernels, 37-pixel disk, 5x5 NMS, threshold 10^8.4"
    )
    notes: ClassVar[str] = (
        "a 5x5 plateau keeps one point (the first in raster order); the other scales are checked at "
        "the candidate pixel itself"
    )

    def _validate(self) -> None:
        p = self.params
        check_number("threshold", p["threshold"], -math.inf, math.inf)
        sc = p["scales"]
        if not isinstance(sc, (tuple, list)) or not sc:
            raise ValueError(f"scales must be a non-empty tuple of sigma^2 values, got {sc!r}")
        for s in sc:
            check_number("scales item", s, 0.0, 100.0, lo_open=True)
        check_number("rho", p["rho"], 0.0, 100.0, lo_open=True)
        check_int("n_orientations", p["n_orientations"], 2, 64)
        check_int("kernel_size", p["kernel_size"], 3, 101)
        if p["kernel_size"] % 2 == 0:
            raise ValueError(f"kernel_size must be odd, got {p['kernel_size']!r}")
        check_number("window_r2", p["window_r2"], 0.0, 400.0)
        check_int("nms_size", p["nms_size"], 1, 101)
        if p["nms_size"] % 2 == 0:
            raise ValueError(f"nms_size must be odd, got {p['nms_size']!r}")
        check_int("max_corners", p["max_corners"], 1, allow_none=True)

    def _abs_responses(self, grey: np.ndarray, sigma2: float) -> np.ndarray:
        p = self.params
        ker = fogdd_kernels(float(sigma2), float(p["rho"]), int(p["n_orientations"]),
                            int(p["kernel_size"]) // 2)
        return directional_responses(grey, ker)

    def response(self, grey: np.ndarray, scale_index: int = 0) -> np.ndarray:
        """The measure map at one of the scales, for a grey 0-255 float image."""
        absl = self._abs_responses(grey, self.params["scales"][scale_index])
        return soddc_from_responses(absl, disk_halfwidths(float(self.params["window_r2"])))

    def _detect(self, grey: np.ndarray, mask: np.ndarray | None) -> Corners:
        p = self.params
        halfw = disk_halfwidths(float(p["window_r2"]))
        resp = self.response(grey, 0)
        rows, cols = select_peaks(resp, threshold=p["threshold"], nms_radius=p["nms_size"] // 2,
                                  mask=mask)
        # the coarser scales only need the measure at the candidates
        for s2 in p["scales"][1:]:
            if len(rows) == 0:
                break
            v = soddc_at(self._abs_responses(grey, s2), halfw, rows, cols)
            keep = v > p["threshold"]
            rows, cols = rows[keep], cols[keep]
        if p["max_corners"] is not None:
            rows, cols = rows[: p["max_corners"]], cols[: p["max_corners"]]
        xy = np.stack([cols, rows], axis=1).astype(np.float64)
        return Corners(xy, resp[rows, cols], np.full(len(rows), float(p["kernel_size"])))
