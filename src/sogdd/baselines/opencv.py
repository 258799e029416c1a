"""Detectors that OpenCV (``opencv-contrib-python-headless`` >= 5) implements.

Each wrapper keeps OpenCV's own defaults except where noted in ``notes``; the
grey image is passed as float32 on the 0-255 scale where OpenCV accepts it
(Harris, Shi-Tomasi) and rounded to uint8 otherwise. SURF is absent: its code
is excluded from the OpenCV wheels as patented (see :mod:`.surf_like`).
"""

from __future__ import annotations

from typing import Any, ClassVar

import cv2
import numpy as np

from ..corners import Corners
from ..select.peaks import select_peaks
from .registry import BaselineDetector, check_choice, check_int, check_number, register, sort_strongest_first

__all__ = ["Harris", "ShiTomasi", "FAST", "SIFT", "KAZE", "AKAZE", "HarrisLaplace", "ORB"]


def _u8(grey: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(grey), 0, 255).astype(np.uint8)


def _mask8(mask: np.ndarray | None) -> np.ndarray | None:
    return None if mask is None else mask.astype(np.uint8) * 255


def _dedupe(c: Corners) -> Corners:
    """One point per location (SIFT and KAZE repeat a point for each orientation).

    Expects strongest first; keeps the first of each exact (x, y).
    """
    if len(c) < 2:
        return c
    _, first = np.unique(c.xy, axis=0, return_index=True)
    return c.subset(np.sort(first))


class _KeypointDetector(BaselineDetector):
    """Wrapper for a ``cv2.Feature2D`` built from ``self.params`` by :meth:`_create`."""

    dedupe: ClassVar[bool] = False

    def _create(self) -> Any:
        raise NotImplementedError

    def _validate(self) -> None:
        self._create()  # OpenCV checks its own arguments; turn its errors into ValueError

    def __init__(self, **params: Any) -> None:
        try:
            super().__init__(**params)
        except cv2.error as exc:
            msg = " ".join(str(exc).split())
            raise ValueError(f"{self.name}: OpenCV rejected the parameters: {msg}") from None

    def _detect(self, grey: np.ndarray, mask: np.ndarray | None) -> Corners:
        kps = self._create().detect(_u8(grey), _mask8(mask))
        c = sort_strongest_first(Corners.from_keypoints(kps))
        return _dedupe(c) if self.dedupe else c


@register
class Harris(BaselineDetector):
    name: ClassVar[str] = "harris"
    defaults: ClassVar[dict[str, Any]] = dict(
        block_size=3, ksize=3, k=0.04, threshold=0.01, nms_radius=1, max_corners=None
    )
    strength_doc: ClassVar[str] = "(fraction of the largest Harris response in the image/mask, in [0, 1])"
    source: ClassVar[str] = (
        "Harris & Stephens 1988 via cv2.cornerHarris; blockSize 3, Sobel aperture 3, k = 0.04 "
        "(OpenCV's tutorial values), 3x3 non-maximum suppression, threshold 0.01 x max (OpenCV tutorial)"
    )

    def _validate(self) -> None:
        p = self.params
        check_choice("block_size", p["block_size"], (2, 3, 4, 5, 6, 7))
        check_choice("ksize", p["ksize"], (1, 3, 5, 7))
        check_number("k", p["k"], 0.0, 0.25)
        check_number("threshold", p["threshold"], 0.0, 1.0)
        check_int("nms_radius", p["nms_radius"], 1, 100)
        check_int("max_corners", p["max_corners"], 1, allow_none=True)

    def _detect(self, grey: np.ndarray, mask: np.ndarray | None) -> Corners:
        p = self.params
        resp = cv2.cornerHarris(grey.astype(np.float32), p["block_size"], p["ksize"], p["k"])
        resp = resp.astype(np.float64)
        rows, cols = select_peaks(
            resp, threshold=0.0, threshold_rel=p["threshold"], nms_radius=p["nms_radius"],
            mask=mask, max_corners=p["max_corners"],
        )
        xy = np.stack([cols, rows], axis=1).astype(np.float64)
        return Corners(xy, resp[rows, cols], np.full(len(rows), float(p["block_size"] + p["ksize"])))


