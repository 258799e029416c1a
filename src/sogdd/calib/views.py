"""Boards in image files: the board specification, and detection over many files with --jobs and progress.

A board specification is a short string:

- ``chessboard:COLSxROWS`` -- a chessboard of COLS x ROWS *inner* corners
  (OpenCV's ``patternSize``; a board of 10 x 7 squares has 9 x 6 inner corners);
- ``chessboard:auto`` -- a chessboard of unknown size (partial boards welcome);
- ``charuco:COLSxROWS:MARKER:DICT`` -- a ChArUco board of COLS x ROWS *squares*,
  markers MARKER times the square's side, OpenCV's dictionary DICT (e.g.
  ``charuco:5x7:0.7:DICT_5X5_100``).
"""

from __future__ import annotations

import os
import re
import sys
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import cv2
import numpy as np

from .board import Board

__all__ = [
    "BoardSpec", "ViewResult", "check_detector", "detect_files", "detect_view", "grid_dims", "parse_board",
]

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

    kind: str
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
        raise ValueError(f"--board {spec!r}: {text!r} is not COLSxROWS; {_SYNTAX}")
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
            raise ValueError(f"--board {spec!r}: a chessboard needs at least 2x2 inner corners")
        return BoardSpec("chessboard", pattern=(cols, rows))
    if kind == "charuco" and len(parts) == 4:
        cols, rows = _size(parts[1], spec)
        try:
            marker = float(parts[2])
        except ValueError:
            marker = float("nan")
        if not 0 < marker < 1:
            raise ValueError(f"--board {spec!r}: MARKER is the marker's side over the square's, in (0, 1)")
        name = parts[3].upper()
        if not name.startswith("DICT_") or not isinstance(getattr(cv2.aruco, name, None), int):
            raise ValueError(f"--board {spec!r}: {parts[3]!r} is not an OpenCV ArUco dictionary "
                             "(e.g. DICT_5X5_100)")
        if cols < 3 or rows < 3:
            raise ValueError(f"--board {spec!r}: a ChArUco board needs at least 3x3 squares")
        return BoardSpec("charuco", squares=(cols, rows), marker=marker, dictionary=name)
    raise ValueError(f"--board {spec!r}: {_SYNTAX}")


@dataclass(frozen=True)
class ViewResult:
    """What one image gave: its boards (possibly none), its size, a read error, what else was seen.

    ``seen`` describes what the detector found where no board matched the
    specification (for the error message); ``other_size`` is the (columns,
    rows) of a complete board of another size than the specification's.
    """

    path: str
    boards: tuple[Board, ...] = ()
    size: tuple[int, int] | None = None
    error: str = ""
    seen: str = ""
    other_size: tuple[int, int] | None = None


def _grey(img: np.ndarray) -> np.ndarray:
    if img.ndim == 3:
        img = cv2.cvtColor(img[..., :3], cv2.COLOR_RGB2GRAY)
    return img


def _matches(size, pattern) -> bool:
    return size is None or tuple(size) in (tuple(pattern), tuple(pattern)[::-1])


def detect_view(path: str, spec: BoardSpec) -> ViewResult:
    """Read one image and find its boards by ``spec`` (the unit of work of :func:`detect_files`)."""
    import sogdd

    from . import detect  # the detector is imported here, so that the specification and I/O work without it

    try:
        img = _grey(sogdd.read_image(path))
    except (ValueError, OSError, cv2.error) as exc:
        msg = " ".join(str(exc).split())
        return ViewResult(str(path), error=msg if str(path) in msg else f"{path}: {msg}")
    size = (int(img.shape[1]), int(img.shape[0]))
    if spec.kind == "charuco":
        from .charuco import detect_charuco

        b = detect_charuco(img, spec.charuco_board())
        return ViewResult(str(path), (b,) if b is not None and len(b) else (), size,
                          seen="" if b is not None else "no ChArUco markers/corners")
    boards = [b for b in detect.detect_boards(img, spec.pattern) if len(b)]
    if spec.pattern is not None:
        wrong = [b for b in boards if not _matches(b.size, spec.pattern)]
        boards = [b for b in boards if _matches(b.size, spec.pattern)]
        if wrong and not boards:
            s = wrong[0].size
            return ViewResult(str(path), (), size, seen=f"a board of {s[0]}x{s[1]} inner corners", other_size=s)
        if not boards:
            return _what_else(str(path), img, size, spec.pattern, detect)
    return ViewResult(str(path), tuple(boards), size, seen="" if boards else "no board")


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


def _what_else(path: str, img: np.ndarray, size, pattern, detect) -> ViewResult:
    """No board of the given size: look for a board of any size, to say what the image shows.

    A complete grid that does not fit in the pattern (in either orientation)
    cannot be part of it: its size contradicts the pattern.
    """
    others = [b for b in detect.detect_boards(img, None) if len(b)]
    for b in others:
        dims = b.size if b.size is not None else grid_dims(b)
        if dims is not None and not _fits(dims, pattern):
            return ViewResult(path, (), size, seen=f"a board of {dims[0]}x{dims[1]} inner corners",
                              other_size=tuple(dims))
    if others:
        return ViewResult(path, (), size, seen=f"a partial board ({max(len(b) for b in others)} corners)")
    return ViewResult(path, (), size, seen="no board")


def _fits(dims, pattern) -> bool:
    (w, h), (c, r) = dims, pattern
    return (w <= c and h <= r) or (w <= r and h <= c)


def check_detector(spec: BoardSpec) -> None:
    """``ValueError`` if the detector that ``spec`` needs cannot be imported (before any work)."""
    import importlib

    name = "charuco" if spec.kind == "charuco" else "detect"
    try:
        importlib.import_module(f"sogdd.calib.{name}")
    except ImportError as exc:
        raise ValueError(f"board detection (sogdd.calib.{name}) is not available: {exc}") from None


def detect_files(paths: Sequence[str | os.PathLike], spec: BoardSpec, *, jobs: int = 1,
                 progress: bool = True) -> list[ViewResult]:
    """:func:`detect_view` on every file, ``jobs`` processes at a time, with a progress bar on stderr.

    A file that cannot be read gives a :class:`ViewResult` with ``error`` set;
    the others complete. Results are in input order.
    """
    from tqdm import tqdm

    if int(jobs) < 1:
        raise ValueError(f"--jobs must be >= 1, got {jobs}")
    check_detector(spec)
    names = [str(p) for p in paths]
    bar = tqdm(total=len(names), desc="boards", unit="img", file=sys.stderr, disable=not progress)
    out: list[ViewResult] = []
    try:
        if jobs == 1 or len(names) == 1:
            for n in names:
                out.append(detect_view(n, spec))
                bar.update(1)
        else:
            with ProcessPoolExecutor(max_workers=min(int(jobs), len(names))) as pool:
                for r in pool.map(detect_view, names, [spec] * len(names)):
                    out.append(r)
                    bar.update(1)
    finally:
        bar.close()
    return out
