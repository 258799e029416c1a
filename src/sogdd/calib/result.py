"""The result of a calibration: the camera and its diagnostics, view by view and corner by corner."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .cameras import MODELS, CameraModel
from .cross_validation import CrossValidation
from .model_selection import ModelSelection
from .uncertainty import centre_and_worst, image_uncertainty
from .weighting import corner_weights

__all__ = ["Calibration"]


@dataclass(frozen=True)
class Calibration:
    """A calibrated camera with its diagnostics (the result of :func:`calibrate`).

    Attributes
    ----------
    model : str
        "pinhole4", "pinhole", "rational" or "fisheye".
    image_size : (width, height)
    K : (3, 3) float64
        Camera matrix ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]``.
    dist : 1-D float64
        Distortion coefficients, named by ``MODELS[model]``.
    rms : float
        RMS reprojection error over the used corners (px):
        :math:`\\sqrt{\\sum \\lVert r \\rVert^2 / n}`.
    std : dict of str to float
        Standard deviations of the intrinsics (``fx, fy, cx, cy`` and the
        distortion coefficients): the square roots of the diagonal of
        :math:`\\sigma^2 (J^T J)^{-1}`, :math:`J` the Jacobian of the
        reprojection residuals at the solution and :math:`\\sigma^2` their
        sum of squares over the degrees of freedom. OpenCV's for the pinhole
        and rational models; for the fisheye model, for which OpenCV gives
        none, :func:`~sogdd.calib.solvers.jacobian_std`'s. 0 for a parameter
        the flags fix; NaN when there are none, ``std_note`` saying why.
    names : tuple of str
        A name per view.
    boards : tuple of Board or None
        The input boards (None where a view had none).
    residuals : tuple of (N_v, 2) float64 or None
        Per corner, observed minus projected position (px); for a rejected view
        from its pose re-estimated with the final intrinsics (``solvePnP``);
        None for a view without a board or a pose.
    corner_used : tuple of (N_v,) bool or None
        Whether the final calibration used each corner.
    view_used : (V,) bool
    view_rms : (V,) float64
        RMS of each view's used corners (of all its corners for a rejected
        view; NaN without a pose).
    reasons : tuple of str
        Why each view was rejected ("" for a used view).
    corner_reasons : tuple of dict
        Per view, ``{corner index: why it was rejected}``.
    rvecs, tvecs : (V, 3) float64
        Board poses (NaN without one).
    cross_validation : CrossValidation or None
        None with fewer than ``2 * min_views`` used views (see ``notes``).
    thresholds : dict of str to float
        The rejection thresholds of the last iteration (px).
    notes : tuple of str
        What the calibration could not do (e.g. why there is no cross-validation).
    square : float
        Board square size (units of ``tvecs``).
    std_note : str
        Why ``std`` is NaN ("" when it is not): one view, which cannot determine
        the intrinsics, or a degenerate fit (also in ``notes``).
    model_selection : ModelSelection or None
        How ``model`` was chosen, with ``model="auto"`` (None when it was given).
    typical_precision : float
        The set's typical corner precision (px): the median over the usable
        views of each view's median corner precision (``Board.precision``),
        which the fit's corner weights are relative to
        (:mod:`~sogdd.calib.weighting`); NaN when the boards carry none (the
        fit is then unweighted).
    pixel_grid : str
        The pixel grid ``K`` is on: ``"image"``, the images as read (their one
        EXIF orientation applied, as ``cv2.imread`` does), or ``"sensor"``, their
        stored pixel order, when the images' orientations differed
        (:func:`~sogdd.calib.detection.on_sensor_grid`; a note says so).
    covariance : (4 + nd, 4 + nd) float64
        The intrinsics' marginal covariance (``fx, fy, cx, cy`` then the
        distortion, as ``std``): their block of :math:`\\sigma^2 (J^T J)^{-1}`
        over the intrinsics and every used view's pose, the poses eliminated by
        their Schur complement so that it carries how they trade against the
        intrinsics (:func:`~sogdd.calib.uncertainty.fit_covariance`, the rig's
        maths); its diagonal is ``std`` squared, zero rows for a parameter the
        flags fix. Empty (0, 0) where there are no standard deviations, for a
        model without OpenCV's analytic Jacobian (omnidir), with extra OpenCV
        flags, or for a camera of a rig, whose covariance is the rig's (``notes``
        says why for a fit). :meth:`projection_uncertainty` comes from it.
    """

    model: CameraModel
    image_size: tuple[int, int]
    K: np.ndarray
    dist: np.ndarray
    rms: float
    std: dict
    names: tuple[str, ...]
    boards: tuple
    residuals: tuple
    corner_used: tuple
    view_used: np.ndarray
    view_rms: np.ndarray
    reasons: tuple[str, ...]
    corner_reasons: tuple
    rvecs: np.ndarray
    tvecs: np.ndarray
    cross_validation: CrossValidation | None
    thresholds: dict = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    square: float = 1.0
    std_note: str = ""
    model_selection: ModelSelection | None = None
    typical_precision: float = float("nan")
    pixel_grid: str = "image"
    covariance: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    @property
    def n_used(self) -> int:
        """Number of views the calibration used."""
        return int(np.sum(self.view_used))

    @property
    def n_corners_used(self) -> int:
        """Number of corners the calibration used."""
        return int(sum(int(u.sum()) for u in self.corner_used if u is not None))

    def corner_weights(self, view: int) -> np.ndarray | None:
        """The fit's weight of each corner of ``view`` (:func:`~sogdd.calib.weighting.corner_weights`);
        None without a board, or when the fit was unweighted."""
        b = self.boards[view]
        if b is None or not np.isfinite(self.typical_precision):
            return None
        return corner_weights(b, self.typical_precision)

    def coefficients(self) -> dict:
        """The distortion coefficients by name."""
        return dict(zip(MODELS[self.model], (float(v) for v in self.dist)))

    def projection_uncertainty(self, grid: tuple[int, int] = (16, 12)) -> tuple[float, float]:
        """The 1-sigma projection uncertainty of a far point (px): at the image's centre, and its worst.

        Each pixel of a ``grid`` (columns, rows) spanning the image is unprojected to
        a ray fixed in the camera's frame and reprojected as the intrinsics vary
        within ``covariance``, :math:`\\Sigma_q = J_q \\Sigma J_q^T`; its uncertainty is
        :math:`\\sqrt{\\lambda_{\\max}(\\Sigma_q)}`
        (:func:`~sogdd.calib.uncertainty.image_uncertainty`, as for each camera of a
        rig). NaN without a covariance.

        Examples
        --------
        >>> from sogdd.calib.demo import demo_calibration
        >>> centre, worst = demo_calibration().projection_uncertainty()
        >>> bool(0 < centre <= worst < 5)
        True
        """
        if self.covariance.size == 0:
            return float("nan"), float("nan")
        pixels, sigma = image_uncertainty(self.K, self.dist, self.model, self.image_size, self.covariance,
                                          grid=grid)
        return centre_and_worst(pixels, sigma, self.image_size)
