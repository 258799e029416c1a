"""The result of a rig calibration: every camera, its pose in the first camera's frame, their uncertainties."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ..result import Calibration
from .connectivity import Connectivity

__all__ = ["RigCalibration", "RigCamera", "cameras_text"]


def cameras_text(n: int) -> str:
    """A number of cameras in words, as the pages and titles say it.

    Examples
    --------
    >>> cameras_text(1), cameras_text(3)
    ('1 camera', '3 cameras')
    """
    return f"{n} camera{'s' * (n != 1)}"


@dataclass(frozen=True)
class RigCamera:
    """One camera of a rig (in :class:`RigCalibration`).

    Attributes
    ----------
    name : str
        The camera's name (``--camera NAME``).
    calibration : Calibration
        This camera alone, as a one-camera calibration: its ``K``, ``dist``,
        ``model`` and ``image_size`` from the joint fit; one view per frame of
        the rig (named by this camera's image file of that frame; ``None`` board
        where it saw none); the joint fit's residuals, ``corner_used``,
        ``view_used`` and reasons; ``rvecs``/``tvecs`` the board's pose in *this*
        camera's frame; ``std`` the intrinsics' standard deviations from the
        joint covariance. ``NAME/camera.yaml``, ``views.csv`` and ``corners.csv``
        are written from it.
    R : (3, 3) float64
    T : (3,) float64
        The camera's pose: :math:`x_{cam} = R\\,x_{first} + T` (the first camera:
        identity and zero), ``T`` in the unit of the board's square. NaN for a
        camera that no shared frame ties to the first (``RigCalibration.notes``).
    std : dict
        Standard deviations from the joint covariance: ``fx, fy, cx, cy`` and each
        distortion coefficient by name (px or unitless), ``"T"`` (3 floats, the
        square's unit), ``"baseline"`` (of :math:`\\lVert T \\rVert`) and
        ``"rotation_deg"`` (the RMS angle of the rotation's error,
        :math:`\\sqrt{\\operatorname{tr} \\Sigma_\\omega}` in degrees, :math:`\\omega`
        the rotation vector's error); 0 for the first camera's pose. NaN where the
        fit cannot give them (``RigCalibration.notes`` says why).
    """

    name: str
    calibration: Calibration
    R: np.ndarray
    T: np.ndarray
    std: dict

    @property
    def K(self) -> np.ndarray:
        """The camera matrix."""
        return self.calibration.K

    @property
    def dist(self) -> np.ndarray:
        """The distortion coefficients, named by ``MODELS[model]``."""
        return self.calibration.dist

    @property
    def model(self) -> str:
        """The camera model."""
        return self.calibration.model

    @property
    def image_size(self) -> tuple[int, int]:
        """``(width, height)``."""
        return self.calibration.image_size

    @property
    def baseline(self) -> float:
        """:math:`\\lVert T \\rVert`, the distance to the first camera (the square's unit)."""
        return float(np.linalg.norm(self.T))

    @property
    def rotation_deg(self) -> float:
        """The angle of ``R``, the rotation from the first camera's frame, in degrees (NaN without a pose).

        :math:`\\theta = \\operatorname{atan2}\\big(\\tfrac12 \\lVert (R_{32} - R_{23}, R_{13} - R_{31},
        R_{21} - R_{12}) \\rVert,\\ \\tfrac12 (\\operatorname{tr} R - 1)\\big)`: the norm of the rotation
        vector, :math:`\\sin\\theta` and :math:`\\cos\\theta` of the same matrix, so that a small angle
        keeps its digits (``arccos`` of the trace alone loses them near 0).

        Examples
        --------
        >>> import cv2
        >>> from sogdd.calib.rig.demo import demo_rig
        >>> right = demo_rig().camera("right")
        >>> bool(np.isclose(right.rotation_deg, np.degrees(np.linalg.norm(cv2.Rodrigues(right.R)[0]))))
        True
        """
        R = np.asarray(self.R, np.float64)
        sin = 0.5 * np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
        return float(np.degrees(np.arctan2(sin, 0.5 * (np.trace(R) - 1.0))))


@dataclass(frozen=True)
class RigCalibration:
    """A calibrated rig (the result of :func:`~sogdd.calib.rig.calibrate_rig`).

    Attributes
    ----------
    cameras : tuple of RigCamera
        The first one is the rig's reference: every pose is in its frame.
    frames : tuple of str
        A name per frame (the number the cameras' file names share, or the rank).
    rvecs, tvecs : (F, 3) float64
        The board's pose in each frame, in the first camera's frame
        (:math:`x_{first} = R(\\mathrm{rvec}) X + \\mathrm{tvec}`); NaN for a frame
        the fit did not use.
    frame_used : (F,) bool
    rms : float
        RMS reprojection error over every used corner of every camera (px).
    sigma : float
        The corner noise the covariance is scaled by (px):
        :math:`\\sqrt{\\lVert r \\rVert^2 / (2N - P)}`, of the whitened residuals
        ``r = w (x - pi)`` where the corners carry their precision (px of each
        camera's typical corner, :mod:`~sogdd.calib.weighting`).
    covariance : (P, P) float64
        Of the fit's free parameters, :math:`\\sigma^2 (J^T J)^{-1}`; empty when
        the fit is degenerate. On a large fit (over 1,000 parameters) the cameras'
        block alone, the frames' poses eliminated (their Schur complement; a note
        says so), and ``layout`` has no frame entries.
    layout : dict of str to slice
        Where each block lies in ``covariance``: ``"NAME.intrinsics"`` (``fx, fy,
        cx, cy`` then the distortion coefficients), ``"NAME.pose"`` (rotation
        vector then translation; not for the first camera, nor one without a pose),
        ``"frame.F.pose"`` (``F`` the frame's index; a camera without a pose has
        frames of its own, ``"NAME.frame.F.pose"``).
    square : float
        The board's square side (the unit of every translation).
    notes : tuple of str
        What the fit could not do, and what it decided (frames dropped, labels turned).
    model_selection : mapping of str to object, optional
        Per camera, how ``model="auto"`` chose its model.
    connectivity : Connectivity, optional
        Which cameras the views the joint fit used tie together: each pair's shared
        frames and corners, the groups (:mod:`~sogdd.calib.rig.connectivity`; a camera
        without a pose is a group of its own).
    """

    cameras: tuple[RigCamera, ...]
    frames: tuple[str, ...]
    rvecs: np.ndarray
    tvecs: np.ndarray
    frame_used: np.ndarray
    rms: float
    sigma: float
    covariance: np.ndarray
    layout: dict
    square: float = 1.0
    notes: tuple[str, ...] = ()
    model_selection: Mapping[str, object] | None = field(default=None)
    connectivity: Connectivity | None = None

    @property
    def names(self) -> tuple[str, ...]:
        """The cameras' names, the reference first."""
        return tuple(c.name for c in self.cameras)

    def camera(self, name: str) -> RigCamera:
        """The camera called ``name`` (``KeyError`` naming the cameras otherwise)."""
        for c in self.cameras:
            if c.name == name:
                return c
        raise KeyError(f"no camera {name!r} in the rig; it has {', '.join(self.names)}")
