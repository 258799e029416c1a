"""Camera models and their maths: one implementation, used by calibration and by the evaluations.

:mod:`.registry`: the lens models, one row per model: a new model is one module and one row.
:mod:`.lens`: :class:`~.lens.LensModel`, what a lens model's record holds, and the equations records share.
:mod:`.pinhole4`: OpenCV's pinhole model with four coefficients (k3 = 0).
:mod:`.pinhole`: OpenCV's pinhole model with five coefficients.
:mod:`.rational`: OpenCV's rational model (eight coefficients).
:mod:`.fisheye`: OpenCV's fisheye (equidistant) model.
:mod:`.omnidir`: the unified omnidirectional model (Mei; OpenCV contrib's ``cv2.omnidir``).
:mod:`.models`: the registered models in numpy by name (distort, project, undistort).
:mod:`.compiled`: the same equations compiled (numba) for per-sample loops.
:mod:`.camera`: :class:`Camera`, a camera as one object (intrinsics, distortion, image size).
:mod:`.difference`: the projection difference between two cameras over the image.
"""

from .camera import Camera, pose_matrix
from .difference import ProjectionDifference, projection_difference
from .lens import LensModel
from .models import MODELS, CameraModel, check_model, check_size, distort, project, to_pixels, undistort
from .registry import LENSES, lens

__all__ = [
    "LENSES",
    "MODELS",
    "Camera",
    "CameraModel",
    "LensModel",
    "ProjectionDifference",
    "check_model",
    "check_size",
    "distort",
    "lens",
    "pose_matrix",
    "project",
    "projection_difference",
    "to_pixels",
    "undistort",
]
