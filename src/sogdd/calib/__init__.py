"""Camera calibration on sogdd's corners: boards, cameras, the fit and its diagnostics.

A client of the core (:mod:`sogdd.detector` and its stages); the core never imports it.

:mod:`.targets`: calibration boards, and how to find, label and refine them in an image.
:mod:`.cameras`: the camera models and their maths (used by the evaluations too).
:mod:`.solvers`: the OpenCV calls (one fit, one pose).
:mod:`.rejection`: the fit of one model with its rejection rounds (shared by the fit and the model selection).
:mod:`.weighting`: each corner's weight in the fit from its measured precision, and the smeared views' rule.
:mod:`.model_selection`: :func:`select_model`, the lens model chosen by cross-validation over views.
:mod:`.fit`: :func:`calibrate`, the fit of a camera to labelled boards with robust rejection.
:mod:`.cross_validation`: the two halves' cross-validation.
:mod:`.result`: :class:`Calibration`, the result with its diagnostics.
:mod:`.uncertainty`: a fit's covariance and a camera's projection uncertainty (one camera's and a rig's).
:mod:`.detection`: boards in image files, over many files (each image read once).
:mod:`.session`: :func:`calibrate_images`, image files to a camera and every view's fate; its output folder.
:mod:`.video`: a calibration's views chosen from a video (sharp, new poses, new coverage), and its fit.
:mod:`.inputs`: :func:`~.inputs.calibrate_inputs_into`, any inputs (images, a video, a rig's) to their folder.
:mod:`.verdict`: what a calibration is worth, in plain words.
:mod:`.guidance`: what to do next: where the next views should put the board, and how to tilt it.
:mod:`.drift`: :func:`~.drift.check_calibration`, new views checked against a stored camera or rig.
:mod:`.files`: camera.yaml (OpenCV FileStorage), camera.json, views.csv, corners.csv.
:mod:`.figures`: the figure helpers the reports share (pyplot, saving a PNG, cameras and board poses in 3-D).
:mod:`.report_figures`: the one-camera report's figures (errors per view, residuals, distortion field, poses).
:mod:`.report`: the HTML report with its figures.
:mod:`.demo`: a small known calibration for examples.
:mod:`.rig`: camera rigs, several cameras calibrated together (:func:`~sogdd.calib.rig.calibrate_rig`).
:mod:`.exchange`: a calibration in other tools' files (ROS, Kalibr, mrcal, COLMAP) and back; ``sogdd convert``.
"""

from .cameras import MODELS, Camera, CameraModel, ProjectionDifference, projection_difference
from .cross_validation import CrossValidation
from .detection import ViewRecord, ViewStatus
from .fit import calibrate
from .model_selection import ModelSelection, select_model
from .result import Calibration
from .session import ImageCalibration, calibrate_images, check_output_folder, write_outputs
from .targets import Board, BoardSpec, detect_board, detect_boards, detect_charuco, parse_board, refine_corners

__all__ = [
    "MODELS",
    "Board",
    "BoardSpec",
    "Calibration",
    "Camera",
    "CameraModel",
    "CrossValidation",
    "ImageCalibration",
    "ModelSelection",
    "ProjectionDifference",
    "ViewRecord",
    "ViewStatus",
    "calibrate",
    "calibrate_images",
    "check_output_folder",
    "detect_board",
    "detect_boards",
    "detect_charuco",
    "parse_board",
    "projection_difference",
    "refine_corners",
    "select_model",
    "write_outputs",
]
