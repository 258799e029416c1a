"""Rendered views of a chessboard through an exactly known camera, with exact ground truth.

Camera model (OpenCV's ``cv2.projectPoints``)
----------------------------------------------
A point ``X_c = R X + t`` in the camera frame goes to ``x' = X_c / Z_c``,
``y' = Y_c / Z_c``; with ``r^2 = x'^2 + y'^2`` and
``radial = 1 + k1 r^2 + k2 r^4 + k3 r^6``,

    x'' = x' radial + 2 p1 x' y' + p2 (r^2 + 2 x'^2)
    y'' = y' radial + p1 (r^2 + 2 y'^2) + 2 p2 x' y'

and the pixel is ``(u, v, 1) = K (x'', y'', 1)``: ``x`` = column, ``y`` = row,
pixel centres at integers, so pixel ``(x, y)`` covers
``[x - 1/2, x + 1/2) x [y - 1/2, y + 1/2)``.

Target
------
:class:`ChessboardTarget` ``(cols, rows, square)`` has ``cols x rows`` inner
corners (OpenCV's ``patternSize``); inner corner ``(i, j)`` lies at
``(i square, j square, 0)`` in board coordinates ``(u, v, 0)``. The board's
``(cols + 1) x (rows + 1)`` squares cover
``[-square, cols square] x [-square, rows square]``; square ``(a, b)``
(``a = floor(u / square) + 1``) is dark when ``a + b`` is even (the top-left
square is dark). A white margin of ``margin`` (default one square) surrounds the
squares; beyond it lies a uniform background.

Rendering
---------
Each pixel is the mean of ``supersample x supersample`` samples on a regular
grid inside it. Each sample is undistorted exactly (Newton's method on the
distortion, started from the extrapolation of the previous two samples and
iterated until a step is below 1e-7, which leaves an error below 1e-13 as
the method converges quadratically), its ray is intersected with the
board plane, and the reflectance there is filtered by a box that matches the
sample's footprint: the footprint's extent along ``u`` and along ``v`` (from
the pixel's local Jacobian ``d(u, v) / d(x, y)``) sets a box half-width per
axis, and the board's reflectance, a sum of products ``f(u) g(v)`` of interval
indicators, is integrated exactly over that box. A symmetric filter leaves every
edge where it is, so the rendered edges and their crossings are unbiased (plain
point sampling would quantise an axis-aligned edge to ``1 / supersample`` px).
Then, in this order: Gaussian blur of ``blur`` px (``cv2.GaussianBlur`` on the
pixel grid, a blur of the optics), illumination falloff (the image times
``1 - falloff (r / r_max)^2``, ``r`` from the image centre, ``r_max`` the
half-diagonal: vignetting at the sensor), Gaussian noise of ``noise`` grey
levels, rounding to ``uint8``.

Ground truth is the projection of the board's inner corners through the same
model (:meth:`Camera.project`); blur is symmetric and the falloff is smooth, so
neither moves a corner by more than about 1e-3 px at the levels of the
sequences.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np
from numba import njit, prange

from ..._jit import JIT

__all__ = ["Camera", "ChessboardTarget", "RenderedView", "render_view", "render_scene", "add_noise",
           "render_charuco", "random_sequence", "pose_matrix", "in_frame"]

_LEVELS = (35.0, 215.0, 110.0)  # dark square, light paper, background


@dataclass(frozen=True)
class Camera:
    """A pinhole camera with OpenCV's distortion ``(k1, k2, p1, p2[, k3])``.

    Parameters
    ----------
    K : (3, 3) array
        Intrinsic matrix ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]``.
    dist : sequence of 4 or 5 floats
        ``(k1, k2, p1, p2[, k3])``; stored as five values.
    size : (width, height)
        Image size in pixels.

    Examples
    --------
    >>> cam = Camera(np.array([[800.0, 0, 319.5], [0, 800.0, 239.5], [0, 0, 1]]), (0.0, 0, 0, 0), (640, 480))
    >>> cam.project(np.array([[0.0, 0.0, 2.0], [0.1, 0.0, 1.0]])).round(6).tolist()
    [[319.5, 239.5], [399.5, 239.5]]
    >>> cam.fx, cam.width, cam.height
    (800.0, 640, 480)
    """

    K: np.ndarray
    dist: tuple = (0.0, 0.0, 0.0, 0.0, 0.0)
    size: tuple[int, int] = (640, 480)

    def __post_init__(self) -> None:
        K = np.asarray(self.K, dtype=np.float64)
        if K.shape != (3, 3) or not np.all(np.isfinite(K)) or K[0, 0] <= 0 or K[1, 1] <= 0:
            raise ValueError(f"K must be a finite (3, 3) matrix with positive focal lengths, got {K.tolist()}")
        d = tuple(float(v) for v in np.asarray(self.dist, dtype=np.float64).reshape(-1))
        if len(d) not in (4, 5) or not all(math.isfinite(v) for v in d):
            raise ValueError(f"dist must be 4 or 5 finite values (k1, k2, p1, p2[, k3]), got {d}")
        w, h = (int(v) for v in self.size)
        if w < 1 or h < 1:
            raise ValueError(f"size must be (width, height) >= 1, got {self.size}")
        K = K.copy()
        K.setflags(write=False)
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "dist", d + (0.0,) * (5 - len(d)))
        object.__setattr__(self, "size", (w, h))

    @property
    def fx(self) -> float:
        return float(self.K[0, 0])

    @property
    def fy(self) -> float:
        return float(self.K[1, 1])

    @property
    def width(self) -> int:
        return self.size[0]

    @property
    def height(self) -> int:
        return self.size[1]

    def distort(self, xy: np.ndarray) -> np.ndarray:
        """Pixels of normalised coordinates ``(x', y')`` (N, 2): the model of the module doc."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        xd, yd = _distort_np(xy[:, 0], xy[:, 1], self.dist)
        K = self.K
        return np.stack([K[0, 0] * xd + K[0, 1] * yd + K[0, 2], K[1, 1] * yd + K[1, 2]], axis=1)

    def project(self, points3d: np.ndarray, rvec: np.ndarray | None = None,
                tvec: np.ndarray | None = None) -> np.ndarray:
        """Project 3-D points (N, 3) to pixels (N, 2), as ``cv2.projectPoints``.

        The points are in the camera frame, or in a frame given by ``rvec``
        (Rodrigues vector) and ``tvec``: ``X_c = R(rvec) X + tvec``. Points at
        or behind the camera's centre plane give NaN.
        """
        P = np.asarray(points3d, dtype=np.float64).reshape(-1, 3)
        if rvec is not None or tvec is not None:
            R, t = pose_matrix(np.zeros(3) if rvec is None else rvec, np.zeros(3) if tvec is None else tvec)
            P = P @ R.T + t
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(P[:, 2] > 0, P[:, 2], np.nan)
            return self.distort(np.stack([P[:, 0] / z, P[:, 1] / z], axis=1))

    def undistort(self, pixels: np.ndarray, *, tol: float = 1e-13, max_iter: int = 100) -> np.ndarray:
        """Normalised coordinates ``(x', y')`` (N, 2) of pixels (N, 2): the exact inverse of :meth:`distort`.

        Newton's method on ``distort(x') = pixel`` from ``x' = K^-1 pixel``,
        until every step is below ``tol`` (in normalised units). A pixel where
        it does not converge (beyond the model's fold) gives NaN.
        """
        px = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
        K = self.K
        yd = (px[:, 1] - K[1, 2]) / K[1, 1]
        xd = (px[:, 0] - K[0, 2] - K[0, 1] * yd) / K[0, 0]
        x, y = xd.copy(), yd.copy()
        active = np.ones(len(px), dtype=bool)
        for _ in range(max_iter):
            if not active.any():
                break
            xa, ya = x[active], y[active]
            fx_, fy_ = _distort_np(xa, ya, self.dist)
            j00, j01, j10, j11 = _distort_jac_np(xa, ya, self.dist)
            ex, ey = fx_ - xd[active], fy_ - yd[active]
            det = j00 * j11 - j01 * j10
            dx = (j11 * ex - j01 * ey) / det
            dy = (-j10 * ex + j00 * ey) / det
            x[active], y[active] = xa - dx, ya - dy
            step = np.maximum(np.abs(dx), np.abs(dy))
            idx = np.flatnonzero(active)
            active[idx[~(step > tol)]] = False  # NaN steps stop too
        out = np.stack([x, y], axis=1)
        bad = active | ~np.all(np.isfinite(out), axis=1)
        if bad.any():
            back = self.distort(out[~bad]) if (~bad).any() else np.zeros((0, 2))
            out[bad] = np.nan
            # a fold of the model can converge to a far-off preimage: check it
            far = np.zeros(len(px), dtype=bool)
            far[np.flatnonzero(~bad)] = np.hypot(*(back - px[~bad]).T) > 1e-6
            out[far] = np.nan
        return out


