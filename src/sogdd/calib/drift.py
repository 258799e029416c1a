"""Is a stored calibration still good? New views of a board checked against a stored camera or rig.

:func:`check_calibration` is what ``sogdd check`` runs: the boards of a handful of new views are
found (:mod:`~sogdd.calib.detection`), each board's pose is fitted with the *stored* intrinsics
(``solvePnP``; :func:`~sogdd.calib.solvers.solve_pose`), and two questions are asked of them.

1. **Do the stored intrinsics explain the new corners?** The residual RMS over the new views,
   :math:`r = \\sqrt{\\operatorname{mean}_c \\lVert x_c - \\pi(K, d, R_v X_c + t_v) \\rVert^2}`, set
   against the stored calibration's own RMS :math:`r_0`. A pose absorbs much of a small change of the
   camera (a longer focal length is a board further away), so this test is coarse: it catches a lens
   whose distortion changed, a refocused or swapped lens, a wrong file.
2. **Would a fresh fit give the same camera?** ``fx, fy, cx, cy`` and every view's pose are fitted
   again to the new corners, the distortion held at its stored value (a handful of views cannot
   pin down the distortion, and holding it keeps the four parameters sharp; a drifting mount or a
   focus that moved changes these four first). Each parameter's difference
   :math:`\\Delta p = p_{new} - p_{stored}` is set against the two estimates' uncertainties,

   .. math:: z_p = \\frac{\\Delta p}{\\sqrt{\\sigma_{stored}^2 + \\sigma_{new}^2}},

   :math:`\\sigma_{stored}` from the file (camera.json ``std``, camera.yaml ``std_intrinsics``,
   rig.json; read by :func:`sogdd.calib.exchange.native.read`), :math:`\\sigma_{new}` from the
   fresh fit's covariance :math:`s^2 (J^\\top J)^{-1}`, :math:`s^2` its residuals' sum of squares
   over the degrees of freedom. A difference is also put in % of the focal length,
   :math:`100\\,\\Delta p / f_x` (for ``cx, cy`` that is the angle of the shifted axis in hundredths of
   a radian): a calibration whose stored standard deviations are tiny (thousands of views) must not
   fail for a change no one could see.

For a rig, each camera is checked so, and each camera's pose relative to the reference is
measured again: per frame, :math:`R_{rel} = R_k R_0^\\top`, :math:`T_{rel} = t_k - R_{rel} t_0` from
the two cameras' board poses, averaged over the frames, and compared with the stored ``R, T``:
the rotation's change in degrees, the translation's in the square's unit and in % of the
baseline, each also in units of :math:`\\sqrt{\\sigma_{stored}^2 + \\sigma_{new}^2}`
(:math:`\\sigma_{new}` the frames' spread over :math:`\\sqrt{n}`).

The verdict
-----------
Every finding is ``pass``, ``warn`` or ``fail``; the check's verdict is its worst, its reason
that finding's one line. A parameter **fails** when its difference is beyond
:data:`FAIL_SIGMA` standard deviations *and* beyond :data:`FAIL_PCT` % of the focal length;
it **warns** beyond :data:`WARN_SIGMA` and :data:`WARN_PCT` %. Without standard deviations
(a file that holds none, a fresh fit of one view) the percentage alone decides. Why these:

- :data:`WARN_SIGMA` = 3, :data:`FAIL_SIGMA` = 5: for an unchanged camera the four
  :math:`z_p` are about standard normal, so one of the four passes 3 about once in a hundred
  checks and 5 about once in a million; the estimated standard deviations are themselves
  uncertain, and optimistic where the model is not quite the lens, hence the wide margin.
- :data:`WARN_PCT` = 0.2 %, :data:`FAIL_PCT` = 0.5 %: at 0.5 % a point 300 px from the centre
  moves 1.5 px, several times a good calibration's RMS and what a stereo rig or a measurement
  notices; 0.2 % (0.6 px there) is worth a look; 0.05 % is within what two good calibrations of
  the same camera differ by, never a failure.
- The residual RMS **fails** beyond :data:`RMS_FAIL_FACTOR` times the stored RMS *and*
  :data:`RMS_FAIL_PX`, and **warns** beyond :data:`RMS_WARN_FACTOR` and :data:`RMS_WARN_PX`:
  new views are seldom as sharp as the calibration's best, so twice the stored RMS is
  expected now and then; the px floors keep a sub-0.1-px calibration from failing for noise
  that no use of it could see. One view beyond the fail limit alone warns (a bent board, a
  smeared view), naming the view.
- A relative pose warns and fails as the intrinsics do, its floors :data:`ROT_WARN_DEG` and
  :data:`ROT_FAIL_DEG` (0.3 degrees is 3 px at a focal length of 600 px: rectified rows no
  longer match) and :data:`BASELINE_WARN_PCT`, :data:`BASELINE_FAIL_PCT` of the baseline (the
  depth scale of everything the rig measures).

Examples
--------
>>> from sogdd.calib.demo import DEMO_K, DEMO_SIZE, demo_boards
>>> from sogdd.calib import calibrate
>>> stored = calibrate(demo_boards(14), DEMO_SIZE)
>>> check_calibration(stored, demo_boards(5, seed=7)).verdict
'pass'
>>> moved = DEMO_K * [[1.01, 1, 1], [1, 1.01, 1], [1, 1, 1]]  # the focal length 1 % longer
>>> check = check_calibration(stored, demo_boards(5, seed=7, K=moved))
>>> check.verdict, round(check.cameras[0].difference_pct["fx"], 1)
('fail', 1.0)
>>> print(check.reason)
f... moved by +5.8... px (+0.97 % of fx, +10... sigma) from the stored 59...: the camera has changed
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Literal

import cv2
import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import lil_matrix

from ..collection import relative_names
from .cameras import project
from .detection import check_read_options, detect_files, pick_boards
from .exchange import native
from .exchange.stored import INTRINSICS, StoredCamera, StoredRig, stored_rig
from .result import Calibration
from .rig.frames import match_frames
from .rig.result import RigCalibration
from .session import check_detections, common_image_size, expand_images
from .solvers import solve_pose
from .targets.board import Board
from .targets.spec import BoardSpec, parse_board

__all__ = ["BASELINE_FAIL_PCT", "BASELINE_WARN_PCT", "FAIL_PCT", "FAIL_SIGMA", "MIN_CORNERS", "MIN_FRESH_VIEWS",
           "RMS_FAIL_FACTOR", "RMS_FAIL_PX", "RMS_WARN_FACTOR", "RMS_WARN_PX", "ROT_FAIL_DEG", "ROT_WARN_DEG",
           "WARN_PCT", "WARN_SIGMA", "CameraDrift", "DriftCheck", "PoseDrift", "Verdict", "check_calibration"]

#: a check's verdict, and each finding's level
Verdict = Literal["pass", "warn", "fail"]

#: a difference is a finding beyond this many standard deviations (and the % floor): module doc
WARN_SIGMA = 3.0
FAIL_SIGMA = 5.0
#: ... and beyond this % of the focal length (the floors: a tiny stored std fails nothing by itself)
WARN_PCT = 0.2
FAIL_PCT = 0.5
#: the new views' residual RMS under the stored camera: warn / fail beyond this times the stored RMS ...
RMS_WARN_FACTOR = 2.0
RMS_FAIL_FACTOR = 4.0
#: ... and beyond this many px
RMS_WARN_PX = 0.25
RMS_FAIL_PX = 0.5
#: a rig camera's rotation relative to the reference: the floors of a finding, degrees
ROT_WARN_DEG = 0.1
ROT_FAIL_DEG = 0.3
#: a rig camera's translation relative to the reference: the floors of a finding, % of the baseline
BASELINE_WARN_PCT = 0.5
BASELINE_FAIL_PCT = 1.0
#: fewest corners for a view to be checked (a pose has six unknowns)
MIN_CORNERS = 6
#: fewest views for the fresh fit (one view of a flat board cannot give its intrinsics and its pose)
MIN_FRESH_VIEWS = 2

_ORDER: dict[str, int] = {"pass": 0, "warn": 1, "fail": 2}
_NAN = float("nan")
_UNREADABLE = "unreadable: "
#: the fresh fit drops corners beyond median + this many robust standard deviations of its residuals, and
#: beyond this many px (the rejection rule of :func:`sogdd.calib.calibrate`, once)
_OUTLIER_K, _OUTLIER_PX = 5.0, 0.5


# --------------------------------------------------------------------------------------------------
# the result


@dataclass(frozen=True)
class CameraDrift:
    """One camera's check.

    ``views`` names the views checked, ``view_rms`` each one's residual RMS under the stored
    camera (px), ``skipped`` the views not checked and why; ``rms`` over their corners and
    ``stored_rms`` the stored fit's. ``stored``, ``fresh`` (None without a fresh fit) map
    ``fx, fy, cx, cy`` to their values, ``stored_std`` and ``fresh_std`` to their standard
    deviations; ``difference`` is ``fresh - stored`` (px), ``difference_pct`` in % of the stored
    ``fx``, ``sigmas`` in units of the two standard deviations combined (NaN unknown).
    """

    name: str
    model: str
    views: tuple[str, ...]
    view_rms: tuple[float, ...]
    skipped: dict[str, str]
    corners: int
    rms: float
    stored_rms: float
    stored: dict[str, float]
    stored_std: dict[str, float]
    fresh: dict[str, float] | None
    fresh_std: dict[str, float]
    fresh_rms: float
    difference: dict[str, float]
    difference_pct: dict[str, float]
    sigmas: dict[str, float]


@dataclass(frozen=True)
class PoseDrift:
    """A rig camera's pose relative to the reference, measured again from ``frames`` frames: the
    rotation's change (degrees) and the translation's (the square's unit, and in % of the stored
    baseline), each also in units of the combined standard deviation (NaN unknown)."""

    name: str
    frames: int
    rotation_deg: float
    rotation_sigmas: float
    translation: float
    translation_pct: float
    translation_sigmas: float


@dataclass(frozen=True)
class DriftCheck:
    """What :func:`check_calibration` found: the ``verdict``, the ``reason`` (one line: its worst
    finding), every finding ``(level, text)``, each camera's check and, for a rig, each camera's
    relative pose."""

    verdict: Verdict
    reason: str
    findings: tuple[tuple[Verdict, str], ...]
    cameras: tuple[CameraDrift, ...]
    poses: tuple[PoseDrift, ...] = ()
    stored: str = ""
    rig: bool = False

    @property
    def unreadable(self) -> tuple[str, ...]:
        """Why each input that could not be read was not checked (one line each, naming the file)."""
        return tuple(why.removeprefix(_UNREADABLE) for c in self.cameras for why in c.skipped.values()
                     if why.startswith(_UNREADABLE))

    def as_dict(self) -> dict:
        """Plain JSON-able data (non-finite numbers as None): what ``sogdd check --json`` prints."""
        def plain(v):
            if isinstance(v, dict):
                return {str(k): plain(x) for k, x in v.items()}
            if isinstance(v, (list, tuple)):
                return [plain(x) for x in v]
            if isinstance(v, (float, np.floating)):
                return float(v) if math.isfinite(v) else None
            if isinstance(v, np.integer):
                return int(v)
            return v

        cams = [{**{f: getattr(c, f) for f in c.__dataclass_fields__},
                 "view_rms": dict(zip(c.views, c.view_rms))} for c in self.cameras]
        for c in cams:
            del c["views"]
        return plain({"verdict": self.verdict, "reason": self.reason, "stored": self.stored, "rig": self.rig,
                      "findings": [{"level": lv, "text": t} for lv, t in self.findings], "cameras": cams,
                      "poses": [{f: getattr(p, f) for f in p.__dataclass_fields__} for p in self.poses]})


# --------------------------------------------------------------------------------------------------
# the check


@dataclass
class _Views:
    """One camera's new views: names, boards (None: no board), and why a view is left out."""

    names: list[str]
    boards: list[Board | None]
    size: tuple[int, int] | None = None
    reasons: dict[str, str] = field(default_factory=dict)


