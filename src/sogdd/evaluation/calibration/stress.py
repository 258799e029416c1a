"""Stress scenes for chessboard detectors: rendered views that break naive detectors, with exact ground truth.

Usage
-----
>>> from sogdd.evaluation.calibration.stress import STRESS_SCENES, stress_scene
>>> sc = stress_scene("edge", rng=0)            # doctest: +SKIP
>>> sc.image, sc.corners, sc.labels, sc.inside, sc.pattern, sc.camera   # doctest: +SKIP

``stress_scene(name, rng=None, *, noise=2.0, blur=0.7) -> StressScene`` renders one
view of the named case (``rng``: a ``numpy.random.Generator`` or a seed; it
draws the pose and the noise, so a seed gives the same image every time).
``STRESS_SCENES`` lists the names:

==============  ===========================================================================
name            what it stresses
==============  ===========================================================================
``edge``        the outermost row and column of squares cut to 0.3-0.6 of a cell by the
                paper's edge, background right beyond (``ChessboardTarget(edge=...)``)
``background``  a second, small board (cells 3-5 px) in the background, not overlapping
                the main board (a screen showing the board); its truth is in ``others``
``fisheye``     an equidistant fisheye (``r = f theta``) covering >= 160 degrees, the board
                near the rim (its centre 55-75 degrees off the axis)
``dots``        a 3 x 3 matrix of dark dots in every inner white square (ECoCheck-like),
                0.2 of a cell clear of the square's edges and corners
``jpeg``        640 x 480, cells 20-30 px, encoded and decoded as JPEG at quality 75
==============  ===========================================================================

:class:`StressScene` fields: ``name``; ``image`` (H, W) uint8, the image to
detect on; ``corners`` (N, 2) float64 the exact projections (x = column,
y = row, pixel centres at integers) of the main board's inner corners;
``labels`` (N, 2) int64 their ``(i, j)`` (``i`` fastest, OpenCV's order);
``inside`` (N,) bool: in the frame and >= 4 px from its edges (score only
these); ``pattern`` ``(cols, rows)``, the main board's inner corners (OpenCV's
``patternSize``); ``camera`` (:class:`~sogdd.calib.cameras.Camera`, with
``camera.model`` ``"pinhole"`` or ``"fisheye"``); ``target``; ``rvec``,
``tvec`` the main board's pose; ``others``: tuple of :class:`OtherBoard`
(``corners``, ``labels``, ``pattern``) for boards that must *not* be returned as
the view's board (the background board). The main board is always the only
board with ``pattern``'s size, except in ``background``, where the small board
has the same pattern on purpose.

The calibration evaluation runs them as one sequence: ``sogdd eval calibration
--sequences stress`` (:data:`.sequences.SEQUENCES` ``["stress"]``, a
:class:`StressSequence` of ``views_per_scene`` views of each scene).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import cv2
import numpy as np

from .render import (
    Camera,
    ChessboardTarget,
    add_noise,
    camera_for,
    in_frame,
    jpeg_roundtrip,
    random_sequence,
    render_scene,
)

__all__ = ["STRESS_SCENES", "StressName", "OtherBoard", "StressScene", "StressSequence", "stress_camera",
           "stress_scene", "stress_poses", "render_stress"]

#: the stress cases' names
StressName = Literal["edge", "background", "fisheye", "dots", "jpeg"]
STRESS_SCENES: tuple[StressName, ...] = ("edge", "background", "fisheye", "dots", "jpeg")

_SIZE = (640, 480)
_BORDER = 4.0


@dataclass(frozen=True)
class OtherBoard:
    """A board in the view that is not the one to detect: its corners' projections (N, 2), labels, size."""

    corners: np.ndarray
    labels: np.ndarray
    pattern: tuple[int, int]
    target: ChessboardTarget
    rvec: np.ndarray
    tvec: np.ndarray


