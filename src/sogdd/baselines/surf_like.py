"""``surf-like``: SURF's detection stage (determinant of Hessian in scale space).

SURF's own code (``cv2.xfeatures2d.SURF_create``) is excluded from the OpenCV
wheels as patented, so this reproduces its *detector* with Gaussian
derivatives instead of box filters (Bay et al. 2006/2008):

* SURF's scale layout: 4 octaves of 4 layers, filter sizes
  ``L = 3 (2^(o+1) (l+1) + 1)`` (9, 15, 21, 27; 15, 27, 39, 51; ...), Gaussian
  scale ``sigma = 1.2 L / 9``, octave ``o`` sampled every ``2^o`` pixels;
* response ``det H = Lxx Lyy - Lxy^2`` of the Gaussian second derivatives,
  scaled by ``(c sigma^2)^2`` with ``c = 135/81/1.44 = 1.157`` (the ratio of a
  9 x 9 SURF box filter's response, normalised by its area as OpenCV does, to
  ``sigma^2 Lxx``), so the threshold is close to OpenCV's ``hessianThreshold``
  (default 100) on 0-255 images;
* 3 x 3 x 3 non-maximum suppression over space and the layers of an octave
  (layers 1 and 2 of each octave are tested), positive responses only;
* sub-pixel position from a quadratic fit on the 3 x 3 patch of the layer.

Approximations: Gaussian instead of box filters (so no 0.9 weight on
``Lxy``); each octave is pre-smoothed with ``sigma = 2^o / 2`` and decimated,
and the remaining blur is applied on the decimated image; no interpolation in
scale.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import cv2
import numpy as np

from ..corners import Corners
from ..select.peaks import local_maxima
from ..select.refine import refine_quadratic
from .registry import BaselineDetector, check_int, check_number, register, sort_strongest_first

__all__ = ["SURFLike", "surf_filter_size"]

_BOX_TO_GAUSS = 135.0 / 81.0 / 1.44


def surf_filter_size(octave: int, layer: int) -> int:
    """SURF's box filter side ``L`` for an octave and layer (both from 0)."""
    return 3 * (2 ** (octave + 1) * (layer + 1) + 1)


def _gauss_derivs(img: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r = max(1, int(math.ceil(3.0 * sigma)))
    t = np.arange(-r, r + 1, dtype=np.float64)
    g = np.exp(-t * t / (2 * sigma * sigma))
    g /= g.sum()
    d1 = -t / (sigma * sigma) * g  # derivative of g (convolution form)
    d2 = (t * t / sigma**4 - 1 / sigma**2) * g
    d2 -= d2.mean()  # no response to a constant on a truncated support
    f = lambda kx, ky: cv2.sepFilter2D(img, cv2.CV_64F, kx[::-1], ky[::-1],  # noqa: E731
                                       borderType=cv2.BORDER_REFLECT)
    return f(d2, g), f(g, d2), f(d1, d1)


@register
class SURFLike(BaselineDetector):
    name: ClassVar[str] = "surf-like"
    family: ClassVar[str] = "blob"
    defaults: ClassVar[dict[str, Any]] = dict(threshold=100.0, n_octaves=4, n_layers=4, max_corners=None)
    strength_doc: ClassVar[str] = (
        "(determinant of Hessian in OpenCV-SURF units on 0-255 images, like hessianThreshold)"
    )
    source: ClassVar[str] = (
        "Bay et al. 2006/2008 (SURF detection stage), reimplemented with Gaussian derivatives: "
        "SURF's octave/layer layout (4 x 4, sizes 9..195), hessianThreshold 100 (OpenCV's default)"
    )
    notes: ClassVar[str] = (
        "SURF's code is patented and excluded from the OpenCV wheels; Gaussian instead of box "
        "filters, no 0.9 weight on Lxy, no interpolation in scale"
    )

    def _validate(self) -> None:
        p = self.params
        check_number("threshold", p["threshold"], -math.inf, math.inf)
        check_int("n_octaves", p["n_octaves"], 1, 8)
        check_int("n_layers", p["n_layers"], 3, 8)
        check_int("max_corners", p["max_corners"], 1, allow_none=True)

    def _detect(self, grey: np.ndarray, mask: np.ndarray | None) -> Corners:
        p = self.params
        H, W = grey.shape
        parts = []
        for o in range(p["n_octaves"]):
            step = 2**o
            if min(H, W) // step < 8:
                break
            pre = 0.5 * step if o else 0.0
            base = grey if o == 0 else cv2.GaussianBlur(grey, (0, 0), pre,
                                                        borderType=cv2.BORDER_REFLECT)
            img = np.ascontiguousarray(base[::step, ::step])
            stack = []
            sizes = []
            for layer in range(p["n_layers"]):
                L = surf_filter_size(o, layer)
                sigma = 1.2 * L / 9.0
                rem = math.sqrt(max(sigma * sigma - pre * pre, 1e-6)) / step
                lxx, lyy, lxy = _gauss_derivs(img, rem)
                scale = (_BOX_TO_GAUSS * sigma * sigma) ** 2
                # derivatives on the decimated grid are per coarse pixel: back to full-res units
                stack.append(scale * (lxx * lyy - lxy * lxy) / step**4)
                sizes.append(L)
            st = np.stack(stack)
            spatial = np.stack([cv2.dilate(s, np.ones((3, 3), np.uint8)) for s in st])
            for layer in range(1, p["n_layers"] - 1):
                cur = st[layer]
                nb = np.maximum(np.maximum(spatial[layer - 1], spatial[layer + 1]), spatial[layer])
                cand = (cur >= nb) & (cur > max(float(p["threshold"]), 0.0)) & local_maxima(cur, 1)
                rows, cols = np.nonzero(cand)
                if len(rows) == 0:
                    continue
                off = refine_quadratic(cur, rows, cols, log=False)
                x = (cols + off[:, 0]) * step
                y = (rows + off[:, 1]) * step
                parts.append(Corners(np.stack([x, y], axis=1), cur[rows, cols],
                                     np.full(len(rows), float(sizes[layer])), np.full(len(rows), o)))
        out = sort_strongest_first(Corners.concatenate(parts))
        if mask is not None:
            from .registry import apply_mask

            out = apply_mask(out, mask)
        if p["max_corners"] is not None:
            out = out.subset(np.arange(min(len(out), p["max_corners"])))
        return out
