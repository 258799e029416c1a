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

A fisheye (``Camera(..., model="fisheye")``, OpenCV's ``cv2.fisheye`` model,
``dist = (k1, k2, k3, k4)``) maps a ray at angle :math:`\\theta` from the axis to the
radius :math:`\\theta_d = \\theta (1 + k_1 \\theta^2 + \\dots + k_4 \\theta^8)` (normalised;
``k = 0``: equidistant, :math:`r = f \\theta`), along the ray's azimuth; it sees rays at 90
degrees and beyond.

Target
------
:class:`ChessboardTarget` ``(cols, rows, square)`` has ``cols x rows`` inner
corners (OpenCV's ``patternSize``); inner corner ``(i, j)`` lies at
``(i square, j square, 0)`` in board coordinates ``(u, v, 0)``. The board's
``(cols + 1) x (rows + 1)`` squares cover
``[-square, cols square] x [-square, rows square]``; square ``(a, b)``
(``a = floor(u / square) + 1``) is dark when ``a + b`` is even (the top-left
square is dark). A white margin of ``margin`` (default one square) surrounds the
squares; beyond it lies a uniform background. Options: ``edge < 1`` cuts the
outermost squares to ``edge`` cells (no margin by default: the paper's edge cuts
them); ``dots`` prints a dot matrix in the inner white squares (ECoCheck-like).
A second board (``behind``) can show where the first board's paper does not: it
replaces the background there (so it must not come between the camera and the
first board; placed beside it in the image it is exact either way).

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
levels, rounding to ``uint8``, and with ``jpeg`` a JPEG encoding and decoding at
that quality (``cv2.imencode``: 8 x 8 block artefacts). A fisheye's sample is
unprojected exactly too: :math:`\\theta` by Newton's method on
:math:`\\theta_d(\\theta)` (exact at once for the equidistant model), its ray
:math:`(\\sin\\theta \\cos\\phi, \\sin\\theta \\sin\\phi, \\cos\\theta)` meets the
board plane at any angle in front of it.

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

from ...calib.cameras import Camera, pose_matrix
from .raster import render_samples as _render
from .raster import sample_coords as _sample_coords
from .target import ChessboardTarget, in_frame

__all__ = ["Camera", "ChessboardTarget", "RenderedView", "render_view", "render_scene", "add_noise",
           "render_charuco", "random_sequence", "pose_matrix", "in_frame", "jpeg_roundtrip", "camera_for"]

_LEVELS = (35.0, 215.0, 110.0)  # dark square, light paper, background


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

Behind = tuple[ChessboardTarget, np.ndarray, np.ndarray]


def render_view(camera: Camera, target: ChessboardTarget, rvec: np.ndarray, tvec: np.ndarray, *,
                supersample: int = 4, blur: float = 0.0, noise: float = 0.0, falloff: float = 0.0,
                rng: np.random.Generator | int | None = None, border: float = 4.0,
                levels: tuple[float, float, float] = _LEVELS, behind: Behind | None = None,
                jpeg: int | None = None) -> RenderedView:
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
    behind : (ChessboardTarget, rvec, tvec), optional
        A second board, seen where ``target``'s paper is not (module doc); its ground truth is
        its own projection, ``camera.project(behind[0].object_points(), behind[1], behind[2])``.
    jpeg : int, optional
        JPEG quality (1-100): the rounded image is encoded and decoded (``cv2.imencode``).

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
    if jpeg is not None and not 1 <= int(jpeg) <= 100:
        raise ValueError(f"jpeg must be a quality in [1, 100], got {jpeg}")
    clean = render_scene(camera, target, rvec, tvec, supersample=supersample, blur=blur, falloff=falloff,
                         levels=levels, behind=behind)
    img = add_noise(clean, noise, rng)
    if jpeg is not None:
        img = jpeg_roundtrip(img, int(jpeg))
    corners = camera.project(target.object_points(), rvec, tvec)
    return RenderedView(img, corners, target.labels(), in_frame(corners, camera.size, border),
                        np.asarray(rvec, dtype=np.float64).reshape(3).copy(),
                        np.asarray(tvec, dtype=np.float64).reshape(3).copy())


def render_scene(camera: Camera, target: ChessboardTarget, rvec: np.ndarray, tvec: np.ndarray, *,
                 supersample: int = 4, blur: float = 0.0, falloff: float = 0.0,
                 levels: tuple[float, float, float] = _LEVELS, behind: Behind | None = None) -> np.ndarray:
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
    second = None
    if behind is not None:
        R2, t2 = pose_matrix(behind[1], behind[2])
        second = (R2, t2, _board(behind[0], levels))
    return _finish(_render(camera, R, t, s, _board(target, levels), second), blur, falloff)


def _board(target: ChessboardTarget, levels: tuple[float, float, float]) -> np.ndarray:
    """The raster kernel's board array (:mod:`.raster`)."""
    dark, light, bg = (float(v) for v in levels)
    return np.array([target.square, target.cols, target.rows, target.margin, dark, light, bg,
                     target.edge, target.dots, target.dot])


def jpeg_roundtrip(image: np.ndarray, quality: int = 75) -> np.ndarray:
    """A uint8 image encoded as JPEG at ``quality`` and decoded (``cv2.imencode``, ``cv2.imdecode``).

    Examples
    --------
    >>> img = np.tile(np.repeat([40, 200], 5).astype(np.uint8), (16, 2))
    >>> out = jpeg_roundtrip(img, 75)
    >>> out.shape, out.dtype, bool(np.any(out != img))
    ((16, 20), dtype('uint8'), True)
    """
    ok, buf = cv2.imencode(".jpg", np.asarray(image, dtype=np.uint8), [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise ValueError("cv2.imencode could not encode the image as JPEG")
    return cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE)


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


#: the distortion of the evaluation's cameras (OpenCV's k1, k2, p1, p2)
_DIST = (-0.22, 0.08, 0.0008, -0.0006)


def camera_for(width: int, height: int, hfov_deg: float = 60.0, dist: tuple = _DIST) -> Camera:
    """A camera of ``width x height`` with a horizontal field of view of ``hfov_deg`` degrees.

    The principal point is a little off the image centre, and ``fy = 0.998 fx``,
    so that neither is a free guess for a calibration.

    Examples
    --------
    >>> cam = camera_for(640, 480)
    >>> round(cam.fx, 3), cam.size
    (554.256, (640, 480))
    """
    fx = (width / 2) / np.tan(np.radians(hfov_deg) / 2)
    cx, cy = (width - 1) / 2 + 0.013 * width, (height - 1) / 2 - 0.011 * height
    K = np.array([[fx, 0.0, cx], [0.0, 0.998 * fx, cy], [0.0, 0.0, 1.0]])
    return Camera(K, dist, (width, height))
