"""Shared helpers of the calibration tests: boards projected through a known camera (the rendered frames
are in tests/conftest.py, shared with the command's tests), and the tests' own renderer (the ``render``
fixture): a chessboard (or an OpenCV ChArUco board) seen through an OpenCV pinhole camera
(:class:`sogdd.calib.cameras.Camera`), exact to the ground truth, so that no calibration test depends on
the evaluation package, a client of the calibration library.

Fixtures, not imports: the tests run in importlib mode, where one test module cannot import another.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from sogdd.calib.cameras import Camera, pose_matrix
from sogdd.calib.demo import DEMO_DIST, DEMO_K, DEMO_PATTERN, DEMO_SIZE, demo_boards, demo_poses

SIZE, K_TRUE, D_TRUE = DEMO_SIZE, DEMO_K, DEMO_DIST
COLS, ROWS = DEMO_PATTERN
OBJ = np.array([(i, j, 0.0) for j in range(ROWS) for i in range(COLS)])
LABELS = OBJ[:, :2].astype(int)
poses, boards = demo_poses, demo_boards


@pytest.fixture(scope="session")
def synthetic():
    """The known camera and board of the synthetic tests, and :func:`poses` and :func:`boards`."""
    return SimpleNamespace(SIZE=SIZE, K_TRUE=K_TRUE, D_TRUE=D_TRUE, COLS=COLS, ROWS=ROWS, OBJ=OBJ,
                           LABELS=LABELS, poses=poses, boards=boards)


# ---------------------------------------------------------------------------------------------
# the tests' own renderer: a chessboard seen through a known camera, with exact ground truth

#: grey levels of the dark squares, the paper and the background
LEVELS = (35.0, 215.0, 110.0)


@dataclass(frozen=True)
class Board:
    """A chessboard of ``cols x rows`` inner corners (OpenCV's ``patternSize``) and squares of ``square``.

    Inner corner ``(i, j)`` is at ``(i square, j square, 0)``; square ``(a, b)``, ``a = 0..cols``, covers
    ``[(a - 1) square, a square] x [(b - 1) square, b square]`` and is dark when ``a + b`` is even. The
    outermost squares are ``edge`` cells wide; a white margin of ``margin`` surrounds them (None: one
    square for a full board, none for a cut one). ``dots = g``: a ``g x g`` matrix of dark dots of side
    ``dot`` cells in every white square with inner corners on all four sides, 0.2 of a cell clear of its
    edges, printed or not by a fixed hash of ``(a, b, kx, ky)`` (ECoCheck-like).
    """

    cols: int
    rows: int
    square: float = 1.0
    edge: float = 1.0
    margin: float | None = None
    dots: int = 0
    dot: float = 0.12

    def __post_init__(self):
        if self.margin is None:
            object.__setattr__(self, "margin", self.square if self.edge == 1 else 0.0)

    def labels(self) -> np.ndarray:
        """``(i, j)`` (N, 2) of the inner corners, ``i`` fastest (OpenCV's order)."""
        j, i = np.mgrid[0:self.rows, 0:self.cols]
        return np.stack([i.ravel(), j.ravel()], axis=1).astype(np.int64)

    def object_points(self) -> np.ndarray:
        """Board coordinates (N, 3) of the inner corners."""
        return np.c_[self.labels() * self.square, np.zeros(self.cols * self.rows)]

    def outline(self, per_side: int = 16) -> np.ndarray:
        """Points (4 per_side, 3) along the paper's outer edge (the squares' and the margin)."""
        e, s, m = self.edge * self.square, self.square, self.margin
        u0, u1, v0, v1 = -e - m, (self.cols - 1) * s + e + m, -e - m, (self.rows - 1) * s + e + m
        t = np.linspace(0.0, 1.0, per_side, endpoint=False)
        uv = np.concatenate([np.c_[u0 + (u1 - u0) * t, np.full_like(t, v0)], np.c_[np.full_like(t, u1),
                             v0 + (v1 - v0) * t], np.c_[u1 - (u1 - u0) * t, np.full_like(t, v1)],
                             np.c_[np.full_like(t, u0), v1 - (v1 - v0) * t]])
        return np.c_[uv, np.zeros(len(uv))]


@dataclass(frozen=True)
class View:
    """A rendered view: ``image`` (H, W) uint8; ``corners`` (N, 2) the exact projections of the inner corners
    (x, y; pixel centres at integers); ``labels`` (N, 2); ``inside`` (N,) bool: at least ``border`` px
    inside the frame; the pose ``rvec``, ``tvec``; ``ids``: ChArUco IDs (None for a chessboard)."""

    image: np.ndarray
    corners: np.ndarray
    labels: np.ndarray
    inside: np.ndarray
    rvec: np.ndarray = field(default_factory=lambda: np.zeros(3))
    tvec: np.ndarray = field(default_factory=lambda: np.zeros(3))
    ids: np.ndarray | None = None


def in_frame(corners: np.ndarray, size: tuple[int, int], border: float) -> np.ndarray:
    """Whether each point (N, 2) is finite and at least ``border`` px inside a frame of ``size`` (w, h)."""
    w, h = size
    with np.errstate(invalid="ignore"):
        return (np.all(np.isfinite(corners), axis=1) & (corners[:, 0] >= border) & (corners[:, 1] >= border)
                & (corners[:, 0] <= w - 1 - border) & (corners[:, 1] <= h - 1 - border))


def _undistort(xd: np.ndarray, yd: np.ndarray, dist: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """OpenCV's distortion ``(k1, k2, p1, p2, k3)`` inverted by Newton's method (to 1e-15); NaN off its fold."""
    k1, k2, p1, p2, k3 = dist
    if not np.any(dist):
        return xd, yd
    x, y = xd.copy(), yd.copy()
    with np.errstate(all="ignore"):
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
            dx, dy = (j11 * ex - j01 * ey) / det, (-j01 * ex + j00 * ey) / det
            x, y = x - dx, y - dy
            bad = ~(np.abs(x) < 1e6) | ~(np.abs(y) < 1e6)
            x[bad], y[bad] = np.nan, np.nan
            if not np.any(np.abs(dx) + np.abs(dy) > 1e-15):
                break
    return x, y


def _rays(camera, s: int) -> tuple[np.ndarray, np.ndarray]:
    """The rays ``(x, y, 1)`` of the ``s x s`` samples of every pixel, (h, s, w, s) each: sample ``(a, b)``
    of pixel ``(c, r)`` is at ``(c - 1/2 + (b + 1/2) / s, r - 1/2 + (a + 1/2) / s)``. Kept per camera."""
    key = (camera.K.tobytes(), np.asarray(camera.dist, float).tobytes(), tuple(camera.size), s)
    if key not in _RAYS:
        w, h = camera.size
        K = camera.K
        dist = np.zeros(5)
        dist[:len(camera.dist)] = camera.dist
        o = (np.arange(s) + 0.5) / s
        py = (np.arange(h)[:, None] - 0.5 + o[None, :])[:, :, None, None]
        px = (-0.5 + (np.arange(w * s) + 0.5) / s).reshape(1, 1, w, s)
        yd = np.array(np.broadcast_to((py - K[1, 2]) / K[1, 1], (h, s, w, s)))
        xd = (px - K[0, 2] - K[0, 1] * yd) / K[0, 0]
        for r0 in range(0, h, 32):  # in bands of rows: Newton's temporaries stay small
            xd[r0:r0 + 32], yd[r0:r0 + 32] = _undistort(xd[r0:r0 + 32], yd[r0:r0 + 32], dist)
        if len(_RAYS) >= 2:
            _RAYS.pop(next(iter(_RAYS)))
        _RAYS[key] = xd, yd
    return _RAYS[key]


_RAYS: dict = {}


def _sample_uv(camera, R, t, s: int, rows: slice) -> tuple[np.ndarray, np.ndarray]:
    """Board coordinates (u, v) of the ``s x s`` samples of each pixel of ``rows``, (h, s, w, s) each; NaN
    where the sample's ray misses the board's plane (or meets it behind the camera)."""
    x, y = (a[rows] for a in _rays(camera, s))
    n = R[:, 2]
    with np.errstate(all="ignore"):
        lam = (n @ t) / (n[0] * x + n[1] * y + n[2])
        lam = np.where(lam > 0, lam, np.nan)
        P = (lam * x - t[0], lam * y - t[1], lam - t[2])
    return R[0, 0] * P[0] + R[1, 0] * P[1] + R[2, 0] * P[2], R[0, 1] * P[0] + R[1, 1] * P[1] + R[2, 1] * P[2]


def _overlap(x, r, lo, hi):
    """The fraction of the box ``[x - r, x + r]`` inside ``[lo, hi]``."""
    return np.maximum(np.minimum(x + r, hi) - np.maximum(x - r, lo), 0.0) / (2 * r)


def _parity_cover(x, r, sq, n, lo, hi):
    """Box-filtered indicators of the even and of the odd squares ``0..n`` along one axis, cut to [lo, hi]."""
    a0 = np.floor(x / sq) + 1
    even, odd = np.zeros_like(x), np.zeros_like(x)
    for d in (-1, 0, 1):
        a = a0 + d
        f = np.where((a >= 0) & (a <= n), _overlap(x, r, np.maximum((a - 1) * sq, lo), np.minimum(a * sq, hi)),
                     0.0)
        is_even = np.mod(a, 2) == 0
        even += np.where(is_even, f, 0.0)
        odd += np.where(is_even, 0.0, f)
    return even, odd


def _dot_cover(u, v, ru, rv, board):
    """Box-filtered coverage of the printed dots (:class:`Board`)."""
    sq, g = board.square, board.dots
    d = board.dot * sq
    pitch = (0.6 * sq - d) / max(g - 1, 1)
    first = 0.2 * sq + 0.5 * d
    a0, b0 = np.floor(u / sq) + 1, np.floor(v / sq) + 1
    acc = np.zeros_like(u)
    for da in (-1, 0, 1):
        for db in (-1, 0, 1):
            a, b = a0 + da, b0 + db
            white = (a >= 1) & (a <= board.cols - 1) & (b >= 1) & (b <= board.rows - 1) \
                & (np.mod(a + b, 2) == 1)
            if not white.any():
                continue
            for kx in range(g):
                cu = (a - 1) * sq + first + kx * pitch
                fu = _overlap(u, ru, cu - 0.5 * d, cu + 0.5 * d)
                for ky in range(g):
                    code = a * 1103 + b * 2371 + kx * 313 + ky * 97 + a * b * 7 + kx * ky * 29
                    printed = np.mod(code, 11) < 6
                    cv = (b - 1) * sq + first + ky * pitch
                    acc += np.where(white & printed, fu * _overlap(v, rv, cv - 0.5 * d, cv + 0.5 * d), 0.0)
    return acc


def _reflectance(u, v, ru, rv, board, levels):
    """The board's grey level box-filtered over each sample's footprint ``(ru, rv)`` (exact: the board is a
    sum of products of interval indicators in u and in v)."""
    dark, light, bg = levels
    sq, m, e = board.square, board.margin, board.edge
    ru, rv = np.clip(ru, 1e-9, 0.5 * sq), np.clip(rv, 1e-9, 0.5 * sq)
    lo, hu, hv = -e * sq, (board.cols - 1 + e) * sq, (board.rows - 1 + e) * sq
    with np.errstate(invalid="ignore"):
        pu, pv = _overlap(u, ru, lo - m, hu + m), _overlap(v, rv, lo - m, hv + m)
        eu, ou = _parity_cover(u, ru, sq, board.cols, lo, hu)
        ev, ov = _parity_cover(v, rv, sq, board.rows, lo, hv)
        out = bg + (light - bg) * pu * pv - (light - dark) * (eu * ev + ou * ov)
        if board.dots > 0:  # on the samples within half a square of the inner squares only (else 0)
            ru, rv = np.broadcast_to(ru, u.shape), np.broadcast_to(rv, u.shape)
            near = (u > -0.5 * sq) & (u < board.cols * sq) & (v > -0.5 * sq) & (v < board.rows * sq)
            out[near] -= (light - dark) * _dot_cover(u[near], v[near], ru[near], rv[near], board)
    return np.where(np.isfinite(u), out, bg)


def _footprint(U, V, s):
    """Half-widths (ru, rv) (h, 1, w, 1) of each pixel's sample box along u and v, from the pixel's Jacobian
    d(u, v)/d(x, y) estimated from its corner samples."""
    step = (s - 1) / s

    def jac(A):
        ax = 0.5 * ((A[:, 0, :, -1] - A[:, 0, :, 0]) + (A[:, -1, :, -1] - A[:, -1, :, 0])) / step
        ay = 0.5 * ((A[:, -1, :, 0] - A[:, 0, :, 0]) + (A[:, -1, :, -1] - A[:, 0, :, -1])) / step
        return ax, ay

    (dux, duy), (dvx, dvy) = jac(U), jac(V)
    ru, rv = 0.5 / s * np.hypot(dux, duy), 0.5 / s * np.hypot(dvx, dvy)
    ru, rv = np.where(np.isfinite(ru), ru, 0.0), np.where(np.isfinite(rv), rv, 0.0)
    return ru[:, None, :, None], rv[:, None, :, None]


def render_scene(camera, board: Board, rvec, tvec, *, supersample: int = 4, blur: float = 0.0,
                 falloff: float = 0.0, levels: tuple[float, float, float] = LEVELS) -> np.ndarray:
    """The noise-free image (H, W) float64 of ``board`` at pose ``(rvec, tvec)`` (board -> camera).

    Each pixel is the mean of ``supersample x supersample`` samples on a regular grid inside it; each
    sample's ray (the pinhole's distortion inverted exactly) meets the board's plane, and the board's grey
    level is averaged exactly over a box the size of the sample's footprint there, so that every edge stays
    where it is. Then a Gaussian blur of ``blur`` px and a gain of ``1 - falloff (r / r_max)^2``.
    Renders are kept (the tests render the same views many times): each call gets its own copy.
    """
    if getattr(camera, "model", "pinhole") != "pinhole":
        raise ValueError("the tests' renderer has the pinhole camera only")
    key = (camera.K.tobytes(), np.asarray(camera.dist, float).tobytes(), tuple(camera.size), board,
           np.asarray(rvec, float).tobytes(), np.asarray(tvec, float).tobytes(), supersample, blur, falloff,
           tuple(levels))
    if key not in _SCENES:
        if len(_SCENES) >= 32:
            _SCENES.pop(next(iter(_SCENES)))
        _SCENES[key] = _render_scene(camera, board, rvec, tvec, int(supersample), blur, falloff, levels)
    return _SCENES[key].copy()


_SCENES: dict = {}


def _render_scene(camera, board, rvec, tvec, s, blur, falloff, levels):
    R, t = pose_matrix(rvec, tvec)
    w, h = camera.size
    img = np.empty((h, w))
    for r0 in range(0, h, 32):
        rows = slice(r0, min(r0 + 32, h))
        U, V = _sample_uv(camera, R, t, s, rows)
        ru, rv = _footprint(U, V, s)
        img[rows] = _reflectance(U, V, ru, rv, board, levels).mean(axis=(1, 3))
    if blur > 0:
        k = 2 * int(np.ceil(4 * blur)) + 1
        img = cv2.GaussianBlur(img, (k, k), blur, borderType=cv2.BORDER_REFLECT)
    if falloff > 0:
        yy, xx = np.mgrid[0:h, 0:w]
        r2 = ((xx - (w - 1) / 2) ** 2 + (yy - (h - 1) / 2) ** 2) / (((w - 1) / 2) ** 2 + ((h - 1) / 2) ** 2)
        img = img * (1.0 - falloff * r2)
    return img


def add_noise(image: np.ndarray, noise: float = 0.0, rng=None) -> np.ndarray:
    """Gaussian noise of ``noise`` grey levels (``rng``: a Generator or a seed), rounded, clipped to uint8."""
    img = np.asarray(image, dtype=np.float64)
    if noise > 0:
        gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        img = img + gen.normal(0.0, noise, img.shape)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def render_view(camera, board: Board, rvec, tvec, *, supersample: int = 4, blur: float = 0.0,
                noise: float = 0.0, falloff: float = 0.0, rng=None, border: float = 4.0,
                levels: tuple[float, float, float] = LEVELS) -> View:
    """:func:`render_scene` with noise, rounded to uint8, and the exact projections of the inner corners."""
    img = add_noise(render_scene(camera, board, rvec, tvec, supersample=supersample, blur=blur, falloff=falloff,
                                 levels=levels), noise, rng)
    corners = camera.project(board.object_points(), rvec, tvec)
    return View(img, corners, board.labels(), in_frame(corners, camera.size, border),
                np.asarray(rvec, dtype=np.float64).reshape(3).copy(),
                np.asarray(tvec, dtype=np.float64).reshape(3).copy())


def render_charuco(camera, board, rvec, tvec, *, supersample: int = 4, blur: float = 0.0, noise: float = 0.0,
                   rng=None, border: float = 4.0, texels_per_square: int = 64) -> View:
    """An OpenCV ChArUco board (its ``generateImage``, read at each sample's exact board position, nearest
    texel: the chessboard's edges fall on texel boundaries) in a margin of a square of paper; ``labels`` are
    ``(id % (nx - 1), id // (nx - 1))`` and ``ids`` OpenCV's."""
    s, tps = int(supersample), int(texels_per_square)
    nx, ny = board.getChessboardSize()
    sq = float(board.getSquareLength())
    dark, light, bg = LEVELS
    tex = dark + board.generateImage((nx * tps, ny * tps), marginSize=0, borderBits=1).astype(np.float32) \
        / 255.0 * (light - dark)
    R, t = pose_matrix(rvec, tvec)
    w, h = camera.size
    U, V = (a.reshape(h * s, w * s) for a in _sample_uv(camera, R, t, s, slice(0, h)))
    samples = cv2.remap(tex, (U / sq * tps - 0.5).astype(np.float32), (V / sq * tps - 0.5).astype(np.float32),
                        cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=bg)
    with np.errstate(invalid="ignore"):
        paper = (U >= -sq) & (U <= (nx + 1) * sq) & (V >= -sq) & (V <= (ny + 1) * sq)
        outside = (U < 0) | (U > nx * sq) | (V < 0) | (V > ny * sq)
    samples = np.where(np.isfinite(U), np.where(outside & paper, light, samples), bg)
    img = samples.reshape(h, s, w, s).mean(axis=(1, 3))
    if blur > 0:
        k = 2 * int(np.ceil(4 * blur)) + 1
        img = cv2.GaussianBlur(img, (k, k), blur, borderType=cv2.BORDER_REFLECT)
    obj = np.asarray(board.getChessboardCorners(), dtype=np.float64).reshape(-1, 3)
    ids = np.arange(len(obj))
    corners = camera.project(obj, rvec, tvec)
    return View(add_noise(img, noise, rng), corners, np.stack([ids % (nx - 1), ids // (nx - 1)], axis=1),
                in_frame(corners, camera.size, border), np.asarray(rvec, dtype=np.float64).reshape(3).copy(),
                t.copy(), ids)


def aprilgrid_texture(cols: int, rows: int, spacing: float, margin: int = 10) -> tuple[np.ndarray, int]:
    """Kalibr's AprilGrid as a grid of grey levels, one cell a bit (a tenth of a tag), and the cells from the
    grid's first cell to the top-left tag's top-left corner.

    As ``kalibr_create_target_pdf`` draws it: tag ``t`` at Kalibr's column ``t % cols`` and row ``t // cols``
    (rows counted *up* the printed target), 36h11 with a border of 2 bits, its bits OpenCV's marker ``t``
    turned half a turn; a black square of ``spacing`` tags at each tag corner; white paper ``margin`` cells
    beyond the squares; the background (two cells) around. Cell ``[b, a]`` is ``v`` in ``[b - o, b - o + 1)``,
    ``u`` in ``[a - o, a - o + 1)`` tenths of a tag in the board's frame (``u`` right, ``v`` down, the origin
    at the top-left tag's top-left corner), ``o`` the offset returned."""
    gap = int(round(10 * spacing))
    assert abs(gap - 10 * spacing) < 1e-9, "the renderer draws spacings of whole bits (tenths of a tag)"
    pitch = 10 + gap
    dark, light, bg = LEVELS
    o = 2 + margin + gap
    w, h = (cols - 1) * pitch + 10 + 2 * o, (rows - 1) * pitch + 10 + 2 * o
    tex = np.full((h, w), bg)
    tex[2:h - 2, 2:w - 2] = light
    d = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
    for t in range(cols * rows):
        c, r = t % cols, rows - 1 - t // cols  # r: tag rows counted down
        a, b = o + c * pitch, o + r * pitch
        bits = np.rot90(cv2.aruco.generateImageMarker(d, t, 10, borderBits=2), 2)
        tex[b:b + 10, a:a + 10] = np.where(bits > 0, light, dark)
        for ya in (b - gap, b + 10):
            for xa in (a - gap, a + 10):
                tex[ya:ya + gap, xa:xa + gap] = dark
    return tex, o


def render_aprilgrid(camera, cols: int, rows: int, tag: float, spacing: float, rvec, tvec, *,
                     supersample: int = 4, blur: float = 0.0, noise: float = 0.0, rng=None,
                     border: float = 4.0) -> View:
    """Kalibr's AprilGrid (:func:`aprilgrid_texture`) of tags of side ``tag`` seen through ``camera``, exact:
    each sample's grey level is the grid's box-filtered over the sample's footprint on the board (the
    board is piecewise constant on cells of ``tag / 10``: the box filter is a sum over the cells it
    overlaps, separable in u and v). ``corners``: the exact projections of Kalibr's points ``0 .. 4 cols
    rows - 1`` (``ids``) at the board coordinates ``(x, Y - y)`` (Kalibr's ``(x, y)``, ``Y`` the top row's
    top edge); ``labels`` those coordinates in tenths of ``tag`` when ``10 spacing`` is whole."""
    s = int(supersample)
    tex, o = aprilgrid_texture(cols, rows, spacing)
    cell = tag / 10
    R, t = pose_matrix(rvec, tvec)
    w, h = camera.size
    img = np.empty((h, w))
    th, tw = tex.shape
    for r0 in range(0, h, 32):
        rows_ = slice(r0, min(r0 + 32, h))
        U, V = _sample_uv(camera, R, t, s, rows_)
        ru, rv = _footprint(U, V, s)
        ru, rv = np.clip(ru, 1e-9, 0.5 * cell), np.clip(rv, 1e-9, 0.5 * cell)
        ru, rv = np.broadcast_to(ru, U.shape), np.broadcast_to(rv, U.shape)
        ok = np.isfinite(U) & np.isfinite(V)
        uu, vv = np.where(ok, U / cell + o, -1e6), np.where(ok, V / cell + o, -1e6)
        uu, vv = np.clip(uu, -4.0, tw + 4.0), np.clip(vv, -4.0, th + 4.0)
        a0, b0 = np.floor(uu).astype(np.int64), np.floor(vv).astype(np.int64)
        acc = np.zeros_like(uu)
        for da in (-1, 0, 1):
            a = a0 + da
            fu = _overlap(uu, ru / cell, a, a + 1)
            for db in (-1, 0, 1):
                b = b0 + db
                f = fu * _overlap(vv, rv / cell, b, b + 1)
                inside = (a >= 0) & (a < tw) & (b >= 0) & (b < th)
                acc += f * np.where(inside, tex[np.clip(b, 0, th - 1), np.clip(a, 0, tw - 1)], LEVELS[2])
        img[rows_] = np.where(ok, acc, LEVELS[2]).mean(axis=(1, 3))
    if blur > 0:
        k = 2 * int(np.ceil(4 * blur)) + 1
        img = cv2.GaussianBlur(img, (k, k), blur, borderType=cv2.BORDER_REFLECT)
    k = np.arange(4 * cols * rows)
    gc, gr = k % (2 * cols), k // (2 * cols)
    pitch = 1 + spacing
    x = (gc // 2) * pitch + (gc % 2)
    y = (gr // 2) * pitch + (gr % 2)
    top = (rows - 1) * pitch + 1
    obj = np.c_[x * tag, (top - y) * tag, np.zeros(len(k))]
    corners = camera.project(obj, rvec, tvec)
    labels = np.rint(np.c_[x, top - y] * 10).astype(np.int64)
    return View(add_noise(img, noise, rng), corners, labels, in_frame(corners, camera.size, border),
                np.asarray(rvec, dtype=np.float64).reshape(3).copy(), t.copy(), k)


def camera_for(width: int, height: int, hfov_deg: float = 60.0,
               dist: tuple = (-0.22, 0.08, 0.0008, -0.0006)) -> Camera:
    """A ``width x height`` camera of ``hfov_deg`` degrees across, its principal point a little off the
    image's centre and ``fy = 0.998 fx``."""
    fx = (width / 2) / np.tan(np.radians(hfov_deg) / 2)
    cx, cy = (width - 1) / 2 + 0.013 * width, (height - 1) / 2 - 0.011 * height
    return Camera(np.array([[fx, 0.0, cx], [0.0, 0.998 * fx, cy], [0.0, 0.0, 1.0]]), dist, (width, height))


def random_poses(camera, board: Board, n_views: int, *, tilt_max: float = 40.0, seed: int = 0,
                 partial: float = 0.0, cell_px: tuple[float, float] | None = None, roll_max: float = 30.0,
                 keep: float = 4.0) -> list[tuple[np.ndarray, np.ndarray]]:
    """Random board poses ``(rvec, tvec)``: tilted by up to ``tilt_max`` degrees about a random axis in the
    board's plane, rolled by up to ``roll_max``, its squares ``cell_px`` px wide at its centre (None: the
    board spans 35-85 % of the image's shorter side), its paper at least ``keep`` px inside the frame; the
    last ``round(partial n_views)`` views cut by the frame, with 30-75 % of the inner corners inside."""
    rng = np.random.default_rng(seed)
    n_cut = int(round(partial * n_views))
    return [_draw_pose(camera, board, rng, tilt_max, roll_max, cell_px, keep, cut=k >= n_views - n_cut)
            for k in range(int(n_views))]


def _draw_pose(camera, board, rng, tilt_max, roll_max, cell_px, keep, cut):
    w, h = camera.size
    centre = np.array([(board.cols - 1) / 2, (board.rows - 1) / 2, 0.0]) * board.square
    span = (max(board.cols, board.rows) + 1) * board.square
    outline, obj = board.outline(), board.object_points()
    for _ in range(400):
        axis = rng.uniform(0, 2 * np.pi)
        tilt = np.radians(rng.uniform(0, tilt_max))
        roll = np.radians(rng.uniform(-roll_max, roll_max))
        R = cv2.Rodrigues(np.array([np.cos(axis), np.sin(axis), 0.0]) * tilt)[0] @ \
            cv2.Rodrigues(np.array([0.0, 0.0, roll]))[0]
        if cell_px is not None:
            z = camera.fx * board.square / rng.uniform(*cell_px)
        else:
            z = camera.fx * span / (rng.uniform(0.35, 0.85) * min(w, h))
        ray = camera.undistort(np.array([[rng.uniform(0, w - 1), rng.uniform(0, h - 1)]]))[0]
        if not np.all(np.isfinite(ray)):
            continue
        t = z * np.array([ray[0], ray[1], 1.0]) - R @ centre
        rvec = cv2.Rodrigues(R)[0].ravel()
        edge = camera.project(outline, rvec, t)
        if not np.all(np.isfinite(edge)):
            continue
        if cut:
            if 0.3 <= in_frame(camera.project(obj, rvec, t), camera.size, keep).mean() <= 0.75:
                return rvec, t
        elif np.all((edge >= keep) & (edge <= np.array([w - 1, h - 1]) - keep)):
            return rvec, t
    raise ValueError(f"could not place a {board.cols}x{board.rows} board in a {w}x{h} frame")


class Renderer:
    """The tests' renderer, no evaluation code (hashable: a test's cached helper may take it)."""

    Board, View, Camera, LEVELS = Board, View, Camera, LEVELS
    render_view, render_scene, add_noise = staticmethod(render_view), staticmethod(render_scene), \
        staticmethod(add_noise)
    render_charuco, random_poses = staticmethod(render_charuco), staticmethod(random_poses)
    render_aprilgrid, aprilgrid_texture = staticmethod(render_aprilgrid), staticmethod(aprilgrid_texture)
    camera_for, in_frame = staticmethod(camera_for), staticmethod(in_frame)


@pytest.fixture(scope="session")
def render():
    """The tests' renderer: :class:`Board`, :class:`View`, :func:`render_view`, :func:`render_scene`,
    :func:`add_noise`, :func:`render_charuco`, :func:`render_aprilgrid`, :func:`aprilgrid_texture`,
    :func:`random_poses`, :func:`camera_for`, :func:`in_frame`,
    ``Camera`` and ``LEVELS``."""
    return Renderer()


# ---------------------------------------------------------------------------------------------
# the reports' figures as drawn, for the tests of their layout


def _hidden_tick_labels(fig) -> set[int]:
    """The ids of the tick labels whose place cannot be measured: beyond their axis's limits (kept, not
    drawn), or of a 3-D axes."""
    hidden = set()
    for ax in fig.axes:
        if hasattr(ax, "zaxis"):  # a 3-D axes places its tick labels while drawing: their extents are not kept
            hidden |= {id(t) for axis in (ax.xaxis, ax.yaxis, ax.zaxis)
                       for t in (*axis.get_majorticklabels(), *axis.get_minorticklabels())}
            continue
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            pairs = [*zip(axis.get_majorticklocs(), axis.get_majorticklabels()),
                     *zip(axis.get_minorticklocs(), axis.get_minorticklabels())]
            slack = 1e-9 * max(abs(lo), abs(hi), 1.0)
            hidden |= {id(t) for loc, t in pairs if not lo - slack <= loc <= hi + slack}
    return hidden


def text_overlaps(fig) -> list[str]:
    """Each drawn text of ``fig`` that leaves the figure, or runs over an axes other than its own (a colour
    bar beside a title)."""
    from matplotlib.text import Text

    out = []
    renderer = fig.canvas.get_renderer()
    frame = fig.bbox
    hidden = _hidden_tick_labels(fig)
    for t in fig.findobj(Text):
        if not t.get_visible() or not t.get_text().strip() or id(t) in hidden:
            continue
        box = t.get_window_extent(renderer)
        if min(box.x0 - frame.x0, box.y0 - frame.y0, frame.x1 - box.x1, frame.y1 - box.y1) < -1:
            out.append(f"{t.get_text()!r} leaves the figure")
        own = t.axes
        for ax in fig.axes:
            if ax is not own and own is not None and ax.get_visible() and box.overlaps(ax.bbox):
                out.append(f"{t.get_text()!r} runs over another axes")
    return out


@pytest.fixture
def drawn_figures(monkeypatch):
    """Every figure the reports save, by file name, drawn and kept open (``save_figure`` still writes it);
    ``.overlaps(fig)``: :func:`text_overlaps`."""
    import matplotlib.pyplot as plt

    import sogdd.calib.figures as figures
    import sogdd.calib.report_figures as report_figures
    import sogdd.calib.rig.report as rig_report

    kept: dict = {}

    def keep(fig, path):
        fig.canvas.draw()
        if path.name in kept:  # another camera's figure of that name: the last one is kept
            plt.close(kept[path.name])
        kept[path.name] = fig
        figures.atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=100, format="png"))

    for module in (figures, report_figures, rig_report):
        monkeypatch.setattr(module, "save_figure", keep)
    yield SimpleNamespace(figures=kept, overlaps=text_overlaps)
    for fig in kept.values():
        plt.close(fig)
