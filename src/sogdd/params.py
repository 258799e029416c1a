"""Detector parameters: the :class:`Params` object, the presets and their validation.

Every parameter lives in :class:`Params`, a frozen dataclass whose ``repr`` shows every value,
validated when made. A preset is a ``Params`` (:data:`PRESETS`): ``Params.preset("hr")`` gives
one, ``.replace(...)`` changes it, :func:`resolve_params` does both in one call. Changes are also
checked against the values they keep: one that would silently give a kept value another meaning
(``threshold_units`` without a threshold in those units; a relative threshold on top of a kept
absolute one, or the reverse) is an error that says what to give instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from dataclasses import replace as _replace

import numpy as np

from .image.grey import BT601, MATLAB_RGB2GRAY
from .image.validate import check_value_range
from .measure.filters import kernel_radius
from .measure.gaussian_window import gaussian_window_spec
from .measure.soddc import MeasureSpec
from .measure.window import window_halfwidths

__all__ = ["CHOICES", "DETECT_FIELDS", "MEASURE_FIELDS", "PRESET", "PRESETS", "SIGMA2_RANGE", "Params",
           "check_levels", "given", "max_levels", "preset_table", "resolve_params"]

_SUBPIXEL = ("gradient", "quadratic", "none", "adaptive")
#: the values of each text-valued parameter (one list: validation, the CLI's choices, spec parsing)
CHOICES: dict[str, tuple[str, ...]] = {
    "window_shape": ("square", "disk", "gaussian"),
    "subpixel": _SUBPIXEL,
    "threshold_units": ("measure", "grey"),
}

#: the scales sigma^2 the SOGDD filters are defined for. The filter's pass band peaks at the
#: frequency sqrt(2) / sigma (rad/px; |FT psi| ~ w^2 exp(-sigma^2 w^2 / 2)); below sigma^2 = 2 / pi^2
#: that peak lies beyond the pixel grid's Nyquist frequency pi, and the sampled kernel no longer is
#: a second derivative of a Gaussian (at sigma^2 -> 0 it is a single pixel of value ~ -1 / sigma^4).
#: The upper end keeps the kernels (radius 4 sigma = 80 px) a filter, not a whole image.
SIGMA2_RANGE = (2.0 / math.pi**2, 400.0)


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


#: the default of the detector's keywords in signatures: "the preset's value" (each function's
#: docstring tabulates the value of every keyword in every preset)
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
    """Every detector parameter, validated when made; the ``repr`` shows every value.

    Make one from a preset, change it with :meth:`replace` (both validate), pass it to
    :func:`sogdd.detect_corners`, :func:`sogdd.corner_response` or :class:`sogdd.SOGDD` in place
    of a preset's name. :func:`sogdd.detect_corners` documents each field, with its value in every
    preset. ``subpixel=True`` / ``False`` are stored as ``"gradient"`` / ``"none"``.

    Raises
    ------
    ValueError
        One line naming the parameter: a value out of range, or options that contradict each other
        (``x_junctions`` needs ``threshold_units="grey"``; ``window_shape="gaussian"`` needs
        ``padding="response"``; ``threshold_rel`` and ``quantile`` are alternatives).

    Examples
    --------
    >>> p = Params.preset("hr").replace(window=5)
    >>> p.sigma2, p.window, p.window_shape
    (1.5, 5, 'gaussian')
    >>> "threshold_units='grey'" in repr(p)
    True
    >>> Params.preset("paper").replace(threshold_units="grey")
    Traceback (most recent call last):
    ...
    ValueError: threshold_units='grey' would read threshold=1e+09, kept from before, in grey levels; ...
    """

    sigma2: float = 1.2
    n_orientations: int = 8
    window: int = 7
    window_shape: str = "square"
    threshold: float | None = 1e9
    threshold_rel: float | None = None
    quantile: float | None = None
    nms_radius: int = 1
    max_corners: int | None = None
    subpixel: str = "gradient"  # "gradient" | "quadratic" | "none" | "adaptive" (True/False accepted)
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

    def __post_init__(self) -> None:
        if isinstance(self.subpixel, (bool, np.bool_)):
            object.__setattr__(self, "subpixel", "gradient" if self.subpixel else "none")
        _check_values(self)
        _check_combinations(self)
        if self.value_range is not None:
            object.__setattr__(self, "value_range", check_value_range(self.value_range))

    @classmethod
    def preset(cls, name: str = "paper", **changes) -> Params:
        """The preset ``name`` (``"paper"``, ``"authors"``, ``"hr"``) with ``changes`` applied and validated.

        Examples
        --------
        >>> Params.preset("authors").window_shape
        'disk'
        """
        if not isinstance(name, str) or name not in PRESETS:
            raise ValueError(f"unknown preset {name!r}; choose from {', '.join(PRESETS)}")
        return PRESETS[name]._changed(changes, f"the {name!r} preset")

    def replace(self, **changes) -> Params:
        """A copy with ``changes`` applied, validated, and checked against the values it keeps.

        Examples
        --------
        >>> Params.preset("paper").replace(threshold=None, quantile=0.99).quantile
        0.99
        >>> Params.preset("paper").replace(quantile=0.99)
        Traceback (most recent call last):
        ...
        ValueError: quantile=0.99 would apply together with threshold=1e+09, kept from before (...); give ...
        """
        return self._changed(changes, "before")

    def _changed(self, changes: dict, origin: str) -> Params:
        unknown = sorted(set(changes) - _NAMES)
        if unknown:
            raise ValueError(f"unknown parameter(s): {', '.join(map(str, unknown))}")
        if not changes:
            return self
        new = _replace(self, **changes)  # each value, and the options together
        _check_kept(self, changes, origin)
        return new

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


_NAMES = {f.name for f in fields(Params)}


def _is_int(v) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def _is_number(v) -> bool:
    return isinstance(v, (int, float, np.number)) and not isinstance(v, (bool, np.bool_)) and math.isfinite(v)


def _is_bool(v) -> bool:
    return isinstance(v, (bool, np.bool_))


def _weights(w) -> bool:
    return (isinstance(w, (tuple, list)) and len(w) == 3 and all(_is_number(v) and v >= 0 for v in w)
            and sum(w) > 0)


_S2_LO, _S2_HI = SIGMA2_RANGE
#: each field's own rule: (test, what a valid value is)
_RULES: dict[str, tuple] = {
    "sigma2": (lambda v: _is_number(v) and _S2_LO <= v <= _S2_HI,
               f"a finite number in [2/pi^2 = {_S2_LO:.4f}, {_S2_HI:g}] (below 2/pi^2 the filters' pass band, "
               "at sqrt(2)/sigma rad/px, lies beyond the pixel grid's Nyquist frequency pi)"),
    "n_orientations": (lambda v: _is_int(v) and 1 <= v <= 64, "an integer in [1, 64]"),
    "window": (lambda v: _is_int(v) and 1 <= v <= 101 and v % 2 == 1, "an odd integer in [1, 101]"),
    "window_shape": (lambda v: v in CHOICES["window_shape"], "'square', 'disk' or 'gaussian'"),
    "threshold": (lambda v: v is None or (_is_number(v) and v >= 0),
                  "a finite number >= 0, or None for no absolute threshold"),
    "threshold_rel": (lambda v: v is None or (_is_number(v) and 0 <= v <= 1), "a number in [0, 1], or None"),
    "quantile": (lambda v: v is None or (_is_number(v) and 0 <= v < 1), "a number in [0, 1), or None"),
    "nms_radius": (lambda v: _is_int(v) and 1 <= v <= 100, "an integer in [1, 100]"),
    "max_corners": (lambda v: v is None or (_is_int(v) and v >= 1), "a positive integer or None"),
    "subpixel": (lambda v: v in _SUBPIXEL,
                 "True, False, 'gradient', 'adaptive', 'quadratic' or 'none'"),
    "border": (lambda v: _is_int(v) and v >= 0, "an integer >= 0"),
    "levels": (lambda v: _is_int(v) and 1 <= v <= 16, "an integer in [1, 16]"),
    "scale_factor": (lambda v: _is_number(v) and 1 < v <= 4, "a number in (1, 4]"),
    "kernel_radius_rule": (lambda v: v in ("paper", "authors"), "'paper' or 'authors'"),
    "zero_mean": (_is_bool, "True or False"),
    "padding": (lambda v: v in ("response", "image"), "'response' or 'image'"),
    "authors_measure": (_is_bool, "True or False"),
    "gray_weights": (_weights, "three finite non-negative numbers, not all 0"),
    "gray_round": (_is_bool, "True or False"),
    "channel_order": (lambda v: v in ("rgb", "bgr"), "'rgb' or 'bgr'"),
    "threshold_units": (lambda v: v in CHOICES["threshold_units"], "'measure' or 'grey'"),
    "x_junctions": (_is_bool, "True or False"),
    "value_range": (lambda v: True, ""),  # checked (and normalised) by check_value_range
}


def _check(cond: bool, msg: str) -> None:
    if not cond:
        raise ValueError(msg)


def _check_values(p: Params) -> None:
    """Each field on its own: one line naming the first bad one."""
    for name, (ok, what) in _RULES.items():
        v = getattr(p, name)
        try:
            good = bool(ok(v))
        except TypeError:  # an unorderable or unhashable value
            good = False
        _check(good, f"{name} must be {what}, got {v!r}")


def _check_combinations(p: Params) -> None:
    """Options that depend on each other: what to use instead."""
    _check(p.window_shape != "gaussian" or (p.padding == "response" and not p.authors_measure),
           "window_shape='gaussian' needs padding='response' and authors_measure=False (the Gaussian window "
           f"weighs the reflected responses; got padding={p.padding!r}, authors_measure={p.authors_measure}); "
           "set those, or use window_shape='square' or 'disk'")
    _check(not p.x_junctions or p.threshold_units == "grey",
           "x_junctions needs threshold_units='grey' (corners and junctions share that scale); add "
           "threshold_units='grey' with a threshold in grey levels (hr: 20), or x_junctions=False")
    _check(p.threshold_units == "measure" or not p.authors_measure,
           "threshold_units='grey' needs the paper's measure (authors_measure=False); set "
           "authors_measure=False, or threshold_units='measure'")
    _check(p.threshold_rel is None or p.quantile is None,
           f"threshold_rel={p.threshold_rel!r} and quantile={p.quantile!r} are two relative thresholds "
           "(the larger would win); give one of them and set the other to None")


def _check_kept(before: Params, changes: dict, origin: str) -> None:
    """A change must not give a value kept from ``before`` another meaning without a word."""
    kept = before.threshold
    units = changes.get("threshold_units", before.threshold_units)
    if "threshold" not in changes and kept is not None and units != before.threshold_units:
        unit = ("in grey levels; give threshold= in grey levels too (hr: 20)" if units == "grey"
                else "on the measure Upsilon; give threshold= on Upsilon too (paper: 1e9)")
        raise ValueError(f"threshold_units={units!r} would read threshold={kept:g}, kept from {origin}, {unit} "
                         "or threshold=None")
    for rel in ("threshold_rel", "quantile"):
        if changes.get(rel) is not None and "threshold" not in changes and kept is not None:
            raise ValueError(f"{rel}={changes[rel]!r} would apply together with threshold={kept:g}, kept "
                             f"from {origin} (the larger of the two thresholds wins); give threshold=None to "
                             f"select by {rel} alone, or give threshold= too to keep both")
    if changes.get("threshold") is not None:
        for rel in ("threshold_rel", "quantile"):
            v = getattr(before, rel)
            if v is not None and rel not in changes:
                raise ValueError(f"threshold={changes['threshold']!r} would apply together with {rel}={v!r}, "
                                 f"kept from {origin} (the larger of the two thresholds wins); give {rel}=None "
                                 f"to select by the threshold alone, or give {rel}= too to keep both")


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

def resolve_params(preset: str | Params = "paper", **params) -> Params:
    """Start from a preset (a name or a :class:`Params`), apply overrides, and validate every value.

    The same as ``Params.preset(preset, **params)``, or ``preset.replace(**params)``
    for a ``Params``. ``subpixel`` is normalised: ``True`` -> ``"gradient"``,
    ``False`` -> ``"none"``.

    Raises
    ------
    ValueError
        One line naming the parameter, for an unknown preset, an unknown
        parameter, a value out of range, options that contradict each other,
        or a change that would silently reinterpret a kept value (see
        :meth:`Params.replace`).

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
    if isinstance(preset, Params):
        return preset.replace(**params)
    return Params.preset(preset, **params)


