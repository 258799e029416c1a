"""The evaluation protocols' constants and definitions, pinned.

Le (eq. 26) is a root mean square; the GT match radius delta is 2 px; the
repeatability radius is 4 px; the chessboard benchmark counts a hit within 1 px
and locates a corner within half a cell. Each test uses distances on both sides
of the constant, and shifts other than 1 px (where a mean square, an RMS and a
mean are all 1).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sogdd.evaluation.chessboard.metrics import RADIUS, score_image
from sogdd.evaluation.gt.metrics import gt_metrics
from sogdd.evaluation.gt.protocol import evaluate_gt
from sogdd.evaluation.gt.tuning import joint_tuning, sweep_curve
from sogdd.evaluation.repeatability.protocol import evaluate_repeatability, pair_repeatability

GT = np.array([[10.0, 10.0], [40.0, 10.0], [10.0, 40.0], [40.0, 40.0]])
#: detections 0.5, 1.5, 0.5 and 1.5 px off: Le = RMS = sqrt(1.25) = 1.118 (mean square 1.25, mean 1.0)
SHIFTED = GT + np.array([[0.5, 0.0], [0.0, 1.5], [-0.3, 0.4], [0.9, -1.2]])
RMS = math.sqrt((0.25 + 2.25 + 0.25 + 2.25) / 4)


def test_le_is_the_root_mean_square_distance():
    m = gt_metrics(GT, SHIFTED)
    assert m.matched == 4 and m.le == pytest.approx(RMS, rel=1e-12)
    assert m.le == pytest.approx(1.1180339887, rel=1e-9)  # not the mean square 1.25, nor the mean 1.0


def test_le_of_the_threshold_sweep_and_the_joint_tuning_is_the_rms_too():
    order_resp = np.array([4.0, 3.0, 2.0, 1.0])
    curve = sweep_curve(GT, SHIFTED, order_resp)
    assert curve.le[-1] == pytest.approx(RMS, rel=1e-12)
    assert curve.metrics(len(curve.k) - 1).le == pytest.approx(RMS, rel=1e-12)
    # pooled over images: the root of the summed squares over all matches
    other = sweep_curve(GT, GT + [[0.2, 0.0]] * 4, order_resp)
    pooled = curve.metrics(len(curve.k) - 1) + other.metrics(len(other.k) - 1)
    assert pooled.le == pytest.approx(math.sqrt((5.0 + 4 * 0.04) / 8), rel=1e-12)
    t, idx = joint_tuning([curve, other])
    assert idx == [len(curve.k) - 1, len(other.k) - 1] and t == 1.0  # every detection kept


def test_gt_delta_is_2_px():
    for f in (gt_metrics, lambda g, d: sweep_curve(g, d, np.ones(len(d))).metrics(-1)):
        assert f(GT[:1], GT[:1] + [1.99, 0.0]).matched == 1
        assert f(GT[:1], GT[:1] + [2.01, 0.0]).matched == 0
    import inspect

    assert inspect.signature(evaluate_gt).parameters["delta"].default == 2.0
    from sogdd.cli.main import build_parser

    argv = ["eval", "gt", "--data", "x"]
    assert build_parser(argv).parse_args(argv).delta == 2.0


def test_repeatability_radius_is_4_px():
    ref = np.array([[50.0, 50.0], [100.0, 60.0]])
    ident = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    lb, ld, lr, r = pair_repeatability(ref, ref + [[3.99, 0.0], [0.0, 4.01]], ident, (200, 200))
    assert (lb, ld, lr) == (2, 2, 1) and r == pytest.approx(0.5)
    import inspect

    assert inspect.signature(evaluate_repeatability).parameters["radius"].default == 4.0


def test_chessboard_hit_radius_1_px_and_capture_radius_half_a_cell():
    corners = np.array([[20.0, 20.0], [26.0, 20.0], [20.0, 26.0], [26.0, 26.0]])
    region = np.array([[17.0, 17.0], [29.0, 17.0], [29.0, 29.0], [17.0, 29.0]])
    # cell 6: 0.99 px is a hit; 1.01 px is a miss but located; 2.94 px located; 3.06 px not located
    det = corners + np.array([[0.99, 0.0], [0.0, 1.01], [-2.94, 0.0], [0.0, 3.06]])
    s = score_image(corners, region, det, cell=6.0)
    assert RADIUS == 1.0
    assert s.hits == 1
    np.testing.assert_allclose(np.sort(s.located), [0.99, 1.01, 2.94])
    s = score_image(corners, region, det, cell=6.2)  # half a cell is 3.1 px: all four located
    assert len(s.located) == 4
