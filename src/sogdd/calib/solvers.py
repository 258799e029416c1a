"""The OpenCV calls of a calibration: one fit of a camera to views, one view's pose given the camera."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import coo_matrix

from .cameras import MODELS, lens, project
from .cameras.models import fisheye_distorted, fisheye_theta
from .targets.board import Board

__all__ = ["COND_MAX", "FISHEYE_FOVS", "BlockNormal", "fisheye_fixed", "fit_camera", "fit_fisheye",
           "fit_fisheye_from", "fit_camera_checked", "jacobian_std", "levenberg_marquardt", "refine_weighted",
           "rotation_matrices", "solve_pose"]

#: (JᵀJ with unit columns) beyond this condition number leaves some parameters undetermined: its
#: inverse would carry the rounding of the other parameters, about 1e-16 times this, into them
COND_MAX = 1e12


def fit_camera(obj: list[np.ndarray], img: list[np.ndarray], size: tuple[int, int], model: str, flags: int,
               weights: list[np.ndarray] | None = None):
    """One calibration: ``(K, dist, rvecs (V, 3), tvecs (V, 3), std (array or None))``.

    By the model's record (:mod:`~sogdd.calib.cameras.registry`): its own ``calibrate`` where it has
    one (a view that fit left out gets its pose from its rays); else by its ``start``.
    Pinhole and rational: ``cv2.calibrateCameraExtended`` with the record's flags (``pinhole4`` with
    ``CALIB_FIX_K3``: k3 held at 0, four coefficients returned). Fisheye: :func:`fit_fisheye`,
    which also starts from ``cv2.fisheye.calibrate``'s answer where OpenCV gives one,
    so it is never worse than OpenCV's where OpenCV works, and works where OpenCV's
    initialisation fails (rays near and beyond 90 degrees); its standard deviations
    come from :func:`jacobian_std` (None here). Raises ``cv2.error`` when no fit is possible.

    ``weights`` (per view, one per corner; :func:`sogdd.calib.weighting.corner_weights`)
    make the fit minimise :math:`\\sum w^2 \\lVert x - \\pi(X) \\rVert^2`: OpenCV's
    calibration has no weights, so its (unweighted) solution is the start of
    :func:`refine_weighted`, whose standard deviations replace OpenCV's; the
    fisheye fit weighs its final least squares. Equal weights change nothing.
    """
    record = lens(model)
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    w = None if weights is None or np.ptp(np.concatenate([np.ravel(x) for x in weights])) == 0 else weights
    if record.calibrate is not None:  # a model that brings its own fit (its record's)
        K, D, rv, tv, std = record.calibrate(obj, img, size, flags, w)
        for v in np.flatnonzero(~np.all(np.isfinite(np.c_[rv, tv]), axis=1)):
            # a view its OpenCV fit left out still needs its pose (rejection scores every view)
            pose = _pose_by_rays(np.asarray(obj[v], np.float64), np.asarray(img[v], np.float64), K, D, model)
            if pose is None:
                raise cv2.error(f"no pose for view {v} under the fitted {model} camera")
            rv[v], tv[v] = pose
        return K, D, rv, tv, std
    if record.start == "fisheye.calibrate":
        K, D, rv, tv = fit_fisheye(obj, img, size, flags, start=_opencv_fisheye(obj, img, size, flags, crit),
                                   weights=w)
        std = None
    else:
        f = flags | record.cv_flags
        nd = len(record.params)
        o = [p.astype(np.float64).reshape(-1, 1, 3) for p in obj]
        i = [p.astype(np.float64).reshape(-1, 1, 2) for p in img]
        _, K, D, rv, tv, std, _, _ = cv2.calibrateCameraExtended(
            o, i, size, np.eye(3), np.zeros(nd), flags=f, criteria=crit)
        D = D.ravel()[:nd]
        std = std.ravel()
    rv = np.array([np.asarray(r, dtype=np.float64).ravel() for r in rv])
    tv = np.array([np.asarray(t, dtype=np.float64).ravel() for t in tv])
    if w is not None and record.start == "calibrateCamera":
        return refine_weighted(obj, img, w, K, D, rv, tv, model, flags)
    return K, np.asarray(D, dtype=np.float64).ravel(), rv, tv, std


def _intrinsic_steps(model: str, flags: int, K: np.ndarray) -> np.ndarray:
    """The directions in which OpenCV's calibration ``flags`` let ``fx, fy, cx, cy`` and the distortion
    move, as the columns of a matrix ``T`` ((4 + nd) x free): a step ``z`` moves them by ``T z``.

    ``CALIB_FIX_PRINCIPAL_POINT``, ``CALIB_FIX_FOCAL_LENGTH``, ``CALIB_ZERO_TANGENT_DIST`` /
    ``CALIB_FIX_TANGENT_DIST`` and ``CALIB_FIX_K1`` .. ``K6`` hold those; ``CALIB_FIX_ASPECT_RATIO``
    moves ``fy`` with ``fx``, keeping their ratio.
    """
    names = ("fx", "fy", "cx", "cy") + MODELS[model]
    fixed = set()
    if flags & cv2.CALIB_FIX_PRINCIPAL_POINT:
        fixed |= {"cx", "cy"}
    if flags & cv2.CALIB_FIX_FOCAL_LENGTH:
        fixed |= {"fx", "fy"}
    if flags & (cv2.CALIB_ZERO_TANGENT_DIST | cv2.CALIB_FIX_TANGENT_DIST):
        fixed |= {"p1", "p2"}
    ks = (cv2.CALIB_FIX_K1, cv2.CALIB_FIX_K2, cv2.CALIB_FIX_K3, cv2.CALIB_FIX_K4, cv2.CALIB_FIX_K5,
          cv2.CALIB_FIX_K6)
    fixed |= {f"k{i}" for i, bit in enumerate(ks, start=1) if flags & bit}
    aspect = bool(flags & cv2.CALIB_FIX_ASPECT_RATIO)
    cols = []
    for i, n in enumerate(names):
        if n in fixed or (aspect and n == "fy"):
            continue
        c = np.zeros(len(names))
        c[i] = 1.0
        if aspect and n == "fx":
            c[1] = K[1, 1] / K[0, 0]
        cols.append(c)
    return np.array(cols).reshape(-1, len(names)).T


@dataclass
class BlockNormal:
    """The normal equations :math:`N \\delta = g` of the weighted fit, by blocks: ``U`` (z, z) of the free
    intrinsics, ``W`` (V, z, 6) between them and each view's pose, ``P`` (V, 6, 6) of each pose (the
    poses share no residual: ``N``'s pose part is block-diagonal), and ``g`` split the same way."""

    U: np.ndarray
    W: np.ndarray
    P: np.ndarray
    gi: np.ndarray
    gp: np.ndarray

    def solve(self, lam: float) -> np.ndarray:
        """The step of :math:`(N + \\lambda\\,\\mathrm{diag} N) \\delta = g`, the poses eliminated (their
        Schur complement), as ``(intrinsics, poses)`` stacked; raises ``LinAlgError`` when singular."""
        U = self.U + lam * np.diag(np.maximum(np.diag(self.U), 1e-12))
        d = np.maximum(np.diagonal(self.P, axis1=1, axis2=2), 1e-12)
        Pinv = np.linalg.inv(self.P + lam * d[:, :, None] * np.eye(6))
        WP = np.einsum("vzi,vij->vzj", self.W, Pinv)
        S = U - np.einsum("vzj,vyj->zy", WP, self.W)
        di = np.linalg.solve(S, self.gi - np.einsum("vzj,vj->z", WP, self.gp))
        dp = np.einsum("vij,vj->vi", Pinv, self.gp - np.einsum("vzi,z->vi", self.W, di))
        return np.r_[di, dp.ravel()]

    def intrinsic_inverse(self) -> np.ndarray:
        """The intrinsics' block of :math:`N^{-1}`: the inverse of the Schur complement
        :math:`U - \\sum_v W_v P_v^{-1} W_v^T`; raises ``LinAlgError`` when singular."""
        WP = np.einsum("vzi,vij->vzj", self.W, np.linalg.inv(self.P))
        S = self.U - np.einsum("vzj,vyj->zy", WP, self.W)
        norms = np.sqrt(np.diag(S))
        if not np.all(norms > 0) or np.linalg.cond(S / np.outer(norms, norms)) > COND_MAX:
            raise np.linalg.LinAlgError("degenerate")
        return np.linalg.inv(S / np.outer(norms, norms)) / np.outer(norms, norms)


