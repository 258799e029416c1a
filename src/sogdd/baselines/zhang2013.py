"""Shui & Zhang (2013): corners from anisotropic directional derivative (ANDD) representations.

P.-L. Shui and W.-C. Zhang, "Corner detection and classification using
anisotropic directional derivative representations", IEEE TIP 22(8), 2013
(the paper's "Zhang(2013)"). A contour-based detector, reimplemented from the
facts gathered from the authors' public MATLAB code:

* Canny edges with thresholds [0.10, 0.35] (fractions of the largest gradient
  magnitude, MATLAB ``edge(I, 'canny', [0.10 0.35], 1)``) and sigma = 1;
  contours shorter than ``(rows + cols) / 25`` pixels are dropped;
* at every remaining contour pixel, the ANDD representation: P = 84 first-order
  anisotropic Gaussian directional derivative filters over ``[0, 2 pi)``,
  ``sigma^2 = rho^2 = 6``, sampled on a 21 x 21 window;
* the corner measure is the residual between the normalised ANDD vector and
  the ideal step-edge template, ``(pi / P) sum_p (template_p - andd_p)^2``;
* 11 x 11 non-maximum suppression and threshold 0.12.

Choices made here, none of them given by those facts (also in ``docs/baselines.md``):

* kernel: ``phi_theta = -(rho^2 / s2) x_r g`` with
  ``g = 1/(2 pi s2) exp(-(rho^2 x_r^2 + y_r^2 / rho^2) / (2 s2))``, i.e. narrow
  across the edge, long along it; ``phi_{theta + pi} = -phi_theta``, so 42
  kernels are filtered and the magnitudes repeat;
* the ANDD vector is the *magnitude* of the responses, normalised by its maximum;
* the template is the magnitude ANDD of an ideal step edge through the pixel,
  ``|cos d| / sqrt(cos^2 d + rho^4 sin^2 d)`` with ``d = theta_p - theta_max``,
  aligned to the orientation of the largest response (derived analytically:
  the edge normal's variance under the kernel is ``s2 (cos^2 d / rho^2 + rho^2 sin^2 d)``);
* Canny: derivative-of-Gaussian gradients (sigma = 1, 9 taps, as MATLAB), then
  OpenCV's non-maximum suppression and hysteresis on them (``cv2.Canny`` with
  user gradients, L2 magnitude);
* contours are the 8-connected components of the edge map, and a contour's
  length is its pixel count (the authors trace curves and split them at
  junctions; components that touch are one contour here).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import cv2
import numpy as np

from ..corners import Corners
from ..select.peaks import select_peaks
from .directional_bank import rotated_coordinates
from .registry import BaselineDetector, check_int, check_number, register

__all__ = ["Zhang2013", "andd_kernels", "canny_matlab", "step_edge_template"]


def andd_kernels(sigma2: float, rho2: float, n_orientations: int, radius: int) -> np.ndarray:
    """(P/2, 2r+1, 2r+1) ANDD kernels at ``theta_p = 2 pi p / P`` for ``p < P/2``."""
    ks = []
    for p in range(n_orientations // 2):
        xr, yr = rotated_coordinates(radius, 2.0 * np.pi * p / n_orientations)
        g = np.exp(-(rho2 * xr * xr + yr * yr / rho2) / (2.0 * sigma2)) / (2.0 * np.pi * sigma2)
        ks.append(-rho2 / sigma2 * xr * g)
    return np.stack(ks)


def step_edge_template(n_orientations: int, rho2: float) -> np.ndarray:
    """Normalised magnitude ANDD of an ideal step edge, peak at index 0, length P."""
    d = 2.0 * np.pi * np.arange(n_orientations) / n_orientations
    c, s = np.cos(d), np.sin(d)
    return np.abs(c) / np.sqrt(c * c + rho2 * rho2 * s * s)


def canny_matlab(grey: np.ndarray, low: float = 0.10, high: float = 0.35, sigma: float = 1.0) -> np.ndarray:
    """Canny edge map (bool) with MATLAB's conventions for thresholds and smoothing.

    Gradients are derivative-of-Gaussian filtered (``8 ceil(sigma) + 1`` taps),
    thresholds are fractions of the largest gradient magnitude.
    """
    r = 4 * int(math.ceil(sigma))
    t = np.arange(-r, r + 1, dtype=np.float64)
    g = np.exp(-t * t / (2 * sigma * sigma))
    g /= g.sum()
    dg = -t / (sigma * sigma) * g
    dg /= np.abs(dg).sum() / 2  # unit response to a unit ramp, up to the sign
    src = np.ascontiguousarray(grey, dtype=np.float64)
    dx = cv2.sepFilter2D(src, cv2.CV_64F, dg[::-1], g, borderType=cv2.BORDER_REFLECT)
    dy = cv2.sepFilter2D(src, cv2.CV_64F, g, dg[::-1], borderType=cv2.BORDER_REFLECT)
    mag = np.hypot(dx, dy)
    top = float(mag.max())
    # rounding leaves ~1e-13 on flat images; relative thresholds would turn it into edges
    if top <= 1e-6:
        return np.zeros(grey.shape, dtype=bool)
    # 16-bit gradients for cv2.Canny; scaled so the largest magnitude is 30000
    k = 30000.0 / top
    dx16 = np.rint(dx * k).astype(np.int16)
    dy16 = np.rint(dy * k).astype(np.int16)
    edges = cv2.Canny(dx16, dy16, low * 30000.0, high * 30000.0, L2gradient=True)
    return edges > 0


@register
class Zhang2013(BaselineDetector):
    name: ClassVar[str] = "zhang2013"
    defaults: ClassVar[dict[str, Any]] = dict(
        threshold=0.12, n_orientations=84, sigma2=6.0, rho2=6.0, kernel_size=21,
        canny_low=0.10, canny_high=0.35, canny_sigma=1.0, min_contour_frac=1.0 / 25.0,
        nms_size=11, max_corners=None,
    )
    strength_doc: ClassVar[str] = (
        "(residual between the normalised ANDD vector and the step-edge template, about 0 on "
        "straight edges and up to ~1.3)"
    )
    source: ClassVar[str] = (
        "Shui & Zhang, IEEE TIP 2013 (ANDD), reimplemented from the facts of the authors' public "
        "MATLAB code: Canny [0.10, 0.35], sigma 1; contours >= (rows + cols)/25; P = 84, "
        "sigma^2 = rho^2 = 6, 21x21 kernels; 11x11 NMS; threshold 0.12"
    )
    notes: ClassVar[str] = (
        "the template form, the magnitude/max normalisation, Canny via cv2.Canny on DoG gradients "
        "and contours as 8-connected components are this package's choices (see the module docstring)"
    )

    def _validate(self) -> None:
        p = self.params
        check_number("threshold", p["threshold"], -math.inf, math.inf)
        check_int("n_orientations", p["n_orientations"], 4, 360)
        if p["n_orientations"] % 2:
            raise ValueError(f"n_orientations must be even, got {p['n_orientations']!r}")
        check_number("sigma2", p["sigma2"], 0.0, 400.0, lo_open=True)
        check_number("rho2", p["rho2"], 0.0, 400.0, lo_open=True)
        check_int("kernel_size", p["kernel_size"], 3, 101)
        if p["kernel_size"] % 2 == 0:
            raise ValueError(f"kernel_size must be odd, got {p['kernel_size']!r}")
        check_number("canny_low", p["canny_low"], 0.0, 1.0)
        check_number("canny_high", p["canny_high"], 0.0, 1.0)
        if p["canny_low"] > p["canny_high"]:
            raise ValueError("canny_low must not exceed canny_high")
        check_number("canny_sigma", p["canny_sigma"], 0.0, 20.0, lo_open=True)
        check_number("min_contour_frac", p["min_contour_frac"], 0.0, 1.0)
        check_int("nms_size", p["nms_size"], 1, 101)
        if p["nms_size"] % 2 == 0:
            raise ValueError(f"nms_size must be odd, got {p['nms_size']!r}")
        check_int("max_corners", p["max_corners"], 1, allow_none=True)

    def contour_pixels(self, grey: np.ndarray) -> np.ndarray:
        """Boolean map of the edge pixels on contours long enough to keep."""
        p = self.params
        edges = canny_matlab(grey, p["canny_low"], p["canny_high"], p["canny_sigma"])
        n, lab, stats, _ = cv2.connectedComponentsWithStats(edges.astype(np.uint8), connectivity=8)
        min_len = (grey.shape[0] + grey.shape[1]) * float(p["min_contour_frac"])
        keep = stats[:, cv2.CC_STAT_AREA] >= min_len
        keep[0] = False
        return keep[lab]

    def measure(self, grey: np.ndarray, rows: np.ndarray, cols: np.ndarray,
                chunk: int = 4096) -> np.ndarray:
        """The ANDD corner measure at the given pixels of a grey 0-255 image."""
        p = self.params
        P = int(p["n_orientations"])
        r = int(p["kernel_size"]) // 2
        ker = andd_kernels(float(p["sigma2"]), float(p["rho2"]), P, r)
        # correlation with the kernels: patches . kernels (sign is irrelevant: magnitudes)
        kmat = ker.reshape(len(ker), -1).T  # (taps, P/2)
        pad = cv2.copyMakeBorder(np.ascontiguousarray(grey, dtype=np.float64), r, r, r, r,
                                 cv2.BORDER_REFLECT)
        win = np.lib.stride_tricks.sliding_window_view(pad, (2 * r + 1, 2 * r + 1))
        tmpl = step_edge_template(P, float(p["rho2"]))
        out = np.empty(len(rows), dtype=np.float64)
        idx = np.arange(P)
        for s in range(0, len(rows), chunk):
            patches = win[rows[s : s + chunk], cols[s : s + chunk]].reshape(-1, kmat.shape[0])
            half = np.abs(patches @ kmat)
            andd = np.concatenate([half, half], axis=1)  # phi_{theta + pi} = -phi_theta
            top = andd.max(axis=1, keepdims=True)
            with np.errstate(invalid="ignore", divide="ignore"):
                a = np.where(top > 0, andd / top, 0.0)
            shift = np.argmax(andd, axis=1)
            t = tmpl[(idx[None, :] - shift[:, None]) % P]
            out[s : s + chunk] = (np.pi / P) * np.sum((t - a) ** 2, axis=1)
        return out

    def _detect(self, grey: np.ndarray, mask: np.ndarray | None) -> Corners:
        p = self.params
        contour = self.contour_pixels(grey)
        rows, cols = np.nonzero(contour)
        if len(rows) == 0:
            return Corners.empty()
        resp = np.full(grey.shape, -np.inf)
        resp[rows, cols] = self.measure(grey, rows, cols)
        rr, cc = select_peaks(resp, threshold=p["threshold"], nms_radius=int(p["nms_size"]) // 2,
                              mask=mask, max_corners=p["max_corners"])
        xy = np.stack([cc, rr], axis=1).astype(np.float64)
        return Corners(xy, resp[rr, cc], np.full(len(rr), float(p["kernel_size"])))
