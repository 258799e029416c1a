"""Camera calibration from labelled boards, through OpenCV, with robust rejection and diagnostics.

:func:`calibrate` fits a camera model to the boards of several views
(``cv2.calibrateCameraExtended`` for the pinhole and rational models,
``cv2.fisheye.calibrate`` for the fisheye one; ``model="auto"``: the model chosen
by cross-validation, :mod:`~sogdd.calib.model_selection`), rejects corners and
views whose residuals lie far beyond the rest (each with its reason,
:mod:`~sogdd.calib.rejection`), and measures how far
two calibrations from the two halves of the views disagree over the image
(:mod:`~sogdd.calib.cross_validation`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from . import cross_validation as _cv
from .cameras import MODELS, check_size, lens
from .model_selection import ModelChoice, check_model_choice, select_model
from .rejection import State, check_boards, fit_with_rejection
from .result import Calibration
from .solvers import fisheye_fixed, jacobian_std
from .targets.board import Board
from .uncertainty import fit_covariance

__all__ = ["SQUARE_RANGE", "calibrate", "check_square", "std_dict"]

#: the board squares a calibration accepts, in any unit (inclusive): the fit is made in squares and its
#: translations scaled by the square afterwards, so any square in the range gives the same intrinsics;
#: beyond it the translations would lose their meaning (a unit of 1e-9 is no board's)
SQUARE_RANGE: tuple[float, float] = (1e-6, 1e6)


def check_square(square: float) -> float:
    """``square`` as a float, refused (a one-line ``ValueError``) unless it is a size in :data:`SQUARE_RANGE`.

    The fits (:func:`calibrate`, :func:`~sogdd.calib.rig.calibrate_rig`) are made
    with the board's points in squares, :math:`X_c = (i, j, 0)`, and every
    translation is then multiplied by ``square``: :math:`t = s\\,t_{squares}`
    (the reprojection :math:`\\pi(K, d, R X + t)` is unchanged when :math:`X` and
    :math:`t` scale together), so the intrinsics cannot depend on the unit.

    Examples
    --------
    >>> check_square(25)
    25.0
    >>> check_square(1e9)
    Traceback (most recent call last):
    ...
    ValueError: square must be from 1e-06 to 1e+06 (the board's square in any unit), got 1000000000.0
    """
    try:
        s = float(square)
    except (TypeError, ValueError):
        raise ValueError(f"square must be a positive size, got {square!r}") from None
    if not np.isfinite(s) or s <= 0:
        raise ValueError(f"square must be a positive size, got {square}")
    lo, hi = SQUARE_RANGE
    if not lo <= s <= hi:
        raise ValueError(f"square must be from {lo:g} to {hi:g} (the board's square in any unit), got {square}")
    return s


def std_dict(std, model: str) -> dict:
    """Name the standard deviations: OpenCV's ``stdDeviationsIntrinsics`` (and :func:`jacobian_std`)
    run fx, fy, cx, cy, then the distortion in OpenCV's order, which is ``MODELS[model]``'s."""
    names = ("fx", "fy", "cx", "cy") + MODELS[model]
    if std is None:
        return {n: float("nan") for n in names}
    return {n: float(s) for n, s in zip(names, std)}




def calibrate(
    boards: Sequence[Board | None],
    image_size: tuple[int, int],
    *,
    square: float = 1.0,
    model: ModelChoice = "pinhole",
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

    Boards that carry their corners' measured precision ``sigma``
    (``Board.precision``; :func:`sogdd.calib.detection.detect_view` measures
    it) are weighted (:mod:`~sogdd.calib.weighting`): the fit minimises
    :math:`\\sum w_{vc}^2 \\lVert x_{vc} - \\pi(\\dots) \\rVert^2` with
    :math:`w = \\sigma_{set} / \\max(\\sigma_{vc}, \\sigma_{set} / 2)`,
    :math:`\\sigma_{set}` the median over the views of their median corner
    precision (``Calibration.typical_precision``). OpenCV's calibration has no
    weights: its solution starts a weighted Levenberg-Marquardt refinement
    (:func:`~sogdd.calib.solvers.refine_weighted`), whose standard deviations
    are reported. Before the fit, ``reject`` drops the smeared views: those whose
    median corner precision exceeds 3 times :math:`\\sigma_{set}` (their reason
    says by how much). The rejection rules above judge the residuals in px.

    Parameters
    ----------
    boards : sequence of Board or None
        One per view (None: no board found there).
    image_size : (width, height)
        Of every view.
    square : float
        Board square size, in any unit from 1e-6 to 1e6 (:data:`SQUARE_RANGE`):
        the fit is made in squares (``s = 1``) and the poses' translations are
        then multiplied by ``square`` (:func:`check_square`), so the intrinsics
        are the same for any unit.
    model : {"pinhole", "pinhole4", "rational", "fisheye", "omnidir", "auto"}
        ``k1, k2, p1, p2, k3``; ``k1, k2, p1, p2`` (k3 held at 0,
        ``CALIB_FIX_K3``: OpenCV's four-coefficient vector); OpenCV's rational
        model (``CALIB_RATIONAL_MODEL``, ``k1..k6, p1, p2``); OpenCV's fisheye
        model (``k1..k4``); the unified omnidirectional model (``cv2.omnidir``,
        ``xi, k1, k2, p1, p2``); each the record of
        :data:`~sogdd.calib.cameras.LENSES`; or ``"auto"``: the model
        :func:`~sogdd.calib.model_selection.select_model` chooses by
        cross-validation over the views (with the same rejection parameters),
        then calibrated as if it had been given; the selection is
        ``Calibration.model_selection`` (``flags`` must then be 0: they are
        one model's).
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
        A ``square`` outside :data:`SQUARE_RANGE`, no corners at all, fewer
        than ``min_views`` usable views (saying how many more are needed), an
        unknown model, points outside ``image_size``, names not matching the
        boards, or OpenCV failing to calibrate.

    Examples
    --------
    >>> from sogdd.calib.cameras import project
    >>> K = np.array([[600.0, 0, 320], [0, 600, 240], [0, 0, 1]])
    >>> obj = np.array([(i, j, 0.0) for j in range(6) for i in range(9)])
    >>> labels = obj[:, :2].astype(int)
    >>> poses = [((0.3 * np.sin(a), 0.3 * np.cos(a), 0.1), (-4.0, -2.5, 12.0)) for a in range(8)]
    >>> boards = [Board(project(obj, K, np.zeros(5), "pinhole", r, t), labels) for r, t in poses]
    >>> cal = calibrate(boards, (640, 480))
    >>> round(float(cal.K[0, 0]), 3), cal.rms < 1e-6, cal.n_used
    (600.0, True, 8)
    """
    check_model_choice(model)
    size = check_size(image_size)
    square = check_square(square)
    if min_views < 1 or min_corners < 4:
        raise ValueError("min_views must be >= 1 and min_corners >= 4")
    boards, names = check_boards(boards, names, size)
    # fitted in squares (X = (i, j, 0)), the translations scaled to the square's unit at the end
    common = dict(square=1.0, reject=reject, k=k, floor=floor, min_corners=min_corners,
                  min_views=min_views, max_iterations=max_iterations)
    if model == "auto":
        if flags:
            raise ValueError("flags are one model's (OpenCV's pinhole and fisheye flags differ): give a model, "
                             "not auto, with flags")
        sel = select_model(boards, size, names=names, **common)
        st, idx, fit, res, thresholds = fit_with_rejection(boards, names, size, model=sel.chosen, flags=0,
                                                           **common)
        cal = _result(st, idx, fit, res, thresholds, min_views, cross_validate)
        return replace(_in_unit(cal, square), model_selection=sel, notes=(*sel.notes, *cal.notes))
    st, idx, fit, res, thresholds = fit_with_rejection(boards, names, size, model=model, flags=flags, **common)
    return _in_unit(_result(st, idx, fit, res, thresholds, min_views, cross_validate), square)


def _in_unit(cal: Calibration, square: float) -> Calibration:
    """A calibration made in squares, its translations in the square's unit: :math:`t = s\\,t_{squares}`."""
    return replace(cal, tvecs=cal.tvecs * square, square=square)


_ONE_VIEW = ("one view: a view of a flat board gives two constraints on the intrinsics, too few to "
             "determine them, so no standard deviation means anything; calibrate with more views")
_DEGENERATE = ("the fit is degenerate: the views cannot tell some parameters apart (boards that all face "
               "the camera, too few corners, or a model with more terms than the data support), so the "
               "standard deviations are undefined")


def _stds(st: State, idx: np.ndarray, fit) -> tuple[np.ndarray | None, str]:
    """The final fit's standard deviations (or None) and why there are none ("" when there are)."""
    K, D, rv, tv, std = fit
    if len(idx) < 2:
        # OpenCV still reports finite ones here, even for a focal length of a sixth of the truth
        return None, _ONE_VIEW
    start = lens(st.model).start
    if start != "calibrateCamera":  # cv2.fisheye / cv2.omnidir give none: the same estimate, computed here
        obj = [st.boards[v].object_points(st.square)[st.corner_ok[v]] for v in idx]
        img = [st.boards[v].image_points[st.corner_ok[v]] for v in idx]
        fixed = fisheye_fixed(st.flags) if start == "fisheye.calibrate" else None
        std = jacobian_std(obj, img, K, D, rv, tv, st.model, fixed, st.weights(idx))
    if std is None or not np.all(np.isfinite(std)):
        return None, _DEGENERATE
    return std, ""


def _covariance(st: State, idx: np.ndarray, fit) -> tuple[np.ndarray, str]:
    """The final fit's intrinsics' covariance (:func:`~sogdd.calib.uncertainty.fit_covariance`, empty where
    there is none) and why there is none ("" when there is)."""
    K, D, rv, tv, _ = fit
    start = lens(st.model).start
    if start == "fisheye.calibrate":
        free = ~np.asarray(fisheye_fixed(st.flags), bool)
    elif start == "calibrateCamera" and st.flags == 0:
        free = None
    else:  # the pinhole flags' held terms are not mapped to the Jacobian's columns here
        return np.zeros((0, 0)), (f"the {st.model} model has no analytic Jacobian" if start != "calibrateCamera"
                                  else "extra OpenCV flags")
    obj = [st.boards[v].object_points(st.square)[st.corner_ok[v]] for v in idx]
    img = [st.boards[v].image_points[st.corner_ok[v]] for v in idx]
    return fit_covariance(obj, img, K, D, rv, tv, st.model, free, st.weights(idx))


def _result(st: State, idx, fit, res, thresholds, min_views: int, cross_validate: bool) -> Calibration:
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
                                      model=st.model, flags=st.flags, min_views=min_views,
                                      weights=st.weights(range(V)))
        if note:
            notes.append(note)
    std, std_note = _stds(st, idx, fit)
    if std_note:
        notes.append(f"no standard deviations: {std_note}")
    cov, cov_note = (np.zeros((0, 0)), "") if std is None else _covariance(st, idx, fit)
    if cov_note:
        notes.append(f"no projection uncertainty: {cov_note}")
    corner_used = tuple(
        None if b is None else (st.corner_ok[v] & bool(st.view_ok[v])) for v, b in enumerate(st.boards))
    return Calibration(
        model=st.model, image_size=st.size, K=K, dist=D, rms=float(np.sqrt(used_r2.mean())),
        std=std_dict(std, st.model), std_note=std_note, names=tuple(st.names), boards=tuple(st.boards),
        residuals=tuple(res), corner_used=corner_used, view_used=st.view_ok.copy(), view_rms=view_rms,
        reasons=tuple(st.reasons), corner_reasons=tuple(st.corner_reasons), rvecs=rvecs, tvecs=tvecs,
        cross_validation=cv, thresholds=thresholds, notes=tuple(notes), square=st.square,
        typical_precision=st.typical, covariance=cov)
