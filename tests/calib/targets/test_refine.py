"""refine_corners: accuracy on rendered boards (blur, tiny cells), the fit it solves, cornerSubPix's API."""

from functools import cache

import cv2
import numpy as np
import pytest
from scipy.ndimage import map_coordinates

from sogdd.calib.cameras import Camera
from sogdd.calib.targets.refine import cell_sizes, half_widths, refine_corners

CAM = Camera(np.array([[500.0, 0, 239.5], [0, 500.0, 179.5], [0, 0, 1]]), (-0.1, 0.02, 0.0, 0.0), (480, 360))
CRIT = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)  # OpenCV's tutorial's
TIGHT = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-7)  # iterate to the fixed point


@cache
def view(render, dist=0.8, blur=1.0, noise=2.0, roll=0.3):
    R = np.array([0.35, -0.25, roll])
    Rm, _ = cv2.Rodrigues(R)
    t = np.array([0.0, 0.0, dist]) - Rm @ np.array([0.12, 0.075, 0.0])
    return render.render_view(CAM, render.Board(9, 6, 0.03), R, t, blur=blur, noise=noise, rng=7)


def starts(v, spread=1.0, seed=0):
    return v.corners + np.random.default_rng(seed).uniform(-spread, spread, v.corners.shape)


def errors(xy, v):
    return np.hypot(*(np.reshape(xy, (-1, 2)) - v.corners).T)


@cache
def x_corner(size=60, at=30.3, blur=1.0):
    """A blurred X-corner at (at, at): each pixel's covered fraction, as the renderer's box filter gives it."""
    edge = np.clip(np.arange(size) + 0.5 - (at + 0.5), -0.5, 0.5)
    img = cv2.GaussianBlur(128 + 200 * edge[:, None] * edge[None, :], (0, 0), blur)
    return np.rint(img).astype(np.uint8)


def gauss_newton_step(image, xy, h, gaussian=True):
    """The length of the Gauss-Newton step ``(J^T W J)^-1 J^T W r`` of the module's fit at each point.

    ``r = I(p + d) - I(p - d)`` and ``J = grad I(p + d) - grad I(p - d)`` over the offsets
    ``|d_x|, |d_y| <= h`` (every ``d`` and its mirror: the same normal equations, doubled), ``I``
    bilinear, ``grad I`` by central differences of 1 px, ``W`` the weights ``exp(-|d|^2 / (2 h^2))`` or
    uniform. The step vanishes where the refinement converged; it does not at the fixed point of
    another weighting or window.
    """
    img = image.astype(np.float64)
    d = np.mgrid[-h:h + 1, -h:h + 1].reshape(2, -1).T.astype(np.float64)
    w = np.exp(-(d * d).sum(1) / (2.0 * h * h)) if gaussian else np.ones(len(d))

    def grey(q):
        return map_coordinates(img, [q[:, 1], q[:, 0]], order=1)

    def grad(q):
        ex, ey = np.array([1.0, 0.0]), np.array([0.0, 1.0])
        return np.c_[grey(q + ex) - grey(q - ex), grey(q + ey) - grey(q - ey)] / 2

    out = []
    for p in np.reshape(xy, (-1, 2)):
        r = grey(p + d) - grey(p - d)
        J = grad(p + d) - grad(p - d)
        out.append(np.hypot(*np.linalg.solve(J.T @ (w[:, None] * J), J.T @ (w * r))))
    return np.array(out)


# accuracy


def test_accurate_from_a_pixel_off(render):
    v = view(render)
    e = errors(refine_corners(v.image, starts(v)), v)
    assert e.mean() < 0.02 and e.max() < 0.06


