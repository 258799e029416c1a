"""The fit of one camera model to the views with robust rejection: the rounds of :func:`~.fit.calibrate`.

The views are checked at the door (:func:`check_boards`, :func:`usable_reason`,
and with rejection the smeared ones: :func:`~.weighting.smeared_views`), then
fitted (:func:`~.solvers.fit_camera`, each corner weighted by its measured
precision where the boards carry one: :func:`~.weighting.corner_weights`) and
cleaned round by round: the worst view beyond the view rule goes, or every
corner beyond the corner rule (:func:`robust_limit`, on the residuals in px),
until nothing changes (:func:`fit_with_rejection`).
:func:`~.fit.calibrate` and :func:`~.model_selection.select_model` share it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .cameras import project
from .solvers import fit_camera_checked, solve_pose
from .targets.board import Board
from .weighting import corner_weights, smeared_views, typical_precision

__all__ = ["State", "check_boards", "fit_with_rejection", "reject_corners", "reject_view", "robust_limit",
           "usable_reason"]

# a robust standard deviation from the median absolute deviation (exact for a normal distribution)
_MAD_SCALE = 1.4826

def check_boards(boards, names, image_size) -> tuple[list, list[str]]:
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


def usable_reason(board: Board | None, min_corners: int) -> str:
    """Why a view cannot enter the calibration ("" if it can)."""
    if board is None or len(board) == 0:
        return "no board"
    if len(board) < min_corners:
        return f"too few corners ({len(board)} < {min_corners})"
    lab = board.labels
    if len(np.unique(lab[:, 0])) < 2 or len(np.unique(lab[:, 1])) < 2:
        return "corners on one line of the board"
    return ""


def robust_limit(values: np.ndarray, k: float, floor: float) -> float:
    """``max(median + k * 1.4826 * MAD, floor)``."""
    med = float(np.median(values))
    mad = float(np.median(np.abs(values - med)))
    return max(med + k * _MAD_SCALE * mad, floor)


# --------------------------------------------------------------------------------------------------
# calibration with rejection


@dataclass
class State:
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
    #: the set's typical corner precision (px) the weights are relative to; NaN: unweighted
    typical: float = float("nan")

    def weights(self, views) -> list | None:
        """The kept corners' weights of ``views`` (:func:`~.weighting.corner_weights`), None unweighted."""
        if not np.isfinite(self.typical):
            return None
        return [None if self.boards[v] is None
                else corner_weights(self.boards[v], self.typical)[self.corner_ok[v]] for v in views]


def _solve(st: State):
    idx = np.flatnonzero(st.view_ok)
    obj = [st.boards[v].object_points(st.square)[st.corner_ok[v]] for v in idx]
    img = [st.boards[v].image_points[st.corner_ok[v]] for v in idx]
    return idx, fit_camera_checked(obj, img, st.size, st.model, st.flags, f"{len(idx)} views", st.weights(idx))


def _all_residuals(st: State, idx, fit) -> list:
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


def reject_view(st: State, res, limit_c: float, k: float, floor: float, min_views: int,
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
    limit_v = max(robust_limit(vals, k, floor), 3.0 * float(np.median(vals))) if len(vals) else floor
    for v in idx:
        if v not in why and rms[v] > limit_v:
            why[v] = f"RMS {rms[v]:.3g} px far above the other views' (limit {limit_v:.3g} px)"
    if why and len(idx) > min_views:
        worst = max(why, key=lambda v: (rms[v] if np.isfinite(rms[v]) else np.inf, -v))
        st.view_ok[worst] = False
        st.reasons[worst] = why[worst]
    return limit_v


def reject_corners(st: State, res, limit_c: float, min_views: int, min_corners: int) -> int:
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


def _iterate(st: State, k: float, floor: float, min_views: int, min_corners: int, reject: bool,
             max_iterations: int):
    thresholds: dict = {}
    for _ in range(max_iterations):
        idx, fit = _solve(st)
        res = _all_residuals(st, idx, fit)
        if not reject:
            return idx, fit, res, thresholds
        used = np.concatenate([np.hypot(*res[v].T)[st.corner_ok[v]] for v in idx])
        limit_c = robust_limit(used, k, floor)
        n_views = int(st.view_ok.sum())
        limit_v = reject_view(st, res, limit_c, k, floor, min_views, min_corners)
        thresholds = {"corner": limit_c, "view_rms": limit_v}
        if st.view_ok.sum() < n_views:
            continue
        if reject_corners(st, res, limit_c, min_views, min_corners) == 0:
            return idx, fit, res, thresholds
    idx, fit = _solve(st)
    return idx, fit, _all_residuals(st, idx, fit), thresholds


def _too_few(n: int, need: int, reasons: list[str], names: list[str]) -> None:
    seen = {}
    for r, nm in zip(reasons, names):
        if r:
            seen.setdefault(r.split(" (")[0], []).append(nm)
    why = "; ".join(f"{r}: {len(v)}" for r, v in seen.items())
    raise ValueError(f"too few views: {n} usable view(s), calibration needs {need} ({need - n} more)"
                     + (f"; rejected: {why}" if why else ""))


def fit_with_rejection(boards: list, names: list[str], size: tuple[int, int], *, square: float, model: str,
                       flags: int, reject: bool, k: float, floor: float, min_corners: int, min_views: int,
                       max_iterations: int):
    """The views' usability, then the fit with its rejection rounds: ``(state, used, fit, residuals,
    thresholds)`` (``fit`` as :func:`~.solvers.fit_camera` returns it, for the ``used`` views).

    Where every usable board carries its corners' precision, the fit weighs each
    corner by it relative to the set's typical corner (``state.typical``,
    :func:`~.weighting.typical_precision`) and, with ``reject``, the smeared
    views go first (:func:`~.weighting.smeared_views`, never below ``min_views``).

    ``boards`` and ``names`` as :func:`check_boards` returns them. Raises ``ValueError`` with fewer
    than ``min_views`` usable views (saying how many more are needed), or when OpenCV cannot calibrate.
    """
    reasons = [usable_reason(b, min_corners) for b in boards]
    usable = np.array([r == "" for r in reasons])
    if usable.sum() < min_views:
        _too_few(int(usable.sum()), min_views, reasons, names)
    typical = typical_precision(boards, usable)
    if reject:
        for v, why in smeared_views(boards, usable, min_views).items():
            usable[v], reasons[v] = False, why
    st = State(boards, names, float(square), size, model, int(flags), usable.copy(), reasons,
               [np.ones(len(b), bool) if b is not None else None for b in boards], [{} for _ in boards],
               typical)
    idx, fit, res, thresholds = _iterate(st, k, floor, min_views, min_corners, reject, max_iterations)
    return st, idx, fit, res, thresholds