def max_levels(p: Params, shape: tuple[int, int]) -> int:
    """The most pyramid levels an image of ``shape`` holds (level ``l``: resized by ``1 / scale_factor ** l``).

    A level's shorter side must span one corner's measure, ``window + 2 r`` px
    (:meth:`Params.keypoint_size`), and leave pixels inside ``border``: on a narrower level every
    response reads the padding beyond its edge, and its "corners", reported at the level's scale,
    are hundreds of pixels of padding.

    Examples
    --------
    >>> max_levels(PRESETS["paper"], (512, 512))  # 512, 256, 128, 64, 32 (16 < the 17 px a corner spans)
    5
    """
    h, w = shape
    need = _level_side(p)
    n = 1
    while n < 64 and min(round(w / p.scale_factor**n), round(h / p.scale_factor**n)) >= need:
        n += 1
    return n


def _level_side(p: Params) -> int:
    return max(math.ceil(p.keypoint_size()), 2 * int(p.border) + 3)


def check_levels(p: Params, shape: tuple[int, int]) -> None:
    """Refuse ``levels`` beyond what an image of ``shape`` holds (:func:`max_levels`), in one line."""
    most = max_levels(p, shape)
    if p.levels > most:
        raise ValueError(
            f"levels={p.levels} is more than this {shape[0]} x {shape[1]} image holds: level l is "
            f"1/{p.scale_factor:g}^l of its size and needs at least {_level_side(p)} px on its shorter side "
            f"(the span of one corner's measure, or 2 border + 3); use levels <= {most}")


