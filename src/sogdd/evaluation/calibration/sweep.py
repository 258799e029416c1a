"""A randomized corpus of rendered chessboard views: the chessboard detectors' development benchmark.

``sogdd eval calibration --sweep N --seed S`` renders ``N`` single views, each with exact ground
truth, runs every board method on each and writes ``sweep.json`` (every view's drawn factors and
every method's result on it) and ``sweep.md`` (the overall table and the complete boards by factor
bin). This module is the corpus (:func:`draw_factors`, :func:`render_factors`); the benchmark run, its
scores and its tables are :mod:`.sweep_metrics` (:func:`~.sweep_metrics.run_sweep`). :func:`sweep_view`
renders view ``k`` of sweep ``S`` alone, so that a failure recorded in ``sweep.json`` is re-rendered
from its seed and index:

>>> from sogdd.evaluation.calibration.comparators import METHODS
>>> v = sweep_view(1, 37)                            # doctest: +SKIP
>>> METHODS["opencv"].detect(v.image, v.pattern)     # doctest: +SKIP

Drawn factors
-------------
View ``k`` of seed ``S`` draws its factors from ``numpy.random.default_rng([S, k])``
(:func:`draw_factors`): first every scalar factor, in a fixed order and each independently of the
others, then the placements (the board's pose, the second board, the hand), then ``render_seed``.
The image's own randomness (the background's texture, the rectangles, the noise) comes from
``default_rng(render_seed)``, so a view's factors (``sweep.json``) give its image
(:func:`render_factors`).

==============  ========================================================================================
factor          drawn
==============  ========================================================================================
frame           pixel count log-uniform in ``[640 x 480, max_pixels]`` (12 MP), aspect 4:3, 16:9 or 3:2
board           inner corners ``cols``, ``rows`` each uniform in 3..12 (the pattern the detectors are
                given); a frame too small for cells of 8 px takes a row or column off the longer side
cell            ``cell_px`` log-uniform in ``[8, min(300, fit)]`` px: the median length of the lattice's
                edges in the image, ``fit = 0.9 min(w, h) / hypot(cols + 1, rows + 1)`` (the board fits
                at any roll); a board that cannot be placed in 150 tries has its cells made 10 % smaller
pose            tilt uniform in [0, 70] degrees (the board's normal against the line of sight to its
                centre) about an axis at any angle in the board's plane, roll uniform in [0, 360)
                degrees, the centre anywhere the board fits: every outer square at least 2 px and every
                inner corner at least 4 px inside the frame (the white margin may leave it)
lens            ``none``, ``pincushion`` (k1 in [0.01, 0.1]), ``barrel`` (k1 in [-0.4, -0.01],
                ``k2 = k1^2 / 2``: the radius stays monotonic) or ``fisheye`` (equidistant), 1/4 each;
                a pinhole's horizontal field of view uniform in [45, 85] degrees
                (:func:`~.render.camera_for`), a fisheye's in [120, 200] degrees across the width
margin          the white paper beyond the outer squares: none w.p. 1/4, else uniform in [0, 1.5]
                cells; w.p. 1/5 the outer squares are cut to 0.3-0.9 of a cell (``edge``)
contrast        dark squares uniform in [10, 100] grey levels, paper uniform in
                ``[max(100, dark + 5), 250]``, the background's mean uniform in [20, 235]
ramp            illumination gain ``1 + g d / r_max`` (``d`` along a random direction from the frame's
                centre, ``r_max`` the half-diagonal), ``g`` uniform in [0, 0.5]
vignetting      gain ``1 - v (r / r_max)^2``, ``v`` uniform in [0, 0.6]
glare           w.p. 0.3, a Gaussian blob of 30-150 grey levels and sigma 5-30 % of the diagonal,
                centred anywhere in the frame, added
noise           Gaussian, sigma uniform in [0, 12] grey levels
blur            optical, a Gaussian of sigma uniform in [0.3, 3] px
motion          none w.p. 0.3, else a line of length uniform in [0, 20] px at any angle
jpeg            none w.p. 0.3, else an encoding and decoding at a quality uniform in 30..95
texture         w.p. 0.5, a textured background: smooth noise of three octaves, 8-50 grey levels std
rectangles      w.p. 0.5, 3-15 rectangles of any grey, of sides 0.5-4 cells, at any angle, behind the
                board
second board    w.p. 0.3, a second board of 3..12 x 3..12 inner corners (the main board's pattern
                w.p. 1/2) with cells 12-33 % of the main board's (at least 2 px), tilted up to 40
                degrees, where its paper stays 4 px clear of the main board's (none if no such place)
hand            w.p. 0.3, a skin-toned hand of grey 90-200 (a palm of 1-2 cells and 1-4 fingers of
                1.5-4 cells past the board's edge) reaching over an edge of the board
==============  ========================================================================================

Rendering
---------
The board (and the second board) is :func:`~.render.render_scene` (exact box-filtered samples,
:mod:`.render`) over a uniform background; a frame of more than :data:`SUPERSAMPLE_4_MAX` pixels
is rendered at 2 x 2 samples per pixel (:func:`~.raster.render_samples`, the renderer's own
sampling; its box filter keeps every edge unbiased, and a pixel differs from the 4 x 4 render by
at most about 1 grey level, on the edges) to keep a 12 MP view at a few seconds. Then, in this order:
the background's texture and rectangles where the paper is not (the paper's anti-aliased outline,
:func:`cv2.fillPoly`), the hand, the illumination ramp and the glare, the optical blur, the motion
blur (a centred line kernel made symmetric, so it moves no corner), the vignetting, the noise
(:func:`~.render.add_noise`) and the JPEG round trip (:func:`~.render.jpeg_roundtrip`). Ground truth
is the projection of the inner corners (:meth:`Camera.project`). A corner is *covered* when a hand
pixel lies within ``max(2, 0.3 cell)`` px of it; the *expected* corners are the others.

Scoring
-------
Each method's ``detect(image, pattern)`` (:data:`~.comparators.METHODS`, board methods only) is scored
by :func:`~.metrics.score_view` against every inner corner, with the expected corners as those to
find (:func:`~.sweep_metrics.score_detection`):

- **complete**: every expected corner found with its right label after the view's best label
  alignment (one of the lattice's 8 symmetries and an offset, :func:`~.metrics.align_labels`);
- **corners found**: the expected corners found with the right label, over all expected corners;
- **wrong labels**: returned corners whose aligned label is no corner's, or half a cell or more
  from its corner;
- **off-board points**: returned points farther than :data:`~.sweep_metrics.OFF_BOARD_PX` (3 px) from
  every inner corner of the main board (covered ones included): points on the second board, the
  clutter, the hand or nothing. It is independent of the labels: a corner 3 px to half a cell from its true
  position is both correct and off-board;
- **corner error**: the distance of each correctly labelled corner to its true position, mean and
  95th percentile over all such corners;
- **time**: the method's call per view, after one untimed call on a small view
  (:data:`~.sweep_metrics.WARM_PIXELS`: a first call compiles or imports).

The tables bin each factor into 2 to 4 bins (:data:`~.sweep_metrics.FACTOR_BINS`) and count, per bin,
the views and each method's complete boards.

Examples
--------
>>> f = draw_factors(1, 0, max_pixels=320 * 240)
>>> f.width * f.height <= 320 * 240, 3 <= f.cols <= 12, 8 <= f.cell_px <= 300
(True, True, True)
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, replace
from typing import Literal

import cv2
import numpy as np

from ...calib.cameras import Camera, pose_matrix
from .metrics import local_cell
from .raster import render_samples
from .render import add_noise, camera_for, jpeg_roundtrip, render_scene
from .target import ChessboardTarget, in_frame

__all__ = ["LENSES", "MAX_PIXELS", "SUPERSAMPLE_4_MAX", "SWEEP_METHODS", "Hand", "SecondBoard", "SweepFactors",
           "SweepView", "draw_factors", "factors_from_dict", "motion_kernel", "render_factors", "sweep_camera",
           "sweep_target", "sweep_view"]

Lens = Literal["none", "pincushion", "barrel", "fisheye"]
Aspect = Literal["4:3", "16:9", "3:2"]

#: the lens kinds, drawn 1/4 each
LENSES: tuple[Lens, ...] = ("none", "pincushion", "barrel", "fisheye")
#: the methods run by default
SWEEP_METHODS: tuple[str, ...] = ("sogdd", "opencv", "opencv-sb")
#: the largest frame drawn by default (pixels)
MAX_PIXELS = 12_000_000
#: the smallest frame drawn (pixels; smaller with a smaller ``max_pixels``)
MIN_PIXELS = 640 * 480
#: frames up to this many pixels are rendered with 4 x 4 samples per pixel, larger ones with 2 x 2
SUPERSAMPLE_4_MAX = 3_000_000

_ASPECTS: dict[Aspect, float] = {"4:3": 4 / 3, "16:9": 16 / 9, "3:2": 3 / 2}
_CELL = (8.0, 300.0)
_TILT_MAX = 70.0
_BORDER = 4.0  # inner corners this far inside the frame
_KEEP = 2.0  # outer squares this far inside the frame
_SQUARE = 0.03  # the board's square (m): the scale of the scene, nothing else
_COVER = 0.3  # a hand pixel within this many cells (at least 2 px) covers a corner


@dataclass(frozen=True)
class SecondBoard:
    """A second, smaller board beside the main one (module doc): its pattern, square (m), pose, cells (px)."""

    cols: int
    rows: int
    square: float
    rvec: tuple[float, float, float]
    tvec: tuple[float, float, float]
    cell_px: float

    def target(self) -> ChessboardTarget:
        return ChessboardTarget(self.cols, self.rows, self.square)


@dataclass(frozen=True)
class Hand:
    """A hand over the board's edge, in image px: where it enters the board ``(x, y)``, the direction into
    the board ``angle`` (degrees), the palm's radius, its fingers (count, length, width, fan in degrees)
    and its grey level."""

    x: float
    y: float
    angle: float
    palm: float
    fingers: int
    length: float
    width: float
    spread: float
    grey: float


@dataclass(frozen=True)
class SweepFactors:
    """Everything view ``index`` of sweep ``seed`` drew (module doc); :func:`render_factors` renders it.

    Angles in degrees, lengths in px unless said; ``fov`` a pinhole's horizontal field of view or a
    fisheye's across the width; ``margin`` and ``edge`` in cells; ``dark``, ``light``,
    ``background``, ``glare``, ``texture`` (std), ``noise`` in grey levels; ``ramp`` and
    ``vignetting`` gains; ``rectangles`` a count (0: none); ``jpeg`` None: no JPEG;
    ``rvec``, ``tvec`` the main board's pose (board -> camera, m); ``supersample`` the render's samples
    per pixel along each axis.
    """

    seed: int
    index: int
    width: int
    height: int
    aspect: Aspect
    cols: int
    rows: int
    cell_px: float
    tilt: float
    tilt_axis: float
    roll: float
    lens: Lens
    k1: float
    k2: float
    fov: float
    margin: float
    edge: float
    dark: float
    light: float
    background: float
    ramp: float
    ramp_angle: float
    vignetting: float
    glare: float
    glare_x: float
    glare_y: float
    glare_sigma: float
    noise: float
    blur: float
    motion: float
    motion_angle: float
    jpeg: int | None
    texture: float
    rectangles: int
    second: SecondBoard | None
    hand: Hand | None
    rvec: tuple[float, float, float]
    tvec: tuple[float, float, float]
    supersample: int
    render_seed: int

    @property
    def pattern(self) -> tuple[int, int]:
        return (self.cols, self.rows)

    def to_dict(self) -> dict:
        """The factors as plain JSON values (:func:`factors_from_dict` reads them back)."""
        return asdict(self)


@dataclass(frozen=True)
class SweepView:
    """One rendered view: ``image`` (H, W) uint8; ``corners`` (N, 2) the exact projections of the inner
    corners, ``labels`` (N, 2) their ``(i, j)``; ``covered`` (N,) under the hand; ``expected`` (N,) the
    corners to find (in the frame and not covered); ``render_s`` the render's seconds."""

    factors: SweepFactors
    image: np.ndarray
    corners: np.ndarray
    labels: np.ndarray
    covered: np.ndarray
    expected: np.ndarray
    camera: Camera
    target: ChessboardTarget
    render_s: float

    @property
    def pattern(self) -> tuple[int, int]:
        return self.factors.pattern