@dataclass(frozen=True)
class StressScene:
    """One rendered stress view and its exact ground truth (module doc)."""

    name: str
    image: np.ndarray
    corners: np.ndarray
    labels: np.ndarray
    inside: np.ndarray
    pattern: tuple[int, int]
    camera: Camera
    target: ChessboardTarget
    rvec: np.ndarray
    tvec: np.ndarray
    others: tuple[OtherBoard, ...] = ()
    jpeg: int | None = None
    note: str = ""
    clean: np.ndarray | None = field(default=None, repr=False)


def stress_camera(name: StressName) -> Camera:
    """The scene's camera: 640 x 480; a pinhole of 60 degrees with the sequences' distortion, or for
    ``fisheye`` an equidistant fisheye (``k = 0``) of ``f = 190`` px: 193 degrees across the width
    (:math:`\\theta = 320 / 190` rad at the frame's side), 80 degrees off the axis at 264 px.

    Examples
    --------
    >>> cam = stress_camera("fisheye")
    >>> cam.model, cam.size, round(cam.fx, 1)
    ('fisheye', (640, 480), 190.0)
    """

    if name == "fisheye":
        K = np.array([[190.0, 0.0, 322.3], [0.0, 189.8, 237.9], [0.0, 0.0, 1.0]])
        return Camera(K, (0.0, 0.0, 0.0, 0.0), _SIZE, model="fisheye")
    return camera_for(*_SIZE)


def _target(name: StressName, rng: np.random.Generator) -> ChessboardTarget:
    if name == "edge":
        return ChessboardTarget(7, 5, 0.02, edge=float(rng.uniform(0.3, 0.6)))
    if name == "dots":
        return ChessboardTarget(7, 5, 0.02, dots=3, dot=0.12)
    if name == "jpeg":
        return ChessboardTarget(9, 6, 0.02)
    if name == "fisheye":
        return ChessboardTarget(7, 5, 0.03)
    return ChessboardTarget(7, 5, 0.02)


def _cells(name: StressName) -> tuple[float, float]:
    return {"edge": (22.0, 34.0), "background": (22.0, 30.0), "dots": (30.0, 40.0),
            "jpeg": (20.0, 30.0)}.get(name, (22.0, 34.0))


def stress_poses(name: StressName, target: ChessboardTarget, rng: np.random.Generator
                 ) -> tuple[np.ndarray, np.ndarray, tuple[OtherBoard, ...]]:
    """The main board's pose ``(rvec, tvec)`` and the other boards of scene ``name``, drawn from ``rng``."""
    cam = stress_camera(name)
    if name == "fisheye":
        return (*_fisheye_pose(cam, target, rng), ())
    for _ in range(50):
        rvec, tvec = random_sequence(cam, target, 1, seed=int(rng.integers(2**31)), cell_px=_cells(name),
                                     tilt_max=35.0)[0]
        if name != "background":
            return rvec, tvec, ()
        other = _background_board(cam, target, rvec, tvec, rng)
        if other is not None:
            return rvec, tvec, (other,)
    raise ValueError(f"could not place the boards of stress scene {name!r}")


def _box(cam: Camera, target: ChessboardTarget, rvec, tvec, pad: float) -> np.ndarray:
    """The board's paper's bounding box in the image ``(x0, y0, x1, y1)``, grown by ``pad`` px."""
    pts = cam.project(target.outline(with_margin=True), rvec, tvec)
    return np.concatenate([pts.min(axis=0) - pad, pts.max(axis=0) + pad])