@register
class ShiTomasi(BaselineDetector):
    name: ClassVar[str] = "shi-tomasi"
    defaults: ClassVar[dict[str, Any]] = dict(
        threshold=0.01, max_corners=None, min_distance=1.0, block_size=3, gradient_size=3
    )
    strength_doc: ClassVar[str] = "(qualityLevel: fraction of the best min-eigenvalue, in [0, 1])"
    source: ClassVar[str] = (
        "Shi & Tomasi 1994 via cv2.goodFeaturesToTrackWithQuality; qualityLevel 0.01, minDistance 1, "
        "blockSize 3 (the defaults of cv2.GFTTDetector)"
    )
    notes: ClassVar[str] = (
        "maxCorners unlimited by default (GFTTDetector caps at 1000), so that the threshold alone "
        "decides how many points a sweep gets"
    )

    def _validate(self) -> None:
        p = self.params
        check_number("threshold", p["threshold"], 0.0, 1.0, lo_open=True)
        check_int("max_corners", p["max_corners"], 1, allow_none=True)
        check_number("min_distance", p["min_distance"], 0.0, 1000.0)
        check_choice("block_size", p["block_size"], tuple(range(2, 32)))
        check_choice("gradient_size", p["gradient_size"], (1, 3, 5, 7))

    def permissive(self) -> BaselineDetector:
        # qualityLevel must be > 0 in OpenCV
        return self.with_params(threshold=1e-12)

    def _detect(self, grey: np.ndarray, mask: np.ndarray | None) -> Corners:
        p = self.params
        pts, quality = cv2.goodFeaturesToTrackWithQuality(
            grey.astype(np.float32), p["max_corners"] or 0, float(p["threshold"]),
            float(p["min_distance"]), _mask8(mask), blockSize=p["block_size"],
            gradientSize=p["gradient_size"],
        )
        if pts is None or len(pts) == 0:
            return Corners.empty()
        xy = pts.reshape(-1, 2).astype(np.float64)
        q = np.asarray(quality, dtype=np.float64).reshape(-1)
        return sort_strongest_first(Corners(xy, q, np.full(len(xy), float(p["block_size"]))))


# Bresenham circle of radius 3 used by FAST-9 (x, y), in order around the circle
_CIRCLE16 = np.array([(0, -3), (1, -3), (2, -2), (3, -1), (3, 0), (3, 1), (2, 2), (1, 3),
                      (0, 3), (-1, 3), (-2, 2), (-3, 1), (-3, 0), (-3, -1), (-2, -2), (-1, -3)])


def fast_score(img: np.ndarray, rows: np.ndarray, cols: np.ndarray, arc: int = 9) -> np.ndarray:
    """FAST score: the largest ``t`` with ``arc`` contiguous circle pixels all ``> c + t`` or ``< c - t``.

    Equivalently the best, over arcs, of the smallest absolute difference on an
    arc whose differences all have the same sign. A pixel passes the segment test
    at threshold ``t`` exactly when its score exceeds ``t``.
    """
    c = img[rows, cols].astype(np.int32)
    h, w = img.shape
    ring = np.stack([img[np.clip(rows + dy, 0, h - 1), np.clip(cols + dx, 0, w - 1)]
                     for dx, dy in _CIRCLE16], axis=1).astype(np.int32) - c[:, None]
    ext = np.concatenate([ring, ring[:, : arc - 1]], axis=1)
    win = np.lib.stride_tricks.sliding_window_view(ext, arc, axis=1)  # (N, 16, arc)
    brighter = win.min(axis=2)
    darker = (-win).min(axis=2)
    return np.maximum(brighter, darker).max(axis=1).astype(np.float64)


