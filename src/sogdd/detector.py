"""Presets, parameter checks, the image pyramid and the public detection API."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import cv2
import numpy as np

from .corners import Corners
from .filters import kernel_radius
from .io import BT601, MATLAB_RGB2GRAY, to_gray255, validate_image
from .peaks import refine_gradient, refine_quadratic, select_peaks
from .response import MeasureSpec, soddc_measure, supports_floor, window_halfwidths

__all__ = ["PRESETS", "Params", "SOGDD", "check_mask", "corner_response", "detect_corners", "resolve_params"]


@dataclass(frozen=True)
class Params:
    """Every detector parameter. See the README's preset table for their meaning."""

    sigma2: float = 1.2
    n_orientations: int = 8
    window: int = 7
    window_shape: str = "square"
    threshold: float | None = 1e9
    threshold_rel: float | None = None
    quantile: float | None = None
    nms_radius: int = 1
    max_corners: int | None = None
    subpixel: bool | str = True
    border: int = 0
    levels: int = 1
    scale_factor: float = 2.0
    # how the measure is computed (the authors' code differs from the paper here)
    kernel_radius_rule: str = "paper"
    zero_mean: bool = False
    padding: str = "response"
    authors_measure: bool = False
    gray_weights: tuple[float, float, float] = BT601
    gray_round: bool = False
    channel_order: str = "rgb"

    def measure_spec(self) -> MeasureSpec:
        return MeasureSpec(
            sigma2=float(self.sigma2),
            n_orientations=int(self.n_orientations),
            halfwidths=window_halfwidths(self.window_shape, int(self.window)),
            radius_rule=self.kernel_radius_rule,
            zero_mean=self.zero_mean,
            padding=self.padding,
            authors_measure=self.authors_measure,
        )

    def keypoint_size(self) -> float:
        """Diameter of the pixels that influence one response: window + kernel support."""
        return float(int(self.window) + 2 * kernel_radius(self.sigma2, self.kernel_radius_rule))


PRESETS: dict[str, Params] = {
    # The paper's experiments: sigma^2 = 1.2, 7x7 window, T_h = 1e9; K = 8 (see README).
    "paper": Params(),
    # The defaults of the authors' public Python code.
    "authors": Params(
        sigma2=1.44,
        n_orientations=4,
        window=5,
        window_shape="disk",
        threshold=None,
        quantile=0.99,
        nms_radius=1,
        subpixel=False,
        border=9,
        kernel_radius_rule="authors",
        zero_mean=True,
        padding="image",
        authors_measure=True,
        gray_weights=MATLAB_RGB2GRAY,
        gray_round=True,
    ),
}

_NAMES = {f.name for f in fields(Params)}


def _is_int(v) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, bool)


def _check(cond: bool, msg: str) -> None:
    if not cond:
        raise ValueError(msg)


