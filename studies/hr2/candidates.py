"""The hr2 study's candidates: one registry detector, ``hr2``, with the design space as parameters.

``hr2`` is today's ``hr`` (``sogdd.detect_corners(preset="hr")``; every core
parameter is accepted as an override) plus four study options, applied after
detection in this order:

``scales=S`` (1) and ``scale_step=F`` (2.0)
    a characteristic scale per point: ``hr`` is run at sigma^2 * F^k for
    k = 0..S-1 (its integration window grown with sigma). The strength is in
    grey levels of corner contrast at every scale (scale-normalised: an ideal
    corner of contrast c has strength c at any sigma), so the scales compare
    directly; a point is kept where no stronger point of another scale lies
    within 1.5 sigma of the larger scale. Its ``size`` becomes a descriptor
    diameter, 8 px times sigma / sigma_0, and the detector reports the family
    ``blob`` so that the descriptor and the COLMAP export use it.
``relabel=false|true|order`` (false; needs ``scales`` > 1; added in stop 20)
    a characteristic scale that only relabels ``hr``'s own points: the point
    set and positions are exactly ``hr``'s (fine scale); each point's
    scale-normalised strength is read at every sigma_k (the largest value of
    the grey-level strength map within 1 px, its own strength at sigma_0).
    ``true``: ``size`` = 8 px * sigma_k / sigma_0 at the strongest scale, family
    ``blob`` (the descriptor and the COLMAP export use it), strengths kept;
    ``order``: sizes kept (family ``sogdd``), the strength becomes the
    max-over-scale strength (what a budget keeps).
``orient=sift|sogdd|centroid`` (sift; with ``desc=native`` only; added in stop 20)
    the descriptor's angle: SIFT's orientation assignment (``sift``, what
    ``desc=sift`` does), SOGDD's own principal axes with the sense from the
    intensity centroid (``sogdd``, :mod:`orientation`) or the centroid alone
    (``centroid``, ORB's rule: the control). ``desc=native`` routes the descriptor stage through
    :meth:`HR2.describe_native`; it is comparable on B2 (mutual NN for every
    row) but not on B1, where ``desc=native`` changes COLMAP's matcher to ``mnn``.
``strength=grey|contrast`` (grey)
    ``contrast``: the response divided by the local gradient energy,
    sqrt(G_8 * |grad I|^2 + (3 sigma_n)^2) with sigma_n the image noise
    (the median absolute Laplacian, Immerkaer-style): a corner's strength
    relative to its surroundings, the same for a dim and a bright photo, and
    flat noisy regions do not rise. It changes the ranking only (the points
    admitted by ``hr``'s threshold stay the same).
``budget=N`` (none) and ``select=top|anms|bucket`` (top)
    keep ``N`` points: the strongest, adaptive non-maximal suppression or
    bucketing (``point_budget.py`` beside this file).

Import this module to register ``hr2`` (``import candidates``).
"""

from __future__ import annotations

import inspect
from dataclasses import asdict
from typing import Any, ClassVar

import cv2
import numpy as np
from point_budget import anms_order, bucket_order  # beside this file: the study's folder is on sys.path

from sogdd.baselines.registry import BaselineDetector, register, registered
from sogdd.corners import Corners
from sogdd.descriptors import assign_orientations, descriptor_sizes
from sogdd.detector import corner_response, detect_corners
from sogdd.image.grey import to_uint8_grey
from sogdd.image.validate import validate_image
from sogdd.measure.units import grey_strength
from sogdd.params import PRESETS, resolve_params

__all__ = ["HR2", "contrast_strength", "merge_scales", "scale_strengths"]

STUDY = {"scales": 1, "scale_step": 2.0, "relabel": False, "orient": "sift", "strength": "grey", "budget": None,
         "select": "top"}


def _grey(image) -> np.ndarray:
    img = validate_image(image)
    if img.ndim == 3:
        img = cv2.cvtColor(img[..., :3], cv2.COLOR_RGB2GRAY)
    g = img.astype(np.float64)
    return g * 255.0 if img.dtype.kind == "f" and g.max() <= 1.0 else g


def noise_sigma(grey: np.ndarray) -> float:
    """Image noise from the median absolute response of a Laplacian-difference mask (Immerkaer 1996)."""
    k = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float64)
    r = cv2.filter2D(grey, cv2.CV_64F, k, borderType=cv2.BORDER_REFLECT)[1:-1, 1:-1]
    return float(np.sqrt(np.pi / 2) * np.mean(np.abs(r)) / 6.0)


