"""Rendered checkerboards with exactly known sub-pixel inner corners.

Geometry
--------
A board of ``n_cols x n_rows`` square cells of side ``c`` px lies on a light
sheet of paper. In board coordinates ``(u, v)`` (origin at the board's
top-left outer corner, ``u`` along the rows) cell ``(i, j)`` covers
``[i c, (i+1) c) x [j c, (j+1) c)`` and is dark when ``i + j`` is even. The
inner (X-) corners are ``(i c, j c)`` for ``1 <= i < n_cols``,
``1 <= j < n_rows``. The board is rotated by ``angle`` about its centre and
its centre is placed at ``((W-1)/2 + phase_x, (H-1)/2 + phase_y)`` in the
image (OpenCV convention: ``x`` = column, pixel centres at integers, pixel
``(j, i)`` covers ``[j - 1/2, j + 1/2) x [i - 1/2, i + 1/2)``). So an image
point is ``p = R(angle) (b - b_centre) + p_centre``.

Rendering (the image is the area integral over each pixel of the blurred scene)
-------------------------------------------------------------------------------
* ``angle == 0``: exact. The scene is
  ``f(x, y) = L + i_x(x) i_y(y) (M - L) + A (i_x s_x)(x) (i_y s_y)(y)`` with
  ``L`` the paper level, ``M`` and ``A`` the mean and half-difference of the
  cell levels, ``i`` the indicator of the board's extent and ``s`` the +-1
  square wave of period ``2c``. Every term is a product of a function of ``x``
  and one of ``y``, and so is the Gaussian PSF, so the pixel integrals
  factorise into 1-D integrals. Each 1-D profile is integrated exactly over
  cells of 1/64 px (the square wave's antiderivative is a triangle wave),
  blurred by the 1-D Gaussian there, and summed per pixel.
* ``angle != 0``: point sampling on a grid ``supersample`` (8) times finer,
  averaged to a 4x grid, blurred there by the PSF (``sigma * 4``), then
  averaged to pixels. Edge positions are quantised to 1/8 px along each
  sample row, and the quantisation averages out along a rotated edge.

Then Gaussian noise of ``noise`` grey levels (seeded per scene) is added and
the image is rounded to ``uint8``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["BoardScene", "RenderedBoard", "board_size", "render_board", "scene_grid",
           "CELLS", "QUICK_GRID", "FULL_GRID"]

#: the cell sizes of the benchmark (px)
CELLS: tuple[int, ...] = (3, 4, 5, 6, 8, 12, 16)

_DARK, _LIGHT = 40.0, 210.0  # grey levels of a printed target under even light
_FINE_1D = 64  # 1-D integration cells per pixel (exact path)


@dataclass(frozen=True)
class BoardScene:
    """One rendered board's parameters (module doc for the geometry)."""

    cell: float
    n_cols: int
    n_rows: int
    angle: float = 0.0  # degrees
    phase: tuple[float, float] = (0.0, 0.0)
    psf: float = 0.0  # Gaussian PSF sigma (px)
    noise: float = 0.0  # noise sigma (grey levels)
    seed: int = 0
    dark: float = _DARK
    light: float = _LIGHT
    margin: float = 0.0  # paper around the board (px); 0 -> 16 + cell

    @property
    def pattern_size(self) -> tuple[int, int]:
        """Inner corners per row and per column, as OpenCV's ``patternSize``."""
        return (self.n_cols - 1, self.n_rows - 1)


@dataclass(frozen=True)
class RenderedBoard:
    """A rendered scene: the image, its inner corners, and the scored region.

    ``corners`` is (N, 2) x, y. ``region`` is a (4, 2) convex polygon (image
    coordinates): the inner corners' rectangle grown by ``c / 2`` in board
    coordinates, halfway to the board's outer edge. Detections outside it are
    not counted as false (see :mod:`.metrics`).
    """

    scene: BoardScene
    image: np.ndarray
    corners: np.ndarray
    region: np.ndarray


def board_size(cell: float, extent: tuple[float, float] = (112.0, 88.0)) -> tuple[int, int]:
    """Cells across and down so the board spans about ``extent`` px (at least 5 x 4).

    The two counts differ, so OpenCV's pattern has no 90-degree ambiguity.
    """
    n_cols = max(5, int(round(extent[0] / cell)))
    n_rows = max(4, int(round(extent[1] / cell)))
    if n_rows == n_cols:
        n_rows -= 1
    return n_cols, n_rows


