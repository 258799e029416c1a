"""Fair threshold tuning, applied identically to every detector.

Procedure
---------
1. Run the detector once with its strength threshold off
   (:func:`~sogdd.evaluation.specs.permissive_detections`) and sort the
   detections by ``response``, strongest first.
2. Every distinct response value ``t`` is an operating point: the detector's
   output at threshold ``t`` is the detections with ``response >= t`` (ties
   are kept or dropped together). :func:`sweep_curve` evaluates all of them
   exactly, for the GT protocol of Table 1.
3. The chosen operating point minimises ``missed + false``; ties are broken
   by the lower localisation error Le, then by the higher threshold.

Per image, step 3 is applied to each image alone (the paper's "properly
tuned to achieve its best test results": optimistic, it sees the answer). The
*joint* threshold applies step 3 to the sums over all images, with one
threshold per detector (:func:`joint_tuning`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..points import candidate_pairs, greedy
from .metrics import GTMetrics

__all__ = ["SweepCurve", "sweep_curve", "best_point", "joint_tuning"]


@dataclass(frozen=True)
class SweepCurve:
    """GT metrics at every operating point of one detector on one image.

    ``k[i]`` detections are kept at threshold ``threshold[i]`` (``inf`` for
    ``k = 0``); ``matched`` and ``sq_sum`` (sum of squared matched distances)
    give every metric through :meth:`metrics`.
    """

    n_gt: int
    k: np.ndarray
    threshold: np.ndarray
    matched: np.ndarray
    sq_sum: np.ndarray
    responses: np.ndarray

    @property
    def cost(self) -> np.ndarray:
        """missed + false at every operating point."""
        return (self.n_gt - self.matched) + (self.k - self.matched)

    @property
    def le(self) -> np.ndarray:
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.matched > 0, np.sqrt(self.sq_sum / np.maximum(self.matched, 1)),
                            np.nan)

    def metrics(self, i: int) -> GTMetrics:
        return GTMetrics.from_counts(self.n_gt, int(self.k[i]), int(self.matched[i]),
                                     float(self.sq_sum[i]))


def sweep_curve(gt: np.ndarray, xy: np.ndarray, response: np.ndarray, delta: float = 2.0
                ) -> SweepCurve:
    """Exact GT metrics for every threshold on ``response`` (detections sorted strongest first).

    Only detections within ``delta`` of some GT corner can change the matching,
    so the greedy matching is recomputed only when such a detection enters;
    between those events every added detection is a false corner.
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    r = np.asarray(response, dtype=np.float64).reshape(-1)
    if len(r) > 1 and np.any(np.diff(r) > 0):
        raise ValueError("detections must be sorted by decreasing response")
    n = len(r)
    ia, ib, d = candidate_pairs(gt, xy, delta)
    matched_at = np.zeros(n + 1, dtype=np.int64)
    sq_at = np.zeros(n + 1)
    events = np.unique(ib) + 1  # k at which a candidate detection enters
    last_k, last_m, last_s = 0, 0, 0.0
    for k in events:
        matched_at[last_k:k] = last_m
        sq_at[last_k:k] = last_s
        sel = ib < k
        _, _, dd = greedy(ia[sel], ib[sel], d[sel])
        last_k, last_m, last_s = int(k), len(dd), float(np.sum(dd**2))
    matched_at[last_k:] = last_m
    sq_at[last_k:] = last_s
    # operating points: k = 0 and every k after which the response strictly drops
    ks = np.arange(n + 1)
    valid = np.ones(n + 1, dtype=bool)
    if n:
        valid[1:n] = r[: n - 1] > r[1:n]
    ks = ks[valid]
    thr = np.concatenate([[np.inf], r])[ks]
    return SweepCurve(len(np.asarray(gt).reshape(-1, 2)), ks, thr, matched_at[ks], sq_at[ks], r)


def _argbest(cost: np.ndarray, le: np.ndarray, thr: np.ndarray) -> int:
    le_key = np.where(np.isfinite(le), le, np.inf)
    order = np.lexsort((-thr, le_key, cost))
    return int(order[0])


def best_point(curve: SweepCurve) -> int:
    """Index of the operating point minimising missed + false (ties: lower Le, higher threshold)."""
    return _argbest(curve.cost, curve.le, curve.threshold)


def joint_tuning(curves: list[SweepCurve]) -> tuple[float, list[int]]:
    """One threshold for all images: minimise the summed missed + false, ties by pooled Le.

    Returns the threshold and, per curve, the index of its operating point.
    """
    cands = np.unique(np.concatenate([[np.inf]] + [c.responses for c in curves]))[::-1]
    total_cost = np.zeros(len(cands))
    total_m = np.zeros(len(cands))
    total_sq = np.zeros(len(cands))
    idx_all = []
    for c in curves:
        # k(t) = number of responses >= t; responses are sorted decreasing
        k = np.searchsorted(-c.responses, -cands, side="right")
        idx = np.searchsorted(c.k, k)
        idx_all.append(idx)
        total_cost += c.cost[idx]
        total_m += c.matched[idx]
        total_sq += c.sq_sum[idx]
    with np.errstate(invalid="ignore", divide="ignore"):
        le = np.where(total_m > 0, np.sqrt(total_sq / np.maximum(total_m, 1)), np.nan)
    b = _argbest(total_cost, le, cands)
    return float(cands[b]), [int(ix[b]) for ix in idx_all]
