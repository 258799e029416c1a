"""A board's refinement windows (calib.targets.chessboard.windows): the cut window's fit kept only where it is
the more point-symmetric one."""

from __future__ import annotations

from functools import cache

import cv2
import numpy as np

from sogdd.calib.cameras import Camera
from sogdd.calib.targets.board import lattice_cells
from sogdd.calib.targets.chessboard import windows
from sogdd.calib.targets.chessboard.windows import (
    asymmetry_limit,
    border_reach,
    edge_halves,
    inner_corners,
    recut,
    refine_board,
    same_window,
    square_within,
    star_refit,
    symmetric,
)
from sogdd.calib.targets.refine import MIN_HALF, REACH_DIRS, half_widths, refine_grey

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


def _recut(grey, start, out, q, half, reach):
    """:func:`recut` on copies; and the cut window's own fits (:func:`square_within`), from the same starts."""
    out2, q2 = out.copy(), q.copy()
    recut(grey, start, out2, q2, half, reach)
    cut = square_within(reach, half)
    xc, qc = refine_grey(grey, start, cut, cut.astype(np.float64))
    return out2, q2, cut, xc, qc


def _assert_the_better_fit_is_kept(out, q, redo, out2, q2, xc, qc):
    np.testing.assert_array_equal(q2[~redo], q[~redo])  # an uncut window is not refined again
    np.testing.assert_array_equal(out2[~redo], out[~redo])
    take = redo & (qc > q)
    np.testing.assert_array_equal(q2, np.where(take, qc, q))
    np.testing.assert_array_equal(out2, np.where(take[:, None], xc, out))


def _reach_of_square(cut):
    """A reach whose square (:func:`square_within`) is ``cut``: ``cut sqrt 2`` along every direction, the
    diagonal's ``|u_x| + |u_y|``."""
    return np.repeat((cut * np.sqrt(2.0) + 1e-9)[:, None], REACH_DIRS, axis=1)


