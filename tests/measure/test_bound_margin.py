"""The pruning bound's rounding margins widen it, on every term, never narrow it.

:func:`sogdd.measure.bound.fischer_row` bounds det(Lambda) by the product over
pairs of adjacent orientations of ``d_i d_j - t_ij^2``. ``d_i`` and ``t_ij``
are computed from window sums, each off by up to ``e = _GAMMA u^2`` through
rounding, so the bound must hold for every value in that box: it must be at
least ``max (d_i + a)(d_j + b) - (t_ij + c)^2`` over ``|a|, |b|, |c| <= e``,
that is ``(d_i + e)(d_j + e) - max(|t_ij| - e, 0)^2``. A margin applied the
wrong way (``|t_ij| + e``) tightens the bound by a rounding-level amount, which
no detection shows, so the bound itself is checked here, on windows whose
blocks are far from and near to singular (a straight edge: ``t_ij^2 ~ d_i d_j``).
"""

import numpy as np
import pytest

from sogdd.measure import bound


def _coefficients(k: int) -> np.ndarray:
    """Steering coefficients of K orientations: l = cos^2 g_xx + 2 sin cos g_xy + sin^2 g_yy."""
    th = np.arange(k) * np.pi / k
    return np.stack([np.cos(th) ** 2, 2 * np.sin(th) * np.cos(th), np.sin(th) ** 2], axis=1)


def _window_sums(rng, n_windows: int, edge_like: bool) -> np.ndarray:
    """(6, n) sums S_pq = sum g_p g_q of the basis responses (g_xx, g_xy, g_yy) over 25-pixel windows."""
    g = rng.normal(0, 1, (n_windows, 25, 3)) * rng.uniform(1, 1e4, (n_windows, 1, 1))
    if edge_like:  # the responses of a straight edge: one direction, plus a trace of noise
        direction = rng.normal(0, 1, (n_windows, 1, 3))
        g = g[:, :, :1] * direction + 1e-7 * g
    pairs = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]
    return np.ascontiguousarray(np.stack([(g[:, :, p] * g[:, :, q]).sum(axis=1) for p, q in pairs]))


def _box_maximum(srow, quad, pair, pi2, pj2) -> tuple[np.ndarray, np.ndarray]:
    """The largest value of the Fischer product over the rounding box, and the Hadamard product."""
    s = srow.T
    u = np.sqrt(np.maximum(s[:, 0], 0)) + np.sqrt(np.maximum(s[:, 3], 0)) + np.sqrt(np.maximum(s[:, 5], 0))
    e = bound._GAMMA * u * u
    d = s @ quad.T  # (n, K)
    t = s @ pair.T  # (n, pairs)
    best, had = np.ones(len(s)), np.ones(len(s))
    for m, (i, j) in enumerate(zip(pi2, pj2)):
        dd = (d[:, i] + e) * (d[:, j] + e)
        best *= dd - np.maximum(np.abs(t[:, m]) - e, 0.0) ** 2
        had *= dd
    if quad.shape[0] % 2 == 1:
        best *= d[:, -1] + e
        had *= d[:, -1] + e
    return best, had


@pytest.mark.parametrize("edge_like", [False, True])
@pytest.mark.parametrize("k", [2, 3, 4, 5, 8])
def test_the_bound_holds_over_the_whole_rounding_box(k, edge_like):
    rng = np.random.default_rng(10 * k + edge_like)
    quad, pair, pi2, pj2 = bound.bound_tables(_coefficients(k))
    n = 400
    srow = _window_sums(rng, n, edge_like)
    keep = np.empty(n, np.bool_)
    work = tuple(np.empty(n) for _ in range(4))
    bound.fischer_row(srow, quad, pair, pi2, pj2, 1.0, keep, n, work)
    fb = work[1]  # the Fischer product, before the elimination's slack
    best, had = _box_maximum(srow, quad, pair, pi2, pj2)
    # float64 rounding of the products themselves: far below the margins (~1e-12 u^2 per term)
    deficit = (best - fb) / had
    assert deficit.max() < 1e-13, f"the bound is below the box maximum by {deficit.max():.2e} (relative)"
