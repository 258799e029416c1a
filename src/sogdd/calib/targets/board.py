"""The result of board detection: image points with integer board labels."""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

__all__ = ["LABEL_TURNS", "SMALL_CELL", "Board", "ViewBoards", "cell_size", "grid_dims", "label_neighbours",
           "lattice_cells", "median", "parse_grid", "view_board"]


#: a board whose median cell is under this fraction of that of its image's largest board is never a view:
#: the targets of one scene lie at comparable distances (a third is one three times as far), while a
#: screen, a reflection or a background pattern taken for the board is about ten times smaller, and its
#: coarse corners and ill-determined pose pull the camera off
SMALL_CELL = Fraction(1, 3)

#: the four quarter turns of a board's label grid, ``labels @ T.T`` (identity, then a quarter turn at a time)
LABEL_TURNS = (np.array([[1, 0], [0, 1]]), np.array([[0, -1], [1, 0]]), np.array([[-1, 0], [0, -1]]),
               np.array([[0, 1], [-1, 0]]))


@dataclass(frozen=True)
class Board:
    """A calibration board seen in one image: its corners, labelled on the board's lattice.

    Attributes
    ----------
    image_points : (N, 2) float64
        Corner positions, ``x`` (column) and ``y`` (row), pixel centres at
        integers (OpenCV's convention).
    labels : (N, 2) int64
        Each corner's lattice label ``(i, j)``: ``i`` counts along the board's
        first axis, ``j`` along its second, and the frame ``(i, j, 0)`` is
        right-handed with the board's normal pointing away from the camera
        (so that ``i`` runs left to right and ``j`` top to bottom for a board
        seen face on and upright, like OpenCV's ``patternSize`` order).
        Labels start at 0 for a complete board of known size; for a partial
        board or one of unknown size they are relative to an arbitrary corner
        but consistent within the view.
    quality : (N,) float64
        Per-corner quality in ``[0, 1]`` (1 is best).
    size : tuple of int or None
        ``(columns, rows)`` of inner corners when the board's size is known and
        its corners span the whole pattern, so that the labels are absolute (a
        corner inside may still be missing: ``len(board) < columns * rows``);
        else None.
    outline : (M, 2) float64
        A polygon around the detected corners, in image coordinates.
    ids : (N,) int64 or None
        Absolute corner IDs (ChArUco), when the board carries them.
    source : str
        Which detector proposed the board: ``"sogdd"`` (its own search),
        ``"opencv"`` or ``"opencv-sb"`` (OpenCV's detectors as a second source,
        :mod:`sogdd.calib.targets.chessboard.proposals`), ``"charuco"``. Its corners are
        measured and checked by sogdd whatever the source.
    precision : (N,) float64 or None
        Each corner's measured 1-sigma position uncertainty in px: the square
        root of the largest eigenvalue of its covariance ``C`` under the
        image's noise (:func:`sogdd.calib.targets.refine.corner_covariance`,
        filled in by :func:`sogdd.calib.targets.precision.with_precision`), the
        standard deviation along the corner's least precise direction (a
        motion-blurred corner is imprecise along the motion only; this is that
        direction's). NaN for a corner whose precision could not be measured;
        None (the default) when unknown for the whole board.

    Examples
    --------
    >>> b = Board(np.array([[10.0, 20.0], [30.0, 20.0]]), np.array([[0, 0], [1, 0]]))
    >>> b.object_points(25.0).tolist()
    [[0.0, 0.0, 0.0], [25.0, 0.0, 0.0]]
    >>> len(b), b.quality.tolist(), b.precision
    (2, [1.0, 1.0], None)
    """

    image_points: np.ndarray
    labels: np.ndarray
    quality: np.ndarray = field(default=None)  # type: ignore[assignment]
    size: tuple[int, int] | None = None
    outline: np.ndarray = field(default=None)  # type: ignore[assignment]
    ids: np.ndarray | None = None
    source: str = "sogdd"
    precision: np.ndarray | None = None

    def __post_init__(self) -> None:
        pts = np.asarray(self.image_points, dtype=np.float64).reshape(-1, 2)
        lab = np.asarray(self.labels, dtype=np.int64).reshape(-1, 2)
        if len(lab) != len(pts):
            raise ValueError(f"{len(pts)} image points but {len(lab)} labels")
        n = len(pts)
        q = np.ones(n) if self.quality is None else np.asarray(self.quality, dtype=np.float64).reshape(-1)
        if len(q) != n:
            raise ValueError(f"{n} image points but {len(q)} quality values")
        outline = self.outline
        if outline is None:
            outline = _hull(pts)
        object.__setattr__(self, "image_points", pts)
        object.__setattr__(self, "labels", lab)
        object.__setattr__(self, "quality", q)
        object.__setattr__(self, "outline", np.asarray(outline, dtype=np.float64).reshape(-1, 2))
        if self.ids is not None:
            object.__setattr__(self, "ids", np.asarray(self.ids, dtype=np.int64).reshape(-1))
        if self.precision is not None:
            sigma = np.asarray(self.precision, dtype=np.float64).reshape(-1)
            if len(sigma) != n:
                raise ValueError(f"{n} image points but {len(sigma)} precision values")
            if np.any(sigma[np.isfinite(sigma)] < 0) or np.any(np.isinf(sigma)):
                raise ValueError("precision must be standard deviations >= 0 (px), or NaN where unknown")
            object.__setattr__(self, "precision", sigma)

    @functools.cached_property
    def cell(self) -> float:
        """:func:`cell_size`, computed once: a board is ranked against others several times in a search
        (its fields are fixed, so the cached value stays its)."""
        return cell_size(self)

    def __len__(self) -> int:
        return len(self.image_points)

    def object_points(self, square: float = 1.0) -> np.ndarray:
        """Board coordinates ``(i * square, j * square, 0)`` of the corners, (N, 3) float64."""
        out = np.zeros((len(self), 3))
        out[:, :2] = self.labels * float(square)
        return out