# ---------------------------------------------------------------------------------------------
# drawing


def _log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _draw_frame(rng: np.random.Generator, max_pixels: int) -> tuple[int, int, Aspect]:
    lo = min(MIN_PIXELS, max_pixels)
    pixels = _log_uniform(rng, lo, max_pixels) if max_pixels > lo else float(lo)
    aspect: Aspect = ("4:3", "16:9", "3:2")[int(rng.integers(3))]
    a = _ASPECTS[aspect]
    w = int(math.sqrt(pixels * a)) // 2 * 2
    h = int(w / a) // 2 * 2
    return w, h, aspect


def _draw_lens(rng: np.random.Generator) -> tuple[Lens, float, float, float]:
    lens = LENSES[int(rng.integers(4))]
    k1 = {"none": 0.0, "pincushion": rng.uniform(0.01, 0.1), "barrel": rng.uniform(-0.4, -0.01),
          "fisheye": 0.0}[lens]
    fov = rng.uniform(120.0, 200.0) if lens == "fisheye" else rng.uniform(45.0, 85.0)
    return lens, float(k1), float(0.5 * k1 * k1 if lens == "barrel" else 0.0), float(fov)


def _fit_cell(w: int, h: int, cols: int, rows: int) -> float:
    return 0.9 * min(w, h) / math.hypot(cols + 1, rows + 1)


