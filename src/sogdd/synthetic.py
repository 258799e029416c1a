"""Rendered test images with exactly known sub-pixel corners.

Polygons are filled on a grid ``supersample`` times finer than the output and
block-averaged, which approximates the area coverage of each pixel (anti-aliasing).
Coordinates follow OpenCV: ``x`` = column, ``y`` = row, pixel centres at integers,
so output pixel ``(j, i)`` covers ``[j - 0.5, j + 0.5) x [i - 0.5, i + 0.5)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["Polygon", "pattern_polygons", "regular_polygon", "render_polygons", "pattern_image"]

_SHIFT = 8  # fixed-point fraction bits for cv2.fillPoly
_BAND_ROWS = 16  # output rows rendered at a time


@dataclass(frozen=True)
class Polygon:
    """A filled polygon: vertices (N, 2) as (x, y), and its grey level (0-255)."""

    vertices: np.ndarray
    level: float = 255.0


def render_polygons(
    shape: tuple[int, int],
    polygons: list[Polygon],
    *,
    background: float = 0.0,
    supersample: int = 16,
) -> np.ndarray:
    """Render polygons (painted in order) into a float64 image on the 0-255 scale.

    The fine grid holds the index of the polygon painted last at each fine pixel
    (``uint8`` for up to 254 polygons), and is turned into grey levels and averaged
    :data:`_BAND_ROWS` output rows at a time: a 640 x 480 image at ``supersample=16``
    needs 79 MB instead of a 630 MB float64 grid, with the same values
    (``tests/test_synthetic.py``).
    """
    h, w = shape
    s = int(supersample)
    levels = np.array([float(background)] + [float(p.level) for p in polygons])
    label = np.zeros((h * s, w * s), dtype=np.uint8 if len(polygons) < 255 else np.int32)
    for k, poly in enumerate(polygons, start=1):
        v = np.asarray(poly.vertices, dtype=np.float64)
        # fine pixel centre u corresponds to coarse coordinate (u + 0.5)/s - 0.5
        fv = ((v + 0.5) * s - 0.5) * (1 << _SHIFT)
        pts = np.round(fv).astype(np.int32).reshape(-1, 1, 2)
        cv2.fillPoly(label, [pts], k, lineType=cv2.LINE_8, shift=_SHIFT)
    out = np.empty((h, w))
    for a in range(0, h, _BAND_ROWS):
        b = min(h, a + _BAND_ROWS)
        out[a:b] = levels[label[a * s : b * s]].reshape(b - a, s, w, s).mean(axis=(1, 3))
    return out


def regular_polygon(centre: tuple[float, float], radius: float, n: int, angle: float = 0.0) -> np.ndarray:
    """Vertices of a regular n-gon."""
    t = angle + 2 * np.pi * np.arange(n) / n
    return np.stack([centre[0] + radius * np.cos(t), centre[1] + radius * np.sin(t)], axis=1)


def pattern_polygons(shape: tuple[int, int] = (240, 320), *, seed: int = 0) -> list[Polygon]:
    """The polygons of :func:`pattern_image`: one per 80-px cell, 3 to 5 vertices each.

    Shapes are separated enough that every vertex is an isolated corner; their
    positions carry random sub-pixel offsets and rotations.
    """
    rng = np.random.default_rng(seed)
    h, w = shape
    polys: list[Polygon] = []
    cell = 80
    for cy in range(cell // 2, h - cell // 2 + 1, cell):
        for cx in range(cell // 2, w - cell // 2 + 1, cell):
            n = int(rng.choice([3, 4, 4, 5]))
            centre = (cx + rng.uniform(-3, 3), cy + rng.uniform(-3, 3))
            radius = rng.uniform(22, 30)
            verts = regular_polygon(centre, radius, n, rng.uniform(0, 2 * np.pi))
            # perturb vertices so angles are not all regular
            verts = verts + rng.uniform(-3, 3, size=verts.shape)
            polys.append(Polygon(verts, float(rng.choice([170.0, 200.0, 230.0]))))
    return polys


def pattern_image(
    shape: tuple[int, int] = (240, 320), *, seed: int = 0, noise: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """A built-in scene of polygons with sub-pixel vertices, and its GT corners.

    Returns ``(image_uint8, corners_xy)`` for the polygons of
    :func:`pattern_polygons` on a dark background. ``noise`` adds seeded
    Gaussian noise (0-255 scale) before rounding to uint8.

    Examples
    --------
    >>> img, gt = pattern_image((240, 320))
    >>> img.shape, img.dtype.name, gt.shape[1]
    ((240, 320), 'uint8', 2)
    """
    polys = pattern_polygons(shape, seed=seed)
    img = render_polygons(shape, polys, background=40.0)
    if noise > 0:
        img = img + np.random.default_rng([seed, 1]).normal(0, noise, size=img.shape)
    img = np.clip(np.round(img), 0, 255).astype(np.uint8)
    gt = np.concatenate([p.vertices for p in polys])
    return img, gt