@register
class FAST(BaselineDetector):
    name: ClassVar[str] = "fast"
    defaults: ClassVar[dict[str, Any]] = dict(threshold=10, nonmax=True, max_corners=None)
    permissive_value: ClassVar[Any] = 0
    strength_doc: ClassVar[str] = (
        "(grey-level difference on the 0-255 scale; the response is the FAST score, and a point "
        "passes threshold t when its score exceeds t)"
    )
    source: ClassVar[str] = (
        "Rosten & Drummond 2006/2008: OpenCV's FAST-9 (9 of 16) segment test, threshold 10, with "
        "3x3 non-maximum suppression of the FAST score (OpenCV's defaults)"
    )
    notes: ClassVar[str] = (
        "OpenCV's own FAST NMS keeps a point only if its score is strictly above its 8 neighbours', "
        "so a two-pixel plateau (common on rendered corners) loses both points and 35% of the corners "
        "of a rendered polygon image vanish; here the segment test is OpenCV's, the score is "
        "recomputed (as OpenCV's cornerScore) and NMS keeps one point per plateau"
    )

    def _validate(self) -> None:
        check_int("threshold", self.params["threshold"], 0, 255)
        check_choice("nonmax", self.params["nonmax"], (True, False))
        check_int("max_corners", self.params["max_corners"], 1, allow_none=True)

    def _detect(self, grey: np.ndarray, mask: np.ndarray | None) -> Corners:
        p = self.params
        img = _u8(grey)
        det = cv2.FastFeatureDetector_create(int(p["threshold"]), False,
                                             cv2.FAST_FEATURE_DETECTOR_TYPE_9_16)
        kps = det.detect(img, _mask8(mask))
        if not kps:
            return Corners.empty()
        xy = np.rint(np.array([k.pt for k in kps])).astype(np.int64)
        rows, cols = xy[:, 1], xy[:, 0]
        score = fast_score(img, rows, cols)
        if p["nonmax"]:
            smap = np.zeros(img.shape, dtype=np.float64)
            smap[rows, cols] = score
            rows, cols = select_peaks(smap, threshold=0.0, nms_radius=1, max_corners=p["max_corners"])
            score = smap[rows, cols]
        else:
            order = np.argsort(-score, kind="stable")[: p["max_corners"]]
            rows, cols, score = rows[order], cols[order], score[order]
        return Corners(np.stack([cols, rows], axis=1).astype(np.float64), score,
                       np.full(len(rows), 7.0))


@register
class SIFT(_KeypointDetector):
    name: ClassVar[str] = "sift"
    family: ClassVar[str] = "blob"
    dedupe: ClassVar[bool] = True
    defaults: ClassVar[dict[str, Any]] = dict(
        threshold=0.04, n_features=0, n_octave_layers=3, edge_threshold=10.0, sigma=1.6
    )
    strength_doc: ClassVar[str] = (
        "(contrastThreshold, on intensities scaled to [0, 1] and divided by nOctaveLayers)"
    )
    source: ClassVar[str] = (
        "Lowe 2004 (DoG extrema) via cv2.SIFT_create with OpenCV's defaults: contrastThreshold 0.04, "
        "edgeThreshold 10, sigma 1.6, 3 layers per octave; the detector's keypoint locations"
    )
    notes: ClassVar[str] = (
        "this is the paper's 'DoG'. Points repeated for several orientations are reported once"
    )

    def _validate(self) -> None:
        p = self.params
        check_number("threshold", p["threshold"], 0.0, 10.0)
        check_int("n_features", p["n_features"], 0)
        check_int("n_octave_layers", p["n_octave_layers"], 1, 32)
        check_number("edge_threshold", p["edge_threshold"], 0.0, 1e6)
        check_number("sigma", p["sigma"], 0.0, 100.0, lo_open=True)
        super()._validate()

    def _create(self) -> Any:
        p = self.params
        return cv2.SIFT_create(p["n_features"], p["n_octave_layers"], float(p["threshold"]),
                               float(p["edge_threshold"]), float(p["sigma"]))


_DIFFUSIVITY = {
    "pm_g1": cv2.xfeatures2d.KAZE_DIFF_PM_G1,
    "pm_g2": cv2.xfeatures2d.KAZE_DIFF_PM_G2,
    "weickert": cv2.xfeatures2d.KAZE_DIFF_WEICKERT,
    "charbonnier": cv2.xfeatures2d.KAZE_DIFF_CHARBONNIER,
}


@register
class KAZE(_KeypointDetector):
    name: ClassVar[str] = "kaze"
    family: ClassVar[str] = "blob"
    dedupe: ClassVar[bool] = True
    defaults: ClassVar[dict[str, Any]] = dict(threshold=0.001, n_octaves=4, n_octave_layers=4,
                                              diffusivity="pm_g2")
    strength_doc: ClassVar[str] = "(detector response threshold, on intensities scaled to [0, 1])"
    source: ClassVar[str] = (
        "Alcantarilla et al. 2012 via cv2.xfeatures2d.KAZE_create with OpenCV's defaults: threshold "
        "0.001, 4 octaves x 4 layers, Perona-Malik g2 diffusivity"
    )

    def _validate(self) -> None:
        p = self.params
        check_number("threshold", p["threshold"], 0.0, 1e6)
        check_int("n_octaves", p["n_octaves"], 1, 16)
        check_int("n_octave_layers", p["n_octave_layers"], 1, 16)
        check_choice("diffusivity", p["diffusivity"], tuple(_DIFFUSIVITY))
        super()._validate()

    def _create(self) -> Any:
        p = self.params
        return cv2.xfeatures2d.KAZE_create(False, False, float(p["threshold"]), p["n_octaves"],
                                           p["n_octave_layers"], _DIFFUSIVITY[p["diffusivity"]])