def _draw_scalars(rng: np.random.Generator, max_pixels: int) -> dict:
    """Every scalar factor, in a fixed order (the placements come after)."""
    w, h, aspect = _draw_frame(rng, max_pixels)
    cols, rows = (int(v) for v in rng.integers(3, 13, 2))
    lens, k1, k2, fov = _draw_lens(rng)
    margin = 0.0 if rng.random() < 0.25 else float(rng.uniform(0.0, 1.5))
    edge = float(rng.uniform(0.3, 0.9)) if rng.random() < 0.2 else 1.0
    dark = float(rng.uniform(10.0, 100.0))
    light = float(rng.uniform(max(100.0, dark + 5.0), 250.0))
    f = dict(width=w, height=h, aspect=aspect, cols=cols, rows=rows, cell_q=float(rng.random()),
             tilt=float(rng.uniform(0.0, _TILT_MAX)), tilt_axis=float(rng.uniform(0.0, 360.0)),
             roll=float(rng.uniform(0.0, 360.0)), lens=lens, k1=k1, k2=k2, fov=fov, margin=margin, edge=edge,
             dark=dark, light=light, background=float(rng.uniform(20.0, 235.0)),
             ramp=float(rng.uniform(0.0, 0.5)), ramp_angle=float(rng.uniform(0.0, 360.0)),
             vignetting=float(rng.uniform(0.0, 0.6)))
    glare = rng.random() < 0.3
    f.update(glare=float(rng.uniform(30.0, 150.0)) if glare else 0.0, glare_x=float(rng.uniform(0, w - 1)),
             glare_y=float(rng.uniform(0, h - 1)), glare_sigma=float(rng.uniform(0.05, 0.3) * math.hypot(w, h)),
             noise=float(rng.uniform(0.0, 12.0)), blur=float(rng.uniform(0.3, 3.0)))
    f.update(motion=0.0 if rng.random() < 0.3 else float(rng.uniform(0.0, 20.0)),
             motion_angle=float(rng.uniform(0.0, 180.0)),
             jpeg=None if rng.random() < 0.3 else int(rng.integers(30, 96)))
    f.update(texture=float(rng.uniform(8.0, 50.0)) if rng.random() < 0.5 else 0.0,
             rectangles=int(rng.integers(3, 16)) if rng.random() < 0.5 else 0,
             second_on=bool(rng.random() < 0.3), hand_on=bool(rng.random() < 0.3))
    return f


