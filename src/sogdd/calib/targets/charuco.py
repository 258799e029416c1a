"""ChArUco boards: OpenCV finds the markers and the corners' IDs, sogdd measures the corners.

``cv2.aruco.CharucoDetector`` decodes the markers and interpolates the
chessboard corners between them, with absolute IDs; each corner is then
re-measured by :func:`sogdd.calib.refine_corners`. A ChArUco corner is point
symmetric only up to the markers: its two light squares hold different markers,
which start ``m = (1 - markerLength / squareLength) / 2`` of a square from the
corner along both axes. The window's half-width is therefore ``0.7 m`` of the
local square (``0.7 < 1 / sqrt 2``: a window turned by 45 degrees stays clear of
the markers too), at least 2 px.

Two layouts: OpenCV 4.6 moved the markers of a board with an even number of
rows to the other set of white squares (``CharucoBoard.setLegacyPattern``), and
boards printed before, or by tools that kept the old layout, are still in use.
The corners and their IDs are where they were; only the markers moved. A
board's spec finds both: where its layout finds no corners,
:func:`view_boards` tries :func:`other_layout` on the markers already found.

Labels: corner ID ``k`` is ``(k % (nx - 1), k // (nx - 1))`` for a board of
``nx x ny`` squares (OpenCV's order: along the first row of the generated image,
then the next), right-handed as :class:`~sogdd.calib.Board` wants.
"""

from __future__ import annotations

import cv2
import numpy as np

from .board import Board, ViewBoards, parse_grid
from .grey import to_grey
from .refine import cell_sizes, refine_grey

__all__ = ["charuco_board", "detect_charuco", "other_layout", "parse_spec", "spec_text", "view_boards"]


def charuco_board(squares: tuple[int, int], marker: float, dictionary: str,
                  square: float = 1.0) -> cv2.aruco.CharucoBoard:
    """OpenCV's ChArUco board of ``squares`` (columns, rows), markers ``marker`` of a square, ``dictionary``.

    Examples
    --------
    >>> charuco_board((5, 7), 0.7, "DICT_5X5_100").getChessboardSize()
    (5, 7)
    """
    d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, dictionary))
    return cv2.aruco.CharucoBoard(tuple(squares), float(square), float(square) * float(marker), d)


def other_layout(board: cv2.aruco.CharucoBoard) -> cv2.aruco.CharucoBoard | None:
    """The board in OpenCV's other layout (module doc: ``setLegacyPattern`` flipped), or None where the two
    layouts are one (an odd number of rows).

    Examples
    --------
    >>> other_layout(charuco_board((5, 6), 0.7, "DICT_5X5_100")).getLegacyPattern()
    True
    >>> other_layout(charuco_board((5, 7), 0.7, "DICT_5X5_100")) is None
    True
    """
    cols, rows = board.getChessboardSize()
    if rows % 2:
        return None
    twin = cv2.aruco.CharucoBoard((cols, rows), board.getSquareLength(), board.getMarkerLength(),
                                  board.getDictionary())
    twin.setLegacyPattern(not board.getLegacyPattern())
    return twin


def parse_spec(parts: list[str], spec: str) -> dict | None:
    """The fields of ``charuco:COLSxROWS:MARKER:DICT`` after its name (a row of
    :data:`sogdd.calib.targets.spec.KINDS`); None when they are not of that form.

    Examples
    --------
    >>> parse_spec(["5x7", "0.7", "dict_5x5_100"], "charuco:5x7:0.7:dict_5x5_100")
    {'squares': (5, 7), 'marker': 0.7, 'dictionary': 'DICT_5X5_100'}
    """
    if len(parts) != 3:
        return None
    size = parse_grid(parts[0])
    if size is None:
        raise ValueError(f"board {spec!r}: {parts[0]!r} is not COLSxROWS")
    try:
        marker = float(parts[1])
    except ValueError:
        marker = float("nan")
    if not 0 < marker < 1:
        raise ValueError(f"board {spec!r}: MARKER is the marker's side over the square's, in (0, 1)")
    name = parts[2].upper()
    if not name.startswith("DICT_") or not isinstance(getattr(cv2.aruco, name, None), int):
        raise ValueError(f"board {spec!r}: {parts[2]!r} is not an OpenCV ArUco dictionary (e.g. DICT_5X5_100)")
    if min(size) < 3:
        raise ValueError(f"board {spec!r}: a ChArUco board needs at least 3x3 squares")
    return {"squares": size, "marker": marker, "dictionary": name}


def spec_text(spec) -> str:
    """A ChArUco :class:`~sogdd.calib.targets.spec.BoardSpec` as its string."""
    return f"charuco:{spec.squares[0]}x{spec.squares[1]}:{spec.marker:g}:{spec.dictionary}"


