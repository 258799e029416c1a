"""The OpenCV calls of a calibration: one fit of a camera to views, one view's pose given the camera."""

from __future__ import annotations

import cv2
import numpy as np

from .cameras import MODELS, project
from .targets.board import Board

__all__ = ["fisheye_fixed", "fit_camera", "fit_camera_checked", "jacobian_std", "solve_pose"]

# (JᵀJ with unit columns) beyond this condition number leaves some parameters undetermined: its
# inverse would carry the rounding of the other parameters, about 1e-16 times this, into them
_COND_MAX = 1e12


def fit_camera(obj: list[np.ndarray], img: list[np.ndarray], size: tuple[int, int], model: str, flags: int):
    """One OpenCV calibration: ``(K, dist, rvecs (V, 3), tvecs (V, 3), std (array or None))``."""
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    if model == "fisheye":
        f = flags | cv2.fisheye.CALIB_RECOMPUTE_EXTRINSIC | cv2.fisheye.CALIB_FIX_SKEW
        o = [p.reshape(1, -1, 3) for p in obj]
        i = [p.reshape(1, -1, 2) for p in img]
        _, K, D, rv, tv = cv2.fisheye.calibrate(o, i, size, np.eye(3), np.zeros(4), flags=f, criteria=crit)
        std = None
    else:
        f = flags | (cv2.CALIB_RATIONAL_MODEL if model == "rational" else 0)
        nd = len(MODELS[model])
        o = [p.astype(np.float64).reshape(-1, 1, 3) for p in obj]
        i = [p.astype(np.float64).reshape(-1, 1, 2) for p in img]
        _, K, D, rv, tv, std, _, _ = cv2.calibrateCameraExtended(
            o, i, size, np.eye(3), np.zeros(nd), flags=f, criteria=crit)
        D = D.ravel()[:nd]
        std = std.ravel()
    rv = np.array([np.asarray(r, dtype=np.float64).ravel() for r in rv])
    tv = np.array([np.asarray(t, dtype=np.float64).ravel() for t in tv])
    return K, np.asarray(D, dtype=np.float64).ravel(), rv, tv, std


def fit_camera_checked(obj, img, size, model, flags, what: str):
    """:func:`fit_camera`, with OpenCV's failure as a one-line ``ValueError`` naming ``what``."""
    try:
        return fit_camera(obj, img, size, model, flags)
    except cv2.error as exc:
        msg = " ".join(str(exc).split())
        raise ValueError(f"OpenCV could not calibrate {what} ({model} model): {msg[-160:]}") from None


def solve_pose(board: Board, square: float, K, dist, model):
    """A view's pose given the intrinsics (solvePnP), or None."""
    obj = board.object_points(square)
    img = board.image_points
    try:
        if model == "fisheye":
            ok, rv, tv = cv2.fisheye.solvePnP(obj.reshape(-1, 1, 3), img.reshape(-1, 1, 2), K, dist)
        else:
            ok, rv, tv = cv2.solvePnP(obj, img, K, dist, flags=cv2.SOLVEPNP_ITERATIVE)
    except cv2.error:
        return None
    return (rv.ravel(), tv.ravel()) if ok else None


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
                 fixed: np.ndarray | None = None) -> np.ndarray | None:
    """Standard deviations of ``fx, fy, cx, cy`` and the distortion at a solution, from the Jacobian.

    With :math:`J` the Jacobian of the :math:`2N` reprojection residuals :math:`r`
    with respect to the :math:`P` free parameters (intrinsics, distortion and
    every view's pose; central differences), the covariance is
    :math:`\\sigma^2 (J^T J)^{-1}` with :math:`\\sigma^2 = \\lVert r \\rVert^2 / (2N - P)`:
    the estimate ``cv2.calibrateCameraExtended`` makes, here for any model (OpenCV's
    fisheye calibration gives none). Skew is held at 0, as the fits do. A
    ``fixed`` parameter (bool per intrinsic) has a standard deviation of 0.

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
    dof = len(r0) - J.shape[1]
    norms = np.linalg.norm(J, axis=0)
    if dof <= 0 or not np.all(norms > 0):
        return None
    Js = J / norms
    JtJ = Js.T @ Js
    if not np.isfinite(JtJ).all() or np.linalg.cond(JtJ) > _COND_MAX:
        return None
    cov = np.linalg.inv(JtJ) / np.outer(norms, norms) * (float(r0 @ r0) / dof)
    std = np.zeros(len(theta))
    std[free] = np.sqrt(np.clip(np.diag(cov), 0, None))
    return std[:4 + nd]