def draw_factors(seed: int, index: int, *, max_pixels: int = MAX_PIXELS) -> SweepFactors:
    """Draw view ``index`` of sweep ``seed`` (module doc): its factors and its placements, no pixels.

    Parameters
    ----------
    seed, index : int
        The draws come from ``numpy.random.default_rng([seed, index])``.
    max_pixels : int, default 12 000 000
        The largest frame (pixels); the smallest is ``min(640 x 480, max_pixels)``.

    Returns
    -------
    SweepFactors

    Examples
    --------
    >>> f = draw_factors(1, 3, max_pixels=320 * 240)
    >>> f == draw_factors(1, 3, max_pixels=320 * 240), f.lens in LENSES, 0 <= f.tilt <= 70
    (True, True, True)
    """
    seed, index, max_pixels = _check_ints(seed, index, max_pixels)
    rng = np.random.default_rng([seed, index])
    f = _draw_scalars(rng, max_pixels)
    w, h, cols, rows = f["width"], f["height"], f["cols"], f["rows"]
    while _fit_cell(w, h, cols, rows) < _CELL[0] and max(cols, rows) > 3:
        cols, rows = (cols - 1, rows) if cols >= rows else (cols, rows - 1)
    hi = min(_CELL[1], _fit_cell(w, h, cols, rows))
    cell = float(math.exp(math.log(_CELL[0]) + f.pop("cell_q") * math.log(max(hi, _CELL[0]) / _CELL[0])))
    second_on, hand_on = f.pop("second_on"), f.pop("hand_on")
    f.update(cols=cols, rows=rows)
    probe = SweepFactors(seed=seed, index=index, **f, cell_px=cell, second=None, hand=None, rvec=(0.0,) * 3,
                         tvec=(0.0,) * 3, supersample=4, render_seed=0)
    cam = sweep_camera(probe)
    rvec, tvec, cell, (cols, rows) = _place_main(cam, probe, rng)
    probe = replace(probe, cols=cols, rows=rows, cell_px=cell, rvec=rvec, tvec=tvec)
    second = _place_second(cam, probe, rng) if second_on else None
    hand = _draw_hand(cam, probe, rng) if hand_on else None
    return replace(probe, second=second, hand=hand, supersample=4 if w * h <= SUPERSAMPLE_4_MAX else 2,
                    render_seed=int(rng.integers(2**63)))


def _check_ints(seed, index, max_pixels) -> tuple[int, int, int]:
    if int(seed) < 0 or int(index) < 0:
        raise ValueError(f"seed and index must be >= 0, got {seed} and {index}")
    if int(max_pixels) < 160 * 120:
        raise ValueError(f"max_pixels must be >= 19200 (160 x 120), got {max_pixels}")
    return int(seed), int(index), int(max_pixels)


def sweep_camera(f: SweepFactors) -> Camera:
    """The view's camera: :func:`~.render.camera_for` with ``(k1, k2, 0, 0)`` and a horizontal field of
    view of ``fov``, or an equidistant fisheye of ``fov`` degrees across the width (its principal point
    off the centre as :func:`~.render.camera_for`'s).

    Examples
    --------
    >>> c = sweep_camera(draw_factors(1, 0, max_pixels=320 * 240))
    >>> c.model in ("pinhole", "fisheye"), c.size == (draw_factors(1, 0, max_pixels=320 * 240).width,
    ...                                                 draw_factors(1, 0, max_pixels=320 * 240).height)
    (True, True)
    """
    w, h = f.width, f.height
    if f.lens != "fisheye":
        return camera_for(w, h, f.fov, (f.k1, f.k2, 0.0, 0.0))
    fx = (w / 2) / math.radians(f.fov / 2)
    K = np.array([[fx, 0.0, (w - 1) / 2 + 0.013 * w], [0.0, 0.998 * fx, (h - 1) / 2 - 0.011 * h], [0, 0, 1.0]])
    return Camera(K, (0.0, 0.0, 0.0, 0.0), (w, h), model="fisheye")


def sweep_target(f: SweepFactors) -> ChessboardTarget:
    """The main board: ``cols x rows`` inner corners, its margin and outer squares (cells) as drawn."""
    return ChessboardTarget(f.cols, f.rows, _SQUARE, margin=f.margin * _SQUARE, edge=f.edge)