def _hull(pts: np.ndarray) -> np.ndarray:
    if len(pts) < 3:
        return pts.copy()
    import cv2

    return cv2.convexHull(pts.astype(np.float32)).reshape(-1, 2).astype(np.float64)


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


@dataclass(frozen=True)
class ViewBoards:
    """A view's boards of the kind asked for and, where there is none, what the view shows instead.

    ``boards`` as the kind's detector returns them; ``seen`` says in a few
    words what the detector found where no board matched ("" when one did);
    ``other_size`` is the (columns, rows) of a complete board of another size
    than the one asked for, seen and ignored.
    """

    boards: tuple[Board, ...]
    seen: str = ""
    other_size: tuple[int, int] | None = None


def parse_grid(text: str) -> tuple[int, int] | None:
    """``COLSxROWS`` of a board specification as two integers, or None when the text is not of that form.

    Examples
    --------
    >>> parse_grid("9x6"), parse_grid("9X6"), parse_grid("9 x 6")
    ((9, 6), (9, 6), None)
    """
    m = re.fullmatch(r"(\d+)[xX](\d+)", text)
    return (int(m.group(1)), int(m.group(2))) if m else None


def cell_size(board: Board) -> float:
    """The board's median cell side in px: the median distance between corners whose labels are neighbours
    (NaN without any).

    Examples
    --------
    >>> b = Board(np.array([[0.0, 0], [10, 0], [0, 12], [10, 12]]), np.array([[0, 0], [1, 0], [0, 1], [1, 1]]))
    >>> cell_size(b)
    11.0
    """
    nb = label_neighbours(board.labels)[:, ::2]  # the (+1, 0) and (0, +1) neighbours: each pair once
    k, d = np.nonzero(nb >= 0)
    pts = board.image_points
    return median(np.hypot(*(pts[nb[k, d]] - pts[k]).T)) if len(k) else float("nan")


