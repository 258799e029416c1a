"""One-to-one point matching, nearest pairs first, and the accuracy metrics.

Matching rule (Table 1 of the paper, and eq. 27's pairs): every pair (a, b)
with distance ``<= radius`` is a candidate; candidates are taken in order of
increasing distance and a pair is accepted when neither point is already
matched. This greedy rule is what "nearest first" means; it is deterministic
(ties broken by index) and, for well-separated points, identical to the
optimal assignment.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["Match", "GTMetrics", "candidate_pairs", "match_points", "gt_metrics"]


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


def _greedy(ia: np.ndarray, ib: np.ndarray, d: np.ndarray):
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
    """Match points ``a`` to points ``b`` one to one within ``radius``, nearest first."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 2)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 2)
    ia, ib, d = _greedy(*candidate_pairs(a, b, radius))
    return Match(ia, ib, d, len(a), len(b))


@dataclass(frozen=True)
class GTMetrics:
    """Table 1's metrics for one image (or summed over images).

    ``le`` is eq. 26: the root of the mean squared distance over matched pairs
    (NaN when nothing matched). ``sq_sum`` keeps the sum of squares so that
    metrics can be pooled over images exactly.
    """

    n_gt: int
    n_det: int
    matched: int
    missed: int
    false: int
    le: float
    precision: float
    recall: float
    f1: float
    sq_sum: float

    @staticmethod
    def from_counts(n_gt: int, n_det: int, matched: int, sq_sum: float) -> GTMetrics:
        prec = matched / n_det if n_det else 0.0
        rec = matched / n_gt if n_gt else 0.0
        f1 = 2 * prec * rec / (prec + rec) if prec + rec > 0 else 0.0
        le = float(np.sqrt(sq_sum / matched)) if matched else float("nan")
        return GTMetrics(n_gt, n_det, matched, n_gt - matched, n_det - matched, le, prec, rec, f1,
                         float(sq_sum))

    def __add__(self, other: GTMetrics) -> GTMetrics:
        return GTMetrics.from_counts(self.n_gt + other.n_gt, self.n_det + other.n_det,
                                     self.matched + other.matched, self.sq_sum + other.sq_sum)

    def as_dict(self) -> dict:
        d = asdict(self)
        d.pop("sq_sum")
        return d


def gt_metrics(gt: np.ndarray, det: np.ndarray, delta: float = 2.0) -> GTMetrics:
    """Missed, false, Le (eq. 26), precision, recall and F1 of detections ``det`` against ``gt``."""
    m = match_points(gt, det, delta)
    return GTMetrics.from_counts(m.n_a, m.n_b, len(m), float(np.sum(m.dist**2)))
