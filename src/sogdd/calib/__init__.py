"""Camera calibration on sogdd's corners: boards, refinement, calibration and its diagnostics.

A client of the core (:mod:`sogdd.detector` and its stages); the core never imports it.
"""

from .board import Board
from .calibrate import Calibration, CrossValidation, ProjectionDifference, calibrate, projection_difference
from .charuco import detect_charuco
from .detect import detect_board, detect_boards
from .refine import refine_corners

__all__ = [
    "Board",
    "Calibration",
    "CrossValidation",
    "ProjectionDifference",
    "calibrate",
    "detect_board",
    "detect_boards",
    "detect_charuco",
    "projection_difference",
    "refine_corners",
]
