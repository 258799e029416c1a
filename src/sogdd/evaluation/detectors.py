"""Detector specifications, the registry, and the permissive run used for sweeps.

A *detector spec* is a registry name with optional parameter overrides,
written ``NAME`` or ``NAME:key=value:key=value`` (e.g. ``sogdd:subpixel=false``,
``sogdd:sigma2=2.0``). Values are parsed as ``true``/``false``/``none``, int,
float, or else kept as strings. The spec text is the row label in every table.

Detectors come from :mod:`sogdd.baselines` (``available()``, ``get(name,
**params)``). Where that registry is not installed, or does not accept an
override for the SOGDD presets, a small local adapter around
:func:`sogdd.detect_corners` stands in for ``sogdd`` and ``sogdd-authors``, so
the evaluations always run on the package's own detector.

Threshold sweeps without per-detector knowledge
-----------------------------------------------
:func:`permissive_detections` runs a detector once with its strength threshold
disabled (or as low as it goes) and returns every detection with its
``response``. Keeping the detections with ``response >= t`` then gives the
output at threshold ``t`` for every ``t`` at once: sorting the responses lists
every distinct operating point. This is exact for detectors that suppress
non-maxima first and threshold afterwards (SOGDD, Harris, Shi-Tomasi, FAST,
whose score is the largest threshold at which a pixel still passes the
segment test); for detectors whose threshold acts before non-maximum
suppression or before refinement (SIFT's contrast threshold, KAZE) it is a
close approximation. :func:`sweep_equivalence` measures the agreement.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..corners import Corners
from ..detector import detect_corners

__all__ = [
    "DetectorSpec",
    "parse_spec",
    "parse_specs",
    "registry_names",
    "default_gt_specs",
    "default_fast_specs",
    "build_detector",
    "permissive_detections",
    "sweep_equivalence",
]

# Stand-ins for the registry's SOGDD entries: preset names.
_LOCAL = {"sogdd": "paper", "sogdd-authors": "authors"}

# How to switch the strength threshold off, tried in order. The registry's
# objects may instead offer ``permissive()``, which is preferred.
_PERMISSIVE_KNOWN: dict[str, list[dict]] = {
    "sogdd": [{"threshold": None, "threshold_rel": None, "quantile": None}, {"threshold": 0.0}],
    "sogdd-authors": [{"threshold": None, "threshold_rel": None, "quantile": None},
                      {"threshold": 0.0}],
}
_PERMISSIVE_GENERIC: list[dict] = [
    {"threshold": 0.0, "max_corners": 1_000_000},
    {"threshold": 0.0},
    {"threshold": None},
    {"threshold": 1e-12},
]


def parse_value(text: str):
    """A detector setting from text: bool, None, int, finite float, or the text itself."""
    low = text.strip().lower()
    if low in ("true", "yes", "on"):
        return True
    if low in ("false", "no", "off"):
        return False
    if low in ("none", "null"):
        return None
    try:
        return int(low)
    except ValueError:
        pass
    try:
        v = float(low)
        if math.isfinite(v):
            return v
    except ValueError:
        pass
    return text.strip()


@dataclass(frozen=True)
class DetectorSpec:
    """A registry name plus parameter overrides; ``label`` is how tables name it."""

    name: str
    params: dict = field(default_factory=dict)
    label: str = ""

    def __post_init__(self) -> None:
        if not self.label:
            extra = "".join(f":{k}={v}" for k, v in self.params.items())
            object.__setattr__(self, "label", self.name + extra)

    def with_params(self, **params) -> DetectorSpec:
        merged = {**self.params, **params}
        return DetectorSpec(self.name, merged, "")


def parse_spec(text: str) -> DetectorSpec:
    """Parse ``NAME[:key=value...]`` (``ValueError`` on malformed text)."""
    parts = [p for p in text.strip().split(":")]
    name = parts[0].strip()
    if not name:
        raise ValueError(f"empty detector name in {text!r}")
    params = {}
    for p in parts[1:]:
        if "=" not in p:
            raise ValueError(f"detector option {p!r} in {text!r} is not key=value")
        k, v = p.split("=", 1)
        params[k.strip()] = parse_value(v)
    return DetectorSpec(name, params, text.strip())


def parse_specs(text: str | None, default: list[DetectorSpec]) -> list[DetectorSpec]:
    """Comma-separated specs; ``None``/empty gives ``default``; ``all`` gives every registry name."""
    if not text:
        return list(default)
    out = []
    for item in text.split(","):
        item = item.strip()
        if not item:
            continue
        if item == "all":
            out += [DetectorSpec(n) for n in registry_names()]
        else:
            out.append(parse_spec(item))
    known = set(registry_names())
    for s in out:
        if s.name not in known:
            raise ValueError(f"unknown detector {s.name!r}; available: {', '.join(sorted(known))}")
    return out


def _registry():
    try:
        from .. import baselines  # type: ignore[attr-defined]
    except ImportError:
        return None
    if not hasattr(baselines, "get") or not hasattr(baselines, "available"):
        return None
    return baselines


def registry_names() -> list[str]:
    """Every detector name: the registry's, and at least ``sogdd`` and ``sogdd-authors``."""
    reg = _registry()
    names = list(reg.available()) if reg is not None else []
    for n in _LOCAL:
        if n not in names:
            names.insert(list(_LOCAL).index(n), n)
    return names


