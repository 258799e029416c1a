"""A board's refinement windows (calib.targets.chessboard.windows): the cut window's fit kept only where it is
the more point-symmetric one."""

from __future__ import annotations

from functools import cache

import cv2
import numpy as np

from sogdd.calib.cameras import Camera
from sogdd.calib.targets.board import lattice_cells
from sogdd.calib.targets.chessboard.windows import edge_halves, inner_corners, recut
from sogdd.calib.targets.refine import MIN_HALF, half_widths, refine_grey

CAM = Camera(np.array([[500.0, 0, 239.5], [0, 500.0, 179.5], [0, 0, 1]]), (0.0, 0, 0, 0), (480, 360))


@cache
def _view(render, edge: float):
    """A 9 x 6 board (cells of about 18 px; outer squares ``edge`` of a cell), blur 1 px, noise 2 grey levels:
    the grey image, the true corners and labels, starts 0.3 px off them, and their full-window fits."""
    R = np.array([0.3, -0.2, 0.1])
    t = np.array([0.0, 0.0, 0.8]) - cv2.Rodrigues(R)[0] @ np.array([4 * 0.03, 2.5 * 0.03, 0.0])
    v = render.render_view(CAM, render.Board(9, 6, 0.03, edge=edge), R, t, blur=1.0, noise=2.0, rng=1)
    grey = v.image.astype(np.float64)
    start = v.corners + np.random.default_rng(0).normal(0, 0.3, v.corners.shape)
    cells = lattice_cells(start, v.labels)
    half = half_widths(start, None, cells)
    out, q = refine_grey(grey, start, half, half.astype(np.float64))
    return grey, v.corners, v.labels, start, cells, half, out, q


def _recut(grey, start, out, q, half, cut):
    """:func:`recut` on copies; and the cut window's own fits, from the same starts."""
    out2, q2 = out.copy(), q.copy()
    recut(grey, start, out2, q2, half, cut)
    xc, qc = refine_grey(grey, start, cut, cut.astype(np.float64))
    return out2, q2, xc, qc


def _assert_the_better_fit_is_kept(out, q, half, cut, out2, q2, xc, qc):
    redo = cut < half
    np.testing.assert_array_equal(q2[~redo], q[~redo])  # an uncut window is not refined again
    np.testing.assert_array_equal(out2[~redo], out[~redo])
    take = redo & (qc > q)
    np.testing.assert_array_equal(q2, np.where(take, qc, q))
    np.testing.assert_array_equal(out2, np.where(take[:, None], xc, out))


def test_a_corner_whose_full_window_fits_better_keeps_that_fit(render):
    """Every window of a whole board cut to half (as a noisy measure of the squares' extent may cut a border
    corner's): the full windows stay on the squares and fit most corners more symmetrically, and more
    accurately; those corners keep the full fit."""
    grey, truth, labels, start, cells, half, out, q = _view(render, 1.0)
    cut = np.maximum(half // 2, MIN_HALF)
    assert (cut < half).all()
    out2, q2, xc, qc = _recut(grey, start, out, q, half, cut)
    _assert_the_better_fit_is_kept(out, q, half, cut, out2, q2, xc, qc)
    full_better = qc < q
    assert full_better.sum() > 0.8 * len(q)  # the premise: most full windows fit better
    np.testing.assert_array_equal(out2[full_better], out[full_better])
    err = {k: np.hypot(*(p - truth).T).mean() for k, p in (("full", out), ("cut", xc), ("kept", out2))}
    assert err["kept"] < err["cut"], err


def test_a_border_corner_beyond_narrow_outer_squares_takes_its_cut_window(render):
    """Outer squares of 0.3 cell: a border corner's full window reaches the background, its cut window
    (:func:`edge_halves`) stays on the squares, fits more symmetrically and far more accurately."""
    grey, truth, labels, start, cells, half, out, q = _view(render, 0.3)
    at = np.where(q[:, None] > 0, out, start)
    cut = edge_halves(grey, at, labels, half, cells)
    border = ~inner_corners(labels)
    assert (cut[border] < half[border]).all() and np.array_equal(cut[~border], half[~border])
    out2, q2, xc, qc = _recut(grey, start, out, q, half, cut)
    _assert_the_better_fit_is_kept(out, q, half, cut, out2, q2, xc, qc)
    assert (qc[border] > q[border]).all()
    np.testing.assert_array_equal(out2[border], xc[border])
    err_full = np.hypot(*(out[border] - truth[border]).T).mean()
    err_kept = np.hypot(*(out2[border] - truth[border]).T).mean()
    assert err_kept < 0.25 * err_full
