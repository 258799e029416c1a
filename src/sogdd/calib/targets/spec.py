"""The board specification: which board to look for, as a short string, and the registry of board kinds.

- ``chessboard:COLSxROWS`` -- a chessboard of COLS x ROWS *inner* corners
  (OpenCV's ``patternSize``; a board of 10 x 7 squares has 9 x 6 inner corners);
- ``chessboard:auto`` -- a chessboard of unknown size (partial boards welcome);
- ``charuco:COLSxROWS:MARKER:DICT`` -- a ChArUco board of COLS x ROWS *squares*,
  markers MARKER times the square's side, OpenCV's dictionary DICT (e.g.
  ``charuco:5x7:0.7:DICT_5X5_100``);
- ``aprilgrid:COLSxROWS:SIZE:SPACING`` -- Kalibr's AprilGrid of COLS x ROWS
  36h11 tags of side SIZE, SPACING times the side apart (e.g.
  ``aprilgrid:6x6:0.088:0.3``, Kalibr's ``tagCols``, ``tagRows``, ``tagSize``,
  ``tagSpacing``).

Board kinds
-----------
:data:`KINDS` holds one :class:`Kind` per kind of board: its name, its syntax,
and three functions of the kind's own module: ``parse`` (the specification's
fields after the name, to :class:`BoardSpec`'s fields), ``text`` (a
:class:`BoardSpec` back to its string) and ``view`` (an image's boards of a
:class:`BoardSpec`, a :class:`~sogdd.calib.targets.board.ViewBoards`). A new
kind of board is one module and one row.

========== ============================================ =======================
kind       module                                        ``view`` finds
========== ============================================ =======================
chessboard :mod:`sogdd.calib.targets.chessboard`        own search, OpenCV's as proposals
charuco    :mod:`sogdd.calib.targets.charuco`           OpenCV's markers, sogdd's corners
aprilgrid  :mod:`sogdd.calib.targets.aprilgrid`         OpenCV's tags, sogdd's corners
========== ============================================ =======================
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

from . import aprilgrid, charuco, chessboard
from .aprilgrid import AprilGrid
from .board import ViewBoards

__all__ = ["KINDS", "BoardKind", "BoardSpec", "Kind", "parse_board", "view_boards"]

#: the kinds of board a specification names (:data:`KINDS`)
BoardKind = Literal["chessboard", "charuco", "aprilgrid"]


@dataclass(frozen=True)
class BoardSpec:
    """A parsed board specification (:func:`parse_board`).

    ``pattern`` is the chessboard's (columns, rows) of inner corners, or None
    for ``auto``; for ChArUco ``squares`` is (columns, rows) of squares,
    ``marker`` the marker's side over the square's and ``dictionary`` the name
    of OpenCV's predefined dictionary; for an AprilGrid ``tags`` is (columns,
    rows) of tags, ``tag_size`` a tag's side and ``spacing`` the gap between
    tags over the side.
    """

    kind: BoardKind
    pattern: tuple[int, int] | None = None
    squares: tuple[int, int] | None = None
    marker: float = 0.0
    dictionary: str = ""
    tags: tuple[int, int] | None = None
    tag_size: float = 0.0
    spacing: float = 0.0

    def charuco_board(self, square: float = 1.0) -> cv2.aruco.CharucoBoard:
        """The OpenCV ChArUco board (square side ``square``)."""
        return charuco.charuco_board(self.squares, self.marker, self.dictionary, square)

    def aprilgrid(self) -> AprilGrid:
        """The AprilGrid (its labels' step :attr:`~sogdd.calib.targets.aprilgrid.AprilGrid.unit`)."""
        return AprilGrid(self.tags[0], self.tags[1], self.tag_size, self.spacing)

    @property
    def label_step(self) -> float:
        """The board length of one label step, in the unit the specification gives sizes in (1: a square,
        for a board whose specification gives none): a calibration's object points are
        ``label x label_step x square``.

        Examples
        --------
        >>> grid = parse_board("aprilgrid:6x6:0.088:0.3")  # one step: SIZE / 10, the gap's share being 3 / 10
        >>> parse_board("chessboard:9x6").label_step, round(grid.label_step, 6)
        (1.0, 0.0088)
        """
        return float(KINDS[self.kind].label_step(self))

    def __str__(self) -> str:
        return KINDS[self.kind].text(self)


@dataclass(frozen=True)
class Kind:
    """One kind of board (module doc): ``name``, ``syntax`` and its module's ``parse``, ``text``, ``view``;
    ``label_step``: the board length of one label step (:attr:`BoardSpec.label_step`)."""

    name: str
    syntax: str
    parse: Callable[[list[str], str], dict]
    text: Callable[[BoardSpec], str]
    view: Callable[[np.ndarray, BoardSpec, bool], ViewBoards]
    label_step: Callable[[BoardSpec], float] = lambda spec: 1.0


KINDS: dict[str, Kind] = {k.name: k for k in (
    Kind("chessboard", "chessboard:COLSxROWS (inner corners), chessboard:auto", chessboard.parse_spec,
         chessboard.spec_text, chessboard.view_boards),
    Kind("charuco", "charuco:COLSxROWS:MARKER:DICT (squares, marker/square ratio, OpenCV dictionary)",
         charuco.parse_spec, charuco.spec_text, charuco.view_boards),
    Kind("aprilgrid", "aprilgrid:COLSxROWS:SIZE:SPACING (Kalibr's: tags, tag side, gap/side)",
         aprilgrid.parse_spec, aprilgrid.spec_text, aprilgrid.view_boards, lambda spec: spec.aprilgrid().unit),
)}

_SYNTAX = ("expected " + " or ".join(k.syntax for k in KINDS.values())
           + ", e.g. chessboard:9x6 or charuco:5x7:0.7:DICT_5X5_100")


def parse_board(spec: str) -> BoardSpec:
    """Parse a board specification (see the module's documentation).

    Examples
    --------
    >>> parse_board("chessboard:9x6").pattern
    (9, 6)
    >>> parse_board("chessboard:auto").pattern is None
    True
    >>> b = parse_board("charuco:5x7:0.7:DICT_5X5_100")
    >>> b.squares, b.marker, b.dictionary, str(b)
    ((5, 7), 0.7, 'DICT_5X5_100', 'charuco:5x7:0.7:DICT_5X5_100')
    >>> parse_board("dots:3x3")
    Traceback (most recent call last):
    ...
    ValueError: board 'dots:3x3': expected chessboard:COLSxROWS (inner corners), chessboard:auto or ...
    """
    parts = str(spec).strip().split(":")
    kind = KINDS.get(parts[0].lower())
    if kind is None:
        raise ValueError(f"board {spec!r}: {_SYNTAX}")
    fields = kind.parse(parts[1:], str(spec))
    if fields is None:
        raise ValueError(f"board {spec!r}: {_SYNTAX}")
    return BoardSpec(kind.name, **fields)  # type: ignore[arg-type]


def view_boards(image: np.ndarray, spec: BoardSpec, view_only: bool = False) -> ViewBoards:
    """An image's boards of ``spec``, by its kind's detector (:data:`KINDS`), and what it shows otherwise.

    ``view_only``: one board per image is wanted; a detector may then stop once the view's board is settled
    (:func:`sogdd.calib.targets.chessboard.find_boards`).

    Examples
    --------
    >>> sq = np.kron((np.indices((6, 8)).sum(axis=0) % 2) * 200 + 30, np.ones((20, 20)))
    >>> img = cv2.GaussianBlur(np.pad(sq, 30, constant_values=230).astype(np.uint8), (0, 0), 1.0)
    >>> [len(b) for b in view_boards(img, parse_board("chessboard:7x5")).boards]
    [35]
    >>> view_boards(img, parse_board("chessboard:5x4")).seen  # a board that cannot be part of a 5 x 4 one
    'a board of 7x5 inner corners'
    """
    return KINDS[spec.kind].view(image, spec, view_only)
