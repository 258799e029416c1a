"""Calibration targets: what a board is, how to name one, and how to find it in an image.

:mod:`.board`: :class:`Board`, a board seen in one image (image points with integer labels).
:mod:`.spec`: the board specification string (``chessboard:9x6``, ``charuco:5x7:0.7:DICT_5X5_100``).
:mod:`.xcorners`: X-corner candidates, saddle points with their two edge lines.
:mod:`.lattice`: the lattice grown from X-corners by local-homography prediction, and its check.
:mod:`.windows`: a board's corners refined: windows that stop at its edge, shading out, the symmetry test.
:mod:`.fill`: corners at the labels a grown lattice left free, measured where the lattice puts them.
:mod:`.proposals`: OpenCV's chessboard detectors as a second source of board candidates.
:mod:`.chessboard`: chessboard detection, from X-corners to refined, labelled boards.
:mod:`.charuco`: ChArUco detection (OpenCV's markers, sogdd's refinement).
:mod:`.refine`: corner refinement to the centre of point symmetry (``cv2.cornerSubPix``'s contract).
:mod:`.precision`: a board's corner precision, each corner's measured 1-sigma position uncertainty.
"""

from .board import Board, grid_dims
from .charuco import detect_charuco
from .chessboard import BoardSearch, detect_board, detect_boards, find_boards
from .refine import refine_corners
from .spec import BoardSpec, parse_board
from .xcorners import XCorners, find_xcorners

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