def _median_cell(pts: np.ndarray, cols: int, rows: int) -> float:
    """The median length (px) of the lattice's edges between the corners ``pts`` (rows x cols, row-major)."""
    g = pts.reshape(rows, cols, 2)
    d = np.concatenate([np.linalg.norm(np.diff(g, axis=1), axis=2).ravel(),
                        np.linalg.norm(np.diff(g, axis=0), axis=2).ravel()])
    return float(np.median(d))


def _facing(d: np.ndarray) -> np.ndarray:
    """A rotation whose z axis (the board's normal) is the unit ray ``d``: the board faces the camera."""
    up = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(up, d)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(d, x), d], axis=1)


def _pose(cam: Camera, target: ChessboardTarget, centre_px, cell: float, tilt: float, axis: float,
          roll: float):
    """The pose putting the board's centre on the ray of pixel ``centre_px`` with cells of ``cell`` px."""
    d = cam.rays(np.asarray(centre_px, dtype=np.float64).reshape(1, 2))[0]
    if not np.all(np.isfinite(d)):
        return None
    a, t_, r_ = np.radians(axis), np.radians(tilt), np.radians(roll)
    R = _facing(d) @ cv2.Rodrigues(np.array([np.cos(a), np.sin(a), 0.0]) * t_)[0] @ \
        cv2.Rodrigues(np.array([0.0, 0.0, r_]))[0]
    rvec = cv2.Rodrigues(R)[0].ravel()
    centre = np.array([(target.cols - 1) / 2, (target.rows - 1) / 2, 0.0]) * target.square
    obj = target.object_points()
    dist = cam.fx * target.square / cell
    for _ in range(4):  # the cell is about inversely proportional to the distance
        t = dist * d - R @ centre
        m = _median_cell(cam.project(obj, rvec, t), target.cols, target.rows)
        if not math.isfinite(m) or m <= 0:
            return None
        dist *= m / cell
    t = dist * d - R @ centre
    m = _median_cell(cam.project(obj, rvec, t), target.cols, target.rows)
    return (rvec, t) if abs(m / cell - 1) < 0.03 else None


def _fits(cam: Camera, target: ChessboardTarget, rvec, tvec) -> bool:
    w, h = cam.size
    edge = cam.project(target.outline(with_margin=False, per_side=24), rvec, tvec)
    inside = in_frame(cam.project(target.object_points(), rvec, tvec), cam.size, _BORDER)
    with np.errstate(invalid="ignore"):
        ok = np.all(np.isfinite(edge)) and np.all((edge >= _KEEP) & (edge <= np.array([w - 1, h - 1]) - _KEEP))
    return bool(ok and inside.all())


def _try_place(cam: Camera, target: ChessboardTarget, cell: float, tilt: float, axis: float, roll: float,
               rng: np.random.Generator, tries: int = 150):
    w, h = cam.size
    half = min(0.5 * cell * math.hypot(target.cols + 1, target.rows + 1), 0.45 * min(w, h))
    for _ in range(tries):
        px = (rng.uniform(half, w - 1 - half), rng.uniform(half, h - 1 - half))
        pose = _pose(cam, target, px, cell, tilt, axis, roll)
        if pose is not None and _fits(cam, target, *pose):
            return pose
    return None


def _place_main(cam: Camera, f: SweepFactors, rng: np.random.Generator):
    """The main board's pose; its cells 10 % smaller after each 150 failed tries (not below 8 px), then
    a row or column fewer. Returns ``(rvec, tvec, cell, (cols, rows))``."""
    cell, cols, rows = f.cell_px, f.cols, f.rows
    for _ in range(80):
        target = ChessboardTarget(cols, rows, _SQUARE, margin=f.margin * _SQUARE, edge=f.edge)
        pose = _try_place(cam, target, cell, f.tilt, f.tilt_axis, f.roll, rng)
        if pose is not None:
            return tuple(float(v) for v in pose[0]), tuple(float(v) for v in pose[1]), cell, (cols, rows)
        if cell > _CELL[0]:
            cell = max(_CELL[0], 0.9 * cell)
        elif max(cols, rows) > 3:
            cols, rows = (cols - 1, rows) if cols >= rows else (cols, rows - 1)
    raise ValueError(f"could not place a {f.cols} x {f.rows} board in a {f.width} x {f.height} frame")


def _paper(cam: Camera, target: ChessboardTarget, rvec, tvec, per_side: int = 48) -> np.ndarray:
    """The board's paper's outline in the image (M, 2), its non-finite points dropped."""
    pts = cam.project(target.outline(with_margin=True, per_side=per_side), rvec, tvec)
    return pts[np.all(np.isfinite(pts), axis=1)]