@register
class AKAZE(KAZE):
    """AKAZE: KAZE's parameters and checks, OpenCV's accelerated detector."""

    name: ClassVar[str] = "akaze"
    source: ClassVar[str] = (
        "Alcantarilla et al. 2013 via cv2.xfeatures2d.AKAZE_create with OpenCV's defaults: threshold "
        "0.001, 4 octaves x 4 layers, Perona-Malik g2 diffusivity"
    )

    def _create(self) -> Any:
        p = self.params
        x = cv2.xfeatures2d
        return x.AKAZE_create(x.AKAZE_DESCRIPTOR_MLDB, 0, 3, float(p["threshold"]), p["n_octaves"],
                              p["n_octave_layers"], _DIFFUSIVITY[p["diffusivity"]])


@register
class HarrisLaplace(_KeypointDetector):
    name: ClassVar[str] = "harris-laplace"
    dedupe: ClassVar[bool] = True
    defaults: ClassVar[dict[str, Any]] = dict(threshold=0.01, n_octaves=6, dog_threshold=0.01,
                                              max_corners=5000, n_layers=4)
    strength_doc: ClassVar[str] = "(corn_thresh: Harris measure threshold, intensities in [0, 1])"
    source: ClassVar[str] = (
        "Mikolajczyk & Schmid 2004 via cv2.xfeatures2d.HarrisLaplaceFeatureDetector with OpenCV's "
        "defaults: 6 octaves x 4 layers, corn_thresh 0.01, DOG_thresh 0.01, maxCorners 5000"
    )

    def _validate(self) -> None:
        p = self.params
        check_number("threshold", p["threshold"], 0.0, 1e6)
        check_number("dog_threshold", p["dog_threshold"], 0.0, 1e6)
        check_int("n_octaves", p["n_octaves"], 1, 16)
        check_int("n_layers", p["n_layers"], 1, 16)
        check_int("max_corners", p["max_corners"], 1)
        super()._validate()

    def _create(self) -> Any:
        p = self.params
        return cv2.xfeatures2d.HarrisLaplaceFeatureDetector_create(
            p["n_octaves"], float(p["threshold"]), float(p["dog_threshold"]), p["max_corners"],
            p["n_layers"],
        )


@register
class ORB(_KeypointDetector):
    name: ClassVar[str] = "orb"
    defaults: ClassVar[dict[str, Any]] = dict(max_corners=500, threshold=20, scale_factor=1.2,
                                              n_levels=8, edge_threshold=31, patch_size=31)
    strength_param: ClassVar[str] = "max_corners"
    stricter_when_higher: ClassVar[bool] = False
    permissive_value: ClassVar[Any] = 100_000
    strength_doc: ClassVar[str] = (
        "(nfeatures: ORB keeps the best N by Harris score; `threshold` is the FAST threshold on the "
        "0-255 scale)"
    )
    source: ClassVar[str] = (
        "Rublee et al. 2011 via cv2.ORB_create with OpenCV's defaults: 500 features, 8 levels x 1.2, "
        "FAST threshold 20, Harris score, edgeThreshold = patchSize = 31"
    )
    notes: ClassVar[str] = (
        "no point lies within max(edgeThreshold, ceil(patchSize/2*sqrt2)) = 31 px of the border; "
        "points from coarser levels are at level resolution"
    )

    def _validate(self) -> None:
        p = self.params
        check_int("max_corners", p["max_corners"], 1)
        check_int("threshold", p["threshold"], 0, 255)
        check_number("scale_factor", p["scale_factor"], 1.0, 4.0, lo_open=True)
        check_int("n_levels", p["n_levels"], 1, 32)
        check_int("edge_threshold", p["edge_threshold"], 0, 1000)
        check_int("patch_size", p["patch_size"], 2, 1000)
        super()._validate()

    def _create(self) -> Any:
        p = self.params
        return cv2.ORB_create(p["max_corners"], float(p["scale_factor"]), p["n_levels"],
                              p["edge_threshold"], 0, 2, cv2.ORB_HARRIS_SCORE, p["patch_size"],
                              p["threshold"])
