"""The board specification: which board to look for, as a short string.

- ``chessboard:COLSxROWS`` -- a chessboard of COLS x ROWS *inner* corners
  (OpenCV's ``patternSize``; a board of 10 x 7 squares has 9 x 6 inner corners);
- ``chessboard:auto`` -- a chessboard of unknown size (partial boards welcome);
- ``charuco:COLSxROWS:MARKER:DICT`` -- a ChArUco board of COLS x ROWS *squares*,
  markers MARKER times the square's side, OpenCV's dictionary DICT (e.g.
  ``charuco:5x7:0.7:DICT_5X5_100``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np  # noqa: F401  (used by the doctests)

from .board import Board

__all__ = ["BoardKind", "BoardSpec", "grid_dims", "parse_board"]

#: the kinds of board a specification names
BoardKind = Literal["chessboard", "charuco"]

_SYNTAX = ("expected chessboard:COLSxROWS (inner corners), chessboard:auto or "
           "charuco:COLSxROWS:MARKER:DICT (squares, marker/square ratio, OpenCV dictionary), "
           "e.g. chessboard:9x6 or charuco:5x7:0.7:DICT_5X5_100")


@dataclass(frozen=True)
class BoardSpec:
    """A parsed board specification (:func:`parse_board`).

    ``pattern`` is the chessboard's (columns, rows) of inner corners, or None
    for ``auto``; for ChArUco ``squares`` is (columns, rows) of squares,
    ``marker`` the marker's side over the square's and ``dictionary`` the name
    of OpenCV's predefined dictionary.
    """

    kind: BoardKind
    pattern: tuple[int, int] | None = None
    squares: tuple[int, int] | None = None
    marker: float = 0.0
    dictionary: str = ""

    def charuco_board(self, square: float = 1.0) -> cv2.aruco.CharucoBoard:
        """The OpenCV ChArUco board (square side ``square``)."""
        d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        return cv2.aruco.CharucoBoard(self.squares, float(square), float(square) * self.marker, d)

    def __str__(self) -> str:
        if self.kind == "charuco":
            return f"charuco:{self.squares[0]}x{self.squares[1]}:{self.marker:g}:{self.dictionary}"
        return "chessboard:auto" if self.pattern is None else f"chessboard:{self.pattern[0]}x{self.pattern[1]}"


def _size(text: str, spec: str) -> tuple[int, int]:
    m = re.fullmatch(r"(\d+)[xX](\d+)", text)
    if not m:
        raise ValueError(f"board {spec!r}: {text!r} is not COLSxROWS; {_SYNTAX}")
    return int(m.group(1)), int(m.group(2))


def parse_board(spec: str) -> BoardSpec:
    """Parse a board specification (see the module's documentation).

    Examples
    --------
    >>> parse_board("chessboard:9x6").pattern
    (9, 6)
    >>> parse_board("chessboard:auto").pattern is None
    True
    >>> b = parse_board("charuco:5x7:0.7:DICT_5X5_100")
    >>> b.squares, b.marker, b.dictionary
    ((5, 7), 0.7, 'DICT_5X5_100')
    """
    parts = str(spec).strip().split(":")
    kind = parts[0].lower()
    if kind == "chessboard" and len(parts) == 2:
        if parts[1].lower() == "auto":
            return BoardSpec("chessboard")
        cols, rows = _size(parts[1], spec)
        if cols < 2 or rows < 2:
            raise ValueError(f"board {spec!r}: a chessboard needs at least 2x2 inner corners")
        return BoardSpec("chessboard", pattern=(cols, rows))
    if kind == "charuco" and len(parts) == 4:
        cols, rows = _size(parts[1], spec)
        try:
            marker = float(parts[2])
        except ValueError:
            marker = float("nan")
        if not 0 < marker < 1:
            raise ValueError(f"board {spec!r}: MARKER is the marker's side over the square's, in (0, 1)")
        name = parts[3].upper()
        if not name.startswith("DICT_") or not isinstance(getattr(cv2.aruco, name, None), int):
            raise ValueError(f"board {spec!r}: {parts[3]!r} is not an OpenCV ArUco dictionary "
                             "(e.g. DICT_5X5_100)")
        if cols < 3 or rows < 3:
            raise ValueError(f"board {spec!r}: a ChArUco board needs at least 3x3 squares")
        return BoardSpec("charuco", squares=(cols, rows), marker=marker, dictionary=name)
    raise ValueError(f"board {spec!r}: {_SYNTAX}")


def grid_dims(board: Board) -> tuple[int, int] | None:
    """(columns, rows) of a board whose labels fill a whole rectangle, else None.

    Examples
    --------
    >>> grid_dims(Board(np.zeros((6, 2)), [(i, j) for j in range(2) for i in range(3)]))
    (3, 2)
    """
    lab = board.labels
    if len(lab) == 0:
        return None
    w, h = (int(v) for v in lab.max(axis=0) - lab.min(axis=0) + 1)
    return (w, h) if w * h == len(lab) else None