def _detect(paths: Sequence[str | os.PathLike], spec: BoardSpec, jobs: int, read_options: dict,
            progress: bool) -> _Views:
    results = detect_files(paths, spec, jobs=jobs, progress=progress, read_options=read_options,
                           thumb_width=None, view_only=True)
    results = [replace(r, boards=pick_boards(r.boards, spec)[0]) for r in results]
    check_detections(results, spec)
    names = relative_names(paths)
    out = _Views(names, [r.boards[0] if r.boards else None for r in results], common_image_size(results))
    for n, r in zip(names, results):
        if r.error:
            out.reasons[n] = f"{_UNREADABLE}{r.error}"
        elif not r.boards:
            out.reasons[n] = r.seen or "no board"
    return out


def _as_views(given, spec: BoardSpec, jobs: int, read_options: dict, recursive: bool, progress: bool) -> _Views:
    """Image files (paths, folders, patterns) or boards as one camera's views."""
    if isinstance(given, (str, os.PathLike)):
        given = [given]
    items = list(given)
    if items and all(b is None or isinstance(b, Board) for b in items):
        return _Views([f"view{k}" for k in range(len(items))], items)
    if any(isinstance(b, Board) for b in items):
        raise TypeError("give image files or boards, not both")
    paths = expand_images(items, recursive=recursive)
    if not paths:
        raise ValueError("no input images")
    return _detect(paths, spec, jobs, read_options, progress)


