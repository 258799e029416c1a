"""Table 1's metrics: missed, false, Le (eq. 26), precision, recall, F1.

Detections are matched to GT corners one to one, nearest first
(:func:`sogdd.evaluation.points.match_points`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..points import match_points

__all__ = ["GTMetrics", "gt_metrics"]


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
