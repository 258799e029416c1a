"""Calibration targets: what a board is, how to name one, and how to find it in an image.

:mod:`.board`: :class:`Board`, a board seen in one image (image points with integer labels).
:mod:`.spec`: the board specification string (``chessboard:9x6``, ``charuco:5x7:0.7:DICT_5X5_100``)
and the registry of board kinds (a new kind is one module and one row).
:mod:`.grey`: an image made grey for the board detectors (the core's conversion, checked at the door).
:mod:`.chessboard`: chessboard detection, a package of stages (its table): X-corners over a pyramid,
lattices, refinement, checks, labels, OpenCV's detectors as proposals.
:mod:`.charuco`: ChArUco detection (OpenCV's markers, sogdd's refinement).
:mod:`.aprilgrid`: Kalibr's AprilGrid (OpenCV's 36h11 tags, Kalibr's point numbers, sogdd's corners).
:mod:`.refine`: corner refinement to the centre of point symmetry (``cv2.cornerSubPix``'s contract).
:mod:`.precision`: a board's corner precision, each corner's measured 1-sigma position uncertainty.
"""

from .board import Board, grid_dims
from .charuco import detect_charuco
from .chessboard import BoardSearch, XCorners, detect_board, detect_boards, find_boards, find_xcorners
from .refine import refine_corners
from .spec import BoardSpec, parse_board

__all__ = [
    "Board",
    "BoardSearch",
    "BoardSpec",
    "XCorners",
    "detect_board",
    "detect_boards",
    "detect_charuco",
    "find_boards",
    "find_xcorners",
    "grid_dims",
    "parse_board",
    "refine_corners",
]