#: the detector's keywords in the order of :func:`sogdd.detect_corners`' signature
DETECT_FIELDS = ("sigma2", "n_orientations", "window", "window_shape", "threshold", "threshold_rel",
                 "quantile", "threshold_units", "nms_radius", "max_corners", "subpixel", "border",
                 "x_junctions", "levels", "scale_factor", "kernel_radius_rule", "zero_mean", "padding",
                 "authors_measure", "gray_weights", "gray_round", "channel_order", "value_range")
#: the keywords of the measure alone (:func:`sogdd.corner_response`)
MEASURE_FIELDS = ("sigma2", "n_orientations", "window", "window_shape", "kernel_radius_rule", "zero_mean",
                  "padding", "authors_measure", "gray_weights", "gray_round", "channel_order", "value_range")


def _cell(v) -> str:
    if isinstance(v, float):
        return repr(v) if len(repr(v)) <= 8 else f"{v:g}"
    if isinstance(v, tuple):
        return "(" + ", ".join(f"{x:.4g}" for x in v) + ")"
    return repr(v)


def preset_table(names: tuple[str, ...] = DETECT_FIELDS, indent: str = "    ") -> str:
    """The value of each parameter of ``names`` in every preset: an RST table, as the docstrings hold it.

    Examples
    --------
    >>> print(preset_table(("sigma2", "window_shape"), indent=""))
    ==============  ========  =======  ==========
    parameter       paper     authors  hr
    ==============  ========  =======  ==========
    sigma2          1.2       1.44     1.5
    window_shape    'square'  'disk'   'gaussian'
    ==============  ========  =======  ==========
    """
    rows = [["parameter", *PRESETS]] + [[n, *(_cell(getattr(p, n)) for p in PRESETS.values())] for n in names]
    widths = [max(len(r[i]) for r in rows) + (2 if i == 0 else 0) for i in range(len(rows[0]))]
    rule = "  ".join("=" * w for w in widths)

    def line(r):
        return "  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip()

    out = [rule, line(rows[0]), rule, *(line(r) for r in rows[1:]), rule]
    return "\n".join(indent + x for x in out)