def test_beats_cornersubpix_on_find_chessboard_corners_output(render):
    v = view(render)
    ok, found = cv2.findChessboardCorners(v.image, (9, 6))
    assert ok
    order = np.argmin(np.hypot(*(found.reshape(-1, 2)[:, None] - v.corners[None]).transpose(2, 0, 1)), axis=1)
    truth = v.corners[order]
    ours = np.hypot(*(refine_corners(v.image, found.copy()).reshape(-1, 2) - truth).T)
    theirs = cv2.cornerSubPix(v.image, found.copy(), (5, 5), (-1, -1), CRIT).reshape(-1, 2)
    theirs = np.hypot(*(theirs - truth).T)
    assert ours.mean() < 0.6 * theirs.mean()
    assert ours.max() < theirs.max()


def test_strong_blur_sends_no_point_away(render):
    v = view(render, dist=0.55, blur=2.5, noise=4.0)  # cells of about 27 px blurred over 5 px
    e = errors(refine_corners(v.image, starts(v)), v)
    assert e.mean() < 0.05 and e.max() < 0.5


def test_tiny_cells(render):
    v = view(render, dist=2.4, blur=0.8)
    assert np.median(cell_sizes(v.corners)) < 6.5
    e = errors(refine_corners(v.image, starts(v, 0.5)), v)
    assert e.mean() < 0.05 and e.max() < 0.15


# the fit: which objective the refined point minimises


def test_the_weights_are_gaussian(render):
    # tiny cells, where the weights matter most: the window (4 px) reaches the perspective-bent edges
    v = view(render, dist=2.4, blur=0.8)
    xy = refine_corners(v.image, starts(v, 0.5), (4, 4), (-1, -1), TIGHT)
    assert np.median(gauss_newton_step(v.image, xy, 4, gaussian=False)) > 1e-3  # the weightings differ here
    assert gauss_newton_step(v.image, xy, 4).max() < 1e-6


def test_the_default_window_is_065_of_the_cell(render):
    # the module doc's examples: a 6 px cell takes a 4 px half-width, a 31 px cell 20 px (the most)
    assert half_widths(np.zeros((4, 2)), None, np.array([6.0, 20.0, 31.0, 100.0])).tolist() == [4, 13, 20, 20]
    assert half_widths(np.zeros((1, 2)), None, None).tolist() == [5]  # a point alone: cornerSubPix's (5, 5)
    for dist, cell, half, other in ((2.4, 6.0, 4, 3), (1.6, 9.0, 6, 4)):  # other: 0.5 of the cell
        v = view(render, dist=dist, blur=0.8)
        xy = refine_corners(v.image, starts(v, 0.5), None, None, TIGHT, cell=cell)
        assert np.median(gauss_newton_step(v.image, xy, other)) > 1e-3  # the two windows' fixed points differ
        assert gauss_newton_step(v.image, xy, half).max() < 1e-6


# points that cannot be refined


def test_a_point_that_would_move_too_far_keeps_its_start_and_quality_0():
    img = x_corner()  # the corner at (30.3, 30.3)
    start = np.array([[27.3, 30.0], [30.0, 33.3]], np.float32)  # 3 px off: well inside the 6 px window
    xy, q = refine_corners(img, start.copy(), 6, return_quality=True)
    assert np.abs(xy - 30.3).max() < 0.05 and np.all(q > 0.99)  # the default bound, 6 px, lets them move
    out, q = refine_corners(img, start.copy(), 6, max_shift=2.0, return_quality=True)
    assert np.array_equal(out, start) and q.tolist() == [0.0, 0.0]


def test_a_point_without_a_corner_keeps_its_start():
    flat = np.full((60, 60), 128, np.uint8)  # a singular fit
    xy, q = refine_corners(flat, [[20.0, 20.0]], 5, return_quality=True)
    assert xy.tolist() == [[20.0, 20.0]] and q[0] == 0.0
    # a straight edge, 30 px from any corner: it has no centre of symmetry, and the fit drifts off it
    # (past the 5 px window) into the flat side, so the point must come back where it started
    edge = np.where(np.arange(60) < 30, 100.0, 200.0)[None, :].repeat(60, axis=0)
    edge = np.clip(np.rint(edge + np.random.default_rng(0).normal(0, 1, edge.shape)), 0, 255).astype(np.uint8)
    start = [[29.5, 30.0], [29.0, 20.0], [31.0, 40.0]]
    xy, q = refine_corners(edge, start, 5, return_quality=True)
    assert xy.tolist() == start and q.tolist() == [0.0, 0.0, 0.0]


