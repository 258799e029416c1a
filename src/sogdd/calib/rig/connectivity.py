"""Which cameras of a rig see the board in the same frames: each pair's shared frames, and the groups.

The joint fit (:func:`~sogdd.calib.rig.calibrate_rig`) places each camera relative to
the first through the frames in which it and another camera both saw the board: a
frame seen by cameras ``a`` and ``b`` ties ``a``'s pose to ``b``'s. Cameras are
*connected* when every camera reaches the first through such ties (the graph whose
edges are the pairs that share a frame has a single component). Cameras in groups
that no frame ties together have no common frame: their relative poses are undefined.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

from ..targets.board import Board

__all__ = ["Connectivity", "rig_connectivity"]


@dataclass(frozen=True)
class Connectivity:
    """How the frames tie the cameras of a rig together (the result of :func:`rig_connectivity`).

    Attributes
    ----------
    names : tuple of str
        The cameras, the first one the rig's reference.
    frames : (C, C) int64
        ``frames[a, b]``: how many frames cameras ``a`` and ``b`` both saw the board in; on the
        diagonal, how many frames each camera saw it in.
    corners : (C, C) int64
        ``corners[a, b]``: over those frames, the corners of the sparser of the two views,
        :math:`\\sum_f \\min(n_{af}, n_{bf})` (``n_{af}`` camera ``a``'s corners in frame ``f``);
        on the diagonal, each camera's corners.
    components : tuple of tuple of str
        The groups of cameras the shared frames tie together (the connected components of the
        graph of pairs that share a frame), each in the order of ``names``, the first camera's
        group first.
    """

    names: tuple[str, ...]
    frames: np.ndarray
    corners: np.ndarray
    components: tuple[tuple[str, ...], ...]

    @classmethod
    def from_counts(cls, names: Sequence[str], counts: np.ndarray) -> Connectivity:
        """The connectivity of cameras ``names`` from their corners per frame, ``counts`` (C, F): 0
        where a camera did not see the board.

        Examples
        --------
        >>> con = Connectivity.from_counts(["a", "b", "c"], np.array([[54, 20, 0], [54, 0, 0], [0, 0, 30]]))
        >>> con.frames.tolist(), con.components
        ([[2, 1, 0], [1, 1, 0], [0, 0, 1]], (('a', 'b'), ('c',)))
        """
        n = np.asarray(counts, dtype=np.int64)
        seen = (n > 0).astype(np.int64)
        frames = seen @ seen.T
        C = len(n)
        corners = np.array([np.minimum(row, n).sum(axis=1) for row in n], dtype=np.int64).reshape(C, C)
        k, label = connected_components(csr_matrix(frames > 0), directed=False)
        names = tuple(str(x) for x in names)
        # the groups in the order of their first camera: the reference's group first
        order = sorted(range(k), key=lambda g: int(np.flatnonzero(label == g)[0]))
        groups = tuple(tuple(names[i] for i in np.flatnonzero(label == g)) for g in order)
        return cls(names, frames, corners, groups)

    @property
    def connected(self) -> bool:
        """Whether the shared frames tie every camera to every other (one group)."""
        return len(self.components) <= 1

    def shared(self, a: str, b: str) -> tuple[int, int]:
        """``(frames, corners)`` cameras ``a`` and ``b`` share (see the attributes)."""
        i, j = self.names.index(a), self.names.index(b)
        return int(self.frames[i, j]), int(self.corners[i, j])

    @property
    def pairs(self) -> dict[tuple[str, str], tuple[int, int]]:
        """Each pair of cameras that share a frame, ``(a, b)`` in the order of ``names``, to its
        ``(frames, corners)``."""
        C = len(self.names)
        return {(self.names[i], self.names[j]): (int(self.frames[i, j]), int(self.corners[i, j]))
                for i in range(C) for j in range(i + 1, C) if self.frames[i, j] > 0}

    def problem(self) -> str:
        """One line saying which groups no frame ties together ("" when connected)."""
        if self.connected:
            return ""
        groups = ["{" + ", ".join(g) + "}" for g in self.components]
        listed = f"{', '.join(groups[:-1])} and {groups[-1]}"
        which = "both groups" if len(groups) == 2 else "cameras of two of these groups"
        return f"cameras are not connected: {listed}: no frame shows the board to {which}"


def rig_connectivity(boards: Mapping[str, Sequence[Board | None]]) -> Connectivity:
    """Which cameras share frames, from each camera's boards (one Board or None per frame).

    A pair of cameras shares frame ``f`` when both have a board in it (any number of
    corners; labels are not compared). The cameras are connected when the pairs that
    share a frame join them all (:attr:`Connectivity.components`).

    Parameters
    ----------
    boards : mapping of str to sequence of Board or None
        Per camera, one entry per frame, all of one length (as :func:`~sogdd.calib.rig.calibrate_rig`
        takes them).

    Returns
    -------
    Connectivity

    Examples
    --------
    >>> from sogdd.calib.rig.demo import synthetic_rig
    >>> d = synthetic_rig(cameras=3, frames=6, seed=0)
    >>> d.boards["cam2"] = [None] * 6
    >>> con = rig_connectivity(d.boards)
    >>> con.components, con.pairs[("cam0", "cam1")][0] > 0
    ((('cam0', 'cam1'), ('cam2',)), True)
    >>> con.problem()
    'cameras are not connected: {cam0, cam1} and {cam2}: no frame shows the board to both groups'
    """
    names = list(boards)
    lists = [list(boards[n]) for n in names]
    F = max((len(b) for b in lists), default=0)
    if any(len(b) != F for b in lists):
        raise ValueError("every camera needs one entry (a Board or None) per frame")
    counts = np.array([[0 if b is None else len(b) for b in bs] for bs in lists], dtype=np.int64).reshape(-1, F)
    return Connectivity.from_counts(names, counts)
