"""OpenCV's pinhole model with five coefficients ``k1, k2, p1, p2, k3`` (``cv2.calibrateCamera``'s default).

Projection :math:`(x, y) = (X/Z, Y/Z)`, then :func:`~.lens.opencv_distort`, then ``K``;
unprojection by Newton's method (:func:`~.lens.newton_undistort`).
"""

from __future__ import annotations

import numpy as np

from .lens import LensModel, newton_undistort, opencv_distort, plane_project, unit_rays

__all__ = ["LENS", "unproject"]


def unproject(pixels: np.ndarray, K: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Unit rays (N, 3) of pixels under OpenCV's pinhole distortion; NaN where it folds.

    Examples
    --------
    >>> K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    >>> unproject(np.array([[320.0, 240.0]]), K, np.zeros(5)).tolist()
    [[0.0, 0.0, 1.0]]
    """
    return unit_rays(newton_undistort(pixels, K, dist, opencv_distort)[0])


#: the record
LENS = LensModel(name="pinhole", params=("k1", "k2", "p1", "p2", "k3"), fisheye=False, start="calibrateCamera",
                 cv_flags=0, distort=opencv_distort, project=plane_project, unproject=unproject, auto_fov=0.0,
                 summary="OpenCV's pinhole model, radial k1..k3 and tangential p1, p2",
                 radial_terms=((0, 3), (1, 5), (4, 7)))
