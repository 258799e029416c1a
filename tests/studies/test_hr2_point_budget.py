"""The hr2 study's point budget spread over the image: ANMS and bucketing (studies/hr2/point_budget.py)."""

import sys
from pathlib import Path

import numpy as np
import pytest

HR2 = Path(__file__).resolve().parents[2] / "studies" / "hr2"
if not HR2.is_dir():  # pragma: no cover - an installed package without the repository
    pytest.skip("needs the repository checkout (studies/hr2)", allow_module_level=True)
sys.path.insert(0, str(HR2))

from point_budget import anms_order, bucket_order, suppression_radii  # noqa: E402


def _brute_radii(xy, resp, robust):
    out = np.full(len(xy), np.inf)
    for i in range(len(xy)):
        s = robust * resp > resp[i]
        if s.any():
            out[i] = np.sqrt(np.min(np.sum((xy[s] - xy[i]) ** 2, axis=1)))
    return out


def test_radii_match_brute_force():
    rng = np.random.default_rng(3)
    xy = rng.uniform(0, 200, (400, 2))
    resp = rng.exponential(1.0, 400)
    for robust in (0.9, 1.0):
        np.testing.assert_allclose(suppression_radii(xy, resp, robust, k=4), _brute_radii(xy, resp, robust))
    assert suppression_radii(xy[:1], resp[:1]).tolist() == [np.inf]


def test_anms_spreads_where_top_k_clusters():
    rng = np.random.default_rng(1)
    cluster = rng.uniform(0, 20, (200, 2))  # strong points in one corner of the image
    spread = rng.uniform(0, 400, (200, 2))
    xy = np.concatenate([cluster, spread])
    resp = np.concatenate([20 * 0.99 ** np.arange(200.0), rng.uniform(1, 2.5, 200)])
    top = np.argsort(-resp)[:50]
    idx = anms_order(xy, resp, 50)
    assert len(set(idx.tolist())) == 50
    assert np.all(xy[top] < 20.0)  # top-k: all in the cluster
    # ANMS: only the points within 10 % of the strongest (infinite radius) stay in the cluster
    in_cluster = np.all(xy[idx] < 20.0, axis=1)
    assert in_cluster.sum() <= np.count_nonzero(resp[:200] > 0.9 * resp.max()) + 1
    assert in_cluster.mean() < 0.5
    assert int(np.argmax(resp)) in idx.tolist()  # the strongest point has the largest radius


def test_bucketing_shares_the_budget():
    rng = np.random.default_rng(2)
    xy = np.concatenate([rng.uniform(0, 50, (300, 2)), rng.uniform(0, 400, (60, 2))])
    resp = np.concatenate([rng.uniform(10, 20, 300), rng.uniform(1, 5, 60)])
    idx = bucket_order(xy, resp, (400, 400), 64, cell=100)  # 16 cells, 4 points each
    assert len(idx) == 64 and len(set(idx.tolist())) == 64
    cells = (xy[idx] // 100).astype(int)
    counts = np.bincount(cells[:, 1] * 4 + cells[:, 0], minlength=16)
    allc = (xy // 100).astype(int)
    avail = np.bincount(allc[:, 1] * 4 + allc[:, 0], minlength=16)
    assert np.all(counts >= np.minimum(avail, 4))  # every cell gets its share where it has the points
    assert counts[0] == 64 - np.minimum(avail, 4)[1:].sum()  # the spare share goes to the strongest left
    np.testing.assert_array_equal(np.sort(bucket_order(xy[:5], resp[:5], (400, 400), 10)), np.arange(5))