def _weighted_system(obj, img, weights, intr, poses, T, nd: int, jacobian: bool = True):
    """Whitened residuals ``w (x - pi)`` (2N,) and, with ``jacobian``, the normal equations
    (:class:`BlockNormal`) of the free intrinsics (``T``) and every pose, from ``cv2.projectPoints``' analytic
    derivatives."""
    K = np.array([[intr[0], 0.0, intr[2]], [0.0, intr[1], intr[3]], [0.0, 0.0, 1.0]])
    z, V = T.shape[1], len(obj)
    ne = BlockNormal(np.zeros((z, z)), np.zeros((V, z, 6)), np.zeros((V, 6, 6)), np.zeros(z), np.zeros((V, 6)))
    out = []
    for v in range(V):
        p, J = cv2.projectPoints(np.asarray(obj[v], np.float64).reshape(-1, 1, 3), poses[v, :3], poses[v, 3:],
                                 K, intr[4:4 + nd])
        w2 = np.repeat(np.asarray(weights[v], np.float64), 2)
        r = w2 * (np.asarray(img[v], np.float64).reshape(-1, 2) - p.reshape(-1, 2)).ravel()
        out.append(r)
        if not jacobian:
            continue
        # columns: rvec, tvec, fx, fy, cx, cy, distortion
        Jp = w2[:, None] * J[:, :6]
        Ji = (w2[:, None] * J[:, 6:10 + nd]) @ T
        ne.U += Ji.T @ Ji
        ne.W[v] = Ji.T @ Jp
        ne.P[v] = Jp.T @ Jp
        ne.gi += Ji.T @ r
        ne.gp[v] = Jp.T @ r
    return np.concatenate(out), (ne if jacobian else None)


