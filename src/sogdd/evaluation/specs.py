"""Detector specs: one type and one parser for every evaluation, detectors from the registry.

A *detector spec* is a registry name with optional settings, written ``NAME`` or
``NAME:key=value:key=value`` (``sogdd:subpixel=false``, ``sogdd:levels=5:top_k=2000``).
Values are parsed as ``true``/``false``/``none``, int, finite float, or else kept
as text, except that a value a text-valued SOGDD parameter documents
(:data:`sogdd.params.CHOICES`: ``subpixel=none``, ``window_shape=gaussian``) is
kept as that text. The spec text is the row label in every table.

Five keys belong to the feature pipeline around the detector and apply to every
detector alike; every other key is passed to the detector:

``remove_border=PX``
    drop points closer than ``PX`` pixels to the image border (the paper removes
    75 px for its HPatches run);
``top_k=K``
    keep the ``K`` strongest points (by ``Corners.response``);
``desc=sift|rootsift|native``, ``upright=true``, ``desc_size=auto|own|PX``
    the descriptor of the matching and SfM evaluations
    (:func:`sogdd.descriptors.descriptor_sizes`); ``native`` is the detector's
    own descriptor (``describe_native``: the learned entries ``xfeat``,
    ``aliked``, ``disk``), where ``upright`` and ``desc_size`` do not apply.

Detectors are built only by :func:`sogdd.baselines.get`.

Threshold sweeps without per-detector knowledge
-----------------------------------------------
:func:`permissive_detections` runs a detector once with its strength threshold
off (the registry's ``permissive()``) and returns every detection with its
``response``. Keeping the detections with ``response >= t`` then gives the
output at threshold ``t`` for every ``t`` at once. This is exact for detectors
that suppress non-maxima first and threshold afterwards (SOGDD, Harris,
Shi-Tomasi, FAST, whose score is the largest threshold at which a pixel still
passes the segment test); for detectors whose threshold acts before
non-maximum suppression or refinement (SIFT's contrast threshold, KAZE) it is a
close approximation.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .. import baselines
from ..baselines import learned_extra
from ..corners import Corners
from ..descriptors import METHODS
from ..params import CHOICES

__all__ = [
    "DEFAULT_MATCHING",
    "DEFAULT_SFM",
    "DESCRIPTORS",
    "FAST_BASELINES",
    "LEARNED",
    "LEARNED_DOWNSTREAM",
    "NATIVE",
    "PIPELINE_KEYS",
    "DetectorSpec",
    "build_detector",
    "check_descriptor",
    "default_fast_specs",
    "default_gt_specs",
    "default_matching",
    "default_sfm",
    "detect",
    "parse_spec",
    "parse_specs",
    "parse_value",
    "permissive_detections",
    "registry_names",
    "select",
]

PIPELINE_KEYS = ("remove_border", "top_k", "desc", "upright", "desc_size")

# OpenCV baselines fast enough for the full repeatability grid.
FAST_BASELINES = ("harris", "shi-tomasi", "fast", "orb", "akaze", "sift")

#: Matching defaults: SOGDD plain and with the paper's pipeline, and the fast baselines.
DEFAULT_MATCHING = (
    "sogdd",
    "sogdd:levels=5:remove_border=75",
    "sogdd:levels=5:remove_border=75:top_k=2000",
    "sift", "harris", "shi-tomasi", "fast", "orb", "akaze",
)
#: SfM defaults. The paper preset's threshold (1e9) leaves ~200 corners on a 6 MP
#: photo, too few for SfM, so SOGDD runs with the threshold off and its strongest 8000.
DEFAULT_SFM = ("sogdd:threshold=none:top_k=8000", "sift")

#: the ``desc`` value of a detector's own descriptor (``describe_native``)
NATIVE = "native"
#: every ``desc`` a spec accepts
DESCRIPTORS = (*METHODS, NATIVE)
#: the learned registry entries (the ``learned`` extra), in the order of every default list
LEARNED = ("xfeat", "aliked", "disk")
#: their rows in the matching and SfM defaults: the common SIFT descriptor, then each one's own
LEARNED_DOWNSTREAM = tuple(row for n in LEARNED for row in (n, f"{n}:desc={NATIVE}"))


def parse_value(text: str):
    """A setting from text: bool, None, int, finite float, or the text itself.

    Examples
    --------
    >>> [parse_value(t) for t in ("off", "none", "5", "1e9", "rootsift")]
    [False, None, 5, 1000000000.0, 'rootsift']
    """
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


def _spec_value(key: str, text: str):
    """``text`` as the value of ``key``: the text itself where it is one of the key's documented
    values (``subpixel=none`` stays ``"none"``, not ``None``), else :func:`parse_value`.

    Examples
    --------
    >>> _spec_value("subpixel", "none"), _spec_value("threshold", "none"), _spec_value("subpixel", "off")
    ('none', None, False)
    """
    low = text.strip().lower()
    return low if low in CHOICES.get(key, ()) else parse_value(text)


def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


@dataclass(frozen=True)
class DetectorSpec:
    """A registry name, its parameter overrides and the feature pipeline around it.

    ``label`` is how tables name it (by default the name and every setting).

    Examples
    --------
    >>> s = DetectorSpec("sogdd", {"sigma2": 2.0}, top_k=100)
    >>> s.label, s.detector_params, s.top_k
    ('sogdd:sigma2=2.0:top_k=100', {'sigma2': 2.0}, 100)
    """

    name: str
    params: dict = field(default_factory=dict)
    label: str = ""
    remove_border: int = 0
    top_k: int | None = None
    desc: str = "sift"
    upright: bool = False
    desc_size: float | str = "auto"

    def __post_init__(self) -> None:
        if not self.name:
            raise ValueError("empty detector name")
        if not _is_int(self.remove_border) or self.remove_border < 0:
            raise ValueError(f"remove_border must be an integer >= 0, got {self.remove_border!r}")
        if self.top_k is not None and (not _is_int(self.top_k) or self.top_k < 1):
            raise ValueError(f"top_k must be a positive integer, got {self.top_k!r}")
        if self.desc not in DESCRIPTORS:
            raise ValueError(f"desc must be one of {', '.join(DESCRIPTORS)}, got {self.desc!r}")
        ok = self.desc_size in ("auto", "own") or (
            isinstance(self.desc_size, (int, float)) and not isinstance(self.desc_size, bool)
            and math.isfinite(self.desc_size) and self.desc_size > 0)
        if not ok:
            raise ValueError(f"desc_size must be 'auto', 'own' or a positive number, got {self.desc_size!r}")
        if not self.label:
            extra = "".join(f":{k}={v}" for k, v in {**self.params, **self.pipeline}.items())
            object.__setattr__(self, "label", self.name + extra)

    @property
    def pipeline(self) -> dict:
        """The pipeline settings that differ from their defaults."""
        default = {"remove_border": 0, "top_k": None, "desc": "sift", "upright": False, "desc_size": "auto"}
        return {k: getattr(self, k) for k in PIPELINE_KEYS if getattr(self, k) != default[k]}

    @property
    def detector_params(self) -> dict:
        """The parameters passed to the detector (a copy)."""
        return dict(self.params)

    def with_params(self, **params) -> DetectorSpec:
        """The same spec with some detector parameters changed (and a new label)."""
        return DetectorSpec(self.name, {**self.params, **params}, "", **self.pipeline)

    def to_json(self) -> dict:
        """JSON-ready summary: detector, parameters and the pipeline."""
        return {
            "detector": self.name,
            "params": dict(self.params),
            "remove_border": self.remove_border,
            "top_k": self.top_k,
            "descriptor": self.desc + (" (upright)" if self.upright else ""),
            "desc_size": self.desc_size,
        }


def parse_spec(text: str) -> DetectorSpec:
    """Parse ``NAME[:key=value...]`` (``ValueError`` on malformed text).

    A key given twice, or an option without a name (``sogdd:=3``), is an error.

    Examples
    --------
    >>> s = parse_spec("sogdd:levels=5:remove_border=75")
    >>> s.name, s.params, s.remove_border, s.label
    ('sogdd', {'levels': 5}, 75, 'sogdd:levels=5:remove_border=75')
    >>> parse_spec("sogdd:sigma2=1.2:sigma2=2")
    Traceback (most recent call last):
    ...
    ValueError: sigma2 is given twice in 'sogdd:sigma2=1.2:sigma2=2'; give it once
    """
    parts = text.strip().split(":")
    name = parts[0].strip()
    if not name:
        raise ValueError(f"empty detector name in {text!r}")
    det, pipe = {}, {}
    for p in parts[1:]:
        if "=" not in p:
            raise ValueError(f"detector option {p!r} in {text!r} is not key=value")
        k, v = (s.strip() for s in p.split("=", 1))
        if not k:
            raise ValueError(f"detector option {p!r} in {text!r} has no name (key=value)")
        if k in det or k in pipe:  # the last value would silently win
            raise ValueError(f"{k} is given twice in {text!r}; give it once")
        (pipe if k in PIPELINE_KEYS else det)[k] = _spec_value(k, v)
    if "desc" in pipe:
        pipe["desc"] = str(pipe["desc"])
    if "upright" in pipe:
        pipe["upright"] = bool(pipe["upright"])
    return DetectorSpec(name, det, text.strip(), **pipe)


def registry_names() -> list[str]:
    """Every detector name that builds without arguments (:func:`sogdd.baselines.available`)."""
    return list(baselines.available())


def build_detector(spec: DetectorSpec, **extra):
    """The registry's detector for ``spec`` (plus ``extra`` parameters): ``baselines.get``.

    A spec with ``desc=native`` whose detector has no descriptor of its own is
    a one-line ``ValueError`` here, before any work (:func:`check_descriptor`).
    """
    return check_descriptor(spec, baselines.get(spec.name, **{**spec.params, **extra}))


def check_descriptor(spec: DetectorSpec, detector):
    """``detector``, after checking that it can give ``spec``'s descriptor (``ValueError`` if not).

    ``desc=native`` needs a detector with its own descriptors: a
    ``describe_native(image, corners)`` method and, where it has one, a true
    ``native_descriptors`` (false for ``aliked``/``disk`` on an ONNX file).

    Examples
    --------
    >>> check_descriptor(parse_spec("sift"), baselines.get("sift")).name
    'sift'
    >>> try:
    ...     check_descriptor(parse_spec("sift:desc=native"), baselines.get("sift"))
    ... except ValueError as exc:
    ...     print(exc)
    sift:desc=native: sift has no descriptor of its own (desc=native needs xfeat, aliked or disk); use desc=sift
    """
    if spec.desc == NATIVE and not (callable(getattr(detector, "describe_native", None))
                                    and getattr(detector, "native_descriptors", True)):
        raise ValueError(f"{spec.label}: {spec.name} has no descriptor of its own "
                         f"(desc={NATIVE} needs {', '.join(LEARNED[:-1])} or {LEARNED[-1]}); use desc=sift")
    return detector


def _with_learned(default: Sequence[str], rows: Sequence[str]) -> list[str]:
    return [*default, *rows] if learned_extra.installed() else list(default)


def default_matching() -> list[str]:
    """``sogdd eval matching``'s detectors: :data:`DEFAULT_MATCHING`, then, where the ``learned``
    extra is installed, :data:`LEARNED_DOWNSTREAM` (each learned entry with SIFT and its own descriptor).

    Examples
    --------
    >>> default_matching()[: len(DEFAULT_MATCHING)] == list(DEFAULT_MATCHING)
    True
    >>> ("xfeat:desc=native" in default_matching()) == learned_extra.installed()
    True
    """
    return _with_learned(DEFAULT_MATCHING, LEARNED_DOWNSTREAM)


def default_sfm() -> list[str]:
    """``sogdd eval sfm``'s detectors: :data:`DEFAULT_SFM`, then the learned rows as in
    :func:`default_matching` where the extra is installed.

    Examples
    --------
    >>> default_sfm()[: len(DEFAULT_SFM)] == list(DEFAULT_SFM)
    True
    """
    return _with_learned(DEFAULT_SFM, LEARNED_DOWNSTREAM)


def parse_specs(items: str | Sequence[str] | None, default: Sequence[DetectorSpec | str]) -> list[DetectorSpec]:
    """Specs from command-line items, each comma-separated; ``all`` adds every registry name.

    ``None`` gives ``default``; items that name no detector (``""``, ``",,"``)
    are an error, not the default. Every spec is built once, so an unknown
    name or a bad parameter fails here, before any work.
    """
    if isinstance(items, str):
        items = [items]
    texts = [t.strip() for item in items or [] for t in item.split(",") if t.strip()]
    if items is not None and not texts:
        raise ValueError(f"--detectors {' '.join(items)!r} names no detector; give NAME[:key=value...] "
                         "(comma-separated) or 'all'")
    if not texts:
        texts = list(default)
    specs: list[DetectorSpec] = []
    for t in texts:
        if t == "all":
            specs += [DetectorSpec(n) for n in registry_names()]
        else:
            specs.append(t if isinstance(t, DetectorSpec) else parse_spec(t))
    for s in specs:
        build_detector(s)
    return specs


def default_gt_specs() -> list[DetectorSpec]:
    """Table 1's rows: both SOGDD presets with sub-pixel on and off, then every registry detector."""
    rows = [
        DetectorSpec("sogdd"),
        DetectorSpec("sogdd", {"subpixel": False}),
        DetectorSpec("sogdd-authors"),
        DetectorSpec("sogdd-authors", {"subpixel": True}),
    ]
    return rows + [DetectorSpec(n) for n in registry_names() if n not in ("sogdd", "sogdd-authors")]


