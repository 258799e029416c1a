"""How far a rig calibration can be trusted: the parameters' covariance and the projection uncertainty.

The covariance
--------------
With :math:`J` the Jacobian of the joint fit's :math:`2N` residuals :math:`r`
with respect to its :math:`P` parameters at the solution,
:math:`\\Sigma = \\sigma^2 (J^T J)^{-1}`, :math:`\\sigma^2 = \\lVert r \\rVert^2 / (2N - P)`:
the corners' noise measured by the residuals, independent and equal for all
corners. The inverse is the *full* one, over every camera's intrinsics and pose
and every frame's board pose, so each block (the intrinsics' marginal
covariance) carries the uncertainty of the board poses it was estimated with.
A fit too large for a dense inverse (many cameras and frames) keeps the cameras'
block alone, the same numbers by the Schur complement of the frames' poses
(:func:`camera_covariance`).

Projection uncertainty, and the frame it is tied to
---------------------------------------------------
The uncertainty of a calibration shows when it is used: a point fixed in space
projects to a pixel that moves as the parameters move within :math:`\\Sigma`. A
point must be fixed in *some* frame that the calibration does not move, and
which one decides the answer. Here it is **the first camera's frame**, which
the fit holds fixed (identity pose) as the rig's reference: a pixel ``q`` of
camera ``c`` is unprojected with the estimated intrinsics to a ray, the point is
put at ``distance`` along it (or at infinity: a direction), expressed in the
first camera's frame with the estimated pose, and reprojected through the
parameters of camera ``c`` as they vary: its intrinsics and its pose
:math:`(R_c, T_c)` (the first camera: its intrinsics only, since its pose is
the reference itself). Linearised, :math:`\\Sigma_q = J_q \\Sigma_c J_q^T`
(:math:`\\Sigma_c` the marginal block of those parameters, their correlations
with every board pose included through the full inverse), and the 1-sigma
uncertainty is :math:`\\sqrt{\\lambda_{\\max}(\\Sigma_q)}`, the worst direction
(mrcal's convention). For a one-camera rig this is the uncertainty of a ray
fixed in the camera frame, from the intrinsics' marginal covariance.

It is what an evaluation of independent sessions measures when it projects a
ray fixed in the true first camera's frame through each session's estimate
(:func:`ray_uncertainty`): the spread of those pixels over sessions is the
predicted :math:`\\Sigma_q`. mrcal (the "mean-frames" method; mrcal 3 prefers
"cross-reprojection") ties a camera instead to the *mean of the board poses*:
its fixed point is carried through every board frame and averaged, because its
reference frame floats and the boards are the most fixed thing it has. A
rotation of the camera then partly cancels against the principal point's
error, so its figure for a mono camera differs from the intrinsics-only one
here; both are "calibrated" for the question each asks. An uncertainty from the
intrinsics' covariance with the board poses *held* (the block of :math:`J^T J`
inverted alone) is too small: it ignores how the poses trade against the
intrinsics.
"""

from __future__ import annotations

import cv2
import numpy as np

from ..cameras import MODELS, project, undistort
from ..solvers import COND_MAX, BlockNormal

__all__ = ["camera_covariance", "covariance", "parameter_std", "projection_uncertainty", "ray_uncertainty"]

_DEGENERATE = ("the joint fit is degenerate (no more residuals than parameters, or parameters the views "
               "cannot tell apart), so the standard deviations are undefined")


def covariance(JtJ: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, float, str]:
    """:math:`\\sigma^2 (J^T J)^{-1}` with :math:`\\sigma^2 = \\lVert r \\rVert^2 / (2N - P)`.

    The inverse is taken with unit columns (the condition number of the scaled
    :math:`J^T J` must stay below 1e12, as in :func:`~sogdd.calib.solvers.jacobian_std`).

    Returns
    -------
    cov : (P, P) float64, or (0, 0) when degenerate
    sigma : float
        :math:`\\sigma` (px; NaN without degrees of freedom).
    note : str
        Why there is no covariance ("" when there is).

    Examples
    --------
    >>> J = np.array([[1.0, 0], [0, 2], [1, 1]])
    >>> cov, s, note = covariance(J.T @ J, np.array([0.1, -0.1, 0.1]))
    >>> cov.shape, round(s, 4), note
    ((2, 2), 0.1732, '')
    """
    P = JtJ.shape[0]
    dof = len(r) - P
    sigma = float(np.sqrt(r @ r / dof)) if dof > 0 else float("nan")
    d = np.sqrt(np.diag(JtJ))
    if dof <= 0 or not np.all(d > 0):
        return np.zeros((0, 0)), sigma, _DEGENERATE
    S = JtJ / np.outer(d, d)
    if not np.isfinite(S).all() or np.linalg.cond(S) > COND_MAX:
        return np.zeros((0, 0)), sigma, _DEGENERATE
    return np.linalg.inv(S) / np.outer(d, d) * sigma ** 2, sigma, ""