def _residuals(board: Board, square: float, K, dist, model: str, rvec, tvec) -> np.ndarray:
    pred = project(board.object_points(square), K, dist, model, rvec, tvec)
    return np.hypot(*(pred - board.image_points).T)


def _rms(r: np.ndarray) -> float:
    return float(np.sqrt(np.mean(r ** 2))) if len(r) else _NAN


def _fresh_fit(boards: list[Board], poses: list, square: float, cam: StoredCamera
               ) -> tuple[dict[str, float], dict[str, float], float]:
    """``fx, fy, cx, cy`` and every pose fitted again (the distortion held): values, standard deviations
    (NaN for one view) and the fit's RMS. One round drops corners far beyond the rest (a mislabelled
    corner must not move the camera)."""
    obj = [b.object_points(square) for b in boards]
    img = [b.image_points for b in boards]
    keep = [np.ones(len(b), bool) for b in boards]
    K0, dist, model = cam.K, cam.dist, cam.model
    x0 = np.r_[K0[0, 0], K0[1, 1], K0[0, 2], K0[1, 2], np.concatenate([np.r_[r, t] for r, t in poses])]

    def fun(x, keep):
        K = np.array([[x[0], K0[0, 1], x[2]], [0, x[1], x[3]], [0, 0, 1]])
        out = [(project(o[k], K, dist, model, x[4 + 6 * v:7 + 6 * v], x[7 + 6 * v:10 + 6 * v]) - i[k]).ravel()
               for v, (o, i, k) in enumerate(zip(obj, img, keep))]
        return np.concatenate(out)

    for _ in range(2):
        n = [2 * int(k.sum()) for k in keep]
        sparsity = lil_matrix((sum(n), len(x0)), dtype=int)
        sparsity[:, :4] = 1
        row = 0
        for v, m in enumerate(n):
            sparsity[row:row + m, 4 + 6 * v:10 + 6 * v] = 1
            row += m
        sol = least_squares(fun, x0, jac_sparsity=sparsity, method="trf", x_scale="jac", args=(keep,))
        r = np.hypot(*sol.fun.reshape(-1, 2).T)
        mad = float(np.median(np.abs(r - np.median(r))))
        limit = max(float(np.median(r)) + _OUTLIER_K * 1.4826 * mad, _OUTLIER_PX)
        parts = np.split(r, np.cumsum([int(k.sum()) for k in keep])[:-1])
        if all(np.all(p <= limit) for p in parts):
            break
        for k, p in zip(keep, parts):
            k[np.flatnonzero(k)[p > limit]] = False
        x0 = sol.x
    x = sol.x
    values = dict(zip(INTRINSICS, map(float, x[:4])))
    dof = sol.fun.size - x.size
    std = {n: _NAN for n in INTRINSICS}
    if len(boards) >= 2 and dof > 0:
        J = sol.jac.toarray() if hasattr(sol.jac, "toarray") else np.asarray(sol.jac)
        s2 = float(sol.fun @ sol.fun) / dof
        try:
            cov = np.linalg.inv(J.T @ J) * s2
            std = {n: float(np.sqrt(cov[k, k])) if cov[k, k] > 0 else _NAN for k, n in enumerate(INTRINSICS)}
        except np.linalg.LinAlgError:
            pass
    return values, std, _rms(r[r <= limit]) if np.any(r <= limit) else _rms(r)