@dataclass(frozen=True)
class ChessboardTarget:
    """A chessboard of ``cols x rows`` inner corners (OpenCV's ``patternSize``) and squares of ``square``.

    Inner corner ``(i, j)`` is at ``(i square, j square, 0)``; the squares cover
    ``[-square, cols square] x [-square, rows square]`` and a white margin of
    ``margin`` (None: one square) surrounds them.

    Examples
    --------
    >>> t = ChessboardTarget(3, 2, 10.0)
    >>> t.labels().tolist()
    [[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1]]
    >>> t.object_points()[-1].tolist()
    [20.0, 10.0, 0.0]
    """

    cols: int
    rows: int
    square: float = 1.0
    margin: float | None = None

    def __post_init__(self) -> None:
        if int(self.cols) < 1 or int(self.rows) < 1:
            raise ValueError(f"a chessboard needs >= 1 inner corner each way, got {self.cols} x {self.rows}")
        if not (self.square > 0 and math.isfinite(self.square)):
            raise ValueError(f"square must be positive, got {self.square}")
        m = self.square if self.margin is None else float(self.margin)
        if not (m >= 0 and math.isfinite(m)):
            raise ValueError(f"margin must be >= 0, got {self.margin}")
        object.__setattr__(self, "cols", int(self.cols))
        object.__setattr__(self, "rows", int(self.rows))
        object.__setattr__(self, "square", float(self.square))
        object.__setattr__(self, "margin", m)

    @property
    def pattern_size(self) -> tuple[int, int]:
        return (self.cols, self.rows)

    def labels(self) -> np.ndarray:
        """``(i, j)`` of every inner corner (N, 2) int64, ``i`` fastest (OpenCV's order)."""
        j, i = np.mgrid[0:self.rows, 0:self.cols]
        return np.stack([i.ravel(), j.ravel()], axis=1).astype(np.int64)

    def object_points(self) -> np.ndarray:
        """Board coordinates (N, 3) of the inner corners, in :meth:`labels`' order."""
        out = np.zeros((self.cols * self.rows, 3))
        out[:, :2] = self.labels() * self.square
        return out

    def outline(self, with_margin: bool = False, per_side: int = 16) -> np.ndarray:
        """Points (4 per_side, 3) along the squares' (or the paper's) outer edge."""
        s, m = self.square, (self.margin if with_margin else 0.0)
        u0, u1, v0, v1 = -s - m, self.cols * s + m, -s - m, self.rows * s + m
        t = np.linspace(0.0, 1.0, per_side, endpoint=False)
        sides = [np.stack([u0 + (u1 - u0) * t, np.full_like(t, v0)], 1),
                 np.stack([np.full_like(t, u1), v0 + (v1 - v0) * t], 1),
                 np.stack([u1 - (u1 - u0) * t, np.full_like(t, v1)], 1),
                 np.stack([np.full_like(t, u0), v1 - (v1 - v0) * t], 1)]
        uv = np.concatenate(sides)
        return np.concatenate([uv, np.zeros((len(uv), 1))], axis=1)


