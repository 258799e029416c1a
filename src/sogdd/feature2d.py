"""``SOGDD``: the detector with OpenCV's ``Feature2D`` vocabulary.

It offers ``detect``, ``compute`` and ``detectAndCompute`` with OpenCV's
signatures and types, without subclassing ``cv2.Feature2D`` (OpenCV's C++ calling
back into a Python subclass crashes).
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from .corners import Corners
from .descriptors import DESC_SIZE, compute_keypoints
from .detector import detect_corners
from .params import resolve_params

__all__ = ["SOGDD"]


class SOGDD:
    """OpenCV-style detector object; colour arrays are taken as BGR, as ``cv2.imread`` returns them.

    Parameters
    ----------
    preset : str
        Starting parameter set (``"paper"``, ``"authors"``, ...).
    **params
        Overrides, validated now (see :func:`sogdd.params.resolve_params`).

    Examples
    --------
    >>> from sogdd.synthetic import pattern_image
    >>> img, _ = pattern_image((240, 320))
    >>> det = SOGDD(max_corners=10)
    >>> kps = det.detect(img)
    >>> len(kps), type(kps[0]).__name__
    (10, 'KeyPoint')
    >>> kps, desc = det.detectAndCompute(img, None)
    >>> desc.shape, desc.dtype.name
    ((10, 128), 'float32')
    """

    def __init__(self, preset: str = "paper", **params) -> None:
        params.setdefault("channel_order", "bgr")
        self.preset = preset
        self.params = resolve_params(preset, **params)
        self._overrides = params

    def detect_corners(self, image: np.ndarray, mask: np.ndarray | None = None) -> Corners:
        """The detected corners as :class:`~sogdd.corners.Corners`."""
        return detect_corners(image, preset=self.preset, mask=mask, **self._overrides)

    def detect(self, image: np.ndarray, mask: np.ndarray | None = None) -> tuple[cv2.KeyPoint, ...]:
        """Detect keypoints (``cv2.Feature2D.detect`` signature)."""
        return self.detect_corners(image, mask).to_keypoints()

    def compute(self, image: np.ndarray, keypoints: Sequence[cv2.KeyPoint], descriptors=None):
        """SIFT descriptors at given keypoints (``cv2.Feature2D.compute`` signature).

        Returns ``(keypoints, descriptors)``: keypoints with SIFT-style orientations,
        descriptors (N, 128) float32 (an empty (0, 128) array where OpenCV gives None).
        """
        return compute_keypoints(image, keypoints, "sift", channel_order=self.params.channel_order)

    def detectAndCompute(self, image, mask=None, descriptors=None, useProvidedKeypoints=False):  # noqa: N802,N803
        """Detect, then describe with SIFT at :data:`~sogdd.descriptors.DESC_SIZE` (``detectAndCompute``)."""
        kps = self.detect(image, mask)
        return compute_keypoints(image, kps, "sift", channel_order=self.params.channel_order,
                                 size=DESC_SIZE, scale_factor=self.params.scale_factor)

    def getDefaultName(self) -> str:  # noqa: N802 - OpenCV's name
        return "SOGDD"

    def __repr__(self) -> str:
        return f"SOGDD(preset={self.preset!r}, {self._overrides})"
