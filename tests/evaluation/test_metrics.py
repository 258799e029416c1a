"""GT metrics, matching and threshold tuning on cases known by construction."""

import math

import numpy as np
import pytest

from sogdd.evaluation.gt.metrics import gt_metrics
from sogdd.evaluation.gt.tuning import best_point, joint_tuning, sweep_curve
from sogdd.evaluation.points import match_points


@pytest.fixture
def gt(rng):
    # well separated points (grid with jitter), so matches are unambiguous
    g = np.stack(np.meshgrid(np.arange(5) * 20.0, np.arange(4) * 20.0), -1).reshape(-1, 2)
    return g + rng.uniform(-2, 2, g.shape)


def test_perfect(gt):
    m = gt_metrics(gt, gt.copy(), 2.0)
    assert (m.missed, m.false, m.matched) == (0, 0, len(gt))
    assert m.le == 0 and m.precision == m.recall == m.f1 == 1.0


def test_shifted_by_one_pixel(gt, rng):
    ang = rng.uniform(0, 2 * np.pi, len(gt))
    det = gt + np.stack([np.cos(ang), np.sin(ang)], 1)
    m = gt_metrics(gt, det, 2.0)
    assert m.missed == 0 and m.false == 0
    assert m.le == pytest.approx(1.0)
    # beyond delta everything is missed and false
    m2 = gt_metrics(gt, gt + [2.5, 0], 2.0)
    assert (m2.missed, m2.false) == (len(gt), len(gt)) and math.isnan(m2.le)


def test_missing_and_extra_points(gt):
    det = np.concatenate([gt[3:], [[500.0, 500.0], [600.0, 10.0]]])
    m = gt_metrics(gt, det, 2.0)
    assert (m.missed, m.false, m.matched) == (3, 2, len(gt) - 3)
    assert m.precision == pytest.approx((len(gt) - 3) / len(det))
    assert m.recall == pytest.approx((len(gt) - 3) / len(gt))


def test_one_to_one_nearest_first():
    gt = np.array([[0.0, 0.0]])
    det = np.array([[1.5, 0.0], [0.5, 0.0]])
    m = match_points(gt, det, 2.0)
    assert len(m) == 1 and m.ib[0] == 1  # the nearer detection wins
    # two GT corners competing for one detection: only one match
    m = match_points(np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([[0.8, 0.0]]), 2.0)
    assert len(m) == 1 and m.ia[0] == 1


def test_sweep_curve_equals_rerun(gt, rng):
    # detections: the GT jittered plus clutter, with random responses
    det = np.concatenate([gt + rng.normal(0, 0.7, gt.shape), rng.uniform(0, 100, (40, 2))])
    resp = rng.uniform(1, 10, len(det))
    order = np.argsort(-resp)
    det, resp = det[order], resp[order]
    curve = sweep_curve(gt, det, resp, 2.0)
    for i in range(0, len(curve.k), 7):
        t = curve.threshold[i]
        direct = gt_metrics(gt, det[resp >= t], 2.0)
        got = curve.metrics(i)
        assert (got.matched, got.missed, got.false) == (direct.matched, direct.missed,
                                                        direct.false)
        assert got.sq_sum == pytest.approx(direct.sq_sum)
    b = best_point(curve)
    costs = curve.cost
    assert costs[b] == costs.min()


def test_tuning_picks_the_separating_threshold(gt, rng):
    # true corners strong, clutter weak: the best threshold keeps exactly the true ones
    clutter = rng.uniform(0, 100, (30, 2)) + 300
    det = np.concatenate([gt, clutter])
    resp = np.concatenate([rng.uniform(5, 10, len(gt)), rng.uniform(0, 4, len(clutter))])
    order = np.argsort(-resp)
    curve = sweep_curve(gt, det[order], resp[order], 2.0)
    b = best_point(curve)
    assert curve.cost[b] == 0 and curve.k[b] == len(gt)
    t, idx = joint_tuning([curve, curve])
    assert curve.k[idx[0]] == len(gt) and 4 < t <= 10


def test_ties_in_response_move_together():
    gt = np.array([[0.0, 0.0]])
    det = np.array([[0.0, 0.0], [50.0, 50.0]])
    curve = sweep_curve(gt, det, np.array([1.0, 1.0]), 2.0)
    assert list(curve.k) == [0, 2]