def refine_weighted(obj: list[np.ndarray], img: list[np.ndarray], weights: list[np.ndarray], K: np.ndarray,
                    dist: np.ndarray, rvecs: np.ndarray, tvecs: np.ndarray, model: str, flags: int = 0,
                    max_iterations: int = 50):
    """A pinhole or rational calibration refined to minimise the weighted reprojection error.

    Minimises :math:`\\sum_{v,c} w_{vc}^2 \\lVert x_{vc} - \\pi(K, d, R_v X_c + t_v) \\rVert^2`
    over ``fx, fy, cx, cy`` (skew 0), the distortion (OpenCV's ``model``, the
    ``flags``' fixed terms held: :func:`_intrinsic_steps`) and every view's pose,
    by Levenberg-Marquardt from the start ``(K, dist, rvecs, tvecs)`` (OpenCV's
    unweighted solution): the step solves
    :math:`(N + \\lambda\\,\\mathrm{diag} N) \\delta = J_w^T r_w` (the poses' blocks eliminated by their
    Schur complement: they share no residual) with the whitened
    residuals :math:`r_w = w (x - \\pi)` and Jacobian :math:`J_w = w\\,\\partial\\pi/\\partial\\theta`
    (``cv2.projectPoints``' analytic one), :math:`N = J_w^T J_w`, and is kept when
    it lowers the cost. The standard deviations are OpenCV's estimate for the
    whitened problem: the diagonal of :math:`s^2 N^{-1}`,
    :math:`s^2 = \\lVert r_w \\rVert^2 / (2N_c - P)` (``P`` free parameters,
    ``N_c`` corners), 0 for a held parameter; None when :math:`N` (unit columns)
    has a condition number above 1e12.

    Returns
    -------
    ``(K, dist, rvecs (V, 3), tvecs (V, 3), std (4 + nd,) or None)``, as :func:`fit_camera`.

    Examples
    --------
    >>> K = np.array([[600.0, 0, 320], [0, 600, 240], [0, 0, 1]])
    >>> obj = np.array([(i, j, 0.0) for j in range(6) for i in range(9)])
    >>> poses = [(np.array([0.3 * np.sin(a), 0.3 * np.cos(a), 0.1]), np.array([-4.0, -2.5, 12.0]))
    ...          for a in range(8)]
    >>> img = [project(obj, K, np.zeros(5), "pinhole", r, t) for r, t in poses]
    >>> img[0] = img[0] + 2.0   # one view 2 px off, weighted down a hundredfold
    >>> w = [np.full(54, 0.01)] + [np.ones(54)] * 7
    >>> K0 = K * [[1.03], [1.03], [1]]
    >>> rv, tv = np.array([p[0] for p in poses]), np.array([p[1] for p in poses])
    >>> Kw, D, _, _, std = refine_weighted([obj] * 8, img, w, K0, np.zeros(5), rv, tv, "pinhole")
    >>> bool(abs(Kw[0, 0] - 600) < 0.5), std.shape
    (True, (9,))
    """
    nd = len(MODELS[model])
    T = _intrinsic_steps(model, flags, K)
    intr = np.r_[K[0, 0], K[1, 1], K[0, 2], K[1, 2], np.asarray(dist, np.float64).ravel()[:nd],
                 np.zeros(max(0, nd - len(np.ravel(dist))))]
    poses = np.c_[np.asarray(rvecs, np.float64), np.asarray(tvecs, np.float64)]
    z = T.shape[1]
    (intr, poses), r, ne = levenberg_marquardt(
        (intr, poses),
        lambda x: _weighted_system(obj, img, weights, x[0], x[1], T, nd),
        lambda x: _weighted_system(obj, img, weights, x[0], x[1], T, nd, jacobian=False)[0],
        lambda x, step: (x[0] + T @ step[:z], x[1] + step[z:].reshape(-1, 6)),
        ftol=1e-12, max_iterations=int(max_iterations))
    Kw = np.array([[intr[0], 0.0, intr[2]], [0.0, intr[1], intr[3]], [0.0, 0.0, 1.0]])
    return Kw, intr[4:].copy(), poses[:, :3].copy(), poses[:, 3:].copy(), _whitened_std(ne, r, T)


def levenberg_marquardt(x0, system: Callable, residuals: Callable, step_to: Callable, *, ftol: float = 1e-10,
                        max_iterations: int = 100) -> tuple:
    """Minimise :math:`\\lVert r(x) \\rVert^2` by Levenberg-Marquardt from ``x0``: ``(x, r, ne)`` at the end.

    ``system(x)`` gives the residuals and their normal equations by blocks, ``(r, ne)``
    (:class:`BlockNormal`: the shared parameters against each view's or frame's pose, the poses
    eliminated by their Schur complement when solved); ``residuals(x)`` the residuals alone;
    ``step_to(x, step)`` the parameters moved by a step. Each iteration solves
    :math:`(N + \\lambda\\,\\mathrm{diag} N) \\delta = -J^T r` and keeps the step when it lowers the cost
    (then :math:`\\lambda` falls tenfold, else it rises tenfold and the step is solved again); it stops
    when a kept step lowers the cost by at most ``ftol`` of it, when no damping up to 1e10 lowers it,
    or after ``max_iterations``. One camera's weighted fit (:func:`refine_weighted`) and the rig's
    joint fit (:func:`sogdd.calib.rig.calibrate_rig`) both run it.

    Examples
    --------
    >>> a, b = np.array([[2.0], [1.0]]), np.array([4.0, 1.0])  # least squares of 2 x = 4, x = 1
    >>> none = np.zeros((0, 1, 6)), np.zeros((0, 6, 6))  # no poses
    >>> def system(x):
    ...     r = a @ x - b
    ...     return r, BlockNormal(a.T @ a, *none, -(a.T @ r), np.zeros((0, 6)))
    >>> x, r, _ = levenberg_marquardt(np.zeros(1), system, lambda x: a @ x - b, lambda x, s: x + s)
    >>> round(float(x[0]), 6)  # (2 * 4 + 1 * 1) / (2^2 + 1^2)
    1.8
    """
    x = x0
    r, ne = system(x)
    cost, lam = float(r @ r), 1e-3
    for _ in range(int(max_iterations)):
        improved = done = False
        while lam < 1e10:
            try:
                step = ne.solve(lam)
            except np.linalg.LinAlgError:
                lam *= 10
                continue
            x2 = step_to(x, step)
            r2 = residuals(x2)
            c2 = float(r2 @ r2)
            if np.isfinite(c2) and c2 < cost:
                done = cost - c2 <= ftol * cost
                x, cost, lam, improved = x2, c2, max(lam / 10, 1e-9), True
                break
            lam *= 10
        if not improved:
            break
        r, ne = system(x)
        if done:
            break
    return x, r, ne