@dataclass(frozen=True)
class RenderedView:
    """One rendered view and its ground truth.

    ``image`` (H, W) uint8; ``corners`` (N, 2) the true projections of all inner
    corners (x, y); ``labels`` (N, 2) their ``(i, j)``; ``inside`` (N,) bool: in
    front of the camera, in the frame and at least ``border`` px from its edges;
    ``rvec``, ``tvec`` the pose; ``ids`` (N,) the ChArUco corner IDs or None.
    """

    image: np.ndarray
    corners: np.ndarray
    labels: np.ndarray
    inside: np.ndarray
    rvec: np.ndarray = field(default_factory=lambda: np.zeros(3))
    tvec: np.ndarray = field(default_factory=lambda: np.zeros(3))
    ids: np.ndarray | None = None


def pose_matrix(rvec: np.ndarray, tvec: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(R, t)`` of a Rodrigues vector and a translation, validated: (3, 3) and (3,)."""
    r = np.asarray(rvec, dtype=np.float64).reshape(-1)
    t = np.asarray(tvec, dtype=np.float64).reshape(-1)
    if r.shape != (3,) or t.shape != (3,) or not (np.all(np.isfinite(r)) and np.all(np.isfinite(t))):
        raise ValueError(f"rvec and tvec must be 3 finite values each, got {r.tolist()} and {t.tolist()}")
    return cv2.Rodrigues(r)[0], t


def render_view(camera: Camera, target: ChessboardTarget, rvec: np.ndarray, tvec: np.ndarray, *,
                supersample: int = 4, blur: float = 0.0, noise: float = 0.0, falloff: float = 0.0,
                rng: np.random.Generator | int | None = None, border: float = 4.0,
                levels: tuple[float, float, float] = _LEVELS) -> RenderedView:
    """Render ``target`` seen by ``camera`` at pose ``(rvec, tvec)`` (board -> camera), with exact ground truth.

    Parameters
    ----------
    camera, target : Camera, ChessboardTarget
    rvec, tvec : (3,) arrays
        The board's pose: ``X_c = R(rvec) X_board + tvec``.
    supersample : int, default 4
        Samples per pixel along each axis (>= 4; module doc for the filtering).
    blur : float, default 0
        Gaussian blur sigma (px).
    noise : float, default 0
        Gaussian noise sigma (grey levels, 0-255 scale).
    falloff : float, default 0
        Illumination falloff in ``[0, 1)``: gain ``1 - falloff (r / r_max)^2``.
    rng : Generator, int or None
        The noise's random generator (or its seed).
    border : float, default 4
        A corner nearer than this to the frame's edge is not ``inside``.
    levels : (dark, light, background)
        Grey levels of the dark squares, the paper and the background.

    Returns
    -------
    RenderedView

    Examples
    --------
    >>> cam = Camera(np.array([[400.0, 0, 79.5], [0, 400.0, 59.5], [0, 0, 1]]), (0.0, 0, 0, 0), (160, 120))
    >>> v = render_view(cam, ChessboardTarget(3, 2, 0.05), np.zeros(3), np.array([-0.05, -0.025, 1.0]))
    >>> v.image.shape, v.corners[0].round(6).tolist(), bool(v.inside.all())
    ((120, 160), [59.5, 49.5], True)
    """
    for name, val in (("noise", noise), ("border", border)):
        if not (val >= 0 and math.isfinite(val)):
            raise ValueError(f"{name} must be a finite value >= 0, got {val}")
    clean = render_scene(camera, target, rvec, tvec, supersample=supersample, blur=blur, falloff=falloff,
                         levels=levels)
    img = add_noise(clean, noise, rng)
    corners = camera.project(target.object_points(), rvec, tvec)
    return RenderedView(img, corners, target.labels(), in_frame(corners, camera.size, border),
                        np.asarray(rvec, dtype=np.float64).reshape(3).copy(),
                        np.asarray(tvec, dtype=np.float64).reshape(3).copy())


def render_scene(camera: Camera, target: ChessboardTarget, rvec: np.ndarray, tvec: np.ndarray, *,
                 supersample: int = 4, blur: float = 0.0, falloff: float = 0.0,
                 levels: tuple[float, float, float] = _LEVELS) -> np.ndarray:
    """The noise-free image of :func:`render_view` before rounding, (H, W) float64.

    Several noise draws of one view share it (:func:`add_noise`).

    Examples
    --------
    >>> cam = Camera(np.array([[400.0, 0, 79.5], [0, 400.0, 59.5], [0, 0, 1]]), (0.0, 0, 0, 0), (160, 120))
    >>> img = render_scene(cam, ChessboardTarget(3, 2, 0.05), np.zeros(3), np.array([-0.05, -0.025, 1.0]))
    >>> img.dtype, float(img[0, 0])
    (dtype('float64'), 110.0)
    """
    s = int(supersample)
    if s < 4:
        raise ValueError(f"supersample must be >= 4, got {supersample}")
    if not (blur >= 0 and math.isfinite(blur)):
        raise ValueError(f"blur must be a finite value >= 0, got {blur}")
    if not 0 <= falloff < 1:
        raise ValueError(f"falloff must be in [0, 1), got {falloff}")
    R, t = pose_matrix(rvec, tvec)
    dark, light, bg = (float(v) for v in levels)
    board = np.array([target.square, target.cols, target.rows, target.margin, dark, light, bg])
    return _finish(_render(camera, R, t, s, board), blur, falloff)


def add_noise(image: np.ndarray, noise: float = 0.0,
              rng: np.random.Generator | int | None = None) -> np.ndarray:
    """Gaussian noise of ``noise`` grey levels added to a float image, rounded and clipped to uint8.

    Examples
    --------
    >>> add_noise(np.full((2, 2), 100.4)).tolist()
    [[100, 100], [100, 100]]
    """
    if not (noise >= 0 and math.isfinite(noise)):
        raise ValueError(f"noise must be a finite value >= 0, got {noise}")
    img = np.asarray(image, dtype=np.float64)
    if noise > 0:
        gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        img = img + gen.normal(0.0, noise, img.shape)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def render_charuco(camera: Camera, board: cv2.aruco.CharucoBoard, rvec: np.ndarray, tvec: np.ndarray, *,
                   supersample: int = 4, blur: float = 0.0, noise: float = 0.0, falloff: float = 0.0,
                   rng: np.random.Generator | int | None = None, border: float = 4.0,
                   texels_per_square: int = 64) -> RenderedView:
    """Render an OpenCV ChArUco board (its ``generateImage``, warped through the camera).

    Board coordinates are OpenCV's (origin at the board's top-left outer corner,
    ``board.getChessboardCorners()`` for the corners). Each sample reads the
    board's generated image at its exact board position (nearest texel; the
    image has ``texels_per_square`` texels per square, so the chessboard's edges
    fall on texel boundaries and the corners are exact; the markers' edges are
    exact to half a texel). The corners' labels are ``(id % (nx - 1), id // (nx - 1))``
    and ``ids`` are OpenCV's ChArUco IDs.

    Examples
    --------
    >>> d = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
    >>> b = cv2.aruco.CharucoBoard((5, 4), 0.04, 0.03, d)
    >>> cam = Camera(np.array([[600.0, 0, 159.5], [0, 600.0, 119.5], [0, 0, 1]]), (0.0, 0, 0, 0), (320, 240))
    >>> v = render_charuco(cam, b, np.zeros(3), np.array([-0.1, -0.08, 0.8]))
    >>> v.image.shape, len(v.ids), v.labels[-1].tolist()
    ((240, 320), 12, [3, 2])
    """
    s = int(supersample)
    if s < 4:
        raise ValueError(f"supersample must be >= 4, got {supersample}")
    nx, ny = board.getChessboardSize()
    sq = float(board.getSquareLength())
    tps = int(texels_per_square)
    tex = board.generateImage((nx * tps, ny * tps), marginSize=0, borderBits=1).astype(np.float32)
    # OpenCV draws black 0 / white 255: map to the print's levels
    tex = _LEVELS[0] + (tex / 255.0) * (_LEVELS[1] - _LEVELS[0])
    R, t = pose_matrix(rvec, tvec)
    w, h = camera.size
    u, v = _sample_coords(camera, R, t, s)
    mx = (u / sq * tps - 0.5).astype(np.float32)
    my = (v / sq * tps - 0.5).astype(np.float32)
    samples = cv2.remap(tex, mx, my, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT,
                        borderValue=_LEVELS[2])
    # paper margin of one square around the board
    paper = (u >= -sq) & (u <= (nx + 1) * sq) & (v >= -sq) & (v <= (ny + 1) * sq)
    outside = (u < 0) | (u > nx * sq) | (v < 0) | (v > ny * sq)
    samples = np.where(outside & paper, _LEVELS[1], samples)
    samples = np.where(np.isfinite(u), samples, _LEVELS[2])
    img = samples.reshape(h, s, w, s).mean(axis=(1, 3))
    img = add_noise(_finish(img, blur, falloff), noise, rng)
    obj = np.asarray(board.getChessboardCorners(), dtype=np.float64).reshape(-1, 3)
    ids = np.arange(len(obj))
    labels = np.stack([ids % (nx - 1), ids // (nx - 1)], axis=1).astype(np.int64)
    corners = camera.project(obj, rvec, tvec)
    return RenderedView(img, corners, labels, in_frame(corners, camera.size, border),
                        np.asarray(rvec, dtype=np.float64).reshape(3).copy(), t.copy(), ids)


def random_sequence(camera: Camera, target: ChessboardTarget, n_views: int, *, tilt_max: float = 40.0,
                    seed: int = 0, partial: float = 0.0, cell_px: tuple[float, float] | None = None,
                    roll_max: float = 30.0, keep: float = 4.0) -> list[tuple[np.ndarray, np.ndarray]]:
    """Random board poses ``(rvec, tvec)`` for a calibration sequence.

    Each view tilts the board by an angle drawn uniformly in ``[0, tilt_max]``
    degrees about a random axis in its plane and rolls it by up to
    ``roll_max`` degrees about its normal. Its distance makes the squares
    ``cell_px`` pixels wide at the board's centre (drawn uniformly in the
    range; None: the board spans 35-85 % of the image's shorter side). A full
    view keeps the whole board, its white margin included, at least ``keep`` px
    inside the frame; the last ``round(partial n_views)`` views are cut by the
    frame, with 30-75 % of the inner corners inside. A view that cannot be
    placed in 400 draws raises ``ValueError`` (board too large for the frame).

    Examples
    --------
    >>> cam = Camera(np.array([[800.0, 0, 319.5], [0, 800.0, 239.5], [0, 0, 1]]), (0.0, 0, 0, 0), (640, 480))
    >>> poses = random_sequence(cam, ChessboardTarget(9, 6, 0.03), 5, seed=1, partial=0.4)
    >>> len(poses), poses[0][0].shape
    (5, (3,))
    """
    if int(n_views) < 1:
        raise ValueError(f"n_views must be >= 1, got {n_views}")
    if not 0 <= partial <= 1:
        raise ValueError(f"partial must be in [0, 1], got {partial}")
    if not 0 <= tilt_max < 80:
        raise ValueError(f"tilt_max must be in [0, 80) degrees, got {tilt_max}")
    if cell_px is not None and not (0 < cell_px[0] <= cell_px[1]):
        raise ValueError(f"cell_px must be (low, high) with 0 < low <= high, got {cell_px}")
    rng = np.random.default_rng(seed)
    n_partial = int(round(partial * n_views))
    out = []
    for k in range(int(n_views)):
        out.append(_draw_pose(camera, target, rng, tilt_max, roll_max, cell_px, keep,
                              cut=k >= n_views - n_partial))
    return out


# ---------------------------------------------------------------------------------------------
# poses


def _draw_pose(camera, target, rng, tilt_max, roll_max, cell_px, keep, cut):
    w, h = camera.size
    centre = np.array([(target.cols - 1) / 2, (target.rows - 1) / 2, 0.0]) * target.square
    span = (max(target.cols, target.rows) + 1) * target.square
    outline = target.outline(with_margin=True)
    obj = target.object_points()
    for _ in range(400):
        axis = rng.uniform(0, 2 * np.pi)
        tilt = np.radians(rng.uniform(0, tilt_max))
        roll = np.radians(rng.uniform(-roll_max, roll_max))
        R = cv2.Rodrigues(np.array([np.cos(axis), np.sin(axis), 0.0]) * tilt)[0] @ \
            cv2.Rodrigues(np.array([0.0, 0.0, roll]))[0]
        if cell_px is not None:
            z = camera.fx * target.square / rng.uniform(*cell_px)
        else:
            z = camera.fx * span / (rng.uniform(0.35, 0.85) * min(w, h))
        px = np.array([[rng.uniform(0, w - 1), rng.uniform(0, h - 1)]])
        ray = camera.undistort(px)[0]
        if not np.all(np.isfinite(ray)):
            continue
        t = z * np.array([ray[0], ray[1], 1.0]) - R @ centre
        rvec = cv2.Rodrigues(R)[0].ravel()
        edge = camera.project(outline, rvec, t)
        if not np.all(np.isfinite(edge)):
            continue
        if cut:
            inner = in_frame(camera.project(obj, rvec, t), camera.size, keep)
            if 0.3 <= inner.mean() <= 0.75:
                return rvec, t
        elif np.all((edge >= keep) & (edge <= np.array([w - 1, h - 1]) - keep)):
            return rvec, t
    raise ValueError(f"could not place a {target.cols}x{target.rows} board in a {w}x{h} frame "
                     f"(cells {cell_px} px): the board is too large for the frame")


def in_frame(corners: np.ndarray, size: tuple[int, int], border: float) -> np.ndarray:
    """Whether each point (N, 2) is finite and at least ``border`` px inside a frame of ``size`` (w, h)."""
    w, h = size
    with np.errstate(invalid="ignore"):
        return (np.all(np.isfinite(corners), axis=1) & (corners[:, 0] >= border) & (corners[:, 1] >= border)
                & (corners[:, 0] <= w - 1 - border) & (corners[:, 1] <= h - 1 - border))


# ---------------------------------------------------------------------------------------------
# the image


def _finish(img: np.ndarray, blur: float, falloff: float) -> np.ndarray:
    img = np.asarray(img, dtype=np.float64)
    if blur > 0:
        k = 2 * int(math.ceil(4 * blur)) + 1
        img = cv2.GaussianBlur(img, (k, k), blur, borderType=cv2.BORDER_REFLECT)
    if falloff > 0:
        h, w = img.shape
        yy, xx = np.mgrid[0:h, 0:w]
        r2 = ((xx - (w - 1) / 2) ** 2 + (yy - (h - 1) / 2) ** 2) / (((w - 1) / 2) ** 2 + ((h - 1) / 2) ** 2)
        img = img * (1.0 - falloff * r2)
    return img


def _cam_args(camera: Camera, R: np.ndarray, t: np.ndarray) -> np.ndarray:
    K = camera.K
    n = R[:, 2]  # the board's normal in the camera frame
    return np.concatenate([[K[0, 0], K[1, 1], K[0, 2], K[1, 2], K[0, 1]], camera.dist, R.ravel(), t,
                           [float(n @ t)]])


def _render(camera: Camera, R: np.ndarray, t: np.ndarray, s: int, board: np.ndarray) -> np.ndarray:
    w, h = camera.size
    out = np.empty((h, w), dtype=np.float64)
    _render_kernel(_cam_args(camera, R, t), board, s, out)
    return out


def _sample_coords(camera: Camera, R: np.ndarray, t: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray]:
    """Board coordinates (u, v) of every sample, (H s, W s) each; NaN where the ray misses the board plane."""
    w, h = camera.size
    u = np.empty((h * s, w * s), dtype=np.float64)
    v = np.empty((h * s, w * s), dtype=np.float64)
    _coords_kernel(_cam_args(camera, R, t), s, u, v)
    return u, v


def _distort_np(x, y, d):
    k1, k2, p1, p2, k3 = d
    r2 = x * x + y * y
    rad = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    return (x * rad + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
            y * rad + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y)


def _distort_jac_np(x, y, d):
    k1, k2, p1, p2, k3 = d
    r2 = x * x + y * y
    rad = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    drad = k1 + r2 * (2 * k2 + 3 * k3 * r2)  # d rad / d r2
    j00 = rad + 2 * x * x * drad + 2 * p1 * y + 6 * p2 * x
    j01 = 2 * x * y * drad + 2 * p1 * x + 2 * p2 * y
    j10 = 2 * x * y * drad + 2 * p1 * x + 2 * p2 * y
    j11 = rad + 2 * y * y * drad + 6 * p1 * y + 2 * p2 * x
    return j00, j01, j10, j11


@njit(**JIT)
def _undistort1(xd, yd, x, y, k1, k2, p1, p2, k3):
    """Newton's method on the distortion from (x, y); returns the solution (NaN if it does not converge)."""
    for _ in range(100):
        r2 = x * x + y * y
        rad = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        drad = k1 + r2 * (2 * k2 + 3 * k3 * r2)
        ex = x * rad + 2 * p1 * x * y + p2 * (r2 + 2 * x * x) - xd
        ey = y * rad + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y - yd
        j00 = rad + 2 * x * x * drad + 2 * p1 * y + 6 * p2 * x
        j01 = 2 * x * y * drad + 2 * p1 * x + 2 * p2 * y
        j11 = rad + 2 * y * y * drad + 6 * p1 * y + 2 * p2 * x
        det = j00 * j11 - j01 * j01
        dx = (j11 * ex - j01 * ey) / det
        dy = (-j01 * ex + j00 * ey) / det
        x -= dx
        y -= dy
        # Newton converges quadratically: after a step of d the error is about d^2 times the
        # distortion's curvature over its slope (< 10 for any usable lens), so d < 1e-7 leaves < 1e-13
        if abs(dx) < 1e-7 and abs(dy) < 1e-7:
            return x, y
        if not (abs(x) < 1e6 and abs(y) < 1e6):
            break
    return np.nan, np.nan