def _level(sig: float, pct: float, warn_pct: float, fail_pct: float) -> Verdict:
    """A difference's level: beyond both the sigma limit (where known) and the % floor."""
    a = abs(pct)
    s = abs(sig) if math.isfinite(sig) else math.inf
    if s >= FAIL_SIGMA and a >= fail_pct:
        return "fail"
    if s >= WARN_SIGMA and a >= warn_pct:
        return "warn"
    return "pass"


def _combined(a: float, b: float) -> float:
    known = [v for v in (a, b) if math.isfinite(v)]
    return math.sqrt(sum(v * v for v in known)) if known else _NAN


def _view_poses(cam: StoredCamera, views: _Views, square: float) -> tuple[list, dict[str, str]]:
    """Each usable view's ``(index, name, board, pose, residuals)`` under the stored camera, and why the
    others are left out."""
    used, skipped = [], dict(views.reasons)
    for v, (n, b) in enumerate(zip(views.names, views.boards)):
        pose = None if b is None or len(b) < MIN_CORNERS else solve_pose(b, square, cam.K, cam.dist, cam.model)
        if b is None:
            skipped.setdefault(n, "no board")
        elif len(b) < MIN_CORNERS:
            skipped[n] = f"{len(b)} corners, fewer than {MIN_CORNERS}"
        elif pose is None:
            skipped[n] = "no pose under the stored camera"
        else:
            used.append((v, n, b, pose, _residuals(b, square, cam.K, cam.dist, cam.model, *pose)))
    return used, skipped


