"""How far a camera's calibration can be trusted: its parameters' covariance and the projection uncertainty.

One camera's fit (:func:`~sogdd.calib.calibrate`) and a rig's joint fit
(:func:`~sogdd.calib.rig.calibrate_rig`) both measure it here, with the same
functions: the rig adds only which camera's parameters and frame a point is tied
to (:mod:`sogdd.calib.rig.uncertainty`).

The covariance
--------------
With :math:`J` the Jacobian of the fit's :math:`2N` (whitened) residuals
:math:`r` with respect to its :math:`P` parameters at the solution,
:math:`\\Sigma = \\sigma^2 (J^T J)^{-1}`, :math:`\\sigma^2 = \\lVert r \\rVert^2 / (2N - P)`:
the corners' noise measured by the residuals, independent and equal for all
corners (after their weights). The inverse is over *every* parameter, each
view's or frame's board pose too, so the intrinsics' block (their marginal
covariance) carries how the poses trade against them; the block of
:math:`J^T J` inverted alone (the poses held) would be too small. The poses'
blocks are eliminated by their Schur complement (:func:`camera_covariance`):
the same numbers as the block of the full inverse (:func:`covariance`).

Projection uncertainty
----------------------
The uncertainty of a calibration shows when it is used: a point fixed in space
projects to a pixel that moves as the parameters move within :math:`\\Sigma`.
A pixel ``q`` is unprojected with the estimated intrinsics to a ray, the point
put at ``distance`` along it (or at infinity: a direction), expressed in the
frame it is fixed in (for one camera: its own; in a rig: the first camera's,
through the camera's estimated pose :math:`(R, T)`), and reprojected through
the camera's parameters :math:`\\theta` (``fx, fy, cx, cy``, the distortion and,
where it varies, the pose's rotation vector and translation) as they vary.
Linearised, :math:`\\Sigma_q = J_q \\Sigma_\\theta J_q^T`, and the 1-sigma
uncertainty is :math:`\\sqrt{\\lambda_{\\max}(\\Sigma_q)}`, the worst direction
(mrcal's convention). For one camera this is the uncertainty of a ray fixed in
the camera's frame, from the intrinsics' marginal covariance; an evaluation of
independent sessions measures it by projecting the same true ray through each
session's estimate.
"""

from __future__ import annotations

import cv2
import numpy as np

from .cameras import MODELS, lens, project, undistort
from .solvers import COND_MAX, BlockNormal

__all__ = ["UNCERTAIN_PX", "camera_covariance", "centre_and_worst", "covariance", "fit_covariance",
           "image_uncertainty", "pixel_covariance", "uncertainty_finding", "worst_direction"]

#: a far point's projection known worse than this (1 sigma, px) somewhere in the frame: boards did not reach
#: there (a "warn" in the one-camera and the rig's verdicts)
UNCERTAIN_PX = 1.0