def _apart(a: np.ndarray, b: np.ndarray, gap: float) -> bool:
    """Whether outlines ``a`` and ``b`` (closed polygons) stay ``gap`` px apart, neither inside the other."""
    ca, cb = a.astype(np.float32).reshape(-1, 1, 2), b.astype(np.float32).reshape(-1, 1, 2)
    for poly, pts in ((ca, b), (cb, a)):
        for p in pts[:: max(1, len(pts) // 64)]:
            if cv2.pointPolygonTest(poly, (float(p[0]), float(p[1])), True) > -gap:
                return False
    return True


def _place_second(cam: Camera, f: SweepFactors, rng: np.random.Generator) -> SecondBoard | None:
    """A second board with cells 12-33 % of the main board's, its paper 4 px clear of the main board's."""
    same = rng.random() < 0.5
    cols, rows = f.pattern if same else tuple(int(v) for v in rng.integers(3, 13, 2))
    cell = max(2.0, f.cell_px * float(rng.uniform(0.12, 0.33)))
    tilt, axis, roll = rng.uniform(0, 40.0), rng.uniform(0, 360.0), rng.uniform(0, 360.0)
    main = _paper(cam, sweep_target(f), f.rvec, f.tvec)
    target = ChessboardTarget(cols, rows, _SQUARE)
    for _ in range(20):
        pose = _try_place(cam, target, cell, tilt, axis, roll, rng, tries=10)
        if pose is not None and _apart(_paper(cam, target, *pose), main, 4.0):
            return SecondBoard(cols, rows, _SQUARE, tuple(float(v) for v in pose[0]),
                               tuple(float(v) for v in pose[1]), cell)
    return None


def _draw_hand(cam: Camera, f: SweepFactors, rng: np.random.Generator) -> Hand:
    """A hand entering the board across one side of its squares, pointing at the board's centre."""
    target = sweep_target(f)
    u0, u1, v0, v1 = target.squares_extent()
    side, s = int(rng.integers(4)), float(rng.uniform(0.15, 0.85))
    u = (u0 + s * (u1 - u0), u1, u0 + s * (u1 - u0), u0)[side]
    v = (v0, v0 + s * (v1 - v0), v1, v0 + s * (v1 - v0))[side]
    centre = np.array([[(u0 + u1) / 2, (v0 + v1) / 2, 0.0]])
    p, c = cam.project(np.array([[u, v, 0.0]]), f.rvec, f.tvec)[0], cam.project(centre, f.rvec, f.tvec)[0]
    cell = f.cell_px
    return Hand(float(p[0]), float(p[1]), float(np.degrees(np.arctan2(*(c - p)[::-1]))),
                palm=cell * float(rng.uniform(1.0, 2.0)), fingers=int(rng.integers(1, 5)),
                length=cell * float(rng.uniform(1.5, 4.0)), width=cell * float(rng.uniform(0.35, 0.6)),
                spread=float(rng.uniform(10.0, 40.0)), grey=float(rng.uniform(90.0, 200.0)))


def factors_from_dict(d: dict) -> SweepFactors:
    """:meth:`SweepFactors.to_dict`'s dict (as ``sweep.json`` holds it) back to :class:`SweepFactors`.

    Examples
    --------
    >>> import json
    >>> f = draw_factors(2, 5, max_pixels=320 * 240)
    >>> factors_from_dict(json.loads(json.dumps(f.to_dict()))) == f
    True
    """
    d = dict(d)
    tup = {k: tuple(d[k]) for k in ("rvec", "tvec")}
    second = d.pop("second")
    hand = d.pop("hand")
    if second is not None:
        second = SecondBoard(**{**second, "rvec": tuple(second["rvec"]), "tvec": tuple(second["tvec"])})
    return SweepFactors(**{**d, **tup, "second": second, "hand": None if hand is None else Hand(**hand)})


# ---------------------------------------------------------------------------------------------
# rendering


def _board_array(target: ChessboardTarget, levels: tuple[float, float, float]) -> np.ndarray:
    """The raster kernel's board array (:mod:`.raster`'s doc)."""
    return np.array([target.square, target.cols, target.rows, target.margin, *levels, target.edge,
                     target.dots, target.dot], dtype=np.float64)


def _render_boards(f: SweepFactors, cam: Camera, target: ChessboardTarget) -> np.ndarray:
    """The board (and the second board) over the uniform background, (H, W) float64, before any effect."""
    levels = (f.dark, f.light, f.background)
    behind = None
    if f.second is not None:
        behind = (f.second.target(), np.array(f.second.rvec), np.array(f.second.tvec))
    if f.supersample >= 4:
        return render_scene(cam, target, np.array(f.rvec), np.array(f.tvec), supersample=f.supersample,
                            levels=levels, behind=behind)
    R, t = pose_matrix(f.rvec, f.tvec)
    second = None
    if behind is not None:
        R2, t2 = pose_matrix(behind[1], behind[2])
        second = (R2, t2, _board_array(behind[0], levels))
    return render_samples(cam, R, t, f.supersample, _board_array(target, levels), second)


def _poly_mask(shape: tuple[int, int], polys: list[np.ndarray]) -> np.ndarray:
    """The anti-aliased coverage (H, W) float32 in [0, 1] of the filled polygons (pixel centres at integers)."""
    canvas = np.zeros(shape, dtype=np.uint8)
    pts = [np.round(np.clip(p, -1e5, 1e5) * 16).astype(np.int32).reshape(-1, 1, 2)
           for p in polys if len(p) >= 3]
    if pts:
        cv2.fillPoly(canvas, pts, 255, cv2.LINE_AA, 4)
    return canvas.astype(np.float32) / 255.0


def _texture(shape: tuple[int, int], amplitude: float, rng: np.random.Generator) -> np.ndarray:
    """Smooth noise of three octaves (periods about 1/8, 1/32 and 1/128 of the frame), std ``amplitude``."""
    h, w = shape
    field = np.zeros(shape, dtype=np.float32)
    for cells, weight in ((8, 1.0), (32, 0.6), (128, 0.35)):
        gh, gw = max(2, round(cells * h / max(h, w))), max(2, round(cells * w / max(h, w)))
        small = rng.standard_normal((gh, gw)).astype(np.float32)
        field += weight * cv2.resize(small, (w, h), interpolation=cv2.INTER_CUBIC)
    return field * np.float32(amplitude / max(float(field.std()), 1e-6))


def _rectangles(layer: np.ndarray, f: SweepFactors, rng: np.random.Generator) -> None:
    """Paint ``f.rectangles`` rectangles of any grey, sides 0.5-4 cells, at any angle, into ``layer``."""
    h, w = layer.shape
    for _ in range(f.rectangles):
        cx, cy = rng.uniform(0, w - 1), rng.uniform(0, h - 1)
        a, b = f.cell_px * rng.uniform(0.5, 4.0, 2) / 2
        th = rng.uniform(0, np.pi)
        grey = np.float32(rng.uniform(0.0, 255.0))
        corners = np.array([[-a, -b], [a, -b], [a, b], [-a, b]]) @ np.array([[np.cos(th), np.sin(th)],
                                                                             [-np.sin(th), np.cos(th)]])
        poly = corners + [cx, cy]
        x0, y0 = (max(0, int(np.floor(v)) - 2) for v in poly.min(axis=0))
        x1, y1 = min(w, int(np.ceil(poly[:, 0].max())) + 3), min(h, int(np.ceil(poly[:, 1].max())) + 3)
        if x1 <= x0 or y1 <= y0:
            continue
        m = _poly_mask((y1 - y0, x1 - x0), [poly - [x0, y0]])
        roi = layer[y0:y1, x0:x1]
        roi += (grey - roi) * m


def _background(img: np.ndarray, f: SweepFactors, cam: Camera, target: ChessboardTarget,
                rng: np.random.Generator) -> np.ndarray:
    """The texture and the rectangles where no paper is (the papers' anti-aliased outlines)."""
    layer = np.full(img.shape, np.float32(f.background))
    if f.texture > 0:
        layer += _texture(img.shape, f.texture, rng)
    if f.rectangles > 0:
        _rectangles(layer, f, rng)
    polys = [_paper(cam, target, f.rvec, f.tvec, per_side=96)]
    if f.second is not None:
        polys.append(_paper(cam, f.second.target(), f.second.rvec, f.second.tvec, per_side=48))
    free = 1.0 - _poly_mask(img.shape, polys)
    return img + (layer - np.float32(f.background)) * free


def _hand_mask(hand: Hand, shape: tuple[int, int]) -> np.ndarray:
    """The hand's anti-aliased coverage (H, W) float32: a palm disc behind the entry point and its fingers."""
    canvas = np.zeros(shape, dtype=np.uint8)
    a = math.radians(hand.angle)
    d = np.array([math.cos(a), math.sin(a)])
    p = np.array([hand.x, hand.y])
    palm = p - 0.8 * hand.palm * d

    def fix(q):
        return tuple(int(round(v * 16)) for v in np.clip(q, -1e5, 1e5))

    r = max(1, int(round(hand.palm * 16)))
    cv2.ellipse(canvas, fix(palm), (r, max(1, int(r * 0.8))), hand.angle, 0, 360, 255, -1, cv2.LINE_AA, 4)
    n = hand.fingers
    for k in range(n):
        off = (k - (n - 1) / 2) / max(n - 1, 1) * hand.spread if n > 1 else 0.0
        b = a + math.radians(off)
        e = np.array([math.cos(b), math.sin(b)])
        start = palm + 0.6 * hand.palm * e
        tip = p + hand.length * e
        cv2.line(canvas, fix(start), fix(tip), 255, max(1, int(round(hand.width))), cv2.LINE_AA, 4)
    return canvas.astype(np.float32) / 255.0


def _covered(mask: np.ndarray, corners: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """Corners with a hand pixel within ``max(2, 0.3 cell)`` px (module doc)."""
    if not mask.any():
        return np.zeros(len(corners), dtype=bool)
    dist = cv2.distanceTransform((mask <= 0.02).astype(np.uint8), cv2.DIST_L2, 5)
    h, w = mask.shape
    x = np.clip(np.round(corners[:, 0]).astype(int), 0, w - 1)
    y = np.clip(np.round(corners[:, 1]).astype(int), 0, h - 1)
    reach = np.maximum(2.0, _COVER * local_cell(corners, labels))
    return dist[y, x] <= reach


def motion_kernel(length: float, angle: float) -> np.ndarray:
    """A motion blur's kernel: a line of ``length`` px at ``angle`` degrees, centred, symmetric, sum 1.

    Points every 1/4 px along the line are splatted bilinearly; the kernel is then averaged with its
    half turn, so it moves no point symmetric content (a corner stays where it is).

    Examples
    --------
    >>> k = motion_kernel(6.0, 0.0)
    >>> k.shape, round(float(k.sum()), 6), bool(np.allclose(k, k[::-1, ::-1]))
    ((9, 9), 1.0, True)
    >>> motion_kernel(0.2, 30.0).tolist()
    [[1.0]]
    """
    if not (length >= 0 and math.isfinite(length)):
        raise ValueError(f"length must be a finite value >= 0, got {length}")
    if length < 0.5:
        return np.ones((1, 1))
    size = 2 * int(math.ceil(length / 2)) + 3
    c = (size - 1) / 2
    t = np.linspace(-length / 2, length / 2, max(2, int(math.ceil(4 * length)) + 1))
    x, y = c + t * math.cos(math.radians(angle)), c + t * math.sin(math.radians(angle))
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = x - x0, y - y0
    k = np.zeros((size, size))
    for dx, dy, wgt in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)), (0, 1, (1 - fx) * fy),
                        (1, 1, fx * fy)):
        np.add.at(k, (y0 + dy, x0 + dx), wgt)
    k = k + k[::-1, ::-1]
    return k / k.sum()