def view_boards(image: np.ndarray, spec, view_only: bool = False) -> ViewBoards:
    """The ChArUco board of ``spec`` in an image (:func:`detect_charuco`), in either layout (module doc) and
    either polarity (where the image shows no marker, its negative is searched: a board printed or seen in
    negative, as a heated board in a thermal camera; the corners are where they are in either), or what was
    missing; one board per image whatever ``view_only`` says (the grid is one board)."""
    board = spec.charuco_board()
    twin = other_layout(board)
    grey = to_grey(image)
    for img in (grey, 255.0 - grey):  # a board in negative (a heated board in a thermal camera): no marker
        markers: list = []
        b = detect_charuco(img, board, markers=markers, value_range=(0.0, 255.0))
        found = 0 if markers[0][1] is None else len(markers[0][1])
        if b is None and twin is not None and found:
            b = detect_charuco(img, twin, markers=markers, value_range=(0.0, 255.0))
        if found:
            break
    dictionary, (cols, rows) = spec.dictionary, spec.squares
    seen = ("" if b is not None else f"no ChArUco markers ({dictionary})" if not found else
            f"{found} {dictionary} marker(s) but no corners of a board of {cols}x{rows} squares: check the "
            "board's COLSxROWS (squares, not inner corners, in the order of its generator) and its markers")
    return ViewBoards((b,) if b is not None and len(b) else (), seen)


def detect_charuco(image: np.ndarray, board: cv2.aruco.CharucoBoard, *, refine: bool = True,
                   min_corners: int = 4, value_range: tuple[float, float] | None = None,
                   markers: list | None = None) -> Board | None:
    """Detect a ChArUco board: OpenCV's markers and corner IDs, corners re-measured by sogdd.

    Parameters
    ----------
    image : ndarray
        Grey or colour image (RGB), any dtype the corner detector takes, on its
        scale (:func:`sogdd.image.to_gray255`): uint8, uint16, float on [0, 1];
        another range needs ``value_range``.
    board : cv2.aruco.CharucoBoard
        The board's layout and dictionary.
    refine : bool
        Re-measure the corners (:func:`sogdd.calib.refine_corners`, window of
        ``0.7 m`` of a square, module doc); else OpenCV's positions. A corner
        whose re-measurement fails is dropped.
    min_corners : int
        Fewer corners than this give None.
    value_range : (lo, hi) or None
        The image's range, mapped to 0-255 (``(0, 255)`` for a float image of
        grey levels); None: the dtype's, and a float image outside [0, 1] is a
        one-line ``ValueError``.
    markers : list, optional
        The markers found, shared between calls on one image: empty, the
        markers are detected and ``(corners, ids)`` appended; else its first
        entry is used (the board's other layout reads the same markers).

    Returns
    -------
    Board or None
        ``labels`` from the IDs, ``ids`` set, ``size`` the board's inner corners
        when all of them were found (else None).

    Examples
    --------
    >>> d = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
    >>> cb = cv2.aruco.CharucoBoard((5, 4), 0.04, 0.02, d)
    >>> img = cv2.GaussianBlur(cb.generateImage((500, 400), marginSize=40), (0, 0), 1.0)
    >>> b = detect_charuco(img, cb)
    >>> len(b), b.size, b.ids[:3].tolist(), b.labels[4].tolist()
    (12, (4, 3), [0, 1, 2], [0, 1])
    >>> np.round(b.image_points[0], 2).tolist()  # 80 px squares from (50, 40): the pixel edge at 130, 120
    [129.5, 119.5]
    """
    if not isinstance(board, cv2.aruco.CharucoBoard):
        raise TypeError(f"board must be a cv2.aruco.CharucoBoard, got {type(board).__name__}")
    if not isinstance(min_corners, (int, np.integer)) or isinstance(min_corners, bool) or min_corners < 1:
        raise ValueError(f"min_corners must be a positive integer, got {min_corners!r}")
    grey = to_grey(image, value_range)
    u8 = np.clip(np.rint(grey), 0, 255).astype(np.uint8)
    detector = cv2.aruco.CharucoDetector(board)
    if markers:
        corners, ids, _, _ = detector.detectBoard(u8, markerCorners=markers[0][0], markerIds=markers[0][1])
    else:
        corners, ids, found, found_ids = detector.detectBoard(u8)
        if markers is not None:
            markers.append((found, found_ids))
    if corners is None or ids is None or len(ids) < min_corners:
        return None
    xy = corners.reshape(-1, 2).astype(np.float64)
    ids = ids.reshape(-1).astype(np.int64)
    quality = np.ones(len(xy))
    if refine:
        m = (1.0 - board.getMarkerLength() / board.getSquareLength()) / 2
        cell = cell_sizes(xy)
        cell = np.where(np.isfinite(cell), cell, 0.0)  # a corner alone: the smallest window
        half = np.maximum(2, np.rint(0.7 * m * cell)).astype(np.int64)
        xy, quality = refine_grey(grey, xy, half, np.maximum(half, 1.0).astype(np.float64))
        keep = quality > 0
        xy, ids, quality = xy[keep], ids[keep], quality[keep]
        if len(ids) < min_corners:
            return None
    nx, ny = board.getChessboardSize()
    labels = np.stack([ids % (nx - 1), ids // (nx - 1)], axis=1)
    order = np.argsort(ids, kind="stable")
    size = (nx - 1, ny - 1) if len(ids) == (nx - 1) * (ny - 1) else None
    return Board(xy[order], labels[order], quality[order], size=size, ids=ids[order], source="charuco")