@njit(**JIT)
def _board_uv(xn, yn, c):
    """Board coordinates of the ray (xn, yn, 1): intersection with the plane n . X = n . t."""
    n0, n1, n2 = c[12], c[15], c[18]  # R[:, 2]
    den = n0 * xn + n1 * yn + n2
    lam = c[22] / den
    if not (lam > 0) or not np.isfinite(lam):
        return np.nan, np.nan
    px, py, pz = lam * xn - c[19], lam * yn - c[20], lam - c[21]
    # R^T (X - t): rows of R^T are the columns of R
    return c[10] * px + c[13] * py + c[16] * pz, c[11] * px + c[14] * py + c[17] * pz


@njit(**JIT)
def _overlap(x, r, lo, hi):
    a = max(x - r, lo)
    b = min(x + r, hi)
    return max(b - a, 0.0) / (2 * r)


@njit(**JIT)
def _parity_cover(x, r, sq, n):
    """Box-filtered indicators of the even and of the odd squares along one axis (squares 0..n)."""
    a0 = int(math.floor(x / sq)) + 1
    even = 0.0
    odd = 0.0
    for a in range(a0 - 1, a0 + 2):
        if a < 0 or a > n:
            continue
        f = _overlap(x, r, (a - 1) * sq, a * sq)
        if a % 2 == 0:
            even += f
        else:
            odd += f
    return even, odd


