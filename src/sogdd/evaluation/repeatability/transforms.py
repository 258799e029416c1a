"""The image transforms of the paper's repeatability test (Fig. 9).

Families and parameter grids (:func:`family_grid`, exactly as the paper's text,
with its "[1, 1]" shear range read as [-1, 1]):

=============  ============================================================
rotation       18 angles in [-90, 90] degrees, step 10, without 0
scale          uniform factor 0.5 to 2.0, step 0.1, without 1.0 (15 values)
anisotropic    sx in [0.7, 1.5], sy in [0.5, 1.8], step 0.1, without
               sx == sy (117 pairs)
shear          x' = x + c*y, c in [-1, 1], step 0.1, without 0 (20 values)
jpeg           quality 5 to 100, step 5 (20 values)
noise          Gaussian, standard deviation 1 to 15 (0-255 scale), seeded
blur           beyond the paper (:mod:`.blur`): Gaussian sigma 0.5 to 5.0,
               step 0.5, then motion blur of length 3 to 15 px, step 2,
               at a seeded random angle (17 members)
=============  ============================================================

``FAMILIES`` are the paper's six, unchanged; ``ALL_FAMILIES`` adds ``blur``
as the seventh (``BEYOND_PAPER``), which tables mark as beyond the paper.

Geometric transforms act about the image centre, with bilinear resampling
(``cv2.warpAffine``, ``INTER_LINEAR``). The output canvas is the bounding box
of the transformed image, so nothing is cropped; its centre is the image of
the input's centre. Pixels outside the input are 0 and the returned ``valid``
mask marks the pixels that came from inside the input. Coordinates follow
OpenCV (pixel centres at integers), so a point ``p`` of the input lies at
``A @ [p, 1]`` in the output for the returned 2x3 matrix ``A``.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .blur import GAUSSIAN_SIGMAS, MOTION_LENGTHS, apply_blur

__all__ = ["ALL_FAMILIES", "BEYOND_PAPER", "FAMILIES", "Transform", "family_grid", "apply_transform",
           "map_points", "affine_for"]

FAMILIES = ("rotation", "scale", "anisotropic", "shear", "jpeg", "noise")
#: families this package adds to the paper's six
BEYOND_PAPER = ("blur",)
ALL_FAMILIES = FAMILIES + BEYOND_PAPER


@dataclass(frozen=True)
class Transform:
    """One member of a family: ``param`` is the family's parameter (a tuple for anisotropic)."""

    family: str
    param: float | tuple[float, float] | tuple[str, float]

    @property
    def label(self) -> str:
        if self.family == "anisotropic":
            return f"sx={self.param[0]:.1f},sy={self.param[1]:.1f}"
        if self.family == "blur":
            kind, v = self.param
            return f"gaussian sigma={v:g}" if kind == "gaussian" else f"motion L={v:g}"
        return f"{self.param:g}"

    @property
    def geometric(self) -> bool:
        return self.family in ("rotation", "scale", "anisotropic", "shear")


def _r(v: np.ndarray) -> list[float]:
    return [round(float(x), 1) for x in v]


def _full_grid(family: str) -> list:
    if family == "rotation":
        return [a for a in range(-90, 91, 10) if a != 0]
    if family == "scale":
        return [v for v in _r(np.arange(5, 21) / 10) if v != 1.0]
    if family == "anisotropic":
        sxs, sys_ = _r(np.arange(7, 16) / 10), _r(np.arange(5, 19) / 10)
        return [(sx, sy) for sx in sxs for sy in sys_ if sx != sy]
    if family == "shear":
        return [v for v in _r(np.arange(-10, 11) / 10) if v != 0.0]
    if family == "jpeg":
        return list(range(5, 101, 5))
    if family == "blur":
        return [("gaussian", s) for s in GAUSSIAN_SIGMAS] + [("motion", n) for n in MOTION_LENGTHS]
    return list(range(1, 16))  # noise


# a few members per family, for CI and smoke runs
_QUICK = {
    "rotation": [-60, -30, 30, 60, 90],
    "scale": [0.5, 0.8, 1.2, 1.5, 2.0],
    "anisotropic": [(0.7, 1.2), (1.0, 0.5), (1.2, 1.8), (1.5, 0.8)],
    "shear": [-1.0, -0.5, 0.5, 1.0],
    "jpeg": [5, 20, 50, 90],
    "noise": [2, 5, 10, 15],
    "blur": [("gaussian", 1.0), ("gaussian", 2.5), ("gaussian", 4.0),
             ("motion", 5), ("motion", 9), ("motion", 15)],
}