def _background_board(cam, target, rvec, tvec, rng) -> OtherBoard | None:
    """A board of the same pattern with cells of 3-5 px, three times farther than the main board, in a
    free part of the frame: its paper's box and the main board's, 6 px apart, do not overlap."""
    main = _box(cam, target, rvec, tvec, 6.0)
    w, h = cam.size
    z = 3.0 * float(tvec[2])
    for _ in range(60):
        cell = rng.uniform(3.2, 4.8)
        small = ChessboardTarget(target.cols, target.rows, cell * z / cam.fx)
        roll = rng.uniform(-0.4, 0.4)
        R = cv2.Rodrigues(np.array([rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), 0.0]))[0] @ \
            cv2.Rodrigues(np.array([0.0, 0.0, roll]))[0]
        px = np.array([[rng.uniform(30, w - 31), rng.uniform(30, h - 31)]])
        ray = cam.undistort(px)[0]
        centre = np.array([(small.cols - 1) / 2, (small.rows - 1) / 2, 0.0]) * small.square
        t2 = z * np.array([ray[0], ray[1], 1.0]) - R @ centre
        r2 = cv2.Rodrigues(R)[0].ravel()
        box = _box(cam, small, r2, t2, 0.0)
        inside = bool(np.all(box[:2] >= _BORDER) and np.all(box[2:] <= np.array([w - 1, h - 1]) - _BORDER))
        apart = box[2] < main[0] or box[0] > main[2] or box[3] < main[1] or box[1] > main[3]
        if inside and apart:
            corners = cam.project(small.object_points(), r2, t2)
            return OtherBoard(corners, small.labels(), small.pattern_size, small, r2, t2)
    return None


def _fisheye_pose(cam: Camera, target: ChessboardTarget, rng: np.random.Generator):
    """A pose near the fisheye's rim: the board's centre 55-75 degrees off the axis, roughly along the
    frame's width, 0.2-0.3 m away, facing the camera within 30 degrees, its paper inside the frame."""
    centre = np.array([(target.cols - 1) / 2, (target.rows - 1) / 2, 0.0]) * target.square
    w, h = cam.size
    for _ in range(400):
        off = np.radians(rng.uniform(55.0, 75.0))
        az = np.radians(rng.uniform(-20.0, 20.0)) + (np.pi if rng.random() < 0.5 else 0.0)
        d = np.array([np.sin(off) * np.cos(az), np.sin(off) * np.sin(az), np.cos(off)])
        dist = rng.uniform(0.2, 0.3)
        # the board's normal (its z axis) points away from the camera along the ray, then tilts
        z_axis = d
        x_axis = np.cross([0.0, 1.0, 0.0], z_axis)
        x_axis /= np.linalg.norm(x_axis)
        y_axis = np.cross(z_axis, x_axis)
        R = np.stack([x_axis, y_axis, z_axis], axis=1)
        tilt_axis = rng.uniform(0, 2 * np.pi)
        tilt = np.radians(rng.uniform(0.0, 30.0))
        R = R @ cv2.Rodrigues(np.array([np.cos(tilt_axis), np.sin(tilt_axis), 0.0]) * tilt)[0] @ \
            cv2.Rodrigues(np.array([0.0, 0.0, rng.uniform(-0.5, 0.5)]))[0]
        t = dist * d - R @ centre
        rvec = cv2.Rodrigues(R)[0].ravel()
        edge = cam.project(target.outline(with_margin=True), rvec, t)
        lim = np.array([w - 1, h - 1]) - _BORDER
        if np.all(np.isfinite(edge)) and np.all((edge >= _BORDER) & (edge <= lim)):
            return rvec, t
    raise ValueError("could not place the board near the fisheye's rim")


def stress_scene(name: StressName, rng: np.random.Generator | int | None = None, *, noise: float = 2.0,
                 blur: float = 0.7, supersample: int = 4) -> StressScene:
    """Render one view of stress case ``name`` (:data:`STRESS_SCENES`) with exact ground truth.

    ``rng`` (a Generator or a seed) draws the target's cut (``edge``), the poses and the noise.
    The image is :func:`.render.render_scene` (blur ``blur`` px, falloff 0.2), noise of
    ``noise`` grey levels, rounded to uint8, and for ``jpeg`` encoded and decoded at quality 75.

    Examples
    --------
    >>> sc = stress_scene("edge", rng=3, supersample=4)
    >>> sc.image.shape, sc.pattern, 0.3 <= sc.target.edge <= 0.6, sc.corners.shape
    ((480, 640), (7, 5), True, (35, 2))
    """
    if name not in STRESS_SCENES:
        raise ValueError(f"unknown stress scene {name!r}; choose one of {', '.join(STRESS_SCENES)}")
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    target = _target(name, gen)
    rvec, tvec, others = stress_poses(name, target, gen)
    return render_stress(name, target, rvec, tvec, others, gen, noise=noise, blur=blur, supersample=supersample)