def _intrinsics_finding(label: str, stored: dict, diff: dict, pct: dict, sig: dict) -> tuple[Verdict, str]:
    worst = max(INTRINSICS, key=lambda n: (_ORDER[_level(sig[n], pct[n], WARN_PCT, FAIL_PCT)], abs(pct[n])))
    lv = _level(sig[worst], pct[worst], WARN_PCT, FAIL_PCT)
    sigma = f", {sig[worst]:+.1f} sigma" if math.isfinite(sig[worst]) else ", no standard deviation known"
    if lv == "pass":
        return "pass", (f"{label}fx, fy, cx, cy as stored (largest change {worst} {pct[worst]:+.3f} % of "
                        f"fx{sigma})")
    return lv, (f"{label}{worst} moved by {diff[worst]:+.2f} px ({pct[worst]:+.2f} % of fx{sigma}) from the "
                f"stored {stored[worst]:.2f}: the camera has changed")


def _beyond(rms: float, r0: float, factor: float, px: float) -> bool:
    """An RMS beyond ``px`` and beyond ``factor`` times the stored RMS (where known)."""
    return rms >= px and not (math.isfinite(r0) and r0 > 0 and rms / r0 < factor)


def _rms_findings(label: str, total: float, r0: float, names: list[str], rms: list[float]
                  ) -> list[tuple[Verdict, str]]:
    against = f" against {r0:.3f} px stored" if math.isfinite(r0) else " (no stored RMS)"
    if _beyond(total, r0, RMS_FAIL_FACTOR, RMS_FAIL_PX):
        return [("fail", f"{label}the stored camera does not explain the new views: residual RMS {total:.3f} px"
                         f"{against}")]
    if _beyond(total, r0, RMS_WARN_FACTOR, RMS_WARN_PX):
        return [("warn", f"{label}residual RMS {total:.3f} px{against}: the views are noisier than the "
                         "calibration's, or the camera changed")]
    lone = [(x, n) for n, x in zip(names, rms) if _beyond(x, r0, RMS_FAIL_FACTOR, RMS_FAIL_PX)]
    if lone and len(names) > 1:
        x, n = max(lone)
        return [("warn", f"{label}view {n}: residual RMS {x:.3f} px{against} (a bent board, a smeared view?)")]
    return []


