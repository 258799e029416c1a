"""Features for the downstream evaluations (matching, SfM): detect, select, describe.

:func:`extract_features` runs a spec's detector, its border removal and top-k
(:func:`sogdd.evaluation.specs.select`), and describes every point with OpenCV's
SIFT descriptor (:func:`sogdd.describe`) at the diameter given by
:func:`sogdd.descriptors.descriptor_sizes`, or, with ``desc=native``, with the
detector's own descriptor (``describe_native``: the learned entries).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..corners import Corners
from ..descriptors import describe, descriptor_sizes
from .specs import NATIVE, DetectorSpec, build_detector, check_descriptor, detect

__all__ = ["FeatureSet", "extract_features"]


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


def extract_features(image: np.ndarray, spec: DetectorSpec, detector=None) -> FeatureSet:
    """Detect with ``spec``'s detector, apply its pipeline, describe every point.

    ``desc=native`` describes the selected points with the detector's own
    ``describe_native(image, corners)`` (float32, L2-normalised); a detector
    without one is a one-line ``ValueError`` before any detection.

    Examples
    --------
    >>> from sogdd.evaluation.specs import parse_spec
    >>> from sogdd.synthetic import pattern_image
    >>> fs = extract_features(pattern_image()[0], parse_spec("sift:top_k=5"))
    >>> len(fs) <= 5, fs.descriptors.shape[1:]
    (True, (128,))
    """
    det = check_descriptor(spec, detector) if detector is not None else build_detector(spec)
    t0 = time.perf_counter()
    corners = detect(spec, image, det)
    t1 = time.perf_counter()
    sizes = descriptor_sizes(corners, spec.desc_size, getattr(det, "family", None))
    if spec.desc == NATIVE:
        # the points the network just found: the learned entries reuse their descriptors (no second pass)
        own = det.describe_native(image, corners)
        desc = np.ascontiguousarray(own, dtype=np.float32).reshape(len(corners), -1 if len(corners) else 0)
    else:
        described = Corners(corners.xy, corners.response, sizes, corners.level)
        desc = describe(image, described, spec.desc, upright=spec.upright)
    t2 = time.perf_counter()
    return FeatureSet(corners.xy.copy(), corners.response.copy(), desc, sizes,
                      corners.level.copy(), tuple(image.shape[:2]), t1 - t0, t2 - t1)