_DEGENERATE = ("the fit is degenerate (no more residuals than parameters, or parameters the views "
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
    """The shared parameters' block of :math:`\\sigma^2 (J^T J)^{-1}`, the poses eliminated: for a fit
    too large for :func:`covariance`'s dense inverse, and one camera's fit.

    With :math:`J^T J = \\begin{pmatrix} U & W \\\\ W^T & P \\end{pmatrix}` (``U`` the shared
    parameters: one camera's intrinsics, or a rig's cameras' intrinsics and poses; ``P``
    block-diagonal: a 6 x 6 block per view's or frame's board pose, as
    :class:`~sogdd.calib.solvers.BlockNormal` holds them), their block of the inverse is the inverse
    of the Schur complement :math:`S = U - W P^{-1} W^T`
    (:meth:`~sogdd.calib.solvers.BlockNormal.intrinsic_inverse`): the same numbers as the block of the
    full inverse, at the cost of the poses' 6 x 6 inverses and one inverse of the shared size.
    :math:`\\sigma^2 = \\lVert r \\rVert^2 / (2N - P)` counts every parameter, the poses' too.
    Degenerate when :math:`S` with unit columns has a condition number beyond 1e12 (or a pose's block
    is singular).

    Returns
    -------
    cov : (n, n) float64, or (0, 0) when degenerate
        ``n`` the shared parameters, in the fit's order.
    sigma : float
    note : str
        Why there is no covariance ("" when there is).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> J = np.zeros((40, 2 + 12))  # 2 shared parameters, then 2 poses of 6 that share no row
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


def fit_covariance(obj: list[np.ndarray], img: list[np.ndarray], K: np.ndarray, dist: np.ndarray,
                   rvecs: np.ndarray, tvecs: np.ndarray, model: str, free: np.ndarray | None = None,
                   weights: list[np.ndarray] | None = None) -> tuple[np.ndarray, str]:
    """One camera's intrinsics' marginal covariance at a solution, and why there is none ("" when there is).

    :math:`J` is the Jacobian of the whitened residuals :math:`w (x - \\pi)` (``weights``
    per view, one per corner; 1 without) with respect to the ``free`` intrinsics
    (``fx, fy, cx, cy`` then the distortion, skew held at 0) and every view's pose,
    OpenCV's analytic derivatives (``cv2.projectPoints``, ``cv2.fisheye.projectPoints``:
    the rig's joint fit takes the same); the intrinsics' block of
    :math:`\\sigma^2 (J^T J)^{-1}` is :func:`camera_covariance`'s. Its diagonal is the
    square of the fit's standard deviations (``Calibration.std``). A parameter not
    ``free`` has zero rows and columns. None for a model without OpenCV's analytic
    Jacobian (omnidir), or a degenerate fit.

    Returns
    -------
    cov : (4 + nd, 4 + nd) float64, or (0, 0)
    note : str

    Examples
    --------
    >>> K = np.array([[600.0, 0, 320], [0, 600, 240], [0, 0, 1]])
    >>> obj = np.array([(i, j, 0.0) for j in range(6) for i in range(9)])
    >>> rv = np.array([[0.3 * np.sin(a), 0.3 * np.cos(a), 0.1] for a in range(6)])
    >>> tv = np.tile([-4.0, -2.5, 12.0], (6, 1))
    >>> rng = np.random.default_rng(0)
    >>> img = [project(obj, K, np.zeros(5), "pinhole", r, t) + rng.normal(0, 0.1, (54, 2))
    ...        for r, t in zip(rv, tv)]
    >>> cov, note = fit_covariance([obj] * 6, img, K, np.zeros(5), rv, tv, "pinhole")
    >>> cov.shape, note, bool(0 < np.sqrt(cov[0, 0]) < 5)
    ((9, 9), '', True)
    """
    n = 4 + len(MODELS[model])
    start = lens(model).start
    if start not in ("calibrateCamera", "fisheye.calibrate"):
        return np.zeros((0, 0)), f"the {model} model has no analytic Jacobian"
    free = np.ones(n, bool) if free is None else np.asarray(free, bool)
    D = np.asarray(dist, np.float64).ravel()
    z = int(free.sum())
    U, W, P, r = np.zeros((z, z)), [], [], []
    for v in range(len(obj)):
        X = np.asarray(obj[v], np.float64).reshape(-1, 1, 3)
        rv, tv = np.asarray(rvecs[v], np.float64), np.asarray(tvecs[v], np.float64)
        if start == "fisheye.calibrate":  # columns: fx, fy, cx, cy, k1..k4, rvec, tvec, skew
            q, J = cv2.fisheye.projectPoints(X, rv, tv, K, D)
            Jp, Ji = J[:, 8:14], J[:, :8]
        else:  # columns: rvec, tvec, fx, fy, cx, cy, distortion
            q, J = cv2.projectPoints(X, rv, tv, K, D)
            Jp, Ji = J[:, :6], J[:, 6:6 + n]
        w = np.ones(2 * len(X)) if weights is None else np.repeat(np.asarray(weights[v], np.float64), 2)
        Ji, Jp = Ji[:, free] * w[:, None], Jp * w[:, None]
        r.append((np.asarray(img[v], np.float64).reshape(-1, 2) - q.reshape(-1, 2)).ravel() * w)
        U += Ji.T @ Ji
        W.append(Ji.T @ Jp)
        P.append(Jp.T @ Jp)
    ne = BlockNormal(U, np.array(W).reshape(-1, z, 6), np.array(P).reshape(-1, 6, 6), np.zeros(z),
                     np.zeros((len(obj), 6)))
    C, _, note = camera_covariance(ne, np.concatenate(r))
    if note:
        return np.zeros((0, 0)), note
    cov = np.zeros((n, n))
    cov[np.ix_(free, free)] = C
    return cov, ""


def _reproject(theta: np.ndarray, p0: np.ndarray, finite: bool, model: str) -> np.ndarray:
    """Points ``p0`` (the reference frame) through the parameters ``theta`` (intrinsics, rvec, tvec)."""
    nd = len(MODELS[model])
    K = np.array([[theta[0], 0.0, theta[2]], [0.0, theta[1], theta[3]], [0.0, 0.0, 1.0]])
    tv = theta[7 + nd:10 + nd] if finite else None  # a direction does not move with the translation
    return project(p0, K, theta[4:4 + nd], model, theta[4 + nd:7 + nd], tv)  # type: ignore[arg-type]


def pixel_covariance(points: np.ndarray, K: np.ndarray, dist: np.ndarray, model: str, cov: np.ndarray,
                     *, R: np.ndarray | None = None, T: np.ndarray | None = None,
                     finite: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Points fixed in a reference frame, their pixels in a camera and those pixels' covariance.

    The camera sees a point :math:`p` of the reference frame at :math:`R p + T`
    (``R`` identity and ``T`` zero by default: the camera's own frame); with
    ``finite`` False the points are directions (at infinity), which ``T`` does
    not move. ``cov`` is the covariance of :math:`\\theta = (f_x, f_y, c_x, c_y,`
    the distortion) or, 6 larger, of those and the pose (the rotation vector of
    ``R``, then ``T``): :math:`\\Sigma_q = J_q \\Sigma_\\theta J_q^T`, :math:`J_q`
    by central differences. NaN without a covariance (``cov`` empty).

    Returns
    -------
    pixels : (M, 2) float64
    S : (M, 2, 2) float64

    Examples
    --------
    >>> K = np.array([[600.0, 0, 320], [0, 600, 240], [0, 0, 1]])
    >>> cov = np.diag([4.0, 4.0, 1.0, 1.0, 0, 0, 0, 0, 0])  # fx, fy: 2 px; cx, cy: 1 px
    >>> q, S = pixel_covariance(np.array([[0.0, 0, 1], [0.5, 0, 1]]), K, np.zeros(5), "pinhole", cov)
    >>> q.round(1).tolist(), np.sqrt(S[:, 0, 0]).round(3).tolist()  # x: sqrt(1 + (0.5 * 2)^2) off-axis
    ([[320.0, 240.0], [620.0, 240.0]], [1.0, 1.414])
    """
    p0 = np.asarray(points, np.float64).reshape(-1, 3)
    rv = np.zeros(3) if R is None else cv2.Rodrigues(np.asarray(R, np.float64))[0].ravel()
    tv = np.zeros(3) if T is None else np.asarray(T, np.float64).ravel()
    theta = np.r_[K[0, 0], K[1, 1], K[0, 2], K[1, 2], np.asarray(dist, np.float64).ravel(), rv, tv]
    q = _reproject(theta, p0, finite, model)
    cov = np.asarray(cov, np.float64)
    if cov.size == 0:
        return q, np.full((len(q), 2, 2), np.nan)
    J = np.zeros((len(q), 2, len(cov)))
    for j in range(len(cov)):  # the parameters that vary: the intrinsics, and the pose when cov holds it
        h = 1e-6 * max(abs(theta[j]), 1.0)
        up, dn = theta.copy(), theta.copy()
        up[j] += h
        dn[j] -= h
        J[:, :, j] = (_reproject(up, p0, finite, model) - _reproject(dn, p0, finite, model)) / (2 * h)
    return q, np.einsum("mip,pq,mjq->mij", J, cov, J)


def worst_direction(S: np.ndarray) -> np.ndarray:
    """:math:`\\sqrt{\\lambda_{\\max}}` of 2 x 2 covariances (M, 2, 2): the 1-sigma uncertainty in the
    worst direction.

    Examples
    --------
    >>> worst_direction(np.array([[[4.0, 0], [0, 1]], [[1, 0], [0, 9]]])).tolist()
    [2.0, 3.0]
    """
    a, b, c = S[:, 0, 0], S[:, 0, 1], S[:, 1, 1]
    return np.sqrt((a + c) / 2 + np.sqrt(((a - c) / 2) ** 2 + b ** 2))


def image_uncertainty(K: np.ndarray, dist: np.ndarray, model: str, image_size: tuple[int, int],
                      cov: np.ndarray, pixels: np.ndarray | None = None, *, R: np.ndarray | None = None,
                      T: np.ndarray | None = None, distance: float = np.inf,
                      grid: tuple[int, int] = (32, 24)) -> tuple[np.ndarray, np.ndarray]:
    """The 1-sigma projection uncertainty (px) over a camera's image, for points at ``distance``.

    Each pixel is unprojected by the estimated intrinsics, the point put at
    ``distance`` along the unit ray (the square's unit; ``inf``: a direction),
    carried into the reference frame (:math:`R^T (p - T)`; the camera's own
    frame by default), and reprojected under ``cov`` (:func:`pixel_covariance`);
    the result is :func:`worst_direction` of the pixel's 2 x 2 covariance.

    Parameters
    ----------
    K, dist, model
        The camera.
    image_size : (width, height)
    cov : (n, n)
        :func:`pixel_covariance`'s; empty: NaN everywhere.
    pixels : (M, 2), optional
        Default: a ``grid`` of ``(columns, rows)`` pixels spanning the image.
    R, T, distance, grid

    Returns
    -------
    pixels : (M, 2) float64
    sigma : (M,) float64
        NaN where a pixel has no ray or there is no covariance.

    Examples
    --------
    >>> from sogdd.calib.demo import demo_calibration
    >>> cal = demo_calibration()
    >>> px, s = image_uncertainty(cal.K, cal.dist, cal.model, cal.image_size, cal.covariance, grid=(4, 3))
    >>> px.shape, bool(np.all((s > 0) & (s < 5)))
    ((12, 2), True)
    """
    if pixels is None:
        w, h = image_size
        gx, gy = np.meshgrid(np.linspace(0, w - 1, grid[0]), np.linspace(0, h - 1, grid[1]))
        pixels = np.c_[gx.ravel(), gy.ravel()]
    px = np.asarray(pixels, np.float64).reshape(-1, 2)
    R0 = np.eye(3) if R is None else np.asarray(R, np.float64)
    T0 = np.zeros(3) if T is None else np.asarray(T, np.float64).ravel()
    xy, ok = undistort(px, K, dist, model)  # type: ignore[arg-type]
    v = np.c_[xy, np.ones(len(xy))]
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    finite = bool(np.isfinite(distance))
    p0 = (v * distance - T0) @ R0 if finite else v @ R0  # R^T (p - T), row-wise
    sigma = np.full(len(px), np.nan)
    if ok.any():
        _, S = pixel_covariance(p0[ok], K, dist, model, cov, R=R, T=T, finite=finite)
        sigma[ok] = worst_direction(S)
    return px, sigma


def centre_and_worst(pixels: np.ndarray, sigma: np.ndarray, image_size: tuple[int, int]) -> tuple[float, float]:
    """The uncertainty at the pixel nearest the image's centre and its worst over ``pixels`` (NaN, NaN
    without a finite one).

    Examples
    --------
    >>> px = np.array([[0.0, 0], [319.5, 239.5], [639, 479]])
    >>> centre_and_worst(px, np.array([0.4, 0.1, np.nan]), (640, 480))
    (0.1, 0.4)
    """
    sigma = np.asarray(sigma, float)
    if sigma.size == 0 or not np.isfinite(sigma).any():
        return float("nan"), float("nan")
    w, h = image_size
    centre = int(np.argmin(np.hypot(pixels[:, 0] - (w - 1) / 2, pixels[:, 1] - (h - 1) / 2)))
    return float(sigma[centre]), float(np.nanmax(sigma))


def uncertainty_finding(centre: float, worst: float) -> tuple[str, str]:
    """The verdicts' line on a far point's projection uncertainty (:func:`centre_and_worst`): "warn"
    beyond :data:`UNCERTAIN_PX` somewhere, else "ok". Beyond it at the edges alone, boards did not
    reach them; beyond it at the centre too, the views as a whole pin the camera down too loosely.

    Examples
    --------
    >>> uncertainty_finding(0.12, 0.5)
    ('ok', 'a far point projects to within 0.12 px (1 sigma) at the centre and 0.5 px at worst over the frame')
    >>> uncertainty_finding(0.2, 3.0)[1].split("; ")[1]
    "boards did not reach the frame's edges"
    >>> uncertainty_finding(2.5, 3.0)[1].split("; ")[1]
    'the views leave the whole camera loose: more views, sharper ones, or more tilted ones'
    """
    level = "warn" if worst > UNCERTAIN_PX else "ok"
    why = ("" if level == "ok" else "; boards did not reach the frame's edges" if centre <= UNCERTAIN_PX
           else "; the views leave the whole camera loose: more views, sharper ones, or more tilted ones")
    return level, (f"a far point projects to within {centre:.2g} px (1 sigma) at the centre and "
                   f"{worst:.2g} px at worst over the frame{why}")