def camera_covariance(ne: BlockNormal, r: np.ndarray) -> tuple[np.ndarray, float, str]:
    """The cameras' block of :math:`\\sigma^2 (J^T J)^{-1}`, the frames' poses eliminated: for a fit too
    large for :func:`covariance`'s dense inverse.

    With :math:`J^T J = \\begin{pmatrix} U & W \\\\ W^T & P \\end{pmatrix}` (``U`` the cameras'
    intrinsics and poses, ``P`` block-diagonal: a 6 x 6 block per frame's pose, as
    :class:`~sogdd.calib.solvers.BlockNormal` holds them), the cameras' block of the inverse is the
    inverse of the Schur complement :math:`S = U - W P^{-1} W^T`
    (:meth:`~sogdd.calib.solvers.BlockNormal.intrinsic_inverse`): the same numbers as the block of the
    full inverse, at the cost of the frames' 6 x 6 inverses and one inverse of the cameras' size.
    :math:`\\sigma^2 = \\lVert r \\rVert^2 / (2N - P)` counts every parameter, the frames' too.
    Degenerate when :math:`S` with unit columns has a condition number beyond 1e12 (or a frame's block
    is singular).

    Returns
    -------
    cov : (n, n) float64, or (0, 0) when degenerate
        ``n`` the cameras' parameters, in the fit's order.
    sigma : float
    note : str
        Why there is no covariance ("" when there is).

    Examples
    --------
    >>> from sogdd.calib.solvers import BlockNormal
    >>> rng = np.random.default_rng(0)
    >>> J = np.zeros((40, 2 + 12))  # 2 shared parameters, then 2 frames of 6 that share no row
    >>> J[:, :2] = rng.normal(size=(40, 2))
    >>> J[:20, 2:8], J[20:, 8:] = rng.normal(size=(20, 6)), rng.normal(size=(20, 6))
    >>> N = J.T @ J
    >>> ne = BlockNormal(N[:2, :2], np.stack([N[:2, 2:8], N[:2, 8:]]), np.stack([N[2:8, 2:8], N[8:, 8:]]),
    ...              np.zeros(2), np.zeros((2, 6)))
    >>> r = rng.normal(0, 0.1, 40)
    >>> bool(np.allclose(camera_covariance(ne, r)[0], covariance(N, r)[0][:2, :2]))
    True
    """
    P = len(ne.gi) + ne.gp.size
    dof = len(r) - P
    sigma = float(np.sqrt(r @ r / dof)) if dof > 0 else float("nan")
    if dof <= 0:
        return np.zeros((0, 0)), sigma, _DEGENERATE
    try:
        C = ne.intrinsic_inverse()
    except np.linalg.LinAlgError:
        return np.zeros((0, 0)), sigma, _DEGENERATE
    if not np.isfinite(C).all():
        return np.zeros((0, 0)), sigma, _DEGENERATE
    return C * sigma ** 2, sigma, ""


def _rotation_error_jacobian(rvec: np.ndarray) -> np.ndarray:
    """:math:`\\partial e / \\partial \\omega`, with :math:`e = \\log(R(\\omega + \\delta) R(\\omega)^T)` the
    rotation's error as a vector (central differences)."""
    R0 = cv2.Rodrigues(np.asarray(rvec, np.float64))[0]

    def log_small(R):  # the rotation vector of a rotation near identity (cv2.Rodrigues rounds it to 0)
        return 0.5 * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])

    J = np.zeros((3, 3))
    h = 1e-6
    for j in range(3):
        d = np.zeros(3)
        d[j] = h
        up, down = cv2.Rodrigues(rvec + d)[0] @ R0.T, cv2.Rodrigues(rvec - d)[0] @ R0.T
        J[:, j] = (log_small(up) - log_small(down)) / (2 * h)
    return J


