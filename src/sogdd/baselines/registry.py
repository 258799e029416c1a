"""The baseline registry: one interface for every comparator of the paper.

Every detector is a :class:`BaselineDetector` subclass registered under a name.
``get(name, **params)`` builds one; ``available()`` lists the names. All of them

* take a grey or colour image (validated and converted to grey exactly as the
  core does: :func:`sogdd.image.validate.validate_image`, :func:`sogdd.image.grey.to_gray255`),
* take an optional ``uint8``/``bool`` mask of the image's shape,
* return :class:`sogdd.corners.Corners` (x = column, y = row, pixel centres at
  integers), strongest first where the detector has a strength,
* raise ``ValueError`` with a one-line message on bad input or parameters,
* expose one sweepable strength parameter (:attr:`BaselineDetector.strength_param`,
  ``threshold`` wherever the method has a threshold),
* give their ``n`` strongest points with that threshold off through one call,
  :meth:`BaselineDetector.top_n` (fixed-count evaluations), and
* say where their defaults come from in :meth:`BaselineDetector.provenance`.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from ..corners import Corners
from ..image.grey import to_gray255
from ..image.validate import check_mask, validate_image

__all__ = ["BaselineDetector", "available", "get", "register", "registered"]

_REGISTRY: dict[str, type[BaselineDetector]] = {}


class BaselineDetector:
    """Base class: parameter handling, input checks, mask, ``provenance()``.

    Subclasses set the class attributes and implement :meth:`_detect`, which
    receives the grey image (float64, 0-255) and the boolean mask (or ``None``)
    and returns ``Corners``. The mask is also applied to the result here, so a
    subclass that cannot pass it to its backend still honours it.
    """

    #: registry name
    name: ClassVar[str] = ""
    #: "corner", "blob" (scale-space interest points), "learned" or "sogdd"
    family: ClassVar[str] = "corner"
    #: default parameters; any other keyword is an error
    defaults: ClassVar[dict[str, Any]] = {}
    #: the parameter evaluations sweep
    strength_param: ClassVar[str] = "threshold"
    #: True when raising the strength parameter gives fewer points
    stricter_when_higher: ClassVar[bool] = True
    #: value of the strength parameter that keeps (nearly) every candidate
    permissive_value: ClassVar[Any] = 0.0
    #: the strength parameter's scale, for provenance()
    strength_doc: ClassVar[str] = ""
    #: whether ``Corners.response`` ranks the points; without one, :meth:`top_n` keeps the
    #: detector's first ``n`` points in its own output order (documented per detector)
    has_strength: ClassVar[bool] = True
    #: where the method and its defaults come from
    source: ClassVar[str] = ""
    #: what was reimplemented or approximated
    notes: ClassVar[str] = ""

    def __init__(self, **params: Any) -> None:
        unknown = sorted(set(params) - set(self.defaults) - {"channel_order"})
        if unknown:
            raise ValueError(
                f"{self.name}: unknown parameter(s) {', '.join(k if k.strip() else repr(k) for k in unknown)}; "
                f"accepted: {', '.join(sorted(self.defaults))}, channel_order"
            )
        self.params: dict[str, Any] = {**self.defaults, **params}
        self.channel_order: str = self.params.pop("channel_order", "rgb")
        if self.channel_order not in ("rgb", "bgr"):
            raise ValueError(f"channel_order must be 'rgb' or 'bgr', got {self.channel_order!r}")
        self._overrides = dict(params)
        self._validate()

    # -- to override ------------------------------------------------------
    @classmethod
    def ready(cls) -> bool:
        """Whether ``get(name)`` works with no arguments here (the learned entries: their extra)."""
        return True

    def _validate(self) -> None:
        """Check ``self.params``; raise ``ValueError`` (one line) on a bad value."""

    def _detect(self, grey: np.ndarray, mask: np.ndarray | None) -> Corners:
        raise NotImplementedError

    # -- public -----------------------------------------------------------
    @property
    def threshold(self) -> Any:
        """The current value of the sweepable strength parameter."""
        return self.params.get(self.strength_param)

    def with_params(self, **params: Any) -> BaselineDetector:
        """A new detector of the same kind with some parameters changed."""
        return type(self)(**{**self._overrides, "channel_order": self.channel_order, **params})

    def permissive(self) -> BaselineDetector:
        """The same detector with its strength threshold (nearly) switched off."""
        return self.with_params(**{self.strength_param: self.permissive_value})

    def top_n(self, image: Any, n: int, mask: Any = None) -> Corners:
        """The ``n`` strongest points with the strength threshold off: the fixed-count mode.

        Runs :meth:`permissive` and keeps the ``n`` largest ``response`` values
        (NaN last; among equal responses the detector's own order decides, e.g.
        raster order for FAST's integer scores). Every detector of the registry
        takes part, whatever its own parameters (AKAZE has no top-k of its own).
        Fewer than ``n`` points come back only where the permissive run has fewer.
        A detector with ``has_strength = False`` keeps its first ``n`` points in
        its own output order instead.

        Examples
        --------
        >>> from sogdd import baselines
        >>> from sogdd.synthetic import pattern_image
        >>> img, _ = pattern_image((120, 160))
        >>> len(baselines.get("akaze").top_n(img, 10))
        10
        """
        check_int("n", n, 1)
        c = self.permissive().detect_corners(image, mask)
        if self.has_strength:
            c = sort_strongest_first(c)
        return c.subset(np.arange(min(int(n), len(c))))

    def prepare(self, image: Any) -> np.ndarray:
        """Validate an image and convert it to grey float64 on the 0-255 scale."""
        return to_gray255(validate_image(image), channel_order=self.channel_order)

    def detect_corners(self, image: Any, mask: Any = None) -> Corners:
        """Detect corners (or interest points) in a grey or colour image.

        Parameters
        ----------
        image : ndarray
            Grey (H, W) or colour (H, W, 3|4) image, uint8, uint16, float in
            [0, 1] or bool (see :mod:`sogdd.image.validate`). Colour arrays are RGB unless
            the detector was built with ``channel_order="bgr"``.
        mask : ndarray of uint8 or bool, optional
            Points are kept only where it is non-zero.

        Returns
        -------
        Corners
            Strongest first where the detector reports a strength.
        """
        grey = self.prepare(image)
        m = check_mask(mask, grey.shape)
        out = self._detect(grey, m)
        return apply_mask(out, m)

    def detect(self, image: Any, mask: Any = None) -> tuple:
        """``cv2.Feature2D.detect``-style call returning ``cv2.KeyPoint`` objects."""
        return self.detect_corners(image, mask).to_keypoints()

    def provenance(self) -> str:
        """Where the method and its defaults come from, and the current parameters."""
        shown = ", ".join(f"{k}={v!r}" for k, v in self.params.items())
        lines = [f"{self.name}: {self.source}", f"parameters: {shown}"]
        direction = "fewer" if self.stricter_when_higher else "more"
        lines.append(
            f"strength parameter: {self.strength_param} (higher gives {direction} points) "
            f"{self.strength_doc}".rstrip()
        )
        if self.notes:
            lines.append(f"notes: {self.notes}")
        return "\n".join(lines)

    def __repr__(self) -> str:
        over = ", ".join(f"{k}={v!r}" for k, v in self._overrides.items())
        return f"baselines.get({self.name!r}{', ' if over else ''}{over})"


def apply_mask(corners: Corners, mask: np.ndarray | None) -> Corners:
    """Keep the points whose nearest pixel lies inside ``mask``."""
    if mask is None or len(corners) == 0:
        return corners
    h, w = mask.shape
    c = np.clip(np.rint(corners.xy[:, 0]).astype(np.int64), 0, w - 1)
    r = np.clip(np.rint(corners.xy[:, 1]).astype(np.int64), 0, h - 1)
    return corners.subset(mask[r, c])


def sort_strongest_first(corners: Corners) -> Corners:
    """Order by decreasing response (stable; NaN responses last)."""
    resp = np.nan_to_num(corners.response, nan=-np.inf)
    return corners.subset(np.argsort(-resp, kind="stable"))


# -- parameter checks shared by the detectors ------------------------------
def check_number(name: str, value: Any, lo: float = -math.inf, hi: float = math.inf, *,
                 lo_open: bool = False, allow_none: bool = False) -> None:
    """``ValueError`` unless ``value`` is a finite real number in the range."""
    if value is None and allow_none:
        return
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    ok = ok and math.isfinite(float(value)) and lo <= float(value) <= hi
    ok = ok and not (lo_open and float(value) == lo)
    if not ok:
        rng = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]"
        raise ValueError(f"{name} must be a finite number in {rng}, got {value!r}")


def check_int(name: str, value: Any, lo: int = 0, hi: int = 2**31 - 1, *,
              allow_none: bool = False) -> None:
    """``ValueError`` unless ``value`` is an integer in ``[lo, hi]``."""
    if value is None and allow_none:
        return
    ok = isinstance(value, (int, np.integer)) and not isinstance(value, bool) and lo <= value <= hi
    if not ok:
        raise ValueError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")


def check_choice(name: str, value: Any, choices: tuple) -> None:
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, choices))}, got {value!r}")


# -- the registry ------------------------------------------------------------
def register(cls: type[BaselineDetector]) -> type[BaselineDetector]:
    """Class decorator: add a detector class under its ``name``."""
    if not cls.name or cls.name in _REGISTRY:
        raise ValueError(f"bad or duplicate baseline name {cls.name!r}")
    _REGISTRY[cls.name] = cls
    return cls


def registered() -> dict[str, type[BaselineDetector]]:
    """Name -> class of every registered detector (a copy)."""
    return dict(_REGISTRY)


def available(include_learned: bool = False) -> list[str]:
    """Names of the registered detectors, in registration order, the learned ones last.

    Parameters
    ----------
    include_learned : bool
        Also list the detectors that cannot run here with no arguments: the
        learned ones (``xfeat``, ``aliked``, ``disk``) where the ``learned``
        extra is not installed (``disk`` and ``aliked`` then still run an ONNX
        file given as ``model_path``). By default every name returned works as
        ``get(name)`` with no arguments.
    """
    names = [n for n, c in _REGISTRY.items() if include_learned or c.ready()]
    # learned entries register first (module order) but belong after the classics in every table
    return sorted(names, key=lambda n: _REGISTRY[n].family == "learned")


def get(name: str, **params: Any) -> BaselineDetector:
    """Build the detector registered as ``name`` with parameter overrides.

    Raises
    ------
    ValueError
        Unknown name, unknown parameter or bad value.
    """
    cls = _REGISTRY.get(name)
    if cls is None:
        raise ValueError(
            f"unknown detector {name!r}; available: {', '.join(available(include_learned=True))}"
        )
    return cls(**params)

