"""The lens model chosen by the data: k-fold cross-validation over views (:func:`select_model`).

A model with more coefficients always fits the corners it saw better; whether
it predicts the corners of views it did not see better is what the lens needs.
Each candidate is fitted to all views but one fold, each held-out view's pose
is fitted to its corners with the candidate's intrinsics, and the held-out
corners' residuals score the candidate. The simplest candidate within the
noise of the best is chosen.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

from .cameras import LENSES, MODELS, check_model, check_size, lens, project, undistort
from .rejection import check_boards, fit_with_rejection, usable_reason
from .solvers import fisheye_fixed, fit_camera, fit_fisheye_from, solve_pose
from .targets.board import Board

__all__ = ["DEFAULT_CANDIDATES", "CandidateScore", "ModelChoice", "ModelSelection", "HigherTerms",
           "check_model_choice", "fix_flags", "select_model", "higher_terms"]

#: a model, or "auto": the one :func:`select_model` chooses
ModelChoice = Literal[("auto", *LENSES)]  # type: ignore[valid-type]

#: the candidates for any lens, simplest first: the registered models whose rule (``auto_fov``) is 0;
#: the others join them for a lens that sees more than their ``auto_fov`` (see select_model)
DEFAULT_CANDIDATES: tuple[str, ...] = tuple(n for n, m in LENSES.items() if m.auto_fov == 0.0)

# a lens is wide when a preliminary fit sees more than this across the frame's diagonal
# (degrees): beyond it a rectilinear projection stretches the edges without bound (tan 60 = 1.7);
# the narrowest field any registered wide model asks for (the fisheye's 120)
_WIDE_FOV = min((m.auto_fov for m in LENSES.values() if m.auto_fov), default=np.inf)
# the held-out score must exceed the best one by more than this many standard errors of the
# paired difference before a simpler model is given up (the one-standard-error rule of
# Breiman et al. 1984; Hastie, Tibshirani & Friedman, "Elements of Statistical Learning" 7.10) ...
_NOISE_SE = 1.0
# ... and by more than this share of the best score: held-out residuals of RMS e_c = sqrt(s^2 + b^2)
# against e_b = s carry a model error b = s sqrt((1 + t)^2 - 1), 0.2 s for t = 0.02 -- below what
# any use of the camera notices, while an unneeded k3 costs accuracy beyond the boards
_TOLERANCE = 0.02


@dataclass(frozen=True)
class CandidateScore:
    """One candidate model's row of the selection table.

    Attributes
    ----------
    model : str
    n_coefficients : int
        Its distortion coefficients (``len(MODELS[model])``).
    fit_rms : float
        RMS reprojection error of its fit to all the selection's views (px).
    cv_rms : float
        RMS of the held-out corners' residuals over all folds (px); inf when
        it failed (``note`` says why), NaN without a cross-validation.
    cv_se : float
        Standard error of ``cv_rms`` over the views (px).
    difference, difference_se : float
        ``cv_rms`` minus the best candidate's, and the standard error of that
        difference from the per-view paired differences (px).
    within_noise : bool
        Whether ``difference`` is within the rule's tolerance.
    note : str
        Why the candidate failed ("" when it did not).
    """

    model: str
    n_coefficients: int
    fit_rms: float
    cv_rms: float
    cv_se: float
    difference: float
    difference_se: float
    within_noise: bool
    note: str = ""


@dataclass(frozen=True)
class ModelSelection:
    """The lens model chosen by cross-validation (:func:`select_model`), with its table.

    Attributes
    ----------
    chosen : str
        The chosen model.
    table : tuple of CandidateScore
        One row per candidate, in the order they were tried.
    folds : tuple of tuple of int
        The views held out in each fold (indices into the boards); empty
        without a cross-validation.
    rule : str
        How the model was chosen, in plain words.
    views : tuple of int
        The views the selection used (after the rejection, with ``reject``).
    notes : tuple of str
        What the selection could not do (too few views; a lens judged wide).
    """

    chosen: str
    table: tuple[CandidateScore, ...]
    folds: tuple[tuple[int, ...], ...]
    rule: str
    views: tuple[int, ...] = ()
    notes: tuple[str, ...] = ()

    def row(self, model: str) -> CandidateScore:
        """The table's row of ``model`` (``KeyError`` if it was no candidate)."""
        for r in self.table:
            if r.model == model:
                return r
        raise KeyError(model)