def _whitened_std(ne: BlockNormal, r: np.ndarray, T: np.ndarray) -> np.ndarray | None:
    """The intrinsics' standard deviations :math:`\\sqrt{\\mathrm{diag}(T\\,[s^2 N^{-1}]_{zz} T^T)}`,
    :math:`s^2 = \\lVert r \\rVert^2 / (\\dim r - \\dim N)`; None when degenerate (a singular pose
    block, or the intrinsics' Schur complement, columns scaled to unit length, beyond 1e12)."""
    dof = len(r) - T.shape[1] - ne.P.size // 6
    try:
        cov = ne.intrinsic_inverse() * (float(r @ r) / dof) if dof > 0 else None
    except np.linalg.LinAlgError:
        cov = None
    if cov is None or not np.all(np.isfinite(cov)):
        return None
    return np.sqrt(np.clip(np.diag(T @ cov @ T.T), 0, None))


def fit_camera_checked(obj, img, size, model, flags, what: str, weights=None):
    """:func:`fit_camera`, with OpenCV's failure as a one-line ``ValueError`` naming ``what``."""
    try:
        return fit_camera(obj, img, size, model, flags, weights)
    except cv2.error as exc:
        msg = " ".join(str(exc).split())
        raise ValueError(f"OpenCV could not calibrate {what} ({model} model): {msg[-160:]}") from None


def solve_pose(board: Board, square: float, K, dist, model):
    """A view's pose given the intrinsics (solvePnP), or None."""
    obj = board.object_points(square)
    img = board.image_points
    record = lens(model)
    if record.start == "fisheye.calibrate":
        # from the rays, as the fisheye fit starts: cv2.fisheye.solvePnP fails beyond 90 degrees
        intr = np.r_[K[0, 0], K[1, 1], K[0, 2], K[1, 2], np.ravel(dist)[:4]].astype(np.float64)
        X, uv = np.asarray(obj, np.float64), np.asarray(img, np.float64)
        pose = _pose_from_rays(X, _rays(uv, intr))
        if pose is None:
            return None
        _, p, _ = _fisheye_lsq(intr, pose[None], X, uv, np.zeros(len(X), int), np.zeros(8, bool), 50, False)
        return (p[0, :3], p[0, 3:]) if np.all(np.isfinite(p)) else None
    if record.start != "calibrateCamera":
        return _pose_by_rays(np.asarray(obj, np.float64), np.asarray(img, np.float64), K, dist, model)
    try:
        ok, rv, tv = cv2.solvePnP(obj, img, K, dist, flags=cv2.SOLVEPNP_ITERATIVE)
    except cv2.error:
        return None
    return (rv.ravel(), tv.ravel()) if ok else None


def _pose_by_rays(X: np.ndarray, uv: np.ndarray, K, dist, model: str):
    """A view's pose under any registered model: from its corners' rays (the record's ``unproject``,
    :func:`_pose_from_rays`), refined by least squares on the record's projection; None if none."""
    pose = _pose_from_rays(X, lens(model).unproject(uv, K, dist))
    if pose is None:
        return None

    def fun(x):
        return (project(X, K, dist, model, x[:3], x[3:]) - uv).ravel()

    with np.errstate(all="ignore"):
        sol = least_squares(fun, pose, method="lm", max_nfev=200)
    return (sol.x[:3], sol.x[3:]) if np.all(np.isfinite(sol.x)) and np.all(np.isfinite(sol.fun)) else None


def fisheye_fixed(flags: int) -> np.ndarray:
    """Which of ``fx, fy, cx, cy, k1..k4`` the fisheye ``flags`` hold fixed (bool, 8)."""
    fe = cv2.fisheye
    bits = (fe.CALIB_FIX_FOCAL_LENGTH,) * 2 + (fe.CALIB_FIX_PRINCIPAL_POINT,) * 2 + (
        fe.CALIB_FIX_K1, fe.CALIB_FIX_K2, fe.CALIB_FIX_K3, fe.CALIB_FIX_K4)
    return np.array([bool(flags & b) for b in bits])


def _residuals(obj, img, theta: np.ndarray, nd: int, model: str, views) -> np.ndarray:
    """Stacked observed-minus-projected positions of ``views`` for the parameter vector ``theta``."""
    fx, fy, cx, cy = theta[:4]
    K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    D = theta[4:4 + nd]
    out = []
    for v in views:
        pose = theta[4 + nd + 6 * v: 4 + nd + 6 * v + 6]
        out.append((img[v] - project(obj[v], K, D, model, pose[:3], pose[3:])).ravel())
    return np.concatenate(out)