def parameter_std(cov: np.ndarray, intr: slice, pose: slice | None, model: str, pose_vec: np.ndarray) -> dict:
    """A camera's standard deviations from the joint covariance.

    ``fx, fy, cx, cy`` and each distortion coefficient by name; ``"T"`` (3
    floats); ``"baseline"``, of :math:`\\lVert T \\rVert`, by the gradient
    :math:`g = T / \\lVert T \\rVert`: :math:`\\sqrt{g^T \\Sigma_T g}`; and
    ``"rotation_deg"``, the RMS angle of the rotation's error,
    :math:`\\sqrt{\\operatorname{tr}(J_e \\Sigma_\\omega J_e^T)}` in degrees
    (:math:`J_e` maps the rotation vector's error to the rotation's). The first
    camera (``pose`` None): 0 for the pose terms. NaN everywhere when ``cov`` is empty.
    """
    names = ("fx", "fy", "cx", "cy") + MODELS[model]
    if cov.size == 0:
        return {**dict.fromkeys(names, float("nan")), "T": [float("nan")] * 3, "baseline": float("nan"),
                "rotation_deg": float("nan")}
    out = {n: float(np.sqrt(max(v, 0.0))) for n, v in zip(names, np.diag(cov[intr, intr]))}
    if pose is None:
        return {**out, "T": [0.0, 0.0, 0.0], "baseline": 0.0, "rotation_deg": 0.0}
    C = cov[pose, pose]
    T = np.asarray(pose_vec[3:6], float)
    g = T / max(np.linalg.norm(T), 1e-300)
    Je = _rotation_error_jacobian(np.asarray(pose_vec[:3], float))
    return {**out, "T": [float(np.sqrt(max(v, 0.0))) for v in np.diag(C[3:, 3:])],
            "baseline": float(np.sqrt(max(g @ C[3:, 3:] @ g, 0.0))),
            "rotation_deg": float(np.degrees(np.sqrt(max(np.trace(Je @ C[:3, :3] @ Je.T), 0.0))))}


def _camera_block(rig, name: str):
    """Camera ``name``'s parameter vector (intrinsics, then rvec, tvec unless the first) and its
    marginal covariance (None when the rig has none)."""
    cam = rig.camera(name)
    K = cam.K
    theta = np.r_[K[0, 0], K[1, 1], K[0, 2], K[1, 2], cam.dist]
    idx = list(range(rig.layout[f"{name}.intrinsics"].start, rig.layout[f"{name}.intrinsics"].stop))
    pose = rig.layout.get(f"{name}.pose")
    if pose is not None:
        theta = np.r_[theta, cv2.Rodrigues(np.asarray(cam.R, np.float64))[0].ravel(), cam.T]
        idx += list(range(pose.start, pose.stop))
    cov = rig.covariance
    return cam, theta, (cov[np.ix_(idx, idx)] if cov.size else None), pose is not None


def _reproject(theta: np.ndarray, p0: np.ndarray, finite: bool, model: str, has_pose: bool) -> np.ndarray:
    nd = len(MODELS[model])
    K = np.array([[theta[0], 0.0, theta[2]], [0.0, theta[1], theta[3]], [0.0, 0.0, 1.0]])
    rv = theta[4 + nd:7 + nd] if has_pose else None
    tv = theta[7 + nd:10 + nd] if has_pose and finite else None
    return project(p0, K, theta[4:4 + nd], model, rv, tv)  # type: ignore[arg-type]


def _propagate(rig, name: str, p0: np.ndarray, finite: bool):
    """Pixels (M, 2) of points ``p0`` (first camera's frame; directions when not ``finite``) in camera
    ``name`` and their covariance (M, 2, 2) from the camera's parameters' (NaN without one)."""
    cam, theta, C, has_pose = _camera_block(rig, name)
    q = _reproject(theta, p0, finite, cam.model, has_pose)
    if C is None:
        return q, np.full((len(q), 2, 2), np.nan)
    J = np.zeros((len(q), 2, len(theta)))
    for j in range(len(theta)):
        h = 1e-6 * max(abs(theta[j]), 1.0)
        up, dn = theta.copy(), theta.copy()
        up[j] += h
        dn[j] -= h
        J[:, :, j] = (_reproject(up, p0, finite, cam.model, has_pose)
                      - _reproject(dn, p0, finite, cam.model, has_pose)) / (2 * h)
    return q, np.einsum("mip,pq,mjq->mij", J, C, J)


