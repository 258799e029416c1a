"""Camera rigs: several cameras calibrated together, each camera's pose in the first one's frame.

:mod:`.result`: :class:`RigCalibration` and :class:`RigCamera`, the result with its uncertainties.
:mod:`.fit`: :func:`calibrate_rig`, the joint fit of every camera, its pose and every frame's board pose.
:mod:`.connectivity`: which cameras share frames (each pair's frames and corners) and the groups they form.
:mod:`.labels`: chessboard labels made to agree across the cameras of a frame (half turns, partial boards).
:mod:`.uncertainty`: the parameters' covariance and the projection uncertainty, tied to the first camera.
:mod:`.stereo`: :func:`stereo_pair`, a two-camera rig as OpenCV's stereo calibration and rectification.
:mod:`.demo`: known rigs and their boards for examples and tests.
:mod:`.frames`: :func:`match_frames`, the cameras' images matched into frames by the numbers in their names.
:mod:`.files`: rig.yaml (OpenCV FileStorage), rig.json and each camera's own files; :func:`read_rig`.
:mod:`.session`: :func:`calibrate_rig_images`, each camera's image files to a rig; its output folder.
:mod:`.video`: :func:`calibrate_rig_video`, a video per camera to a rig, its frames matched by index and chosen.
"""

from .files import read_rig, write_rig
from .fit import calibrate_rig
from .frames import match_frames
from .result import RigCalibration, RigCamera
from .session import RigImageCalibration, calibrate_rig_images, write_rig_outputs
from .stereo import StereoPair, rectify_points, stereo_pair
from .uncertainty import projection_uncertainty, ray_uncertainty
from .video import calibrate_rig_video, calibrate_rig_video_into

__all__ = ["RigCalibration", "RigCamera", "StereoPair", "calibrate_rig", "projection_uncertainty",
           "ray_uncertainty", "rectify_points", "stereo_pair"]
__all__ += ["RigImageCalibration", "calibrate_rig_images", "calibrate_rig_video", "calibrate_rig_video_into",
            "match_frames", "read_rig", "write_rig", "write_rig_outputs"]