def family_grid(family: str, quick: bool = False) -> list[Transform]:
    """The transforms of ``family``; ``quick`` keeps a few per family for CI and smoke runs.

    Examples
    --------
    >>> len(family_grid("rotation")), len(family_grid("anisotropic")), family_grid("jpeg", quick=True)[0]
    (18, 117, Transform(family='jpeg', param=5))
    """
    if family not in ALL_FAMILIES:
        raise ValueError(f"unknown transform family {family!r}; choose from {', '.join(ALL_FAMILIES)}")
    return [Transform(family, v) for v in (_QUICK[family] if quick else _full_grid(family))]


def _linear(t: Transform) -> np.ndarray:
    if t.family == "rotation":
        a = np.deg2rad(t.param)
        # positive angle: counter-clockwise as seen on screen (y axis points down)
        return np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])
    if t.family == "scale":
        return np.diag([t.param, t.param])
    if t.family == "anisotropic":
        return np.diag([t.param[0], t.param[1]])
    if t.family == "shear":
        return np.array([[1.0, t.param], [0.0, 1.0]])
    return np.eye(2)


def affine_for(t: Transform, shape: tuple[int, int]) -> tuple[np.ndarray, tuple[int, int]]:
    """The 2x3 matrix mapping input to output coordinates, and the output shape ``(h, w)``."""
    h, w = shape[:2]
    lin = _linear(t)
    if not t.geometric:
        return np.hstack([lin, np.zeros((2, 1))]), (h, w)
    # the output canvas holds the transformed pixel footprints [-0.5, w-0.5] x [-0.5, h-0.5]
    box = np.array([[-0.5, -0.5], [w - 0.5, -0.5], [-0.5, h - 0.5], [w - 0.5, h - 0.5]])
    c_in = np.array([(w - 1) / 2, (h - 1) / 2])
    q = (box - c_in) @ lin.T
    span = q.max(axis=0) - q.min(axis=0)
    ow, oh = int(np.ceil(span[0] - 1e-6)), int(np.ceil(span[1] - 1e-6))
    c_out = np.array([(ow - 1) / 2, (oh - 1) / 2])
    return np.hstack([lin, (c_out - lin @ c_in)[:, None]]), (oh, ow)


def map_points(xy: np.ndarray, affine: np.ndarray) -> np.ndarray:
    """Apply a 2x3 affine matrix to (N, 2) points."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    return xy @ affine[:, :2].T + affine[:, 2]


def apply_transform(image: np.ndarray, t: Transform, seed: int = 0
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Transform a grey uint8 image: ``(output uint8, 2x3 affine input->output, valid mask)``."""
    img = np.asarray(image)
    if img.dtype != np.uint8:
        raise ValueError("apply_transform expects a uint8 image")
    a, (oh, ow) = affine_for(t, img.shape)
    if t.geometric:
        out = cv2.warpAffine(img, a, (ow, oh), flags=cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        ones = np.full(img.shape[:2], 255, np.uint8)
        valid = cv2.warpAffine(ones, a, (ow, oh), flags=cv2.INTER_LINEAR,
                               borderMode=cv2.BORDER_CONSTANT, borderValue=0) == 255
        return out, a, valid
    valid = np.ones(img.shape[:2], dtype=bool)
    if t.family == "jpeg":
        ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, int(t.param)])
        if not ok:  # pragma: no cover - OpenCV always encodes uint8
            raise RuntimeError("JPEG encoding failed")
        return cv2.imdecode(buf, cv2.IMREAD_UNCHANGED), a, valid
    if t.family == "noise":
        rng = np.random.default_rng([int(seed), int(round(float(t.param) * 1000))])
        noisy = img.astype(np.float64) + rng.normal(0.0, float(t.param), size=img.shape)
        return np.clip(np.round(noisy), 0, 255).astype(np.uint8), a, valid
    if t.family == "blur":
        return apply_blur(img, t.param[0], t.param[1], seed=seed), a, valid
    raise ValueError(f"unknown transform family {t.family!r}")