def _check_camera(cam: StoredCamera, views: _Views, square: float, label: str
                  ) -> tuple[CameraDrift, list[tuple[Verdict, str]], dict[int, tuple]]:
    if views.size is not None and tuple(views.size) != tuple(cam.image_size):
        w, h = views.size
        raise ValueError(f"{label}the images are {w}x{h} but the stored camera is "
                         f"{cam.image_size[0]}x{cam.image_size[1]}: a calibration holds at one resolution only")
    used, skipped = _view_poses(cam, views, square)
    if not used:
        why = "; ".join(f"{n}: {w}" for n, w in list(skipped.items())[:3])
        raise ValueError(f"{label}no view to check: {why}")
    _, names, boards, poses, res = (list(t) for t in zip(*used))
    total, rms = _rms(np.concatenate(res)), [_rms(r) for r in res]
    stored = cam.intrinsics
    none = dict.fromkeys(INTRINSICS, _NAN)
    if len(boards) >= MIN_FRESH_VIEWS:
        fresh, fresh_std, fresh_rms = _fresh_fit(boards, poses, square, cam)
        diff = {n: fresh[n] - stored[n] for n in INTRINSICS}
    else:  # one view of a flat board gives 8 constraints for 4 intrinsics and 6 pose parameters
        fresh, fresh_std, fresh_rms, diff = None, none, _NAN, none
    pct = {n: 100.0 * diff[n] / stored["fx"] for n in INTRINSICS}
    sig = {n: diff[n] / s if (s := _combined(cam.std.get(n, _NAN), fresh_std[n])) > 0 else _NAN
           for n in INTRINSICS}
    findings = [_intrinsics_finding(label, stored, diff, pct, sig) if fresh is not None else
                ("warn", f"{label}one view: fx, fy, cx, cy cannot be fitted again from one view of a flat "
                         f"board, only the residuals were checked; give {MIN_FRESH_VIEWS} or more"),
                *_rms_findings(label, total, cam.rms, names, rms)]
    drift = CameraDrift(cam.name, cam.model, tuple(names), tuple(rms), skipped, sum(len(b) for b in boards),
                        total, cam.rms, stored, {n: cam.std.get(n, _NAN) for n in INTRINSICS}, fresh, fresh_std,
                        fresh_rms, diff, pct, sig)
    return drift, findings, {v: pose for v, _, _, pose, _ in used}


def _half_turn(board: Board) -> Board | None:
    """The board labelled from its opposite corner (a sized board's 180-degree ambiguity), or None."""
    if board.size is None:
        return None
    c, r = board.size
    return replace(board, labels=np.c_[c - 1 - board.labels[:, 0], r - 1 - board.labels[:, 1]])


def _rel(pose0, posek) -> tuple[np.ndarray, np.ndarray]:
    R0, Rk = cv2.Rodrigues(np.asarray(pose0[0], float))[0], cv2.Rodrigues(np.asarray(posek[0], float))[0]
    R = Rk @ R0.T
    return R, np.ravel(posek[1]) - R @ np.ravel(pose0[1])


def _frame_deltas(cam: StoredCamera, ref_poses: dict, views: _Views, square: float) -> tuple[list, list]:
    """Per frame both cameras saw, the change of the relative pose from the stored one: the rotation
    vector of :math:`R_{rel} R^\\top` and :math:`T_{rel} - T` (the board's half turn, where its labels
    allow one, whichever is nearer the stored pose). A partial chessboard, whose labels are relative, is
    left out."""
    rot, trans = [], []
    for f, pose0 in ref_poses.items():
        b = views.boards[f]
        if b is not None and b.size is None and b.ids is None:
            continue  # a partial chessboard: its labels are its own, not the other camera's
        best = None
        for cand in (b, None if b is None else _half_turn(b)):
            pose = None if cand is None or len(cand) < MIN_CORNERS else \
                solve_pose(cand, square, cam.K, cam.dist, cam.model)
            if pose is not None:
                R, T = _rel(pose0, pose)
                w = cv2.Rodrigues(R @ cam.R.T)[0].ravel()
                if best is None or np.linalg.norm(w) < np.linalg.norm(best[0]):
                    best = (w, T - cam.T)
        if best is not None:
            rot.append(best[0])
            trans.append(best[1])
    return rot, trans


