"""A calibrated pair in OpenCV's stereo conventions: R, T, E, F and the rectification.

For exactly two cameras, :func:`stereo_pair` gives what ``cv2.stereoCalibrate``
and ``cv2.stereoRectify`` would: :math:`(R, T)` the second camera's pose in the
first one's frame (:math:`x_2 = R x_1 + T`), the essential matrix
:math:`E = [T]_\\times R`, the fundamental matrix :math:`F = K_2^{-T} E K_1^{-1}`
(so that :math:`\\tilde u_2^T F \\tilde u_1 = 0` for undistorted pixels), and the
rectification ``R1, R2, P1, P2, Q``; :func:`rectify_points` maps pixels into the
rectified images, where a point's two images share one row.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

from ..cameras import lens, undistort
from .result import RigCalibration

__all__ = ["StereoPair", "rectify_points", "stereo_pair"]


@dataclass(frozen=True)
class StereoPair:
    """Two cameras as ``cv2.stereoCalibrate`` and ``cv2.stereoRectify`` describe them.

    Read by name (``pair.F``), or unpacked as OpenCV gives them, the nine
    matrices in the order of ``stereoCalibrate``'s ``R, T, E, F`` and
    ``stereoRectify``'s ``R1, R2, P1, P2, Q``:
    ``R, T, E, F, R1, R2, P1, P2, Q = stereo_pair(rig)``.

    Attributes
    ----------
    R : (3, 3), T : (3,)
        The second camera's pose: :math:`x_2 = R x_1 + T`.
    E, F : (3, 3)
        Essential and fundamental matrices.
    R1, R2 : (3, 3)
        The rectifying rotations of the two cameras.
    P1, P2 : (3, 4)
        The rectified cameras' projection matrices (``P2[0, 3] = f T_x``).
    Q : (4, 4)
        The disparity-to-depth matrix.
    image_size : (width, height)
        The size the rectification was made for (the first camera's).
    names : (str, str)
    """

    R: np.ndarray
    T: np.ndarray
    E: np.ndarray
    F: np.ndarray
    R1: np.ndarray
    R2: np.ndarray
    P1: np.ndarray
    P2: np.ndarray
    Q: np.ndarray
    image_size: tuple[int, int]
    names: tuple[str, str]

    def __iter__(self) -> Iterator[np.ndarray]:
        """``R, T, E, F, R1, R2, P1, P2, Q``, in that order (not ``image_size`` nor ``names``).

        Examples
        --------
        >>> from sogdd.calib.rig.demo import demo_rig
        >>> R, T, E, F, R1, R2, P1, P2, Q = stereo_pair(demo_rig())
        >>> bool(np.allclose(E, _cross(T) @ R)), P2.shape, Q.shape
        (True, (3, 4), (4, 4))
        """
        return iter((self.R, self.T, self.E, self.F, self.R1, self.R2, self.P1, self.P2, self.Q))


def _cross(t: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -t[2], t[1]], [t[2], 0.0, -t[0]], [-t[1], t[0], 0.0]])


def stereo_pair(rig: RigCalibration, first: str | None = None, second: str | None = None) -> StereoPair:
    """Two cameras of a rig as a stereo pair, in OpenCV's conventions: ``R, T, E, F, R1, R2, P1, P2, Q``.

    The :class:`StereoPair` unpacks as those nine
    (``R, T, E, F, R1, R2, P1, P2, Q = stereo_pair(rig)``) and holds them by name.

    By default the two cameras of a two-camera rig; ``first`` and ``second``
    name any two cameras of a larger one, with :math:`R = R_2 R_1^T`,
    :math:`T = T_2 - R T_1` from their poses in the rig's frame.

    The rectification is ``cv2.stereoRectify`` (``alpha = 0``,
    ``CALIB_ZERO_DISPARITY``) for two non-fisheye cameras and
    ``cv2.fisheye.stereoRectify`` (``balance = 0``) for two fisheye ones; for a
    fisheye with a non-fisheye camera, ``cv2.stereoRectify`` without the
    distortion (the rotations ``R1``, ``R2`` depend on ``R, T`` alone; ``P1``,
    ``P2`` then ignore how the lenses bend the image's border).

    Raises
    ------
    ValueError
        No names for a rig of other than two cameras, one camera twice, or a camera without a pose.

    Examples
    --------
    >>> from sogdd.calib.rig.demo import demo_rig
    >>> pair = stereo_pair(demo_rig())
    >>> pair.P2.shape, bool(abs(pair.P2[0, 3] / pair.P2[0, 0] + np.linalg.norm(pair.T)) < 1e-6)
    ((3, 4), True)
    """
    if first is None and second is None:
        if len(rig.cameras) != 2:
            raise ValueError(f"a rig of {len(rig.cameras)} cameras: name the stereo pair's two cameras")
        a, b = rig.cameras
    else:
        a = rig.camera(first if first is not None else rig.names[0])
        b = rig.camera(second if second is not None else rig.names[1])
    if a.name == b.name:
        raise ValueError(f"a stereo pair needs two cameras; got {a.name!r} twice")
    for cam in (a, b):
        if not (np.all(np.isfinite(cam.R)) and np.all(np.isfinite(cam.T))):
            raise ValueError(f"camera {cam.name!r} has no pose in the rig: no stereo pair")
    R = np.asarray(b.R, np.float64) @ np.asarray(a.R, np.float64).T
    T = np.asarray(b.T, np.float64).reshape(3) - R @ np.asarray(a.T, np.float64).reshape(3)
    E = _cross(T) @ R
    F = np.linalg.inv(b.K).T @ E @ np.linalg.inv(a.K)
    size = tuple(int(v) for v in a.image_size)
    start = {lens(a.model).start, lens(b.model).start}
    if start == {"fisheye.calibrate"}:  # both: OpenCV's fisheye rectification
        R1, R2, P1, P2, Q = cv2.fisheye.stereoRectify(
            a.K, np.ravel(a.dist)[:4].reshape(4, 1), b.K, np.ravel(b.dist)[:4].reshape(4, 1), size, R,
            T.reshape(3, 1), flags=cv2.CALIB_ZERO_DISPARITY, balance=0.0)
    else:
        mixed = start != {"calibrateCamera"}  # OpenCV's pinhole rectification, without the other's distortion
        d1 = np.zeros(5) if mixed else np.asarray(a.dist, np.float64)
        d2 = np.zeros(5) if mixed else np.asarray(b.dist, np.float64)
        R1, R2, P1, P2, Q, _, _ = cv2.stereoRectify(a.K, d1, b.K, d2, size, R, T.reshape(3, 1),
                                                    flags=cv2.CALIB_ZERO_DISPARITY, alpha=0.0)
    return StereoPair(R=R, T=T, E=E, F=F / F[2, 2] if abs(F[2, 2]) > 1e-12 else F, R1=R1, R2=R2, P1=P1,
                      P2=P2, Q=Q, image_size=size, names=(a.name, b.name))  # type: ignore[arg-type]


def rectify_points(pair: StereoPair, K: np.ndarray, dist: np.ndarray, model: str, points: np.ndarray,
                   which: Literal[1, 2]) -> np.ndarray:
    """Pixels of camera ``which`` (1 or 2) mapped into its rectified image, (N, 2) -> (N, 2).

    What ``cv2.undistortPoints(points, K, dist, R=R_which, P=P_which)`` computes,
    with the distortion inverted to convergence (:func:`~sogdd.calib.cameras.undistort`;
    OpenCV stops after a few iterations): the ray :math:`(x, y, 1)` of each pixel is
    turned by :math:`R_i`, normalised to :math:`z = 1`, and mapped by the left
    3 x 3 of :math:`P_i`. NaN where a pixel has no ray. The vertical disparity of
    a point is the difference of its two rectified rows.

    Examples
    --------
    >>> from sogdd.calib.rig.demo import demo_rig
    >>> rig = demo_rig()
    >>> pair = stereo_pair(rig)
    >>> cam = rig.camera("left")
    >>> rectify_points(pair, cam.K, cam.dist, cam.model, np.array([[320.0, 240.0]]), 1).shape
    (1, 2)
    """
    if which not in (1, 2):
        raise ValueError(f"which must be 1 or 2 (the pair's first or second camera), got {which!r}")
    Rr, P = (pair.R1, pair.P1) if which == 1 else (pair.R2, pair.P2)
    xy, _ = undistort(np.asarray(points, np.float64).reshape(-1, 2), K, dist, model)  # type: ignore[arg-type]
    r = np.c_[xy, np.ones(len(xy))] @ np.asarray(Rr, np.float64).T
    q = (r / r[:, 2:3]) @ np.asarray(P, np.float64)[:, :3].T
    return q[:, :2] / q[:, 2:3]