def resolve_params(preset: str = "paper", **params) -> Params:
    """Start from a preset, apply overrides, and validate every value (``ValueError``)."""
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; choose from {', '.join(PRESETS)}")
    unknown = sorted(set(params) - _NAMES)
    if unknown:
        raise ValueError(f"unknown parameter(s): {', '.join(unknown)}")
    p = replace(PRESETS[preset], **params)
    s2 = p.sigma2
    _check(
        isinstance(s2, (int, float, np.number)) and not isinstance(s2, bool) and math.isfinite(s2)
        and 0 < s2 <= 400,
        f"sigma2 must be a finite number in (0, 400], got {s2!r}",
    )
    _check(_is_int(p.n_orientations) and 1 <= p.n_orientations <= 64,
           f"n_orientations must be an integer in [1, 64], got {p.n_orientations!r}")
    _check(p.window_shape in ("square", "disk"),
           f"window_shape must be 'square' or 'disk', got {p.window_shape!r}")
    _check(_is_int(p.window) and p.window >= 1 and p.window % 2 == 1 and p.window <= 101,
           f"window must be an odd integer in [1, 101], got {p.window!r}")
    for name in ("threshold",):
        v = getattr(p, name)
        _check(v is None or (isinstance(v, (int, float, np.number)) and math.isfinite(v)),
               f"{name} must be a finite number or None, got {v!r}")
    _check(p.threshold_rel is None or (0 <= float(p.threshold_rel) <= 1),
           f"threshold_rel must be in [0, 1], got {p.threshold_rel!r}")
    _check(p.quantile is None or (0 <= float(p.quantile) < 1),
           f"quantile must be in [0, 1), got {p.quantile!r}")
    _check(_is_int(p.nms_radius) and 1 <= p.nms_radius <= 100,
           f"nms_radius must be an integer in [1, 100], got {p.nms_radius!r}")
    _check(p.max_corners is None or (_is_int(p.max_corners) and p.max_corners >= 1),
           f"max_corners must be a positive integer or None, got {p.max_corners!r}")
    _check(isinstance(p.subpixel, bool) or p.subpixel in ("gradient", "quadratic", "none"),
           f"subpixel must be True, False, 'gradient', 'quadratic' or 'none', got {p.subpixel!r}")
    _check(_is_int(p.border) and p.border >= 0, f"border must be an integer >= 0, got {p.border!r}")
    _check(_is_int(p.levels) and 1 <= p.levels <= 16,
           f"levels must be an integer in [1, 16], got {p.levels!r}")
    _check(isinstance(p.scale_factor, (int, float, np.number)) and math.isfinite(p.scale_factor)
           and 1 < p.scale_factor <= 4, f"scale_factor must be in (1, 4], got {p.scale_factor!r}")
    _check(p.padding in ("response", "image"), "padding must be 'response' or 'image'")
    _check(p.channel_order in ("rgb", "bgr"), "channel_order must be 'rgb' or 'bgr'")
    return p


def _prepare(image, p: Params) -> np.ndarray:
    img = validate_image(image)
    return to_gray255(
        img, weights=p.gray_weights, round_integer=p.gray_round, channel_order=p.channel_order
    )


def check_mask(mask, shape: tuple[int, int]) -> np.ndarray | None:
    """Validate an OpenCV-style mask (uint8 or bool, image-sized); return it as bool."""
    if mask is None:
        return None
    m = np.asarray(mask)
    if m.dtype not in (np.uint8, np.bool_):
        raise ValueError(f"mask must be uint8 or bool, got {m.dtype}")
    if m.shape != shape:
        raise ValueError(f"mask shape {m.shape} does not match image shape {shape}")
    return m.astype(bool)


def corner_response(image, *, preset: str = "paper", **params) -> np.ndarray:
    """The corner measure Upsilon (eq. 25) of an image: an H x W float64 map.

    Parameters
    ----------
    image : ndarray
        Grey (H, W) or colour (H, W, 3|4) image; uint8, uint16, float in [0, 1]
        or bool. Converted to grey on the 0-255 scale (see :mod:`sogdd.io`).
    preset : {"paper", "authors"}
        Starting parameter set; keyword arguments override it.
    """
    p = resolve_params(preset, **params)
    return soddc_measure(_prepare(image, p), p.measure_spec())


def _floor(p: Params, spec: MeasureSpec) -> float | None:
    """The absolute threshold, when it alone decides which peaks pass (no relative or quantile one)."""
    if p.threshold is None or p.threshold <= 0 or p.threshold_rel is not None or p.quantile is not None:
        return None
    return float(p.threshold) if supports_floor(spec) else None


def _detect_level(grey: np.ndarray, p: Params, mask: np.ndarray | None) -> Corners:
    # Exact wherever a peak above the threshold or its 3x3 neighbourhood can be, -inf
    # where a bound proves the measure below it: the same corners as the full map.
    spec = p.measure_spec()
    resp = soddc_measure(grey, spec, floor=_floor(p, spec))
    rows, cols = select_peaks(
        resp,
        threshold=p.threshold,
        threshold_rel=p.threshold_rel,
        quantile=p.quantile,
        nms_radius=p.nms_radius,
        border=p.border,
        mask=mask,
        max_corners=p.max_corners,
    )
    xy = np.stack([cols, rows], axis=1).astype(np.float64)
    if p.subpixel is not False and p.subpixel != "none" and len(rows):
        xy += refine_quadratic(resp, rows, cols)
        if p.subpixel is True or p.subpixel == "gradient":
            xy = refine_gradient(grey, xy)
    return Corners(xy, resp[rows, cols], np.full(len(rows), p.keypoint_size()))


