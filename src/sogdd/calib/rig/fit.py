"""The joint calibration of a camera rig: every camera's intrinsics, its pose, every frame's board pose.

:func:`calibrate_rig` starts from each camera's own calibration
(:func:`sogdd.calib.calibrate`), finds each camera's pose relative to the first
from the frames both saw (:func:`~sogdd.calib.rig.labels.consensus`), makes the
chessboard labels of each frame agree across cameras
(:func:`~sogdd.calib.rig.labels.resolve`), and fits everything at once by
sparse least squares, rejecting corners and views by the mono rule
(:func:`sogdd.calib.fit.calibrate`'s), camera by camera.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy.sparse import csr_matrix

from ..cameras import LENSES, MODELS, check_size, lens
from ..fit import calibrate, check_square, std_dict
from ..model_selection import ModelChoice, check_model_choice
from ..rejection import State, reject_corners, reject_view, robust_limit
from ..result import Calibration
from ..solvers import BlockNormal, levenberg_marquardt, rotation_matrices
from ..targets.board import Board
from ..uncertainty import camera_covariance, covariance
from ..weighting import corner_weights
from . import labels as _labels
from . import uncertainty as _unc
from .connectivity import Connectivity, rig_connectivity
from .frames import check_pairing
from .result import RigCalibration, RigCamera
from .units import in_unit

__all__ = ["calibrate_rig"]


# --------------------------------------------------------------------------------------------------
# poses as (R (3, 3), t (3,)): x' = R x + t


def _inverse(P):
    return P[0].T, -P[0].T @ P[1]


def _compose(A, B):
    """``A o B``: :math:`x \\mapsto R_A (R_B x + t_B) + t_A`."""
    return A[0] @ B[0], A[0] @ B[1] + A[1]


def _from_vec(v: np.ndarray):
    return cv2.Rodrigues(np.asarray(v[:3], np.float64))[0], np.asarray(v[3:6], np.float64)


def _to_vec(P) -> np.ndarray:
    return np.r_[cv2.Rodrigues(np.asarray(P[0], np.float64))[0].ravel(), P[1]]


# --------------------------------------------------------------------------------------------------
# validation at the door


def _check_pattern(pattern) -> tuple[int, int] | None:
    if pattern is None:
        return None
    try:
        c, r = (int(v) for v in pattern)
    except (TypeError, ValueError):
        raise ValueError(f"pattern must be (cols, rows) of inner corners, got {pattern!r}") from None
    if c < 2 or r < 2:
        raise ValueError(f"pattern must have at least 2 x 2 inner corners, got {pattern!r}")
    return c, r


def _check_boards(boards) -> tuple[list[str], dict, int]:
    if not isinstance(boards, Mapping) or not boards:
        raise ValueError("boards must map each camera's name to its boards, one per frame")
    names = [str(n) for n in boards]
    if len(set(names)) != len(names):
        raise ValueError("two cameras share a name")
    lists = {str(n): list(b) for n, b in boards.items()}
    F = len(lists[names[0]])
    for n in names[1:]:
        if len(lists[n]) != F:
            raise ValueError(f"camera {n!r} has {len(lists[n])} frames but {names[0]!r} has {F}; "
                             "every camera needs one entry (a Board or None) per frame")
    if F == 0:
        raise ValueError("no frames")
    return names, lists, F


def _per_camera(value, names: list[str], what: str, default=None) -> dict:
    if isinstance(value, Mapping):
        missing = [n for n in names if n not in value]
        if missing and default is None:
            raise ValueError(f"no {what} for camera(s) {', '.join(map(repr, missing))}")
        return {n: value.get(n, default) for n in names}
    return {n: value for n in names}


def _check_names(frames, view_names, names, F) -> tuple[tuple[str, ...], dict]:
    frames = tuple(str(i) for i in range(F)) if frames is None else tuple(str(f) for f in frames)
    if len(frames) != F:
        raise ValueError(f"{len(frames)} frame names for {F} frames")
    views = {n: list(frames) for n in names}
    for n, v in (view_names or {}).items():
        if n not in views:
            raise ValueError(f"view_names has camera {n!r}, which has no boards")
        if len(v) != F:
            raise ValueError(f"camera {n!r}: {len(v)} view names for {F} frames")
        views[n] = [str(x) for x in v]
    return frames, views


# --------------------------------------------------------------------------------------------------
# the start: each camera alone, the cameras' poses, the labels


def _mono(names, boards, sizes, models, views, kw) -> dict:
    out = {}
    for n in names:
        try:
            out[n] = calibrate(boards[n], sizes[n], model=models[n], names=views[n], cross_validate=False, **kw)
        except ValueError as exc:
            raise ValueError(f"camera {n!r}: {exc}") from None
    return out


def _mono_pose(cal: Calibration, f: int):
    return _from_vec(np.r_[cal.rvecs[f], cal.tvecs[f]])


def _pair_candidates(b0: Board, bc: Board, pattern, square: float, P0, Pc):
    """The relative poses of camera ``c`` that frame's two views allow, and whether both were whole
    (one per turn the board allows) or one partial (every placement inside the pattern; None when
    both are partial)."""
    def rel(G):  # G maps c's board coordinates to the reference's
        return _compose(_compose(Pc, _inverse(G)), _inverse(P0))

    if pattern is None or (b0.size is not None and bc.size is not None):
        return [rel(_labels.transform(k, o, square)) for k, o in _labels.discrete(bc, b0, pattern)], True
    if bc.size is None and b0.size is not None:
        return [rel(_labels.transform(k, o, square)) for k, o in _labels.inside(bc, pattern)], False
    if b0.size is None and bc.size is not None:  # the reference's placement inside c's pattern, inverted
        return [rel(_inverse(_labels.transform(k, o, square))) for k, o in _labels.inside(b0, pattern)], False
    return None, False


def _pair_pose(m: str, n: str, mono, boards, pattern, square: float, shift: int = 0):
    """Camera ``n``'s pose relative to camera ``m`` from the frames both used: the consensus over the
    frames both saw whole, or where there are none, over those where one saw the board whole and
    the other part of it; ``(R, t, disagreeing frames, shared frames)``, or None without such frames.
    ``shift``: ``m``'s frame ``f`` is paired with ``n``'s frame ``f + shift`` (0: as given)."""
    cands, loose, dists = [], [], []
    F = len(boards[m])
    for f in range(max(0, -shift), min(F, F - shift)):
        g = f + shift
        if not (mono[m].view_used[f] and mono[n].view_used[g]):
            continue
        P0, Pc = _mono_pose(mono[m], f), _mono_pose(mono[n], g)
        cs, whole = _pair_candidates(boards[m][f], boards[n][g], pattern, square, P0, Pc)
        if cs:
            (cands if whole else loose).append(cs)
            dists.append(float(np.linalg.norm(P0[1])))
    if not (cands or loose):
        return None
    # placements of a partial board differ by whole squares: a tighter translation tolerance
    R, t, chosen = (_labels.consensus(cands, float(np.median(dists))) if cands else
                    _labels.consensus(loose, float(np.median(dists)), tol_t=0.4 * square))
    return R, t, sum(c < 0 for c in chosen), len(chosen)


def _relative_poses(names, mono, boards, pattern, square, notes, views) -> dict:
    """Each camera's pose in the first camera's frame (:func:`_pair_pose` to the first, else through
    a camera already placed); None for a camera that nothing ties to the first. Frames paired wrong
    stop it (:func:`~sogdd.calib.rig.frames.check_pairing`)."""
    ref = names[0]
    poses: dict = {ref: (np.eye(3), np.zeros(3))}
    todo = list(names[1:])
    while todo:
        found = None
        for n in todo:
            for m in [x for x in names if x in poses]:
                rel = _pair_pose(m, n, mono, boards, pattern, square)
                if rel is not None:
                    found = n, m, rel
                    break
            if found:
                break
        if found is None:
            break
        n, m, (R, t, off, shared) = found
        if off:  # frames paired with the wrong moment stop here, before the joint fit bends to them
            check_pairing(m, n, off, shared, views[m], views[n],
                          lambda k, m=m, n=n: _pair_pose(m, n, mono, boards, pattern, square, shift=k))
        poses[n] = _compose((R, t), poses[m])
        todo.remove(n)
        via = "" if m == ref else f" (through camera {m!r})"
        if off:
            notes.append(f"camera {n!r}: {off} of {shared} shared frames disagree with the consensus of "
                         f"its pose{via} (left to the joint fit's rejection)")
    for n in todo:
        notes.append(f"camera {n!r} shares no frame with the reference camera {ref!r} (or a camera tied to "
                     "it) in which both calibrations used the board: its pose is unknown (NaN), and its "
                     "intrinsics come from its own views alone")
        poses[n] = None
    return poses


def _joint_frame(c: int, f: int, F: int, private: bool) -> int:
    """The joint fit's frame of camera ``c``'s view ``f``: ``f``, or for a camera without a pose
    (``private``) a frame of its own, ``(c + 1) F + f``."""
    return (c + 1) * F + f if private else f


def _anchor_key(board: Board, pattern, rank: int):
    why = _labels.ambiguity(board, pattern)
    return why == "partial", why != "", rank


@dataclass
class _Start:
    boards: dict  # name -> list of Board or None (relabelled)
    resolved: dict  # name -> (F,) bool: labels agree with the frame's
    frames: np.ndarray  # (F, 6) board poses in the first camera's frame, NaN unknown
    reasons: dict  # name -> list of str
    relabelled: dict = field(default_factory=dict)  # name -> count


def _align(names, mono, boards, poses, pattern, square) -> _Start:
    """Fix each frame's labels from one camera (whole boards and the reference first) and relabel the
    other cameras' observations of the frame against its predicted pose. A camera without a pose keeps
    its views in frames of its own (:func:`_joint_frame`)."""
    F = len(boards[names[0]])
    st = _Start({n: list(boards[n]) for n in names}, {n: np.zeros(F, bool) for n in names},
                np.full((F * (len(names) + 1), 6), np.nan), {n: list(mono[n].reasons) for n in names},
                dict.fromkeys(names, 0))
    for c, n in enumerate(names):
        if poses[n] is None:
            for f in np.flatnonzero(mono[n].view_used):
                st.frames[_joint_frame(c, f, F, True)] = _to_vec(_mono_pose(mono[n], f))
                st.resolved[n][f] = True
    for f in range(F):
        seen = [n for n in names if mono[n].view_used[f] and poses[n] is not None]
        if not seen:
            continue
        a = min(seen, key=lambda n: _anchor_key(boards[n][f], pattern, names.index(n)))
        Pf = _compose(_inverse(poses[a]), _mono_pose(mono[a], f))
        st.frames[f] = _to_vec(Pf)
        st.resolved[a][f] = True
        for n in seen:
            b = boards[n][f]
            if n == a or not (_labels.ambiguity(b, pattern) or _labels.ambiguity(boards[a][f], pattern)):
                st.resolved[n][f] = True
                continue
            cal = mono[n]
            new, why = _labels.resolve(b, boards[a][f], pattern, square, cal.K, cal.dist, cal.model,
                                       _compose(poses[n], Pf))
            if new is None:
                st.reasons[n][f] = why
                continue
            st.boards[n][f], st.resolved[n][f] = new, True
            st.relabelled[n] += bool(why)
    return st


# --------------------------------------------------------------------------------------------------
# the joint fit


@dataclass
class _Layout:
    """Where each block lies in the parameter vector."""

    intr: list  # per camera: slice of fx, fy, cx, cy, distortion
    pose: list  # per camera: slice of rvec, tvec (None for the first)
    frame: dict  # frame index -> slice of rvec, tvec
    size: int


def _n_cameras(lay: _Layout) -> int:
    """How many parameters are the cameras' (intrinsics and poses): they come first, the frames' after."""
    return min((s.start for s in lay.frame.values()), default=lay.size)


def _layout(nds: list[int], frames: list[int], private: list[bool]) -> _Layout:
    intr, pose, at = [], [], 0
    for c, nd in enumerate(nds):
        intr.append(slice(at, at + 4 + nd))
        at += 4 + nd
        free = c > 0 and not private[c]
        pose.append(slice(at, at + 6) if free else None)
        at += 6 if free else 0
    fr = {}
    for f in frames:
        fr[f] = slice(at, at + 6)
        at += 6
    return _Layout(intr, pose, fr, at)


@dataclass
class _Corners:
    """Corners as flat arrays: camera, frame, board point, pixel, weight in the fit; and where each view's
    corners lie."""

    cam: np.ndarray
    frame: np.ndarray
    X: np.ndarray
    uv: np.ndarray
    segments: list  # (camera, frame, corner indices in the board, slice in the arrays)
    w: np.ndarray = field(default_factory=lambda: np.zeros(0))


def _gather(states, square, take, private) -> _Corners:
    """The corners ``take(c, f, state)`` selects (an index array into the board, or None), their
    frames mapped by :func:`_joint_frame`."""
    cam, frm, X, uv, seg, w, at = [], [], [], [], [], [], 0
    for c, st in enumerate(states):
        for f, b in enumerate(st.boards):
            idx = None if b is None else take(c, f, st)
            if idx is None or len(idx) == 0:
                continue
            cam.append(np.full(len(idx), c))
            frm.append(np.full(len(idx), _joint_frame(c, f, len(st.boards), private[c])))
            X.append(b.object_points(square)[idx])
            uv.append(b.image_points[idx])
            w.append(corner_weights(b, st.typical)[idx])
            seg.append((c, f, idx, slice(at, at + len(idx))))
            at += len(idx)
    if not seg:
        return _Corners(np.zeros(0, int), np.zeros(0, int), np.zeros((0, 3)), np.zeros((0, 2)), [])
    return _Corners(np.concatenate(cam), np.concatenate(frm), np.concatenate(X), np.concatenate(uv), seg,
                    np.concatenate(w))


def _poses(x: np.ndarray, lay: _Layout, n_cams: int, n_frames: int) -> tuple[np.ndarray, np.ndarray]:
    """Every joint frame's board pose (n_frames, 6) and every camera's pose (n_cams, 6) in ``x`` (zero where
    fixed or unused): rvec, tvec."""
    fr = np.zeros((n_frames, 6))
    for f, s in lay.frame.items():
        fr[f] = x[s]
    cams = np.zeros((n_cams, 6))
    for c, s in enumerate(lay.pose):
        if s is not None:
            cams[c] = x[s]
    return fr, cams


def _predict(x: np.ndarray, lay: _Layout, models: list[str], co: _Corners) -> np.ndarray:
    """Projected pixels (N, 2) of the corners: :math:`\\pi_c(R_c (R_f X + t_f) + T_c)`, all at once."""
    fr, cams = _poses(x, lay, len(models), int(co.frame.max()) + 1 if len(co.frame) else 1)
    p = np.einsum("nij,nj->ni", rotation_matrices(fr[:, :3])[co.frame], co.X) + fr[co.frame, 3:]
    p = np.einsum("nij,nj->ni", rotation_matrices(cams[:, :3])[co.cam], p) + cams[co.cam, 3:]
    out = np.empty((len(p), 2))
    for c, model in enumerate(models):
        sel = co.cam == c
        if not sel.any():
            continue
        intr = x[lay.intr[c]]
        out[sel] = lens(model).project(p[sel], intr[4:]) * intr[:2] + intr[2:4]
    return out


def _whitened(x: np.ndarray, lay: _Layout, models: list[str], co: _Corners) -> np.ndarray:
    """The fit's residuals (2N,): each corner's observed minus projected pixel times its weight, ``u, v``
    interleaved (the rows of OpenCV's projection Jacobians)."""
    return ((co.uv - _predict(x, lay, models, co)) * co.w[:, None]).ravel()


#: the OpenCV calibrations whose models the joint fit has analytic projection Jacobians for
#: (``cv2.projectPoints``, ``cv2.fisheye.projectPoints``)
_JACOBIANS = ("calibrateCamera", "fisheye.calibrate")


def _no_jacobian(model: str) -> str:
    """The one-line refusal of a model the joint fit cannot take."""
    ok = ", ".join(n for n, m in LENSES.items() if m.start in _JACOBIANS)
    return (f"the joint rig fit cannot take the {model} model: it needs OpenCV's analytic projection "
            f"Jacobians, which only {ok} have; choose one of those, or calibrate that camera alone")


def _check_models(mods: Mapping[str, str]) -> None:
    """A one-line ``ValueError`` naming the camera if a model is unknown or the joint fit cannot take it."""
    for n, m in mods.items():
        try:
            check_model_choice(m)
        except ValueError as exc:
            raise ValueError(f"camera {n!r}: {exc}") from None
        if m != "auto" and lens(m).start not in _JACOBIANS:
            raise ValueError(f"camera {n!r}: {_no_jacobian(m)}")


def _projection_jacobian(X: np.ndarray, rv: np.ndarray, tv: np.ndarray, intr: np.ndarray, model: str):
    """OpenCV's derivatives of the pixels of board points ``X`` (n, 3) seen from the pose ``rv, tv``:
    with respect to the pose (2n, 6: rvec, tvec) and to the intrinsics (2n, 4 + nd: fx, fy, cx, cy,
    distortion), rows ``u, v`` interleaved."""
    K = np.array([[intr[0], 0.0, intr[2]], [0.0, intr[1], intr[3]], [0.0, 0.0, 1.0]])
    start = lens(model).start
    if start not in _JACOBIANS:
        raise ValueError(_no_jacobian(model))
    if start == "fisheye.calibrate":  # its columns: fx, fy, cx, cy, k1..k4, rvec, tvec, skew
        J = cv2.fisheye.projectPoints(X[:, None, :], rv, tv, K, intr[4:])[1]
        return J[:, 8:14], J[:, :8]
    J = cv2.projectPoints(X, rv, tv, K, intr[4:])[1]  # rvec, tvec, fx, fy, cx, cy, distortion
    return J[:, :6], J[:, 6:]


def _chain(drdr, drdt, dtdr, dtdt) -> np.ndarray:
    """The 6 x 6 derivative of a composed ``(rvec, tvec)`` with respect to one pose's ``(rvec, tvec)``."""
    out = np.empty((6, 6))
    out[:3, :3], out[:3, 3:], out[3:, :3], out[3:, 3:] = drdr, drdt, dtdr, dtdt
    return out


def _jacobian(x: np.ndarray, lay: _Layout, models: list[str], co: _Corners) -> csr_matrix:
    """The Jacobian (2N, P) of :func:`_whitened`, sparse: view by view, the projection's derivatives
    (:func:`_projection_jacobian`) with respect to the intrinsics, and to the composed pose
    :math:`(R_c R_f, R_c t_f + T_c)` chained to the camera's and the frame's pose by ``cv2.composeRT``'s
    derivatives; times minus each corner's weight. A camera whose pose is fixed (the first, one without
    a pose) sees its frames' poses directly."""
    fr, cams = _poses(x, lay, len(models), int(co.frame.max()) + 1 if len(co.frame) else 1)
    data, indices, counts = [], [], []
    for c, _, _, s in co.segments:
        f = int(co.frame[s.start])
        if lay.pose[c] is None:
            Jp, Ji = _projection_jacobian(co.X[s], fr[f, :3], fr[f, 3:], x[lay.intr[c]], models[c])
            blocks, slices = [Ji, Jp], [lay.intr[c], lay.frame[f]]
        else:
            rv, tv, *d = cv2.composeRT(fr[f, :3], fr[f, 3:], cams[c, :3], cams[c, 3:])
            Jp, Ji = _projection_jacobian(co.X[s], rv, tv, x[lay.intr[c]], models[c])
            # composeRT's d(rv, tv) / d(camera's rvec, tvec), and / d(frame's rvec, tvec)
            blocks = [Ji, Jp @ _chain(d[2], d[3], d[6], d[7]), Jp @ _chain(d[0], d[1], d[4], d[5])]
            slices = [lay.intr[c], lay.pose[c], lay.frame[f]]
        # each row's entries in increasing columns (a camera's intrinsics, its pose, then the frames'): the
        # CSR arrays directly, row after row
        data.append((np.hstack(blocks) * -np.repeat(co.w[s], 2)[:, None]).ravel())
        cols = np.concatenate([np.arange(sl.start, sl.stop) for sl in slices])
        indices.append(np.tile(cols, 2 * (s.stop - s.start)))
        counts.append(np.full(2 * (s.stop - s.start), len(cols)))
    shape = (2 * len(co.cam), lay.size)
    if not data:
        return csr_matrix(shape)
    indptr = np.r_[0, np.cumsum(np.concatenate(counts))]
    return csr_matrix((np.concatenate(data), np.concatenate(indices), indptr), shape=shape)


# up to this many parameters the covariance is the full inverse (P x P, O(P^3)); beyond, the cameras' block
# alone, by the Schur complement of the frames' poses (:func:`~sogdd.calib.uncertainty.camera_covariance`)
_FULL_COVARIANCE_MAX = 1000


def _normal(J: csr_matrix, r: np.ndarray, n: int) -> BlockNormal:
    """The normal equations :math:`J^T J \\delta = -J^T r` of the whitened fit by blocks
    (:class:`~sogdd.calib.solvers.BlockNormal`): the first ``n`` parameters (the cameras') against each
    frame's pose; the frames share no residual, so their part of :math:`J^T J` is block-diagonal."""
    H = (J.T @ J).tocsr()
    g = -(J.T @ r)
    m = (J.shape[1] - n) // 6
    Hf = H[n:, n:].tocoo()
    P = np.zeros((m, 6, 6))
    P[Hf.row // 6, Hf.row % 6, Hf.col % 6] = Hf.data
    W = H[:n, n:].toarray().reshape(n, m, 6).transpose(1, 0, 2)
    return BlockNormal(H[:n, :n].toarray(), W, P, g[:n], g[n:].reshape(m, 6))


@dataclass
class _Solution:
    x: np.ndarray
    fun: np.ndarray  # the whitened residuals at x
    jac: csr_matrix  # their Jacobian at x


def _fit(fun, jac, x0: np.ndarray, n: int) -> _Solution:
    """The joint fit from ``x0``: :func:`~sogdd.calib.solvers.levenberg_marquardt` on the whitened residuals
    ``fun``, their sparse Jacobian ``jac`` and its normal equations with the frames' poses (every parameter
    after the first ``n``) eliminated; it stops when a step lowers the cost by less than 1e-10 of it."""
    last = {}

    def system(x):
        r, J = fun(x), jac(x)
        last["J"] = J  # the Jacobian at the end, for the covariance
        return r, _normal(J, r, n)

    x, r, _ = levenberg_marquardt(x0, system, fun, lambda x, step: x + step, ftol=1e-10, max_iterations=100)
    return _Solution(x, r, last["J"])


@dataclass
class _Params:
    intr: list  # per camera (4 + nd,)
    pose: list  # per camera (6,): rvec, tvec in the first camera's frame
    frames: np.ndarray  # (F, 6), NaN unknown


def _solve(states, par: _Params, models, square, private):
    """One joint least-squares fit of the used corners; updates ``par``; returns the solution and layout."""
    used = _gather(states, square, lambda c, f, st: np.flatnonzero(st.corner_ok[f]) if st.view_ok[f] else None,
                   private)
    frames = sorted(set(used.frame.tolist()))
    lay = _layout([len(MODELS[m]) for m in models], frames, private)
    x0 = np.zeros(lay.size)
    for c in range(len(models)):
        x0[lay.intr[c]] = par.intr[c]
        if lay.pose[c] is not None:
            x0[lay.pose[c]] = par.pose[c]
    for f, s in lay.frame.items():
        x0[s] = par.frames[f]

    def fun(x):  # whitened: each corner's residual times its weight (each camera's own set's, mono's)
        return _whitened(x, lay, models, used)

    sol = _fit(fun, lambda x: _jacobian(x, lay, models, used), x0, _n_cameras(lay))
    for c in range(len(models)):
        par.intr[c] = sol.x[lay.intr[c]].copy()
        if lay.pose[c] is not None:
            par.pose[c] = sol.x[lay.pose[c]].copy()
    par.frames[:] = np.nan
    for f, s in lay.frame.items():
        par.frames[f] = sol.x[s]
    return sol, lay, x0


def _residuals(states, models, square, lay: _Layout, x: np.ndarray, resolved, private) -> list:
    """Per camera, per frame: observed minus projected corners of every view whose labels agree and
    whose frame has a pose (rejected views too); None elsewhere."""
    def take(c, f, st):
        ok = resolved[c][f] and _joint_frame(c, f, len(st.boards), private[c]) in lay.frame
        return np.arange(len(st.boards[f])) if ok else None

    co = _gather(states, square, take, private)
    out = [[None] * len(st.boards) for st in states]
    if len(co.cam):
        r = co.uv - _predict(x, lay, models, co)
        for c, f, _, s in co.segments:
            out[c][f] = r[s]
    return out


def _reject(states, res, k, floor, min_views, min_corners, thresholds) -> bool:
    """One round of the mono rule, camera by camera; True when nothing changed."""
    limits, dropped = [], False
    for c, st in enumerate(states):
        idx = np.flatnonzero(st.view_ok)
        r = np.concatenate([np.hypot(*res[c][v].T)[st.corner_ok[v]] for v in idx])
        limits.append(robust_limit(r, k, floor))
        n = int(st.view_ok.sum())
        thresholds[c] = {"corner": limits[c],
                         "view_rms": reject_view(st, res[c], limits[c], k, floor, min_views, min_corners)}
        dropped |= int(st.view_ok.sum()) < n
    if dropped:
        return False
    changed = sum(reject_corners(st, res[c], limits[c], min_views, min_corners) for c, st in enumerate(states))
    return changed == 0


def _iterate(states, par, models, square, resolved, private, opts):
    reject, k, floor, min_views, min_corners, max_iterations = opts
    thresholds = [{} for _ in states]
    for _ in range(max_iterations):
        sol, lay, _ = _solve(states, par, models, square, private)
        res = _residuals(states, models, square, lay, sol.x, resolved, private)
        if not reject or _reject(states, res, k, floor, min_views, min_corners, thresholds):
            return sol, lay, res, thresholds
    sol, lay, _ = _solve(states, par, models, square, private)
    return sol, lay, _residuals(states, models, square, lay, sol.x, resolved, private), thresholds


# --------------------------------------------------------------------------------------------------
# the result


def _view_rms(res, st) -> np.ndarray:
    out = np.full(len(st.boards), np.nan)
    for v, r in enumerate(res):
        if r is None:
            continue
        sel = st.corner_ok[v] if st.view_ok[v] else np.ones(len(r), bool)
        out[v] = float(np.sqrt(np.mean(np.sum(r[sel] ** 2, axis=1)))) if sel.any() else np.nan
    return out


def _camera_result(c, name, st, res, par, thresholds, cov, lay, std_note, private, selection) -> RigCamera:
    F = len(st.boards)
    Pc = _from_vec(par.pose[c])
    rvecs, tvecs = np.full((F, 3), np.nan), np.full((F, 3), np.nan)
    for f in np.flatnonzero(st.view_ok):
        pose = _compose(Pc, _from_vec(par.frames[_joint_frame(c, f, F, private)]))
        rvecs[f], tvecs[f] = np.split(_to_vec(pose), 2)
    used = [np.sum(res[v][st.corner_ok[v]] ** 2, axis=1) for v in np.flatnonzero(st.view_ok)]
    intr = par.intr[c]
    K = np.array([[intr[0], 0.0, intr[2]], [0.0, intr[1], intr[3]], [0.0, 0.0, 1.0]])
    std = _unc.parameter_std(cov, lay.intr[c], lay.pose[c], st.model, par.pose[c])
    corner_used = tuple(None if b is None else (st.corner_ok[v] & bool(st.view_ok[v]))
                        for v, b in enumerate(st.boards))
    cal = Calibration(
        model=st.model, image_size=st.size, K=K, dist=intr[4:].copy(),
        rms=float(np.sqrt(np.concatenate(used).mean())),
        std=std_dict(None if cov.size == 0 else [std[n] for n in ("fx", "fy", "cx", "cy") + MODELS[st.model]],
                      st.model),
        names=tuple(st.names), boards=tuple(st.boards), residuals=tuple(res), corner_used=corner_used,
        view_used=st.view_ok.copy(), view_rms=_view_rms(res, st), reasons=tuple(st.reasons),
        corner_reasons=tuple(st.corner_reasons), rvecs=rvecs, tvecs=tvecs, cross_validation=None,
        thresholds=thresholds, notes=(), square=st.square, std_note=std_note, model_selection=selection,
        typical_precision=st.typical)
    if private:  # no frame ties it to the reference: its pose is unknown
        Pc = (np.full((3, 3), np.nan), np.full(3, np.nan))
        std.update({"T": [float("nan")] * 3, "baseline": float("nan"), "rotation_deg": float("nan")})
    return RigCamera(name=name, calibration=cal, R=Pc[0], T=Pc[1].copy(), std=std)


def calibrate_rig(
    boards: Mapping[str, Sequence[Board | None]],
    image_sizes: Mapping[str, tuple[int, int]],
    *,
    square: float = 1.0,
    models: ModelChoice | Mapping[str, ModelChoice] = "pinhole",
    frames: Sequence[str] | None = None,
    view_names: Mapping[str, Sequence[str]] | None = None,
    pattern: tuple[int, int] | None = None,
    reject: bool = True,
    k: float = 5.0,
    floor: float = 0.1,
    min_corners: int = 6,
    min_views: int = 3,
    max_iterations: int = 30,
) -> RigCalibration:
    """Calibrate a rig of cameras from the boards each saw in common frames.

    With :math:`(R_c, T_c)` camera ``c``'s pose in the first camera's frame
    (:math:`x_c = R_c x_1 + T_c`; the first: identity, zero) and
    :math:`(R_f, t_f)` frame ``f``'s board pose in the first camera's frame, the
    fit minimises over every camera's ``fx, fy, cx, cy`` (skew 0) and distortion,
    every :math:`(R_c, T_c)` of ``c > 1`` and every used frame's
    :math:`(R_f, t_f)`

    .. math::
        \\sum_{c, f, i} \\lVert u_{cfi} - \\pi_c(R_c (R_f X_i + t_f) + T_c) \\rVert^2

    (Levenberg-Marquardt on the sparse Jacobian, OpenCV's analytic derivatives: a
    residual depends on its camera's intrinsics and pose and its frame's pose, so
    each step eliminates the frames' poses by their Schur complement and solves for
    the cameras' parameters alone: time and memory grow linearly with the frames),
    each corner's residual whitened by its measured precision where the boards
    carry one: times :func:`~sogdd.calib.weighting.corner_weights` relative to
    its camera's typical corner (``Calibration.typical_precision`` of its own
    calibration, whose smeared views stay out of the joint fit too).
    A frame seen by one camera still constrains that camera's intrinsics.

    The start: each camera's :func:`~sogdd.calib.calibrate` (its rejection too);
    each camera's pose from the consensus of the frames both it and the first saw
    whole (:func:`~sogdd.calib.rig.labels.consensus`, over the half turns a
    symmetric board allows; without such frames, over the placements of a partial
    board inside the whole one; without any, through a camera already placed; a
    camera whose shared views its own calibration rejected keeps its views in
    frames of its own, its pose NaN); each frame's labels fixed by one camera (a whole
    board first, the first camera first) and the others' observations relabelled
    against the frame's predicted pose (:func:`~sogdd.calib.rig.labels.resolve`),
    dropped with the reason when no relabelling is clearly best. Rejection
    follows the mono rule (:func:`~sogdd.calib.calibrate`) on each camera's
    residuals of the joint fit, until nothing changes.

    Parameters
    ----------
    boards : mapping of str to sequence of Board or None
        Per camera (the first is the reference), one entry per frame, all of one length.
    image_sizes : mapping of str to (width, height)
    square : float
        The board's square (the unit of every translation), from 1e-6 to 1e6
        (:data:`~sogdd.calib.fit.SQUARE_RANGE`): the fit is made in squares and
        the translations scaled at the end (:func:`~sogdd.calib.rig.units.in_unit`).
    models : str or mapping of str to str
        One of :data:`~sogdd.calib.cameras.MODELS` (or ``"auto"``: each camera's own
        calibration chooses, :func:`~sogdd.calib.calibrate`) for every camera, or per camera.
    frames : sequence of str, optional
        Frame names (default ``"0" .. "F-1"``).
    view_names : mapping of str to sequence of str, optional
        Per camera, a name per frame (its image files), for its calibration's ``names``.
    pattern : (cols, rows), optional
        The chessboard's inner corners: labels of half-turn-symmetric and partial
        boards are then made to agree across cameras. None: labels are absolute
        (ChArUco).
    reject, k, floor, min_corners, min_views, max_iterations
        As in :func:`~sogdd.calib.calibrate`, per camera.

    Returns
    -------
    RigCalibration

    Raises
    ------
    ValueError
        Cameras with different frame counts, an unknown model, a missing image
        size, a camera with fewer than ``min_views`` usable views (its name and
        the mono error), a bad ``pattern``, frame or view names that do not match the frames, or
        cameras in groups that no frame shows the board to both of
        (:meth:`~sogdd.calib.rig.connectivity.Connectivity.problem`: the groups named),
        a ``square`` out of range, or shared frames that disagree on the pose between two
        cameras (:func:`~sogdd.calib.rig.frames.check_pairing`: the likely shift named).

    Examples
    --------
    >>> from sogdd.calib.rig.demo import synthetic_rig
    >>> d = synthetic_rig(cameras=2, frames=10, noise=0.05, seed=0)
    >>> rig = calibrate_rig(d.boards, d.image_sizes)
    >>> rig.names, bool(np.abs(rig.cameras[1].T - d.T[1]).max() < 0.05), bool(rig.rms < 0.1)
    (('cam0', 'cam1'), True, True)
    """
    names, blists, F = _check_boards(boards)
    unit = check_square(square)
    square = 1.0  # fitted in squares, every translation scaled to the square's unit at the end (in_unit)
    sizes = {n: check_size(s) for n, s in _per_camera(image_sizes, names, "image size").items()}
    mods = _per_camera(models, names, "model")
    _check_models(mods)
    pattern = _check_pattern(pattern)
    frame_names, views = _check_names(frames, view_names, names, F)
    con = rig_connectivity(blists)  # before any camera's calibration: a rig in pieces cannot be fitted
    if not con.connected:
        raise ValueError(con.problem())
    kw = dict(square=square, reject=reject, k=k, floor=floor, min_corners=min_corners, min_views=min_views,
              max_iterations=max_iterations)
    mono = _mono(names, blists, sizes, mods, views, kw)
    _check_models({n: mono[n].model for n in names})  # "auto" may have chosen a model the fit cannot take
    notes: list[str] = []
    poses = _relative_poses(names, mono, blists, pattern, float(square), notes, views)
    start = _align(names, mono, blists, poses, pattern, float(square))
    for n, m in start.relabelled.items():
        if m:
            notes.append(f"camera {n!r}: {m} view(s) relabelled to agree with the frame's other cameras")
    states = [State(start.boards[n], views[n], float(square), sizes[n], mono[n].model, 0,
                     np.array([bool(mono[n].view_used[f] and start.resolved[n][f]) for f in range(F)]),
                     start.reasons[n], [np.asarray(u, bool).copy() if u is not None else None
                                        for u in mono[n].corner_used],
                     [dict(r) for r in mono[n].corner_reasons], mono[n].typical_precision) for n in names]
    for n, st in zip(names, states):
        if st.view_ok.sum() < min_views:
            why = sorted({r.split(" (")[0] for r in st.reasons if r and r != "no board"})
            raise ValueError(f"camera {n!r}: {int(st.view_ok.sum())} view(s) left once the labels were made "
                             f"to agree across cameras, fewer than min_views={min_views}"
                             + (f"; {'; '.join(why)}" if why else ""))
        st.corner_ok = [np.ones(len(b), bool) if b is not None and (u is None or not u.any()) else u
                        for b, u in zip(st.boards, st.corner_ok)]
    par = _Params([np.r_[m.K[0, 0], m.K[1, 1], m.K[0, 2], m.K[1, 2], m.dist] for m in mono.values()],
                  [np.zeros(6) if poses[n] is None else _to_vec(poses[n]) for n in names], start.frames.copy())
    private = [poses[n] is None for n in names]
    selections = {n: m.model_selection for n, m in mono.items()}
    rig = _finish(names, states, par, frame_names, float(square), notes, start.resolved, private, selections,
                  (reject, k, floor, min_views, min_corners, max_iterations))
    return in_unit(rig, unit)


def _used_connectivity(names, states, private) -> Connectivity:
    """Which cameras the joint fit's used views tie together (a camera without a pose: its own frames)."""
    F = len(states[0].boards)
    counts = np.zeros((len(names), F * (len(names) + 1)), np.int64)
    for c, st in enumerate(states):
        for f in np.flatnonzero(st.view_ok):
            counts[c, _joint_frame(c, f, F, private[c])] = int(np.sum(st.corner_ok[f]))
    return Connectivity.from_counts(names, counts[:, counts.any(axis=0)])


def _finish(names, states, par, frame_names, square, notes, resolved, private, selections,
            opts) -> RigCalibration:
    models = [st.model for st in states]
    sol, lay, res, thresholds = _iterate(states, par, models, square, [resolved[n] for n in names], private,
                                         opts)
    full = lay.size <= _FULL_COVARIANCE_MAX
    if full:
        cov, sigma, std_note = covariance((sol.jac.T @ sol.jac).toarray(), sol.fun)
    else:  # a large fit: the cameras' block alone, without the dense inverse of every frame's pose
        n_cam = _n_cameras(lay)
        cov, sigma, std_note = camera_covariance(_normal(sol.jac, sol.fun, n_cam), sol.fun)
        notes.append(f"the covariance holds the cameras' {n_cam} parameters alone: the {len(lay.frame)} "
                     "frames' poses are eliminated (their Schur complement), too many for the full matrix")
    if std_note:
        notes.append(f"no standard deviations: {std_note}")
    cameras = tuple(_camera_result(c, n, st, res[c], par, thresholds[c], cov, lay, std_note, private[c],
                                   selections[n])
                    for c, (n, st) in enumerate(zip(names, states)))
    layout = {}
    for c, n in enumerate(names):
        layout[f"{n}.intrinsics"] = lay.intr[c]
        if lay.pose[c] is not None:
            layout[f"{n}.pose"] = lay.pose[c]
    F = len(frame_names)
    for f, s in lay.frame.items() if full else ():  # a camera without a pose has frames of its own
        layout[f"frame.{f}.pose" if f < F else f"{names[f // F - 1]}.frame.{f % F}.pose"] = s
    used = np.array([f in lay.frame for f in range(F)])
    fr = np.where(used[:, None], par.frames[:F], np.nan)
    # in px, not whitened: over every camera's used corners
    r2 = np.concatenate([np.sum(res[c][f][st.corner_ok[f]] ** 2, axis=1) for c, st in enumerate(states)
                         for f in np.flatnonzero(st.view_ok) if res[c][f] is not None])
    return RigCalibration(
        cameras=cameras, frames=tuple(frame_names), rvecs=fr[:, :3].copy(), tvecs=fr[:, 3:].copy(),
        frame_used=used, rms=float(np.sqrt(np.mean(r2))), sigma=sigma, covariance=cov,
        layout=layout, square=square, notes=tuple(notes),
        model_selection={n: s for n, s in selections.items() if s is not None} or None,
        connectivity=_used_connectivity(names, states, private))