@njit(**JIT)
def _reflectance(u, v, ru, rv, b):
    sq, cols, rows, margin, dark, light, bg = b[0], int(b[1]), int(b[2]), b[3], b[4], b[5], b[6]
    if not np.isfinite(u):
        return bg
    ru = min(max(ru, 1e-9), 0.5 * sq)
    rv = min(max(rv, 1e-9), 0.5 * sq)
    pu = _overlap(u, ru, -sq - margin, cols * sq + margin)
    pv = _overlap(v, rv, -sq - margin, rows * sq + margin)
    eu, ou = _parity_cover(u, ru, sq, cols)
    ev, ov = _parity_cover(v, rv, sq, rows)
    return bg + (light - bg) * pu * pv - (light - dark) * (eu * ev + ou * ov)


@njit(**JIT)
def _row_samples(c, row, sub, s, w, us, vs):
    """(u, v) of every sample of sub-row ``sub`` of pixel row ``row``, (w s,) each, warm-started Newton."""
    fx, fy, cx, cy, skew = c[0], c[1], c[2], c[3], c[4]
    k1, k2, p1, p2, k3 = c[5], c[6], c[7], c[8], c[9]
    py = row - 0.5 + (sub + 0.5) / s
    yd = (py - cy) / fy
    x0 = np.nan  # the previous two solutions: their linear extrapolation starts Newton's method
    y0 = np.nan
    x1 = np.nan
    y1 = np.nan
    for k in range(w * s):
        px = -0.5 + (k + 0.5) / s
        xd = (px - cx - skew * yd) / fx
        if np.isfinite(x0) and np.isfinite(x1):
            x, y = 2 * x1 - x0, 2 * y1 - y0
        elif np.isfinite(x1):
            x, y = x1, y1
        else:
            x, y = xd, yd
        x, y = _undistort1(xd, yd, x, y, k1, k2, p1, p2, k3)
        x0, y0, x1, y1 = x1, y1, x, y
        if np.isfinite(x):
            us[k], vs[k] = _board_uv(x, y, c)
        else:
            us[k], vs[k] = np.nan, np.nan