def view_board(boards: Sequence[Board]) -> Board | None:
    """The image's board, of several: the largest in the image, complete first, then the most corners.

    A board whose cells (:func:`cell_size`) are under :data:`SMALL_CELL` of
    the largest board's is a screen, a reflection or a pattern in the
    background: never the view's board, even complete where the view's own is
    cut by an occluder or the frame. Of the others, ``(B.size is not None,
    len(B), cell_size(B))`` decides: of two complete boards, the one of larger cells.

    Examples
    --------
    >>> grid = np.array([(i, j) for j in range(4) for i in range(6)])
    >>> screen = Board(grid * 4.0, grid, size=(6, 4))
    >>> cut = Board(grid[:20] * 40.0, grid[:20])  # the view's board, a hand over four corners
    >>> view_board([screen, cut]) is cut
    True
    >>> near = Board(grid * 6.0, grid, size=(6, 4))  # complete too, cells of 6 px
    >>> view_board([screen, near]) is near
    True
    """
    cells = [b.cell for b in boards]
    largest = max((c for c in cells if np.isfinite(c)), default=float("nan"))
    keep = [k for k, c in enumerate(cells) if not c < SMALL_CELL * largest]
    if not keep:
        return None
    rank = [(b.size is not None, len(b), 0.0 if math.isnan(c) else c) for b, c in zip(boards, cells)]
    return boards[max(keep, key=rank.__getitem__)]


def lattice_cells(xy: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """Each corner's distance (px) to its nearest 4-neighbour on the board's lattice; inf with none.

    The local cell, as the board's own labels define it (unlike
    :func:`~sogdd.calib.targets.refine.cell_sizes`, the nearest other point,
    which a corner across a gap or a foreshortened diagonal could be).

    Examples
    --------
    >>> lattice_cells(np.array([[0.0, 0], [10, 0], [30, 5]]), np.array([[0, 0], [1, 0], [5, 5]])).tolist()
    [10.0, 10.0, inf]
    """
    pts = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    nb = label_neighbours(labels)
    d = np.hypot(*(pts[nb] - pts[:, None]).transpose(2, 0, 1))
    return np.where(nb >= 0, d, np.inf).min(axis=1, initial=np.inf)


def label_neighbours(labels: np.ndarray) -> np.ndarray:
    """(N, 4) index of each corner's neighbour on the lattice at label ``(+1, 0)``, ``(-1, 0)``, ``(0, +1)``,
    ``(0, -1)``; -1 where there is none.

    Examples
    --------
    >>> label_neighbours(np.array([[0, 0], [1, 0], [0, 1]])).tolist()
    [[1, -1, 2, -1], [-1, 0, -1, -1], [-1, -1, -1, 0]]
    """
    lab = np.asarray(labels, dtype=np.int64).reshape(-1, 2)
    if not len(lab):
        return np.zeros((0, 4), np.int64)
    ij = lab - lab.min(axis=0) + 1  # a border of one empty label each side
    grid = np.full(ij.max(axis=0) + 2, -1, np.int64)
    grid[ij[:, 0], ij[:, 1]] = np.arange(len(lab))
    return grid[ij[:, :1] + _STEPS[:, 0], ij[:, 1:] + _STEPS[:, 1]]  # one gather: it runs several times a view


#: :func:`label_neighbours`' label steps, in its column order
_STEPS = np.array([(1, 0), (-1, 0), (0, 1), (0, -1)])


def median(values: np.ndarray) -> float:
    """``float(np.median(values))`` of a 1-D array, without its overhead (it runs many times a view).

    The middle value of the sorted values, or the mean ``(a + b) / 2`` of the middle two in the values'
    own dtype (float32's sum is float32's), as numpy's; NaN when a value is NaN or there is none.

    Examples
    --------
    >>> median(np.array([3.0, 1.0, 2.0])), median(np.array([4.0, 1.0, 2.0, 3.0]))
    (2.0, 2.5)
    >>> median(np.array([1.0, np.nan]))
    nan
    """
    v = np.sort(np.asarray(values).reshape(-1))
    n = len(v)
    if n == 0 or np.isnan(v[-1]):  # NaN sorts last
        return float("nan")
    m = n // 2
    return float(v[m]) if n % 2 else float((v[m - 1] + v[m]) / 2)