# cornerSubPix's contract


def test_opencv_tutorial_code_gets_the_refined_corners_in_place(render):
    v = view(render)
    ok, corners = cv2.findChessboardCorners(v.image, (9, 6))
    assert ok
    before = corners.copy()
    refine_corners(v.image, corners, (11, 11), (-1, -1), CRIT)  # the tutorial ignores the return value
    order = np.argmin(np.hypot(*(before.reshape(-1, 2)[:, None] - v.corners[None]).transpose(2, 0, 1)), axis=1)
    truth = v.corners[order]
    assert np.hypot(*(corners.reshape(-1, 2) - truth).T).mean() < 0.5 * np.hypot(
        *(before.reshape(-1, 2) - truth).T).mean()
    # OpenCV takes the result where it takes cornerSubPix's
    colour = cv2.cvtColor(v.image, cv2.COLOR_GRAY2BGR)
    cv2.drawChessboardCorners(colour, (9, 6), corners, ok)
    cv2.cornerSubPix(v.image, corners.copy(), (5, 5), (-1, -1), CRIT)
    obj = np.c_[np.mgrid[0:9, 0:6].T.reshape(-1, 2), np.zeros(54)].astype(np.float32)
    cv2.calibrateCamera([obj], [corners], CAM.size, None, None)


@pytest.mark.parametrize("shape, dtype", [((54, 1, 2), np.float32), ((54, 2), np.float32),
                                          ((54, 2), np.float64), ((1, 54, 2), np.float64)])
def test_the_given_array_is_refined_in_place_in_its_shape_and_dtype(render, shape, dtype):
    v = view(render)
    p = starts(v).astype(dtype).reshape(shape)
    out = refine_corners(v.image, p, (7, 7))
    assert out is p and out.shape == shape and out.dtype == dtype
    assert errors(p, v).mean() < 0.03
    if dtype == np.float32:  # computed in float64 and rounded once
        q = refine_corners(v.image, starts(v).reshape(shape), (7, 7))
        assert np.array_equal(p, q.astype(np.float32))


def test_other_inputs_are_left_as_they_are(render):
    v = view(render)
    pts = starts(v)
    listed = pts.tolist()
    out = refine_corners(v.image, listed, (7, 7))
    assert listed == pts.tolist() and out.shape == (54, 2) and out.dtype == np.float64
    frozen = pts.astype(np.float32).reshape(-1, 1, 2)
    frozen.flags.writeable = False
    kept = frozen.copy()
    out = refine_corners(v.image, frozen, (7, 7))
    assert np.array_equal(frozen, kept) and out.shape == (54, 1, 2) and out.dtype == np.float32
    assert errors(out, v).mean() < 0.03
    whole = np.rint(pts).astype(np.int32)
    out = refine_corners(v.image, whole, (7, 7))
    assert out.dtype == np.float64 and errors(out, v).mean() < 0.03 and np.array_equal(whole, np.rint(pts))


def test_a_point_that_cannot_be_refined_keeps_its_float32_start_exactly():
    img = x_corner()
    p = np.array([[[27.3, 30.0]], [[10.1, 50.7]], [[31.0, 29.5]]], np.float32)  # the middle one: a flat square
    start = p.copy()
    _, q = refine_corners(img, p, 6, max_shift=2.0, return_quality=True)
    assert q[1] == 0.0 and q[0] == 0.0 and q[2] > 0.99
    assert np.array_equal(p[:2], start[:2]) and np.abs(p[2] - 30.3).max() < 0.05