def _worst(S: np.ndarray) -> np.ndarray:
    """:math:`\\sqrt{\\lambda_{\\max}}` of 2 x 2 covariances (M, 2, 2)."""
    a, b, c = S[:, 0, 0], S[:, 0, 1], S[:, 1, 1]
    return np.sqrt((a + c) / 2 + np.sqrt(((a - c) / 2) ** 2 + b ** 2))


def projection_uncertainty(rig, name: str, pixels: np.ndarray | None = None, *, distance: float = np.inf,
                           grid: tuple[int, int] = (32, 24)) -> tuple[np.ndarray, np.ndarray]:
    """The 1-sigma projection uncertainty (px) over camera ``name``'s image, for points at ``distance``.

    Each pixel is unprojected by the camera's estimated intrinsics, the point put
    at ``distance`` along the unit ray (the square's unit; ``inf``: a direction),
    carried into the first camera's frame, and reprojected under the covariance
    of the camera's intrinsics and pose (module docstring); the result is
    :math:`\\sqrt{\\lambda_{\\max}}` of the 2 x 2 covariance of the pixel.

    Parameters
    ----------
    rig : RigCalibration
    name : str
    pixels : (M, 2), optional
        Default: a ``grid`` of ``(columns, rows)`` pixels spanning the image.
    distance : float
    grid : (int, int)

    Returns
    -------
    pixels : (M, 2) float64
    sigma : (M,) float64
        NaN where a pixel has no ray or the rig has no covariance.

    Examples
    --------
    >>> from sogdd.calib.rig import calibrate_rig
    >>> from sogdd.calib.rig.demo import synthetic_rig
    >>> d = synthetic_rig(cameras=2, frames=8, seed=0)
    >>> px, s = projection_uncertainty(calibrate_rig(d.boards, d.image_sizes), "cam1", grid=(4, 3))
    >>> px.shape, bool(np.all((s > 0) & (s < 5)))
    ((12, 2), True)
    """
    cam = rig.camera(name)
    if pixels is None:
        w, h = cam.image_size
        gx, gy = np.meshgrid(np.linspace(0, w - 1, grid[0]), np.linspace(0, h - 1, grid[1]))
        pixels = np.c_[gx.ravel(), gy.ravel()]
    px = np.asarray(pixels, np.float64).reshape(-1, 2)
    xy, ok = undistort(px, cam.K, cam.dist, cam.model)
    v = np.c_[xy, np.ones(len(xy))]
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    finite = bool(np.isfinite(distance))
    if finite:
        p0 = (v * distance - cam.T) @ cam.R  # R^T (p_c - T), row-wise
    else:
        p0 = v @ cam.R
    sigma = np.full(len(px), np.nan)
    if ok.any():
        _, S = _propagate(rig, name, p0[ok], finite)
        sigma[ok] = _worst(S)
    return px, sigma


def ray_uncertainty(rig, name: str, ray: np.ndarray, *, distance: float = np.inf):
    """The projection of one ray fixed in the first camera's frame, and its predicted spread.

    The point :math:`d\\,\\hat v` (``ray`` normalised; at infinity by default) in the
    first camera's frame projects through camera ``name`` to ``pixel``, whose
    covariance over the calibration's uncertainty is ``cov``. An evaluation
    over independent sessions projects the same true ray through each session's
    rig: the spread of those pixels should match ``cov`` (per axis, or
    ``sigma``, the worst direction's).

    Returns
    -------
    pixel : (2,), cov : (2, 2), sigma : float

    Examples
    --------
    >>> from sogdd.calib.rig import calibrate_rig
    >>> from sogdd.calib.rig.demo import synthetic_rig
    >>> d = synthetic_rig(cameras=2, frames=8, seed=0)
    >>> q, cov, s = ray_uncertainty(calibrate_rig(d.boards, d.image_sizes), "cam0", np.array([0.1, 0, 1]))
    >>> q.shape, cov.shape, bool(0 < s < 2)
    ((2,), (2, 2), True)
    """
    v = np.asarray(ray, np.float64).reshape(3)
    v = v / np.linalg.norm(v)
    finite = bool(np.isfinite(distance))
    q, S = _propagate(rig, name, (v * distance if finite else v)[None], finite)
    return q[0], S[0], float(_worst(S)[0])
