"""The chessboard target of the calibration renderer (:mod:`.render` has the maths); its camera is
:class:`sogdd.calib.cameras.Camera`, the one camera model of calibration and evaluation."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...calib.cameras import Camera, pose_matrix
from .raster import dot_printed

__all__ = ["Camera", "ChessboardTarget", "pose_matrix", "in_frame"]


@dataclass(frozen=True)
class ChessboardTarget:
    """A chessboard of ``cols x rows`` inner corners (OpenCV's ``patternSize``) and squares of ``square``.

    Inner corner ``(i, j)`` is at ``(i square, j square, 0)``; square ``(a, b)``, ``a = 0..cols``,
    ``b = 0..rows``, covers ``[(a - 1) square, a square] x [(b - 1) square, b square]`` and is dark
    when ``a + b`` is even. The outermost squares are ``edge`` cells wide (the paper's edge cuts
    them): the squares cover ``[-e, (cols - 1) square + e] x [-e, (rows - 1) square + e]`` with
    ``e = edge square``; ``edge = 1`` is the full board. A white margin of ``margin`` surrounds them
    (None: one square for a full board, none when ``edge < 1``: the cut is the paper's edge).

    ``dots = g > 0`` prints a ``g x g`` matrix of dark square dots of side ``dot`` cells in every
    white square bounded by inner corners on all four sides (``1 <= a <= cols - 1``,
    ``1 <= b <= rows - 1``), ECoCheck-like: the matrix spans the square's central 0.6 cell, so the
    dots keep 0.2 of a cell clear of its edges and corners; dot ``(kx, ky)`` is centred at
    ``(0.2 + dot / 2 + k pitch) square`` from the square's low edges, ``pitch = (0.6 - dot) / (g - 1)``,
    and printed or not by a fixed hash of ``(a, b, kx, ky)`` (:meth:`dot_centres`).

    Examples
    --------
    >>> t = ChessboardTarget(3, 2, 10.0)
    >>> t.labels().tolist()
    [[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1]]
    >>> t.object_points()[-1].tolist()
    [20.0, 10.0, 0.0]
    >>> cut = ChessboardTarget(3, 2, 10.0, edge=0.4)
    >>> cut.margin, cut.squares_extent()
    (0.0, (-4.0, 24.0, -4.0, 14.0))
    """

    cols: int
    rows: int
    square: float = 1.0
    margin: float | None = None
    edge: float = 1.0
    dots: int = 0
    dot: float = 0.12

    def __post_init__(self) -> None:
        if int(self.cols) < 1 or int(self.rows) < 1:
            raise ValueError(f"a chessboard needs >= 1 inner corner each way, got {self.cols} x {self.rows}")
        if not (self.square > 0 and math.isfinite(self.square)):
            raise ValueError(f"square must be positive, got {self.square}")
        if not 0 < self.edge <= 1:
            raise ValueError(f"edge must be in (0, 1] (a fraction of a cell), got {self.edge}")
        if int(self.dots) < 0 or (int(self.dots) > 0 and not 0 < self.dot * self.dots < 0.6):
            raise ValueError(f"dots must be >= 0 and dots x dot < 0.6 (the matrix's span), got {self.dots} "
                             f"dots of {self.dot}")
        m = (self.square if self.edge == 1 else 0.0) if self.margin is None else float(self.margin)
        if not (m >= 0 and math.isfinite(m)):
            raise ValueError(f"margin must be >= 0, got {self.margin}")
        object.__setattr__(self, "cols", int(self.cols))
        object.__setattr__(self, "rows", int(self.rows))
        object.__setattr__(self, "square", float(self.square))
        object.__setattr__(self, "margin", m)
        object.__setattr__(self, "edge", float(self.edge))
        object.__setattr__(self, "dots", int(self.dots))
        object.__setattr__(self, "dot", float(self.dot))

    @property
    def pattern_size(self) -> tuple[int, int]:
        return (self.cols, self.rows)

    def labels(self) -> np.ndarray:
        """``(i, j)`` of every inner corner (N, 2) int64, ``i`` fastest (OpenCV's order)."""
        j, i = np.mgrid[0:self.rows, 0:self.cols]
        return np.stack([i.ravel(), j.ravel()], axis=1).astype(np.int64)

    def object_points(self) -> np.ndarray:
        """Board coordinates (N, 3) of the inner corners, in :meth:`labels`' order."""
        out = np.zeros((self.cols * self.rows, 3))
        out[:, :2] = self.labels() * self.square
        return out

    def squares_extent(self) -> tuple[float, float, float, float]:
        """``(u0, u1, v0, v1)``: the squares cover ``[u0, u1] x [v0, v1]`` (class doc)."""
        e = self.edge * self.square
        return (-e, (self.cols - 1) * self.square + e, -e, (self.rows - 1) * self.square + e)

    def dot_centres(self) -> np.ndarray:
        """Board coordinates ``(u, v)`` (M, 2) of the printed dots' centres (none without ``dots``).

        Which are printed is the renderer's own choice (:func:`.raster.dot_printed`).
        """
        g, sq = self.dots, self.square
        if g == 0:
            return np.zeros((0, 2))
        d = self.dot
        pitch = (0.6 - d) / max(g - 1, 1)
        out = []
        for a in range(1, self.cols):
            for b in range(1, self.rows):
                if (a + b) % 2 == 0:
                    continue
                for kx in range(g):
                    for ky in range(g):
                        if dot_printed(a, b, kx, ky):
                            out.append(((a - 1 + 0.2 + d / 2 + kx * pitch) * sq,
                                        (b - 1 + 0.2 + d / 2 + ky * pitch) * sq))
        return np.array(out, dtype=np.float64).reshape(-1, 2)

    def outline(self, with_margin: bool = False, per_side: int = 16) -> np.ndarray:
        """Points (4 per_side, 3) along the squares' (or the paper's) outer edge."""
        m = self.margin if with_margin else 0.0
        if self.edge == 1:
            # the full board's expressions as they were, so that the poses drawn with them are unchanged
            s = self.square
            u0, u1, v0, v1 = -s - m, self.cols * s + m, -s - m, self.rows * s + m
        else:
            e0, e1, f0, f1 = self.squares_extent()
            u0, u1, v0, v1 = e0 - m, e1 + m, f0 - m, f1 + m
        t = np.linspace(0.0, 1.0, per_side, endpoint=False)
        sides = [np.stack([u0 + (u1 - u0) * t, np.full_like(t, v0)], 1),
                 np.stack([np.full_like(t, u1), v0 + (v1 - v0) * t], 1),
                 np.stack([u1 - (u1 - u0) * t, np.full_like(t, v1)], 1),
                 np.stack([np.full_like(t, u0), v1 - (v1 - v0) * t], 1)]
        uv = np.concatenate(sides)
        return np.concatenate([uv, np.zeros((len(uv), 1))], axis=1)

def in_frame(corners: np.ndarray, size: tuple[int, int], border: float) -> np.ndarray:
    """Whether each point (N, 2) is finite and at least ``border`` px inside a frame of ``size`` (w, h)."""
    w, h = size
    with np.errstate(invalid="ignore"):
        return (np.all(np.isfinite(corners), axis=1) & (corners[:, 0] >= border) & (corners[:, 1] >= border)
                & (corners[:, 0] <= w - 1 - border) & (corners[:, 1] <= h - 1 - border))
