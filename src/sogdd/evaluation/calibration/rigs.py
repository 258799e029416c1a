"""Rendered camera rigs with exact ground truth: the cameras, their poses, board poses they see, sessions.

A rig (:class:`RigSpec`) is a list of cameras, each a :class:`~sogdd.calib.cameras.Camera`
(intrinsics, OpenCV distortion ``k1, k2, p1, p2``, image size) and its pose in the first
camera's frame, :math:`x_k = R_k\\,x_0 + T_k` (the first camera: identity, zero), in mm.
The board is a 9 x 6 inner-corner chessboard of 25 mm squares. A board pose
:math:`x_0 = R_b X + t_b` in the first camera's frame is seen by camera ``k`` at
:math:`(R_k R_b,\\; R_k t_b + T_k)`, rendered by :func:`.render.render_view` (4 x 4
supersampling, blur, illumination falloff, noise, as the mono sequences); the ground
truth is each camera's exact projection of the inner corners.

========== ======= =========== ================ =========== ========= ========================
name       cameras image       baseline (mm)    toe-in      frames    distance (mm)
========== ======= =========== ================ =========== ========= ========================
parallel   2       1280 x 960  120              0           16        450-1100
convergent 2       640 x 480   300              16 deg      16        550-1300
trio       3       640 x 480   60, 250          0, 12 deg   16        450-1200
========== ======= =========== ================ =========== ========= ========================

Each camera has its own focal length, principal point and distortion. Frames are of
three kinds (:func:`rig_poses`): *full* (every camera sees the whole board, its margin
included), *cut* (one camera's frame cuts the board: 30-75 % of its corners inside,
the others see it whole) and *some* (one camera sees fewer than 9 of the 54 corners, or
none: too few for any detector, so the board is seen by only the others).
Each rig's last frames are cut, the ones before them seen by only some cameras
(:attr:`RigSpec.cut`, :attr:`RigSpec.some`).

A *session* (:func:`render_rig_session`) is one calibration's data: every frame's board
pose drawn, the grey levels of the board and the background drawn (dark 25-50, paper
190-230, background 60-180), the illumination falloff drawn (0.1-0.4), and each image's
noise drawn, all from the session's seed: two seeds give independent sessions, as two
people calibrating the same rig would (noise draws of one rendering alone would keep
every corner's systematic error and understate the spread).
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field

import cv2
import numpy as np

from ...calib.cameras import Camera
from .render import RenderedView, render_view
from .target import ChessboardTarget, in_frame

__all__ = ["RigCameraSpec", "RigSpec", "RigFrame", "RigSession", "RIGS", "QUICK_RIGS", "rigs", "rig_poses",
           "render_rig_session", "toe_in", "board_in_camera"]

FrameKind = str  # "full", "cut" or "some"


@dataclass(frozen=True)
class RigCameraSpec:
    """One camera of a rendered rig: name, true camera, pose ``x_cam = R x_first + T`` (mm)."""

    name: str
    camera: Camera
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    T: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        R = np.asarray(self.R, dtype=np.float64).reshape(3, 3)
        T = np.asarray(self.T, dtype=np.float64).reshape(3)
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
            raise ValueError("R must be a rotation matrix")
        object.__setattr__(self, "R", R)
        object.__setattr__(self, "T", T)

    @property
    def centre(self) -> np.ndarray:
        """The camera's centre in the first camera's frame, :math:`-R^T T`."""
        return -self.R.T @ self.T


@dataclass(frozen=True)
class RigSpec:
    """A rendered rig: cameras (the first is the reference), board, frames and how they are rendered."""

    name: str
    cameras: tuple[RigCameraSpec, ...]
    target: ChessboardTarget = field(default_factory=lambda: ChessboardTarget(9, 6, 25.0))
    n_frames: int = 16
    distance: tuple[float, float] = (600.0, 1400.0)
    blur: float = 0.8
    noise: float = 2.0
    cut: int = 2
    some: int = 2
    tilt_max: float = 40.0
    note: str = ""

    def __post_init__(self) -> None:
        if len(self.cameras) < 2:
            raise ValueError(f"a rig needs >= 2 cameras, got {len(self.cameras)}")
        names = [c.name for c in self.cameras]
        if len(set(names)) != len(names):
            raise ValueError(f"camera names must differ, got {names}")
        if not np.allclose(self.cameras[0].R, np.eye(3)) or np.any(self.cameras[0].T != 0):
            raise ValueError("the first camera is the reference: identity R, zero T")

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.cameras)

    def camera(self, name: str) -> RigCameraSpec:
        for c in self.cameras:
            if c.name == name:
                return c
        raise KeyError(f"no camera {name!r} in rig {self.name}; it has {', '.join(self.names)}")

    def baseline(self, name: str) -> float:
        """:math:`\\lVert T \\rVert` of camera ``name`` (mm)."""
        return float(np.linalg.norm(self.camera(name).T))


@dataclass(frozen=True)
class RigFrame:
    """One frame: the board's pose in the first camera's frame, its kind, and each camera's view."""

    rvec: np.ndarray
    tvec: np.ndarray
    kind: FrameKind
    views: dict[str, RenderedView]