def _light(img: np.ndarray, f: SweepFactors) -> np.ndarray:
    """The illumination ramp (a gain) and the glare (added)."""
    h, w = img.shape
    xs = np.arange(w, dtype=np.float32) - np.float32((w - 1) / 2)
    ys = np.arange(h, dtype=np.float32) - np.float32((h - 1) / 2)
    rmax = math.hypot((w - 1) / 2, (h - 1) / 2)
    a = math.radians(f.ramp_angle)
    if f.ramp > 0:
        img = img * (1 + np.float32(f.ramp / rmax) * (ys[:, None] * np.float32(math.sin(a))
                                                       + xs[None, :] * np.float32(math.cos(a))))
    if f.glare > 0:
        s2 = 2 * f.glare_sigma ** 2
        gx = np.exp(-((np.arange(w) - f.glare_x) ** 2) / s2).astype(np.float32)
        gy = np.exp(-((np.arange(h) - f.glare_y) ** 2) / s2).astype(np.float32)
        img = img + np.float32(f.glare) * gy[:, None] * gx[None, :]
    return img


def _optics(img: np.ndarray, f: SweepFactors) -> np.ndarray:
    """The optical blur, the motion blur and the vignetting."""
    if f.blur > 0:
        k = 2 * int(math.ceil(4 * f.blur)) + 1
        img = cv2.GaussianBlur(img, (k, k), f.blur, borderType=cv2.BORDER_REFLECT)
    kernel = motion_kernel(f.motion, f.motion_angle)
    if kernel.size > 1:
        img = cv2.filter2D(img, -1, kernel.astype(np.float32), borderType=cv2.BORDER_REFLECT)
    if f.vignetting > 0:
        h, w = img.shape
        xs = (np.arange(w, dtype=np.float32) - np.float32((w - 1) / 2)) ** 2
        ys = (np.arange(h, dtype=np.float32) - np.float32((h - 1) / 2)) ** 2
        r2 = (ys[:, None] + xs[None, :]) / np.float32(((w - 1) / 2) ** 2 + ((h - 1) / 2) ** 2)
        img = img * (1 - np.float32(f.vignetting) * r2)
    return img