@njit(parallel=True, cache=True, error_model="numpy")
def _render_kernel(c, b, s, out):
    h, w = out.shape
    for row in prange(h):
        us = np.empty((s, w * s))
        vs = np.empty((s, w * s))
        for sub in range(s):
            _row_samples(c, row, sub, s, w, us[sub], vs[sub])
        for col in range(w):
            k0 = col * s
            # the pixel's Jacobian d(u, v)/d(x, y) from its corner samples (1 px = s - 1 sample steps * s/(s-1))
            step = (s - 1) / s
            dux = 0.5 * ((us[0, k0 + s - 1] - us[0, k0]) + (us[s - 1, k0 + s - 1] - us[s - 1, k0])) / step
            dvx = 0.5 * ((vs[0, k0 + s - 1] - vs[0, k0]) + (vs[s - 1, k0 + s - 1] - vs[s - 1, k0])) / step
            duy = 0.5 * ((us[s - 1, k0] - us[0, k0]) + (us[s - 1, k0 + s - 1] - us[0, k0 + s - 1])) / step
            dvy = 0.5 * ((vs[s - 1, k0] - vs[0, k0]) + (vs[s - 1, k0 + s - 1] - vs[0, k0 + s - 1])) / step
            half = 0.5 / s
            ru = half * math.sqrt(dux * dux + duy * duy)
            rv = half * math.sqrt(dvx * dvx + dvy * dvy)
            if not np.isfinite(ru):
                ru = 0.0
            if not np.isfinite(rv):
                rv = 0.0
            acc = 0.0
            for sub in range(s):
                for k in range(s):
                    acc += _reflectance(us[sub, k0 + k], vs[sub, k0 + k], ru, rv, b)
            out[row, col] = acc / (s * s)


@njit(parallel=True, cache=True, error_model="numpy")
def _coords_kernel(c, s, u, v):
    hs, ws = u.shape
    w = ws // s
    for r in prange(hs):
        _row_samples(c, r // s, r % s, s, w, u[r], v[r])
