"""Shared pieces of the downstream evaluations (matching, SfM): detector specs and features.

A *detector spec* is ``NAME`` or ``NAME:key=value:key=value`` (the syntax of
the other evaluations). Two keys belong to the feature pipeline, not to the
detector, and apply to every detector alike:

``remove_border=PX``
    drop points closer than ``PX`` full-resolution pixels to the image border
    (the paper removes 75 px for its HPatches run);
``top_k=K``
    keep the ``K`` strongest points (by ``Corners.response``).

``desc=sift|rootsift`` and ``upright=true`` choose the descriptor, and
``desc_size`` its scale (see :func:`descriptor_sizes`). Every other
key is passed to the detector (``sogdd:levels=5`` builds the paper's 5-level
pyramid). The spec text is the detector's label in every result.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np

from ..corners import Corners
from ..describe import DESC_SIZE, METHODS, describe
from .detectors import parse_value

__all__ = [
    "PAPER_PIPELINE",
    "FeatureSet",
    "FeatureSpec",
    "build_detector",
    "descriptor_sizes",
    "extract_features",
    "parse_feature_spec",
]

# The paper's HPatches pipeline for its own detector (Section "Image Matching").
PAPER_PIPELINE = {"levels": 5, "remove_border": 75}

_PIPELINE_KEYS = {"remove_border", "top_k", "desc", "upright", "desc_size"}


@dataclass(frozen=True)
class FeatureSpec:
    """A detector (registry name and parameters) and the feature pipeline around it."""

    name: str
    params: dict = field(default_factory=dict)
    remove_border: int = 0
    top_k: int | None = None
    desc: str = "sift"
    upright: bool = False
    label: str = ""
    desc_size: float | str = "auto"

    def __post_init__(self) -> None:
        if self.remove_border < 0:
            raise ValueError(f"remove_border must be >= 0, got {self.remove_border}")
        if self.top_k is not None and self.top_k < 1:
            raise ValueError(f"top_k must be a positive integer, got {self.top_k}")
        if self.desc not in METHODS:
            raise ValueError(f"desc must be one of {', '.join(METHODS)}, got {self.desc!r}")
        if not self.label:
            object.__setattr__(self, "label", self.name)
        ok = self.desc_size in ("auto", "own") or (
            isinstance(self.desc_size, (int, float)) and not isinstance(self.desc_size, bool)
            and math.isfinite(self.desc_size) and self.desc_size > 0)
        if not ok:
            raise ValueError(f"desc_size must be 'auto', 'own' or a positive number, got {self.desc_size!r}")

    def describe(self) -> dict:
        """JSON-ready summary of the spec."""
        return {
            "detector": self.name,
            "params": dict(self.params),
            "remove_border": self.remove_border,
            "top_k": self.top_k,
            "descriptor": self.desc + (" (upright)" if self.upright else ""),
            "desc_size": self.desc_size,
        }


def parse_feature_spec(text: str) -> FeatureSpec:
    """Parse ``NAME[:key=value...]`` into a :class:`FeatureSpec` (``ValueError`` if malformed)."""
    parts = text.strip().split(":")
    name = parts[0].strip()
    if not name:
        raise ValueError(f"empty detector name in {text!r}")
    det, pipe = {}, {}
    for p in parts[1:]:
        if "=" not in p:
            raise ValueError(f"detector option {p!r} in {text!r} is not key=value")
        k, v = (s.strip() for s in p.split("=", 1))
        (pipe if k in _PIPELINE_KEYS else det)[k] = parse_value(v)
    rb = pipe.get("remove_border", 0)
    tk = pipe.get("top_k")
    if not isinstance(rb, int) or isinstance(rb, bool):
        raise ValueError(f"remove_border must be an integer, got {rb!r}")
    if tk is not None and (not isinstance(tk, int) or isinstance(tk, bool)):
        raise ValueError(f"top_k must be an integer, got {tk!r}")
    return FeatureSpec(name, det, rb, tk, str(pipe.get("desc", "sift")), bool(pipe.get("upright", False)),
                       text.strip(), pipe.get("desc_size", "auto"))


class _LocalSOGDD:
    """Stand-in for the registry's ``sogdd`` entry when the registry is not importable."""

    def __init__(self, preset: str, **params: Any) -> None:
        from ..params import resolve_params

        resolve_params(preset, **params)  # fail early on bad parameters
        self.name = "sogdd" if preset == "paper" else "sogdd-authors"
        self.preset = preset
        self.params = params

    def detect_corners(self, image, mask=None) -> Corners:
        from ..detector import detect_corners

        return detect_corners(image, preset=self.preset, mask=mask, **self.params)


class _LocalSIFT:
    """Stand-in for the registry's ``sift`` entry: OpenCV's SIFT detector."""

    name = "sift"
    family = "blob"

    def __init__(self, **params: Any) -> None:
        self.sift = cv2.SIFT_create(**params)

    def detect_corners(self, image, mask=None) -> Corners:
        from ..io import to_uint8_grey

        kps = self.sift.detect(to_uint8_grey(image), None if mask is None else np.asarray(mask, np.uint8))
        c = Corners.from_keypoints(kps)
        return c.subset(np.argsort(-c.response, kind="stable"))