def test_positional_and_keyword_arguments_as_cornersubpix(render):
    v = view(render)
    a = refine_corners(v.image, starts(v), (5, 5), (-1, -1), CRIT)
    b = refine_corners(image=v.image, corners=starts(v), winSize=(5, 5), zeroZone=(-1, -1), criteria=CRIT)
    c = refine_corners(v.image, starts(v), 5, (2, 2), CRIT)  # zeroZone is accepted and ignored
    d = refine_corners(v.image, starts(v), (5, 8), None, CRIT)  # a square window of the smaller half-width
    assert np.array_equal(a, b) and np.array_equal(a, c) and np.array_equal(a, d)
    cell = refine_corners(v.image, starts(v))
    assert np.array_equal(refine_corners(v.image, starts(v), (-1, -1)), cell)
    assert not np.array_equal(a, cell)  # the cell's window (about 12 px here) is not (5, 5)


def test_criteria_map_as_cornersubpix_maps_them():
    img = x_corner()
    start = [[27.3, 30.0]]
    one = refine_corners(img, start, 6, None, (cv2.TERM_CRITERIA_COUNT, 1, 0.0))
    assert np.isclose(np.hypot(*(one[0] - start[0])), 0.5)  # one step, damped to 0.5 px
    assert np.array_equal(refine_corners(img, start, 6, None, (cv2.TERM_CRITERIA_COUNT, 0, 0.0)), one)  # >= 1
    assert np.array_equal(refine_corners(img, start, 6, None, (cv2.TERM_CRITERIA_EPS, 5, 10.0)), one)  # eps
    for crit in ((cv2.TERM_CRITERIA_COUNT, 10, 0.0), (cv2.TERM_CRITERIA_EPS, 1, 1e-6), None):
        # count alone: 10 steps; eps alone: up to 100 steps, the count ignored; None: up to 20, to 1e-4 px
        assert np.abs(refine_corners(img, start, 6, None, crit) - 30.3).max() < 0.05, crit
    assert np.abs(refine_corners(img, start, 6, None, (cv2.TERM_CRITERIA_COUNT, 5, 0.0)) - 30.3).max() > 0.5


def test_colour_and_float_images(render):
    v = view(render)
    colour = np.repeat(v.image[:, :, None], 3, axis=2)
    a = refine_corners(colour, starts(v))
    b = refine_corners(v.image.astype(np.float32) / 255.0, starts(v))
    c = refine_corners(v.image, starts(v))
    assert np.allclose(a, c, atol=1e-9) and np.allclose(b, c, atol=1e-6)


@pytest.mark.parametrize("kwargs, message", [
    (dict(corners=np.zeros((3, 3))), "corners"), (dict(corners=np.zeros((3, 2), bool)), "corners"),
    (dict(corners=[[1.0, 2.0], [3.0]]), "corners"), (dict(corners=[[np.nan, 1.0]]), "finite"),
    (dict(winSize=0), "winSize"), (dict(winSize=(0, 5)), "winSize"), (dict(winSize=(-1, 5)), "winSize"),
    (dict(winSize=(5.0, 5.0)), "winSize"), (dict(winSize=(5, 5, 5)), "winSize"),
    (dict(zeroZone=(1, 2, 3)), "zeroZone"), (dict(zeroZone=1.5), "zeroZone"),
    (dict(criteria=(3, 30)), "criteria"), (dict(criteria=(3, 30, np.nan)), "criteria"),
    (dict(criteria=(3.0, 30, 0.1)), "criteria"),
    (dict(cell=-1.0), "cell"), (dict(max_shift=0.0), "max_shift"),
])
def test_bad_arguments_are_one_line_errors(kwargs, message):
    args = dict(corners=[[10.0, 10.0]])
    args.update(kwargs)
    with pytest.raises(ValueError, match=message) as err:
        refine_corners(np.zeros((20, 20), np.uint8), **args)
    assert "\n" not in str(err.value)
