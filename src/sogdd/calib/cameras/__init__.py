"""Camera models and their maths: one implementation, used by calibration and by the evaluations.

:mod:`.models`: OpenCV's pinhole, rational and fisheye models in numpy (distort, project, undistort).
:mod:`.compiled`: the same equations compiled (numba) for per-sample loops.
:mod:`.camera`: :class:`Camera`, a camera as one object (intrinsics, distortion, image size).
:mod:`.difference`: the projection difference between two cameras over the image.
"""

from .camera import Camera, pose_matrix
from .difference import ProjectionDifference, projection_difference
from .models import MODELS, CameraModel, check_model, check_size, distort, project, to_pixels, undistort

__all__ = [
    "MODELS",
    "Camera",
    "CameraModel",
    "ProjectionDifference",
    "check_model",
    "check_size",
    "distort",
    "pose_matrix",
    "project",
    "projection_difference",
    "to_pixels",
    "undistort",
]
