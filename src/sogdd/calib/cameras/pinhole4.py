"""OpenCV's four-coefficient pinhole vector ``k1, k2, p1, p2`` (k3 = 0; mrcal's LENSMODEL_OPENCV4).

The equations are :mod:`.pinhole`'s with ``k3`` held at 0 (``cv2.CALIB_FIX_K3``); OpenCV
takes the four-value vector wherever it takes one.
"""

from __future__ import annotations

import cv2

from .lens import LensModel, opencv_distort, plane_project
from .pinhole import unproject

__all__ = ["LENS"]

#: the record
LENS = LensModel(name="pinhole4", params=("k1", "k2", "p1", "p2"), fisheye=False, start="calibrateCamera",
                 cv_flags=cv2.CALIB_FIX_K3, distort=opencv_distort, project=plane_project, unproject=unproject,
                 auto_fov=0.0, summary="OpenCV's pinhole model with k3 = 0: k1, k2, p1, p2",
                 radial_terms=((0, 3), (1, 5)))
