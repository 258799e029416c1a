"""Rendered END- and L-type corner pairs with exact ground truth (the resolution scenes).

The paper's central claim is that SOGDD with the right scale resolves corners
that are close together. This benchmark makes it measurable.

Configurations
--------------
In a local frame (``u`` along the shared edge, ``v`` across it), two corners
sit at ``(0, 0)`` and ``(d, 0)`` on an edge between grey levels ``T1`` (the
background) and ``T2``:

* **END-type** (eq. 3): the ``T2`` region is a bar whose end is the segment
  between the corners; its sides leave the corners at angles ``alpha`` and
  ``beta`` from the perpendicular, on the same side of the edge. Both corners
  turn the same way (interior angles ``pi/2 + alpha`` and ``pi/2 + beta``).
* **L-type** (eq. 11 for the corner at ``u = 0``): the side at ``u = d`` leaves
  on the *other* side of the edge, so the boundary is a step and the corners
  turn opposite ways. Eq. 11 defines only the first corner; the step is our
  reading of the two-corner model of the paper's Fig. 2(b).

Each configuration is rotated by a random angle, shifted by a random sub-pixel
offset, rendered with 16x16 supersampling (anti-aliasing) by
:func:`sogdd.synthetic.render_polygons`, and given seeded Gaussian noise. The
sides are long enough to leave the image, so the two corners are the only
corners in it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...synthetic import Polygon, render_polygons

__all__ = ["Config", "configurations", "render_configuration"]

_LONG = 400.0  # side length: far outside every image


@dataclass(frozen=True)
class Config:
    """One rendered configuration's parameters."""

    kind: str  # "END" or "L"
    d: float
    alpha: float
    beta: float
    noise: float
    theta: float
    offset: tuple[float, float]
    seed: int


def _local_polygon(kind: str, d: float, alpha: float, beta: float) -> np.ndarray:
    sa, ca, sb, cb = math.sin(alpha), math.cos(alpha), math.sin(beta), math.cos(beta)
    a = (-_LONG * sa, _LONG * ca)  # far end of the side at u = 0 (v > 0 side)
    if kind == "END":
        b = (d + _LONG * sb, _LONG * cb)
        return np.array([a, (0.0, 0.0), (d, 0.0), b])
    if kind == "L":
        b = (d + _LONG * sb, -_LONG * cb)  # the other side of the edge: a step
        big = 3 * _LONG
        return np.array([a, (0.0, 0.0), (d, 0.0), b, (big, -_LONG * cb), (big, big), (a[0], big)])
    raise ValueError(f"unknown configuration kind {kind!r} (END or L)")


def render_configuration(cfg: Config, size: int = 96, t1: float = 50.0, t2: float = 100.0,
                         supersample: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Render ``cfg``: ``(uint8 image, (2, 2) corner positions x, y)``.

    ``t1``/``t2`` default to the grey levels of the paper's Figs. 4 and 5.
    """
    poly = _local_polygon(cfg.kind, cfg.d, cfg.alpha, cfg.beta)
    c, s = math.cos(cfg.theta), math.sin(cfg.theta)
    rot = np.array([[c, -s], [s, c]])
    centre = np.array([(size - 1) / 2 + cfg.offset[0], (size - 1) / 2 + cfg.offset[1]])
    # centre the pair in the image
    shift = centre - rot @ np.array([cfg.d / 2, 0.0])
    verts = poly @ rot.T + shift
    corners = np.array([[0.0, 0.0], [cfg.d, 0.0]]) @ rot.T + shift
    img = render_polygons((size, size), [Polygon(verts, t2)], background=t1,
                          supersample=supersample)
    if cfg.noise > 0:
        img = img + np.random.default_rng(cfg.seed).normal(0.0, cfg.noise, img.shape)
    return np.clip(np.round(img), 0, 255).astype(np.uint8), corners


def configurations(quick: bool = False, seed: int = 0) -> list[Config]:
    """The benchmark grid: kinds x d x (alpha, beta) x noise x repeats (random pose)."""
    rng = np.random.default_rng(seed)
    if quick:
        ds = [2, 3, 4, 6, 8, 12]
        angles = [(math.pi / 8, math.pi / 8)]
        noises = [0.0, 5.0]
        reps = 2
    else:
        ds = list(range(2, 13))
        grid = [math.pi / 12, math.pi / 6, math.pi / 4]
        angles = [(a, b) for a in grid for b in grid]
        noises = [0.0, 2.0, 5.0]
        reps = 2
    out = []
    for kind in ("END", "L"):
        for d in ds:
            for a, b in angles:
                for nz in noises:
                    for _ in range(reps):
                        out.append(Config(kind, float(d), a, b, nz,
                                          float(rng.uniform(0, 2 * math.pi)),
                                          (float(rng.uniform(-0.5, 0.5)),
                                           float(rng.uniform(-0.5, 0.5))),
                                          int(rng.integers(2**31))))
    return out
