"""Known rigs for examples, doctests and tests: boards projected through known cameras.

:func:`demo_rig_boards` and :data:`DEMO_RIG`: a two-camera rig ("left", "right") and its boards;
:func:`demo_rig`: its calibration (cached); :func:`synthetic_rig`: any number of cameras, with
boards seen by only some cameras, partial boards, fisheye cameras and labels turned as a detector may.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import cv2
import numpy as np

from ..cameras import project
from ..targets.board import LABEL_TURNS, Board

__all__ = ["DEMO_RIG", "SyntheticRig", "demo_rig", "demo_rig_boards", "synthetic_rig"]



@dataclass(frozen=True)
class SyntheticRig:
    """A known rig and its boards (the result of :func:`synthetic_rig`).

    ``R[c], T[c]``: camera ``c``'s pose, :math:`x_c = R x_{cam0} + T`; ``rvecs,
    tvecs``: each frame's board pose in ``cam0``'s frame; ``boards``: per camera,
    one Board or None per frame, as a detector would label them.
    """

    names: tuple[str, ...]
    boards: dict
    image_sizes: dict
    K: list
    dist: list
    models: dict
    R: list
    T: list
    rvecs: np.ndarray
    tvecs: np.ndarray
    pattern: tuple[int, int]


def _camera(c: int, baseline: float, model: str):
    yaw = np.deg2rad(-3.0 * c)  # a slightly convergent rig
    R = cv2.Rodrigues(np.array([0.01 * c, yaw, -0.005 * c]))[0]
    T = -R @ np.array([baseline * c, 0.3 * c, 0.0])
    K = np.array([[600.0 + 25 * c, 0, 320.0 + 4 * c], [0, 598.0 + 25 * c, 240.0 - 3 * c], [0, 0, 1]])
    dist = (np.array([0.05, -0.01, 0.002, 0.0]) if model == "fisheye"
            else np.array([-0.2 + 0.03 * c, 0.05, 0.001, -0.0005, 0.0]))
    return R, T, K, dist


def _board_pose(rng, centre_x: float, spread: float, pattern):
    cols, rows = pattern
    tilt = np.deg2rad(35) * rng.uniform(0, 1)
    axis = rng.normal(size=3)
    axis[2] *= 0.3
    R = cv2.Rodrigues(axis / np.linalg.norm(axis) * tilt)[0] @ cv2.Rodrigues(
        np.array([0, 0, rng.uniform(-0.4, 0.4)]))[0]
    z = rng.uniform(12, 18)
    c = np.array([centre_x + spread * rng.uniform(-0.22, 0.22) * z, spread * rng.uniform(-0.16, 0.16) * z, z])
    t = c - R @ np.array([(cols - 1) / 2, (rows - 1) / 2, 0.0])
    return cv2.Rodrigues(R)[0].ravel(), t


def _observe(px, inside, lab, pattern, rng, partial: bool, absolute: bool, relabel: bool):
    """The board a detector would report from the projected corners (or None)."""
    cols, rows = pattern
    if inside.all():
        if relabel and cols == rows:  # a square board: any quarter turn
            lab = lab @ LABEL_TURNS[int(rng.integers(4))].T
            lab = lab - lab.min(axis=0)
        elif relabel and (cols + rows) % 2 == 0 and rng.uniform() < 0.5:
            lab = np.array([cols - 1, rows - 1]) - lab  # the half turn a symmetric board allows
        return Board(px, lab, size=(cols, rows))
    keep = inside
    sub = lab[keep]
    if not partial or keep.sum() < 12 or min(len(np.unique(sub[:, 0])), len(np.unique(sub[:, 1]))) < 3:
        return None
    if not absolute:
        if relabel:
            sub = sub @ LABEL_TURNS[int(rng.integers(4))].T
        sub = sub - sub.min(axis=0)
    return Board(px[keep], sub)


def synthetic_rig(cameras: int = 2, frames: int = 10, noise: float = 0.05, seed: int = 0, *,
             pattern: tuple[int, int] = (9, 6), models: dict | None = None, baseline: float = 6.0,
             spread: float = 1.0, missing: float = 0.0, partial: bool = False, absolute: bool = False,
             relabel: bool = False, size: tuple[int, int] = (640, 480)) -> SyntheticRig:
    """A rig of ``cameras`` 640 x 480 cameras ``baseline`` squares apart and ``frames`` boards it saw.

    Camera ``c`` sits at ``(baseline c, 0.3 c, 0)`` in ``cam0``'s frame, turned
    by about ``-3 c`` degrees about ``y``, with ``fx = 600 + 25 c`` and OpenCV's
    ``k1 = -0.2 + 0.03 c, k2 = 0.05, p1, p2`` (a fisheye camera, ``models[name] ==
    "fisheye"``: ``k1..k4 = 0.05, -0.01, 0.002, 0``). Each board is tilted by up
    to 35 degrees, 12-18 squares away, and seen whole by at least one camera;
    corners carry Gaussian noise of ``noise`` px. A camera that sees part of a
    board reports it when ``partial`` (relative labels unless ``absolute``), else
    none; each observation goes missing with probability ``missing``;
    ``relabel`` turns each whole half-turn-symmetric board by a half turn (a
    square one by any quarter turn), and each partial one by any quarter turn, at
    random (as a detector may).

    Examples
    --------
    >>> d = synthetic_rig(cameras=3, frames=6)
    >>> d.names, len(d.boards["cam2"]), d.T[0].tolist()
    (('cam0', 'cam1', 'cam2'), 6, [0.0, 0.0, 0.0])
    """
    rng = np.random.default_rng(seed)
    names = tuple(f"cam{c}" for c in range(cameras))
    models = {n: (models or {}).get(n, "pinhole") for n in names}
    cams = [_camera(c, baseline, models[n]) for c, n in enumerate(names)]
    cols, rows = pattern
    lab = np.array([(i, j) for j in range(rows) for i in range(cols)])
    obj = np.c_[lab, np.zeros(len(lab))].astype(float)
    out: dict = {n: [] for n in names}
    rv_all, tv_all = [], []
    w, h = size
    while len(rv_all) < frames:
        rv, tv = _board_pose(rng, baseline * (cameras - 1) / 2, spread, pattern)
        Rb = cv2.Rodrigues(rv)[0]
        obs, whole = [], False
        for R, T, K, D in cams:
            pc = (obj @ Rb.T + tv) @ R.T + T
            px = project(pc, K, D, models[names[len(obs)]])
            inside = (pc[:, 2] > 0) & np.all((px > 3) & (px < [w - 4, h - 4]), axis=1)
            whole |= bool(inside.all())
            obs.append((px, inside))
        if not whole:
            continue
        rv_all.append(rv)
        tv_all.append(tv)
        for n, (px, inside) in zip(names, obs):
            b = None if rng.uniform() < missing else _observe(
                px + rng.normal(0, noise, px.shape), inside, lab, pattern, rng, partial, absolute, relabel)
            out[n].append(b)
    return SyntheticRig(names, out, dict.fromkeys(names, size), [c[2] for c in cams], [c[3] for c in cams],
                   models, [c[0] for c in cams], [c[1] for c in cams], np.array(rv_all), np.array(tv_all),
                   pattern)


#: the demo rig's cameras: name -> (K, dist, R, T), :math:`x = R x_{left} + T` (squares)
DEMO_RIG: dict = {n: (K, D, R, T) for n, (R, T, K, D) in zip(("left", "right"), (_camera(c, 6.0, "pinhole")
                                                                                 for c in range(2)))}


def demo_rig_boards(n: int = 12, noise: float = 0.05, seed: int = 3) -> tuple[dict, dict]:
    """``n`` frames of the 9 x 6 board seen by the :data:`DEMO_RIG` (``(boards, image_sizes)``, by camera name).

    Examples
    --------
    >>> boards, sizes = demo_rig_boards(4)
    >>> sorted(boards), len(boards["left"]), sizes["right"]
    (['left', 'right'], 4, (640, 480))
    """
    d = synthetic_rig(cameras=2, frames=n, noise=noise, seed=seed)
    rename = dict(zip(d.names, ("left", "right")))
    return ({rename[k]: list(v) for k, v in d.boards.items()},
            {rename[k]: v for k, v in d.image_sizes.items()})


@functools.lru_cache(maxsize=1)
def demo_rig():
    """The calibration of :func:`demo_rig_boards` (12 frames, 0.05 px noise), computed once.

    Examples
    --------
    >>> rig = demo_rig()
    >>> rig.names, bool(abs(rig.camera("right").baseline - np.linalg.norm(DEMO_RIG["right"][3])) < 0.05)
    (('left', 'right'), True)
    """
    from .fit import calibrate_rig

    boards, sizes = demo_rig_boards(12)
    return calibrate_rig(boards, sizes, pattern=(9, 6))