def contrast_strength(grey: np.ndarray, c: Corners, rho: float = 8.0) -> np.ndarray:
    """``response / sqrt(G_rho * |grad I|^2 + (3 sigma_n)^2)`` at every corner."""
    gx = cv2.Sobel(grey, cv2.CV_64F, 1, 0, ksize=3) / 8.0
    gy = cv2.Sobel(grey, cv2.CV_64F, 0, 1, ksize=3) / 8.0
    e = cv2.GaussianBlur(gx * gx + gy * gy, (0, 0), rho)
    h, w = grey.shape
    xi = np.clip(np.round(c.xy[:, 0]).astype(int), 0, w - 1)
    yi = np.clip(np.round(c.xy[:, 1]).astype(int), 0, h - 1)
    den = np.sqrt(e[yi, xi] + (3.0 * noise_sigma(grey)) ** 2)
    return np.asarray(c.response, np.float64) / np.maximum(den, 1e-9)


def merge_scales(parts: list[tuple[Corners, float]]) -> tuple[Corners, np.ndarray]:
    """Across-scale suppression: ``(corners, sigma of each)``; stronger first, 1.5 sigma_max apart."""
    from scipy.spatial import cKDTree

    xy = np.concatenate([c.xy for c, _ in parts]) if parts else np.zeros((0, 2))
    resp = np.concatenate([np.asarray(c.response, np.float64) for c, _ in parts])
    sig = np.concatenate([np.full(len(c), s) for c, s in parts])
    lvl = np.concatenate([np.full(len(c), k) for k, (c, _) in enumerate(parts)])
    if len(xy) == 0:
        return Corners.empty(), np.zeros(0)
    order = np.argsort(-resp, kind="stable")
    tree = cKDTree(xy)
    alive = np.ones(len(xy), bool)
    keep = []
    rmax = 1.5 * float(sig.max())
    for i in order:
        if not alive[i]:
            continue
        keep.append(i)
        for j in tree.query_ball_point(xy[i], rmax):
            if j != i and lvl[j] != lvl[i] and np.hypot(*(xy[j] - xy[i])) <= 1.5 * max(sig[i], sig[j]):
                alive[j] = False
    keep = np.array(keep, np.int64)
    return Corners(xy[keep], resp[keep], np.zeros(len(keep)), np.zeros(len(keep), np.int64)), sig[keep]


def _window_at(window: int, f: float) -> int:
    """The integration window at sigma^2 * f: grown with sigma, odd."""
    return 2 * int(window * np.sqrt(f) / 2) + 1


def scale_strengths(image, c: Corners, core: dict, sigma2: float, window: int, scales: int,
                    step: float) -> np.ndarray:
    """(N, S) grey-level strengths of ``c``'s points at sigma^2 * step^k (k = 0..S-1).

    Column 0 is each point's own strength; column k the largest grey-level
    strength of ``hr``'s measure at sigma^2 * step^k within 1 px (3 x 3) of the point.
    """
    out = np.zeros((len(c), scales))
    out[:, 0] = np.asarray(c.response, np.float64)
    if not len(c):
        return out
    measure_keys = set(inspect.signature(corner_response).parameters) - {"image", "preset", "device"}
    kw = {k: v for k, v in core.items() if k in measure_keys}
    h, w = np.asarray(image).shape[:2]
    xi = np.clip(np.round(c.xy[:, 0]).astype(int), 0, w - 1)
    yi = np.clip(np.round(c.xy[:, 1]).astype(int), 0, h - 1)
    for k in range(1, scales):
        f = float(step) ** k
        kk = {**kw, "sigma2": sigma2 * f, "window": _window_at(window, f)}
        r = corner_response(image, preset="hr", **kk)
        # the 3 x 3 maximum: Upsilon's peak at a coarser scale may sit a pixel off the fine one
        r = cv2.dilate(r.astype(np.float32), np.ones((3, 3), np.uint8))
        out[:, k] = grey_strength(r[yi, xi].astype(np.float64), resolve_params("hr", **kk).measure_spec())
    return out


