"""Learned detectors OpenCV 5 runs from an ONNX model: ``disk`` and ``aliked``.

``cv2.DISK_create`` and ``cv2.ALIKED_create`` need the network weights as an
ONNX file. OpenCV ships none and this package downloads nothing, so these
entries work only when the user passes ``model_path``; without it (or with a
file that does not exist) building the detector raises ``ValueError`` saying
so. They are listed by ``available(include_learned=True)`` only.
"""

from __future__ import annotations

import os
from typing import Any, ClassVar

import cv2
import numpy as np

from ..corners import Corners
from .registry import BaselineDetector, check_int, check_number, register, sort_strongest_first

__all__ = ["DISK", "ALIKED"]


class _OnnxDetector(BaselineDetector):
    family: ClassVar[str] = "learned"
    strength_param: ClassVar[str] = "max_corners"
    stricter_when_higher: ClassVar[bool] = False
    permissive_value: ClassVar[Any] = -1
    model_name: ClassVar[str] = ""

    def _validate(self) -> None:
        path = self.params["model_path"]
        if path is None:
            raise ValueError(
                f"{self.name} needs its ONNX model: pass model_path='.../{self.model_name}.onnx' "
                "(OpenCV ships no weights and sogdd downloads nothing)"
            )
        if not isinstance(path, (str, os.PathLike)) or not os.path.isfile(path):
            raise ValueError(f"{self.name}: model file {path!r} does not exist")
        if self.params["max_corners"] != -1:
            check_int("max_corners", self.params["max_corners"], 1)
        try:
            self._model = self._create()
        except cv2.error as exc:
            msg = " ".join(str(exc).split())
            raise ValueError(f"{self.name}: OpenCV could not load {path!r}: {msg}") from None

    def _create(self) -> Any:
        raise NotImplementedError

    def _detect(self, grey: np.ndarray, mask: np.ndarray | None) -> Corners:
        # the networks take 3-channel 8-bit images; grey is replicated
        img = cv2.cvtColor(np.clip(np.rint(grey), 0, 255).astype(np.uint8), cv2.COLOR_GRAY2BGR)
        kps = self._model.detect(img, None if mask is None else mask.astype(np.uint8) * 255)
        return sort_strongest_first(Corners.from_keypoints(kps))


@register
class DISK(_OnnxDetector):
    name: ClassVar[str] = "disk"
    model_name: ClassVar[str] = "disk"
    defaults: ClassVar[dict[str, Any]] = dict(model_path=None, max_corners=-1, score_threshold=0.0)
    strength_doc: ClassVar[str] = "(maxKeypoints, -1 = all; score_threshold is the network score cut)"
    source: ClassVar[str] = "Tyszkiewicz et al. 2020 via cv2.DISK_create; needs a user-supplied ONNX model"

    def _validate(self) -> None:
        check_number("score_threshold", self.params["score_threshold"], -1e9, 1e9)
        super()._validate()

    def _create(self) -> Any:
        p = self.params
        return cv2.DISK_create(os.fspath(p["model_path"]), int(p["max_corners"]),
                               float(p["score_threshold"]))


@register
class ALIKED(_OnnxDetector):
    name: ClassVar[str] = "aliked"
    model_name: ClassVar[str] = "aliked"
    defaults: ClassVar[dict[str, Any]] = dict(model_path=None, max_corners=-1)
    strength_doc: ClassVar[str] = "(kept for interface symmetry; ALIKED's own parameters are its defaults)"
    source: ClassVar[str] = "Zhao et al. 2023 via cv2.ALIKED_create; needs a user-supplied ONNX model"

    def _create(self) -> Any:
        return cv2.ALIKED_create(os.fspath(self.params["model_path"]))

    def _detect(self, grey: np.ndarray, mask: np.ndarray | None) -> Corners:
        out = super()._detect(grey, mask)
        k = self.params["max_corners"]
        return out if k == -1 else out.subset(np.arange(min(k, len(out))))
