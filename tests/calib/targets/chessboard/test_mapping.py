"""The lattice's compiled local map: one homography per label, and its small solve."""

import numpy as np
import pytest

from sogdd.calib.targets.chessboard.mapping import SUPPORT, apply, predict_batch, predict_local, solve_small


@pytest.mark.parametrize("n", [2, 8, 14])
def test_solve_small_is_numpys_solve(n):
    rng = np.random.default_rng(n)
    for _ in range(20):
        A = rng.normal(size=(n, n)) * 10.0 ** rng.uniform(-3, 3, size=(n, 1))  # rows of unequal scale
        b = rng.normal(size=n)
        x = b.copy()
        assert solve_small(A.copy(), x)
        assert np.allclose(x, np.linalg.solve(A, b), rtol=1e-8, atol=1e-10)


def test_solve_small_refuses_a_singular_matrix():
    A = np.array([[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 0.0]])
    assert not solve_small(A, np.ones(3))


def test_predict_local_is_predict_batchs_map():
    """The compiled map of one label is the batched one: the same fit in the same normalisation."""
    rng = np.random.default_rng(3)
    lab = np.array([(i, j) for j in range(-2, 3) for i in range(-2, 3)])
    H = np.array([[30.0, 4.0, 320.0], [-3.0, 27.0, 240.0], [3e-3, -2e-3, 1.0]])
    xy = apply(H, lab.astype(float)) + rng.normal(0, 0.3, (len(lab), 2))
    at = {tuple(v): k for k, v in enumerate(lab.tolist())}
    offs = SUPPORT.astype(float)
    for drop in ([], [0, 5, 17], list(range(0, 24, 2))):
        nbr = np.array([at[tuple(o)] for o in SUPPORT.tolist()])
        nbr[drop] = -1
        P = np.empty((5, 2))
        assert predict_local(xy, nbr, offs, P)
        want = predict_batch(xy, nbr[None], (nbr >= 0).astype(float)[None], offs)[0]
        assert np.allclose(P, want, rtol=0, atol=1e-9)
        # and it is the homography at the centre label, within the noise
        assert np.hypot(*(P[0] - apply(H, np.zeros((1, 2)))[0])) < 1.0



def test_check_refits_without_a_neighbour_that_is_off():
    """A corner far off the lattice spoils its neighbours' homographies (a 4 x 4 board: few neighbours each);
    each is fitted again without the neighbour its map misses most, and only the corner that is off fails."""
    from sogdd.calib.targets.chessboard.mapping import check

    lab = np.array([(i, j) for j in range(4) for i in range(4)])
    H = np.array([[20.0, 1.0, 30.0], [-1.0, 19.0, 40.0], [1e-3, 5e-4, 1.0]])
    for off, shift in ((5, (6.0, -5.0)), (5, (10.0, -8.0)), (0, (6.0, -5.0))):
        xy = apply(H, lab.astype(float))
        xy[off] += shift  # 0.4-0.6 of a cell
        ok = check(xy, lab, tol=0.05, curved=False)
        assert np.flatnonzero(~ok).tolist() == [off]