def render_stress(name: StressName, target: ChessboardTarget, rvec: np.ndarray, tvec: np.ndarray,
                  others: tuple[OtherBoard, ...], rng: np.random.Generator | int | None, *, noise: float = 2.0,
                  blur: float = 0.7, supersample: int = 4, clean: np.ndarray | None = None) -> StressScene:
    """The view of :func:`stress_scene` at a given pose (``clean``: its noise-free render, if made before)."""
    cam = stress_camera(name)
    behind = (others[0].target, others[0].rvec, others[0].tvec) if others else None
    if clean is None:
        clean = render_scene(cam, target, rvec, tvec, supersample=supersample, blur=blur, falloff=0.2,
                             behind=behind)
    image = add_noise(clean, noise, rng)
    quality = 75 if name == "jpeg" else None
    if quality is not None:
        image = jpeg_roundtrip(image, quality)
    corners = cam.project(target.object_points(), rvec, tvec)
    return StressScene(name, image, corners, target.labels(), in_frame(corners, cam.size, _BORDER),
                       target.pattern_size, cam, target, np.asarray(rvec, float), np.asarray(tvec, float),
                       tuple(others), quality, _NOTES[name], clean)


_NOTES = {
    "edge": "outer squares cut to 0.3-0.6 of a cell by the paper's edge",
    "background": "a second board of the same pattern, cells 3-5 px, in the background",
    "fisheye": "equidistant fisheye, 193 degrees across, the board 55-75 degrees off the axis",
    "dots": "3 x 3 dot matrices in the inner white squares",
    "jpeg": "JPEG quality 75, cells 20-30 px",
}


