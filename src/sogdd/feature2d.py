"""``SOGDD``: the detector with OpenCV's ``Feature2D`` vocabulary.

It offers ``detect``, ``compute`` and ``detectAndCompute`` with OpenCV's
signatures, types and contract, without subclassing ``cv2.Feature2D`` (OpenCV's
C++ calling back into a Python subclass crashes):

* ``detectAndCompute(image, mask)`` is ``compute(image, detect(image, mask))``:
  the same keypoints and the same descriptors;
* a keypoint's ``size`` is the diameter its descriptor covers, as for OpenCV's
  SIFT: ``desc_size * scale_factor ** level`` (:data:`~sogdd.descriptors.DESC_SIZE`,
  8 px at level 0, for every detector in the evaluations);
* ``compute`` describes each keypoint at its own size and angle (a negative
  angle, as ``detect`` leaves it, gets SIFT's orientation assignment) and drops
  the keypoints it cannot describe (outside the image, size <= 0), returning
  the ones it kept, as ``cv2.Feature2D.compute`` documents;
* ``detectAndCompute(image, mask, useProvidedKeypoints=True)`` describes the
  keypoints given by ``keypoints=`` (none: OpenCV's Python binding cannot pass
  any, and gives no keypoints and a (0, 128) array).
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from .corners import Corners
from .descriptors import DESC_SIZE, compute_keypoints
from .detector import detect_corners
from .params import Params, resolve_params

__all__ = ["SOGDD"]


class SOGDD:
    """OpenCV-style detector object; colour arrays are taken as BGR, as ``cv2.imread`` returns them.

    Parameters
    ----------
    preset : str or Params
        Starting parameter set: a preset's name (``"paper"``, ``"authors"``,
        ``"hr"``) or a :class:`~sogdd.params.Params`.
    desc_size : float or None
        Keypoint diameter at pyramid level 0 (level ``l``: times
        ``scale_factor ** l``): the region ``compute`` describes. None: the
        detector's own ``Corners.size`` (window plus filter support, 17 px for
        ``paper``).
    channel_order : {"bgr", "rgb"}
        Channel order of colour images ("bgr", as OpenCV reads them); it
        replaces the ``channel_order`` of ``preset``.
    **params
        Overrides, validated now (see :meth:`sogdd.params.Params.replace`).

    Examples
    --------
    >>> from sogdd.synthetic import pattern_image
    >>> img, _ = pattern_image((240, 320))
    >>> det = SOGDD(max_corners=10)
    >>> kps = det.detect(img)
    >>> len(kps), type(kps[0]).__name__, kps[0].size
    (10, 'KeyPoint', 8.0)
    >>> kps, desc = det.detectAndCompute(img, None)
    >>> desc.shape, desc.dtype.name
    ((10, 128), 'float32')
    >>> np.array_equal(det.compute(img, det.detect(img))[1], desc)  # OpenCV's contract
    True
    """

    def __init__(self, preset: str | Params = "paper", *, desc_size: float | None = DESC_SIZE,
                 channel_order: str = "bgr", **params) -> None:
        if desc_size is not None and not (isinstance(desc_size, (int, float, np.number))
                                          and np.isfinite(desc_size) and desc_size > 0):
            raise ValueError(f"desc_size must be a positive number or None, got {desc_size!r}")
        self.params = resolve_params(preset, channel_order=channel_order, **params)
        self.desc_size = None if desc_size is None else float(desc_size)

    def detect_corners(self, image: np.ndarray, mask: np.ndarray | None = None) -> Corners:
        """The detected corners as :class:`~sogdd.corners.Corners`."""
        return detect_corners(image, self.params, mask=mask)

    def detect(self, image: np.ndarray, mask: np.ndarray | None = None) -> tuple[cv2.KeyPoint, ...]:
        """Detect keypoints (``cv2.Feature2D.detect`` signature): angle -1, size as ``desc_size`` says."""
        c = self.detect_corners(image, mask)
        if self.desc_size is None:
            return c.to_keypoints()
        size = self.desc_size * float(self.params.scale_factor) ** c.level.astype(np.float64)
        return Corners(c.xy, c.response, size, c.level).to_keypoints()

    def compute(self, image: np.ndarray, keypoints: Sequence[cv2.KeyPoint], descriptors=None):
        """SIFT descriptors at given keypoints (``cv2.Feature2D.compute`` signature; module doc).

        Returns ``(keypoints, descriptors)``: the keypoints described, with their
        angles, and their descriptors, (N, 128) float32.
        """
        return compute_keypoints(image, keypoints, "sift", channel_order=self.params.channel_order)

    def detectAndCompute(self, image, mask=None, descriptors=None, useProvidedKeypoints=False,  # noqa: N802,N803
                         *, keypoints: Sequence[cv2.KeyPoint] | None = None):
        """``compute(image, detect(image, mask))``; ``useProvidedKeypoints``: ``compute(image, keypoints)``."""
        if useProvidedKeypoints:
            return self.compute(image, () if keypoints is None else keypoints)
        if keypoints is not None:
            raise ValueError("keypoints= are described only with useProvidedKeypoints=True")
        return self.compute(image, self.detect(image, mask))

    def getDefaultName(self) -> str:  # noqa: N802 - OpenCV's name
        return "SOGDD"

    def __repr__(self) -> str:
        return f"SOGDD({self.params!r}, desc_size={self.desc_size!r})"
