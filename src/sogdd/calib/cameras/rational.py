"""OpenCV's rational model ``k1, k2, p1, p2, k3, k4, k5, k6`` (``cv2.CALIB_RATIONAL_MODEL``).

The radial factor is :math:`(1 + k_1 r^2 + k_2 r^4 + k_3 r^6) / (1 + k_4 r^2 + k_5 r^4 + k_6 r^6)`
(:func:`~.lens.opencv_distort`); the rest as :mod:`.pinhole`.
"""

from __future__ import annotations

import cv2

from .lens import LensModel, opencv_distort, plane_project
from .pinhole import unproject

__all__ = ["LENS"]

#: the record
LENS = LensModel(name="rational", params=("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"), fisheye=False,
                 start="calibrateCamera", cv_flags=cv2.CALIB_RATIONAL_MODEL, distort=opencv_distort,
                 project=plane_project, unproject=unproject, auto_fov=0.0,
                 summary="OpenCV's rational model: a ratio of radial polynomials, k1..k6, p1, p2")