def _rotation(angle_deg: float) -> np.ndarray:
    a = math.radians(angle_deg)
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def _image_shape(s: BoardScene) -> tuple[int, int]:
    w, h = s.n_cols * s.cell, s.n_rows * s.cell
    a = math.radians(s.angle)
    bw = abs(w * math.cos(a)) + abs(h * math.sin(a))
    bh = abs(w * math.sin(a)) + abs(h * math.cos(a))
    m = s.margin if s.margin > 0 else 16.0 + s.cell
    return int(math.ceil(bh + 2 * m)), int(math.ceil(bw + 2 * m))


def _frame(s: BoardScene, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(R, board centre, image centre)`` of the board-to-image map."""
    h, w = shape
    bc = np.array([s.n_cols * s.cell / 2, s.n_rows * s.cell / 2])
    pc = np.array([(w - 1) / 2 + s.phase[0], (h - 1) / 2 + s.phase[1]])
    return _rotation(s.angle), bc, pc


def board_to_image(s: BoardScene, shape: tuple[int, int], uv: np.ndarray) -> np.ndarray:
    """Map board coordinates (N, 2) to image x, y."""
    r, bc, pc = _frame(s, shape)
    return (np.asarray(uv, dtype=np.float64) - bc) @ r.T + pc


def _tri(x: np.ndarray, c: float, n: int) -> np.ndarray:
    """Antiderivative from 0 of the board's +-1 square wave (+1 on the first cell), clipped to [0, n c]."""
    x = np.clip(x, 0.0, n * c)
    r = np.mod(x, 2 * c)
    return np.where(r < c, r, 2 * c - r)


def _profile(n_px: int, origin: float, c: float, n: int, psf: float) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel 1-D integrals of the board indicator and of indicator x square wave (PSF applied).

    ``origin`` is the image coordinate of the board's edge ``u = 0``.
    """
    f = _FINE_1D
    edges = (np.arange(n_px * f + 1) / f) - 0.5 - origin  # fine cell edges in board coordinates
    ind = np.diff(np.clip(edges, 0.0, n * c))
    sq = np.diff(_tri(edges, c, n))
    if psf > 0:
        ind = _blur1d(ind, psf * f)
        sq = _blur1d(sq, psf * f)
    return ind.reshape(n_px, f).sum(1), sq.reshape(n_px, f).sum(1)


def _blur1d(x: np.ndarray, sigma: float) -> np.ndarray:
    from scipy.ndimage import gaussian_filter1d

    return gaussian_filter1d(x, sigma, mode="nearest", truncate=5.0)


def _render_exact(s: BoardScene, shape: tuple[int, int]) -> np.ndarray:
    h, w = shape
    _, bc, pc = _frame(s, shape)
    ox, oy = pc - bc  # image position of the board's top-left outer corner
    ix, sx = _profile(w, ox, s.cell, s.n_cols, s.psf)
    iy, sy = _profile(h, oy, s.cell, s.n_rows, s.psf)
    mid, amp = (s.dark + s.light) / 2, (s.light - s.dark) / 2
    # the first cell (i + j even) is dark: the product of square waves is +1 there
    return s.light + np.outer(iy, ix) * (mid - s.light) - amp * np.outer(sy, sx)


def _render_sampled(s: BoardScene, shape: tuple[int, int], supersample: int = 8) -> np.ndarray:
    h, w = shape
    ss, mid_ss = supersample, 4
    if ss % mid_ss:
        raise ValueError(f"supersample must be a multiple of {mid_ss}, got {ss}")
    r, bc, pc = _frame(s, shape)
    xs = ((np.arange(w * ss) + 0.5) / ss - 0.5 - pc[0]).astype(np.float32)
    ys = ((np.arange(h * ss) + 0.5) / ss - 0.5 - pc[1]).astype(np.float32)
    # image -> board: b = R^T (p - pc) + bc
    r32, c = r.astype(np.float32), np.float32(s.cell)
    u = (r32[0, 0] * xs[None, :] + r32[1, 0] * ys[:, None] + np.float32(bc[0])) / c
    v = (r32[0, 1] * xs[None, :] + r32[1, 1] * ys[:, None] + np.float32(bc[1])) / c
    inside = (u >= 0) & (u < s.n_cols) & (v >= 0) & (v < s.n_rows)
    dark = ((np.floor(u) + np.floor(v)) % 2) == 0
    fine = np.where(inside & dark, s.dark, s.light).astype(np.float32)
    k = ss // mid_ss
    img = fine.reshape(h * mid_ss, k, w * mid_ss, k).mean(axis=(1, 3), dtype=np.float64)
    if s.psf > 0:
        sig = s.psf * mid_ss
        img = cv2.GaussianBlur(img, (0, 0), sigmaX=sig, sigmaY=sig, borderType=cv2.BORDER_REPLICATE)
    return img.reshape(h, mid_ss, w, mid_ss).mean(axis=(1, 3))


def render_board(s: BoardScene) -> RenderedBoard:
    """Render ``s``: the uint8 image, its inner corners and the scored region.

    Examples
    --------
    >>> rb = render_board(BoardScene(cell=8, n_cols=6, n_rows=5))
    >>> rb.image.dtype, rb.corners.shape
    (dtype('uint8'), (20, 2))
    >>> bool(rb.image[int(rb.corners[0, 1]) - 2, int(rb.corners[0, 0]) - 2] < 100)  # dark cell (0, 0)
    True
    """
    if not (s.cell > 0 and s.n_cols >= 2 and s.n_rows >= 2):
        raise ValueError(f"a board needs cell > 0 and at least 2 x 2 cells, got {s}")
    if s.psf < 0 or s.noise < 0:
        raise ValueError(f"psf and noise must be >= 0, got psf={s.psf}, noise={s.noise}")
    shape = _image_shape(s)
    img = _render_exact(s, shape) if s.angle % 360 == 0 else _render_sampled(s, shape)
    if s.noise > 0:
        img = img + np.random.default_rng(s.seed).normal(0.0, s.noise, img.shape)
    img8 = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    i, j = np.meshgrid(np.arange(1, s.n_cols), np.arange(1, s.n_rows))
    uv = np.stack([i.ravel(), j.ravel()], axis=1) * s.cell
    c = s.cell
    box = np.array([[c / 2, c / 2], [(s.n_cols - 0.5) * c, c / 2],
                    [(s.n_cols - 0.5) * c, (s.n_rows - 0.5) * c], [c / 2, (s.n_rows - 0.5) * c]])
    return RenderedBoard(s, img8, board_to_image(s, shape, uv), board_to_image(s, shape, box))


@dataclass(frozen=True)
class SceneGrid:
    """The nuisance grid rendered for every cell size."""

    phases: int  # repeats of the angle x PSF x noise grid, each scene with its own phase
    angles: tuple[float, ...]
    psfs: tuple[float, ...]
    noises: tuple[float, ...]

    def size(self) -> int:
        return self.phases * len(self.angles) * len(self.psfs) * len(self.noises)


#: about a second per detector for all seven cell sizes
QUICK_GRID = SceneGrid(phases=1, angles=(0.0, 30.0), psfs=(0.7,), noises=(2.0,))
#: 4 repeats x 3 angles x 3 PSFs x 3 noise levels = 108 boards (and phases) per cell size
FULL_GRID = SceneGrid(phases=4, angles=(0.0, 10.0, 30.0), psfs=(0.0, 0.7, 1.5), noises=(0.0, 2.0, 5.0))


def scene_grid(cells=CELLS, quick: bool = False, seed: int = 0) -> list[BoardScene]:
    """Every scene of the benchmark: cells x phases x angles x PSFs x noise levels.

    Every scene draws its own phase, uniform in ``[0, 1)^2``, and its own noise
    seed from a generator seeded with ``seed`` (so a cell size sees
    ``grid.size()`` distinct phases). The quick grid has one repeat, two angles,
    PSF 0.7 and noise 2.
    """
    g = QUICK_GRID if quick else FULL_GRID
    rng = np.random.default_rng(seed)
    out = []
    for c in cells:
        c = float(c)
        if not (math.isfinite(c) and 2 <= c <= 64):
            raise ValueError(f"cell sizes must be in [2, 64] px, got {c:g}")
        n_cols, n_rows = board_size(c)
        for _ in range(g.phases):
            for a in g.angles:
                for p in g.psfs:
                    for nz in g.noises:
                        ph = (float(rng.uniform(0, 1)), float(rng.uniform(0, 1)))
                        out.append(BoardScene(c, n_cols, n_rows, a, ph, p, nz,
                                              int(rng.integers(2**31))))
    return out
