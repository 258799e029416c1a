"""Camera calibration from labelled boards, through OpenCV, with robust rejection and diagnostics.

:func:`calibrate` fits a camera model to the boards of several views
(``cv2.calibrateCameraExtended`` for the pinhole and rational models,
``cv2.fisheye.calibrate`` for the fisheye one), rejects corners and views whose
residuals lie far beyond the rest (each with its reason), and measures how far
two calibrations from the two halves of the views disagree over the image
(:mod:`~sogdd.calib.cross_validation`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from . import cross_validation as _cv
from .cameras import MODELS, CameraModel, check_model, check_size, project
from .result import Calibration
from .solvers import fisheye_fixed, fit_camera_checked, jacobian_std, solve_pose
from .targets.board import Board

__all__ = ["calibrate"]

# a robust standard deviation from the median absolute deviation (exact for a normal distribution)
_MAD_SCALE = 1.4826


# --------------------------------------------------------------------------------------------------
# validation at the door


def _check_boards(boards, names, image_size) -> tuple[list, list[str]]:
    boards = list(boards)
    names = [f"view {i}" for i in range(len(boards))] if names is None else [str(n) for n in names]
    if len(names) != len(boards):
        raise ValueError(f"{len(boards)} boards but {len(names)} view names")
    w, h = image_size
    for b, n in zip(boards, names):
        if b is None:
            continue
        if not isinstance(b, Board):
            raise ValueError(f"{n}: expected a Board or None, got {type(b).__name__}")
        p = b.image_points
        if not np.all(np.isfinite(p)):
            raise ValueError(f"{n}: corner positions must be finite")
        out = (p[:, 0] < -0.5) | (p[:, 0] > w - 0.5) | (p[:, 1] < -0.5) | (p[:, 1] > h - 0.5)
        if out.any():
            x, y = p[np.argmax(out)]
            raise ValueError(f"{n}: corner at ({x:.1f}, {y:.1f}) lies outside the {w}x{h} image; "
                             "image_size is (width, height) and must be the size of every view")
        if len(np.unique(b.labels, axis=0)) != len(b):
            raise ValueError(f"{n}: two corners share a board label")
    if not any(b is not None and len(b) for b in boards):
        raise ValueError("no corners: no view has a board")
    return boards, names


def _usable(board: Board | None, min_corners: int) -> str:
    """Why a view cannot enter the calibration ("" if it can)."""
    if board is None or len(board) == 0:
        return "no board"
    if len(board) < min_corners:
        return f"too few corners ({len(board)} < {min_corners})"
    lab = board.labels
    if len(np.unique(lab[:, 0])) < 2 or len(np.unique(lab[:, 1])) < 2:
        return "corners on one line of the board"
    return ""


def _std_dict(std, model: str) -> dict:
    """Name the standard deviations: OpenCV's ``stdDeviationsIntrinsics`` (and :func:`jacobian_std`)
    run fx, fy, cx, cy, then the distortion in OpenCV's order, which is ``MODELS[model]``'s."""
    names = ("fx", "fy", "cx", "cy") + MODELS[model]
    if std is None:
        return {n: float("nan") for n in names}
    return {n: float(s) for n, s in zip(names, std)}


def _robust_limit(values: np.ndarray, k: float, floor: float) -> float:
    """``max(median + k * 1.4826 * MAD, floor)``."""
    med = float(np.median(values))
    mad = float(np.median(np.abs(values - med)))
    return max(med + k * _MAD_SCALE * mad, floor)


# --------------------------------------------------------------------------------------------------
# calibration with rejection


@dataclass
class _State:
    boards: list
    names: list[str]
    square: float
    size: tuple[int, int]
    model: str
    flags: int
    view_ok: np.ndarray
    reasons: list[str]
    corner_ok: list
    corner_reasons: list


def _solve(st: _State):
    idx = np.flatnonzero(st.view_ok)
    obj = [st.boards[v].object_points(st.square)[st.corner_ok[v]] for v in idx]
    img = [st.boards[v].image_points[st.corner_ok[v]] for v in idx]
    return idx, fit_camera_checked(obj, img, st.size, st.model, st.flags, f"{len(idx)} views")


def _all_residuals(st: _State, idx, fit) -> list:
    """Observed minus projected position of every corner of every view with a pose."""
    K, D, rv, tv, _ = fit
    out: list = [None] * len(st.boards)
    poses = {v: (rv[n], tv[n]) for n, v in enumerate(idx)}
    for v, b in enumerate(st.boards):
        if b is None or len(b) == 0:
            continue
        pose = poses.get(v) or (solve_pose(b, st.square, K, D, st.model) if len(b) >= 4 else None)
        if pose is None:
            continue
        proj = project(b.object_points(st.square), K, D, st.model, pose[0], pose[1])
        out[v] = b.image_points - proj
    return out


def _reject_view(st: _State, res, limit_c: float, k: float, floor: float, min_views: int,
                 min_corners: int) -> float:
    """Reject the worst view beyond the view rule (one per iteration); return the view threshold."""
    idx = np.flatnonzero(st.view_ok)
    rms = np.full(len(st.boards), np.nan)
    why: dict[int, str] = {}
    for v in idx:
        r = np.hypot(*res[v].T)
        bad = r > limit_c
        keep = st.corner_ok[v] & ~bad
        rms[v] = float(np.sqrt(np.mean(r[keep] ** 2))) if keep.any() else np.inf
        if bad.mean() > 0.5:
            why[v] = f"most corners far off ({int(bad.sum())} of {len(r)} beyond {limit_c:.3g} px)"
        elif keep.sum() < min_corners:
            why[v] = f"too few corners left after rejection ({int(keep.sum())} < {min_corners})"
    vals = rms[idx][np.isfinite(rms[idx])]
    limit_v = max(_robust_limit(vals, k, floor), 3.0 * float(np.median(vals))) if len(vals) else floor
    for v in idx:
        if v not in why and rms[v] > limit_v:
            why[v] = f"RMS {rms[v]:.3g} px far above the other views' (limit {limit_v:.3g} px)"
    if why and len(idx) > min_views:
        worst = max(why, key=lambda v: (rms[v] if np.isfinite(rms[v]) else np.inf, -v))
        st.view_ok[worst] = False
        st.reasons[worst] = why[worst]
    return limit_v


def _reject_corners(st: _State, res, limit_c: float, min_views: int, min_corners: int) -> int:
    """Mark the used views' corners beyond ``limit_c`` rejected and re-admit those back within it
    (a gross outlier drags its view's pose, and with it its neighbours, until it is gone);
    return how many changed. A view left with fewer than ``min_corners`` goes as a whole
    (while more than ``min_views`` remain; else its corners stay)."""
    n = 0
    for v in np.flatnonzero(st.view_ok):
        r = np.hypot(*res[v].T)
        ok = r <= limit_c
        if ok.sum() < min_corners:
            if st.view_ok.sum() > min_views:
                st.view_ok[v] = False
                st.reasons[v] = (f"too few corners left after rejection ({int(ok.sum())} < {min_corners} "
                                 f"within {limit_c:.3g} px)")
                n += 1
            continue
        n += int(np.sum(ok != st.corner_ok[v]))
        st.corner_ok[v] = ok
        st.corner_reasons[v] = {int(c): f"residual {r[c]:.3g} px beyond the limit {limit_c:.3g} px"
                                for c in np.flatnonzero(~ok)}
    return n


def _iterate(st: _State, k: float, floor: float, min_views: int, min_corners: int, reject: bool,
             max_iterations: int):
    thresholds: dict = {}
    for _ in range(max_iterations):
        idx, fit = _solve(st)
        res = _all_residuals(st, idx, fit)
        if not reject:
            return idx, fit, res, thresholds
        used = np.concatenate([np.hypot(*res[v].T)[st.corner_ok[v]] for v in idx])
        limit_c = _robust_limit(used, k, floor)
        n_views = int(st.view_ok.sum())
        limit_v = _reject_view(st, res, limit_c, k, floor, min_views, min_corners)
        thresholds = {"corner": limit_c, "view_rms": limit_v}
        if st.view_ok.sum() < n_views:
            continue
        if _reject_corners(st, res, limit_c, min_views, min_corners) == 0:
            return idx, fit, res, thresholds
    idx, fit = _solve(st)
    return idx, fit, _all_residuals(st, idx, fit), thresholds


def calibrate(
    boards: Sequence[Board | None],
    image_size: tuple[int, int],
    *,
    square: float = 1.0,
    model: CameraModel = "pinhole",
    names: Sequence[str] | None = None,
    reject: bool = True,
    k: float = 5.0,
    floor: float = 0.1,
    min_corners: int = 6,
    min_views: int = 3,
    cross_validate: bool = True,
    flags: int = 0,
    max_iterations: int = 30,
) -> Calibration:
    """Calibrate a camera from boards seen in several views, rejecting corners and views far off.

    The model (``cv2.calibrateCameraExtended``; fisheye: ``cv2.fisheye.calibrate``)
    minimises :math:`\\sum_{v,c} \\lVert x_{vc} - \\pi(K, d, R_v X_c + t_v) \\rVert^2`
    over the intrinsics ``K``, distortion ``d`` and each view's pose, with
    :math:`X_c = (i s, j s, 0)` the board point of corner label ``(i, j)``
    (``s = square``). Rejection repeats until nothing changes: with ``r`` the
    residual lengths of the used corners,

    - a view goes, the worst first and one per round, when more than half its
      corners lie beyond the corner limit, when fewer than ``min_corners`` of
      its corners remain, or when its RMS exceeds
      ``max(median + k * 1.4826 * MAD, 3 * median, floor)`` over the views' RMS;
    - otherwise every corner with :math:`r > \\max(\\mathrm{median}(r) + k \\cdot 1.4826
      \\cdot \\mathrm{MAD}(r), \\mathrm{floor})` goes (for normal noise, ``k = 5`` rejects
      about 4e-5 of good corners).

    Views are never rejected below ``min_views``. The cross-validation
    calibrates the even- and odd-ranked used views separately and measures
    :func:`projection_difference` between the two cameras.

    Parameters
    ----------
    boards : sequence of Board or None
        One per view (None: no board found there).
    image_size : (width, height)
        Of every view.
    square : float
        Board square size (any unit; the poses are in it).
    model : {"pinhole", "rational", "fisheye"}
        ``k1, k2, p1, p2, k3``; OpenCV's rational model (``CALIB_RATIONAL_MODEL``,
        ``k1..k6, p1, p2``); or OpenCV's fisheye model (``k1..k4``).
    names : sequence of str, optional
        A name per view (e.g. the image files), used in reasons and errors.
    reject : bool
        Reject outlying corners and views.
    k, floor : float
        The rejection rule's multiple of the robust standard deviation, and its
        lower limit in px.
    min_corners, min_views : int
        Fewest corners for a view, fewest usable views (>= 1).
    cross_validate : bool
        Compute the two halves' cross-validation.
    flags : int
        Extra OpenCV calibration flags (e.g. ``cv2.CALIB_FIX_K3``).
    max_iterations : int
        Most rejection rounds.

    Returns
    -------
    Calibration

    Raises
    ------
    ValueError
        No corners at all, fewer than ``min_views`` usable views (saying how
        many more are needed), an unknown model, points outside ``image_size``,
        names not matching the boards, or OpenCV failing to calibrate.

    Examples
    --------
    >>> K = np.array([[600.0, 0, 320], [0, 600, 240], [0, 0, 1]])
    >>> obj = np.array([(i, j, 0.0) for j in range(6) for i in range(9)])
    >>> labels = obj[:, :2].astype(int)
    >>> poses = [((0.3 * np.sin(a), 0.3 * np.cos(a), 0.1), (-4.0, -2.5, 12.0)) for a in range(8)]
    >>> boards = [Board(project(obj, K, np.zeros(5), "pinhole", r, t), labels) for r, t in poses]
    >>> cal = calibrate(boards, (640, 480))
    >>> round(float(cal.K[0, 0]), 3), cal.rms < 1e-6, cal.n_used
    (600.0, True, 8)
    """
    check_model(model)
    size = check_size(image_size)
    if not np.isfinite(square) or square <= 0:
        raise ValueError(f"square must be a positive size, got {square}")
    if min_views < 1 or min_corners < 4:
        raise ValueError("min_views must be >= 1 and min_corners >= 4")
    boards, names = _check_boards(boards, names, size)
    reasons = [_usable(b, min_corners) for b in boards]
    usable = np.array([r == "" for r in reasons])
    if usable.sum() < min_views:
        _too_few(int(usable.sum()), min_views, reasons, names)
    st = _State(boards, names, float(square), size, model, int(flags), usable.copy(), reasons,
                [np.ones(len(b), bool) if b is not None else None for b in boards],
                [{} for _ in boards])
    idx, fit, res, thresholds = _iterate(st, k, floor, min_views, min_corners, reject, max_iterations)
    return _result(st, idx, fit, res, thresholds, min_views, cross_validate)


def _too_few(n: int, need: int, reasons: list[str], names: list[str]) -> None:
    seen = {}
    for r, nm in zip(reasons, names):
        if r:
            seen.setdefault(r.split(" (")[0], []).append(nm)
    why = "; ".join(f"{r}: {len(v)}" for r, v in seen.items())
    raise ValueError(f"too few views: {n} usable view(s), calibration needs {need} ({need - n} more)"
                     + (f"; rejected: {why}" if why else ""))


_ONE_VIEW = ("one view: a view of a flat board gives two constraints on the intrinsics, too few to "
             "determine them, so no standard deviation means anything; calibrate with more views")
_DEGENERATE = ("the fit is degenerate: the views cannot tell some parameters apart (boards that all face "
               "the camera, too few corners, or a model with more terms than the data support), so the "
               "standard deviations are undefined")


def _stds(st: _State, idx: np.ndarray, fit) -> tuple[np.ndarray | None, str]:
    """The final fit's standard deviations (or None) and why there are none ("" when there are)."""
    K, D, rv, tv, std = fit
    if len(idx) < 2:
        # OpenCV still reports finite ones here, even for a focal length of a sixth of the truth
        return None, _ONE_VIEW
    if st.model == "fisheye":  # cv2.fisheye.calibrate gives none: the same estimate, computed here
        obj = [st.boards[v].object_points(st.square)[st.corner_ok[v]] for v in idx]
        img = [st.boards[v].image_points[st.corner_ok[v]] for v in idx]
        std = jacobian_std(obj, img, K, D, rv, tv, st.model, fisheye_fixed(st.flags))
    if std is None or not np.all(np.isfinite(std)):
        return None, _DEGENERATE
    return std, ""