def check_model_choice(model: str) -> None:
    """``ValueError`` naming the choices if ``model`` is neither "auto" nor one of :data:`MODELS`."""
    if model != "auto" and model not in MODELS:
        raise ValueError(f"unknown camera model {model!r}; choose auto or one of {', '.join(MODELS)}")


def _order(model: str) -> tuple[int, int]:
    """Simplest first: fewer coefficients, then the order of :data:`MODELS`."""
    return len(MODELS[model]), list(MODELS).index(model)


def _check_candidates(candidates) -> tuple[str, ...] | None:
    if candidates is None:
        return None
    out: list[str] = []
    for c in candidates:
        check_model(c)
        if c not in out:
            out.append(c)
    if not out:
        raise ValueError("candidates: give at least one model")
    return tuple(out)


def _diagonal_fov(K: np.ndarray, dist: np.ndarray, size: tuple[int, int], model: str) -> float:
    """The angle (degrees) between the rays of opposite frame corners, the larger diagonal; 180 when a
    corner has no ray (the model folds before the frame's corner: a lens too wide for it)."""
    w, h = size
    px = np.array([[-0.5, -0.5], [w - 0.5, h - 0.5], [w - 0.5, -0.5], [-0.5, h - 0.5]])
    xy, ok = undistort(px, K, dist, model)
    if not ok.all():
        return 180.0
    rays = np.c_[xy, np.ones(4)]
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    return float(max(np.degrees(np.arccos(np.clip(rays[a] @ rays[b], -1, 1))) for a, b in ((0, 1), (2, 3))))


def _wide_models(fov: float) -> tuple[str, ...]:
    """The registered models that join the candidates of a lens seen to span ``fov`` degrees: those
    whose rule (``auto_fov > 0``) it exceeds, narrowest rule first."""
    wide = [n for n, m in LENSES.items() if m.auto_fov and fov > m.auto_fov]
    return tuple(sorted(wide, key=lambda n: LENSES[n].auto_fov))


def _is_wide(obj, img, size) -> tuple[tuple[str, ...], str]:
    """The wide models that join the candidates (:func:`_wide_models`), and what showed the lens wide: a
    preliminary pinhole4 or rational fit that sees more than 120 degrees across the frame's diagonal, or
    fails (then the lens is taken to see 180). Both: a pinhole4 fit of a fisheye puts its focal length
    near twice the truth and sees only 110 degrees where the lens sees 180; the rational model follows
    the lens further out. The largest field either fit sees decides."""
    seen, why = 0.0, ""
    for model in ("pinhole4", "rational"):
        try:
            K, D, _, _, _ = fit_camera(obj, img, size, model, 0)
        except cv2.error:
            seen, why = 180.0, why or f"the preliminary {model} fit failed"
            break
        fov = _diagonal_fov(K, D, size, model)
        if fov > _WIDE_FOV and not why:
            why = (f"the preliminary {model} fit sees {fov:.0f} deg across the frame's diagonal "
                   f"(> {_WIDE_FOV:.0f})")
        seen = max(seen, fov)
        if why and not _wide_models(180.0)[len(_wide_models(seen)):]:
            break  # every wide model has joined: no need to look further
    added = _wide_models(seen)
    return (added, f"{why}: {', '.join(added)} added to the candidates") if added else ((), "")


def _check_numbers(square, folds, noise_se, min_views, min_corners) -> None:
    if not np.isfinite(square) or square <= 0:
        raise ValueError(f"square must be a positive size, got {square}")
    if int(folds) != folds or folds < 2:
        raise ValueError(f"folds must be an integer >= 2, got {folds}")
    if not (noise_se >= 0 and np.isfinite(noise_se)):
        raise ValueError(f"noise_se must be a finite value >= 0, got {noise_se}")
    if min_views < 1 or min_corners < 4:
        raise ValueError("min_views must be >= 1 and min_corners >= 4")


def _default_candidates(boards, size, square, min_corners, min_views) -> tuple[tuple[str, ...], str]:
    """:data:`DEFAULT_CANDIDATES`, and the wide models for a wide lens (:func:`_is_wide`), with why."""
    ok = [v for v, b in enumerate(boards) if usable_reason(b, min_corners) == ""]
    if len(ok) < min_views:
        return DEFAULT_CANDIDATES, ""
    wide, why = _is_wide([boards[v].object_points(square) for v in ok], [boards[v].image_points for v in ok],
                         size)
    return (*DEFAULT_CANDIDATES, *wide), why


