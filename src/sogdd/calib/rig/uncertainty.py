"""How far a rig calibration can be trusted: each camera's parameters' standard deviations and the
projection uncertainty, tied to the first camera.

The covariance is the joint fit's, :math:`\\Sigma = \\sigma^2 (J^T J)^{-1}` over every
camera's intrinsics and pose and every frame's board pose
(:func:`sogdd.calib.uncertainty.covariance`; a fit too large for a dense inverse
keeps the cameras' block alone, :func:`sogdd.calib.uncertainty.camera_covariance`),
so each block (the intrinsics' marginal covariance) carries the uncertainty of
the board poses it was estimated with. The projection uncertainty is one
camera's (:func:`sogdd.calib.uncertainty.image_uncertainty`), with the frame a
point is fixed in chosen here.

Projection uncertainty, and the frame it is tied to
---------------------------------------------------
A point must be fixed in *some* frame that the calibration does not move, and
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
fixed in the camera frame, from the intrinsics' marginal covariance: one
camera's calibration (:meth:`sogdd.calib.Calibration.projection_uncertainty`)
gives the same.

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

from ..cameras import MODELS
from ..uncertainty import image_uncertainty, pixel_covariance, worst_direction

__all__ = ["parameter_std", "projection_uncertainty", "ray_uncertainty"]


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
    """Camera ``name`` and the marginal covariance of its parameters (intrinsics, then rvec, tvec unless
    the first: :func:`~sogdd.calib.uncertainty.pixel_covariance`'s order); empty when the rig has none."""
    cam = rig.camera(name)
    idx = list(range(rig.layout[f"{name}.intrinsics"].start, rig.layout[f"{name}.intrinsics"].stop))
    pose = rig.layout.get(f"{name}.pose")
    if pose is not None:
        idx += list(range(pose.start, pose.stop))
    cov = rig.covariance
    return cam, (cov[np.ix_(idx, idx)] if cov.size else np.zeros((0, 0)))


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
    cam, cov = _camera_block(rig, name)
    return image_uncertainty(cam.K, cam.dist, cam.model, cam.image_size, cov, pixels, R=cam.R, T=cam.T,
                             distance=distance, grid=grid)


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
    cam, cov = _camera_block(rig, name)
    q, S = pixel_covariance((v * distance if finite else v)[None], cam.K, cam.dist, cam.model, cov, R=cam.R,
                            T=cam.T, finite=finite)
    return q[0], S[0], float(worst_direction(S)[0])