@dataclass(frozen=True)
class RigSession:
    """One calibration session of a rig: its frames (seeded by ``seed``)."""

    spec: RigSpec
    seed: int
    frames: tuple[RigFrame, ...]

    def images(self, name: str) -> list[np.ndarray]:
        """Camera ``name``'s images, one per frame."""
        return [f.views[name].image for f in self.frames]


def toe_in(degrees: float) -> np.ndarray:
    """The rotation of a camera turned by ``degrees`` about its ``y`` axis (positive: its axis turns to -x).

    A camera right of the first one (``+x``) turned by a positive angle looks inwards, towards it.

    Examples
    --------
    >>> R = toe_in(90.0)
    >>> np.round(R.T @ [0, 0, 1.0], 12).tolist()  # its optical axis, in the first camera's frame
    [-1.0, 0.0, 0.0]
    """
    a = math.radians(degrees)
    # x_cam = R x_first: the camera's axis R^T (0, 0, 1) = (-sin a, 0, cos a)
    return cv2.Rodrigues(np.array([0.0, a, 0.0]))[0]


def board_in_camera(cam: RigCameraSpec, rvec: np.ndarray, tvec: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The board's pose ``(rvec, tvec)`` in camera ``cam``'s frame from its pose in the first camera's frame.

    Examples
    --------
    >>> c = RigCameraSpec("b", Camera(np.diag([500.0, 500, 1]), (0, 0, 0, 0), (640, 480)), T=[-100.0, 0, 0])
    >>> r, t = board_in_camera(c, np.zeros(3), np.array([0.0, 0, 1000]))
    >>> t.tolist()
    [-100.0, 0.0, 1000.0]
    """
    Rb = cv2.Rodrigues(np.asarray(rvec, dtype=np.float64).reshape(3))[0]
    return cv2.Rodrigues(cam.R @ Rb)[0].ravel(), cam.R @ np.asarray(tvec, dtype=np.float64).reshape(3) + cam.T


def _camera(size, hfov, dist, pp=(0.013, -0.011), aspect=0.998) -> Camera:
    w, h = size
    fx = (w / 2) / math.tan(math.radians(hfov) / 2)
    K = np.array([[fx, 0.0, (w - 1) / 2 + pp[0] * w], [0.0, aspect * fx, (h - 1) / 2 + pp[1] * h], [0, 0, 1]])
    return Camera(K, dist, (w, h))


def _placed(name, camera, x_mm, toe_deg=0.0, y_mm=0.0, roll_deg=0.0) -> RigCameraSpec:
    """A camera at ``(x_mm, y_mm, 0)`` in the first camera's frame, turned inwards by ``toe_deg``."""
    R = cv2.Rodrigues(np.array([0.0, 0.0, math.radians(roll_deg)]))[0] @ toe_in(toe_deg)
    centre = np.array([x_mm, y_mm, 0.0])
    return RigCameraSpec(name, camera, R, -R @ centre)


_D0 = (-0.22, 0.08, 0.0008, -0.0006)
_D1 = (-0.14, 0.03, -0.0005, 0.0009)
_D2 = (-0.30, 0.12, 0.0012, 0.0004)

#: the full evaluation's rigs, by name (module doc)
RIGS: dict[str, RigSpec] = {r.name: r for r in (
    RigSpec("parallel", (
        _placed("left", _camera((1280, 960), 60.0, _D0), 0.0),
        _placed("right", _camera((1280, 960), 56.0, _D1, pp=(-0.008, 0.006), aspect=1.001), 120.0, 0.0, 1.5,
                0.8),
    ), distance=(450.0, 1100.0), note="2 cameras, 1280x960, parallel, baseline 120 mm"),
    RigSpec("convergent", (
        _placed("left", _camera((640, 480), 52.0, _D1), 0.0),
        _placed("right", _camera((640, 480), 48.0, _D0, pp=(0.01, 0.012)), 300.0, 16.0, -2.0, -1.0),
    ), distance=(550.0, 1300.0), note="2 cameras, 640x480, toe-in 16 deg, baseline 300 mm"),
    RigSpec("trio", (
        _placed("a", _camera((640, 480), 58.0, _D0), 0.0),
        _placed("b", _camera((640, 480), 62.0, _D2, pp=(-0.012, 0.004), aspect=1.002), 60.0, 0.0, 0.0, 1.0),
        _placed("c", _camera((640, 480), 54.0, _D1, pp=(0.006, -0.014)), 250.0, 12.0, 4.0, -0.5),
    ), distance=(450.0, 1200.0), note="3 cameras, 640x480, baselines 60 and 250 mm, the third toed in 12 deg"),
)}

#: small rigs for tests and CI
QUICK_RIGS: dict[str, RigSpec] = {r.name: r for r in (
    RigSpec("quick", RIGS["convergent"].cameras, n_frames=6, cut=1, some=1, distance=(550.0, 1200.0),
            note="quick: the convergent rig, 6 frames"),
)}


def rigs(names: list[str] | None = None, *, quick: bool = False) -> list[RigSpec]:
    """The rigs to run: ``names`` of :data:`RIGS` (None: all), or the quick set.

    Examples
    --------
    >>> [r.name for r in rigs(["trio"])], [len(r.cameras) for r in rigs(quick=True)]
    (['trio'], [2])
    """
    table = QUICK_RIGS if quick else RIGS
    if names is None:
        return list(table.values())
    bad = [n for n in names if n not in table]
    if bad:
        raise ValueError(f"unknown rig(s) {', '.join(bad)}; known: {', '.join(table)}")
    return [table[n] for n in names]


def _seed(*parts: object) -> int:
    return zlib.crc32("/".join(str(p) for p in parts).encode())


#: a camera with fewer corners inside than this does not see the board (no detector reads so few as a board)
_FEW = 9


def _visibility(spec: RigSpec, rvec, tvec, keep: float) -> tuple[list[str], np.ndarray]:
    """Per camera: "full", "cut" (30-75 % of corners inside), "none" (fewer than :data:`_FEW` corners inside,
    or none) or "bad"; the fractions inside."""
    t = spec.target
    obj, outline = t.object_points(), t.outline(with_margin=True)
    Rb = cv2.Rodrigues(np.asarray(rvec))[0]
    normal = Rb[:, 2]
    out, frac = [], []
    for c in spec.cameras:
        r, tc = board_in_camera(c, rvec, tvec)
        # the front of the board faces the camera, and not too obliquely for a detector
        view = (c.R @ np.asarray(tvec) + c.T)
        n_c = c.R @ normal
        cosang = float(n_c @ view / np.linalg.norm(view))
        if cosang < math.cos(math.radians(62)):
            out.append("bad")
            frac.append(0.0)
            continue
        pts = c.camera.project(obj, r, tc)
        edge = c.camera.project(outline, r, tc)
        inside = in_frame(pts, c.camera.size, keep)
        w, h = c.camera.size
        with np.errstate(invalid="ignore"):
            lim = np.array([w - 1, h - 1]) - keep
            whole = np.all(np.isfinite(edge)) and np.all((edge >= keep) & (edge <= lim))
            gone = np.all(np.isfinite(edge)) and not np.any(in_frame(edge, c.camera.size, 0.0))
        f = float(inside.mean())
        frac.append(f)
        few = int(inside.sum()) < _FEW
        out.append("full" if whole else "cut" if 0.3 <= f <= 0.75 else "none" if gone or few else "bad")
    return out, np.array(frac)


def _kind_ok(kind: FrameKind, vis: list[str]) -> bool:
    if kind == "full":
        return all(v == "full" for v in vis)
    if kind == "cut":
        return vis.count("cut") == 1 and vis.count("full") == len(vis) - 1
    return vis.count("none") == 1 and vis.count("full") == len(vis) - 1


def _frame_kinds(spec: RigSpec, n: int) -> list[FrameKind]:
    scale = n / spec.n_frames
    n_cut = min(n, int(round(spec.cut * scale)))
    n_some = min(n - n_cut, int(round(spec.some * scale)))
    return ["full"] * (n - n_cut - n_some) + ["some"] * n_some + ["cut"] * n_cut


def rig_poses(spec: RigSpec, n_frames: int | None = None, seed: int = 0, *, keep: float = 4.0,
              tries: int = 4000) -> list[tuple[np.ndarray, np.ndarray, FrameKind]]:
    """Board poses ``(rvec, tvec, kind)`` in the first camera's frame for ``n_frames`` frames (module doc).

    Each draw picks a camera at random, a pixel of its image and a distance in
    ``spec.distance`` (up to 1.5 times as far for a *some* frame) along that
    pixel's ray for the board's centre; the board faces that camera, tilted by
    up to ``tilt_max`` degrees about a random axis in its plane and rolled by up
    to 30 degrees. A draw is kept when every camera sees it as the frame's kind
    asks (and no camera sees it more than 62 degrees off face-on); a frame that
    cannot be placed in ``tries`` draws is a ``ValueError``.

    Examples
    --------
    >>> poses = rig_poses(RIGS["convergent"], 8, seed=1)  # 2 of the rig's 16 frames are cut, 2 seen by some
    >>> [k for _, _, k in poses]
    ['full', 'full', 'full', 'full', 'full', 'full', 'some', 'cut']
    """
    n = spec.n_frames if n_frames is None else int(n_frames)
    if n < 1:
        raise ValueError(f"n_frames must be >= 1, got {n_frames}")
    rng = np.random.default_rng(seed)
    t = spec.target
    centre = np.array([(t.cols - 1) / 2, (t.rows - 1) / 2, 0.0]) * t.square
    out = []
    for kind in _frame_kinds(spec, n):
        for _ in range(tries):
            cam = spec.cameras[int(rng.integers(len(spec.cameras)))]
            w, h = cam.camera.size
            ray = cam.camera.rays(np.array([[rng.uniform(0, w - 1), rng.uniform(0, h - 1)]]))[0]
            # a board that one camera misses and another sees whole lies far or off to the side
            z = rng.uniform(spec.distance[0], spec.distance[1] * (1.5 if kind == "some" else 1.0))
            axis = rng.uniform(0, 2 * np.pi)
            tilt = math.radians(rng.uniform(0, spec.tilt_max))
            roll = math.radians(rng.uniform(-30, 30))
            Rc = cv2.Rodrigues(np.array([np.cos(axis), np.sin(axis), 0.0]) * tilt)[0] @ \
                cv2.Rodrigues(np.array([0.0, 0.0, roll]))[0]
            pc = ray / ray[2] * z - Rc @ centre  # the board's origin in the drawing camera's frame
            R0 = cam.R.T @ Rc
            t0 = cam.R.T @ (pc - cam.T)
            rvec = cv2.Rodrigues(R0)[0].ravel()
            vis, _ = _visibility(spec, rvec, t0, keep)
            if _kind_ok(kind, vis):
                out.append((rvec, t0, kind))
                break
        else:
            raise ValueError(f"rig {spec.name}: could not place a {kind!r} frame in {tries} draws")
    return out


def render_rig_session(spec: RigSpec, n_frames: int | None = None, seed: int = 0, *, supersample: int = 4,
                       blur: float | None = None, noise: float | None = None) -> RigSession:
    """One session of ``spec`` (module doc): ``n_frames`` frames (default ``spec.n_frames``) from ``seed``.

    Every camera renders every frame (a camera that does not see the board
    renders the background); each view's ``corners`` are that camera's exact
    projection of the inner corners and ``inside`` says which lie in its frame.

    Examples
    --------
    >>> s = render_rig_session(QUICK_RIGS["quick"], 2, seed=3)
    >>> len(s.frames), s.frames[0].views["right"].image.shape
    (2, (480, 640))
    """
    rng = np.random.default_rng(_seed("levels", spec.name, seed))
    levels = (rng.uniform(25, 50), rng.uniform(190, 230), rng.uniform(60, 180))
    falloff = rng.uniform(0.1, 0.4)
    frames = []
    for f, (rvec, tvec, kind) in enumerate(rig_poses(spec, n_frames, _seed("poses", spec.name, seed))):
        views = {}
        for c in spec.cameras:
            r, t = board_in_camera(c, rvec, tvec)
            views[c.name] = render_view(c.camera, spec.target, r, t, supersample=supersample,
                                        blur=spec.blur if blur is None else blur,
                                        noise=spec.noise if noise is None else noise, falloff=falloff,
                                        rng=_seed("noise", spec.name, seed, f, c.name), levels=levels)
        frames.append(RigFrame(rvec, tvec, kind, views))
    return RigSession(spec, int(seed), tuple(frames))