def detect_corners(image, *, preset: str = "paper", mask=None, **params) -> Corners:
    """Detect corners: local maxima of Upsilon above a threshold.

    Parameters
    ----------
    image : ndarray
        Grey or colour image (see :func:`corner_response`).
    preset : {"paper", "authors"}
        Starting parameter set; keyword arguments override it (``sigma2``,
        ``n_orientations``, ``window``, ``threshold``, ``quantile``,
        ``nms_radius``, ``max_corners``, ``subpixel``, ``border``, ``levels``,
        ``scale_factor``, ...).
    mask : ndarray of uint8 or bool, optional
        Same height and width as the image; corners are kept where it is non-zero.

    Returns
    -------
    Corners
        Strongest first. ``xy`` is (x, y) with pixel centres at integers.
    """
    p = resolve_params(preset, **params)
    grey = _prepare(image, p)
    m = check_mask(mask, grey.shape)
    parts = []
    h, w = grey.shape
    for level in range(p.levels):
        if level == 0:
            g, mk, sx, sy = grey, m, 1.0, 1.0
        else:
            f = p.scale_factor**level
            lw, lh = int(round(w / f)), int(round(h / f))
            if min(lw, lh) < 2 * p.border + 3 or min(lw, lh) < 8:
                break
            g = cv2.resize(grey, (lw, lh), interpolation=cv2.INTER_AREA)
            mk = None if m is None else cv2.resize(
                m.astype(np.uint8), (lw, lh), interpolation=cv2.INTER_NEAREST
            ).astype(bool)
            sx, sy = w / lw, h / lh
        c = _detect_level(g, p, mk)
        # pixel centres at integers: x_full = (x_level + 0.5) * s - 0.5
        xy = np.stack([(c.xy[:, 0] + 0.5) * sx - 0.5, (c.xy[:, 1] + 0.5) * sy - 0.5], axis=1)
        parts.append(Corners(xy, c.response, c.size * (sx + sy) / 2, np.full(len(c), level)))
    out = Corners.concatenate(parts)
    if p.levels > 1:
        order = np.argsort(-out.response, kind="stable")
        if p.max_corners is not None:
            order = order[: p.max_corners]
        out = out.subset(order)
    return out


class SOGDD:
    """OpenCV-style detector object (``detect``), without subclassing ``cv2.Feature2D``.

    Colour arrays are taken as BGR here, as ``cv2.imread`` returns them.
    """

    def __init__(self, preset: str = "paper", **params) -> None:
        params.setdefault("channel_order", "bgr")
        self.preset = preset
        self.params = resolve_params(preset, **params)
        self._overrides = params

    def detect_corners(self, image, mask=None) -> Corners:
        return detect_corners(image, preset=self.preset, mask=mask, **self._overrides)

    def detect(self, image, mask=None) -> tuple[cv2.KeyPoint, ...]:
        """Detect keypoints (``cv2.Feature2D.detect`` signature)."""
        return self.detect_corners(image, mask).to_keypoints()

    def compute(self, image, keypoints, descriptors=None):
        """SIFT descriptors at given keypoints (``cv2.Feature2D.compute`` signature).

        Returns ``(keypoints, descriptors)``: keypoints with SIFT-style orientations,
        descriptors (N, 128) float32 (an empty (0, 128) array where OpenCV gives None).
        """
        from .describe import compute_keypoints  # descriptors are a client of the detector

        return compute_keypoints(image, keypoints, "sift", channel_order=self.params.channel_order)

    def detectAndCompute(self, image, mask=None, descriptors=None, useProvidedKeypoints=False):  # noqa: N802,N803
        """Detect, then describe (``cv2.Feature2D.detectAndCompute`` signature)."""
        from .describe import compute_keypoints

        kps = self.detect(image, mask)
        return compute_keypoints(image, kps, "sift", channel_order=self.params.channel_order,
                                 size=8.0, scale_factor=self.params.scale_factor)

    def getDefaultName(self) -> str:  # noqa: N802 - OpenCV's name
        return "SOGDD"

    def __repr__(self) -> str:
        return f"SOGDD(preset={self.preset!r}, {self._overrides})"