def _fold_sizes(n: int, folds: int, min_views: int) -> int:
    """The number of folds to use for ``n`` views (``folds``, else leave-one-out), 0 when none fits:
    every training set needs ``min_views`` views."""
    k = min(folds, n)
    if k >= 2 and n - -(-n // k) >= min_views:
        return k
    return n if n >= 2 and n - 1 >= min_views else 0


def _held_out(board: Board, ok: np.ndarray, square: float, K, D, model: str) -> float | None:
    """Sum of squared residual lengths of a held-out view's kept corners, its pose fitted to them with
    the camera ``(K, D)``; None without a pose."""
    sub = Board(board.image_points[ok], board.labels[ok])
    pose = solve_pose(sub, square, K, D, model)
    if pose is None:
        return None
    r = sub.image_points - project(sub.object_points(square), K, D, model, pose[0], pose[1])
    s = float(np.sum(r * r))
    return s if np.isfinite(s) else None


def _ratio_se(s: np.ndarray, n: np.ndarray) -> float:
    """Standard error of :math:`\\sum_v s_v / \\sum_v n_v` over the views (a ratio estimator):
    :math:`\\sqrt{V / (V - 1) \\sum_v (s_v - n_v m)^2} / N`, :math:`m = \\sum s / N`."""
    V, N = len(s), float(np.sum(n))
    if V < 2:
        return float("nan")
    m = float(np.sum(s)) / N
    return float(np.sqrt(V / (V - 1) * np.sum((s - n * m) ** 2)) / N)


def select_model(
    boards: Sequence[Board | None],
    image_size: tuple[int, int],
    *,
    square: float = 1.0,
    candidates: Sequence[str] | None = None,
    folds: int = 5,
    names: Sequence[str] | None = None,
    reject: bool = True,
    min_views: int = 3,
    min_corners: int = 6,
    k: float = 5.0,
    floor: float = 0.1,
    noise_se: float = _NOISE_SE,
    tolerance: float = _TOLERANCE,
    max_iterations: int = 30,
) -> ModelSelection:
    """Choose the lens model by k-fold cross-validation over views.

    1. With ``reject``, the views are cleaned once by the most flexible
       candidate's fit with rejection (the rational model; for a wide lens,
       where that rejects more than a tenth of the corners, the fisheye model
       too, the one keeping more corners kept): the folds then fit without
       rejection, every candidate on the same corners.
    2. The used views, ranked by index, go round-robin into ``F`` folds (view
       of rank ``r`` into fold ``r mod F``; ``F = folds``, or one per view
       when fewer views than that leave too few to fit).
    3. In each fold each candidate is fitted to the other folds' views
       (:func:`~sogdd.calib.solvers.fit_camera`, as :func:`calibrate` with
       ``reject=False``), and each held-out view's pose is fitted to its
       corners with those intrinsics (:func:`~sogdd.calib.solvers.solve_pose`).
       With :math:`s_{cv}` the sum of squared residual lengths of view ``v``'s
       :math:`n_v` corners under candidate ``c``, the score is
       :math:`e_c = \\sqrt{\\sum_v s_{cv} / \\sum_v n_v}` (px).
    4. With ``b`` the best candidate, the difference :math:`e_c - e_b` has the
       standard error :math:`\\mathrm{SE}(\\sum_f d_f / N) / (e_c + e_b)` of the
       per-fold paired differences :math:`d_f = \\sum_{v \\in f} (s_{cv} - s_{bv})`
       (a ratio estimator over the folds, :func:`_ratio_se`). The folds are the
       units: a fold's held-out views share one fitted camera, so its views'
       errors are not independent; pairing removes what all candidates share,
       the views' corner noise.
    5. Chosen: the candidate with the fewest distortion coefficients (pinhole4
       and fisheye 4 < pinhole 5 < rational 8; a tie to the lower score) whose
       difference is at most ``max(noise_se * SE, tolerance * e_b)``: the
       one-standard-error rule of cross-validation (Breiman et al. 1984), with
       a floor of 2 % of the best score. A richer model must predict unseen
       views better by more than its score's noise, and by more than a model
       error of a fifth of the corner noise (:math:`\\sqrt{1.02^2 - 1} = 0.2`):
       on synthetic boards of a lens with k3 = 0 a free k3 predicted 0.3 %
       better, consistently over the folds (SE 0.07 %), and an unneeded k3
       costs accuracy beyond the boards, where nothing checks it. Real
       misfits are far larger: pinhole4 on a lens with k3 = -0.05 seeing 134
       degrees across, 170 % worse; pinhole4 and rational on a fisheye,
       160-180 %.

    Candidates by default: pinhole4, pinhole, rational; fisheye joins them when
    the lens is wide: a preliminary pinhole4 or rational fit of all usable
    views (no rejection) sees more than 120 degrees across the frame's diagonal
    (or its distortion has no ray for a frame corner), or fails (the rendered
    sequences' lenses: 76-78 degrees; fisheyes of 180 degrees and more and a
    rectilinear lens of 106 degrees with strong barrel distortion: 134-180).
    In general each registered model whose rule (``auto_fov`` of its record) the
    largest field either preliminary fit sees exceeds joins (a failed fit: 180 degrees):
    fisheye beyond 120, omnidir beyond 150.
    In the folds a fisheye is refitted from its fit to all views. With fewer views than leave-one-out
    needs (``min_views + 1``), nothing is cross-validated: the simplest
    candidate is chosen, with a note.

    Parameters
    ----------
    boards, image_size, square, names, reject, min_views, min_corners, k, floor, max_iterations
        As :func:`~sogdd.calib.calibrate`.
    candidates : sequence of str, optional
        Models to compare (default above; given ones are used as they are).
    folds : int
        Number of folds (>= 2).
    noise_se : float
        The rule's tolerance in standard errors of the paired difference (>= 0).
    tolerance : float
        The rule's floor, a share of the best score (>= 0).

    Returns
    -------
    ModelSelection

    Raises
    ------
    ValueError
        Bad parameters, too few usable views, or no candidate that OpenCV can fit.

    Examples
    --------
    >>> K = np.array([[600.0, 0, 320], [0, 600, 240], [0, 0, 1]])
    >>> obj = np.array([(i, j, 0.0) for j in range(6) for i in range(9)])
    >>> labels = obj[:, :2].astype(int)
    >>> rng = np.random.default_rng(1)
    >>> poses = [((0.4 * np.sin(a), 0.4 * np.cos(a), 0.1), (-4.0 + np.cos(a), -2.5 + np.sin(a), 11.0))
    ...          for a in np.linspace(0, 6, 10)]
    >>> boards = [Board(project(obj, K, np.array([-0.2, 0.05, 0, 0]), "pinhole", r, t)
    ...                 + rng.normal(0, 0.1, (54, 2)), labels) for r, t in poses]
    >>> sel = select_model(boards, (640, 480))
    >>> sel.chosen, [r.model for r in sel.table], len(sel.folds)
    ('pinhole4', ['pinhole4', 'pinhole', 'rational'], 5)
    """
    size = check_size(image_size)
    cands = _check_candidates(candidates)
    _check_numbers(square, folds, noise_se, min_views, min_corners)
    square = 1.0  # made in squares: nothing it gives has a unit, so the square's size cannot change it
    if not (tolerance >= 0 and np.isfinite(tolerance)):
        raise ValueError(f"tolerance must be a finite value >= 0, got {tolerance}")
    boards, names = check_boards(boards, names, size)
    notes: list[str] = []
    if cands is None:
        cands, why = _default_candidates(boards, size, square, min_corners, min_views)
        notes += [why] if why else []
    common = dict(square=square, flags=0, k=k, floor=floor, min_corners=min_corners, min_views=min_views,
                  max_iterations=max_iterations)
    used, corner_ok = _cleaned(boards, names, size, cands, reject, common)
    obj = {v: boards[v].object_points(square)[corner_ok[v]] for v in used}
    img = {v: boards[v].image_points[corner_ok[v]] for v in used}
    full = {c: _fit(c, [obj[v] for v in used], [img[v] for v in used], size) for c in cands}
    n_folds = _fold_sizes(len(used), int(folds), min_views)
    if n_folds == 0:
        chosen = min(cands, key=_order)
        notes.append(f"too few views to cross-validate ({len(used)} used; leave-one-out needs "
                     f"{min_views + 1}): the simplest candidate, {chosen}, without a comparison")
        table = tuple(CandidateScore(c, len(MODELS[c]), full[c][1], float("nan"), float("nan"), float("nan"),
                                     float("nan"), c == chosen, full[c][2]) for c in cands)
        return ModelSelection(chosen, table, (), "the simplest candidate (too few views to compare them)",
                              tuple(int(v) for v in used), tuple(notes))
    if n_folds < folds:
        notes.append(f"leave-one-out: {len(used)} views are too few for {folds} folds")
    fold_of = np.arange(len(used)) % n_folds
    s, why = _scores(boards, names, used, corner_ok, obj, img, fold_of, cands, full, square, size)
    table = _table(cands, s, np.array([len(obj[v]) for v in used], float), fold_of, full, why, noise_se,
                   tolerance)
    chosen = min((r for r in table if r.within_noise), key=lambda r: (_order(r.model), r.cv_rms)).model
    rule = (f"{n_folds}-fold cross-validation over {len(used)} views (view of rank r held out in fold r mod "
            f"{n_folds}): each candidate fitted to the other folds, each held-out view's pose fitted with its "
            "intrinsics, scored by the RMS of the held-out corners' residuals; chosen: the fewest distortion "
            f"coefficients within {noise_se:g} standard error(s) of the paired difference to the best (over "
            f"the folds), or {tolerance:.0%} of the best score if more")
    fold_views = tuple(tuple(int(v) for v in used[fold_of == f]) for f in range(n_folds))
    return ModelSelection(chosen, table, fold_views, rule, tuple(int(v) for v in used), tuple(notes))


def _scores(boards, names, used, corner_ok, obj, img, fold_of, cands, full, square, size):
    """Per candidate, each used view's held-out sum of squared residuals, and why it failed ("" if not)."""
    s = {c: np.full(len(used), np.nan) for c in cands}
    why = {c: full[c][2] for c in cands}
    for f in range(int(fold_of.max()) + 1):
        train = used[fold_of != f]
        for c in cands:
            if why[c]:
                continue
            cam, _, _ = _fit(c, [obj[v] for v in train], [img[v] for v in train], size, full[c][0])
            if cam is None:
                why[c] = f"the fit failed in fold {f + 1}"
                continue
            for r in np.flatnonzero(fold_of == f):
                v = used[r]
                got = _held_out(boards[v], corner_ok[v], square, cam[0], cam[1], c)
                if got is None:
                    why[c] = f"no pose for held-out view {names[v]}"
                    break
                s[c][r] = got
    return s, why


def _fit(model: str, obj: list, img: list, size: tuple[int, int], start=None):
    """``((K, D) or None, RMS, why it failed)`` of one fit without rejection; a fisheye with a ``start``
    camera (the fit of all views) is refitted from it (:func:`fit_fisheye_from`: its multi-start fit
    takes seconds, and a fold's views are most of the views)."""
    try:
        if lens(model).start == "fisheye.calibrate" and start is not None:
            K, D, rv, tv = fit_fisheye_from(obj, img, start[0], start[1])
        else:
            K, D, rv, tv, _ = fit_camera(obj, img, size, model, 0)
    except cv2.error as exc:
        return None, float("nan"), "OpenCV could not fit it: " + " ".join(str(exc).split())[-120:]
    r = np.concatenate([i - project(o, K, D, model, rv[n], tv[n]) for n, (o, i) in enumerate(zip(obj, img))])
    rms = float(np.sqrt(np.mean(np.sum(r * r, axis=1))))
    if not (np.all(np.isfinite(K)) and np.all(np.isfinite(D)) and np.isfinite(rms)):
        return None, float("nan"), "the fit is not finite"
    return (K, D), rms, ""


def _cleaned(boards, names, size, cands, reject: bool, common: dict) -> tuple[np.ndarray, list]:
    """The views and corners the folds use: every usable one, or with ``reject`` those the most flexible
    candidate's rejection keeps: the richest of the pinhole family; where fisheye is a candidate and
    that fails or rejects more than a tenth of the corners, the fisheye's too, the one keeping more
    corners kept (the fisheye's rejection rounds cost seconds each, so only when needed)."""
    family = [c for c in cands if lens(c).start == "calibrateCamera"]
    cleaners = ([max(family, key=_order)] if family else []) + [c for c in cands if c not in family]
    best, err = None, None
    total = sum(len(b) for v, b in enumerate(boards) if usable_reason(b, common["min_corners"]) == "")
    for c in cleaners:
        if best is not None and (not reject or best[0] >= 0.9 * total):
            break  # without rejection every candidate keeps the same corners
        try:
            st, idx, _, _, _ = fit_with_rejection(boards, names, size, model=c, reject=reject, **common)
        except ValueError as exc:
            err = exc
            continue
        kept = sum(int(st.corner_ok[v].sum()) for v in idx)
        if best is None or kept > best[0]:
            best = (kept, idx, st.corner_ok)
    if best is None:
        raise err if err is not None else ValueError("no candidate model could be fitted")
    return np.asarray(best[1]), best[2]


def _per_fold(x: np.ndarray, fold_of: np.ndarray) -> np.ndarray:
    return np.bincount(fold_of, weights=x)


def _table(cands, s: dict, n: np.ndarray, fold_of: np.ndarray, full: dict, why: dict,
           noise_se: float, tolerance: float) -> tuple[CandidateScore, ...]:
    """The table's rows; the standard errors over the folds (:func:`_ratio_se` of the folds' sums)."""
    N = float(n.sum())
    nf = _per_fold(n, fold_of)
    mse = {c: (float(np.sum(s[c])) / N if not why[c] else np.inf) for c in cands}
    if all(not np.isfinite(m) for m in mse.values()):
        raise ValueError("no candidate model could be cross-validated: "
                         + "; ".join(f"{c}: {why[c]}" for c in cands))
    b = min(cands, key=lambda c: (mse[c], _order(c)))
    eb = np.sqrt(mse[b])
    rows = []
    for c in cands:
        if why[c]:
            rows.append(CandidateScore(c, len(MODELS[c]), full[c][1], np.inf, float("nan"), np.inf,
                                       float("nan"), False, why[c]))
            continue
        e = float(np.sqrt(mse[c]))
        se = _ratio_se(_per_fold(s[c], fold_of), nf) / (2 * e) if e > 0 else 0.0
        diff = e - eb
        dse = _ratio_se(_per_fold(s[c] - s[b], fold_of), nf) / (e + eb) if e + eb > 0 else 0.0
        dse = 0.0 if c == b else dse
        within = c == b or diff <= max(noise_se * (dse if np.isfinite(dse) else 0.0), tolerance * eb)
        rows.append(CandidateScore(c, len(MODELS[c]), full[c][1], e, float(se), float(diff), float(dse),
                                   bool(within), ""))
    return tuple(rows)


# --------------------------------------------------------------------------------------------------
# whether a model's higher radial terms are the lens's or noise


@dataclass(frozen=True)
class HigherTerms:
    """Whether a model's higher radial terms predict held-out corners better than the model without them
    (:func:`higher_terms`).

    Attributes
    ----------
    fixed : tuple of str
        The terms held at 0 in the comparison that decided: the largest set of
        top terms whose removal predicts as well (``noise`` True), else the
        top term alone (``noise`` False).
    noise : bool
        Whether the model without ``fixed`` predicts held-out corners as well
        (the rule of :func:`select_model`): the terms fit noise.
    free_rms, fixed_rms : float
        RMS of the held-out corners' residuals, the model as it is and with
        ``fixed`` held at 0 (px).
    difference_se : float
        Standard error of ``fixed_rms - free_rms`` from the paired per-view differences (px).
    folds : int
    """

    fixed: tuple[str, ...]
    noise: bool
    free_rms: float
    fixed_rms: float
    difference_se: float
    folds: int


def fix_flags(model: str, terms: Sequence[str]) -> tuple[int, str]:
    """OpenCV's flags holding the distortion ``terms`` of ``model`` at 0, and their names.

    Examples
    --------
    >>> fix_flags("pinhole", ["k2", "k3"])[1]
    'cv2.CALIB_FIX_K2 | cv2.CALIB_FIX_K3'
    >>> fix_flags("fisheye", ["k4"])[1]
    'cv2.fisheye.CALIB_FIX_K4'
    """
    space, prefix = (cv2.fisheye, "cv2.fisheye.") if lens(model).start == "fisheye.calibrate" else (cv2, "cv2.")
    flags, words = 0, []
    for t in terms:
        name = f"CALIB_FIX_{t.upper()}"
        flags |= getattr(space, name)
        words.append(prefix + name)
    return flags, " | ".join(words)


def higher_terms(
    boards: Sequence[Board | None],
    corner_used: Sequence[np.ndarray | None],
    views: Sequence[int],
    image_size: tuple[int, int],
    model: str,
    *,
    folds: int = 5,
    min_views: int = 3,
    noise_se: float = _NOISE_SE,
    tolerance: float = _TOLERANCE,
) -> HigherTerms | None:
    """Whether a fit's higher radial terms are the lens's: do they predict the corners of views the fit
    did not see better than the model without them?

    The radial series of ``model`` (:attr:`~sogdd.calib.cameras.LensModel.radial_terms`:
    ``k1, k2[, k3]`` of the pinhole family, ``k1..k4`` of the fisheye) is cut
    from the top: first its last term held at 0, then the last two, ... down to
    ``k1`` alone. Each cut is scored as :func:`select_model` scores a candidate:
    ``folds``-fold cross-validation over ``views`` (each held-out view's pose
    fitted to its corners with the fold's intrinsics), the RMS :math:`e` of the
    held-out residuals, and the cut predicts "as well" when
    :math:`e_{cut} - e_{free} \\le \\max(\\text{noise\\_se} \\cdot SE, \\text{tolerance} \\cdot e_{free})`,
    SE that of the paired per-view difference. The largest cut that predicts as
    well is returned (the terms it holds at 0 fit noise); when none does, the
    top term alone, ``noise`` False.

    Parameters
    ----------
    boards, corner_used : sequences, one per view
        The calibration's boards and the corners it used (``Calibration.boards``,
        ``Calibration.corner_used``).
    views : sequence of int
        The used views.
    image_size : (width, height)
    model : str
        A model with a radial series (others: None).
    folds, min_views, noise_se, tolerance
        As :func:`select_model`.

    Returns
    -------
    HigherTerms or None
        None for a model without a series of two or more terms, too few views
        for the folds, or a fit that fails.
    """
    series = lens(model).radial_terms
    names = MODELS[model]
    if len(series) < 2:
        return None
    used = np.asarray(list(views), int)
    n_folds = _fold_sizes(len(used), int(folds), min_views)
    if n_folds == 0:
        return None
    size = check_size(image_size)
    fold_of = np.arange(len(used)) % n_folds
    obj = {v: boards[v].object_points(1.0)[corner_used[v]] for v in used}
    img = {v: boards[v].image_points[corner_used[v]] for v in used}
    n = np.array([len(obj[v]) for v in used], float)
    start = None
    if lens(model).start == "fisheye.calibrate":
        try:
            start = fit_camera([obj[v] for v in used], [img[v] for v in used], size, model, 0)[:2]
        except cv2.error:
            return None

    data = (boards, corner_used, used, fold_of, obj, img, size, model, start)
    free = _fold_scores(data, 0)
    if free is None:
        return None
    N = float(n.sum())
    e_free = float(np.sqrt(free.sum() / N))
    nf = _per_fold(n, fold_of)
    best = None
    for cut in range(1, len(series)):
        fixed = tuple(names[i] for i, _ in series[len(series) - cut:])
        s = _fold_scores(data, fix_flags(model, fixed)[0])
        if s is None:
            break
        e = float(np.sqrt(s.sum() / N))
        dse = _ratio_se(_per_fold(s - free, fold_of), nf) / (e + e_free) if e + e_free > 0 else 0.0
        dse = dse if np.isfinite(dse) else 0.0
        as_well = e - e_free <= max(noise_se * dse, tolerance * e_free)
        test = HigherTerms(fixed, as_well, e_free, e, dse, n_folds)
        if not test.noise:
            return best or test
        best = test
    return best


def _fold_scores(data, flags: int) -> np.ndarray | None:
    """Each used view's held-out sum of squared residuals under ``model`` with ``flags`` (None: a fit or a
    pose failed); a fisheye refitted from ``start``, its fixed terms at 0."""
    boards, corner_used, used, fold_of, obj, img, size, model, start = data
    s = np.full(len(used), np.nan)
    for f in range(int(fold_of.max()) + 1):
        train = used[fold_of != f]
        o, i = [obj[v] for v in train], [img[v] for v in train]
        try:
            if start is not None:
                K, D = fit_fisheye_from(o, i, start[0], np.where(fisheye_fixed(flags)[4:], 0.0, start[1]),
                                        flags)[:2]
            else:
                K, D = fit_camera(o, i, size, model, flags)[:2]
        except cv2.error:
            return None
        for r in np.flatnonzero(fold_of == f):
            got = _held_out(boards[used[r]], corner_used[used[r]], 1.0, K, D, model)
            if got is None:
                return None
            s[r] = got
    return s