def jacobian_std(obj: list[np.ndarray], img: list[np.ndarray], K: np.ndarray, dist: np.ndarray,
                 rvecs: np.ndarray, tvecs: np.ndarray, model: str,
                 fixed: np.ndarray | None = None, weights: list[np.ndarray] | None = None) -> np.ndarray | None:
    """Standard deviations of ``fx, fy, cx, cy`` and the distortion at a solution, from the Jacobian.

    With :math:`J` the Jacobian of the :math:`2N` reprojection residuals :math:`r`
    with respect to the :math:`P` free parameters (intrinsics, distortion and
    every view's pose; central differences), the covariance is
    :math:`\\sigma^2 (J^T J)^{-1}` with :math:`\\sigma^2 = \\lVert r \\rVert^2 / (2N - P)`:
    the estimate ``cv2.calibrateCameraExtended`` makes, here for any model (OpenCV's
    fisheye calibration gives none). Skew is held at 0, as the fits do. A
    ``fixed`` parameter (bool per intrinsic) has a standard deviation of 0.
    With ``weights`` (per view, one per corner) the residuals and their
    Jacobian are whitened, :math:`w r`: the same estimate for the weighted fit.

    Returns
    -------
    (4 + len(dist),) float64, or None
        In the order ``("fx", "fy", "cx", "cy") + MODELS[model]``; None when the
        fit is degenerate: no more residuals than parameters, or :math:`J^T J`
        (columns scaled to unit length) with a condition number above 1e12.

    Examples
    --------
    >>> K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    >>> obj = np.array([(i, j, 0.0) for j in range(6) for i in range(9)])
    >>> poses = [((0.3 * np.sin(a), 0.3 * np.cos(a), 0.1), (-4.0, -2.5, 12.0)) for a in range(6)]
    >>> rng = np.random.default_rng(0)
    >>> img = [project(obj, K, np.zeros(4), "fisheye", r, t) + rng.normal(0, 0.1, (54, 2)) for r, t in poses]
    >>> rv, tv = np.array([p[0] for p in poses], float), np.array([p[1] for p in poses], float)
    >>> std = jacobian_std([obj] * 6, img, K, np.zeros(4), rv, tv, "fisheye")
    >>> std.shape, bool(0 < std[0] < 5)
    ((8,), True)
    """
    nd = len(MODELS[model])
    V = len(obj)
    theta = np.concatenate([[K[0, 0], K[1, 1], K[0, 2], K[1, 2]], np.asarray(dist, float).ravel()[:nd],
                            np.c_[np.asarray(rvecs, float), np.asarray(tvecs, float)].ravel()])
    free = np.ones(len(theta), bool)
    if fixed is not None:
        free[:4 + nd] = ~np.asarray(fixed, bool)
    r0 = _residuals(obj, img, theta, nd, model, range(V))
    rows = np.cumsum([0] + [2 * len(o) for o in obj])
    J = np.zeros((len(r0), len(theta)))
    for j in np.flatnonzero(free):
        # a pose parameter moves only its own view's residuals
        views = range(V) if j < 4 + nd else [(j - 4 - nd) // 6]
        sl = slice(0, len(r0)) if j < 4 + nd else slice(rows[views[0]], rows[views[0] + 1])
        h = 1e-6 * max(abs(theta[j]), 1.0)
        up, down = theta.copy(), theta.copy()
        up[j] += h
        down[j] -= h
        J[sl, j] = (_residuals(obj, img, up, nd, model, views)
                    - _residuals(obj, img, down, nd, model, views)) / (2 * h)
    J = J[:, free]
    if weights is not None:
        w2 = np.repeat(np.concatenate([np.ravel(w) for w in weights]).astype(np.float64), 2)
        r0, J = w2 * r0, w2[:, None] * J
    dof = len(r0) - J.shape[1]
    norms = np.linalg.norm(J, axis=0)
    if dof <= 0 or not np.all(norms > 0):
        return None
    Js = J / norms
    JtJ = Js.T @ Js
    if not np.isfinite(JtJ).all() or np.linalg.cond(JtJ) > COND_MAX:
        return None
    cov = np.linalg.inv(JtJ) / np.outer(norms, norms) * (float(r0 @ r0) / dof)
    std = np.zeros(len(theta))
    std[free] = np.sqrt(np.clip(np.diag(cov), 0, None))
    return std[:4 + nd]


# --------------------------------------------------------------------------------------------------
# the fisheye fit: OpenCV's fisheye model, fitted by sogdd's own least squares

#: the equidistant starts' fields of view across the image's larger side (degrees): lenses from a
#: wide angle to beyond a half sphere
FISHEYE_FOVS = (100.0, 130.0, 160.0, 190.0, 220.0)
# rays farther than this from a view's mean ray are left out of its first pose: projected to a plane
# they stretch without bound towards 90 degrees, where a guessed focal length errs the most
_POSE_RAY_MAX = np.deg2rad(70.0)
# a start's short fit: enough steps to rank the starts, robust to the few gross corners that the
# rejection in fit.py has not yet removed
_START_STEPS = 25
_START_LOSS_SCALE = 3.0  # px
_STARTS_FITTED = 2


def _robust_cost(r: np.ndarray) -> float:
    """``least_squares``' soft-L1 cost of residuals ``r`` (scale :data:`_START_LOSS_SCALE`):
    :math:`\\sum_i s^2 (\\sqrt{1 + (r_i / s)^2} - 1)`; infinite where any is not finite."""
    z = (np.asarray(r) / _START_LOSS_SCALE) ** 2
    c = float(np.sum(_START_LOSS_SCALE ** 2 * (np.sqrt(1 + z) - 1)))
    return c if np.isfinite(c) else np.inf


def _opencv_fisheye(obj, img, size, flags, crit):
    """``cv2.fisheye.calibrate``'s solution as a start ``(intrinsics (8,), poses (V, 6))``, or None
    where it raises or returns something non-finite (its homography-based initialisation fails for
    rays near and beyond 90 degrees)."""
    f = flags | cv2.fisheye.CALIB_RECOMPUTE_EXTRINSIC | cv2.fisheye.CALIB_FIX_SKEW
    o = [p.astype(np.float64).reshape(1, -1, 3) for p in obj]
    i = [p.astype(np.float64).reshape(1, -1, 2) for p in img]
    try:
        _, K, D, rv, tv = cv2.fisheye.calibrate(o, i, size, np.eye(3), np.zeros(4), flags=f, criteria=crit)
    except cv2.error:
        return None
    intr = np.r_[K[0, 0], K[1, 1], K[0, 2], K[1, 2], np.ravel(D)[:4]]
    poses = np.c_[np.array([np.ravel(r) for r in rv]), np.array([np.ravel(t) for t in tv])]
    ok = np.all(np.isfinite(intr)) and np.all(np.isfinite(poses)) and intr[0] > 0 and intr[1] > 0
    return (intr, poses) if ok else None


def rotation_matrices(rv: np.ndarray) -> np.ndarray:
    """Rotation matrices (V, 3, 3) of rotation vectors (V, 3): :math:`R = I + \\sin\\alpha\\,[k]_\\times
    + (1 - \\cos\\alpha)[k]_\\times^2`, :math:`\\alpha = \\lVert r \\rVert`, :math:`k = r / \\alpha`."""
    a = np.linalg.norm(rv, axis=1)
    k = rv / np.where(a > 1e-12, a, 1.0)[:, None]
    Kx = np.zeros((len(rv), 3, 3))
    Kx[:, 0, 1], Kx[:, 0, 2], Kx[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    Kx = Kx - Kx.transpose(0, 2, 1)
    s, c = np.sin(a)[:, None, None], (1 - np.cos(a))[:, None, None]
    return np.eye(3) + s * Kx + c * (Kx @ Kx)


def _fisheye_residuals(intr: np.ndarray, poses: np.ndarray, X: np.ndarray, uv: np.ndarray,
                       view: np.ndarray) -> np.ndarray:
    """Projected minus observed pixels (2N,) of all views at once: :func:`~sogdd.calib.cameras.project`'s
    fisheye (:math:`\\theta = \\operatorname{atan2}(r, Z)`), vectorised over the views."""
    R = rotation_matrices(poses[:, :3])[view]
    xd = fisheye_distorted(np.einsum("nij,nj->ni", R, X) + poses[view, 3:], intr[4:8])
    u = intr[0] * xd[:, 0] + intr[2] - uv[:, 0]
    v = intr[1] * xd[:, 1] + intr[3] - uv[:, 1]
    return np.stack([u, v], axis=1).ravel()


def _sparsity(view: np.ndarray, n_views: int, n_intr: int):
    """Which parameters each residual depends on: every intrinsic, and its own view's 6 pose terms."""
    rows = np.arange(2 * len(view))
    cols_pose = n_intr + 6 * np.repeat(view, 2)[:, None] + np.arange(6)
    r = np.r_[np.repeat(rows, n_intr), np.repeat(rows, 6)]
    c = np.r_[np.tile(np.arange(n_intr), len(rows)), cols_pose.ravel()]
    return coo_matrix((np.ones(len(r), np.int8), (r, c)), shape=(len(rows), n_intr + 6 * n_views)).tocsr()


def _fisheye_lsq(intr0, poses0, X, uv, view, free, max_nfev, robust: bool, weights=None):
    """Least squares over the free intrinsics and every pose (TRF, finite differences on the sparse
    Jacobian), each corner's residual times its weight (none: 1); returns ``(intrinsics, poses, cost)``."""
    V, nf = len(poses0), int(free.sum())
    w = 1.0 if weights is None else np.repeat(np.asarray(weights, np.float64), 2)

    def fun(x):
        intr = intr0.copy()
        intr[free] = x[:nf]
        return w * _fisheye_residuals(intr, x[nf:].reshape(V, 6), X, uv, view)

    x0 = np.r_[intr0[free], poses0.ravel()]
    kw = {"loss": "soft_l1", "f_scale": _START_LOSS_SCALE} if robust else {}
    sol = least_squares(fun, x0, jac_sparsity=_sparsity(view, V, nf), method="trf", tr_solver="lsmr",
                        x_scale="jac", max_nfev=max_nfev, xtol=1e-10, ftol=1e-10, gtol=1e-10,
                        tr_options={"atol": 1e-10, "btol": 1e-10}, **kw)
    intr = intr0.copy()
    intr[free] = sol.x[:nf]
    return intr, sol.x[nf:].reshape(V, 6), float(sol.cost)


def _rays(uv: np.ndarray, intr: np.ndarray) -> np.ndarray:
    """Unit rays (N, 3) of pixels under the fisheye intrinsics: :math:`\\theta_d = \\lVert ((u - c_x)/f_x,
    (v - c_y)/f_y) \\rVert`, :math:`\\theta = \\theta_d^{-1}`, the ray
    :math:`(\\sin\\theta\\cos\\phi, \\sin\\theta\\sin\\phi, \\cos\\theta)` (NaN where the model folds)."""
    xd = (uv - intr[2:4]) / intr[:2]
    th = fisheye_theta(np.hypot(xd[:, 0], xd[:, 1]), intr[4:8])
    phi = np.arctan2(xd[:, 1], xd[:, 0])
    return np.stack([np.sin(th) * np.cos(phi), np.sin(th) * np.sin(phi), np.cos(th)], axis=1)


def _to_axis(m: np.ndarray) -> np.ndarray:
    """A rotation matrix taking the unit vector ``m`` to the optical axis (0, 0, 1)."""
    axis = np.cross(m, [0.0, 0.0, 1.0])
    s, c = np.linalg.norm(axis), float(m[2])
    if s < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    return cv2.Rodrigues(axis / s * np.arctan2(s, c))[0]


def _pose_from_rays(obj: np.ndarray, rays: np.ndarray):
    """A view's pose ``(6,)`` from its corners' rays, or None.

    The rays are turned so that their mean lies on the axis (a board seen at
    and beyond 90 degrees then lies in front of a virtual pinhole), those
    within 70 degrees of it are projected to the plane :math:`z = 1`, and
    ``cv2.solvePnP`` (IPPE for a flat board) gives the pose :math:`(R', t')`
    of the turned camera; with :math:`R_m` the turn, :math:`R = R_m^T R'`,
    :math:`t = R_m^T t'`.
    """
    ok = np.all(np.isfinite(rays), axis=1)
    if ok.sum() < 4:
        return None
    m = rays[ok].mean(axis=0)
    if np.linalg.norm(m) < 1e-6:
        return None
    Rm = _to_axis(m / np.linalg.norm(m))
    d = rays @ Rm.T
    sel = ok & (d[:, 2] > np.cos(_POSE_RAY_MAX))
    if sel.sum() < 4:
        return None
    xy = (d[sel, :2] / d[sel, 2:]).astype(np.float64)
    o = np.asarray(obj, np.float64)[sel]
    method = cv2.SOLVEPNP_IPPE if np.ptp(o[:, 2]) < 1e-9 else cv2.SOLVEPNP_ITERATIVE
    try:
        good, rv, tv = cv2.solvePnP(o, xy, np.eye(3), None, flags=method)
    except cv2.error:
        return None
    if not good:
        return None
    R = Rm.T @ cv2.Rodrigues(rv)[0]
    return np.r_[cv2.Rodrigues(R)[0].ravel(), Rm.T @ tv.ravel()]


def _initial_poses(obj, img, intr: np.ndarray, X, uv, view) -> np.ndarray | None:
    """Every view's pose under the intrinsics ``intr``: from its rays, then refined (the intrinsics
    held); None if any view has none."""
    poses = []
    for o, i in zip(obj, img):
        pose = _pose_from_rays(o, _rays(np.asarray(i, np.float64), intr))
        if pose is None:
            return None
        poses.append(pose)
    # all views at once: with the intrinsics held the Jacobian is block-diagonal, 6 columns per view
    _, p, _ = _fisheye_lsq(intr, np.array(poses), X, uv, view, np.zeros(8, bool), _START_STEPS, robust=True)
    return p


def fit_fisheye(obj: list[np.ndarray], img: list[np.ndarray], size: tuple[int, int], flags: int = 0,
                start: tuple[np.ndarray, np.ndarray] | None = None, weights: list[np.ndarray] | None = None):
    """Fit OpenCV's fisheye model to views by least squares, for lenses up to and beyond 180 degrees.

    The model is ``cv2.fisheye``'s (skew 0): a point :math:`X_c = R_v X + t_v`
    at angle :math:`\\theta = \\operatorname{atan2}(\\sqrt{X_c^2 + Y_c^2}, Z_c)`
    from the axis lands at :math:`u = f_x \\theta_d X_c / r + c_x`,
    :math:`v = f_y \\theta_d Y_c / r + c_y`, with
    :math:`\\theta_d = \\theta (1 + k_1 \\theta^2 + k_2 \\theta^4 + k_3 \\theta^6 + k_4 \\theta^8)`.
    The fit minimises :math:`\\sum_{v,c} \\lVert x_{vc} - \\pi(X_c) \\rVert^2` over
    ``fx, fy, cx, cy, k1..k4`` (those ``flags`` do not fix) and each view's
    ``rvec, tvec`` with ``scipy.optimize.least_squares``, the Jacobian sparse (a
    view's residuals depend on the 8 intrinsics and its own 6 pose terms only).

    It starts from equidistant lenses (:math:`k = 0`, :math:`(c_x, c_y)` the
    image centre, :math:`f` giving 100 to 220 degrees across the image's
    larger side), each view's pose from its rays under that lens
    (:func:`_pose_from_rays`, then refined alone), and from ``start`` (e.g.
    ``cv2.fisheye.calibrate``'s answer); the two starts of the lowest robust
    (soft-L1) cost get a short robust fit of everything, and the better is fitted
    to convergence by plain least squares. Unlike OpenCV's initialisation
    (homographies of the normalised points, a focal guess from the image
    size), nothing here needs the rays in front of the camera.

    Parameters
    ----------
    obj, img : list of (N_v, 3) and (N_v, 2) arrays
        Board points and their pixels, per view.
    size : (width, height)
    flags : int
        ``cv2.fisheye`` flags; ``CALIB_FIX_K1..K4`` hold those at 0,
        ``CALIB_FIX_FOCAL_LENGTH`` and ``CALIB_FIX_PRINCIPAL_POINT`` at the start's.
    start : (intrinsics (8,), poses (V, 6)), optional
        One more start.
    weights : list of (N_v,) arrays, optional
        Per view, each corner's weight ``w`` (:func:`sogdd.calib.weighting.corner_weights`): the final
        fit minimises :math:`\\sum w^2 \\lVert x - \\pi(X) \\rVert^2` (the starts are ranked unweighted).

    Returns
    -------
    K : (3, 3), dist : (4,), rvecs : (V, 3), tvecs : (V, 3)

    Raises
    ------
    cv2.error
        When no start could be built (no view's pose from its rays), as OpenCV's own fit would fail.

    Examples
    --------
    >>> K = np.array([[200.0, 0, 320], [0, 200, 240], [0, 0, 1]])
    >>> obj = np.array([(i, j, 0.0) for j in range(4) for i in range(6)])
    >>> rng = np.random.default_rng(0)
    >>> poses = []
    >>> for a in np.linspace(0, 2 * np.pi, 8, endpoint=False):  # boards 80 degrees off the axis
    ...     d = np.array([np.sin(1.4) * np.cos(a), np.sin(1.4) * np.sin(a), np.cos(1.4)])
    ...     R = cv2.Rodrigues(np.cross([0, 0, 1.0], d) / np.sin(1.4) * 1.4)[0]
    ...     poses.append((cv2.Rodrigues(R @ cv2.Rodrigues(np.array([0.2, -0.3, 0.1]))[0])[0].ravel(),
    ...                   8 * d - R @ np.array([2.5, 1.5, 0])))
    >>> img = [project(obj, K, np.zeros(4), "fisheye", r, t) + rng.normal(0, 0.05, (24, 2)) for r, t in poses]
    >>> Kf, D, rv, tv = fit_fisheye([obj] * 8, img, (640, 480))
    >>> bool(abs(Kf[0, 0] - 200) < 1 and abs(Kf[0, 2] - 320) < 1)
    True
    """
    fixed = fisheye_fixed(flags)
    free = ~fixed
    X = np.concatenate([np.asarray(o, np.float64).reshape(-1, 3) for o in obj])
    uv = np.concatenate([np.asarray(i, np.float64).reshape(-1, 2) for i in img])
    view = np.repeat(np.arange(len(obj)), [len(o) for o in obj])
    w, h = size
    starts = [] if start is None else [start]
    for fov in FISHEYE_FOVS:
        f0 = max(w, h) / 2 / np.deg2rad(fov / 2)
        intr = np.array([f0, f0, (w - 1) / 2, (h - 1) / 2, 0.0, 0.0, 0.0, 0.0])
        poses = _initial_poses(obj, img, intr, X, uv, view)
        if poses is not None:
            starts.append((intr, poses))
    if not starts:
        raise cv2.error("the fisheye fit found no start: no view's pose could be found from its rays")
    # rank the starts by their robust cost as they are (each view's pose already fitted to its lens),
    # and fit the intrinsics from the best few only: the fits cost far more than the ranking
    order = np.argsort([_robust_cost(_fisheye_residuals(i, p, X, uv, view)) for i, p in starts])
    ranked = [_fisheye_lsq(*starts[n], X, uv, view, free, _START_STEPS, True) for n in order[:_STARTS_FITTED]]
    intr, poses, _ = min(ranked, key=lambda s: s[2] if np.isfinite(s[2]) else np.inf)
    wts = None if weights is None else np.concatenate([np.ravel(w) for w in weights])
    intr, poses, _ = _fisheye_lsq(intr, poses, X, uv, view, free, 500, robust=False, weights=wts)
    K = np.array([[intr[0], 0.0, intr[2]], [0.0, intr[1], intr[3]], [0.0, 0.0, 1.0]])
    return K, intr[4:8].copy(), poses[:, :3].copy(), poses[:, 3:].copy()


def fit_fisheye_from(obj: list[np.ndarray], img: list[np.ndarray], K: np.ndarray, dist: np.ndarray,
                     flags: int = 0, max_nfev: int = 100):
    """:func:`fit_fisheye`'s least squares from one start, a nearby camera ``(K, dist)`` (e.g. the fit of
    a superset of the views): each view's pose from its rays under it, then everything fitted, at
    most ``max_nfev`` evaluations (from a nearby start a lens the model fits converges in a few
    tens; one it does not fit crawls for hundreds). For refits of subsets (cross-validation).

    Returns ``(K, dist (4,), rvecs (V, 3), tvecs (V, 3))``; raises ``cv2.error`` when a view has no
    pose from its rays under the start.

    Examples
    --------
    >>> K = np.array([[200.0, 0, 320], [0, 200, 240], [0, 0, 1]])
    >>> obj = np.array([(i, j, 0.0) for j in range(4) for i in range(6)])
    >>> poses = [((0.3 * np.sin(a), 0.3 * np.cos(a), 0.1), (-2.5 + np.cos(a), -1.5, 6.0)) for a in range(6)]
    >>> img = [project(obj, K, np.zeros(4), "fisheye", r, t) for r, t in poses]
    >>> Kf, D, rv, tv = fit_fisheye_from([obj] * 6, img, K * [[1.02], [1.02], [1]], np.zeros(4))
    >>> bool(abs(Kf[0, 0] - 200) < 1e-6)
    True
    """
    X = np.concatenate([np.asarray(o, np.float64).reshape(-1, 3) for o in obj])
    uv = np.concatenate([np.asarray(i, np.float64).reshape(-1, 2) for i in img])
    view = np.repeat(np.arange(len(obj)), [len(o) for o in obj])
    intr = np.r_[K[0, 0], K[1, 1], K[0, 2], K[1, 2], np.ravel(dist)[:4]].astype(np.float64)
    poses = _initial_poses(obj, img, intr, X, uv, view)
    if poses is None:
        raise cv2.error("the fisheye refit found no pose for a view from its rays under the start")
    intr, poses, _ = _fisheye_lsq(intr, poses, X, uv, view, ~fisheye_fixed(flags), int(max_nfev), robust=False)
    Kf = np.array([[intr[0], 0.0, intr[2]], [0.0, intr[1], intr[3]], [0.0, 0.0, 1.0]])
    return Kf, intr[4:8].copy(), poses[:, :3].copy(), poses[:, 3:].copy()
