"""One-to-one point matching, nearest pairs first: shared by every evaluation.

Matching rule (Table 1 of the paper, and eq. 27's pairs): every pair (a, b)
with distance ``<= radius`` is a candidate; candidates are taken in order of
increasing distance and a pair is accepted when neither point is already
matched. This greedy rule is what "nearest first" means; it is deterministic
(ties broken by index) and, for well-separated points, identical to the
optimal assignment.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["Match", "candidate_pairs", "greedy", "match_points"]


@dataclass(frozen=True)
class Match:
    """Result of :func:`match_points`: index pairs ``(i_a, i_b)`` and their distances."""

    ia: np.ndarray
    ib: np.ndarray
    dist: np.ndarray
    n_a: int
    n_b: int

    def __len__(self) -> int:
        return len(self.ia)

    @property
    def unmatched_a(self) -> np.ndarray:
        return np.setdiff1d(np.arange(self.n_a), self.ia)

    @property
    def unmatched_b(self) -> np.ndarray:
        return np.setdiff1d(np.arange(self.n_b), self.ib)


def candidate_pairs(a: np.ndarray, b: np.ndarray, radius: float):
    """All pairs within ``radius``, sorted by distance: ``(ia, ib, dist)``."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 2)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 2)
    if len(a) == 0 or len(b) == 0:
        e = np.zeros(0, dtype=np.int64)
        return e, e, np.zeros(0)
    lists = cKDTree(a).query_ball_tree(cKDTree(b), r=float(radius) + 1e-12)
    ia = np.fromiter((i for i, js in enumerate(lists) for _ in js), dtype=np.int64)
    ib = np.fromiter((j for js in lists for j in js), dtype=np.int64)
    d = np.hypot(*(a[ia] - b[ib]).T) if len(ia) else np.zeros(0)
    keep = d <= radius
    ia, ib, d = ia[keep], ib[keep], d[keep]
    order = np.lexsort((ib, ia, d))
    return ia[order], ib[order], d[order]


def greedy(ia: np.ndarray, ib: np.ndarray, d: np.ndarray):
    """Accept candidate pairs in the given order unless one of their points is already matched."""
    used_a: set[int] = set()
    used_b: set[int] = set()
    keep = []
    for k, (i, j) in enumerate(zip(ia.tolist(), ib.tolist())):
        if i in used_a or j in used_b:
            continue
        used_a.add(i)
        used_b.add(j)
        keep.append(k)
    keep_arr = np.asarray(keep, dtype=np.int64)
    return ia[keep_arr], ib[keep_arr], d[keep_arr]


def match_points(a: np.ndarray, b: np.ndarray, radius: float) -> Match:
    """Match points ``a`` to points ``b`` one to one within ``radius``, nearest first.

    Examples
    --------
    >>> m = match_points([[0, 0], [10, 0]], [[0.5, 0], [0.2, 0], [30, 0]], radius=2.0)
    >>> m.ia.tolist(), m.ib.tolist(), m.unmatched_b.tolist()
    ([0], [1], [0, 2])
    """
    a = np.asarray(a, dtype=np.float64).reshape(-1, 2)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 2)
    ia, ib, d = greedy(*candidate_pairs(a, b, radius))
    return Match(ia, ib, d, len(a), len(b))
