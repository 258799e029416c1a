"""The two halves' cross-validation (sogdd.calib.cross_validation): which views go into which half."""

from __future__ import annotations

import numpy as np

from sogdd.calib.cross_validation import cross_validate
from sogdd.calib.solvers import fit_camera


def test_the_halves_alternate_by_rank_among_the_used_views_not_by_view_index(synthetic):
    """Views 2 and 5 unused: the halves take every other used view (ranks 0, 2, 4, ... and 1, 3, 5, ...),
    whatever the views' own indices; by index parity views 3 and 4 would swap halves."""
    boards = synthetic.boards(10, noise=0.05, seed=7)
    used = np.array([0, 1, 3, 4, 6, 7, 8, 9])
    ok = [np.ones(len(b), bool) for b in boards]
    cv, why = cross_validate(boards, ok, used, square=1.0, image_size=synthetic.SIZE, model="pinhole", flags=0,
                             min_views=3)
    assert cv is not None, why
    assert cv.views_a == (0, 3, 6, 8) and cv.views_b == (1, 4, 7, 9)
    assert cv.views_a == tuple(used[0::2].tolist()) and cv.views_b == tuple(used[1::2].tolist())
    # each half's camera is the fit of exactly those views
    for views, K in ((cv.views_a, cv.K_a), (cv.views_b, cv.K_b)):
        obj = [boards[v].object_points(1.0) for v in views]
        K_ref = fit_camera(obj, [boards[v].image_points for v in views], synthetic.SIZE, "pinhole", 0)[0]
        np.testing.assert_allclose(K, K_ref, rtol=1e-9)


def test_each_half_needs_min_views_so_an_odd_set_one_short_is_not_split(synthetic):
    """5 used views and min_views 3: the halves would hold 3 and 2 views, and the smaller one is under
    min_views, so there is no cross-validation (the rule is 2 * min_views used views); 6 views split 3 + 3.
    A rule on the larger half alone would calibrate a half of 2 views."""
    boards = synthetic.boards(6, noise=0.05, seed=11)
    ok = [np.ones(len(b), bool) for b in boards]
    kw = dict(square=1.0, image_size=synthetic.SIZE, model="pinhole", flags=0, min_views=3)
    cv, why = cross_validate(boards, ok, np.arange(5), **kw)
    assert cv is None and "5 used views" in why and "needs 6" in why
    cv, why = cross_validate(boards, ok, np.arange(6), **kw)
    assert cv is not None, why
    assert len(cv.views_a) == len(cv.views_b) == 3