def _result(st: _State, idx, fit, res, thresholds, min_views: int, cross_validate: bool) -> Calibration:
    K, D, rv, tv, _ = fit
    V = len(st.boards)
    rvecs = np.full((V, 3), np.nan)
    tvecs = np.full((V, 3), np.nan)
    rvecs[idx], tvecs[idx] = rv, tv
    view_rms = np.full(V, np.nan)
    for v in range(V):
        if res[v] is None:
            continue
        r2 = np.sum(res[v] ** 2, axis=1)
        sel = st.corner_ok[v] if st.view_ok[v] else np.ones(len(r2), bool)
        view_rms[v] = float(np.sqrt(r2[sel].mean())) if sel.any() else np.nan
    used_r2 = np.concatenate([np.sum(res[v][st.corner_ok[v]] ** 2, axis=1) for v in idx])
    notes = []
    cv = None
    if cross_validate:
        cv, note = _cv.cross_validate(st.boards, st.corner_ok, idx, square=st.square, image_size=st.size,
                                  model=st.model, flags=st.flags, min_views=min_views)
        if note:
            notes.append(note)
    std, std_note = _stds(st, idx, fit)
    if std_note:
        notes.append(f"no standard deviations: {std_note}")
    corner_used = tuple(
        None if b is None else (st.corner_ok[v] & bool(st.view_ok[v])) for v, b in enumerate(st.boards))
    return Calibration(
        model=st.model, image_size=st.size, K=K, dist=D, rms=float(np.sqrt(used_r2.mean())),
        std=_std_dict(std, st.model), std_note=std_note, names=tuple(st.names), boards=tuple(st.boards),
        residuals=tuple(res), corner_used=corner_used, view_used=st.view_ok.copy(), view_rms=view_rms,
        reasons=tuple(st.reasons), corner_reasons=tuple(st.corner_reasons), rvecs=rvecs, tvecs=tvecs,
        cross_validation=cv, thresholds=thresholds, notes=tuple(notes), square=st.square)
