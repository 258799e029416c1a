"""Detector parameters: the presets and their validation.

Every parameter of the detector lives in :class:`Params`; a preset is a
``Params`` value, and :func:`resolve_params` applies overrides to a preset and
checks every field once, at the door, so the rest of the pipeline can trust it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np

from .image.grey import BT601, MATLAB_RGB2GRAY
from .image.validate import check_value_range
from .measure.filters import kernel_radius
from .measure.gaussian_window import gaussian_window_spec
from .measure.soddc import MeasureSpec
from .measure.window import window_halfwidths

__all__ = ["CHOICES", "PRESET", "PRESETS", "Params", "given", "resolve_params"]

_SUBPIXEL = ("gradient", "quadratic", "none", "adaptive")
#: the values of each text-valued parameter (one list: validation, the CLI's choices, spec parsing)
CHOICES: dict[str, tuple[str, ...]] = {
    "window_shape": ("square", "disk", "gaussian"),
    "subpixel": _SUBPIXEL,
    "threshold_units": ("measure", "grey"),
}


class _FromPreset:
    """The default of every detector keyword: the value of the chosen preset."""

    _instance = None

    def __new__(cls):  # one object, so that ``is`` tests work across pickling and copies
        if cls._instance is None:
            cls._instance = super().__new__(cls)
        return cls._instance

    def __repr__(self) -> str:
        return "PRESET"

    def __reduce__(self):
        return (_FromPreset, ())


#: the default of the detector's keywords in signatures: "the preset's value" (README, preset table)
PRESET = _FromPreset()


def given(arguments: dict) -> dict:
    """The detector parameters a caller set: the :class:`Params` fields of ``arguments`` not at :data:`PRESET`.

    ``arguments``: a function's ``locals()`` on entry (its arguments by name).

    Examples
    --------
    >>> given({"image": None, "sigma2": 1.5, "window": PRESET})
    {'sigma2': 1.5}
    """
    return {k: v for k, v in arguments.items() if k in _NAMES and v is not PRESET}


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
    subpixel: str = "gradient"  # "gradient" | "quadratic" | "none" (True/False accepted)
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
    # "measure": threshold and response on Upsilon itself; "grey": in grey levels of corner
    # contrast (sogdd.measure.units), so a threshold means the same on a dim and a bright image
    threshold_units: str = "measure"
    # report each X-junction once, on its saddle point (sogdd.select.x_junctions); needs threshold_units="grey"
    x_junctions: bool = False
    value_range: tuple[float, float] | None = None  # input values mapped onto 0-255 (None: by dtype)

    def measure_spec(self) -> MeasureSpec:
        """The resolved :class:`~sogdd.measure.soddc.MeasureSpec` of these parameters."""
        if self.window_shape == "gaussian":
            return gaussian_window_spec(float(self.sigma2), int(self.n_orientations), int(self.window),
                                        self.kernel_radius_rule, bool(self.zero_mean))
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
        subpixel="none",
        border=9,
        kernel_radius_rule="authors",
        zero_mean=True,
        padding="image",
        authors_measure=True,
        gray_weights=MATLAB_RGB2GRAY,
        gray_round=True,
    ),
    # The best corners the family gives, chosen by the declared study of docs/hr.md;
    # the values and the study row each comes from are in the README's preset table.
    "hr": Params(
        sigma2=1.5,
        n_orientations=4,
        window=3,
        window_shape="gaussian",
        threshold=20.0,
        threshold_units="grey",
        x_junctions=True,
        subpixel="adaptive",
    ),
}

_NAMES = {f.name for f in fields(Params)}


def _is_int(v) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, bool)


def _is_number(v) -> bool:
    return isinstance(v, (int, float, np.number)) and not isinstance(v, (bool, np.bool_)) and math.isfinite(v)


def _check(cond: bool, msg: str) -> None:
    if not cond:
        raise ValueError(msg)


def resolve_params(preset: str = "paper", **params) -> Params:
    """Start from a preset, apply overrides, and validate every value.

    ``subpixel`` is normalised: ``True`` -> ``"gradient"``, ``False`` -> ``"none"``.

    Raises
    ------
    ValueError
        One line naming the parameter, for an unknown preset, an unknown
        parameter or a value out of range.

    Examples
    --------
    >>> p = resolve_params("paper", window=5, subpixel=False)
    >>> p.sigma2, p.n_orientations, p.window, p.subpixel
    (1.2, 8, 5, 'none')
    >>> resolve_params(window=4)
    Traceback (most recent call last):
    ...
    ValueError: window must be an odd integer in [1, 101], got 4
    """
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
    _check(p.window_shape in CHOICES["window_shape"],
           f"window_shape must be 'square', 'disk' or 'gaussian', got {p.window_shape!r}")
    _check(p.window_shape != "gaussian" or (p.padding == "response" and not p.authors_measure),
           "window_shape='gaussian' needs padding='response' and authors_measure=False")
    _check(_is_int(p.window) and p.window >= 1 and p.window % 2 == 1 and p.window <= 101,
           f"window must be an odd integer in [1, 101], got {p.window!r}")
    for name in ("threshold",):
        v = getattr(p, name)
        _check(v is None or (isinstance(v, (int, float, np.number)) and math.isfinite(v)),
               f"{name} must be a finite number or None, got {v!r}")
    _check(p.threshold_rel is None or (_is_number(p.threshold_rel) and 0 <= p.threshold_rel <= 1),
           f"threshold_rel must be a number in [0, 1], got {p.threshold_rel!r}")
    _check(p.quantile is None or (_is_number(p.quantile) and 0 <= p.quantile < 1),
           f"quantile must be a number in [0, 1), got {p.quantile!r}")
    _check(_is_int(p.nms_radius) and 1 <= p.nms_radius <= 100,
           f"nms_radius must be an integer in [1, 100], got {p.nms_radius!r}")
    _check(p.max_corners is None or (_is_int(p.max_corners) and p.max_corners >= 1),
           f"max_corners must be a positive integer or None, got {p.max_corners!r}")
    _check(isinstance(p.subpixel, (bool, np.bool_)) or p.subpixel in _SUBPIXEL,
           f"subpixel must be True, False, 'gradient', 'adaptive', 'quadratic' or 'none', got {p.subpixel!r}")
    if isinstance(p.subpixel, (bool, np.bool_)):
        p = replace(p, subpixel="gradient" if p.subpixel else "none")
    _check(_is_int(p.border) and p.border >= 0, f"border must be an integer >= 0, got {p.border!r}")
    _check(_is_int(p.levels) and 1 <= p.levels <= 16,
           f"levels must be an integer in [1, 16], got {p.levels!r}")
    _check(isinstance(p.scale_factor, (int, float, np.number)) and math.isfinite(p.scale_factor)
           and 1 < p.scale_factor <= 4, f"scale_factor must be in (1, 4], got {p.scale_factor!r}")
    _check(p.padding in ("response", "image"), f"padding must be 'response' or 'image', got {p.padding!r}")
    _check(p.kernel_radius_rule in ("paper", "authors"),
           f"kernel_radius_rule must be 'paper' or 'authors', got {p.kernel_radius_rule!r}")
    for name in ("zero_mean", "authors_measure", "gray_round"):
        _check(isinstance(getattr(p, name), (bool, np.bool_)), f"{name} must be True or False")
    w = p.gray_weights
    _check(isinstance(w, (tuple, list)) and len(w) == 3
           and all(isinstance(v, (int, float, np.number)) and math.isfinite(v) and v >= 0 for v in w)
           and sum(w) > 0, f"gray_weights must be three finite non-negative numbers, got {w!r}")
    _check(p.channel_order in ("rgb", "bgr"), "channel_order must be 'rgb' or 'bgr'")
    _check(p.threshold_units in CHOICES["threshold_units"],
           f"threshold_units must be 'measure' or 'grey', got {p.threshold_units!r}")
    _check(isinstance(p.x_junctions, (bool, np.bool_)),
           f"x_junctions must be True or False, got {p.x_junctions!r}")
    _check(not p.x_junctions or p.threshold_units == "grey",
           "x_junctions needs threshold_units='grey' (corners and junctions share that scale)")
    _check(p.threshold_units == "measure" or not p.authors_measure,
           "threshold_units='grey' needs the paper's measure (authors_measure=False)")
    if p.value_range is not None:
        p = replace(p, value_range=check_value_range(p.value_range))
    return p
