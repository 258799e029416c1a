"""ChArUco boards: OpenCV finds the markers and the corners' IDs, sogdd measures the corners.

``cv2.aruco.CharucoDetector`` decodes the markers and interpolates the
chessboard corners between them, with absolute IDs; each corner is then
re-measured by :func:`sogdd.calib.refine_corners`. A ChArUco corner is point
symmetric only up to the markers: its two light squares hold different markers,
which start ``m = (1 - markerLength / squareLength) / 2`` of a square from the
corner along both axes. The window's half-width is therefore ``0.7 m`` of the
local square (``0.7 < 1 / sqrt 2``: a window turned by 45 degrees stays clear of
the markers too), at least 2 px.

Labels: corner ID ``k`` is ``(k % (nx - 1), k // (nx - 1))`` for a board of
``nx x ny`` squares (OpenCV's order: along the first row of the generated image,
then the next), right-handed as :class:`~sogdd.calib.Board` wants.
"""

from __future__ import annotations

import cv2
import numpy as np

from .board import Board
from .refine import cell_sizes, refine_grey
from .xcorners import to_grey

__all__ = ["detect_charuco"]


def detect_charuco(image: np.ndarray, board: cv2.aruco.CharucoBoard, *, refine: bool = True,
                   min_corners: int = 4, value_range: tuple[float, float] | None = None) -> Board | None:
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
    corners, ids, _, _ = cv2.aruco.CharucoDetector(board).detectBoard(u8)
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