def _spread(x: list) -> float:
    """The standard deviation of the mean of vectors ``x`` (their norm's), NaN for one."""
    return float(np.sqrt(np.sum(np.var(x, axis=0, ddof=1)) / len(x))) if len(x) >= 2 else _NAN


def _check_pose(ref: StoredCamera, cam: StoredCamera, ref_poses: dict, views: _Views, square: float
                ) -> tuple[PoseDrift | None, list[tuple[Verdict, str]]]:
    rot, trans = _frame_deltas(cam, ref_poses, views, square)
    if not rot:
        return None, [("warn", f"{cam.name}: no frame shows the board to both {ref.name} and {cam.name}; its "
                               "pose relative to them is not checked")]
    n = len(rot)
    ang = float(np.degrees(np.linalg.norm(np.mean(rot, axis=0))))
    dt = float(np.linalg.norm(np.mean(trans, axis=0)))
    base = float(np.linalg.norm(cam.T))
    pct = 100.0 * dt / base if base > 0 else _NAN
    rs = _combined(cam.pose_std.get("rotation_deg", _NAN), float(np.degrees(_spread(rot))))
    ts = _combined(cam.pose_std.get("baseline", _NAN), _spread(trans))
    rsig, tsig = ang / rs if rs > 0 else _NAN, dt / ts if ts > 0 else _NAN
    lr = _level(rsig, ang, ROT_WARN_DEG, ROT_FAIL_DEG)
    lt = _level(tsig, pct, BASELINE_WARN_PCT, BASELINE_FAIL_PCT) if math.isfinite(pct) else "pass"
    out: list[tuple[Verdict, str]] = []
    if lr != "pass":
        out.append((lr, f"{cam.name}: its rotation relative to {ref.name} moved by {ang:.3f} degrees "
                        f"({rsig:.1f} sigma) over {n} frames"))
    if lt != "pass":
        out.append((lt, f"{cam.name}: its position relative to {ref.name} moved by {dt:.4g} ({pct:.2f} % of "
                        f"the baseline, {tsig:.1f} sigma) over {n} frames"))
    if not out:
        out.append(("pass", f"{cam.name}: pose relative to {ref.name} as stored ({ang:.3f} degrees, "
                            f"{pct:.2f} % of the baseline, over {n} frames)"))
    return PoseDrift(cam.name, n, ang, rsig, dt, pct, tsig), out


def _rig_views(stored: StoredRig, given: Mapping, spec: BoardSpec, jobs: int, read_options: dict,
               recursive: bool, progress: bool) -> dict[str, _Views]:
    """Each camera's views of the frames (its images matched by their numbers, or its boards)."""
    unknown = [n for n in given if n not in stored.names]
    if unknown:
        raise ValueError(f"camera {unknown[0]!r} is not in the stored rig (its cameras: "
                         f"{', '.join(stored.names)})")
    if all(_boards_only(v) for v in given.values()):
        return {n: _Views([f"frame{k}" for k in range(len(v))], list(v)) for n, v in given.items()}
    if spec.kind == "chessboard" and spec.pattern is None:
        raise ValueError(f"board {spec} cannot check a rig: each camera would label its corners its own way; "
                         "give the board's size (chessboard:COLSxROWS)")
    files = {}
    for n, v in given.items():
        files[n] = expand_images([v] if isinstance(v, (str, os.PathLike)) else list(v), recursive=recursive)
        if not files[n]:
            raise ValueError(f"camera {n}: no input images")
    _, matched = match_frames(files)
    out = {}
    for n, paths in matched.items():
        try:
            out[n] = _detect(paths, spec, jobs, read_options, progress)
        except ValueError as exc:
            raise ValueError(f"camera {n}: {exc}") from None
    return out


def _boards_only(v) -> bool:
    return (not isinstance(v, (str, os.PathLike)) and isinstance(v, Sequence) and len(v) > 0
            and all(b is None or isinstance(b, Board) for b in v))