@dataclass(frozen=True)
class StressSequence:
    """The stress scenes as one evaluation sequence: ``views_per_scene`` views of each scene.

    View ``k`` of scene ``s`` (the ``s``-th of ``scenes``) draws its pose from
    ``default_rng([seed, s, k])`` and noise draw ``d`` from ``default_rng([seed, s, k, d + 1])``.
    Its cameras differ from scene to scene (a fisheye among them), so no calibration is made.
    :meth:`run` is the evaluation; ``boards``, ``recall``, ``wrong_labels``,
    ``flipped_views`` as for the other sequences (:mod:`.protocol`), ``other_board``: views
    where the board returned is (half or more of its points within 1.5 px of) a board that is
    not the one to detect, ``extra_points``: returned points more than 3 px from every true
    corner of the main board; each also per scene (``per_scene``).

    Examples
    --------
    >>> seq = StressSequence(views_per_scene=1, scenes=("edge",))
    >>> seq.n_views, seq.name
    (1, 'stress')
    """

    name: str = "stress"
    views_per_scene: int = 3
    seed: int = 31
    noise: float = 2.0
    blur: float = 0.7
    scenes: tuple[StressName, ...] = STRESS_SCENES
    note: str = ("stress: " + "; ".join(_NOTES[n] for n in STRESS_SCENES))
    partial: float = 0.0
    calibrate: bool = False

    @property
    def n_views(self) -> int:
        return self.views_per_scene * len(self.scenes)

    def clean_views(self, views: int | None = None) -> list[StressScene]:
        """The noise-free renders of the views (the first ``views`` of each scene), with their truth."""
        out = []
        per = self.views_per_scene if views is None else min(self.views_per_scene, max(1, int(views)))
        for si, name in enumerate(self.scenes):
            for k in range(per):
                out.append(stress_scene(name, np.random.default_rng([self.seed, si, k]), noise=0.0,
                                        blur=self.blur))
        return out

    def draw(self, view: StressScene, index: tuple[int, int], draw: int) -> StressScene:
        """View ``view`` with noise draw ``draw`` (``index``: its scene's position and view number)."""
        rng = np.random.default_rng([self.seed, index[0], index[1], draw + 1])
        return render_stress(view.name, view.target, view.rvec, view.tvec, view.others, rng, noise=self.noise,
                             blur=self.blur, clean=view.clean)

    def run(self, methods: list[str], *, draws: int = 1, views: int | None = None,
            progress: Callable[[str], None] | None = None) -> list[dict]:
        """Every method on every view and draw: one row per method, as :func:`.protocol.run_sequences`'."""
        from .comparators import METHODS
        from .metrics import error_stats, score_view

        clean = self.clean_views(views)
        per = len(clean) // len(self.scenes)
        tallies = {m: {} for m in methods}
        for n, view in enumerate(clean):
            index = (n // per, n % per)
            for d in range(draws):
                sc = self.draw(view, index, d)
                for m in methods:
                    t0 = time.perf_counter()
                    det = METHODS[m].detect(sc.image, sc.pattern)
                    dt = time.perf_counter() - t0
                    score = score_view(det.points, det.labels, sc.corners, sc.labels, sc.inside)
                    _tally(tallies[m].setdefault(sc.name, _new_tally()), det, score, sc, dt)
            if progress:
                progress(f"{self.name}: view {n + 1}/{len(clean)} ({view.name})")
        rows = []
        for m in methods:
            total = _new_tally()
            for t in tallies[m].values():
                for key in total:
                    total[key] += t[key]
            row = {"sequence": self.name, "method": m, "kind": METHODS[m].kind, "views": len(clean),
                   "draws": draws}
            row.update(_summary(total, error_stats))
            row["per_scene"] = {name: _summary(t, error_stats) for name, t in tallies[m].items()}
            rows.append(row)
        return rows


def _new_tally() -> dict:
    return {"frames": 0, "boards": 0, "recalled": 0, "inside": 0, "wrong_labels": 0, "flipped_views": 0,
            "other_board": 0, "extra_points": 0, "errors": [], "times": []}


def _tally(t: dict, det, score, sc: StressScene, dt: float) -> None:
    t["frames"] += 1
    t["boards"] += int(score.found)
    t["recalled"] += score.recalled
    t["inside"] += score.n_inside
    t["wrong_labels"] += score.n_wrong
    t["flipped_views"] += int(score.flipped)
    t["errors"].append(score.errors)
    t["times"].append(dt)
    pts = np.asarray(det.points, dtype=np.float64).reshape(-1, 2)
    if len(pts):
        near = np.min(np.linalg.norm(pts[:, None] - sc.corners[None], axis=2), axis=1)
        t["extra_points"] += int(np.sum(near > 3.0))
        for o in sc.others:
            d = np.min(np.linalg.norm(pts[:, None] - o.corners[None], axis=2), axis=1)
            if det.found and np.mean(d < 1.5) >= 0.5:
                t["other_board"] += 1
                break


def _summary(t: dict, error_stats) -> dict:
    errors = np.concatenate(t["errors"]) if t["errors"] else np.zeros(0)
    return {"frames": t["frames"], "boards": t["boards"],
            "recall": round(t["recalled"] / max(1, t["inside"]), 4), "wrong_labels": t["wrong_labels"],
            "flipped_views": t["flipped_views"], "other_board": t["other_board"],
            "extra_points": t["extra_points"], "corner": error_stats(errors),
            "ms_per_frame": round(1000 * float(np.median(t["times"])), 1) if t["times"] else None}