def default_fast_specs() -> list[DetectorSpec]:
    """sogdd plus the fast OpenCV baselines, then the learned entries where the extra is installed."""
    names = registry_names()
    return [DetectorSpec("sogdd")] + [DetectorSpec(n) for n in (*FAST_BASELINES, *LEARNED) if n in names]


def select(corners: Corners, shape: tuple[int, int], remove_border: int = 0, top_k: int | None = None
           ) -> Corners:
    """The pipeline's border removal and top-k, in that order (the input order is kept).

    Examples
    --------
    >>> c = Corners(np.array([[5.0, 50], [50, 50], [90, 50]]), np.array([3.0, 1.0, 2.0]))
    >>> select(c, (100, 100), remove_border=10).xy.tolist()
    [[50.0, 50.0]]
    >>> select(c, (100, 100), top_k=2).response.tolist()
    [3.0, 2.0]
    """
    h, w = shape
    c = corners
    if remove_border > 0 and len(c):
        b = float(remove_border)
        keep = (c.xy[:, 0] >= b) & (c.xy[:, 0] <= w - 1 - b) & (c.xy[:, 1] >= b) & (c.xy[:, 1] <= h - 1 - b)
        c = c.subset(keep)
    if top_k is not None and len(c) > top_k:
        resp = np.nan_to_num(c.response, nan=-np.inf)
        c = c.subset(np.sort(np.argsort(-resp, kind="stable")[:top_k]))
    return c


