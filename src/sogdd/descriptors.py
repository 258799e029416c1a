"""Descriptors at detected points: OpenCV's SIFT descriptor (and RootSIFT).

The paper describes its corners with SOSNet, a learned descriptor whose weights
cannot be downloaded here. For the downstream evaluations (HPatches MMA, COLMAP)
we use one hand-crafted descriptor for *every* detector instead, so that any
difference measured is a difference in detection, not in description.

Each point gets a SIFT-style scale and orientation before it is described:

* **scale** -- the keypoint diameter ``size`` (``Corners.size``, which the SOGDD
  detector multiplies by the pyramid factor of the level the corner was found
  on), or a fixed diameter scaled by ``scale_factor ** level``. The SIFT
  scale is ``sigma = size / 2``; it selects the octave and layer of OpenCV's
  Gaussian scale space (``sigma = 1.6 * 2 ** (octave + layer / 3)``) the way
  SIFT's own keypoints do, so the descriptor is computed on an image blurred to
  the keypoint's scale.
* **orientation** -- Lowe's gradient-histogram assignment as OpenCV implements
  it: 36 bins, Gaussian weight ``1.5 sigma`` over a radius of ``4.5 sigma`` on
  the blurred image of the keypoint's layer, histogram smoothed with
  (1, 4, 6, 4, 1) / 16, parabolic interpolation of the highest peak. One
  orientation per point (the dominant one), so descriptors stay aligned with
  the corners. ``upright=True`` skips this (angle 0).

Angles follow ``cv2.KeyPoint``: degrees in [0, 360), measured in image
coordinates (y down), as OpenCV's SIFT writes them.

**Which points have a descriptor** (:func:`describable`): those inside the
image, ``-0.5 <= x <= W - 0.5`` and ``-0.5 <= y <= H - 0.5`` (the pixels'
extent, centres at integers), with a positive finite size. A point inside it
is described from the pixels around it that exist (as OpenCV's SIFT does, near
the border too). A point outside it is not a point of that image: OpenCV's SIFT
gives it a row of zeros, which matches anything. :func:`describe` refuses such
points (one line, with the count); :func:`compute_keypoints` drops them and
returns the keypoints it kept, as ``cv2.Feature2D.compute`` documents.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from .corners import Corners
from .image.grey import to_uint8_grey

__all__ = [
    "DESC_SIZE",
    "METHODS",
    "assign_orientations",
    "compute_keypoints",
    "describable",
    "describe",
    "descriptor_sizes",
    "keypoint_octaves",
    "rootsift",
]

METHODS = ("sift", "rootsift")

#: Descriptor diameter (px, at pyramid level 0) for corners, which carry no scale
#: estimate of their own. Chosen once on the local HPatches and Oxford sequences
#: for sogdd (4, 6, 8, 12 px tried; 8 best at 5-10 px); the same for every corner
#: detector in the evaluations.
DESC_SIZE = 8.0

# OpenCV SIFT constants (modules/features2d/src/sift.simd.hpp)
_SIGMA = 1.6
_N_LAYERS = 3
_INIT_SIGMA = 0.5
_ORI_BINS = 36
_ORI_SIG = 1.5
_ORI_RADIUS = 3 * _ORI_SIG


def keypoint_octaves(size: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """SIFT octave and layer of keypoints of diameter ``size`` (full-resolution px).

    SIFT's keypoint sizes are ``2 * 1.6 * 2 ** (octave + layer / 3)``; this is
    the inverse, rounded to the nearest layer. Octave -1 (OpenCV's upsampled
    first octave) is the smallest allowed, layers run 0..3.
    """
    sigma = np.maximum(np.asarray(size, dtype=np.float64) / 2.0, 1e-6)
    t = np.round(np.log2(sigma / _SIGMA) * _N_LAYERS).astype(np.int64)
    t = np.maximum(t, -_N_LAYERS)
    octave = np.floor_divide(t, _N_LAYERS)
    layer = t - octave * _N_LAYERS
    return octave, layer


def _orientation_hist_peak(hist: np.ndarray) -> np.ndarray:
    """Smoothed-histogram peak, parabolically interpolated: OpenCV's angle in degrees."""
    n = hist.shape[1]
    t = hist
    smooth = (
        (np.roll(t, 2, 1) + np.roll(t, -2, 1)) * (1.0 / 16)
        + (np.roll(t, 1, 1) + np.roll(t, -1, 1)) * (4.0 / 16)
        + t * (6.0 / 16)
    )
    j = np.argmax(smooth, axis=1)
    rows = np.arange(len(j))
    c = smooth[rows, j]
    left = smooth[rows, (j - 1) % n]
    right = smooth[rows, (j + 1) % n]
    denom = left - 2 * c + right
    with np.errstate(divide="ignore", invalid="ignore"):
        off = np.where(np.abs(denom) > 1e-12, 0.5 * (left - right) / denom, 0.0)
    b = (j + off) % n
    angle = 360.0 - b * (360.0 / n)
    angle = np.where(np.abs(angle - 360.0) < 1.2e-7 * 360, 0.0, angle)
    # a flat histogram (no gradient at all) has no orientation: use 0
    return np.where(c > 0, angle % 360.0, 0.0)