def render_factors(f: SweepFactors) -> SweepView:
    """Render the view that ``f`` describes (module doc for the order of the effects), with exact truth.

    Examples
    --------
    >>> v = render_factors(draw_factors(1, 2, max_pixels=320 * 240))
    >>> v.image.dtype, v.image.shape == (v.factors.height, v.factors.width), len(v.corners) == v.labels.shape[0]
    (dtype('uint8'), True, True)
    >>> bool(np.all(v.expected == ~v.covered))
    True
    """
    t0 = time.perf_counter()
    cam, target = sweep_camera(f), sweep_target(f)
    rng = np.random.default_rng(f.render_seed)
    img = _render_boards(f, cam, target).astype(np.float32)
    if f.texture > 0 or f.rectangles > 0:
        img = _background(img, f, cam, target, rng)
    corners = cam.project(target.object_points(), np.array(f.rvec), np.array(f.tvec))
    labels = target.labels()
    covered = np.zeros(len(corners), dtype=bool)
    if f.hand is not None:
        m = _hand_mask(f.hand, img.shape)
        img += (np.float32(f.hand.grey) - img) * m
        covered = _covered(m, corners, labels)
    img = _optics(_light(img, f), f)
    image = add_noise(img, f.noise, rng)
    if f.jpeg is not None:
        image = jpeg_roundtrip(image, f.jpeg)
    expected = in_frame(corners, cam.size, _BORDER) & ~covered
    return SweepView(f, image, corners, labels, covered, expected, cam, target, time.perf_counter() - t0)


def sweep_view(seed: int, index: int, *, max_pixels: int = MAX_PIXELS) -> SweepView:
    """View ``index`` of sweep ``seed``, rendered alone: ``render_factors(draw_factors(seed, index))``.

    Examples
    --------
    >>> a = sweep_view(3, 1, max_pixels=320 * 240)
    >>> b = sweep_view(3, 1, max_pixels=320 * 240)
    >>> bool(np.array_equal(a.image, b.image)), a.pattern == (a.factors.cols, a.factors.rows)
    (True, True)
    """
    return render_factors(draw_factors(seed, index, max_pixels=max_pixels))