def _check_rig(stored: StoredRig, per: dict[str, _Views], square: float
               ) -> tuple[list[CameraDrift], list[PoseDrift], list[tuple[Verdict, str]]]:
    by_name = {c.name: c for c in stored.cameras}
    drifts, poses, findings, found = [], [], [], {}
    for n in (n for n in stored.names if n in per):
        d, f, found[n] = _check_camera(by_name[n], per[n], square, f"{n}: ")
        drifts.append(d)
        findings += f
    ref = stored.cameras[0]
    for n in (n for n in stored.names[1:] if n in per and ref.name in per):
        p, f = _check_pose(ref, by_name[n], found[ref.name], per[n], square)
        findings += f
        poses += [] if p is None else [p]
    return drifts, poses, findings


def check_calibration(
    stored: str | os.PathLike | StoredRig | StoredCamera | Calibration | RigCalibration,
    images_or_boards: str | os.PathLike | Iterable | Mapping,
    *,
    board: str | BoardSpec = "chessboard:auto",
    jobs: int = 1,
    read_options: dict | None = None,
    recursive: bool = False,
    progress: bool = False,
) -> DriftCheck:
    """Do new views of a board agree with a stored calibration? (module doc: the rule and its limits).

    Parameters
    ----------
    stored : path, StoredRig, StoredCamera, Calibration or RigCalibration
        A ``camera.yaml``, ``camera.json``, ``rig.yaml`` or ``rig.json``, or the output folder holding
        one (read with its standard deviations by :func:`sogdd.calib.exchange.native.read`), or a
        calibration in memory (:func:`~sogdd.calib.exchange.stored_rig`). Two or more cameras are a
        rig; the board's corners are placed with the rig's ``square`` (1 where unknown).
    images_or_boards : paths, or boards; for a rig a mapping of camera name to them
        One camera: image files, folders or glob patterns (``sogdd calibrate``'s inputs), or
        :class:`~sogdd.calib.targets.board.Board` objects (None: a view without one). A rig: per
        camera its images (matched into frames by the numbers in their names,
        :func:`~sogdd.calib.rig.match_frames`) or its boards, one per frame in the same order.
    board : str or BoardSpec
        The board in the images (``--board``); a rig's relative poses need its size.
    jobs, read_options, recursive, progress
        As :func:`sogdd.calib.calibrate_images`.

    Returns
    -------
    DriftCheck

    Raises
    ------
    ValueError
        One line: a missing or unreadable stored file; no images; none readable; no board in any
        view; images of another size than the stored camera's; a rig given the images of one
        camera, or a camera given a rig's; a camera the rig does not have.
    """
    path = ""
    if isinstance(stored, (str, os.PathLike)):
        path, stored = str(stored), native.read(Path(stored))
    else:
        stored = stored_rig(stored)
    is_rig, square = len(stored.cameras) > 1, stored.square or 1.0
    spec = parse_board(board) if isinstance(board, str) else board
    opts = check_read_options(read_options)
    if int(jobs) < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    what = path or "the stored calibration"
    if is_rig != isinstance(images_or_boards, Mapping):
        raise ValueError(f"{what} is a rig of {len(stored.cameras)} cameras ({', '.join(stored.names)}): give "
                         "each camera's images by its name" if is_rig else
                         f"{what} is one camera, not a rig: give its images without camera names")
    if not is_rig:
        views = _as_views(images_or_boards, spec, jobs, opts, recursive, progress)
        drift, findings, _ = _check_camera(stored.cameras[0], views, square, "")
        drifts, poses = [drift], []
    else:
        if not images_or_boards:
            raise ValueError("no cameras given")
        per = _rig_views(stored, images_or_boards, spec, jobs, opts, recursive, progress)
        drifts, poses, findings = _check_rig(stored, per, square)
    level: Verdict = max((lv for lv, _ in findings), key=_ORDER.__getitem__, default="pass")
    if level == "pass":
        rms = "; ".join(f"{d.name + ' ' if is_rig else ''}{d.rms:.3f} px" for d in drifts)
        n = sum(len(d.views) for d in drifts)
        reason = f"{n} view(s) agree with the stored calibration: residual RMS {rms}; {findings[0][1]}"
    else:
        reason = next(t for lv, t in findings if lv == level)
    return DriftCheck(level, reason, tuple(findings), tuple(drifts), tuple(poses), path, is_rig)