def _level_image(base: np.ndarray, octave: int, layer: int) -> np.ndarray:
    """The Gaussian scale-space image of (octave, layer), from a float32 grey image."""
    if octave < 0:
        img = cv2.resize(base, None, fx=2.0, fy=2.0, interpolation=cv2.INTER_LINEAR)
        have = 2 * _INIT_SIGMA
    else:
        img = base
        have = _INIT_SIGMA
        for _ in range(octave):
            # blur before decimating so the halved image carries sigma = 0.5 again
            if min(img.shape) < 4:
                break
            img = cv2.GaussianBlur(img, (0, 0), math.sqrt(1.0 - 0.25) * 1.0)
            img = img[::2, ::2]
    want = _SIGMA * 2.0 ** (layer / _N_LAYERS)
    if want > have:
        img = cv2.GaussianBlur(img, (0, 0), math.sqrt(want * want - have * have))
    return img


def assign_orientations(
    grey: np.ndarray, xy: np.ndarray, size: np.ndarray, *, chunk: int = 2048
) -> np.ndarray:
    """Dominant gradient orientation of each keypoint (SIFT's assignment).

    Parameters
    ----------
    grey : (H, W) ndarray
        Grey image (any numeric dtype; uint8 as for SIFT).
    xy : (N, 2) ndarray
        Keypoint positions, x = column, y = row, pixel centres at integers.
    size : (N,) ndarray
        Keypoint diameters in pixels (``cv2.KeyPoint.size``).

    Returns
    -------
    (N,) float64
        Angles in degrees, ``cv2.KeyPoint.angle`` convention (what OpenCV's
        SIFT detector would assign to a keypoint at that position and size).
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    size = np.asarray(size, dtype=np.float64).reshape(-1)
    if len(size) != len(xy) or not (np.isfinite(size) & (size > 0)).all():
        raise ValueError("size must hold one positive finite diameter per point")
    out = np.zeros(len(xy))
    if len(xy) == 0:
        return out
    base = np.asarray(grey, dtype=np.float32)
    octave, layer = keypoint_octaves(size)
    for o, la in sorted(set(zip(octave.tolist(), layer.tolist()))):
        sel = np.flatnonzero((octave == o) & (layer == la))
        img = _level_image(base, o, la)
        h, w = img.shape
        scale = 2.0 ** (-o)
        scl = size[sel] * 0.5 * scale
        radius = np.round(_ORI_RADIUS * scl).astype(np.int64)
        rmax = int(radius.max())
        # gradients as OpenCV takes them: central differences, y pointing up
        pad = np.pad(img, rmax + 1, mode="constant")
        dx = pad[1:-1, 2:] - pad[1:-1, :-2]
        dy = pad[:-2, 1:-1] - pad[2:, 1:-1]
        mag = np.hypot(dx, dy)
        ang = np.rad2deg(np.arctan2(dy, dx)) % 360.0
        # the border row/column of the image has no gradient in OpenCV (skipped)
        valid = np.zeros_like(mag, dtype=bool)
        valid[rmax + 2 : rmax + h, rmax + 2 : rmax + w] = True
        offs = np.arange(-rmax, rmax + 1)
        oy, ox = np.meshgrid(offs, offs, indexing="ij")
        r2 = (ox * ox + oy * oy).ravel()
        ox = ox.ravel()
        oy = oy.ravel()
        px = np.round(xy[sel, 0] * scale).astype(np.int64)
        py = np.round(xy[sel, 1] * scale).astype(np.int64)
        for s in range(0, len(sel), chunk):
            e = slice(s, s + chunk)
            cy = np.clip(py[e], -rmax - 1, h + rmax)[:, None] + oy[None, :] + rmax
            cx = np.clip(px[e], -rmax - 1, w + rmax)[:, None] + ox[None, :] + rmax
            cy = np.clip(cy, 0, pad.shape[0] - 3)
            cx = np.clip(cx, 0, pad.shape[1] - 3)
            inside = (np.abs(oy)[None, :] <= radius[e, None]) & (np.abs(ox)[None, :] <= radius[e, None])
            sig = _ORI_SIG * scl[e]
            wgt = np.exp(-r2[None, :] / (2.0 * sig[:, None] ** 2))
            m = mag[cy, cx] * wgt * (inside & valid[cy, cx])
            b = np.round(ang[cy, cx] * (_ORI_BINS / 360.0)).astype(np.int64) % _ORI_BINS
            hist = np.zeros((m.shape[0], _ORI_BINS))
            np.add.at(hist, (np.repeat(np.arange(m.shape[0]), m.shape[1]), b.ravel()), m.ravel())
            out[sel[s : s + chunk]] = _orientation_hist_peak(hist)
    return out


def rootsift(desc: np.ndarray, eps: float = 1e-12) -> np.ndarray:
    """RootSIFT (Arandjelovic and Zisserman, CVPR 2012): L1-normalise, square root.

    The result has unit L2 norm, so Euclidean distance on it is the Hellinger
    kernel on the original SIFT histograms.
    """
    d = np.maximum(np.asarray(desc, dtype=np.float32), 0)
    d = d / (d.sum(axis=1, keepdims=True) + eps)
    return np.sqrt(d).astype(np.float32)


def _sizes(corners: Corners, size: float | None, scale_factor: float) -> np.ndarray:
    if size is None:
        return corners.size.astype(np.float64)
    for name, v in (("size", size), ("scale_factor", scale_factor)):
        if not (isinstance(v, (int, float, np.number)) and math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a positive number, got {v!r}")
    return float(size) * float(scale_factor) ** corners.level.astype(np.float64)


def describable(shape: tuple[int, ...], xy: np.ndarray, size: np.ndarray) -> np.ndarray:
    """Mask of the points that have a descriptor in an image of ``shape`` (module doc).

    Inside the pixels' extent ``[-0.5, W - 0.5] x [-0.5, H - 0.5]`` (pixel centres
    at integers), with a positive finite diameter ``size``.

    Examples
    --------
    >>> describable((100, 100), np.array([[5.0, 5.0], [99.5, 0.0], [120.0, 5.0], [5.0, 5.0]]),
    ...             np.array([8.0, 8.0, 8.0, 0.0])).tolist()
    [True, True, False, False]
    """
    h, w = shape[:2]
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    size = np.asarray(size, dtype=np.float64).reshape(-1)
    with np.errstate(invalid="ignore"):  # NaN compares False: not describable
        inside = (xy[:, 0] >= -0.5) & (xy[:, 0] <= w - 0.5) & (xy[:, 1] >= -0.5) & (xy[:, 1] <= h - 0.5)
        return inside & np.isfinite(size) & (size > 0)


def _sift_compute(grey_u8: np.ndarray, xy, size, angle) -> np.ndarray:
    octave, layer = keypoint_octaves(size)
    packed = (octave & 0xFF) | (layer << 8)
    kps = [
        cv2.KeyPoint(float(x), float(y), float(s), float(a), 0.0, int(p))
        for (x, y), s, a, p in zip(xy, size, angle, packed)
    ]
    if not kps:
        return np.zeros((0, 128), np.float32)
    sift = cv2.SIFT_create()
    kps_out, desc = sift.compute(grey_u8, kps)
    # OpenCV's SIFT never drops provided keypoints; check, as alignment matters
    if desc is None or len(kps_out) != len(kps):
        raise RuntimeError("OpenCV SIFT dropped keypoints while computing descriptors")
    return desc.astype(np.float32)


def describe(
    image,
    corners: Corners,
    method: str = "sift",
    *,
    upright: bool = False,
    size: float | None = None,
    scale_factor: float = 2.0,
    channel_order: str = "rgb",
    return_angles: bool = False,
):
    """Descriptors at detected points.

    Parameters
    ----------
    image : ndarray
        The image the corners were detected in (grey or colour; see
        :func:`sogdd.read_image`).
    corners : Corners
        Points to describe (any detector's output).
    method : {"sift", "rootsift"}
        ``"sift"``: OpenCV's 128-D SIFT descriptor (float32, OpenCV's 0-255
        scale). ``"rootsift"``: its RootSIFT transform (unit L2 norm).
    upright : bool
        Skip orientation assignment (angle 0): not rotation invariant, slightly
        more distinctive when the images are known to be upright.
    size : float, optional
        Keypoint diameter at level 0; a point of pyramid level ``l`` gets
        ``size * scale_factor ** l``. Default: each point's ``Corners.size``.
    scale_factor : float
        Pyramid factor used with ``size``.
    channel_order : {"rgb", "bgr"}
        Channel order of a colour ``image``.
    return_angles : bool
        Also return the assigned orientations (degrees, ``cv2.KeyPoint``
        convention).

    Returns
    -------
    descriptors : (N, 128) float32
        Row ``i`` describes ``corners.xy[i]``.
    angles : (N,) float64
        Only with ``return_angles=True``.

    Raises
    ------
    ValueError
        One line: a bad method, image or size, or points that have no
        descriptor in this image (outside it, or of size <= 0; see
        :func:`describable`), with their count; describe
        ``corners.subset(describable(image.shape, corners.xy, sizes))`` instead.

    Examples
    --------
    >>> from sogdd.synthetic import pattern_image
    >>> import sogdd
    >>> img, _ = pattern_image((120, 160))
    >>> c = sogdd.detect_corners(img)
    >>> describe(img, c).shape == (len(c), 128)
    True
    >>> describe(img[:60, :80], c)
    Traceback (most recent call last):
    ...
    ValueError: ... of ... points have no descriptor in this 60 x 80 image (outside it, or of size <= 0); ...
    """
    if method not in METHODS:
        raise ValueError(f"unknown descriptor method {method!r}; choose from {', '.join(METHODS)}")
    if not isinstance(corners, Corners):
        raise ValueError(f"corners must be a sogdd.Corners, got {type(corners).__name__}")
    grey = to_uint8_grey(image, channel_order)
    sizes = _sizes(corners, size, scale_factor)
    ok = describable(grey.shape, corners.xy, sizes)
    if not ok.all():
        h, w = grey.shape[:2]
        raise ValueError(
            f"{int((~ok).sum())} of {len(ok)} points have no descriptor in this {h} x {w} image (outside "
            "it, or of size <= 0); describe the others: corners.subset(sogdd.descriptors.describable("
            "image.shape, corners.xy, corners.size))")
    desc, angles = _describe(grey, corners.xy, sizes, None if not upright else np.zeros(len(corners)))
    if method == "rootsift":
        desc = rootsift(desc)
    return (desc, angles) if return_angles else desc


def _describe(grey: np.ndarray, xy: np.ndarray, sizes: np.ndarray, angles: np.ndarray | None):
    """SIFT descriptors and angles of describable points; ``angles`` None: assigned (negative ones too)."""
    todo = np.ones(len(xy), bool) if angles is None else np.asarray(angles) < 0
    angles = np.zeros(len(xy)) if angles is None else np.asarray(angles, dtype=np.float64).copy()
    if todo.any():
        angles[todo] = assign_orientations(grey, xy[todo], sizes[todo])
    return _sift_compute(grey, xy, sizes, angles), angles


def compute_keypoints(
    image, keypoints: Sequence[cv2.KeyPoint], method: str = "sift", *, channel_order: str = "bgr",
    upright: bool = False, size: float | None = None, scale_factor: float = 2.0,
) -> tuple[tuple[cv2.KeyPoint, ...], np.ndarray]:
    """``cv2.Feature2D.compute`` in OpenCV's types: ``(keypoints, descriptors)``.

    Parameters
    ----------
    image : ndarray
        Grey or colour image; colour is BGR by default, as ``cv2.imread`` returns it.
    keypoints : sequence of cv2.KeyPoint
        Points to describe, each at its own ``size`` (the descriptor's diameter,
        as OpenCV's SIFT reads it) and its own ``angle``; a negative angle
        (-1: not assigned, as detectors leave it) gets SIFT's orientation
        assignment, or 0 with ``upright=True``. Points without a descriptor in
        this image (:func:`describable`: outside it, or of size <= 0) are
        dropped, as ``cv2.Feature2D.compute`` documents.
    method : {"sift", "rootsift"}
    upright : bool
        Angle 0 for every point (no orientation assignment, given angles ignored).
    size : float, optional
        Describe at this diameter at pyramid level 0 instead, multiplied by
        ``scale_factor ** octave`` (the octave read as the pyramid level, as
        SOGDD's keypoints carry it).

    Returns
    -------
    keypoints : tuple of cv2.KeyPoint
        The points described, in input order, with their angles (and sizes,
        with ``size``) as described; the dropped ones are left out.
    descriptors : (N, 128) float32
        Row ``i`` describes ``keypoints[i]``; (0, 128) when there are none, as
        OpenCV 5's SIFT returns.
    """
    if method not in METHODS:
        raise ValueError(f"unknown descriptor method {method!r}; choose from {', '.join(METHODS)}")
    kps = tuple(keypoints)
    if not all(isinstance(k, cv2.KeyPoint) for k in kps):
        raise ValueError("keypoints must be cv2.KeyPoint objects")
    grey = to_uint8_grey(image, channel_order)
    corners = Corners.from_keypoints(kps)
    sizes = _sizes(corners, size, scale_factor)
    keep = np.flatnonzero(describable(grey.shape, corners.xy, sizes))
    kps, sizes = tuple(kps[i] for i in keep), sizes[keep]
    given = np.zeros(len(kps)) if upright else np.array([k.angle for k in kps], dtype=np.float64)
    desc, angles = _describe(grey, corners.xy[keep], sizes, given)
    if method == "rootsift":
        desc = rootsift(desc)
    out = tuple(
        cv2.KeyPoint(k.pt[0], k.pt[1], float(s), float(a), k.response, k.octave, k.class_id)
        for k, a, s in zip(kps, angles, sizes)
    )
    return out, desc


def descriptor_sizes(
    corners: Corners, desc_size: float | str = "auto", family: str | None = None
) -> np.ndarray:
    """Descriptor diameters (SIFT keypoint sizes) for detected points.

    The detectors' own ``size`` values mean different things (SOGDD: window
    plus filter support, 17 px; Harris 6; Shi-Tomasi 3; ORB 31), so they are not
    used as they are: a point's size is a common base diameter times its
    pyramid scale, ``desc_size * size / size_of_level_0`` (for SOGDD's pyramid
    this is ``desc_size * scale_factor ** level``). Detectors that estimate a
    scale themselves (``family == "blob"``: SIFT, KAZE, AKAZE, Harris-Laplace,
    ORB) keep their own sizes under ``"auto"``; that scale is part of what they
    detect. ``"own"`` keeps every detector's sizes.
    """
    size = corners.size.astype(np.float64)
    if len(corners) == 0 or desc_size == "own" or (desc_size == "auto" and family == "blob"):
        return size
    base = DESC_SIZE if desc_size == "auto" else float(desc_size)
    lvl0 = size[corners.level == 0]
    ref = float(lvl0.min()) if len(lvl0) else float(size.min())
    return base * size / max(ref, 1e-9)