def test_a_corner_whose_full_window_fits_better_keeps_that_fit(render):
    """Every window of a whole board cut to half (as a noisy measure of the squares' extent may cut a border
    corner's): the full windows stay on the squares and fit most corners more symmetrically, and more
    accurately; those corners keep the full fit."""
    grey, truth, labels, start, cells, half, out, q = _view(render, 1.0)
    reach = _reach_of_square(np.maximum(half // 2, MIN_HALF))
    out2, q2, cut, xc, qc = _recut(grey, start, out, q, half, reach)
    assert np.array_equal(cut, np.maximum(half // 2, MIN_HALF)) and (cut < half).all()
    _assert_the_better_fit_is_kept(out, q, cut < half, out2, q2, xc, qc)
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
    reach = border_reach(grey, at, labels, cells)
    border = ~inner_corners(labels)
    assert np.array_equal(edge_halves(grey, at, labels, half, cells), square_within(reach, half))
    out2, q2, cut, xc, qc = _recut(grey, start, out, q, half, reach)
    assert (cut[border] < half[border]).all() and np.array_equal(cut[~border], half[~border])
    assert np.isinf(reach[~border]).all()
    _assert_the_better_fit_is_kept(out, q, cut < half, out2, q2, xc, qc)
    assert (qc[border] > q[border]).all()
    np.testing.assert_array_equal(out2[border], xc[border])
    err_full = np.hypot(*(out[border] - truth[border]).T).mean()
    err_kept = np.hypot(*(out2[border] - truth[border]).T).mean()
    assert err_kept < 0.25 * err_full


def test_star_refit_keeps_the_more_symmetric_fit_of_the_corners_it_is_given(render):
    """:func:`star_refit` refits only the corners named whose reach bounds the window (the border corners
    here), with the star window (the same as :func:`refine_grey` with ``reach``), and keeps the better."""
    grey, truth, labels, start, cells, half, out, q = _view(render, 0.3)
    at = np.where(q[:, None] > 0, out, start)
    reach = border_reach(grey, at, labels, cells)
    border = ~inner_corners(labels)
    which = border.copy()
    which[np.flatnonzero(border)[0]] = False  # one border corner not named
    out2, q2 = out.copy(), q.copy()
    star_refit(grey, start, out2, q2, half, reach, which)
    xs, qs = refine_grey(grey, start, half, half.astype(np.float64), reach=reach)
    take = which & (qs > q)
    assert take.sum() > 0.5 * which.sum()  # outer squares of 0.3 cell: the star fits most border corners better
    np.testing.assert_array_equal(q2, np.where(take, qs, q))
    np.testing.assert_array_equal(out2, np.where(take[:, None], xs, out))
    star_err = np.hypot(*(xs[take] - truth[take]).T).mean()
    assert star_err < 0.5 * np.hypot(*(out[take] - truth[take]).T).mean()


def test_a_star_window_fits_border_corners_of_a_blurred_board_with_cut_outer_squares(render):
    """Outer squares of 0.45 cell on a dark background, blur 2.7 px, noise 8: a border corner's symmetric
    surroundings are long along the border and short across it. The square window cut to the short side
    holds too few pixels for the noise; the star window keeps the long side, so the own search (no OpenCV
    proposals) completes most of these boards (the square alone: 1 of 12)."""
    from sogdd.calib.targets import detect_board

    cam = Camera(np.array([[500.0, 0, 239.5], [0, 500.0, 179.5], [0, 0, 1]]), (0.0, 0, 0, 0), (480, 360))
    complete, errors = 0, []
    for seed in range(12):
        rng = np.random.default_rng(seed)
        R = np.array([0.3, -0.2, 0.1]) + rng.normal(0, 0.1, 3)
        t = np.array([0.0, 0.0, 0.75]) - cv2.Rodrigues(R)[0] @ np.array([3.5 * 0.03, 3 * 0.03, 0.0])
        v = render.render_view(cam, render.Board(8, 7, 0.03, edge=0.45), R, t, blur=2.7, noise=8.0, rng=seed,
                               levels=(25.0, 200.0, 30.0))
        b = detect_board(v.image, (8, 7), proposals=False)
        if b is not None and len(b) == 56:
            complete += 1
            order = np.lexsort((v.labels[:, 0], v.labels[:, 1]))
            errors.append(np.hypot(*(b.image_points - v.corners[order]).T).mean())
    assert complete >= 6, complete
    assert max(errors) < 0.5, errors


def test_a_corner_nearer_no_symmetry_than_its_noisy_board_is_dropped():
    """On a noisy board (median asymmetry 0.1) ten times the median would keep any fit; a corner whose
    asymmetry is more than halfway from the median to 1 (no symmetry at all) is dropped, one within it kept."""
    rng = np.random.default_rng(0)
    asym = rng.uniform(0.08, 0.12, 40)
    asym[[3, 17]] = (0.8, 0.5)
    keep = symmetric(1.0 - asym)
    assert not keep[3] and keep[17] and keep.sum() == 39
    # a clean board keeps its rule: ten times the median, at least 0.1
    assert asymmetry_limit(0.001) == 0.1 and asymmetry_limit(0.02) == 0.2


def _steep_view(render, tilt: float, edge: float, noise: float, blur: float = 2.0):
    """A 9 x 6 board tilted ``tilt`` degrees about its rows (outer squares ``edge`` of a cell), through the
    480 x 360 pinhole: the grey image, the true corners and labels, and starts 0.3 px off them."""
    R = cv2.Rodrigues(np.radians([tilt, 0.0, 10.0]))[0]
    t = np.array([0.0, 0.0, 0.5]) - R @ np.array([4 * 0.03, 2.5 * 0.03, 0.0])
    v = render.render_view(CAM, render.Board(9, 6, 0.03, edge=edge), cv2.Rodrigues(R)[0].ravel(), t, blur=blur,
                           noise=noise, rng=1)
    start = v.corners + np.random.default_rng(0).normal(0, 0.3, v.corners.shape)
    return v.image.astype(np.float64), v.corners, v.labels, start


def test_a_corner_whose_full_window_slides_off_is_refitted_from_the_lattice_point(render, monkeypatch):
    """Tilted 70 degrees, outer squares of 0.3 cell, noise 10: the full windows of some border corners slide
    4-5 px off them, onto the background; a cut window started where they slid cannot come back, so the
    corner is refitted from its lattice point, kept and within 1 px (from the slid fit: 3.4 px off, dropped).
    The refit's own rule, without the later judgement through the corner's own window (which starts from
    the lattice point too)."""
    monkeypatch.setattr(windows, "same_window", lambda *args: None)
    grey, truth, labels, start = _steep_view(render, 70.0, 0.3, 10.0)
    half = half_widths(start, None, lattice_cells(start, labels))
    full, _ = refine_grey(grey, start, half, half.astype(np.float64))
    slid = np.hypot(*(full - start).T) > 3.0
    assert slid.sum() >= 2  # the premise
    out, q = refine_board(grey, start, labels)
    assert symmetric(q)[slid].all()
    assert (np.hypot(*(out[slid] - truth[slid]).T) < 1.0).all()


def test_a_narrow_outer_row_is_judged_through_its_own_window(render):
    """Outer squares of 0.2 cell, blur 2 px, noise 10: the border corners' windows are cut to a few px of
    blurred squares, where the noise alone makes their asymmetry several times the board's median (10 of 54
    dropped by it). Judged against the board's inner corners seen through the same window
    (:func:`same_window`), every corner is kept, and every one within 1 px."""
    grey, truth, labels, start = _steep_view(render, 17.0, 0.2, 10.0)
    out, q = refine_board(grey, start, labels)
    assert symmetric(q).all()
    assert (np.hypot(*(out - truth).T) < 1.0).all()


def test_a_corner_an_occluder_moved_stays_dropped_through_its_own_window(render):
    """The same board with a flat grey patch over half of one border corner's surroundings: through the
    board's windows or its own, it is far less symmetric than the board's corners and stays dropped."""
    grey, truth, labels, start = _steep_view(render, 17.0, 0.2, 10.0)
    k = int(np.flatnonzero((labels[:, 0] == 4) & (labels[:, 1] == 0))[0])
    x, y = np.rint(truth[k]).astype(int)
    grey = grey.copy()
    grey[y - 12 : y + 13, x + 1 : x + 13] = 110.0
    cells = lattice_cells(start, labels)
    out, q = refine_board(grey, start, labels, cells)
    assert not symmetric(q)[k]
    out2, q2 = out.copy(), q.copy()
    same_window(grey, start, out2, q2, labels, cells, half_widths(start, None, cells), ~symmetric(q))
    assert not symmetric(q2)[k]


def _reach_reference(grey, xy, labels, cells, also=None):
    """:func:`border_reach` as numpy states it: the ring's 10th and 90th percentiles (``np.percentile``),
    then each ray's first step whose mirrored samples differ by more than a fifth of their spread."""
    from sogdd.calib.targets.chessboard.windows import bilinear

    dirs = np.stack([np.cos(np.arange(16) * np.pi / 16), np.sin(np.arange(16) * np.pi / 16)], axis=1)
    ring_dirs = np.r_[dirs, -dirs]
    steps = np.arange(0.1, 0.96, 0.05)
    border = ~inner_corners(labels) if also is None else ~inner_corners(labels) | also
    out = np.full((len(xy), REACH_DIRS), np.inf)
    for c in np.flatnonzero(border & np.isfinite(cells)):
        hi, lo = np.percentile(bilinear(grey, xy[c] + 0.2 * cells[c] * ring_dirs), [90, 10])
        for u in range(len(dirs)):
            r = np.inf
            for t in steps:
                d = (t * cells[c]) * dirs[u]
                if abs(bilinear(grey, xy[c] + d) - bilinear(grey, xy[c] - d)) > 0.2 * (hi - lo):
                    r = t * cells[c]
                    break
            out[c, u] = max(0.8 * r, MIN_HALF)
    return out


def test_border_reach_is_numpys_percentiles_and_rays_to_the_bit():
    """The compiled ring spread (sorted samples, numpy's linear interpolation term for term) and rays give
    exactly what ``np.percentile`` and the rays written in numpy give, on noise, blocks and grey levels."""
    rng = np.random.default_rng(0)
    for t in range(30):
        h, w = rng.integers(40, 120, 2)
        grey = rng.uniform(0, 255, (h, w))
        if t % 3 == 1:  # flat blocks: ties among the ring's samples
            grey = np.kron(rng.integers(0, 4, (h // 8 + 1, w // 8 + 1)) * 60.0, np.ones((8, 8)))[:h, :w]
        elif t % 3 == 2:
            grey = np.round(grey)
        n = int(rng.integers(2, 12))
        xy = np.c_[rng.uniform(-3, w + 3, n), rng.uniform(-3, h + 3, n)]
        labels = rng.integers(0, 3, (n, 2))
        cells = rng.uniform(3.0, 30.0, n)
        cells[0] = np.inf
        also = rng.random(n) < 0.5
        np.testing.assert_array_equal(border_reach(grey, xy, labels, cells, also=also),
                                      _reach_reference(grey, xy, labels, cells, also))