def default_gt_specs() -> list[DetectorSpec]:
    """Table 1's rows: both SOGDD presets with sub-pixel on and off, then every registry detector."""
    rows = [
        DetectorSpec("sogdd"),
        DetectorSpec("sogdd", {"subpixel": False}),
        DetectorSpec("sogdd-authors"),
        DetectorSpec("sogdd-authors", {"subpixel": True}),
    ]
    rows += [DetectorSpec(n) for n in registry_names() if n not in _LOCAL]
    return rows


# OpenCV baselines fast enough for the full repeatability grid.
FAST_BASELINES = ("harris", "shi-tomasi", "fast", "orb", "akaze", "sift")


def default_fast_specs() -> list[DetectorSpec]:
    """sogdd plus the fast OpenCV baselines that the registry has."""
    names = registry_names()
    return [DetectorSpec("sogdd")] + [DetectorSpec(n) for n in FAST_BASELINES if n in names]


class LocalSOGDD:
    """Stand-in for the registry's SOGDD entries: wraps :func:`sogdd.detect_corners`."""

    def __init__(self, name: str = "sogdd", **params) -> None:
        if name not in _LOCAL:
            raise ValueError(f"no local adapter for {name!r}")
        self.name = name
        self.preset = _LOCAL[name]
        self.params = params
        # fail early on bad parameters, as the registry does
        from ..params import resolve_params

        resolve_params(self.preset, **params)

    @property
    def threshold(self):
        from ..params import resolve_params

        return resolve_params(self.preset, **self.params).threshold

    def detect_corners(self, image, mask=None) -> Corners:
        return detect_corners(image, preset=self.preset, mask=mask, **self.params)

    def describe(self) -> str:
        return f"SOGDD ({self.preset} preset) {self.params or ''}".strip()


def build_detector(spec: DetectorSpec, **extra):
    """An object with ``detect_corners(image, mask=None)`` for ``spec`` (plus ``extra`` params)."""
    params = {**spec.params, **extra}
    reg = _registry()
    if reg is not None and spec.name in reg.available():
        try:
            return reg.get(spec.name, **params)
        except (TypeError, ValueError):
            if spec.name not in _LOCAL:
                raise
    if spec.name in _LOCAL:
        return LocalSOGDD(spec.name, **params)
    raise ValueError(f"unknown detector {spec.name!r}")


def permissive_detections(spec: DetectorSpec, image) -> tuple[Corners, Corners, dict | None]:
    """Run ``spec`` at its default and with its threshold disabled.

    Returns ``(default, permissive, overrides)``. ``permissive`` holds every
    detection the detector reports with the threshold off, strongest first; it
    is checked to contain at least as many points as the default run. When no
    way to switch the threshold off works, ``permissive`` is the default output
    (the sweep then covers thresholds at or above the default only) and
    ``overrides`` is ``None``.
    """
    default = build_detector(spec).detect_corners(image)
    tries = list(_PERMISSIVE_KNOWN.get(spec.name, [])) + _PERMISSIVE_GENERIC
    det0 = build_detector(spec)
    if hasattr(det0, "permissive"):
        tries.insert(0, {"__method__": True})
    for over in tries:
        try:
            if over.get("__method__"):
                det = det0.permissive()
            else:
                det = build_detector(spec, **{k: v for k, v in over.items() if k not in spec.params})
            c = det.detect_corners(image)
        except (TypeError, ValueError):
            continue
        resp = np.asarray(c.response, dtype=np.float64)
        if len(c) >= len(default) and np.all(np.isfinite(resp)):
            order = np.argsort(-resp, kind="stable")
            return default, c.subset(order), over
    order = np.argsort(-np.nan_to_num(default.response, nan=-np.inf), kind="stable")
    return default, default.subset(order), None


def sweep_equivalence(spec: DetectorSpec, image, n_points: int = 5, tol: float = 1e-6) -> dict:
    """Compare the response-sweep with re-running the detector at explicit thresholds.

    For ``n_points`` thresholds taken from quantiles of the permissive run's
    responses, runs ``build_detector(spec, threshold=t)`` and compares its
    points with the permissive points whose response is above ``t``. Returns
    the mean Jaccard agreement of the two point sets (positions within
    ``tol`` px) and the per-threshold detail. Only meaningful where the
    detector's ``threshold`` is in the units of its ``response``.
    """
    _, perm, over = permissive_detections(spec, image)
    resp = perm.response
    out = {"detector": spec.label, "overrides": over, "checks": []}
    if len(perm) < 2:
        out["agreement"] = float("nan")
        return out
    qs = np.linspace(0.5, 0.98, n_points)
    param = getattr(build_detector(spec), "strength_param", "threshold")
    out["param"] = param
    for t in np.quantile(resp, qs):
        try:
            rerun = build_detector(spec, **{param: float(t)}).detect_corners(image)
        except (TypeError, ValueError):
            continue
        kept = perm.xy[resp > t]
        from .matching import match_points

        m = match_points(kept, rerun.xy, tol)
        union = len(kept) + len(rerun) - len(m)
        out["checks"].append({"threshold": float(t), "sweep": len(kept), "rerun": len(rerun),
                              "jaccard": len(m) / union if union else 1.0})
    vals = [c["jaccard"] for c in out["checks"]]
    out["agreement"] = float(np.mean(vals)) if vals else float("nan")
    return out