class HR2(BaselineDetector):
    """``hr`` with the study's options (module docstring)."""

    name: ClassVar[str] = "hr2"
    family: ClassVar[str] = "sogdd"
    defaults: ClassVar[dict[str, Any]] = {**asdict(PRESETS["hr"]), **STUDY}
    strength_param: ClassVar[str] = "threshold"
    permissive_value: ClassVar[Any] = None
    source: ClassVar[str] = "studies/hr2/candidates.py: hr plus the hr2 study's options"

    def __init__(self, **params: Any) -> None:
        super().__init__(**params)
        p = self.params
        if p["strength"] not in ("grey", "contrast") or p["select"] not in ("top", "anms", "bucket"):
            raise ValueError(f"hr2: bad strength/select {p['strength']!r}/{p['select']!r}")
        if p["relabel"] not in (False, True, "order"):
            raise ValueError(f"hr2: bad relabel {p['relabel']!r} (false, true or order)")
        if p["orient"] not in ("sift", "sogdd", "centroid"):
            raise ValueError(f"hr2: bad orient {p['orient']!r} (sift, sogdd or centroid)")
        self.core = {k: v for k, v in self._overrides.items() if k not in STUDY and k != "channel_order"}
        if int(p["scales"]) > 1 and p["relabel"] != "order":
            self.family = "blob"  # own sizes: the descriptor follows the characteristic scale

    def permissive(self) -> BaselineDetector:
        return self.with_params(threshold=None)

    def detect_corners(self, image: Any, mask: Any = None) -> Corners:
        p = self.params
        base = detect_corners(image, preset="hr", mask=mask, **self.core)
        s0 = float(np.sqrt(p["sigma2"]))
        if int(p["scales"]) > 1 and p["relabel"] is not False:
            st = scale_strengths(image, base, self.core, float(p["sigma2"]), int(p["window"]),
                                 int(p["scales"]), float(p["scale_step"]))
            if p["relabel"] == "order":
                c = Corners(base.xy, st.max(axis=1), base.size, base.level)
            else:
                k = np.argmax(st, axis=1)  # first maximum: ties stay at the fine scale
                c = Corners(base.xy, base.response, 8.0 * float(p["scale_step"]) ** (k / 2.0), base.level)
        elif int(p["scales"]) > 1:
            parts = [(base, s0)]
            for k in range(1, int(p["scales"])):
                f = float(p["scale_step"]) ** k
                win = 2 * int(p["window"] * np.sqrt(f) / 2) + 1  # the window grows with sigma (odd)
                ck = detect_corners(image, preset="hr", mask=mask, **{**self.core, "sigma2": p["sigma2"] * f,
                                                                      "window": win})
                parts.append((ck, s0 * np.sqrt(f)))
            c, sig = merge_scales(parts)
            c = Corners(c.xy, c.response, 8.0 * sig / s0, c.level)
        else:
            c = base
        if p["strength"] == "contrast" and len(c):
            c = Corners(c.xy, contrast_strength(_grey(image), c), c.size, c.level)
        n = p["budget"]
        if n is not None and len(c) > int(n):
            if p["select"] == "anms":
                idx = anms_order(c.xy, c.response, int(n))
            elif p["select"] == "bucket":
                idx = bucket_order(c.xy, c.response, np.asarray(image).shape[:2], int(n))
            else:
                idx = np.argsort(-np.nan_to_num(c.response, nan=-np.inf), kind="stable")[: int(n)]
            c = c.subset(np.sort(idx))
        order = np.argsort(-np.nan_to_num(np.asarray(c.response, np.float64), nan=-np.inf), kind="stable")
        return c.subset(order)

    def describe_native(self, image: Any, corners: Corners) -> np.ndarray:
        """SIFT descriptors at the ``orient`` option's angles (``desc=native``), sizes as ``desc=sift``'s."""
        from orientation import describe_at_angles, sogdd_orientations

        grey = to_uint8_grey(image, "rgb")
        sizes = descriptor_sizes(corners, "auto", self.family)
        if self.params["orient"] in ("sogdd", "centroid"):
            angles = sogdd_orientations(grey, corners.xy, sizes, float(self.params["sigma2"]),
                                        snap=self.params["orient"] == "sogdd")
        else:
            angles = assign_orientations(grey, corners.xy, sizes)
        return describe_at_angles(grey, corners.xy, sizes, angles)

    def _detect(self, grey, mask):  # pragma: no cover - detect_corners is overridden
        raise NotImplementedError


if "hr2" not in registered():
    register(HR2)