def detect(spec: DetectorSpec, image: np.ndarray, detector=None) -> Corners:
    """Detect with ``spec`` (its detector, or ``detector``) and apply its border removal and top-k."""
    det = detector if detector is not None else build_detector(spec)
    return select(det.detect_corners(image), image.shape[:2], spec.remove_border, spec.top_k)


def permissive_detections(spec: DetectorSpec, image) -> tuple[Corners, Corners, dict | None]:
    """Run ``spec`` at its default and with its threshold off (the registry's ``permissive()``).

    Returns ``(default, permissive, overrides)``. ``permissive`` holds every
    detection with the threshold off, strongest first; it is checked to hold at
    least as many points as the default run, with finite responses, and
    ``overrides`` are the parameters ``permissive()`` changed. Where that check
    fails, ``permissive`` is the default output sorted (the sweep then covers
    thresholds at or above the default only) and ``overrides`` is ``None``.
    """
    det = build_detector(spec)
    default = detect(spec, image, det)
    loose = det.permissive()
    c = detect(spec, image, loose)
    resp = np.asarray(c.response, dtype=np.float64)
    if len(c) >= len(default) and np.all(np.isfinite(resp)):
        over = {k: v for k, v in loose.params.items() if k not in det.params or det.params[k] != v}
        return default, c.subset(np.argsort(-resp, kind="stable")), over
    order = np.argsort(-np.nan_to_num(default.response, nan=-np.inf), kind="stable")
    return default, default.subset(order), None