def build_detector(name: str, **params: Any):
    """A detector object with ``detect_corners(image, mask=None) -> Corners``.

    Uses the registry :mod:`sogdd.baselines` when it is importable, else local
    stand-ins for ``sogdd``, ``sogdd-authors`` and ``sift``.
    """
    try:
        from .. import baselines  # type: ignore[attr-defined]

        get = baselines.get
        names = list(baselines.available())
    except (ImportError, AttributeError):
        get, names = None, []
    if get is not None and name in names:
        return get(name, **params)
    if name in ("sogdd", "sogdd-authors"):
        return _LocalSOGDD("paper" if name == "sogdd" else "authors", **params)
    if name == "sift":
        return _LocalSIFT(**params)
    known = names or ["sogdd", "sogdd-authors", "sift"]
    raise ValueError(f"unknown detector {name!r}; available: {', '.join(known)}")


@dataclass
class FeatureSet:
    """Features of one image, in D2-Net's layout plus the corner metadata.

    ``keypoints`` (N, 2) x, y (pixel centres at integers); ``scores`` (N,);
    ``descriptors`` (N, D) float32; ``size`` and ``level`` as in ``Corners``.
    """

    keypoints: np.ndarray
    scores: np.ndarray
    descriptors: np.ndarray
    size: np.ndarray
    level: np.ndarray
    image_shape: tuple[int, int]
    seconds_detect: float = 0.0
    seconds_describe: float = 0.0

    def __len__(self) -> int:
        return len(self.keypoints)

    def save_npz(self, path) -> None:
        """Write D2-Net's ``.npz`` layout (``keypoints``, ``scores``, ``descriptors``) to ``path``.

        The file is written to ``path`` exactly (no ``.npz`` suffix added), as
        D2-Net names its files ``<image>.<method>``.
        """
        with open(path, "wb") as fh:
            np.savez(fh, keypoints=self.keypoints.astype(np.float32), scores=self.scores.astype(np.float32),
                     descriptors=self.descriptors.astype(np.float32), size=self.size.astype(np.float32),
                     level=self.level.astype(np.int32))

    @staticmethod
    def load_npz(path) -> FeatureSet:
        """Read a file written by :meth:`save_npz` (or by D2-Net)."""
        with np.load(path) as z:
            kp = np.asarray(z["keypoints"], dtype=np.float64)[:, :2]
            n = len(kp)
            scores = np.asarray(z["scores"]) if "scores" in z else np.zeros(n)
            size = np.asarray(z["size"]) if "size" in z else np.full(n, np.nan)
            level = np.asarray(z["level"]) if "level" in z else np.zeros(n, np.int64)
            return FeatureSet(kp, scores, np.asarray(z["descriptors"], np.float32), size, level, (0, 0))


def select(corners: Corners, shape: tuple[int, int], remove_border: int, top_k: int | None) -> Corners:
    """Apply the pipeline's border removal and top-k to detections."""
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


def descriptor_sizes(
    corners: Corners, desc_size: float | str = "auto", family: str | None = None
) -> np.ndarray:
    """Descriptor diameters (SIFT keypoint sizes) for detected points.

    The detectors' own ``size`` values mean different things (SOGDD: window
    plus filter support, 17 px; Harris 6; Shi-Tomasi 3; ORB 31), so they are not
    used as they are: a point's size is a common base diameter times its
    pyramid scale, ``desc_size * size / size_of_level_0`` (for SOGDD's pyramid
    this is ``desc_size * scale_factor ** level``). Detectors that estimate a
    scale themselves (``family == "blob"``: SIFT, KAZE, AKAZE, Harris-Laplace,
    ORB) keep their own sizes under ``"auto"``; that scale is part of what they
    detect. ``"own"`` keeps every detector's sizes.
    """
    size = corners.size.astype(np.float64)
    if len(corners) == 0 or desc_size == "own" or (desc_size == "auto" and family == "blob"):
        return size
    base = DESC_SIZE if desc_size == "auto" else float(desc_size)
    lvl0 = size[corners.level == 0]
    ref = float(lvl0.min()) if len(lvl0) else float(size.min())
    return base * size / max(ref, 1e-9)


def extract_features(image: np.ndarray, spec: FeatureSpec, detector=None) -> FeatureSet:
    """Detect with ``spec``'s detector, apply its pipeline, describe every point."""
    det = detector if detector is not None else build_detector(spec.name, **spec.params)
    t0 = time.perf_counter()
    corners = det.detect_corners(image)
    corners = select(corners, image.shape[:2], spec.remove_border, spec.top_k)
    t1 = time.perf_counter()
    sizes = descriptor_sizes(corners, spec.desc_size, getattr(det, "family", None))
    described = Corners(corners.xy, corners.response, sizes, corners.level)
    desc = describe(image, described, spec.desc, upright=spec.upright)
    t2 = time.perf_counter()
    return FeatureSet(corners.xy.copy(), corners.response.copy(), desc, sizes,
                      corners.level.copy(), tuple(image.shape[:2]), t1 - t0, t2 - t1)
