"""The SOGDD detector itself in the registry: ``sogdd`` and ``sogdd-authors``.

Both wrap :func:`sogdd.detect_corners` with a preset, so an evaluation that
iterates over the registry runs exactly the package's detector. Every core
parameter (``sigma2``, ``threshold``, ``subpixel``, ...) is accepted and
validated by :func:`sogdd.resolve_params`.
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any, ClassVar

import numpy as np

from ..corners import Corners
from ..detector import detect_corners
from ..params import PRESETS, resolve_params
from .registry import BaselineDetector, register

__all__ = ["SOGDDPaper", "SOGDDAuthors", "SOGDDHR"]


class _SOGDDEntry(BaselineDetector):
    family: ClassVar[str] = "sogdd"
    preset: ClassVar[str] = "paper"

    def __init__(self, **params: Any) -> None:
        # ``preset=`` starts from another preset (the spec ``sogdd:preset=hr``)
        self.active_preset = params.pop("preset", self.preset)
        # the core validates (and owns) every parameter, channel_order included
        self.params = asdict(resolve_params(self.active_preset, **params))
        self.channel_order = self.params["channel_order"]
        self._overrides = dict(params)

    def with_params(self, **params: Any) -> BaselineDetector:
        return type(self)(**{"preset": self.active_preset, **self._overrides, **params})

    def permissive(self) -> BaselineDetector:
        return self.with_params(threshold=None, threshold_rel=None, quantile=None)

    def detect_corners(self, image: Any, mask: Any = None) -> Corners:
        return detect_corners(image, preset=self.active_preset, mask=mask, **self._overrides)

    def _detect(self, grey: np.ndarray, mask: np.ndarray | None) -> Corners:  # pragma: no cover
        raise NotImplementedError("detect_corners delegates to sogdd.detect_corners")


@register
class SOGDDPaper(_SOGDDEntry):
    name: ClassVar[str] = "sogdd"
    preset: ClassVar[str] = "paper"
    defaults: ClassVar[dict[str, Any]] = asdict(PRESETS["paper"])
    strength_param: ClassVar[str] = "threshold"
    permissive_value: ClassVar[Any] = None
    strength_doc: ClassVar[str] = "(absolute, on the measure Upsilon of eq. 25 for 0-255 intensities)"
    source: ClassVar[str] = (
        "this package, 'paper' preset: sigma^2 = 1.2, K = 8, 7x7 window, T_h = 1e9 (the paper's "
        "experimental settings; see the README's preset table)"
    )


@register
class SOGDDAuthors(_SOGDDEntry):
    name: ClassVar[str] = "sogdd-authors"
    preset: ClassVar[str] = "authors"
    defaults: ClassVar[dict[str, Any]] = asdict(PRESETS["authors"])
    strength_param: ClassVar[str] = "quantile"
    permissive_value: ClassVar[Any] = None
    strength_doc: ClassVar[str] = (
        "(the fraction of positive responses below the threshold; the authors' code keeps the top 1%)"
    )
    source: ClassVar[str] = (
        "this package, 'authors' preset: the defaults of the authors' public Python code "
        "(sigma^2 = 1.44, K = 4, 21-pixel disk window, 0.99 quantile threshold)"
    )


@register
class SOGDDHR(_SOGDDEntry):
    name: ClassVar[str] = "sogdd-hr"
    preset: ClassVar[str] = "hr"
    defaults: ClassVar[dict[str, Any]] = asdict(PRESETS["hr"])
    strength_param: ClassVar[str] = "threshold"
    permissive_value: ClassVar[Any] = None
    strength_doc: ClassVar[str] = (
        "(grey levels of corner contrast: a right-angle corner of contrast T has strength T, "
        "an X-junction of contrast T too; see sogdd.measure.units)"
    )
    source: ClassVar[str] = (
        "this package, 'hr' preset: the configuration chosen by the declared study of docs/hr.md "
        "(a declared search on dev images); X-junctions reported on their saddle point"
    )
